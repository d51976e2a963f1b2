"""The drives the page runs on a scene: the DC motor's servo on a revolute drive, the valve-commanded cylinder
on a cylinder's, and sizing for either.

Examples
--------
>>> servo_defaults()["motor"]
'maxon-re40-148877'
"""

from __future__ import annotations

import math

import numpy as np

from grubler.errors import GrublerError, InputError, SceneError
from grubler.limits import brief, did_you_mean
from grubler.mechanism.assembly import assemble
from grubler.mechanism.scene import scene_from_dict
from grubler.app.runs import _f32, drive_frames
from grubler.app.scene_form import scene_toml

SERVO_SIGNALS = ["trajectory.position", "mechanism.drive_angle", "motor.current", "motor.voltage",
                 "motor.terminal_voltage"]


def servo_defaults() -> dict:
    """What the servo form starts from: the data sets, and the servo four-bar's design (``ServoDesign()``)."""
    from grubler.motors import list_motors
    from grubler.system.servo import ServoDesign

    d = ServoDesign()
    return {"motors": list_motors(), "motor": d.motor, "gear_ratio": d.gear_ratio, "supply_voltage": d.supply_voltage,
            "current_limit": d.current_limit, "K": d.pid["K"], "Ti": d.pid["Ti"], "Td": d.pid["Td"],
            "kind": d.trajectory["kind"], "distance": d.trajectory["distance"], "v_max": d.trajectory["v_max"],
            "a_max": d.trajectory["a_max"], "dwell": d.trajectory["dwell"], "t_end": d.t_end, "step": d.step}


def _servo_design(data: dict, settings: dict):
    """A :class:`grubler.system.servo.ServoDesign` of the scene from the form's settings, each number checked."""
    from grubler.limits import number
    from grubler.motors import list_motors
    from grubler.system.servo import ServoDesign

    if not isinstance(settings, dict):
        raise InputError("servo", "missing: the page sends the servo settings as a JSON object")
    scene = scene_from_dict(data)
    if scene.mechanism.actuators:  # a DC motor on the crank of a boom its cylinder lifts is not its drive
        m = scene.mechanism
        raise SceneError("servo", f"{m.name or 'the scene'} is driven by its cylinder {m.actuator_names[0]}, not "
                                  f"a motor on {m.drive or 'a joint'}: its servo is the cylinder's")
    if scene.mechanism.drive is None:
        raise SceneError("drive.joint", "the servo drives the scene's drive joint: name one ([drive] joint)")
    base = ServoDesign()
    pos = {"low": 0.0, "low_open": True}

    def get(key, **bounds):
        v = settings.get(key)
        return number(base_values[key] if v in (None, "") else v, f"servo.{key}", **bounds)

    base_values = servo_defaults()
    motor = settings.get("motor") or base.motor
    if motor not in list_motors():
        raise InputError("servo.motor", f"no such data set: {brief(motor)}{did_you_mean(motor, list_motors())}")
    kind = settings.get("kind") or "trapezoid"
    if kind not in ("trapezoid", "scurve"):
        raise InputError("servo.kind", f"must be 'trapezoid' or 'scurve', got {brief(kind)}")
    trajectory = {**base.trajectory, "kind": kind, "distance": get("distance"), "v_max": get("v_max", **pos),
                  "a_max": get("a_max", **pos), "dwell": get("dwell", low=0.0)}
    pid = {**base.pid, "K": get("K", low=0.0), "Ti": get("Ti", **pos), "Td": get("Td", low=0.0)}
    supply = get("supply_voltage", **pos)
    pid["u_min"], pid["u_max"] = -supply, supply
    return ServoDesign(scene=scene_toml(data), motor=motor, gear_ratio=get("gear_ratio", **pos),
                       supply_voltage=supply, current_limit=get("current_limit", **pos),
                       trajectory=trajectory, pid=pid, t_end=get("t_end", **pos), step=get("step", **pos))


def _column(name: str, words: str, unit: str, values) -> dict:
    """A servo graph's column: its words and unit (a length or an angle in SI, which the page shows in the
    units chosen; a pressure in bar, a force in kN, as a cylinder's datasheet gives them)."""
    return {"name": name, "words": words, "unit": unit, "label": f"{words} ({unit})", "f32": _f32(values)}


