"""Linear models of a mechanism about an operating point, for control design.

A closed chain of N real joints and C closures moves with n = N - 2C freedoms;
its minimal realisation has 2n states, the independent coordinates (the drive
first, as assembly holds them) and their rates.  The dependent coordinates and
rates follow from the closures (``kernel/minimal.c``), so the state equation in
minimal coordinates is ``xdot = (zd_i, zdd_i)(y(x), u)`` with ``y(x)`` the whole
state.  Its Jacobians come from the kernel's own equations compiled over complex
numbers (``grubler_cs.h``): evaluated at ``x + i h e_k`` the imaginary part of
every output over h is its exact derivative along ``e_k``, the tangent of the
constraint manifold included, with no step-size trade-off (complex-step
differentiation).  Finite differences only check them (tests/test_linearize.py).

With a DC motor (:mod:`grubler.motors`) the winding current is a third kind of
state, the input is the voltage, and the rotor's inertia joins the drive joint
(``drive.inertia`` = J_rotor N², as the servo system puts it there); the motor's
partial derivatives are the C model's own (:func:`grubler.motors.linearization`).

Examples
--------
The parallelogram swings as a simple pendulum of length 1 m (MODEL.md): its
linear model has the pendulum's frequency sqrt(g / l).

>>> import numpy as np, grubler
>>> sys = grubler.linearize("fourbar-parallelogram", at="equilibrium")
>>> sys.nstates, sys.state_labels
(2, ['theta2', 'theta2_d'])
>>> wn = np.abs(sys.poles()).max()
>>> bool(abs(wn - np.sqrt(9.81 / 1.0)) < 1e-9)
True
>>> round(float(sys.operating_point.coordinates["theta2"]), 6)     # hanging straight down
-1.570796
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from grubler import binding
from grubler.mechanism.assembly import SINGULAR_RCOND, _scale, assemble, constraint, freedom, held_coordinates
from grubler.mechanism.dynamics import EXACT, Inputs, forward_dynamics, inverse_dynamics, observation_names
from grubler.errors import SceneError
from grubler.mechanism.model import Mechanism
from grubler.mechanism.scene import Scene, coordinate_text, load_scene, parse_coordinate
from grubler.mechanism.simulate import Simulator, unit_of

H_STEP = 1e-30  # complex step: any tiny h is exact; this one keeps h^2 far above underflow
EQUILIBRIUM_TOL = 1e-10  # rad/s^2 (or m/s^2): residual joint acceleration of an equilibrium
EQUILIBRIUM_ITERATIONS = 60
MAX_NEWTON_STEP = 0.5  # rad (or m): one equilibrium step at most, where the local model still holds
# A step of the independent coordinates is walked (_Plant.follow): each piece is
# predicted along the tangent and closed by Newton, and kept only when Newton's
# correction is a small part of the predicted move; else halved.  Newton from a
# far guess lands on whichever branch is nearest the guess.
FOLLOW_RATIO = 0.25  # largest correction over predicted move of one piece
FOLLOW_MOVE = 0.1  # rad (or m over the length scale): largest predicted move of a dependent coordinate
FOLLOW_FLOOR = 1e-9  # rad (or m over the length scale): a correction this small passes whatever the move
FOLLOW_SHORTEST = 1e-10  # rad (or m): a piece this short that still fails is stopped by a toggle
FOLLOW_PIECES = 2000  # pieces of one walk at most: beyond, a coordinate runs off towards an asymptote
# The search moves in whichever independent coordinates are well conditioned: a
# double-rocker's crank reaches a toggle on the way down and turns back while the
# rest swings on, as its damped release does.  It changes chart when the current
# one's conditioning falls below this fraction of the best one's.
CHART_SWITCH = 0.25
ISOLATION_RCOND = 1e-6  # relative stiffness below which an equilibrium is not isolated

DRIVE, LOAD, VOLTAGE = "drive", "load", "voltage"
_INPUT_ALIASES = {"drive": DRIVE, "tau_drive": DRIVE, "torque": DRIVE, "load": LOAD, "tau_load": LOAD,
                  "load_torque": LOAD, "voltage": VOLTAGE}
_TIME = re.compile(r"^\s*t\s*=\s*(?P<t>\S+)\s*$")


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


class _Plant:
    """One mechanism's state equation in minimal coordinates, with complex-step derivatives."""

    def __init__(self, model: Mechanism):
        self.model = model
        self.n = model.n_links
        self.scale = _scale(model)
        self.lib = binding.library()
        self.work = binding.work(self.n, len(model.closures))
        self.cwork = np.zeros(self.work.size, dtype=complex)
        self.ind = np.zeros(0, dtype=np.int32)

    def choose_independent(self, z: np.ndarray) -> None:
        m = self.model
        # the closures' rank, not the Grübler count: a redundant closure (a third
        # crank on a parallelogram's rod) leaves a freedom the count does not see
        free = freedom(m, z) if m.n_constraints else self.n
        if free < 1:
            raise SceneError("closure", f"the mechanism has mobility {free}: nothing moves to linearise")
        ind = sorted(held_coordinates(m, z)) if m.n_constraints else list(range(self.n))
        if len(ind) != free:
            raise SceneError("closure", f"the closures leave {free} freedoms but "
                                        f"{len(ind)} independent coordinates were found")
        self.ind = np.array(ind, dtype=np.int32)

    @property
    def rows(self) -> np.ndarray:
        """Indices in (z, zd) of the minimal state (z_i, zd_i)."""
        return np.concatenate([self.ind, self.n + self.ind])

    def close(self, y: np.ndarray, where: str = "at") -> np.ndarray:
        """The whole state from its independent part (the others as a nearby guess), real."""
        y = np.ascontiguousarray(y, dtype=float).copy()
        status = self.lib.grb_minimal_state(self.model.arrays.c, len(self.ind), binding.address(self.ind),
                                            self.scale, binding.address(y), binding.address(self.work))
        self._check(status, where, y)
        return y

    def _check(self, status: int, where: str, y) -> None:
        if status == binding.OK:
            return
        names = [self.model.free_names[i] for i in self.ind]
        at = _where(names, y, self.ind)
        if status == binding.SINGULAR:
            raise SceneError(where, f"at {at} the coordinates {', '.join(names)} do not determine the others "
                                    "(the closure Jacobian's dependent columns are singular: a dead centre or "
                                    "change point); linearise elsewhere")
        raise SceneError(where, f"the loop cannot be closed at {at}")

    def _charts(self, z: np.ndarray, ind) -> tuple[float, list[int]]:
        """How well ``ind`` determines the rest at ``z`` (the smallest singular value of the
        closures' null space restricted to it), and the best-conditioned chart's choice."""
        weight = np.where(self.model.arrays.revolute, 1.0, 1.0 / self.scale)
        _, J = constraint(self.model, z)
        _, s, vt = np.linalg.svd(J / weight, full_matrices=True)
        null = vt[len(vt) - len(ind):].T  # n x k: the closures' tangent space
        best, rest = [], null.copy()
        for _ in range(len(ind)):  # greedy pivoting: the coordinate that moves most, then the next ...
            i = int(np.argmax(np.linalg.norm(rest, axis=1)))
            best.append(i)
            v = rest[i] / np.linalg.norm(rest[i])
            rest = rest - np.outer(rest @ v, v)
        quality = lambda chosen: np.linalg.svd(null[sorted(chosen)], compute_uv=False)[-1]  # noqa: E731
        return quality(ind) / quality(best), sorted(best)

    def well_conditioned_chart(self, y: np.ndarray) -> None:
        """Move to the best-conditioned independent coordinates when the current ones near a toggle."""
        if not self.model.n_constraints:
            return
        ratio, best = self._charts(y[:self.n], list(self.ind))
        if ratio < CHART_SWITCH:
            self.ind = np.array(best, dtype=np.int32)

    def follow(self, y: np.ndarray, target: np.ndarray, where: str = "at") -> np.ndarray:
        """The closed state (at rest) with the independent coordinates at ``target``, reached from
        ``y`` by continuity: on ``y``'s assembly branch, as a simulation keeps it.

        Raises SceneError(``where``) when a dead centre or change point on the way stops the walk.
        """
        n, ind = self.n, self.ind
        y = np.array(y, dtype=float)
        y[n:] = 0.0
        start = y[ind].copy()
        delta = np.asarray(target, dtype=float) - start
        if not self.model.n_constraints:
            y[ind] = target
            return y
        weight = np.where(self.model.arrays.revolute, 1.0, 1.0 / self.scale)
        done, piece = 0.0, 1.0
        for _ in range(FOLLOW_PIECES):
            if done >= 1.0:
                break
            piece = min(piece, 1.0 - done)
            ok = False
            try:
                tangent = y.copy()
                tangent[n + ind] = piece * delta  # as rates: the dependent rates are the first-order move
                move = self.close(tangent, where)[n:]
                predicted = y.copy()
                predicted[:n] += move
                predicted[n:] = 0.0
                predicted[ind] = start + (done + piece) * delta
                if np.abs(move * weight).max() <= FOLLOW_MOVE:
                    closed = self.close(predicted, where)
                    correction = np.abs((closed[:n] - predicted[:n]) * weight).max()
                    ok = correction <= max(FOLLOW_RATIO * np.abs(move * weight).max(), FOLLOW_FLOOR)
            except SceneError:
                pass
            if ok:
                y, done, piece = closed, done + piece, 2.0 * piece
                continue
            piece /= 2.0
            if piece * np.abs(delta).max() < FOLLOW_SHORTEST:
                names = [self.model.free_names[i] for i in ind]
                raise SceneError(where, f"turning {', '.join(names)} from {_where(names, start, range(len(ind)))} "
                                        f"towards {_where(names, target, range(len(ind)))} stops at "
                                        f"{_where(names, y, ind)}: a dead centre or change point there (the closure "
                                        "Jacobian's dependent columns are singular) bars the way on this branch")
        else:
            if done < 1.0:
                names = [self.model.free_names[i] for i in ind]
                raise SceneError(where, f"turning {', '.join(names)} towards {_where(names, target, range(len(ind)))}"
                                        f" takes more than {FOLLOW_PIECES} steps from {_where(names, y, ind)}: "
                                        "the others run off on the way")
        y[ind] = target  # exactly, not as the sum of the pieces
        return self.close(y, where)

    def check_regular(self, y: np.ndarray) -> None:
        """Refuse a configuration where the dependent coordinates barely follow from the independent ones."""
        if not self.model.n_constraints:
            return
        _, J = constraint(self.model, y[:self.n])
        dep = [i for i in range(self.n) if i not in self.ind]
        s = np.linalg.svd(J[:, dep], compute_uv=False)
        if s[-1] <= SINGULAR_RCOND * s[0]:
            self._check(binding.SINGULAR, "at", y)

    def rhs(self, y: np.ndarray, drive: float, load: float) -> np.ndarray:
        out = np.empty(2 * self.n)
        status = self.lib.grb_rhs(self.model.arrays.c, 0, binding.address(y), float(drive), float(load),
                                  binding.address(self.work), binding.address(out))
        if status != binding.OK:
            raise SceneError("at", "the equations of motion are singular at this state")
        return out

    def derivatives(self, y: np.ndarray, drive: float, load: float):
        """Exact derivatives along the minimal state and the two efforts.

        Returns
        -------
        F, G : ndarray
            d(ydot)/dx (2N x 2n) and d(ydot)/d(drive, load) (2N x 2).
        H, K : ndarray
            d(observations)/dx and d(observations)/d(drive, load).
        T : ndarray
            dy/dx, the tangent of the constraint manifold (2N x 2n).
        """
        n, rows = self.n, self.rows
        n_obs = 9 * n + 11
        k_dirs = len(rows) + 2
        F, T, H = np.empty((2 * n, k_dirs)), np.empty((2 * n, k_dirs)), np.empty((n_obs, k_dirs))
        out, obs = np.empty(2 * n, dtype=complex), np.empty(n_obs, dtype=complex)
        m = self.model.arrays.c
        cs_minimal_state, cs_rhs, cs_observe = (binding.complex_step(f"grb_cs_{f}")
                                                for f in ("minimal_state", "rhs_at", "observe_at"))
        for k in range(k_dirs):
            yc = y.astype(complex)
            efforts = np.array([drive, load], dtype=complex)
            if k < len(rows):
                yc[rows[k]] += 1j * H_STEP
                status = cs_minimal_state(m, len(self.ind), binding.address(self.ind), self.scale,
                                          binding.address(yc), binding.address(self.cwork))
                self._check(status, "at", yc)
            else:
                efforts[k - len(rows)] += 1j * H_STEP
            s1 = cs_rhs(m, 0, binding.address(yc), binding.address(efforts),
                        binding.address(self.cwork), binding.address(out))
            s2 = cs_observe(m, 0, binding.address(yc), binding.address(efforts), 1,
                            binding.address(self.cwork), binding.address(obs))
            if s1 != binding.OK or s2 != binding.OK:
                raise SceneError("at", "the equations of motion are singular at this state")
            F[:, k], H[:, k], T[:, k] = out.imag / H_STEP, obs.imag / H_STEP, yc.imag / H_STEP
        nx = len(rows)
        return F[:, :nx], F[:, nx:], H[:, :nx], H[:, nx:], T[:, :nx]

    def observe(self, y: np.ndarray, drive: float, load: float) -> np.ndarray:
        out = np.zeros(9 * self.n + 11)
        self.lib.grb_observe(self.model.arrays.c, 0, binding.address(y), float(drive), float(load), 1,
                             binding.address(self.work), binding.address(out))
        return out


