"""A simulation run as the page plays and plots it: its frames, its columns in words, its CSV.

Examples
--------
>>> describe("theta3_d")
'angular rate of link 3 (theta3_d), rad/s'
"""

from __future__ import annotations


import numpy as np

from grubler.errors import Cancelled
from grubler.mechanism.kinematics import link_points
from grubler.mechanism.scene import scene_from_dict
from grubler.mechanism.simulate import force_kinds, simulate, unit_of
from grubler.quantities import mechanism_output
from grubler.views.animation import Sketch, trace_point
from grubler.app.drawing import _frame, default_trace

MAX_FRAMES = 400  # frames sent to the page: 40 per second of a 10 s run (the graphs get every output row)


def describe(column: str, actuators=(), forces=(), unit: str | None = None) -> str:
    """A run column in words with its unit: 'theta3_d' -> 'angular rate of link 3 (theta3_d), rad/s'.

    ``forces``: the force elements as (name, kind) pairs (grubler.mechanism.simulate.force_kinds)."""
    q = mechanism_output(column, actuators, forces)
    words = q.label if q else column
    u = unit_of(column) if unit is None else unit
    return f"{words} ({column})" + (f", {u}" if u else "")


def plotted(column: str, values, actuators=(), forces=(), unit: str | None = None) -> dict:
    """A column as the graphs get it: its SI values and unit, and its words; the page shows it in the units
    its user chose (static/units.js: an angle in deg or rad, a length in m or mm), the label saying so.

    ``unit``: the column's unit where the scene decides it (:func:`joint_units`), else the column's own."""
    u = unit or unit_of(column)
    return {"name": column, "words": describe(column, actuators, forces, unit=""),
            "label": describe(column, actuators, forces, unit=u), "unit": u, "f32": _f32(values)}


def run_simulation(data: dict, t_end: float | None, dt_out: float | None, torque: float | None, cancel=None,
                   trace: str | None = None, actuator_force: float | None = None):
    """Simulate the scene (the CLI's ``simulate``) and what the page plays and plots of it.

    Returns
    -------
    result : grubler.Result
        Kept by the session for the CSV export.
    view : dict
        Times, frames (at most :data:`MAX_FRAMES`, evenly spread), the traced
        point's path, every output column with its description, and the
        run's warnings (an actuator given no force holds nothing).
    ``actuator_force`` (N, pushing its points apart) is the scene's first
    actuator's, as ``grubler simulate --actuator-force NAME=N`` gives it.
    """
    from grubler.limits import number

    scene = scene_from_dict(data)
    kw = {}
    if t_end not in (None, ""):
        kw["t_end"] = number(t_end, "t_end", low=0.0, low_open=True, unit="s")
    if dt_out not in (None, ""):
        kw["dt_out"] = number(dt_out, "dt_out", low=0.0, low_open=True, unit="s")
    if torque not in (None, ""):
        kw["torque"] = number(torque, "torque")
    if actuator_force not in (None, "") and scene.mechanism.actuator_names:
        kw["actuator_forces"] = {scene.mechanism.actuator_names[0]: number(actuator_force, "actuator_force",
                                                                           unit="N")}
    point = trace_point(trace or default_trace(scene.mechanism), scene.mechanism)
    res = simulate(scene, cancel=cancel, **kw)
    _check_cancel(cancel, res.t[-1])
    rows = np.unique(np.linspace(0, len(res.t) - 1, min(len(res.t), MAX_FRAMES)).round().astype(int))
    sketch = Sketch(scene.mechanism, point)
    pos = sketch.positions(res.z[rows])
    frames = [_frame(sketch.geometry(p), sketch) for p in pos]
    k, local = point
    path = link_points(scene.mechanism, res.z, [k], [local])[:, 0, :]
    columns = res.columns
    res.compute(["state", "dynamics", "energy"])  # every column in one kernel pass, then one more look at the flag
    _check_cancel(cancel, res.t[-1])
    view = {"t": res.t.tolist(), "frame_t": res.t[rows].tolist(), "frames": frames,
            "path": np.round(path, 6).tolist(),
            "columns": [plotted(c, res[c], scene.mechanism.actuator_names, force_kinds(scene.mechanism),
                                joint_units(scene.mechanism).get(c)) for c in columns] + [balance_column(res, columns)],
            # the force elements, whose columns the page's graphs start with (their force and stored energy)
            "elements": [{"name": n, "kind": k} for n, k in force_kinds(scene.mechanism)],
            "summary": _summary(scene, res), "warnings": list(res.warnings)}
    return res, view


