"""Figures of a sizing study: what the cycle needs against what each candidate gives.

The studies (:mod:`grubler.studies.sizing` for motors, :mod:`grubler.studies.cylinder_sizing`
for cylinders) compute; this module only
draws what it computed, as python-control's ``timeplot`` draws ``timeresp``'s
data.  Pressures are in bar and forces in kN, as the CLI's lines print them.
"""

from __future__ import annotations

import math

import numpy as np

from grubler.quantities import RPM

from grubler.views.plotting import plt

MARGIN_FLOOR = 1e-3  # a margin of 0 (no force at all) has no logarithm: drawn at the floor, and said


def save_cylinder_sizing(study, path) -> None:
    """Save :func:`cylinder_sizing_figure` of ``study`` to ``path`` (PNG or any format matplotlib writes)."""
    fig = cylinder_sizing_figure(study)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def cylinder_sizing_figure(study):
    """Three panels of a :class:`~grubler.studies.cylinder_sizing.CylinderStudy`.

    The force the piston must give over the cycle beside what the best candidate
    (or, when none fits, the nearest) gives at each instant; each limit's margin
    against the bore, the force's at each supply pressure (log axis, 1 is
    exactly enough); and
    the hydraulic power each installs, the ranking's key (filled: it fits).
    """
    d = study.demand
    shown = study.best or (study.rejected[0] if study.rejected else None)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), layout="constrained")
    ax = axes[0]
    if shown is not None and shown.needed is not None:
        ax.plot(d.t, shown.needed / 1e3, label="needed (load and seal friction)")
        ax.plot(d.t, shown.available / 1e3, "--", label=f"{shown.candidate.label} gives")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("piston force along the actuator [kN]")
    ax.set_title(("best: " if study.best is not None else "none fits; nearest: ")
                 + (shown.candidate.label if shown is not None else "-"), fontsize=9)
    ax.legend(fontsize=8, loc="best")
    pressures = sorted({a.candidate.pressure for a in study.assessments})
    floored = False

    def margin_line(group, limit, label, style):
        nonlocal floored
        bores = np.array([a.candidate.bore * 1e3 for a in group])
        m = np.array([a.margins[limit] for a in group], dtype=float)
        floored |= bool(np.any(m < MARGIN_FLOOR))
        return axes[1].plot(bores, np.clip(np.where(np.isfinite(m), m, np.nan), MARGIN_FLOOR, None), style,
                            label=label)[0]

    for k, p in enumerate(pressures):
        group = sorted((a for a in study.assessments if a.candidate.pressure == p), key=lambda a: a.candidate.bore)
        # the force's margin is the supply pressure's; flow, stroke and buckling are the bore's alone
        line = margin_line(group, "force", f"force, {p / 1e5:g} bar", "o-")
        if k == 0:
            for limit, style in (("flow", "s--"), ("stroke", "^:"), ("buckling", "d-.")):
                margin_line(group, limit, limit, style).set_color(("0.45", "0.3", "0.15")[("flow", "stroke",
                                                                                            "buckling").index(limit)])
        bores = np.array([a.candidate.bore * 1e3 for a in group])
        power = np.array([a.power / 1e3 for a in group])
        fits = np.array([a.feasible for a in group])
        axes[2].plot(bores, power, "-", color=line.get_color(), label=f"{p / 1e5:g} bar")
        axes[2].plot(bores[fits], power[fits], "o", color=line.get_color())
        axes[2].plot(bores[~fits], power[~fits], "o", mfc="none", color=line.get_color())
    ax = axes[1]
    ax.set_yscale("log")
    ax.axhline(1.0, color="k", lw=1.0, label="exactly enough")
    ax.set_xlabel("bore [mm]")
    ax.set_ylabel("margin of each limit (available / needed)")
    ax.set_title("a candidate fits where every limit is above 1"
                 + (f"; a margin of 0 is drawn at {MARGIN_FLOOR:g}" if floored else ""), fontsize=9)
    ax.legend(fontsize=8, loc="best")
    ax = axes[2]
    ax.set_xlabel("bore [mm]")
    ax.set_ylabel("installed power at the peak flow [kW]")
    ax.set_title("filled: fits, hollow: rejected", fontsize=9)
    ax.legend(fontsize=8, title="supply", title_fontsize=8, loc="best")
    if study.best is not None:
        b = study.best
        axes[2].plot(b.candidate.bore * 1e3, b.power / 1e3, "o", ms=14, mfc="none", color="k", label="_best")
    for a in axes:
        a.grid(True, alpha=0.3)
    name = getattr(d, "name", "")
    fig.suptitle("cylinder sizing" + (f": {name}" if name else "") + f", {len(study.ranked)} of "
                 f"{len(study.assessments)} bore x supply pressure combinations fit")
    return fig