# -- operating points ----------------------------------------------------------------
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


def _equilibrium(plant: _Plant, y: np.ndarray, drive: float, load: float, held: list[int]):
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
                                       f"at {_where(names, y, ind)} with joint accelerations "
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
        raise SceneError("at", f"no equilibrium found: at {_where(names, y, ind)} the joint accelerations are "
                               f"{_accelerations(names, acc)}")
    if not held:
        # the stiffness against gravity's own scale g / l: below that fraction the
        # natural frequency is a rounding error's
        _, Mr, K, _ = local(y)
        s = np.linalg.svd(K, compute_uv=False)
        if s[-1] <= ISOLATION_RCOND * max(s[0], max(model.gravity, 1.0) / plant.scale):
            raise SceneError("at", f"the equilibrium at {_where(names, y, ind)} is not isolated: the joint "
                                   "accelerations do not change with the coordinates there (neutral "
                                   "equilibrium: every nearby configuration is one, so there is no one point "
                                   "to linearise about); hold a coordinate instead (at={'" + names[0] + "': ...})")
    return y, drive


def _PE(n: int) -> int:
    return observation_names(n).index("PE")


def _mass_matrix(model: Mechanism, y: np.ndarray) -> np.ndarray:
    n = model.n_links
    return np.array(forward_dynamics(model, y[:n], np.zeros(n), Inputs()).M, copy=True)


