"""Labelled plots of a trajectory (matplotlib, no display needed)."""

from __future__ import annotations

import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np  # noqa: E402

from grubler.mechanism.simulate import Result, unit_of  # noqa: E402


# A curve with more samples than this is drawn as its min/max envelope over
# bins plus the bins' means: a 1 kHz record of a chattering current on a
# 10-inch axis would otherwise be a solid band of zig-zags (chatter), and a
# subsample of it would alias.
ENVELOPE_BINS = 500


def closing_force_words(model) -> str:
    """The closing joint's force in a design review's words: the pin's on the rocker, the guide's on the slider.

    Examples
    --------
    >>> from grubler.mechanism.scene import load_scene
    >>> closing_force_words(load_scene("thesis-fourbar").mechanism)
    'closing-pin force on the rocker'
    >>> closing_force_words(load_scene("slider-crank").mechanism)
    'guide force on the slider'
    """
    cl = model.closures[0]
    four_link = model.n_links == 3 and cl.link == 4  # the closing link of a four-bar or slider-crank
    if cl.kind == "revolute":
        return f"closing-pin force on {'the rocker' if four_link else f'link{cl.link}'}"
    return f"guide force on {'the slider' if four_link else f'link{cl.link}'}"


def _all_zero(values) -> bool:
    return bool(np.all(np.asarray(values) == 0.0))


def plot_result(res: Result, path: str) -> None:
    """Save :func:`result_figure` of ``res`` to ``path`` (PNG or any format matplotlib writes).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import grubler
    >>> res = grubler.simulate("thesis-fourbar", t_end=0.5)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     plot_result(res, pathlib.Path(d) / "fourbar.png")
    ...     print(sorted(p.name for p in pathlib.Path(d).iterdir()))
    ['fourbar.png']
    """
    fig = result_figure(res)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def result_figure(res: Result):
    """Coordinates, closing-joint force, closure error and energy against time.

    Columns that are zero at every sample (a revolute closure's moment ``Mz``)
    are left out and named in the panel's title; the energy panel shows the
    drive's work beside the energies, and ``E(0)`` plus that work, which ``E``
    would follow without damping; the closure violation is drawn on a log axis
    only where it is not exactly zero.

    Examples
    --------
    >>> import grubler
    >>> fig = result_figure(grubler.simulate("thesis-fourbar", t_end=0.5))   # a matplotlib Figure, not shown
    >>> fig.axes[-1].get_xlabel()                      # the panels share the time axis
    't [s]'
    >>> fig.axes[-1].get_ylabel()
    'energy [J]'
    """
    m = res.model
    title = f"{m.name or 'scene'}: {m.kind or ''} ({res.method} closure)".replace(" ()", "")
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.0), sharex=True, layout="constrained")
    ax = axes[0, 0]
    for name in m.free_names:
        ax.plot(res.t, res[name], label=f"{name} [{unit_of(name)}]")
    ax.set_ylabel("real joint coordinates (absolute)")
    _legend_above(ax)
    ax = axes[0, 1]
    if len(m.closures) > 1:
        # several loops: each closure's force magnitude on its closing link
        for j, cl in enumerate(m.closures):
            fx, fy = (res["Fx"], res["Fy"]) if j == 0 else (res[f"closure{j}_Fx"], res[f"closure{j}_Fy"])
            ax.plot(res.t, np.hypot(fx, fy), label=f"closure[{j}]: link{cl.link}-link{cl.to_link} [N]")
        ax.set_ylabel("closing-joint force magnitudes")
        _legend_above(ax)
    elif m.closures:
        zero = [c for c in ("Fx", "Fy", "Mz") if _all_zero(res[c])]
        for c in ("Fx", "Fy", "Mz"):
            if c not in zero:
                ax.plot(res.t, res[c], label=f"{c} [{unit_of(c)}]")

        ax.set_ylabel(closing_force_words(m))
        if zero:  # right-aligned: the legend takes the left of the space above the axes
            ax.set_title(f"{', '.join(zero)} = 0 throughout (not drawn)", fontsize=9, loc="right")
        if len(zero) < 3:
            _legend_above(ax)
    else:
        ax.plot(res["tip_x"], res["tip_y"])
        ax.set_ylabel("tip path y [m] (x on the bottom axis)")
    ax = axes[1, 0]
    err = np.abs(np.asarray(res["closure_error"], dtype=float))
    nonzero = err > 0
    if nonzero.any():
        # exact zeros have no logarithm: leave them out rather than floor them
        # into a fence of spikes, and say how many there were
        ax.semilogy(res.t[nonzero], err[nonzero], ".", ms=2.5)
        n0 = int((~nonzero).sum())
        if n0:
            ax.set_title(f"exactly 0 at {n0} of {len(err)} samples (not drawn)", fontsize=9)
    else:
        ax.plot(res.t, err)
        ax.set_title("exactly 0 at every sample", fontsize=9)
    ax.set_ylabel("closure violation [m or rad]")
    ax.set_xlabel("t [s]")
    ax = axes[1, 1]
    for c, words in (("KE", "kinetic KE"), ("PE", "potential PE"), ("E", "total E = KE + PE")):
        ax.plot(res.t, res[c], label=words)
    power = sum((res[c] for c in ["P_drive"] + [f"{a}_power" for a in m.actuator_names] if c in res.columns),
                np.zeros_like(res.t))
    if not _all_zero(power):
        import scipy.integrate  # here: a second of imports that the film's strips do not need

        who = "drive" if not m.actuators else "drive and actuators" if "P_drive" in res.columns and not \
            _all_zero(res["P_drive"]) else "actuators"
        work = scipy.integrate.cumulative_trapezoid(power, res.t, initial=0.0)
        ax.plot(res.t, work, "--", label=f"work done by the {who}")
        ax.plot(res.t, res["E"][0] + work, ":", color="0.3", label=f"E(0) + {who} work (E without losses)")
    else:
        damped = any(getattr(lk, "damping", 0.0) for lk in m.links)
        ax.set_title("no drive work" + ("; E falls by what the dampers take" if damped else ""), fontsize=9)
    ax.set_ylabel("energy [J]")
    ax.set_xlabel("t [s]")
    _legend_above(ax)
    for a in axes.flat:
        a.grid(True, alpha=0.3)
    fig.suptitle(title)
    return fig


