"""A one-page run report: the plots a user looks at first, the mechanism at a few
instants, and the run's key numbers."""

from __future__ import annotations

import numpy as np

from .animation import Drawer, fit_view, frame_geometry
from .model import Mechanism
from .simulate import unit_of


def energy_balance(columns: dict[str, np.ndarray], model: Mechanism) -> np.ndarray:
    """E(t) - E(0) minus the drive's work plus what the joint dampers took (J).

    Zero for an exact run: what is left is integration error (and the trapezoid
    rule's error on the output grid for the work).
    """
    t = columns["t"]
    qd = np.column_stack([columns[f"{n}_d"] for n in model.coordinate_names])
    zd = np.array([model.zd_from_qd(row) for row in qd])
    power = columns.get("P_drive", np.zeros_like(t)) - (zd**2) @ model.arrays.damping
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    e = columns["E"]
    return e - e[0] - work


def key_numbers(columns: dict[str, np.ndarray], drive: str | None,
                model: Mechanism | None = None) -> list[tuple[str, str]]:
    """The figures a reader wants from a run, as (label, value) pairs."""
    t = columns["t"]
    out = [("duration", f"{t[-1] - t[0]:.4g} s ({len(t)} points)")]
    if drive:
        out.append(("drive", drive))
    if "tau_drive" in columns:
        tau = columns["tau_drive"]
        out.append(("peak |drive torque|", f"{np.max(np.abs(tau)):.4g} N m"))
        out.append(("RMS drive torque", f"{np.sqrt(np.mean(tau**2)):.4g} N m"))
    if drive and f"{drive}_d" in columns:
        out.append(("peak |drive speed|", f"{np.max(np.abs(columns[f'{drive}_d'])):.4g} /s"))
    if "current" in columns:
        out.append(("peak |motor current|", f"{np.max(np.abs(columns['current'])):.4g} A"))
    if "voltage" in columns:
        out.append(("peak |motor voltage|", f"{np.max(np.abs(columns['voltage'])):.4g} V"))
    if "Fx" in columns and "Fy" in columns:
        out.append(("peak closing-joint force", f"{np.max(np.hypot(columns['Fx'], columns['Fy'])):.4g} N"))
    if "E" in columns:
        e = columns["E"]
        out.append(("energy E(end) - E(0)", f"{e[-1] - e[0]:.4g} J (range {np.ptp(e):.3g} J)"))
        if model is not None and all(f"{n}_d" in columns for n in model.coordinate_names):
            bal = energy_balance(columns, model)
            out.append(("energy balance (drift)", f"max {np.max(np.abs(bal)):.3g} J"))
    if "closure_error" in columns:
        out.append(("max closure error", f"{np.max(columns['closure_error']):.3g} m or rad"))
    return out


def write_report(columns: dict[str, np.ndarray], out: str, title: str = "",
                 model: Mechanism | None = None) -> None:
    """Write the report page (PNG or PDF, by the file name).

    Parameters
    ----------
    columns : dict of str to ndarray
        A run's columns in simulate vocabulary (``t`` required; see
        :func:`grubler.runs.read_run_csv`, which also reads cosim CSVs).
    out : str
        Output file; ``.pdf`` writes a PDF, anything else a PNG.
    model : Mechanism, optional
        The mechanism, to draw it at four instants.
    """
    import matplotlib.pyplot as plt

    t = columns["t"]
    drive = model.drive if model is not None else next((c for c in ("theta2", "B1") if c in columns), None)
    fig = plt.figure(figsize=(11.7, 8.3))
    gs = fig.add_gridspec(3, 4, height_ratios=[1, 1, 1.15], hspace=0.45, wspace=0.35)

    def panel(pos, names, ylabel):
        ax = fig.add_subplot(pos)
        for n in names:
            if n in columns:
                ax.plot(t, columns[n], label=n, lw=1.2)
        ax.set_ylabel(ylabel, fontsize=9)
        ax.set_xlabel("t [s]", fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.tick_params(labelsize=8)
        if sum(n in columns for n in names) > 1:  # a legend only for the lines there are
            ax.legend(fontsize=7)
        return ax

    if drive:
        panel(gs[0, 0], [drive], f"drive {drive} [{unit_of(drive)}]")
        panel(gs[0, 1], [f"{drive}_d"], f"drive speed [{unit_of(drive + '_d')}]")
    motor = [c for c in ("current", "voltage") if c in columns]
    panel(gs[0, 2], ["tau_drive"] + motor,
          "drive torque [N m]" + "".join(f" / {c} [{'A' if c == 'current' else 'V'}]" for c in motor))
    panel(gs[1, 0], ["Fx", "Fy", "Mz"], "closing-joint force [N, N m]")
    panel(gs[1, 1], ["KE", "PE", "E"], "energy [J]")
    ax = panel(gs[1, 2], [], "closure violation [m or rad]")
    if "closure_error" in columns:
        ax.semilogy(t, np.abs(columns["closure_error"]) + 1e-18, lw=1.0)
    text = fig.add_subplot(gs[0:2, 3])
    text.axis("off")
    lines = [f"{k}: {v}" for k, v in key_numbers(columns, drive, model)]
    text.text(0.0, 1.0, "Key numbers\n\n" + "\n".join(lines), va="top", fontsize=8.5, family="monospace",
              wrap=True)
    if model is not None:
        names = model.coordinate_names
        q = np.column_stack([columns[n] for n in names])
        zs = np.array([model.z_from_q(row) for row in q])
        xlim, ylim = fit_view(model, zs)
        for j, i in enumerate(np.linspace(0, len(t) - 1, 4).astype(int)):
            ax = fig.add_subplot(gs[2, j])
            Drawer(ax, model, xlim, ylim).draw(frame_geometry(model, zs[i]), f"t = {t[i]:.3g} s")
            ax.tick_params(labelsize=7)
            ax.xaxis.label.set_size(8)
            ax.yaxis.label.set_size(8)
    else:
        ax = fig.add_subplot(gs[2, :])
        ax.axis("off")
        ax.text(0.5, 0.5, "(pass --scene to draw the mechanism at four instants)", ha="center", fontsize=10)
    fig.suptitle(title or "grubler run report", fontsize=12)
    fig.savefig(out, dpi=100)
    plt.close(fig)