def _where(names, y, ind) -> str:
    return ", ".join(f"{nm} = {coordinate_text(nm, float(np.real(y[i])))}" for nm, i in zip(names, ind))


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
                     near: OperatingPoint | None = None) -> tuple[OperatingPoint, _Plant]:
    model = scene.mechanism
    kind, what = _parse_at(at)
    drive = _effort(torque, scene.torque, "torque")
    load = _effort(load_torque, scene.load_torque, "load_torque")
    if drive != 0.0 and model.drive is None:
        raise SceneError("torque", f"{model.name or 'this scene'} has no drive joint to apply it to")
    if load != 0.0 and model.load is None:
        raise SceneError("load_torque", f"{model.name or 'this scene'} has no load joint to apply it to")
    plant = _Plant(model)
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


# -- the linear model ----------------------------------------------------------------
def _inputs(inputs, motor, model: Mechanism) -> list[str]:
    if isinstance(inputs, str):
        inputs = [s for s in inputs.split(",") if s.strip()]
    chosen = []
    for name in inputs:
        key = _INPUT_ALIASES.get(str(name).strip())
        if key is None:
            raise SceneError("inputs", f"unknown input {name!r}; expected drive, load" + (", voltage" if motor else ""))
        if key == VOLTAGE and motor is None:
            raise SceneError("inputs", "'voltage' needs a motor (motor=...)")
        if key == DRIVE and motor is not None:
            raise SceneError("inputs", "with a motor the drive effort is the motor's: use 'voltage'")
        if key == DRIVE and model.drive is None:
            raise SceneError("inputs", "the scene has no drive joint")
        if key == LOAD and model.load is None:
            raise SceneError("inputs", "the scene has no load joint: give it a [load] joint to use 'load'")
        if key in chosen:
            raise SceneError("inputs", f"{name!r} is given twice")
        chosen.append(key)
    if not chosen:
        raise SceneError("inputs", "at least one input is needed")
    return chosen


