"""Labelled plots of a trajectory (matplotlib, no display needed)."""

from __future__ import annotations

import math
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

# A joint that turns further than this between two samples (1/8 turn) is drawn as a
# stroboscope would show it: its curve, or the film, steps by whole fractions of a
# turn and may even seem to turn backwards.
MAX_TURN_PER_SAMPLE = math.pi / 4


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


def kind_words(model) -> str:
    """What a mechanism is, for a title: its declared type, else what :func:`grubler.classify` reads off it.

    Examples
    --------
    >>> import dataclasses
    >>> from grubler.mechanism.scene import load_scene
    >>> m = dataclasses.replace(load_scene("fourbar-crank-rocker").mechanism, kind="")  # a scene with no type
    >>> kind_words(m)
    'four-bar (crank-rocker)'
    """
    if model.kind:
        return model.kind
    from grubler.mechanism.analysis import classify

    return classify(model).name


def turns(values) -> float:
    """How many turns an angle series sweeps (its range over 2 pi); above 1 it is drawn wrapped.

    Examples
    --------
    >>> turns([0.0, 10 * math.pi])
    5.0
    """
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.ptp(v) / (2.0 * math.pi)) if v.size else 0.0


def wrap_angle(t, values, lo=None, hi=None):
    """An angle series wrapped to [-pi, pi), broken (NaN) where it wraps, so a turning crank's curve
    stays on the scale of every other curve and no line is drawn across a wrap.

    ``lo`` and ``hi`` (a band about ``values``, e.g. :func:`envelope`'s) are moved
    by the same whole turns.  Returns ``(t, values)`` or ``(t, values, lo, hi)``.

    Examples
    --------
    >>> t, w = wrap_angle([0.0, 1.0, 2.0], [3.0, 3.3, 3.6])
    >>> [round(float(x), 3) for x in w]
    [3.0, nan, -2.983, -2.683]
    """
    t = np.asarray(t, dtype=float)
    values = np.asarray(values, dtype=float)
    k = np.floor((values + math.pi) / (2.0 * math.pi))
    shift = 2.0 * math.pi * k
    cut = np.flatnonzero(np.diff(k) != 0) + 1  # a NaN before each sample in a new turn
    out = [np.insert(t, cut, np.nan), np.insert(values - shift, cut, np.nan)]
    if lo is not None:
        out += [np.insert(np.asarray(lo) - shift, cut, np.nan), np.insert(np.asarray(hi) - shift, cut, np.nan)]
    out[0][cut + np.arange(len(cut))] = t[cut]  # a break in y is enough: keep the time axis monotonic
    return tuple(out)


def wrapped_label(label: str, values) -> str:
    """The legend of a turning angle drawn wrapped: how it is drawn and how far it turned."""
    return f"{label}, wrapped to ±π ({turns(values):.3g} turns)"


def coarse_sampling(t, angles, option: str, per: str = "sample", speed: float = 1.0) -> str | None:
    """A warning when the fastest of ``angles`` (name -> rad at ``t``) turns more than 1/8 turn between two
    samples: the curve or film shows it stroboscopically.  ``option`` is what refines the grid
    (``--dt-out``, ``--fps``); the warning names it and the value that would do
    (for a film, ``t`` are the frames' times, ``speed`` seconds of motion per second of film).

    Examples
    --------
    >>> t = np.arange(0.0, 1.0, 0.01)
    >>> coarse_sampling(t, {"theta2": 2 * np.pi * 30 * t}, "--dt-out")[:60]
    '--dt-out: theta2 turns 0.3 turn per sample (0.01 s): the cur'
    >>> coarse_sampling(t, {"theta2": np.sin(t)}, "--dt-out") is None
    True
    >>> coarse_sampling([0.0, 0.0, 0.0, 1.0], {"theta2": [0.0, 0.0, 0.0, 1.0]}, "--fps", "frame")[:46]
    '--fps: theta2 turns 0.16 turn per frame (1 s):'
    """
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        return None
    fastest, step = None, 0.0
    for name, values in angles.items():
        d = np.abs(np.diff(np.asarray(values, dtype=float)))
        d = d[np.isfinite(d)]
        if d.size and d.max() > step:
            fastest, step = name, float(d.max())
    if step <= MAX_TURN_PER_SAMPLE:
        return None
    # frames of a record coarser than the film repeat its rows: only the times that advance are intervals
    intervals = np.diff(t)
    intervals = intervals[intervals > 0]
    if not intervals.size:
        return None
    dt = float(np.median(intervals))
    what = "the film" if option == "--fps" else "the curve"
    factor = step / MAX_TURN_PER_SAMPLE
    fps = factor * speed / dt
    fix = (f"--fps {fps:.3g} or more" if option == "--fps" and fps <= 100 else
           f"{factor:.2g} times the frames per second of motion (--fps at most 100, a lower --speed)"
           if option == "--fps" else f"{option} {dt / factor:.2g} or less")
    return (f"{option}: {fastest} turns {step / (2 * math.pi):.2g} turn per {per} ({dt:.3g} s): {what} shows it "
            f"stroboscopically (more than 1/8 turn per {per}); use {fix}")


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
    title = f"{m.name or 'scene'}: {kind_words(m)} ({res.method} closure)"
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.0), sharex=True, layout="constrained")
    ax = axes[0, 0]
    for name in m.free_names:
        label, values = f"{name} [{unit_of(name)}]", res[name]
        if unit_of(name) == "rad" and turns(values) > 1.0:  # a turning crank would flatten every other curve
            ax.plot(*wrap_angle(res.t, values), label=wrapped_label(label, values))
        else:
            ax.plot(res.t, values, label=label)
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
        note = ""
    else:
        damped = any(getattr(lk, "damping", 0.0) for lk in m.links)
        note = "no drive work" + ("; E falls by what the dampers take" if damped else "")
    ax.set_ylabel("energy [J]")
    ax.set_xlabel("t [s]")
    _legend_above(ax, note)
    for a in axes.flat:
        a.grid(True, alpha=0.3)
    fig.suptitle(title)
    return fig


