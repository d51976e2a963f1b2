"""A one-page run report that reads like a datasheet.

The page has the run's name as its title, a table of key numbers with their
units, the run's quantities against time (one quantity per axis, dense records
drawn as their min/max band), and, given the scene, the mechanism at four
instants.  The layout is matplotlib's constrained layout: no label, tick or
title overlaps another (tests/test_report.py checks every pair of text boxes).
"""

from __future__ import annotations

import math
import os

import numpy as np

from grubler.mechanism.model import Mechanism
from grubler.quantities import RPM

PAGE = (11.69, 8.27)  # inches: A4 landscape
LEFT_SHARE, TABLE_SHARE = 0.36, 0.5  # of the page's width: the left column; of its height: the table
BLUE, ORANGE, GREEN, GREY = "#1f77b4", "#ff7f0e", "#2ca02c", "0.35"


def energy_balance(columns: dict[str, np.ndarray], model: Mechanism) -> np.ndarray:
    """E(t) - E(0) minus the work of the drive, the actuators and the point loads plus what the joint dampers
    and the force elements' dampers and friction took (J).

    Zero for an exact run: what is left is integration error (and the trapezoid
    rule's error on the output grid for the work).  In a co-simulation the drive
    torque is held over each communication step, which the trapezoid rule over
    the record does not know: there the remainder is the coupling's, not the
    mechanism's (see :func:`residue_name`).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import grubler
    >>> from grubler.views.runs import read_run_csv
    >>> with tempfile.TemporaryDirectory() as d:
    ...     grubler.simulate("thesis-fourbar", t_end=0.5).to_csv(pathlib.Path(d) / "run.csv")
    ...     columns = read_run_csv(pathlib.Path(d) / "run.csv")
    >>> residue = energy_balance(columns, grubler.load_scene("thesis-fourbar").mechanism)
    >>> bool(abs(residue).max() < 1e-6)               # J: an exact run leaves only integration error
    True
    """
    t = columns["t"]
    qd = np.column_stack([columns[f"{n}_d"] for n in model.coordinate_names])
    zd = np.array([model.zd_from_qd(row) for row in qd])
    power = columns.get("P_drive", np.zeros_like(t)) - (zd**2) @ model.arrays.damping
    for name in model.actuator_names:  # an actuator's power, force x rate, in the record or from them
        if f"{name}_power" in columns:
            power = power + columns[f"{name}_power"]
        elif f"{name}_force" in columns and f"{name}_rate" in columns:
            power = power + columns[f"{name}_force"] * columns[f"{name}_rate"]
    for element in model.forces:  # a spring's stored energy is in E; a load's work and a damper's loss are not
        if element.table == "point_load":
            power = power + columns.get(f"{element.name}_power", 0.0)
        else:
            power = power - columns.get(f"{element.name}_dissipation", 0.0)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    e = columns["E"]
    return e - e[0] - work


def residue_name(cosim: bool) -> str:
    """What :func:`energy_balance` measures, in words, for a simulate or a cosim record."""
    return "coupling residue" if cosim else "energy balance error"


def _drive_units(drive: str | None) -> tuple[str, str, str]:
    """(coordinate, speed, effort) units of a drive coordinate: a slide's are m, m/s, N."""
    if drive and drive.startswith("B"):
        return "m", "m/s", "N"
    return "rad", "rad/s", "N m"


def _closure_unit(model: Mechanism | None) -> str:
    if model is not None and all(cl.kind == "revolute" for cl in model.closures):
        return "m"
    return "m, rad (norm)"


def servo_target(columns: dict[str, np.ndarray], drive: str | None, model: Mechanism | None) -> tuple[str, str]:
    """What a record's setpoint is for, and its unit: the first actuator's length when the mechanism has
    actuators (a cylinder's position loop), else the drive coordinate."""
    if model is not None and model.actuators and f"{model.actuator_names[0]}_length" in columns:
        return f"{model.actuator_names[0]}_length", "m"
    return drive or "", _drive_units(drive)[0]