def output_names(model: Mechanism, motor=None) -> list[str]:
    """Every output a linear model of ``model`` can have."""
    names = [c for c in observation_names(model.n_links) if c != "closure_error"]
    return names + (["current"] if motor is not None else [])


def _outputs(outputs, model: Mechanism, motor, plant: _Plant) -> list[str]:
    if outputs is None:
        drive = model.drive or model.free_names[int(plant.ind[0])]
        return [drive]
    if isinstance(outputs, str):
        outputs = [s.strip() for s in outputs.split(",") if s.strip()]
    allowed = output_names(model, motor)
    chosen = []
    for name in outputs:
        if name == "closure_error":
            raise SceneError("outputs", "closure_error is zero on the constraint manifold and has no derivative "
                                        "there (it is a norm)")
        if name not in allowed:
            raise SceneError("outputs", f"unknown output {name!r}; expected one of {', '.join(allowed)}")
        chosen.append(name)
    if not chosen:
        raise SceneError("outputs", "at least one output is needed")
    return chosen


def input_unit(name: str, model: Mechanism) -> str:
    """Unit of an input of the linear model."""
    if name == VOLTAGE:
        return "V"
    joint = model.drive if name == DRIVE else model.load
    return "N" if joint and joint.startswith("B") else "N m"


def signal_unit(name: str) -> str:
    """Unit of a state or output of the linear model."""
    return "A" if name == "current" else unit_of(name)


