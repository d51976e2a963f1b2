"""A servo-driven linkage as an SSP system: trajectory, encoder, PID, DC motor with
gearbox, and the mechanism, each its own FMU.

The design is data (:class:`ServoDesign`); :func:`servo_system` turns it into a
:class:`grubler.system.ssp.System` the co-simulation runner (or any SSP tool) runs.  The
motor's rotor inertia is written into the mechanism's ``drive.inertia``
(J_rotor N²), where it belongs for a stable coupling at ordinary steps.

Signal flow::

    trajectory.position --> controller.setpoint
    mechanism.drive_angle --> encoder.position --> controller.measurement
    controller.u --> motor.voltage
    motor.shaft_torque --> mechanism.motor_torque
    mechanism.drive_speed --> motor.shaft_speed
    (with feedforward: trajectory.position/velocity/acceleration --> feedforward
     --> controller.feedforward, the computed-torque voltage)

Examples
--------
>>> s = servo_system(ServoDesign(), "dist")
>>> list(s.components)
['trajectory', 'encoder', 'controller', 'motor', 'mechanism']
>>> round(s.components["mechanism"].parameters["drive.inertia"], 6)
0.0335
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from grubler.views.plotting import closing_force_words
from grubler.system.ssp import Plot, System


def _default_trajectory() -> dict:
    # half a turn and back, with a rest at each end, endlessly
    return {"kind": "trapezoid", "distance": math.pi, "v_max": 2 * math.pi, "a_max": 20.0, "dwell": 0.5,
            "repeat": 0, "reverse": True}


def _default_pid() -> dict:
    # tuned on the thesis four-bar through 50:1 (about 2.3 N m/V at the crank):
    # K for stiffness against gravity and the coupler's inertia, Td for damping
    # beyond the back-EMF's, Ti slow enough not to overshoot
    return {"K": 300.0, "Ti": 0.2, "Td": 0.02, "N": 10.0, "Ts": 1e-3, "u_min": -48.0, "u_max": 48.0}


@dataclass
class ServoDesign:
    """What a servo-driven linkage is made of.

    Parameters
    ----------
    scene : str
        Preset name or scene TOML text of the mechanism (its drive joint is driven).
    motor : str
        Motor data set (see :func:`grubler.motors.list_motors`) or motor TOML text.
    gear_ratio, gear_efficiency : float
    supply_voltage, current_limit : float
        The motor drive's supply (V) and current limit (A).
    trajectory, pid, encoder : dict
        Parameters of the Trajectory, PID and Encoder FMUs.
    feedforward : bool
        Add the computed-torque feedforward (a ComputedTorque FMU) to the PID.
    load_joint, load_torque : str, float
        A constant load (N m, or N on a slide) on a joint of the mechanism.
    t_end, step : float
        The default experiment: run length and communication step, s.

    Examples
    --------
    >>> from grubler.system.servo import ServoDesign
    >>> d = ServoDesign()                   # the README's servo four-bar
    >>> d.scene, d.motor, d.gear_ratio, d.step
    ('thesis-fourbar', 'maxon-re40-148877', 50.0, 0.001)
    >>> ServoDesign(gear_ratio=35.0, t_end=2.0).gear_ratio
    35.0
    """

    scene: str = "thesis-fourbar"
    motor: str = "maxon-re40-148877"
    gear_ratio: float = 50.0
    gear_efficiency: float = 0.9
    supply_voltage: float = 48.0
    current_limit: float = 10.0
    trajectory: dict = field(default_factory=_default_trajectory)
    pid: dict = field(default_factory=_default_pid)
    encoder: dict = field(default_factory=lambda: {"counts_per_rev": 16384, "Ts": 1e-3})
    feedforward: bool = False
    load_joint: str | None = None
    load_torque: float = 0.0
    t_end: float = 10.0
    step: float = 1e-3


def servo_system(design: ServoDesign, fmu_dir: str | Path, name: str = "servo") -> System:
    """The SSP system of a servo-driven linkage (FMUs taken from ``fmu_dir``).

    Parameters
    ----------
    design : ServoDesign
    fmu_dir : path
        Where ``python build_fmu.py`` put the FMUs.
    name : str

    Returns
    -------
    System

    Examples
    --------
    >>> from grubler.system.servo import ServoDesign, servo_system
    >>> s = servo_system(ServoDesign(), "dist")       # names the FMUs in dist/; cosim.run(s) runs it
    >>> list(s.components), len(s.connections)
    (['trajectory', 'encoder', 'controller', 'motor', 'mechanism'], 6)
    >>> s.components["motor"].parameters["gear_ratio"]
    50.0
    """
    from grubler.motors import DCMotor, Drive, Gearbox, load_motor
    from grubler.errors import SceneError
    from grubler.fmi.build import computed_torque_fmu, scene_fmu
    from grubler.fmi.motor import motor_parameters
    from grubler.mechanism.scene import load_scene

    from grubler.fmi.build import spatial_fmu
    from grubler.fmi.spatial import closure_prefix, spatial_preset

    data = load_motor(design.motor)
    motor = DCMotor(data, Gearbox(design.gear_ratio, design.gear_efficiency),
                    Drive(design.supply_voltage, design.current_limit))
    d = Path(fmu_dir)
    spatial = spatial_preset(design.scene)  # a spatial preset (rssr, ...): its native FMU, docs/spatial.md
    if spatial is not None:
        if design.feedforward or design.load_joint:
            raise SceneError("feedforward" if design.feedforward else "load_joint",
                             f"{design.scene} is spatial: its servo has no computed-torque feedforward or load "
                             "joint yet (the spatial FMU's effort.* inputs take a load)")
        mech_fmu, scene_params = spatial_fmu(spatial, d)
        start = scene_params[f"initial.{scene_params['drive_joint']}"]
        model = spatial
    else:
        scene = load_scene(design.scene)
        model = scene.mechanism
        start = float(model.z_from_q(model.q_ref)[model.free_index(model.drive)]) if model.drive else 0.0
        mech_fmu, scene_params = scene_fmu(scene, d)
    s = System(name, description=f"{data.name} through {design.gear_ratio:g}:1 driving "
                                 f"{getattr(model, 'name', '') or 'a mechanism'} "
                                 "under PID position control", start_time=0.0, stop_time=design.t_end,
               step=design.step)
    s.add("trajectory", d / "Trajectory.fmu", **{"start": start, **design.trajectory})
    s.add("encoder", d / "Encoder.fmu", **design.encoder)
    s.add("controller", d / "PID.fmu", **design.pid)
    # the native motor FMU is made this motor through its data set's numbers
    s.add("motor", d / "DCMotor.fmu", **{**motor_parameters(data), "gear_ratio": float(design.gear_ratio),
                                         "gear_efficiency": float(design.gear_efficiency),
                                         "supply_voltage": float(design.supply_voltage),
                                         "current_limit": float(design.current_limit)
                                         if math.isfinite(design.current_limit) else 0.0})
    loads = {"load_joint": design.load_joint, "load_torque": float(design.load_torque)} if design.load_joint else {}
    # the native mechanism FMU is re-tuned into the scene through its parameters
    s.add("mechanism", mech_fmu, **{**scene_params, "drive.inertia": motor.reflected_inertia, **loads})
    s.connect("trajectory.position", "controller.setpoint")
    s.connect("mechanism.drive_angle", "encoder.position")
    s.connect("encoder.measured_position", "controller.measurement")
    s.connect("controller.u", "motor.voltage")
    s.connect("motor.shaft_torque", "mechanism.motor_torque")
    s.connect("mechanism.drive_speed", "motor.shaft_speed")
    if design.feedforward:
        # the native computed-torque FMU is made this mechanism through the same scene parameters
        ct_fmu, ct_scene = computed_torque_fmu(scene, d)
        if ct_fmu.name != "ComputedTorque.fmu" and not ct_fmu.exists():
            raise SceneError("feedforward", f"ComputedTorque.fmu serves mechanisms of the thesis four-bar's shape; "
                                            f"this scene needs {ct_fmu.name} in {d}: build it with "
                                            "grubler.controllers.native_fmu.export_computed_torque(scene, fmu_dir)")
        s.add("feedforward", ct_fmu, **ct_scene, drive_inertia=motor.reflected_inertia, gear_ratio=float(design.gear_ratio),
              efficiency=float(design.gear_efficiency), R=data.resistance, k_t=data.torque_constant,
              k_e=data.back_emf_constant, Ts=float(design.pid.get("Ts", 0.0)))
        for sig in ("position", "velocity", "acceleration"):
            s.connect(f"trajectory.{sig}", f"feedforward.{sig}")
        s.connect("feedforward.voltage", "controller.feedforward")
    # the encoder and PID sample at the start of a step: they go before the
    # mechanism and the trajectory, whose outputs are end-of-step values, so
    # that they read the crank and the setpoint at the sample instant itself
    s.order = ["encoder"] + (["feedforward"] if design.feedforward else []) + [
        "controller", "motor", "mechanism", "trajectory"]
    # what a design review asks of a servo: does it follow, by how much does it
    # miss, and what does it cost the motor; legends in words, one unit per axis
    s.plots += [
        Plot("crank angle [rad]", ["trajectory.position", "mechanism.drive_angle", "encoder.measured_position"],
             {"trajectory.position": "crank angle, setpoint", "mechanism.drive_angle": "crank angle, response",
              "encoder.measured_position": "crank angle, encoder"}),
        Plot("tracking error [rad]", ["trajectory.position", "mechanism.drive_angle"],
             {"difference": "setpoint - response"}, difference=True),
        Plot("motor current [A]", ["motor.current"], {"motor.current": "winding current"}),
        Plot("motor voltage [V]", ["motor.voltage", "motor.terminal_voltage"],
             {"motor.voltage": "commanded", "motor.terminal_voltage": "applied"}),
        Plot("torque at the crank [N m]", ["motor.shaft_torque"], {"motor.shaft_torque": "gearbox output torque"}),
    ]
    if spatial is not None and spatial.closures:  # the first closure's force, in its frame on the target
        pre = f"mechanism.{closure_prefix(len(spatial.closures), 0)}"
        s.plots.append(Plot("force at the closing joint [N]", [f"{pre}.F{c}" for c in "xyz"],
                            {f"{pre}.F{c}": f"closing joint, {c} (its frame)" for c in "xyz"}))
    elif spatial is None and model.closures:  # an open chain (a pendulum driven at its first joint) has none
        s.plots.append(Plot("force at the closing joint [N]", ["mechanism.Fx", "mechanism.Fy"],
                            {"mechanism.Fx": f"{closing_force_words(model)}, x",
                             "mechanism.Fy": f"{closing_force_words(model)}, y"}))
    return s


__all__ = ["ServoDesign", "servo_system"]
