"""A cylinder-driven linkage as an SSP system: setpoint, PID on the valve, cylinder, mechanism.

The design is data (:class:`CylinderServoDesign`); :func:`cylinder_servo_system`
turns it into a :class:`grubler.system.ssp.System` that ``grubler cosim`` (or
any SSP tool) runs.  A position controller holds the actuator's length: the
scene's actuator (an ``[[actuator]]`` of its TOML) joins the mechanism FMU to a
HydraulicCylinder or PneumaticCylinder FMU.

Signal flow::

    trajectory.position --> controller.setpoint
    mechanism.<actuator>_length --> controller.measurement, cylinder.length
    mechanism.<actuator>_rate --> cylinder.rate
    controller.u --> cylinder.command           (the valve, in [-1, 1])
    cylinder.force --> mechanism.<actuator>_force

The cylinder's ``retracted_length`` is set so that its piston starts
``start_position`` from the cap end at the mechanism's assembled start.

Examples
--------
>>> from grubler.mechanism.scene import load_scene
>>> boom = load_scene("luffing-boom")
>>> round(start_length(boom, "lift"), 4), round(holding_force(boom, "lift"))
(1.226, 10816)
>>> sorted(PRESET_DESIGNS), PRESET_DESIGNS["luffing-boom"].cylinder    # the shipped presets' designs
(['cylinder-slider-crank', 'luffing-boom', 'toggle-clamp'], 'hydraulic')
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from grubler.errors import SceneError
from grubler.system.ssp import Plot, System

CYLINDERS = ("hydraulic", "pneumatic")
FMU_OF = {"hydraulic": "HydraulicCylinder.fmu", "pneumatic": "PneumaticCylinder.fmu"}


@dataclass
class CylinderServoDesign:
    """What a cylinder-driven linkage under position control is made of.

    Parameters
    ----------
    scene : str
        Preset name or scene TOML text of a mechanism with an actuator.
    actuator : str, optional
        The actuator the cylinder is (default: the scene's first).
    cylinder : {'hydraulic', 'pneumatic'}
    constants : dict
        The cylinder's constants where they differ from the FMU's defaults
        (:data:`grubler.motors.hydraulic.DEFAULT`, :data:`grubler.motors.pneumatic.DEFAULT`).
    start_position : float
        The piston's distance from the cap end at the start, m.
    move : float
        How far the setpoint moves the actuator's length, m (negative: retract).
    speed, acceleration : float
        The move's speed and acceleration limits, m/s and m/s2.
    delay : float
        Rest before the move, s.
    setpoint : dict, optional
        Trajectory FMU parameters that replace the trapezoid move.
    trajectory_fmu : str
        The setpoint's FMU in the FMU folder: ``Trajectory.fmu``, or one whose
        table of lengths over time is built in
        (:func:`grubler.controllers.native_fmu.export_table`).
    pid : dict
        Parameters of the PID FMU; its output is the valve command.
    load_torque : float
        A constant effort on the scene's load joint (N m, or N on a slide).
    t_end, step : float
        The default experiment: run length and communication step, s.

    Examples
    --------
    >>> design = CylinderServoDesign("luffing-boom", move=0.05, constants={"bore": 0.063})
    >>> design.actuator, design.cylinder, design.pid["K"]     # the scene's first actuator, by default
    (None, 'hydraulic', 20.0)
    """

    scene: str
    actuator: str | None = None
    cylinder: str = "hydraulic"
    constants: dict = field(default_factory=dict)
    start_position: float = 0.05
    move: float = 0.1
    speed: float = 0.1
    acceleration: float = 0.5
    delay: float = 0.5
    setpoint: dict | None = None
    trajectory_fmu: str = "Trajectory.fmu"
    pid: dict = field(default_factory=lambda: {"K": 20.0, "Ti": 0.0, "Td": 0.0, "N": 10.0, "Ts": 1e-3,
                                               "u_min": -1.0, "u_max": 1.0})
    load_torque: float = 0.0
    t_end: float = 5.0
    step: float = 1e-3


# the cylinder presets under position control, as examples/cylinder_systems.py writes them (and the app's
# Run servo starts from): what each one's cylinder and move are
PRESET_DESIGNS = {
    # a four-bar boom, 200 kg past the head, lifted 0.1 m of cylinder stroke by a 50/28 mm hydraulic cylinder
    "luffing-boom": CylinderServoDesign(
        "luffing-boom", cylinder="hydraulic", move=0.1, speed=0.1, acceleration=0.5, t_end=4.0,
        pid={"K": 20.0, "Ts": 1e-3, "u_min": -1.0, "u_max": 1.0}),
    # the slider-crank of the second type: a 32/18 mm hydraulic cylinder pulls the rod 50 mm down its line;
    # the seals' friction changes sign over 50 mm/s, which a 1 ms coupling to a 12 kg rod can follow
    "cylinder-slider-crank": CylinderServoDesign(
        "cylinder-slider-crank", cylinder="hydraulic", move=-0.05, speed=0.1, acceleration=0.5, t_end=3.0,
        start_position=0.1, constants={"bore": 0.032, "rod": 0.018, "stroke": 0.2, "smoothing_speed": 0.05},
        pid={"K": 20.0, "Ts": 1e-3, "u_min": -1.0, "u_max": 1.0}),
    # a 32/12 mm pneumatic cylinder closes the clamp to 6 degrees short of its toggle;
    # PI(D): a pneumatic position loop needs the integral to pull through the seals' friction
    "toggle-clamp": CylinderServoDesign(
        "toggle-clamp", cylinder="pneumatic", move=0.02, speed=0.05, acceleration=0.5, t_end=4.0,
        start_position=0.02, constants={"smoothing_speed": 0.05},
        pid={"K": 20.0, "Ti": 0.3, "Td": 0.01, "N": 10.0, "Ts": 1e-3, "u_min": -1.0, "u_max": 1.0}),
}


def start_length(scene, actuator: str) -> float:
    """The actuator's length at the scene's assembled start, m.

    Examples
    --------
    >>> from grubler import load_scene
    >>> round(start_length(load_scene("luffing-boom"), "lift"), 4)          # m, between the attachments
    1.226
    """
    from grubler.mechanism.simulate import Simulator

    sim = Simulator(scene.mechanism, method=scene.method, zd0=scene.initial_rates)
    return float(sim.outputs(["actuators"])[f"{actuator}_length"])


def holding_force(scene, actuator: str) -> float:
    """The actuator force that holds the scene's mechanism still at its assembled start, N.

    The accelerations are affine in the force: two evaluations of the forward
    dynamics at rest give the force that zeroes the first real joint's.

    Examples
    --------
    >>> from grubler import load_scene
    >>> round(holding_force(load_scene("luffing-boom"), "lift"))            # N: the boom's weight, over the lever
    10816
    """
    import numpy as np

    from grubler.mechanism.assembly import assemble
    from grubler.mechanism.dynamics import Inputs, forward_dynamics

    m = scene.mechanism
    z, zd = assemble(m, m.z_from_q(m.q_ref), np.zeros(m.n_free))
    unit = np.zeros(len(m.actuators))
    unit[m.actuator_names.index(actuator)] = 1.0
    free = forward_dynamics(m, z, zd, Inputs(load=scene.load_torque)).zdd
    pushed = forward_dynamics(m, z, zd, Inputs(load=scene.load_torque, actuators=tuple(unit))).zdd
    i = int(np.argmax(np.abs(pushed - free)))
    return float(-free[i] / (pushed[i] - free[i]))


def cylinder_servo_system(design: CylinderServoDesign, fmu_dir: str | Path, name: str = "cylinder_servo",
                          build_dir: str | Path | None = None, reuse: bool = False) -> System:
    """The SSP system of a cylinder-driven linkage under position control (FMUs taken from ``fmu_dir``).

    A mechanism of another shape than ``Mechanism.fmu``'s gets its own FMU,
    built in ``build_dir`` (default ``fmu_dir``); with ``reuse``, one built
    there before is taken (:func:`grubler.fmi.build.scene_fmu`).

    Raises
    ------
    SceneError
        Naming ``cylinder`` or ``actuator`` for one the design cannot have, or a
        cylinder constant the cylinder refuses.

    Examples
    --------
    >>> design = CylinderServoDesign("luffing-boom", move=0.05)
    >>> cylinder_servo_system(CylinderServoDesign("luffing-boom", cylinder="electric"), "dist")
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: cylinder: must be one of hydraulic, pneumatic, got 'electric'

    A scene with an actuator gets a mechanism FMU of its own, exported into the
    folder (a compile of 5 to 8 s) when it is not there, so the build is not
    run here; ``tests/test_cylinder_systems.py`` builds and runs three:

    >>> s = cylinder_servo_system(design, "dist")     # doctest: +SKIP
    >>> list(s.components), s.order                   # doctest: +SKIP
    (['trajectory', 'controller', 'cylinder', 'mechanism'], ['controller', 'cylinder', 'mechanism', 'trajectory'])
    """
    from grubler.fmi.build import scene_fmu
    from grubler.fmi.cylinder import cylinder_parameters
    from grubler.mechanism.scene import load_scene
    from grubler.motors.hydraulic import HydraulicCylinder
    from grubler.motors.pneumatic import PneumaticCylinder

    if design.cylinder not in CYLINDERS:
        raise SceneError("cylinder", f"must be one of {', '.join(CYLINDERS)}, got {design.cylinder!r}")
    scene = load_scene(design.scene)
    model = scene.mechanism
    names = model.actuator_names
    if not names:
        raise SceneError("actuator", f"{model.name or 'the scene'} has no [[actuator]] for a cylinder to be")
    act = design.actuator or names[0]
    if act not in names:
        raise SceneError("actuator", f"no actuator named {act!r}; the scene's: {', '.join(names)}")
    length0 = start_length(scene, act)
    kind = HydraulicCylinder if design.cylinder == "hydraulic" else PneumaticCylinder
    cylinder = kind(**{"retracted_length": length0 - design.start_position, **design.constants})
    if design.load_torque and model.load is None:
        raise SceneError("load_torque", f"{model.name or 'the scene'} has no load joint ([load] joint) to apply it to")
    scene = replace(scene, load_torque=float(design.load_torque))
    # the cylinder starts holding the mechanism still: the load on the cap side (or, pulled, the rod side)
    hold = holding_force(scene, act)
    area_a, area_b = cylinder.areas
    start = {"initial_pressure_a": max(hold, 0.0) / area_a, "initial_pressure_b": max(-hold, 0.0) / area_b}
    d = Path(fmu_dir)
    s = System(name, description=f"a {design.cylinder} cylinder ({cylinder.bore * 1e3:g} mm bore, "
                                 f"{cylinder.stroke * 1e3:g} mm stroke) driving {model.name or 'a mechanism'} "
                                 "under PID position control of its length", start_time=0.0,
               stop_time=design.t_end, step=design.step)
    move = dict(kind="trapezoid", start=length0, delay=design.delay, distance=design.move, v_max=design.speed,
                a_max=design.acceleration, repeat=1)
    s.add("trajectory", d / design.trajectory_fmu, **(design.setpoint or move))
    s.add("controller", d / "PID.fmu", **design.pid)
    s.add("cylinder", d / FMU_OF[design.cylinder], **cylinder_parameters(cylinder), **start)
    mech_fmu, scene_params = scene_fmu(scene, d, build_dir, reuse=reuse)
    s.add("mechanism", mech_fmu, **scene_params, **({"load_torque": scene.load_torque} if model.load else {}))
    s.connect("trajectory.position", "controller.setpoint")
    s.connect(f"mechanism.{act}_length", "controller.measurement")
    s.connect("controller.u", "cylinder.command")
    s.connect(f"mechanism.{act}_length", "cylinder.length")
    s.connect(f"mechanism.{act}_rate", "cylinder.rate")
    s.connect("cylinder.force", f"mechanism.{act}_force")
    # the PID samples at the start of a step; the cylinder steps on the mechanism's
    # length and rate there and gives the force the mechanism then steps with
    s.order = ["controller", "cylinder", "mechanism", "trajectory"]
    pressures = ["cylinder.pressure_a", "cylinder.pressure_b"] + (
        ["cylinder.supply_pressure"] if design.cylinder == "hydraulic" else [])
    s.plots += [
        Plot("actuator length [m]", ["trajectory.position", f"mechanism.{act}_length"],
             {"trajectory.position": "setpoint", f"mechanism.{act}_length": "response"}),
        Plot("tracking error [m]", ["trajectory.position", f"mechanism.{act}_length"],
             {"difference": "setpoint - response"}, difference=True),
        Plot("valve command [1]", ["controller.u", "cylinder.spool"],
             {"controller.u": "command", "cylinder.spool": "spool"}),
        Plot("pressure [Pa]", pressures, {"cylinder.pressure_a": "cap side A", "cylinder.pressure_b": "rod side B",
                                         "cylinder.supply_pressure": "supply"}),
        Plot("cylinder force [N]", ["cylinder.force"], {"cylinder.force": "on the rod, pushing apart"}),
    ]
    return s


__all__ = ["CylinderServoDesign", "PRESET_DESIGNS", "cylinder_servo_system", "holding_force", "start_length"]