def linearize(scene, at="equilibrium", inputs=None, outputs=None, motor=None, *, torque=None,
              load_torque=None, near=None):
    """The mechanism's linear model about an operating point, as a python-control StateSpace.

    Parameters
    ----------
    scene : Scene or str
        A scene, or a preset name / TOML file path (exact closure).
    at : {'equilibrium', 'initial'}, str 't=T', float or dict
        The operating point (see :func:`operating_point`).
    inputs : sequence of str, optional
        'drive' (the drive effort, default), 'load' (the load effort), or with a
        motor 'voltage' (default) and 'load'.
    outputs : sequence of str, optional
        Any coordinate, rate or acceleration (``theta3``, ``theta4_d``,
        ``B3_dd``), ``tip_x``, ``tip_y``, the closing force ``Fx``, ``Fy``,
        ``Mz``, a joint reaction ``R2_Fy``, ``KE``, ``PE``, ``tau_drive``, and
        with a motor ``current``; default the drive coordinate.
    motor : grubler.motors.DCMotor, optional
        A DC motor and gearbox on the drive joint: the input is its voltage and
        its winding current a state (the winding temperature is held at ambient).
    torque, load_torque : float, optional
        Constant efforts defining the operating point (default the scene's).
    near : OperatingPoint, optional
        A nearby operating point whose assembly branch to keep (for sweeps).

    Returns
    -------
    control.StateSpace
        States: the independent coordinates, their rates, and with a motor
        ``current``; in SI units (rad, m, A).  Its ``operating_point`` attribute
        is the :class:`OperatingPoint`; the model maps deviations from it.

    Raises
    ------
    SceneError
        Naming the field: ``at`` when no equilibrium exists, it is not isolated,
        or the configuration is singular; ``inputs``, ``outputs``, ``motor``,
        ``torque``, ``method``.

    Examples
    --------
    >>> import control
    >>> from grubler.motors import DCMotor, Gearbox, load_motor
    >>> m = DCMotor(load_motor("maxon-re40-148877"), Gearbox(50.0, 0.9))
    >>> sys = linearize("thesis-fourbar", at={"theta2": 0.5}, motor=m, outputs=["theta2", "current"])
    >>> sys.state_labels, sys.input_labels
    (['theta2', 'theta2_d', 'current'], ['voltage'])
    >>> p = sorted(sys.poles(), key=abs)                # gravity tips the held crank over: one slow unstable pole
    >>> bool(p[0].real > 0), bool(p[1].real < 0), bool(p[2].real < -3000)   # the winding's R/L pole
    (True, True, True)
    >>> loop = control.feedback(50.0 * sys[0, 0], 1)       # 50 V/rad of crank error holds it
    >>> bool(all(p.real < 0 for p in loop.poles()))
    True
    """
    import control

    scene = _scene(scene)
    if motor is not None:
        motor = _motor_model(motor)
    scene = _prepared(scene, motor)
    model = scene.mechanism
    op, plant = _operating_point(scene, at, torque, load_torque, motor, near)
    in_names = _inputs(inputs if inputs is not None else [VOLTAGE if motor is not None else DRIVE], motor, model)
    out_names = _outputs(outputs, model, motor, plant)
    n, rows = plant.n, plant.rows
    y = np.concatenate([op.z, op.zd])
    F, G, Hx, Hu, T = plant.derivatives(y, op.drive, op.load)
    A, Bm = F[rows], G[rows]  # Bm columns: drive, load
    obs_index = {name: i for i, name in enumerate(observation_names(n))}
    state_names = [model.free_names[i] for i in plant.ind]
    state_names += [f"{s}_d" for s in state_names]
    if motor is None:
        Bu = {DRIVE: Bm[:, 0], LOAD: Bm[:, 1]}
        B = np.column_stack([Bu[k] for k in in_names])
        C = np.array([Hx[obs_index[o]] for o in out_names])
        D = np.array([[Hu[obs_index[o], 0 if k == DRIVE else 1] for k in in_names] for o in out_names])
    else:
        A, B, C, D = _with_motor(motor, op, plant, A, Bm, Hx, Hu, T, in_names, out_names, obs_index)
        state_names.append("current")
    sys = control.ss(A, B, C, D, states=state_names, inputs=[_input_label(k) for k in in_names],
                     outputs=out_names, name=model.name or "mechanism")
    sys.operating_point = op
    sys.motor = motor
    sys.units = {**{s: signal_unit(s) for s in state_names + out_names},
                 **{_input_label(k): input_unit(k, model) for k in in_names}}
    return sys


