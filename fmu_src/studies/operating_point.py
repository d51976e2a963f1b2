"""Operating points: where a mechanism is linearised.

An equilibrium under the given efforts (found by Newton on the minimal state
equation, walking along the assembly branch from the scene's sketch), the
scene's initial state, or a time along a simulated trajectory; with a DC motor,
the winding current and voltage that hold it there.

Examples
--------
>>> op = operating_point("thesis-fourbar-damped")    # at rest under gravity
>>> op.kind, op.independent
('equilibrium', ('theta2',))
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from grubler.mechanism.assembly import assemble
from grubler.mechanism.dynamics import EXACT, Inputs, forward_dynamics, inverse_dynamics, observation_names
from grubler.errors import SceneError
from grubler.mechanism.model import Mechanism
from grubler.mechanism.minimal import MinimalPlant, where_text
from grubler.mechanism.scene import Scene, load_scene, parse_coordinate
from grubler.mechanism.simulate import Simulator, unit_of

EQUILIBRIUM_TOL = 1e-10  # rad/s^2 (or m/s^2): residual joint acceleration of an equilibrium
EQUILIBRIUM_ITERATIONS = 60
MAX_NEWTON_STEP = 0.5  # rad (or m): one equilibrium step at most, where the local model still holds

ISOLATION_RCOND = 1e-6  # relative stiffness below which an equilibrium is not isolated

_TIME = re.compile(r"^\s*t\s*=\s*(?P<t>\S+)\s*$")

DRIVE, LOAD, VOLTAGE = "drive", "load", "voltage"  # the inputs: the efforts on the drive and load joints, a motor's voltage


def input_unit(name: str, model: Mechanism) -> str:
    """Unit of an input of the linear model."""
    if name == VOLTAGE:
        return "V"
    joint = model.drive if name == DRIVE else model.load
    return "N" if joint and joint.startswith("B") else "N m"


@dataclass(frozen=True)
class OperatingPoint:
    """Where a mechanism is linearised.

    Attributes
    ----------
    kind : str
        'equilibrium', 'initial' or 'trajectory'.
    time : float or None
        Time along the simulated trajectory, s ('trajectory' only).
    z, zd : ndarray
        Every real joint coordinate and rate (the kernel's order).
    drive, load : float
        Efforts on the drive and load joints, N m (or N on a slide).
    independent : tuple of str
        The independent coordinates: the linear model's states are these and their rates.
    coordinates : dict
        Absolute coordinates (thesis order, B1, theta2, ...) and their rates.
    acceleration : ndarray
        The independent coordinates' accelerations here (zero at an equilibrium:
        elsewhere the linear model describes perturbations of a moving point).
    current, voltage : float or None
        The motor's winding current (A) and the voltage that holds it (V), with a motor.
    effort_units : dict
        The units of ``drive`` and ``load``: 'N m' on a revolute, 'N' on a slide.

    Examples
    --------
    >>> import grubler
    >>> op = grubler.operating_point("thesis-fourbar-damped")    # at rest under gravity
    >>> op.kind, op.independent, round(float(op.coordinates["theta2"]), 4), op.drive
    ('equilibrium', ('theta2',), -1.9649, 0.0)
    """

    kind: str
    time: float | None
    z: np.ndarray
    zd: np.ndarray
    drive: float
    load: float
    independent: tuple[str, ...]
    coordinates: dict = field(default_factory=dict)
    acceleration: np.ndarray = field(default_factory=lambda: np.zeros(0))
    current: float | None = None
    voltage: float | None = None
    effort_units: dict = field(default_factory=lambda: {"drive": "N m", "load": "N m"})

    def as_dict(self) -> dict:
        """Plain numbers for JSON."""
        d = {"kind": self.kind, "time": self.time, "drive_effort": self.drive, "load_effort": self.load,
             "independent": list(self.independent),
             "coordinates": {k: float(v) for k, v in self.coordinates.items()},
             "acceleration": [float(a) for a in self.acceleration], "effort_units": dict(self.effort_units)}
        if self.current is not None:
            d["current"], d["voltage"] = self.current, self.voltage
        return d

def _scene(scene) -> Scene:
    return scene if isinstance(scene, Scene) else load_scene(scene)


def _effort(value, default: float, name: str) -> float:
    v = default if value is None else value
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise SceneError(name, f"must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise SceneError(name, f"must be finite, got {v}")
    return v


def _parse_at(at):
    """('equilibrium' | 'initial' | 'trajectory' | 'held', time or {coordinate: value})."""
    if isinstance(at, dict):
        return "held", at
    if isinstance(at, bool):
        raise SceneError("at", f"must be 'equilibrium', 'initial', 't=T' or a time, got {at!r}")
    if isinstance(at, (int, float)):
        t = float(at)
    elif isinstance(at, str) and at.strip() in ("equilibrium", "initial"):
        return at.strip(), None
    elif isinstance(at, str) and _TIME.match(at):
        try:
            t = float(_TIME.match(at)["t"])
        except ValueError:
            raise SceneError("at", f"cannot read the time in {at!r} (write t=1.5)") from None
    else:
        raise SceneError("at", f"must be 'equilibrium', 'initial', 't=T' (a time along the simulated "
                               f"trajectory) or a coordinate held at a value ({{'theta2': 0.5}} in rad, or "
                               f"{{'theta2': '30 deg'}}; on the command line theta2=30deg), got {at!r}")
    if not (math.isfinite(t) and t >= 0):
        raise SceneError("at", f"the time must be finite and >= 0, got {t}")
    return "trajectory", t


def _equilibrium(plant: MinimalPlant, y: np.ndarray, drive: float, load: float, held: list[int]):
    """Rest state near y where the efforts balance gravity; returns (y, drive).

    A stable equilibrium is a minimum of the potential V = PE - tau_drive z_drive
    - tau_load z_load along the constraint manifold.  Its gradient is exact (the
    complex-step derivative of the kernel's PE and of the manifold), and the
    step is Newton's on the exact stiffness ``-M_r dzdd/dx`` where that is
    positive definite, else along the accelerations ``-M_r^-1 grad V`` (a
    descent direction whatever the curvature), with a line search on V: the
    accelerations themselves make a poor merit function, since the reduced
    inertia M_r changes with the configuration.  ``held`` lists independent
    coordinates (positions in ``plant.ind``) kept at their values: the others
    settle, and the drive effort that holds the whole is found afterwards.
    """
    model, n, ind = plant.model, plant.n, plant.ind
    names = [model.free_names[i] for i in ind]
    free = [k for k in range(len(ind)) if k not in held]
    d, l = model.arrays.drive, model.arrays.load
    y = y.copy()
    y[n:] = 0.0
    start = y[:n].copy()
    weight = np.where(model.arrays.revolute, 1.0, 1.0 / plant.scale)

    def potential(yy):
        obs = plant.observe(yy, drive, load)
        v = obs[_PE(n)] - (drive * yy[d] if d >= 0 else 0.0) - (load * yy[l] if l >= 0 else 0.0)
        return v

    def local(yy):
        F, G, Hx, Hu, T = plant.derivatives(yy, drive, load)
        nz = len(ind)
        g = Hx[_PE(n), :nz] - (drive * T[d, :nz] if d >= 0 else 0.0) - (load * T[l, :nz] if l >= 0 else 0.0)
        Tz = T[:n, :nz]
        M = _mass_matrix(model, yy)
        Mr = Tz.T @ M @ Tz
        K = F[n + ind][:, :nz]
        return g, Mr, K, plant.rhs(yy, drive, load)[n + ind]

    for _ in range(EQUILIBRIUM_ITERATIONS):
        if not held:  # every coordinate settles: any chart will do, and a toggle of this one is no wall
            plant.well_conditioned_chart(y)
            ind, names = plant.ind, [model.free_names[i] for i in plant.ind]
        g, Mr, K, acc = local(y)
        if not free or np.abs(acc[free] if held else acc).max() <= EQUILIBRIUM_TOL:
            break
        gf, Mf = g[free], Mr[np.ix_(free, free)]
        stiff = -(Mr @ K)[np.ix_(free, free)]
        stiff = 0.5 * (stiff + stiff.T)
        try:
            np.linalg.cholesky(stiff)
            step, newton = -np.linalg.solve(stiff, gf), True
        except np.linalg.LinAlgError:
            step, newton = -np.linalg.solve(Mf, gf), False
        biggest = np.abs(step).max()
        if biggest > MAX_NEWTON_STEP:
            step *= MAX_NEWTON_STEP / biggest
        v0, slope, lam, residual = potential(y), float(gf @ step), 1.0, np.linalg.norm(acc[free])
        while True:
            target = y[ind].copy()
            target[free] += lam * step
            try:
                trial = plant.follow(y, target)
                # near the minimum V's decrease drowns in its rounding: there a
                # Newton step that halves the accelerations is as good
                ok = (potential(trial) <= v0 + 1e-4 * lam * slope or
                      (newton and np.linalg.norm(plant.rhs(trial, drive, load)[n + ind][free]) < 0.5 * residual))
            except SceneError:
                ok = False
            if ok:
                y = trial
                break
            lam /= 2
            if lam < 1e-8:
                raise SceneError("at", "no equilibrium found near the initial configuration: the search stalls "
                                       f"at {where_text(names, y, ind)} with joint accelerations "
                                       f"{_accelerations(names, acc)}")
        travel = np.abs(y[:n] - start) * weight
        if travel.max() > 4 * math.pi:  # two turns (or lengths): no well on the way
            why = ("the drive or load effort exceeds what gravity can hold" if drive or load else
                   "nothing stops the fall on this side")
            runner = d if d >= 0 and travel[d] > 2 * math.pi else int(np.argmax(travel))
            raise SceneError("at", f"no equilibrium under these efforts: the potential keeps falling as "
                                   f"{model.free_names[runner]} moves on ({why})")
    else:
        raise SceneError("at", f"no equilibrium found in {EQUILIBRIUM_ITERATIONS} steps from the initial "
                               f"configuration (joint accelerations {_accelerations(names, acc)})")
    if not held:  # back to the drive's chart, the linear model's states
        plant.choose_independent(y[:n])
        ind, names = plant.ind, [model.free_names[i] for i in plant.ind]
        y = plant.close(y)
    if held:
        drive, _ = inverse_dynamics(model, y[:n], np.zeros(n), np.zeros(n), Inputs(0.0, load))
    acc = plant.rhs(y, drive, load)[n + ind]
    if np.abs(acc).max() > 1e3 * EQUILIBRIUM_TOL:
        raise SceneError("at", f"no equilibrium found: at {where_text(names, y, ind)} the joint accelerations are "
                               f"{_accelerations(names, acc)}")
    if not held:
        # the stiffness against gravity's own scale g / l: below that fraction the
        # natural frequency is a rounding error's
        _, Mr, K, _ = local(y)
        s = np.linalg.svd(K, compute_uv=False)
        if s[-1] <= ISOLATION_RCOND * max(s[0], max(model.gravity, 1.0) / plant.scale):
            raise SceneError("at", f"the equilibrium at {where_text(names, y, ind)} is not isolated: the joint "
                                   "accelerations do not change with the coordinates there (neutral "
                                   "equilibrium: every nearby configuration is one, so there is no one point "
                                   "to linearise about); hold a coordinate instead (at={'" + names[0] + "': ...})")
    return y, drive


def _PE(n: int) -> int:
    return observation_names(n).index("PE")


def _mass_matrix(model: Mechanism, y: np.ndarray) -> np.ndarray:
    n = model.n_links
    return np.array(forward_dynamics(model, y[:n], np.zeros(n), Inputs()).M, copy=True)

def _accelerations(names, acc) -> str:
    return ", ".join(f"{nm} {a:.3g} {unit_of(nm + '_dd')}" for nm, a in zip(names, acc))


def _motor_model(motor):
    from grubler.motors import DCMotor

    if not isinstance(motor, DCMotor):
        raise SceneError("motor", f"must be a grubler.motors.DCMotor, got {type(motor).__name__}")
    return motor


def operating_point(scene, at="equilibrium", *, torque=None, load_torque=None, motor=None,
                    near: OperatingPoint | None = None) -> OperatingPoint:
    """Find the state a mechanism is linearised about.

    Parameters
    ----------
    scene : Scene or str
        A scene, or a preset name / TOML file path.
    at : {'equilibrium', 'initial'}, str 't=T', float or dict
        'equilibrium': at rest under the constant efforts, found by Newton from
        the scene's initial configuration (whose branch it keeps);
        'initial': the scene's assembled initial state; 't=T' or a number: the
        state at time T of the trajectory simulated under the constant efforts;
        ``{'theta2': angle}``: at rest with that coordinate held, under the drive
        effort that holds it there (found from the inverse statics).
    torque, load_torque : float, optional
        Constant drive and load efforts, N m (N on a slide); default the scene's.
    motor : grubler.motors.DCMotor, optional
        Its rotor inertia joins the drive joint; the point gets the current that
        gives the drive effort and the voltage that holds that current.
    near : OperatingPoint, optional
        Start from this point's configuration instead of the scene's sketch: a
        sweep that passes each point to the next stays on one assembly branch.

    Returns
    -------
    OperatingPoint

    Raises
    ------
    SceneError
        Naming ``at`` (no equilibrium, not isolated, a singular configuration),
        ``torque``, ``motor`` or ``method``.

    Examples
    --------
    >>> op = operating_point("thesis-fourbar-damped")    # where its damped simulation settles
    >>> round(math.degrees(op.coordinates["theta2"]), 2)
    -112.58
    >>> op = operating_point("thesis-fourbar", at={"theta2": 0.0})
    >>> round(op.drive, 4)                                 # the torque that holds the crank level
    5.3955
    """
    return _operating_point(_prepared(_scene(scene), motor), at, torque, load_torque, motor, near)[0]


def _prepared(scene: Scene, motor) -> Scene:
    if scene.method != EXACT:
        raise SceneError("method", "linearisation works in minimal coordinates, on the exact closure; the "
                                   f"scene asks for {scene.method!r}")
    if motor is None:
        return scene
    motor = _motor_model(motor)
    model = scene.mechanism
    if model.drive is None:
        raise SceneError("motor", "the scene has no drive joint for the motor to drive")
    from dataclasses import replace

    return replace(scene, mechanism=model.replace(drive_inertia=motor.reflected_inertia))


def _operating_point(scene: Scene, at, torque, load_torque, motor,
                     near: OperatingPoint | None = None) -> tuple[OperatingPoint, MinimalPlant]:
    model = scene.mechanism
    kind, what = _parse_at(at)
    drive = _effort(torque, scene.torque, "torque")
    load = _effort(load_torque, scene.load_torque, "load_torque")
    if drive != 0.0 and model.drive is None:
        raise SceneError("torque", f"{model.name or 'this scene'} has no drive joint to apply it to")
    if load != 0.0 and model.load is None:
        raise SceneError("load_torque", f"{model.name or 'this scene'} has no load joint to apply it to")
    plant = MinimalPlant(model)
    z0, zd0 = model.z_from_q(model.q_ref), np.asarray(scene.initial_rates, dtype=float)
    if near is not None:
        if not isinstance(near, OperatingPoint) or near.z.shape != z0.shape:
            raise SceneError("near", "must be an OperatingPoint of this mechanism")
        z0 = near.z.copy()
    time = None
    if kind == "trajectory":
        sim = Simulator(model, z0=z0, zd0=zd0, inputs=Inputs(drive, load))
        if what > 0:
            sim.advance_to(what)
        z, zd, time = sim.z.copy(), sim.zd.copy(), what
    else:
        z, zd = assemble(model, z0, zd0 if kind == "initial" else np.zeros(model.n_free))
    if kind == "held":
        # the value is the absolute coordinate (thesis order), as every output names it
        q = model.q_from_z(z)
        for name, value in what.items():
            if not isinstance(name, str) or name not in model.free_names:
                raise SceneError("at", f"{name!r} is not a real joint coordinate; expected one of "
                                       f"{', '.join(model.free_names)}")
            q[model.coordinate_names.index(name)] = parse_coordinate(name, value, f"at.{name}")
        z = model.z_from_q(q)
        if model.n_constraints:
            z, _ = assemble(model, z, None, field="at")
    plant.choose_independent(z)
    y = plant.close(np.concatenate([z, zd]))
    if kind == "held":
        # a held coordinate at a toggle is refused by the conditioning it gives,
        # before any search whose verdict there would hang on rounding
        plant.check_regular(y)
    if kind in ("equilibrium", "held"):
        held = []
        if kind == "held":
            if model.drive is None:
                raise SceneError("at", "holding a coordinate needs a drive joint whose effort holds it")
            names = [model.free_names[i] for i in plant.ind]
            for name in what:
                if name not in names:
                    raise SceneError("at", f"{name!r} is not an independent coordinate here; expected one of "
                                           f"{', '.join(names)}")
                held.append(names.index(name))
            if model.drive not in names or held != [names.index(model.drive)]:
                raise SceneError("at", f"hold the drive coordinate {model.drive} alone: its effort is the one "
                                       "unknown that replaces it")
        y, drive = _equilibrium(plant, y, drive, load, held)
        kind = "equilibrium"
    n = plant.n
    plant.check_regular(y)
    acc = plant.rhs(y, drive, load)[n + plant.ind]
    q, qd = model.q_from_z(y[:n]), model.S @ y[n:]
    coords = dict(zip(model.coordinate_names, q))
    coords.update({f"{nm}_d": v for nm, v in zip(model.coordinate_names, qd)})
    current = voltage = None
    if motor is not None:
        current, voltage = _motor_operating(motor, y[n + model.arrays.drive], drive)
    op = OperatingPoint(kind, time, y[:n].copy(), y[n:].copy(), float(drive), float(load),
                        tuple(model.free_names[i] for i in plant.ind), coords, acc, current, voltage,
                        {"drive": input_unit(DRIVE, model), "load": input_unit(LOAD, model)})
    return op, plant


def _motor_operating(motor, shaft_speed: float, torque: float) -> tuple[float, float]:
    from grubler.motors import current_for_torque, initial_state, linearization

    i0 = float(current_for_torque(motor, torque, motor.gear.ratio * shaft_speed))
    limit = motor.drive.current_limit
    if not abs(i0) < limit:
        raise SceneError("motor", f"the operating point needs {i0:.4g} A for {torque:.4g} N m at the drive, "
                                  f"at or beyond the current limit {limit:g} A: the drive saturates there")
    lin = linearization(motor, initial_state(motor, 0.0), shaft_speed)
    v0 = lin.steady_voltage(i0, shaft_speed)
    if not abs(v0) < motor.drive.supply_voltage:
        raise SceneError("motor", f"the operating point needs {v0:.4g} V, beyond the {motor.drive.supply_voltage:g} V "
                                  "supply: the drive saturates there")
    return i0, float(v0)


__all__ = ["OperatingPoint", "operating_point", "input_unit", "DRIVE", "LOAD", "VOLTAGE"]
