"""Labelled plots of a trajectory (matplotlib, no display needed)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np  # noqa: E402

from .simulate import Result, unit_of  # noqa: E402


def plot_result(res: Result, path: str) -> None:
    """Coordinates, closing-joint force, closure error and energy against time."""
    m = res.model
    title = f"{m.name or 'scene'}: {m.kind or ''} ({res.method} closure)".replace(" ()", "")
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True)
    ax = axes[0, 0]
    for name in m.free_names:
        ax.plot(res.t, res[name], label=f"{name} [{unit_of(name)}]")
    ax.set_ylabel("real joint coordinates (absolute)")
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    if len(m.closures) > 1:
        # several loops: each closure's force magnitude on its closing link
        for j, cl in enumerate(m.closures):
            fx, fy = (res["Fx"], res["Fy"]) if j == 0 else (res[f"closure{j}_Fx"], res[f"closure{j}_Fy"])
            ax.plot(res.t, np.hypot(fx, fy), label=f"closure[{j}]: link{cl.link}-link{cl.to_link} [N]")
        ax.set_ylabel("closing-joint force magnitudes")
        ax.legend(fontsize=8)
    elif m.closures:
        for c in ("Fx", "Fy", "Mz"):
            ax.plot(res.t, res[c], label=f"{c} [{unit_of(c)}]")
        ax.set_ylabel("closing-joint force on the last link")
        ax.legend(fontsize=8)
    else:
        ax.plot(res["tip_x"], res["tip_y"])
        ax.set_ylabel("tip path y [m] (x on the bottom axis)")
    ax = axes[1, 0]
    ax.semilogy(res.t, abs(res["closure_error"]) + 1e-18)
    ax.set_ylabel("closure violation [m or rad]")
    ax.set_xlabel("t [s]")
    ax = axes[1, 1]
    for c in ("KE", "PE", "E"):
        ax.plot(res.t, res[c], label=c)
    ax.set_ylabel("energy [J]")
    ax.set_xlabel("t [s]")
    ax.legend(fontsize=8)
    for a in axes.flat:
        a.grid(True, alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_panels(t, panels, path: str, title: str = "") -> None:
    """Stacked time plots sharing the time axis.

    Parameters
    ----------
    t : array
    panels : list of (title, [(label, values, unit), ...])
    path : str
        PNG (or any format matplotlib writes) to save.
    """
    n = max(len(panels), 1)
    fig, axes = plt.subplots(n, 1, figsize=(10, 2.3 * n + 0.8), sharex=True, squeeze=False)
    for ax, (name, lines) in zip(axes[:, 0], panels):
        units = sorted({u for _, _, u in lines if u})
        for label, values, unit in lines:
            ax.plot(t, values, label=label, lw=1.2)
        ax.set_ylabel(f"{name}" + (f" [{', '.join(units)}]" if units and f"[{units[0]}]" not in name else ""))
        if lines:
            ax.legend(fontsize=8, loc="best")
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