def _input_label(key: str) -> str:
    return {DRIVE: "tau_drive", LOAD: "tau_load", VOLTAGE: "voltage"}[key]


def _with_motor(motor, op, plant, A, Bm, Hx, Hu, T, in_names, out_names, obs_index):
    """Append the winding current: tau_drive = tau(i, w(x)), L di/dt = v - R i - k_e N w(x)."""
    from grubler.motors import MotorState, linearization

    n, drive = plant.n, plant.model.arrays.drive
    lin = linearization(motor, MotorState(op.current, motor.ambient_temperature), op.zd[drive])
    dw = T[n + drive]  # d(drive speed)/dx along the manifold
    nx = A.shape[0]
    Aa = np.zeros((nx + 1, nx + 1))
    Aa[:nx, :nx] = A + np.outer(Bm[:, 0], lin.dtau_dspeed * dw)
    Aa[:nx, nx] = Bm[:, 0] * lin.dtau_di
    Aa[nx, :nx] = lin.di_dspeed * dw
    Aa[nx, nx] = lin.di_di
    cols = {VOLTAGE: np.r_[np.zeros(nx), lin.di_dvoltage], LOAD: np.r_[Bm[:, 1], 0.0]}
    B = np.column_stack([cols[k] for k in in_names])
    C, D = [], []
    for o in out_names:
        if o == "current":
            C.append(np.r_[np.zeros(nx), 1.0])
            D.append([0.0] * len(in_names))
            continue
        i = obs_index[o]
        C.append(np.r_[Hx[i] + Hu[i, 0] * lin.dtau_dspeed * dw, Hu[i, 0] * lin.dtau_di])
        D.append([Hu[i, 1] if k == LOAD else 0.0 for k in in_names])
    return Aa, B, np.array(C), np.array(D)