def check_fmu_folder(d, names=("Mechanism", "DCMotor", "PID", "Encoder", "Trajectory")) -> None:
    """The FMUs the servo runs are in ``d`` (the app's ``dist/``, where ``python3 build_fmu.py`` puts them)."""
    from pathlib import Path

    d = Path(d)
    missing = [n for n in names if not (d / f"{n}.fmu").is_file()]
    if missing:
        raise InputError("servo", f"no {', '.join(m + '.fmu' for m in missing)} in {d}: build the FMUs there first "
                                  "(python3 build_fmu.py, in the folder the app was started in)")


def run_servo(data: dict, settings: dict, fmu_dir, cancel=None, unpacked=None, build_dir=None,
              trace: str | None = None) -> dict:
    """Co-simulate the servo drive of the scene (``grubler cosim`` of :func:`grubler.system.servo.servo_system`).

    Returns the tracking error, the current and the voltages over time (every
    10th step), and the drive's and the motor's limits to hold them against.
    A scene driven by a cylinder gets the cylinder's servo instead
    (:func:`run_cylinder_servo`; its mechanism FMU is built in ``build_dir``).  Either comes with its
    frames (:func:`grubler.app.runs.drive_frames`, ``trace`` the traced point) to play on the drawing.
    """
    from grubler.motors import load_motor
    from grubler.system import cosim
    from grubler.system.servo import servo_system

    if scene_from_dict(data).mechanism.actuators:
        return run_cylinder_servo(data, settings, fmu_dir, build_dir, cancel, unpacked, trace)
    design = _servo_design(data, settings)
    check_fmu_folder(fmu_dir)
    system = servo_system(design, fmu_dir, name="app-servo")
    every = max(1, round(design.t_end / design.step / 2000))  # some 2000 rows: a graph's worth
    res = cosim.run(system, t_end=design.t_end, step=design.step, record=SERVO_SIGNALS, record_every=every,
                    cancel=cancel, unpacked=unpacked)
    error = res["trajectory.position"] - res["mechanism.drive_angle"]
    motor = load_motor(design.motor)
    current, volts = res["motor.current"], res["motor.terminal_voltage"]
    limits = {"current_limit": design.current_limit, "supply_voltage": design.supply_voltage,
              "nominal_current": getattr(motor, "nominal_current", None)}
    return {"t": res.t.tolist(), "wall_time": res.wall_time,
            **drive_frames(data, res.t, res["mechanism.drive_angle"], trace),
            # angles in SI, as every column the page gets: it shows them in the units chosen (static/units.js)
            "columns": [_column("error", "tracking error, setpoint - response", "rad", error),
                        _column("setpoint", "crank angle, setpoint", "rad", res["trajectory.position"]),
                        _column("response", "crank angle, response", "rad", res["mechanism.drive_angle"]),
                        _column("current", "motor current", "A", current),
                        _column("voltage", "motor voltage, applied", "V", volts),
                        _column("command", "motor voltage, commanded", "V", res["motor.voltage"])],
            "limits": {k: v for k, v in limits.items() if v is not None and math.isfinite(v)},
            "summary": f"{design.t_end:g} s at {design.step:g} s steps in {res.wall_time:.2f} s: tracking error "
                       f"up to {np.degrees(np.max(np.abs(error))):.3g} deg, current up to {np.max(np.abs(current)):.3g} A "
                       f"(limit {design.current_limit:g} A), voltage up to {np.max(np.abs(volts)):.3g} V "
                       f"(supply {design.supply_voltage:g} V)"}


def _move_cycle(model, settings: dict):
    """The servo form's move of the drive joint, there and back, as the sizing studies' duty cycle."""
    from grubler.controllers.trajectory import Trajectory
    from grubler.limits import number
    from grubler.studies.sizing import DutyCycle

    if not isinstance(settings, dict):
        raise InputError("servo", "missing: the page sends the servo settings as a JSON object")
    if model.drive is None:
        raise SceneError("drive.joint", "the move is of the scene's drive joint: name one ([drive] joint)")
    base, pos = servo_defaults(), {"low": 0.0, "low_open": True}

    def get(key, **bounds):
        v = settings.get(key)
        return number(base[key] if v in (None, "") else v, f"servo.{key}", **bounds)

    kind = settings.get("kind") or "trapezoid"
    if kind not in ("trapezoid", "scurve"):
        raise InputError("servo.kind", f"must be 'trapezoid' or 'scurve', got {brief(kind)}")
    distance, dwell = get("distance"), get("dwell", low=0.0)
    traj = Trajectory(kind, distance=distance, v_max=get("v_max", **pos), a_max=get("a_max", **pos),
                      dwell=dwell, repeat=2, reverse=True)
    start = float(model.z_from_q(model.q_ref)[model.free_index(model.drive)])
    return DutyCycle.from_trajectory(traj, (traj.move_time + dwell) * 2, start=start,
                                     name=f"{kind} move of {distance:g} rad and back")