# -- motors ----------------------------------------------------------------------------------------------
LOOP_COLOUR = "0.25"  # the closed loop's points: grey under every motor's colour


def save_motor_sizing(study, path) -> None:
    """Save :func:`motor_sizing_figure` of ``study`` to ``path`` (PNG or any format matplotlib writes)."""
    fig = motor_sizing_figure(study)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def motor_sizing_figure(study):
    """A motor :class:`~grubler.studies.sizing.SizingStudy`: duty-cycle points over each motor's envelopes, margin against gear ratio, and the key.

    One panel per motor, the best combination's first, each at that motor's
    best ratio; then the smallest margin of every combination against its
    ratio (log axis; a winding that runs away thermally has no margin and is
    marked on the axis, not drawn as a 0); then one key for all panels and
    the ranking, so that no legend covers data.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from grubler.views.plotting import plt

    motors = sorted(dict.fromkeys(a.candidate.motor.name for a in study.assessments),
                    key=lambda name: -max(a.known_margin for a in study.assessments
                                          if a.candidate.motor.name == name))
    if study.best is not None:  # the winner first, even where another motor's margin on known limits is larger
        motors.remove(study.best.candidate.motor.name)
        motors.insert(0, study.best.candidate.motor.name)
    panels = len(motors) + 2
    # three columns, but never the key alone on a last row: four panels in two by two, seven in two by four
    ncols = 2 if panels == 4 else 4 if panels % 3 == 1 and panels > 4 else min(panels, 3)
    nrows = -(-panels // ncols)
    fig = plt.figure(figsize=(5.4 * ncols, 4.3 * nrows), layout="constrained")
    grid = fig.add_gridspec(nrows, ncols)
    cells = [grid[k // ncols, k % ncols] for k in range(len(motors) + 1)]
    colours = {name: f"C{i}" for i, name in enumerate(motors)}
    for cell, name in zip(cells, motors):
        ax = fig.add_subplot(cell)
        pick = (study.best if study.best is not None and study.best.candidate.motor.name == name
                else max((a for a in study.assessments if a.candidate.motor.name == name), key=lambda a: a.known_margin))
        _envelope_panel(study, ax, pick, colours[name])
    _margin_panel(study, fig.add_subplot(cells[-1]), motors, colours)
    k = len(motors) + 1
    key_ax = fig.add_subplot(grid[k // ncols, k % ncols:])  # the key takes the rest of the last row
    key_ax.axis("off")
    handles = [Line2D([], [], ls="", marker=".", color="C0", label="duty cycle, ideal drive (each motor's colour)"),
               Line2D([], [], ls="", marker=".", color=LOOP_COLOUR, alpha=0.5,
                      label="with the servo's PID and encoder"),
               Patch(color="tab:orange", alpha=0.25, label="peak envelope: supply voltage and current limit"),
               Patch(color="tab:green", alpha=0.3, label="continuous: the nominal torque"),
               Line2D([], [], ls="", marker="*", ms=11, color="k", label="best combination")]
    handles += [Line2D([], [], color=colours[n], marker="o", ms=3, label=f"{n}: smallest margin") for n in motors]
    handles += [Line2D([], [], ls="", marker="x", color="0.3",
                       label="winding runs away thermally: no margin")]
    key_ax.legend(handles=handles, loc="upper left", fontsize=8, frameon=False, title="key", title_fontsize=9,
                  alignment="left")
    ranked = [f"{k + 1}. {a.candidate.label}: margin {a.min_margin:.2f} ({a.binding})"
              for k, a in enumerate(study.ranked[:5])] or ["no combination fits"]
    if len(study.ranked) > 5:
        ranked.append(f"... {len(study.ranked) - 5} more")
    key_ax.text(0.0, 0.0, "ranking\n" + "\n".join(ranked), transform=key_ax.transAxes, va="bottom", ha="left",
                fontsize=8, family="DejaVu Sans Mono")
    fig.suptitle(f"sizing: {study.cycle.name}")
    return fig

def _envelope_panel(study, ax, pick, colour: str) -> None:
    """One motor at its best ratio: the cycle's points over what the supply and the winding allow."""
    c, d = pick.candidate, pick.candidate.motor
    w = np.abs(pick.motor_speed)
    # the envelopes under the points: what the supply and the current limit allow (back-EMF eats the
    # voltage while the motor drives, and adds to it while it brakes), and the continuous torque
    w_top = (d.max_speed or d.no_load_speed or float(np.max(w)) * 1.2)
    ws = np.linspace(-w_top, w_top, 200)
    i_max = min(c.current_limit, c.supply_voltage / d.resistance)
    kt, ke, R, V = d.torque_constant, d.back_emf_constant, d.resistance, c.supply_voltage
    upper = np.clip(kt * (V - ke * ws) / R, -kt * i_max, kt * i_max)
    lower = np.clip(-kt * (V + ke * ws) / R, -kt * i_max, kt * i_max)
    ax.fill_between(ws * RPM, lower * 1e3, upper * 1e3, color="tab:orange", alpha=0.15, lw=0)
    if d.nominal_torque:
        ax.fill_between(ws * RPM, -d.nominal_torque * 1e3, d.nominal_torque * 1e3, color="tab:green", alpha=0.2,
                        lw=0)
    loop = pick.closed_loop
    if loop is not None:  # what the margins judge: the torque the loop's current makes
        speed = np.interp(loop.t, study.cycle.t - study.cycle.t[0], pick.motor_speed)
        ax.plot(speed * RPM, d.torque_constant * loop.current * 1e3, ".", ms=1, color=LOOP_COLOUR, alpha=0.25)
    ax.plot(pick.motor_speed * RPM, pick.motor_torque * 1e3, ".", ms=2, color=colour)
    ax.set_xlabel("motor speed [rpm]")
    ax.set_ylabel("motor torque [mN m]")
    verdict = "fits" if pick.feasible else "fails on " + ", ".join(k for k, v in pick.margins.items() if v < 1.0)
    margin = "none (thermal runaway)" if pick.runaway else f"{pick.min_margin:.2f} ({pick.binding})"
    supply = f"{c.supply_voltage:g} V" + (f", {c.current_limit:g} A" if math.isfinite(c.current_limit) else "")
    best = "best: " if pick is study.best else ""
    ax.set_title(f"{best}{d.name} at {c.ratio:g}:1 on {supply}\n{verdict}; smallest margin {margin}",
                 fontsize=9)
    ax.grid(True, alpha=0.3)