def key_numbers(columns: dict[str, np.ndarray], drive: str | None, model: Mechanism | None = None,
                cosim: bool = False) -> list[tuple[str, str]]:
    """The figures a reader wants from a run, as (label, value with unit) pairs.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import grubler
    >>> from grubler.views.runs import read_run_csv
    >>> with tempfile.TemporaryDirectory() as d:
    ...     grubler.simulate("thesis-fourbar", t_end=0.5).to_csv(pathlib.Path(d) / "run.csv")
    ...     columns = read_run_csv(pathlib.Path(d) / "run.csv")
    >>> numbers = dict(key_numbers(columns, "theta2", grubler.load_scene("thesis-fourbar").mechanism))
    >>> numbers["duration"], numbers["drive"]
    ('0.5 s, 51 samples', 'theta2 (revolute)')
    """
    t = columns["t"]
    unit, speed_unit, effort_unit = _drive_units(drive)
    out = [("duration", f"{t[-1] - t[0]:.4g} s, {len(t)} samples")]
    if len(t) > 1:
        dt = np.diff(t)
        out.append(("sample interval", f"{np.median(dt) * 1e3:.4g} ms"))
    if drive:
        kind = "slide" if unit == "m" else "revolute"
        out.append(("drive", f"{drive} ({kind})"))
        if drive in columns:
            q = columns[drive]
            out.append(("drive travel (min to max)", f"{q.min():.4g} to {q.max():.4g} {unit}"))
    if drive and f"{drive}_d" in columns:
        w = float(np.max(np.abs(columns[f"{drive}_d"])))
        rpm = f" ({w * RPM:.4g} rpm)" if unit == "rad" else ""
        out.append(("peak |drive speed|", f"{w:.4g} {speed_unit}{rpm}"))
    target, target_unit = servo_target(columns, drive, model)
    if target and "setpoint" in columns and target in columns:
        err = np.abs(columns["setpoint"] - columns[target])
        deg = f" ({math.degrees(err.max()):.3g} deg)" if target_unit == "rad" else ""
        out.append(("peak |tracking error|", f"{err.max():.3g} {target_unit}{deg}"))
        out.append(("RMS tracking error", f"{np.sqrt(np.mean(err**2)):.3g} {target_unit}"))
        out.append(("final tracking error", f"{err[-1]:.3g} {target_unit}"))
    if "cylinder_force" in columns:
        out.append(("peak |cylinder force|", f"{np.max(np.abs(columns['cylinder_force'])):.4g} N"))
    for name in unforced_actuators(columns, model):  # the page says what the run's warning said
        out.append((f"actuator {name} force", "0 N throughout: none was given"))
    for c, words in (("pressure_a", "cap side"), ("pressure_b", "rod side")):
        if c in columns:
            out.append((f"{words} pressure (min to max)",
                        f"{columns[c].min() / 1e5:.3g} to {columns[c].max() / 1e5:.3g} bar"))
    if "tau_drive" in columns:
        tau = columns["tau_drive"]
        out.append(("peak |drive torque|", f"{np.max(np.abs(tau)):.4g} {effort_unit}"))
        out.append(("RMS drive torque", f"{np.sqrt(np.mean(tau**2)):.4g} {effort_unit}"))
    if "current" in columns:
        i = columns["current"]
        out.append(("peak |motor current|", f"{np.max(np.abs(i)):.4g} A"))
        out.append(("RMS motor current", f"{np.sqrt(np.mean(i**2)):.4g} A"))
    if "voltage" in columns:
        out.append(("peak |motor voltage|", f"{np.max(np.abs(columns['voltage'])):.4g} V"))
    if "Fx" in columns and "Fy" in columns:
        out.append(("peak closing-joint force", f"{np.max(np.hypot(columns['Fx'], columns['Fy'])):.4g} N"))
    if "E" in columns:
        e = columns["E"]
        out.append(("energy change E(end) - E(0)", f"{e[-1] - e[0]:.4g} J"))
        out.append(("energy range (max - min)", f"{np.ptp(e):.4g} J"))
        if model is not None and all(f"{n}_d" in columns for n in model.coordinate_names):
            bal = energy_balance(columns, model)
            out.append((f"max |{residue_name(cosim)}|", f"{np.max(np.abs(bal)):.3g} J"))
    if "closure_error" in columns:
        out.append(("max closure violation", f"{np.max(np.abs(columns['closure_error'])):.3g} "
                                             f"{_closure_unit(model)}"))
    return out


def unforced_actuators(columns: dict[str, np.ndarray], model: Mechanism | None = None) -> list[str]:
    """The actuators whose recorded force is 0 at every sample: a run given no force for them.

    Without the scene, an actuator is known by its columns (``NAME_length`` beside ``NAME_force``).
    """
    names = model.actuator_names if model is not None else [
        c[:-len("_force")] for c in columns if c.endswith("_force") and f"{c[:-len('_force')]}_length" in columns]
    return [n for n in names if f"{n}_force" in columns and not np.any(columns[f"{n}_force"])]