# -- a cylinder's servo: the valve commanded by a PID on the actuator's length, as examples/cylinder_systems.py
def cylinder_servo_defaults(data: dict) -> dict | None:
    """What the cylinder servo's form starts from: the preset's design (``PRESET_DESIGNS``), or the defaults.

    None for a scene without an actuator.  Lengths in m, the move's limits in
    m/s and m/s2, the gain in valve opening per metre of error.
    """
    from grubler.motors.hydraulic import DEFAULT as HYDRAULIC
    from grubler.motors.pneumatic import DEFAULT as PNEUMATIC
    from grubler.system.cylinder_servo import PRESET_DESIGNS, CylinderServoDesign

    scene = scene_from_dict(data)
    if not scene.mechanism.actuators:
        return None
    d = PRESET_DESIGNS.get(scene.name) or CylinderServoDesign(scene.name or "scene")
    cyl = {"hydraulic": HYDRAULIC, "pneumatic": PNEUMATIC}[d.cylinder]
    return {**_sizing_move(scene.mechanism, d), "actuator": scene.mechanism.actuator_names[0], "cylinder": d.cylinder,
            "bore": d.constants.get("bore", cyl.bore), "rod": d.constants.get("rod", cyl.rod),
            "stroke": d.constants.get("stroke", cyl.stroke), "start_position": d.start_position, "move": d.move,
            "speed": d.speed, "acceleration": d.acceleration, "delay": d.delay, "K": d.pid.get("K", 0.0),
            "Ti": d.pid.get("Ti", 0.0), "Td": d.pid.get("Td", 0.0), "t_end": d.t_end, "step": d.step}


def _sizing_move(model, design) -> dict:
    """The design's move of the actuator's length as the drive joint's (what sizing takes), so that Size sizes
    the cylinder for the move Run servo makes: the drive angle at which the length has moved that far (secant
    steps from the lever dL/dx at the start), the limits over that lever.  Where the drive joint cannot go
    that far (a toggle or a dead point on the way), the largest half, quarter or eighth of the lever's
    estimate that it can ({} where not even that)."""
    from grubler.mechanism.simulate import actuator_lines

    if model.drive is None:
        return {}
    i, a = model.free_index(model.drive), model.actuator_names.index(design.actuator or model.actuator_names[0])
    z0 = assemble(model, model.z_from_q(model.q_ref))[0]

    def length(dx: float) -> float:  # the actuator's length with the drive joint moved dx from the start
        z = z0.copy()
        z[i] += dx
        z = assemble(model, z)[0]
        return float(actuator_lines(model, np.hstack([z, np.zeros_like(z)])[None, :])[0, a, 0])

    def reachable(dx: float) -> bool:  # the loop closes all the way there
        try:
            return all(math.isfinite(length(dx * k / 20)) for k in range(1, 21))
        except (GrublerError, ValueError):
            return False

    try:
        l0, h = length(0.0), 1e-6
        lever = (length(h) - l0) / h
    except (GrublerError, ValueError):
        return {}
    if not (math.isfinite(lever) and abs(lever) > 1e-9):
        return {}
    x0, f0, x1 = 0.0, -design.move, design.move / lever
    try:
        for _ in range(12):
            f1 = length(x1) - l0 - design.move
            if abs(f1) < 1e-9 or f1 == f0:
                break
            x0, f0, x1 = x1, f1, x1 - f1 * (x1 - x0) / (f1 - f0)
        found = abs(length(x1) - l0 - design.move) < 1e-6
    except (GrublerError, ValueError, ZeroDivisionError):
        found = False
    guess = design.move / lever
    distance = next((d for d in ([x1] if found else []) + [guess * f for f in (0.5, 0.25, 0.125)]
                     if math.isfinite(d) and reachable(d)), None)
    if distance is None:
        return {}
    g = lambda v: float(f"{v:.4g}")  # noqa: E731 (as a person would type it)
    return {"distance": g(distance), "v_max": g(design.speed / abs(lever)),
            "a_max": g(design.acceleration / abs(lever)), "dwell": g(design.delay), "kind": "trapezoid"}