def joint_units(model) -> dict:
    """A joint spring's columns whose unit its joint decides ('N m or N'), each in its joint's: a revolute's
    effort in N m, a slide's in N (its position and speed: rad and rad/s, or m and m/s)."""
    from grubler.quantities import FORCE_OUTPUTS

    out = {}
    for e in model.forces:
        if e.table == "joint_spring":
            slide = e.joint.startswith("B")
            for q, _ in FORCE_OUTPUTS["joint_spring"]:
                if " or " in q.unit:
                    out[f"{e.name}_{q.name}"] = q.unit.split(" or ")[slide]
    return out


BALANCE = "energy_balance"  # the graphs' column of grubler report's energy balance


def balance_column(res, columns) -> dict:
    """The run's energy balance as ``grubler report`` draws it (:func:`grubler.views.report.energy_balance`):
    E - E(0) less the work of the drive, the actuators and the loads, plus what the dampers and the force
    elements' dampers and friction took, J.  Zero but for integration error: a force left out shows."""
    from grubler.views.report import energy_balance, residue_name

    values = energy_balance({c: res[c] for c in columns}, res.model)
    return {"name": BALANCE, "unit": "J", "f32": _f32(values),
            "words": f"{residue_name(False)}: E - E(0) - work in + dissipated ({BALANCE})",
            "label": f"{residue_name(False)}: E - E(0) - work in + dissipated ({BALANCE}), J"}


def drive_frames(data: dict, t, drive, trace: str | None = None) -> dict:
    """The frames of a run known by its drive joint's coordinate alone (a servo's co-simulation records it),
    for the page to play as it plays a simulation: at most :data:`MAX_FRAMES` rows, evenly spread, each the
    mechanism assembled with its drive joint there, from the row before (so it stays on the sketch's branch),
    and the traced point's path.  Where the loop stops closing the frames stop; none for a scene without a
    drive joint or of more than one degree of freedom."""
    from grubler.errors import AssemblyError
    from grubler.mechanism.assembly import assemble

    scene = scene_from_dict(data)
    m = scene.mechanism
    t, drive = np.asarray(t, dtype=float), np.asarray(drive, dtype=float)
    if m.drive is None or len(m.free_names) - len(m.closures) * 2 > 1 or not len(t):
        return {"frame_t": [], "frames": [], "path": []}
    point = trace_point(trace or default_trace(m), m)
    i = m.free_index(m.drive)
    rows = np.unique(np.linspace(0, len(t) - 1, min(len(t), MAX_FRAMES)).round().astype(int))
    z = assemble(m, m.z_from_q(m.q_ref), scene.initial_rates)[0]
    zs = []
    for r in rows:
        guess = z.copy()
        guess[i] = drive[r]
        try:
            z = assemble(m, guess)[0]
        except AssemblyError:
            break
        zs.append(z)
    if not zs:
        return {"frame_t": [], "frames": [], "path": []}
    zs = np.array(zs)
    sketch = Sketch(m, point)
    k, local = point
    return {"frame_t": t[rows[:len(zs)]].tolist(),
            "frames": [_frame(sketch.geometry(p), sketch) for p in sketch.positions(zs)],
            "path": np.round(link_points(m, zs, [k], [local])[:, 0, :], 6).tolist()}


def _check_cancel(cancel, t: float) -> None:
    """The run's outputs take a while too (a kernel pass over every row): a cancel then is honoured as well."""
    if cancel is not None and cancel.is_set():
        raise Cancelled("run", f"cancelled at t = {t:.6g} s (the end: its outputs were being computed)")


def _f32(values) -> str:
    """A column for the graphs: little-endian float32, base64 (a fifth of its JSON; the CSV keeps every digit)."""
    import base64

    return base64.b64encode(np.asarray(values, dtype="<f4").tobytes()).decode()


def _summary(scene, res) -> str:
    e = res["E"]
    text = (f"{scene.name or 'scene'}: {len(res.t)} points to t = {res.t[-1]:g} s, method {res.method}, "
            f"{res.stats['steps']} steps; max closure error {np.max(res['closure_error']):.3g}; "
            f"energy {e[0]:.6g} J -> {e[-1]:.6g} J")
    count = res.stats.get("passage_count", 0)
    if count:
        text += f"; passed {count} change point{'s' if count > 1 else ''}"
    return text


def result_csv(res, path) -> None:
    """The run as ``grubler simulate --csv`` writes it."""
    res.to_csv(path, ["state", "dynamics", "energy"])


__all__ = ["describe", "plotted", "run_simulation", "result_csv"]