def system_numbers(system) -> list[tuple[str, str]]:
    """What drove the mechanism in a co-simulation, from its system file: motor, gearbox, power stage, controller.

    A motor is a component with ``torque_constant`` and ``gear_ratio``
    parameters (the DC motor FMU's), named by the shipped data set whose
    figures it carries; the controller is the component that feeds the
    motor's voltage, named by its FMU and its numeric parameters.
    """
    from pathlib import Path

    from grubler.motors import list_motors, load_motor

    out = []
    for name, comp in system.components.items():
        p = comp.parameters
        if "torque_constant" not in p or "gear_ratio" not in p:
            continue
        figures = ("resistance", "torque_constant", "rotor_inertia")
        known = [m.name for m in map(load_motor, list_motors())
                 if all(math.isclose(getattr(m, f), float(p.get(f, math.nan)), rel_tol=1e-9) for f in figures)]
        out.append(("motor", known[0] if known else f"R {p['resistance']:.3g} Ohm, k_t "
                                                    f"{1e3 * p['torque_constant']:.3g} mN m/A"))
        out.append(("gearbox", f"{p['gear_ratio']:g}:1, efficiency {p.get('gear_efficiency', 1.0):g}"))
        limit = float(p.get("current_limit", 0.0))
        out.append(("power stage", f"{p.get('supply_voltage', math.nan):g} V, "
                                   + (f"{limit:g} A limit" if 0 < limit < math.inf else "no current limit")))
        feeder = next((c.start_element for c in system.connections if c.end == f"{name}.voltage"), None)
        if feeder is not None:
            ctrl = system.components[feeder]
            gains = [f"{k} {v:g}" for k, v in ctrl.parameters.items()
                     if isinstance(v, (int, float)) and not isinstance(v, bool)]
            # the first three (a PID's K, Ti, Td): what fits the table's line
            out.append(("controller", f"{Path(ctrl.source).stem}: {', '.join(gains[:3])}"))
    if system.step:
        out.append(("co-simulation step", f"{system.step * 1e3:.4g} ms"))
    return out


def _panels(columns, drive, model, cosim: bool) -> list[tuple[str, list[tuple[str, np.ndarray, str]], str, str]]:
    """(axis label with unit, [(legend, values, colour)], scale, note) of each quantity there is."""
    from grubler.views.plotting import turns

    unit, speed_unit, effort_unit = _drive_units(drive)
    panels = []
    target, target_unit = servo_target(columns, drive, model)
    for name in model.actuator_names if model is not None else []:
        if f"{name}_length" in columns:
            lines = [("length", columns[f"{name}_length"], BLUE)]
            if target == f"{name}_length" and "setpoint" in columns:
                lines.append(("setpoint", columns["setpoint"], ORANGE))
            panels.append((f"actuator {name} [m]", lines, "linear", ""))
    if drive and drive in columns:
        q = columns[drive]
        if unit == "rad" and turns(q) > 1.0:  # a turning crank: wrapped, so its axis reads an angle
            panels.append((f"drive {drive} [rad, wrapped to ±π]", [("", q, BLUE)], "wrapped",
                           f"{turns(q):.3g} turns"))
        else:
            panels.append((f"drive {drive} [{unit}]", [("", q, BLUE)], "linear", ""))
    if target and target in columns and "setpoint" in columns:  # a servo's key figure
        panels.append((f"tracking error [{target_unit}]", [("", columns["setpoint"] - columns[target], BLUE)],
                       "linear", "setpoint - response"))
    pressures = [(w, columns[c] / 1e5, col) for c, w, col in (("pressure_a", "cap side A", BLUE),
                                                              ("pressure_b", "rod side B", ORANGE),
                                                              ("supply_pressure", "supply", GREEN)) if c in columns]
    if pressures:
        panels.append(("cylinder pressure [bar]", pressures, "linear", ""))
    if "cylinder_force" in columns:
        panels.append(("cylinder force [N]", [("", columns["cylinder_force"], BLUE)], "linear", "pushing apart"))
    if drive and f"{drive}_d" in columns:
        panels.append((f"drive speed [{speed_unit}]", [("", columns[f"{drive}_d"], BLUE)], "linear", ""))
    if "tau_drive" in columns and np.ptp(columns["tau_drive"]) > 0.0:  # a constant one is in the table
        panels.append((f"drive torque [{effort_unit}]", [("", columns["tau_drive"], BLUE)], "linear", ""))
    if "current" in columns:
        panels.append(("motor current [A]", [("", columns["current"], BLUE)], "linear", ""))
    if "voltage" in columns:
        panels.append(("motor voltage [V]", [("", columns["voltage"], BLUE)], "linear", ""))
    if "Fx" in columns and "Fy" in columns:
        panels.append(("closing-joint force [N]", [("", np.hypot(columns["Fx"], columns["Fy"]), BLUE)], "linear", ""))
    if "E" in columns:
        lines = [(w, columns[c], col) for c, w, col in (("KE", "kinetic", ORANGE), ("PE", "potential", GREEN))
                 if c in columns]
        panels.append(("energy [J]", lines + [("total E", columns["E"], BLUE)], "linear", ""))
        if model is not None and all(f"{n}_d" in columns for n in model.coordinate_names):
            # in a co-simulation the torque is held over each communication step, which the
            # trapezoid rule over the record does not know: the remainder is the coupling's
            note = ("E - E(0) - work of the recorded torque;\nthe master held it over each step" if cosim
                    else "E - E(0) - drive work + damper losses")
            panels.append((f"{residue_name(cosim)} [J]", [("", energy_balance(columns, model), BLUE)], "linear", note))
    if "closure_error" in columns:
        panels.append((f"closure violation [{_closure_unit(model)}]",
                       [("", np.abs(columns["closure_error"]), BLUE)], "log", ""))
    return panels