def _cylinder_design(data: dict, settings: dict):
    """A :class:`grubler.system.cylinder_servo.CylinderServoDesign` of the scene from the form, each number checked."""
    from grubler.limits import number
    from grubler.system.cylinder_servo import CYLINDERS, PRESET_DESIGNS, CylinderServoDesign

    if not isinstance(settings, dict):
        raise InputError("servo", "missing: the page sends the servo settings as a JSON object")
    base = cylinder_servo_defaults(data)
    pos = {"low": 0.0, "low_open": True}

    def get(key, **bounds):
        v = settings.get(key)
        return number(base[key] if v in (None, "") else v, f"servo.{key}", **bounds)

    kind = settings.get("cylinder") or base["cylinder"]
    if kind not in CYLINDERS:
        raise InputError("servo.cylinder", f"must be one of {', '.join(CYLINDERS)}, got {brief(kind)}")
    preset = PRESET_DESIGNS.get(data.get("name"))
    # the preset's other constants (its seals' smoothing) where its cylinder is the one asked for
    constants = dict(preset.constants) if preset and preset.cylinder == kind else {}
    constants.update(bore=get("bore", **pos), rod=get("rod", **pos), stroke=get("stroke", **pos))
    pid = {**(preset.pid if preset else CylinderServoDesign("").pid), "K": get("K", low=0.0), "Ti": get("Ti", low=0.0),
           "Td": get("Td", low=0.0)}
    return CylinderServoDesign(scene_toml(data), actuator=base["actuator"], cylinder=kind, constants=constants,
                               start_position=get("start_position", low=0.0), move=get("move"),
                               speed=get("speed", **pos), acceleration=get("acceleration", **pos),
                               delay=get("delay", low=0.0), pid=pid, t_end=get("t_end", **pos), step=get("step", **pos))


def run_cylinder_servo(data: dict, settings: dict, fmu_dir, build_dir, cancel=None, unpacked=None,
                       trace: str | None = None) -> dict:
    """Co-simulate the scene's cylinder under position control (``grubler cosim`` of
    :func:`grubler.system.cylinder_servo.cylinder_servo_system`): the actuator's length against its setpoint,
    the chambers' pressures against the supply, the force.

    The mechanism FMU of an actuator's scene is compiled (5 to 8 s) into
    ``build_dir``/<the scene's hash>: a re-run of the same scene (a gain tuned) takes it from there.
    """
    import hashlib
    from pathlib import Path

    from grubler.system import cosim
    from grubler.system.cylinder_servo import FMU_OF, cylinder_servo_system

    design = _cylinder_design(data, settings)
    check_fmu_folder(fmu_dir, ("PID", "Trajectory", FMU_OF[design.cylinder].removesuffix(".fmu")))
    if build_dir is None:
        raise InputError("servo", "the cylinder's servo builds its mechanism FMU: give it a folder (build_dir)")
    folder = Path(build_dir) / hashlib.sha256(design.scene.encode()).hexdigest()[:16]
    folder.mkdir(parents=True, exist_ok=True)
    system = cylinder_servo_system(design, fmu_dir, name="app_cylinder_servo", build_dir=folder, reuse=True)
    act = design.actuator
    hydraulic = design.cylinder == "hydraulic"
    signals = ["trajectory.position", f"mechanism.{act}_length", "controller.u", "cylinder.pressure_a",
               "cylinder.pressure_b", "cylinder.force", "mechanism.drive_angle"]
    every = max(1, round(design.t_end / design.step / 2000))  # some 2000 rows: a graph's worth
    res = cosim.run(system, t_end=design.t_end, step=design.step, record=signals, record_every=every,
                    cancel=cancel, unpacked=unpacked)
    setpoint, length = res["trajectory.position"], res[f"mechanism.{act}_length"]
    error = setpoint - length
    pa, pb, force = res["cylinder.pressure_a"], res["cylinder.pressure_b"], res["cylinder.force"]
    # the pressure the circuit is rated for: a hydraulic supply's relief valve, a pneumatic one's supply
    supply = float(system.components["cylinder"].parameters.get("relief_pressure" if hydraulic else "supply_pressure",
                                                                math.nan))
    mm, bar = 1e3, 1e-5
    return {"t": res.t.tolist(), "wall_time": res.wall_time, "kind": "cylinder",
            **drive_frames(data, res.t, res["mechanism.drive_angle"], trace),
            "columns": [_column("error", "tracking error, setpoint - response", "m", error),
                        _column("setpoint", f"{act} length, setpoint", "m", setpoint),
                        _column("response", f"{act} length, response", "m", length),
                        _column("pressure_a", "cap side A pressure", "bar", pa * bar),
                        _column("pressure_b", "rod side B pressure", "bar", pb * bar),
                        _column("force", "cylinder force, pushing apart", "kN", force * 1e-3),
                        _column("command", "valve command", "1", res["controller.u"])],
            "limits": {"supply_pressure": supply * bar} if math.isfinite(supply) else {},
            "summary": f"{design.t_end:g} s at {design.step:g} s steps in {res.wall_time:.2f} s: a "
                       f"{design.constants['bore'] * mm:g}/{design.constants['rod'] * mm:g} mm {design.cylinder} "
                       f"cylinder moves {act} {design.move * mm:g} mm; tracking error up to "
                       f"{np.max(np.abs(error)) * mm:.3g} mm ({abs(error[-1]) * mm:.3g} mm at the end), pressure up "
                       f"to {max(np.max(pa), np.max(pb)) * bar:.4g} bar"
                       + (f" (supply {supply * bar:.4g} bar)" if math.isfinite(supply) else "")
                       + f", force {np.min(force) * 1e-3:.4g} to {np.max(force) * 1e-3:.4g} kN"
                       # why a page in m still reads mm here: a cylinder is chosen by its bore in mm
                       + "; bore/rod in mm whatever the page's unit, as cylinder catalogs (ISO 3320) list them"}