def _margin_panel(study, ax, motors: list[str], colours: dict[str, str]) -> None:
    """The smallest margin of every combination against its gear ratio, per motor."""
    import matplotlib.ticker
    import matplotlib.transforms as mtransforms

    on_axis = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    for name in reversed(motors):  # the winner's line on top
        mine = sorted((a for a in study.assessments if a.candidate.motor.name == name),
                      key=lambda a: a.candidate.ratio)
        ratios = [a.candidate.ratio for a in mine]
        # a runaway has no margin: a gap in the line, a cross on the axis, never a 0 that looks like data
        margins = [math.nan if a.runaway else a.known_margin for a in mine]
        ax.plot(ratios, margins, "o-", ms=3, color=colours[name], lw=2.0 if name == motors[0] else 1.2)
        gone = [r for r, a in zip(ratios, mine) if a.runaway]
        ax.plot(gone, [0.03] * len(gone), "x", color=colours[name], ms=6, transform=on_axis, clip_on=False)
    if study.best is not None:
        ax.plot([study.best.candidate.ratio], [study.best.min_margin], "*", ms=13, color="k", zorder=5)
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_yscale("log")
    # plain numbers on the log axis: 0.5 and 2 read as margins, 5e-1 and 2e0 do not
    ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("gear ratio")
    ax.set_ylabel("smallest margin (limit / need)")
    ax.set_title("margin against gear ratio (fits above the dashed line)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)


__all__ = ["cylinder_sizing_figure", "save_cylinder_sizing", "motor_sizing_figure", "save_motor_sizing"]