def _draw_panel(ax, t, lines, scale: str) -> str:
    """One quantity against time; returns a note for the axis title ('' if none)."""
    from grubler.views.plotting import ENVELOPE_BINS, envelope, wrap_angle

    dense = len(t) > 2 * ENVELOPE_BINS
    note = ""
    for label, values, colour in lines:
        values = np.asarray(values, dtype=float)
        if scale == "log":
            keep = values > 0  # exact zeros have no logarithm: left out, and counted
            if not keep.any():
                ax.plot(t, values, color=colour, lw=1.0)
                return "exactly 0 throughout"
            ax.semilogy(t[keep], values[keep], ".", ms=1.5, color=colour)
            zeros = int((~keep).sum())
            if zeros:
                note = f"0 at {zeros} of {len(values)} samples"
            continue
        if dense:
            tb, lo, hi, mean = envelope(t, values, ENVELOPE_BINS)
            if scale == "wrapped":
                tb, mean, lo, hi = wrap_angle(tb, mean, lo, hi)
            ax.plot(tb, mean, color=colour, lw=1.0, label=label or None)
            ax.fill_between(tb, lo, hi, color=colour, alpha=0.3, lw=0)
        else:
            ax.plot(*(wrap_angle(t, values) if scale == "wrapped" else (t, values)), color=colour, lw=1.1,
                    label=label or None)
    if any(label for label, _, _ in lines):  # above the axes, in one row: never over a peak
        ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=len(lines), frameon=False,
                  borderaxespad=0.2, handlelength=1.2, columnspacing=0.8)
    return note


def _label_panel(ax, ylabel: str, note: str) -> None:
    """Every panel reads on its own: its quantity and unit, and its time axis labelled, wherever it sits."""
    ax.set_ylabel(ylabel, fontsize=9)
    ax.tick_params(labelsize=8, labelbottom=True)
    ax.grid(True, alpha=0.3)
    if note:
        ax.set_title(note, fontsize=8, loc="right", color=GREY)
    ax.set_xlabel("t [s]", fontsize=8, labelpad=1)


SUBTITLE_CHARS = 56  # of the 9-point subtitle, what the left column holds on one line


def _title(model: Mechanism | None, source: str, cosim: bool) -> tuple[str, str]:
    """The page's title and the subtitle under it, wrapped to the left column (it never runs into the plots)."""
    import textwrap

    from grubler.views.plotting import kind_words

    name = os.path.basename(source)
    what = "co-simulation record" if cosim else "simulation record"
    if model is not None:
        title, subtitle = model.name or name, f"{kind_words(model)}, {what} {name}"
    else:
        title, subtitle = name, f"{what} (no --scene: the mechanism is not drawn)"
    return title, "\n".join(textwrap.wrap(subtitle, SUBTITLE_CHARS, break_on_hyphens=False)) or subtitle