# -- reports ------------------------------------------------------------------------
def summary(sys) -> str:
    """Poles, zeros, natural frequencies, damping ratios and DC gains with units, for people."""
    import control

    units = getattr(sys, "units", {})
    lines = []
    op = getattr(sys, "operating_point", None)
    if op is not None:
        at = op.kind + (f" at t = {op.time:g} s" if op.time is not None else "")
        coords = ", ".join(f"{k} = {coordinate_text(k, op.coordinates[k], radians=True)}" for k in op.independent)
        lines.append(f"operating point: {at}: {coords}; drive effort {op.drive:.6g} {op.effort_units['drive']}, "
                     f"load effort {op.load:.6g} {op.effort_units['load']}")
        if op.current is not None:
            lines.append(f"motor: {op.current:.6g} A at {op.voltage:.6g} V")
        if op.kind != "equilibrium":
            lines.append(f"  (not an equilibrium: accelerations {_accelerations(op.independent, op.acceleration)})")
    lines.append("states: " + ", ".join(f"{s} [{units.get(s, '')}]" for s in sys.state_labels))
    lines.append("poles, rad/s (natural frequency, damping ratio):")
    wn, zeta, poles = control.damp(sys, doprint=False)
    for p, w, z in sorted(zip(poles, wn, zeta), key=lambda t: abs(t[0])):
        # (+ 0.0 turns a negative zero, an undamped pole's, into a plain one)
        lines.append(f"  {p.real + 0.0:+.6g} {p.imag + 0.0:+.6g}j   wn = {w:.6g} rad/s ({w / (2 * math.pi):.6g} Hz), "
                     f"zeta = {z + 0.0:.4g}")
    for i, out in enumerate(sys.output_labels):
        for j, inp in enumerate(sys.input_labels):
            sub = sys[i, j]
            try:
                zeros = sub.zeros()
            except Exception:  # noqa: BLE001 - python-control's zero finder; report instead of failing
                zeros = None
            ztxt = "none" if zeros is not None and len(zeros) == 0 else (
                "?" if zeros is None else ", ".join(f"{z.real:+.6g}{z.imag:+.6g}j" for z in zeros) + " rad/s")
            with np.errstate(divide="ignore", invalid="ignore"):
                try:
                    g = complex(np.squeeze(sub.dcgain())).real
                except Exception:  # noqa: BLE001 - a pole at zero: the gain is infinite
                    g = math.inf
            per = units.get(inp, "")
            lines.append(f"{inp} -> {out}: zeros {ztxt}; DC gain {g:.6g} "
                         f"{units.get(out, '')}/{f'({per})' if ' ' in per else per}")
    return "\n".join(lines)


BODE_SUFFIXES = (".png", ".pdf", ".svg")  # what --bode writes


def frequency_response(sys, omega: np.ndarray) -> np.ndarray:
    """G(j w) = C (j w I - A)^-1 B + D at each ``omega`` (rad/s): outputs x inputs x frequencies."""
    A, B, C, D = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    eye = np.eye(A.shape[0])
    return np.stack([C @ np.linalg.solve(1j * w * eye - A, B) + D for w in omega], axis=-1)


def phase_deg(g: np.ndarray) -> np.ndarray:
    """The phase of a frequency response, deg, unwrapped along frequency and placed by its
    low-frequency end: near 0 where the gain there is positive, near -180 where it is
    negative (and -90 under an integrator), rather than wherever the arctangent left it."""
    phase = np.degrees(np.unwrap(np.angle(g)))
    target = 0.0 if g[0].real >= 0 else -180.0
    return phase - 360.0 * np.round((phase[0] - target) / 360.0)