def run_sizing(data: dict, settings: dict) -> dict:
    """Which motor and gear ratio fit the servo's move (``grubler size --move``), ranked: the study's table.

    A scene driven by a cylinder gets the cylinder's study instead, bore x supply
    pressure over the CLI's candidates (``grubler size --cylinder ACTUATOR``).
    """
    from grubler.motors import list_motors, load_motor
    from grubler.studies.sizing import Control, size

    model = scene_from_dict(data).mechanism
    if model.actuators:
        return _cylinder_sizing(model, _move_cycle(model, settings))
    design = _servo_design(data, settings)
    cycle = _move_cycle(model, settings)
    study = size(model, cycle, [load_motor(n) for n in list_motors()], [5, 10, 20, 35, 50, 75, 100, 150],
                 supply_voltage=design.supply_voltage, current_limit=design.current_limit, control=Control.servo())
    rows = []
    for a in study.ranked + study.rejected:
        r = a.summary()
        rows.append({"motor": a.candidate.motor.name, "ratio": a.candidate.ratio, "fits": bool(a.feasible),
                     "margin": round(float(a.min_margin), 3), "binding": a.binding,
                     "peak_current": round(r["peak_current"], 3), "peak_voltage": round(r["peak_voltage"], 2),
                     "rpm": round(r["peak_motor_speed"]), "why_not": r["why_not"]})  # the summary's rpm already
    return {"cycle": cycle.name, "kind": "motor", "rows": rows}


def _cylinder_sizing(model, cycle) -> dict:
    """``grubler size --cylinder`` of the scene's first actuator, with the CLI's candidates and constants."""
    from grubler.studies.cylinder_sizing import CANDIDATE_DEFAULTS as CYLINDER_OPTIONS, size_cylinder
    from grubler.studies.sweep import parse_values

    bores = parse_values(CYLINDER_OPTIONS["bores"], "--bores", "mm")
    pressures = parse_values(CYLINDER_OPTIONS["pressures"], "--pressures", "bar")
    name = model.actuator_names[0]
    study = size_cylinder(model, name, cycle, [b * 1e-3 for b in bores], [p * 1e5 for p in pressures],
                          rod_ratio=CYLINDER_OPTIONS["rod_ratio"], constants={"stroke": CYLINDER_OPTIONS["stroke"]})
    rows = []
    for a in study.ranked + study.rejected:
        r = a.summary()
        rows.append({"cylinder": a.candidate.label, "bore": round(r["bore"], 1), "rod": round(r["rod"], 1),
                     "pressure": round(r["supply_pressure"], 1), "fits": bool(a.feasible),
                     "margin": round(float(a.min_margin), 3), "binding": a.binding,
                     "power": round(r["installed_power"], 3), "why_not": r["why_not"]})
    d = study.demand
    return {"cycle": f"{cycle.name}, by actuator {name}: force {d.force.min() / 1e3:.4g} to "
                     f"{d.force.max() / 1e3:.4g} kN, speed up to {abs(d.rate).max():.4g} m/s",
            "kind": "cylinder", "rows": rows}


__all__ = ["servo_defaults", "check_fmu_folder", "run_servo", "cylinder_servo_defaults", "run_cylinder_servo", "run_sizing"]