def report_figure(columns: dict[str, np.ndarray], model: Mechanism | None = None, source: str = "run.csv",
                  cosim: bool = False, system=None):
    """The report page as a matplotlib figure (A4 landscape).

    Parameters
    ----------
    columns : dict of str to ndarray
        A run's columns in simulate vocabulary (``t`` required; see
        :func:`grubler.views.runs.read_run`, which also reads cosim CSVs).
    model : Mechanism, optional
        The mechanism the run is of: its name titles the page, and it is drawn
        at four instants.  Check that it fits first (:func:`grubler.views.runs.check_fits`).
    source : str
        The CSV's path (its file name is quoted under the title).
    cosim : bool
        A co-simulation's record: the energy remainder is named a coupling residue.
    system : grubler.system.ssp.System, optional
        The co-simulated system: its motor, gearbox, power stage and controller
        head the table (:func:`system_numbers`).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import grubler
    >>> from grubler.views.runs import read_run_csv
    >>> with tempfile.TemporaryDirectory() as d:
    ...     grubler.simulate("thesis-fourbar", t_end=0.5).to_csv(pathlib.Path(d) / "run.csv")
    ...     columns = read_run_csv(pathlib.Path(d) / "run.csv")
    >>> fig = report_figure(columns, grubler.load_scene("thesis-fourbar").mechanism)   # a Figure, not shown
    >>> fig.get_size_inches().tolist()               # A4 landscape
    [11.69, 8.27]
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from grubler.views.animation import Drawer, Sketch

    from grubler.views.plotting import supply_pressures

    t = columns["t"]
    drive = model.drive if model is not None else next((c for c in ("theta2", "B1") if c in columns), None)
    supply = supply_pressures(system) if system is not None else {}
    if "pressure_a" in columns and "supply_pressure" not in columns and len(supply) == 1:
        # a pneumatic cylinder's supply is a parameter, not a record: drawn beside its chambers all the same
        columns = {**columns, "supply_pressure": np.full_like(t, next(iter(supply.values())))}
    panels = _panels(columns, drive, model, cosim)
    title, subtitle = _title(model, source, cosim)
    fig = plt.figure(figsize=PAGE, layout="constrained")
    fig.get_layout_engine().set(w_pad=0.06, h_pad=0.06, wspace=0.04, hspace=0.04)
    left, right = fig.subfigures(1, 2, width_ratios=[LEFT_SHARE, 1 - LEFT_SHARE], wspace=0.02)
    left.suptitle(title, x=0.02, ha="left", fontsize=17, fontweight="bold")
    # the table and the mechanism share the left column; without a scene the last panel takes its place
    table_fig, low_fig = left.subfigures(2, 1, height_ratios=[TABLE_SHARE, 1 - TABLE_SHARE], hspace=0.02)
    made_of = system_numbers(system) if system is not None else (
        [("motor, gearbox, controller", "give --system SSD")] if cosim else [])
    _table(table_fig, subtitle, made_of + key_numbers(columns, drive, model, cosim))
    if model is not None:
        _instants(low_fig, model, columns, Drawer, Sketch)
    elif panels:
        ylabel, lines, scale, note = panels.pop()
        ax = low_fig.add_subplot()
        _label_panel(ax, ylabel, _draw_panel(ax, t, lines, scale) or note)
        if len(t) > 1:
            ax.set_xlim(t[0], t[-1])
    ncols = 3 if len(panels) > 8 else 2
    nrows = max(1, math.ceil(len(panels) / ncols))
    gs = right.add_gridspec(nrows, ncols)
    first = None
    for k, (ylabel, lines, scale, note) in enumerate(panels):
        r, c = divmod(k, ncols)
        span = ncols - c if k == len(panels) - 1 else 1  # the last panel takes the rest of its row
        ax = right.add_subplot(gs[r, c:c + span], sharex=first)
        first = first or ax
        _label_panel(ax, ylabel, _draw_panel(ax, t, lines, scale) or note)
    if first is None:
        right.text(0.5, 0.5, "the record has no column the report plots against time", ha="center", fontsize=11,
                   color=GREY)
    elif len(t) > 1:
        first.set_xlim(t[0], t[-1])
    from grubler.views.plotting import ENVELOPE_BINS

    if len(t) > 2 * ENVELOPE_BINS:
        right.suptitle(f"dense records: line = mean, band = min to max over {(t[-1] - t[0]) / ENVELOPE_BINS * 1e3:.3g}"
                       " ms bins", fontsize=8, color=GREY, x=0.99, ha="right")
    return fig


def _table(fig, subtitle: str, rows: list[tuple[str, str]]) -> None:
    """The key numbers as a two-column table: labels left, values right-aligned."""
    ax = fig.add_subplot()
    ax.axis("off")
    ax.set_title(subtitle, fontsize=9, loc="left", color=GREY)
    n = len(rows) + 1
    step = 1.0 / max(n, 12)  # the same row height for short tables
    ax.text(0.0, 1.0, "key numbers", fontsize=10, fontweight="bold", va="top", transform=ax.transAxes)
    ax.plot([0.0, 1.0], [1.0 - 0.85 * step] * 2, color=GREY, lw=0.6, transform=ax.transAxes)
    for i, (label, value) in enumerate(rows, start=1):
        y = 1.0 - (i + 0.1) * step
        if i % 2:
            ax.add_patch(_band(ax, y, step))
        ax.text(0.01, y, label, fontsize=9, va="top", transform=ax.transAxes)
        ax.text(0.99, y, value, fontsize=9, va="top", ha="right", transform=ax.transAxes, family="DejaVu Sans Mono")


def _band(ax, y: float, step: float):
    """A light band behind every other row, so the eye follows a row across."""
    from matplotlib.patches import Rectangle

    return Rectangle((0.0, y - 0.9 * step), 1.0, step, transform=ax.transAxes, color="0.94", lw=0, zorder=0)


def _instants(fig, model: Mechanism, columns, Drawer, Sketch) -> None:
    """The mechanism at four instants spread over the run, one view for all."""
    from grubler.views.animation import _view
    from grubler.views.runs import coordinates

    t = columns["t"]
    zs = coordinates(columns, model)
    sketch = Sketch(model)
    pos = sketch.positions(zs)
    xlim, ylim = _view(sketch.drawn_points(pos).reshape(-1, 2))
    # the grid that draws the mechanism largest in the space there is: 2 x 2, or
    # one column of four for a flat one (a slider-crank), one row for a tall one
    w, h = PAGE[0] * LEFT_SHARE, PAGE[1] * (1 - TABLE_SHARE)
    xs, ys = xlim[1] - xlim[0], ylim[1] - ylim[0]
    rows, cols = max([(2, 2), (4, 1), (1, 4)], key=lambda rc: min((w / rc[1] - 0.7) / xs, (h / rc[0] - 0.6) / ys))
    axes = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False)
    for ax, i in zip(axes.flat, np.linspace(0, len(t) - 1, 4).astype(int)):
        Drawer(ax, model, xlim, ylim).draw(sketch.geometry(pos[i]))
        ax.set_title(f"t = {t[i]:.3g} s", fontsize=9, loc="left")
        ax.tick_params(labelsize=7)
        ax.xaxis.label.set_size(8)
        ax.yaxis.label.set_size(8)
        ax.label_outer()


def write_report(columns: dict[str, np.ndarray], out, model: Mechanism | None = None, source: str = "run.csv",
                 cosim: bool = False, system=None) -> list[str]:
    """Write :func:`report_figure` to each of ``out`` (a path or a list; the format follows each suffix).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import grubler
    >>> from grubler.views.runs import read_run_csv
    >>> with tempfile.TemporaryDirectory() as d:
    ...     grubler.simulate("thesis-fourbar", t_end=0.5).to_csv(pathlib.Path(d) / "run.csv")
    ...     columns = read_run_csv(pathlib.Path(d) / "run.csv")
    ...     written = write_report(columns, pathlib.Path(d) / "report.png",   # or a list: .png, .pdf, .svg ...
    ...                            model=grubler.load_scene("thesis-fourbar").mechanism, source="run.csv")
    ...     print([pathlib.Path(p).name for p in written], pathlib.Path(written[0]).stat().st_size > 0)
    ['report.png'] True
    """
    import matplotlib.pyplot as plt

    outs = [out] if isinstance(out, (str, os.PathLike)) else list(out)
    fig = report_figure(columns, model, source, cosim, system)
    for path in outs:
        fig.savefig(path, dpi=110)
    plt.close(fig)
    return [str(p) for p in outs]


# the public names (the API reference's): the rest is the package's inside
__all__ = ["write_report", "report_figure", "key_numbers", "energy_balance"]