def plot_bode(sys, path: str) -> None:
    """Bode plot of every input-output pair (:func:`bode_figure`) to a PNG, PDF or SVG file."""
    import matplotlib.pyplot as plt

    fig = bode_figure(sys)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def bode_figure(sys):
    """The Bode plot of every input-output pair as a matplotlib Figure: magnitude in dB of
    the pair's own unit, phase in degrees (:func:`phase_deg`), the poles' natural
    frequencies marked, a title with the operating point, the motor and its ratio, and
    under it a note when the plant is open-loop unstable."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator, MultipleLocator

    units = getattr(sys, "units", {})
    poles = np.asarray(sys.poles())
    # a decade beyond the slowest and the fastest pole: python-control's own
    # choice misses the winding's pole three decades above the mechanism's
    corners = np.abs(poles)
    corners = corners[corners > 1e-9] if np.any(corners > 1e-9) else np.array([1.0])
    omega = np.logspace(np.log10(corners.min() / 10), np.log10(corners.max() * 10), 800)
    G = frequency_response(sys, omega)
    growing = poles.real > 1e-9 * max(1.0, corners.max())  # (a rounding's worth right of the axis is not)
    outs, ins = list(sys.output_labels), list(sys.input_labels)
    fig, axes = plt.subplots(2 * len(outs), len(ins), sharex=True, squeeze=False, layout="constrained",
                             figsize=(7.5 * len(ins), 1.4 + 3.6 * len(outs)))
    for i, out in enumerate(outs):
        for j, inp in enumerate(ins):
            g, ax_mag, ax_ph = G[i, j], axes[2 * i, j], axes[2 * i + 1, j]
            per = units.get(inp, "")
            unit = f"{units.get(out, '')}/{f'({per})' if ' ' in per else per}"
            with np.errstate(divide="ignore"):
                ax_mag.semilogx(omega, 20 * np.log10(np.abs(g)), color="C0", lw=1.6)
            phase = phase_deg(g)
            ax_ph.semilogx(omega, phase, color="C1", lw=1.6)
            ax_mag.set_title(f"{inp} -> {out}", fontsize=10)
            ax_mag.set_ylabel(f"magnitude, dB re 1 {unit}", fontsize=9)
            ax_ph.set_ylabel("phase, deg", fontsize=9)
            ax_mag.yaxis.set_major_locator(MaxNLocator(nbins=7, steps=[1, 2, 2.5, 5, 10]))
            ax_ph.yaxis.set_major_locator(MultipleLocator(45 if np.ptp(phase) <= 270 else 90))
            for ax in (ax_mag, ax_ph):
                ax.grid(True, which="major", alpha=0.5)
                ax.grid(True, which="minor", alpha=0.15)
                for p, bad in zip(poles, growing):  # an unstable pole's in red
                    ax.axvline(abs(p), color="firebrick" if bad else "0.4", ls=":", lw=0.9)
    for ax in axes[-1]:
        ax.set_xlabel("frequency, rad/s  (dotted: the poles' natural frequencies, an unstable one's red)",
                      fontsize=9)
    fig.suptitle(_bode_title(sys), fontsize=10)
    unstable = poles[growing]
    if len(unstable):
        import textwrap

        note = ("open-loop unstable: pole" + ("s" if len(unstable) > 1 else "") + " at "
                + ", ".join(f"{p.real:+.4g}{p.imag:+.4g}j" if p.imag else f"{p.real:+.4g}" for p in unstable)
                + " rad/s; no gain or phase margin can be read from this plot (use the Nyquist criterion "
                "or the closed loop's poles)")
        fig.supxlabel("\n".join(textwrap.wrap(note, 95)), fontsize=9, color="firebrick")
    return fig


def _bode_title(sys) -> str:
    """Scene, operating point, and motor with its ratio, for the plot's title."""
    op = getattr(sys, "operating_point", None)
    lines = [f"{sys.name}: linear model"]
    if op is not None:
        at = op.kind + (f" at t = {op.time:g} s" if op.time is not None else "")
        coords = ", ".join(f"{k} = {coordinate_text(k, op.coordinates[k], 4)}" for k in op.independent)
        lines[0] += f" about the {at}, {coords}, drive effort {op.drive:.4g} {op.effort_units['drive']}"
    motor = getattr(sys, "motor", None)
    if motor is not None:
        lines.append(f"motor {motor.data.name} through {motor.gear.ratio:g}:1 ({motor.gear.efficiency:.0%}), "
                     f"{op.current:.3g} A at {op.voltage:.3g} V" if op is not None else "")
    return "\n".join(lines)


def to_json(sys) -> dict:
    """A, B, C, D (lists of rows), the names, units and the operating point."""
    op = getattr(sys, "operating_point", None)
    return {"A": np.asarray(sys.A).tolist(), "B": np.asarray(sys.B).tolist(), "C": np.asarray(sys.C).tolist(),
            "D": np.asarray(sys.D).tolist(), "states": list(sys.state_labels), "inputs": list(sys.input_labels),
            "outputs": list(sys.output_labels), "units": dict(getattr(sys, "units", {})),
            "operating_point": op.as_dict() if op is not None else None}


__all__ = ["OperatingPoint", "linearize", "operating_point", "output_names", "plot_bode", "bode_figure",
           "frequency_response", "phase_deg", "summary", "to_json",
           "input_unit", "signal_unit"]