def _legend_above(ax) -> None:
    """The axes' legend above it, beside any title, never over a curve (constrained layout makes the room)."""
    ax.legend(fontsize=8, loc="lower left", bbox_to_anchor=(0.0, 1.01), ncol=3, frameon=False, borderaxespad=0.0,
              handlelength=1.5, columnspacing=1.0)


def envelope(t, values, bins: int):
    """Per-bin time, min, max and mean of a dense series (bins of equal sample count)."""
    edges = np.linspace(0, len(t), bins + 1).astype(int)
    idx = edges[:-1]
    tb = 0.5 * (t[idx] + t[edges[1:] - 1])
    lo = np.minimum.reduceat(values, idx)
    hi = np.maximum.reduceat(values, idx)
    mean = np.add.reduceat(values, idx) / np.diff(edges)
    return tb, lo, hi, mean


def plot_panels(t, panels, path: str, title: str = "", limits=None) -> None:
    """Save :func:`panels_figure` to ``path`` (PNG or any format matplotlib writes).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     plot_panels(t, [("voltage [V]", [("motor", 12 * np.sin(t), "V")])], pathlib.Path(d) / "v.png")
    ...     print([p.name for p in pathlib.Path(d).iterdir()])
    ['v.png']
    """
    fig = panels_figure(t, panels, title, limits)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def panels_figure(t, panels, title: str = "", limits=None):
    """Stacked time plots sharing the time axis.

    Curves in a panel that are equal at every sample are drawn once, their
    labels joined by " = "; a series denser than the axis can show is drawn as
    its min/max band and mean over bins (the x label says how wide).

    Parameters
    ----------
    t : array
    panels : list of (title, [(label, values, unit), ...])
        The title is the axis label; give it the unit in square brackets.
    title : str
        The figure's title.
    limits : dict, optional
        Horizontal lines by panel title: ``{title: [(label, value), ...]}``, a
        limit such as the supply voltage, drawn dashed and drawn at +-value
        when the label starts with "±".

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> fig = panels_figure(t, [("crank angle [rad]", [("setpoint", t, "rad"), ("response", t ** 2, "rad")]),
    ...                         ("voltage", [("motor", 12 * np.sin(t), "V")])],
    ...                     title="servo", limits={"voltage": [("±24 V supply", 24.0)]})
    >>> [ax.get_ylabel() for ax in fig.axes]          # a title without its unit gets the curves'
    ['crank angle [rad]', 'voltage [V]']
    >>> [line.get_ydata()[0] for line in fig.axes[1].lines[1:]]   # the supply drawn at +24 and -24 V
    [24.0, -24.0]
    """
    t = np.asarray(t, dtype=float)
    n = max(len(panels), 1)
    fig, axes = plt.subplots(n, 1, figsize=(12, 1.9 * n + 1.0), sharex=True, squeeze=False)
    dense = len(t) > 2 * ENVELOPE_BINS
    for ax, (name, lines) in zip(axes[:, 0], panels):
        merged: list[tuple[str, np.ndarray, str]] = []
        for label, values, unit in lines:
            values = np.asarray(values, dtype=float)
            for k, (other, ov, ou) in enumerate(merged):
                if np.array_equal(ov, values):
                    merged[k] = (f"{other} = {label}", ov, ou or unit)
                    break
            else:
                merged.append((label, values, unit))
        units = sorted({u for _, _, u in merged if u})
        for label, values, _unit in merged:
            if dense:
                tb, lo, hi, mean = envelope(t, values, ENVELOPE_BINS)
                (line,) = ax.plot(tb, mean, label=textwrap.fill(label, 28), lw=1.1)
                ax.fill_between(tb, lo, hi, color=line.get_color(), alpha=0.3, lw=0)
            else:
                ax.plot(t, values, label=textwrap.fill(label, 28), lw=1.2)
        for k, (label, value) in enumerate((limits or {}).get(name, [])):
            both = label.startswith("±")
            for v in ((value, -value) if both else (value,)):
                ax.axhline(v, color="0.35", lw=1.0, ls=("--", ":", "-.")[k % 3], label=label if v == value else None)
        # a title that carries its unit keeps it; the FMUs' spellings ("N.m") would repeat it
        ax.set_ylabel(name if "[" in name or not units else f"{name} [{', '.join(units)}]", fontsize=9)
        if ax.get_legend_handles_labels()[0]:
            # beside the axes, never over a curve
            ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)
        ax.grid(True, alpha=0.3)
    xlabel = "t [s]"
    if dense:
        width = (t[-1] - t[0]) / ENVELOPE_BINS
        xlabel += f"    (line: mean, band: min to max over each {width * 1e3:.3g} ms)"
    axes[-1, 0].set_xlabel(xlabel)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


# the public names (the API reference's): the rest is the package's inside
__all__ = ["plot_result", "result_figure", "plot_panels", "panels_figure"]