def _legend_above(ax, note: str = ""):
    """The axes' legend above it, beside any title, never over a curve (constrained layout makes the room).

    A ``note`` on the panel heads the legend (its title), so the two never share a line.
    """
    legend = ax.legend(fontsize=8, loc="lower left", bbox_to_anchor=(0.0, 1.01), ncol=3, frameon=False,
                       borderaxespad=0.0, handlelength=1.5, columnspacing=1.0, title=note or None,
                       title_fontsize=9, alignment="left")
    return legend


def envelope(t, values, bins: int):
    """Per-bin time, min, max and mean of a dense series (bins of equal sample count)."""
    edges = np.linspace(0, len(t), bins + 1).astype(int)
    idx = edges[:-1]
    tb = 0.5 * (t[idx] + t[edges[1:] - 1])
    lo = np.minimum.reduceat(values, idx)
    hi = np.maximum.reduceat(values, idx)
    mean = np.add.reduceat(values, idx) / np.diff(edges)
    return tb, lo, hi, mean


PRESSURE_UNIT, BAR = "Pa", 1e5  # a pressure recorded in Pa is drawn in bar

# how a curve is drawn by what it is (a word of its legend): a reference dashed on top,
# a sampled measurement as thin steps under it (seen between the dashes), what responds
# solid and wide underneath both, so that three curves that nearly coincide all stay visible
ROLES = (
    (("setpoint", "reference", "command", "target", "demand"),
     {"ls": (0, (4, 3)), "lw": 1.4, "zorder": 3.5}),
    (("encoder", "measured", "sensor", "sampled"),
     {"drawstyle": "steps-post", "lw": 0.9, "zorder": 3.0}),
)


def supply_pressures(system) -> dict[str, float]:
    """The supply pressure (Pa) a system's components are given as a parameter, by component.

    A pneumatic cylinder's supply is a constant it is given; a hydraulic one's is a
    node it records (``supply_pressure`` as an output).  Plots of the chamber
    pressures draw the given one as a reference line.
    """
    out = {}
    for name, comp in getattr(system, "components", {}).items():
        value = comp.parameters.get("supply_pressure")
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            out[name] = float(value)
    return out


def _role(label: str) -> dict | None:
    words = label.lower()
    return next((dict(style) for keys, style in ROLES if any(key in words for key in keys)), None)


def curve_style(labels: list[str], k: int) -> dict:
    """Line keywords of curve ``k`` of a panel whose curves are ``labels``, by its role (:data:`ROLES`).

    Any other curve is solid, wide and underneath: of several, each later one is
    narrower and above the one before, so none hides another.

    Examples
    --------
    >>> labels = ["crank angle, setpoint", "crank angle, response", "crank angle, encoder"]
    >>> curve_style(labels, 0)["zorder"] > curve_style(labels, 1)["zorder"]
    True
    >>> curve_style(["x"], 0)
    {'lw': 1.2, 'zorder': 2.0}
    """
    if len(labels) == 1:  # alone ("setpoint - response" too): nothing to tell it from
        return {"lw": 1.2, "zorder": 2.0}
    role = _role(labels[k])
    if role is not None:
        return role
    plain = [i for i, label in enumerate(labels) if _role(label) is None]
    rank = plain.index(k)
    return {"lw": 3.6 - 2.0 * rank / max(len(plain) - 1, 1), "zorder": 2.0 + 0.1 * rank, "solid_capstyle": "butt"}


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
        drawn_limits = (limits or {}).get(name, [])  # by the panel's title as given
        merged: list[tuple[str, np.ndarray, str]] = []
        for label, values, unit in lines:
            values = np.asarray(values, dtype=float)
            for k, (other, ov, ou) in enumerate(merged):
                if np.array_equal(ov, values):
                    merged[k] = (f"{other} = {label}", ov, ou or unit)
                    break
            else:
                merged.append((label, values, unit))
        scale = 1.0
        if PRESSURE_UNIT in {u for _, _, u in merged} or name.endswith(f"[{PRESSURE_UNIT}]"):
            # a pressure is read in bar, as the report and the datasheets give it (no 1e7 offset)
            scale, name = BAR, name.replace(f"[{PRESSURE_UNIT}]", "[bar]")
            merged = [(lb, v / BAR, "bar" if u == PRESSURE_UNIT else u) for lb, v, u in merged]
        units = sorted({u for _, _, u in merged if u})
        for k, (label, values, unit) in enumerate(merged):
            style = curve_style([lb for lb, _, _ in merged], k)
            turning = unit == "rad" and turns(values) > 1.0  # drawn wrapped: it would flatten the others
            label = textwrap.fill(wrapped_label(label, values) if turning else label, 28)
            if dense:
                tb, lo, hi, mean = envelope(t, values, ENVELOPE_BINS)
                if turning:
                    tb, mean, lo, hi = wrap_angle(tb, mean, lo, hi)
                style.pop("drawstyle", None)  # steps of bin means would be the bins', not the sampling's
                (line,) = ax.plot(tb, mean, label=label, **style)
                ax.fill_between(tb, lo, hi, color=line.get_color(), alpha=0.3, lw=0, zorder=1.5)  # under every line
            else:
                ax.plot(*(wrap_angle(t, values) if turning else (t, values)), label=label, **style)
        for k, (label, value) in enumerate(drawn_limits):
            both = label.startswith("±")
            value = value / scale
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
