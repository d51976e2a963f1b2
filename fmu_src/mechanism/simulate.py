"""Running a mechanism: the simulator (state + integrator) and its results.

:class:`Simulator` is what the CLI, the FMU slave and the benchmarks drive: it
holds the state of one run (joint coordinates and rates, the integrator, the
current inputs) over an immutable :class:`~grubler.mechanism.model.Mechanism`, advances to any
time, and evaluates only the output groups that are asked for.

Examples
--------
>>> res = simulate("thesis-fourbar", t_end=0.5, dt_out=0.1)
>>> res.columns[:4]
['t', 'B1', 'theta2', 'B2']
>>> bool(abs(res["closure_error"]).max() < 1e-9)
True
"""

from __future__ import annotations

import csv
import functools
import math
from dataclasses import dataclass, field
from typing import Callable, Iterable

import numpy as np

from grubler import binding
from grubler.quantities import ACTUATOR_OUTPUTS, FORCE_OUTPUTS, mechanism_output
from grubler.mechanism.assembly import POSITION_TOL, assemble
from grubler.mechanism.analysis import explain_singular_start
from grubler.mechanism.dynamics import (EXACT, METHOD_CODE, METHODS, PENALTY, Inputs, actuator_forces,
                                        forward_dynamics, observation_names, put_actuator_forces)
from grubler.errors import Cancelled, IntegrationError, LimitError, SceneError
from grubler.mechanism.integrators import Integrator, StateEquation, StepBudgetError
from grubler.limits import check_size, number, open_output
from grubler.mechanism.model import Mechanism, coordinate_names
from grubler.mechanism.scene import Scene, load_scene

# Output groups.  One compiled forward-dynamics evaluation (about a microsecond)
# serves 'state', 'dynamics' and 'energy' alike; only 'reactions' adds work, a
# Newton-Euler pass, and only when asked for.  The joint coordinates and rates
# need no evaluation at all: they are the stored states.
GROUPS = ("state", "dynamics", "energy", "reactions", "actuators", "forces")
DEFAULT_GROUPS = ("state", "dynamics", "energy", "actuators", "forces")
# each actuator's columns: <name>_length, _rate (kinematics), _force (the input), _power (force x rate);
# each force element's: its kind's (grubler.quantities.FORCE_OUTPUTS), from the state alone

DEFAULT_RTOL = 1e-9
DEFAULT_ATOL = 1e-9


def output_columns(model: Mechanism, groups: Iterable[str] = DEFAULT_GROUPS) -> list[str]:
    """Column names, in CSV order, for the chosen output groups.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> grubler.output_columns(m, ["energy"])
    ['t', 'KE', 'PE', 'E']
    >>> grubler.output_columns(m, ["state"])[-3:]
    ['tip_x', 'tip_y', 'closure_error']
    """
    return list(_columns(model.n_links, frozenset(groups), len(model.closures), tuple(model.actuator_names),
                         force_kinds(model)))


def force_kinds(model: Mechanism) -> tuple[tuple[str, str], ...]:
    """Each force element's name and kind (its scene table: 'spring', 'joint_spring', 'point_load')."""
    return tuple((e.name, e.table) for e in model.forces)


@functools.lru_cache(maxsize=64)
def _columns(n_links: int, groups: frozenset, n_closures: int = 1, actuators: tuple[str, ...] = (),
             forces: tuple[tuple[str, str], ...] = ()) -> tuple[str, ...]:
    names = coordinate_names(n_links)
    cols = ["t"]
    if "state" in groups:
        cols += names + [f"{x}_d" for x in names]
    if "dynamics" in groups:
        cols += [f"{x}_dd" for x in names]
    if "state" in groups:
        cols += ["tip_x", "tip_y", "closure_error"]
    if "dynamics" in groups:
        cols += ["Fx", "Fy", "Mz"]
    if "energy" in groups:
        cols += ["KE", "PE", "E"]
    if "dynamics" in groups:
        cols += ["tau_drive", "P_drive"]
    if "reactions" in groups:
        for k in range(1, n_links + 1):
            cols += [f"R{k}_Fx", f"R{k}_Fy", f"R{k}_Mz"]
        # the first closure's force is Fx, Fy, Mz; the others' are closureJ_*
        for j in range(1, n_closures):
            cols += [f"closure{j}_Fx", f"closure{j}_Fy", f"closure{j}_Mz"]
    if "actuators" in groups:
        cols += [f"{a}_{q.name}" for a in actuators for q in ACTUATOR_OUTPUTS]
    if "forces" in groups:
        cols += [f"{e}_{q.name}" for e, table in forces for q, _ in FORCE_OUTPUTS[table]]
    return tuple(cols)


def unit_of(column: str) -> str:
    """Unit of an output column, for labels ('' for a name that is no output of a mechanism).

    One table says it (:func:`grubler.quantities.mechanism_output`); an
    actuator's column is known by its last part.
    """
    q = mechanism_output(column)
    if q is not None:
        return q.unit
    known = [*ACTUATOR_OUTPUTS, *(q for outputs in FORCE_OUTPUTS.values() for q, _ in outputs)]
    return next((q.unit for q in known if column.endswith(f"_{q.name}")), "")


@functools.lru_cache(maxsize=64)
def _observed(n_links: int, groups: frozenset) -> tuple[tuple[str, int], ...]:
    """(column, index in the observation vector) of the groups' columns, in CSV order."""
    index = {name: i for i, name in enumerate(observation_names(n_links))}
    return tuple((c, index[c]) for c in _columns(n_links, groups) if c != "t" and c in index)


def evaluate(model: Mechanism, method: str, t: float, z: np.ndarray, zd: np.ndarray, inputs: Inputs,
             groups: Iterable[str] = DEFAULT_GROUPS, work: np.ndarray | None = None) -> dict[str, float]:
    """Outputs at one state; only the requested groups are computed.

    One compiled evaluation of the equations of motion and the outputs; the joint
    reactions (a Newton-Euler pass) only when 'reactions' is asked for.  ``work``
    is a kernel workspace to reuse (:func:`grubler.binding.work`).

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> out = grubler.evaluate(m, "exact", 0.0, m.z_from_q(m.q_ref), [0.0, 0.0, 0.0], grubler.Inputs(drive=3.0))
    >>> round(out["theta2_dd"], 3), round(out["Fy"], 3), bool(out["closure_error"] < 1e-12)
    (-10.359, 28.596, True)
    """
    groups = frozenset(groups)
    n = model.n_links
    if work is None:
        work = binding.work(n, len(model.closures))
    put_actuator_forces(model, work, inputs)
    y = np.empty(2 * n)
    y[:n], y[n:] = z, zd
    values = np.zeros(9 * n + 11)
    status = binding.library().grb_observe(model.arrays.c, METHOD_CODE[method], binding.address(y),
                                           float(inputs.drive), float(inputs.load), "reactions" in groups,
                                           binding.address(work), binding.address(values))
    if status != binding.OK and groups & {"dynamics", "energy", "reactions"}:
        raise np.linalg.LinAlgError("Singular matrix")
    values = values.tolist()
    out: dict[str, float] = {"t": t}
    for column, i in _observed(n, groups):
        out[column] = values[i]
    if "reactions" in groups and len(model.closures) > 1:
        for j, f in enumerate(closure_forces(model, method, z, zd, inputs)[1:], start=1):
            out[f"closure{j}_Fx"], out[f"closure{j}_Fy"], out[f"closure{j}_Mz"] = f
    if "actuators" in groups and model.actuators:
        lines = actuator_lines(model, y[None, :], work)[0]
        for a, force in zip(model.actuators, actuator_forces(model, inputs)):
            length, rate = lines[model.actuators.index(a)]
            out.update({f"{a.name}_length": length, f"{a.name}_rate": rate, f"{a.name}_force": force,
                        f"{a.name}_power": force * rate})
    if "forces" in groups and model.forces:
        out.update({c: float(v[0]) for c, v in force_outputs(model, y[None, :], work).items()})
    return out


def force_outputs(model: Mechanism, y: np.ndarray, work: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Each force element's output columns (its kind's, :data:`~grubler.quantities.FORCE_OUTPUTS`) at states
    ``y`` (rows x 2N): the kernel's ``grb_force_rows``, from the state alone."""
    y = np.ascontiguousarray(y, dtype=float)
    out = np.empty((y.shape[0], len(model.forces), binding.FORCE_OUTPUTS))
    if work is None:
        work = binding.work(model.n_links, len(model.closures))
    status = binding.library().grb_force_rows(model.arrays.c, y.shape[0], binding.address(y), binding.address(work),
                                              binding.address(out))
    if status != binding.OK:
        raise ValueError(f"force elements: {binding.status_message(status)}")
    return {f"{e.name}_{q.name}": out[:, j, k].copy() for j, e in enumerate(model.forces)
            for q, k in FORCE_OUTPUTS[e.table]}


def actuator_lines(model: Mechanism, y: np.ndarray, work: np.ndarray | None = None) -> np.ndarray:
    """Each actuator's length (m) and rate (m/s) at states ``y`` (rows x 2N): shape (rows, A, 2).

    Kinematics only: the kernel's ``grb_actuator_lines``.
    """
    y = np.ascontiguousarray(y, dtype=float)
    out = np.empty((y.shape[0], len(model.actuators), 2))
    if work is None:
        work = binding.work(model.n_links, len(model.closures))
    status = binding.library().grb_actuator_lines(model.arrays.c, y.shape[0], binding.address(y),
                                                  binding.address(work), binding.address(out))
    if status != binding.OK:
        raise ValueError(f"actuators: {binding.status_message(status)}")
    return out


def closure_forces(model: Mechanism, method: str, z, zd, inputs: Inputs) -> np.ndarray:
    """Force (world frame) and moment every closure exerts on its closing link, (C, 3).

    Row 0 is what ``Fx, Fy, Mz`` report; a mechanism of several loops (a six-bar)
    reads the others here.  From the closure multipliers of one forward-dynamics
    evaluation: the pin's force, or a line's normal force and holding moment.
    """
    dyn = forward_dynamics(model, np.asarray(z, float), np.asarray(zd, float), inputs, method)
    out = np.empty((len(model.closures), 3))
    for j in range(len(model.closures)):
        lam = dyn.lam[2 * j:2 * j + 2]
        out[j, :2] = dyn.ck.force_dir[j] @ lam
        out[j, 2] = dyn.ck.moment_row[j] @ lam
    return out


TorqueLike = float | Callable[[float], float]

CLOSURE_WARNING = 0.05
"""A loop open by more than this fraction of the mechanism's size (:func:`mechanism_size`)
is warned of.  The penalty closure is compliant by design: over 1 s at their own
efforts and the default gain it opens the loops of the presets that start closed by
0.2 % (quick-return) to 9 % (the Oldham coupling: 1.8 mm on its 20 mm offset); a
large effort pulls the joints apart (a four-bar under 1e4 N m: 170 %), and the
motion then no longer describes the linkage."""


def mechanism_size(model: Mechanism) -> float:
    """The mechanism's size, m: its longest link, ground vector or closure offset (1 m if all are 0)."""
    sizes = [abs(link.a) for link in model.links] + [abs(model.a1)]
    for c in model.closures:
        sizes += [math.hypot(*c.point), math.hypot(*c.to_point)]
    return max(sizes) or 1.0


def used_up_gas(model: Mechanism, z: np.ndarray) -> tuple[int, float, float] | None:
    """The first gas spring whose gas column is used up at the configuration ``z``: (its index, its column
    gas_column + length - free_length, m, its length, m); None when every column is positive.

    There its force is not finite: a run cannot start there, nor a drive demand be met."""
    springs = [(j, e) for j, e in enumerate(model.forces) if e.table == "spring" and e.gas_force > 0]
    if not springs:
        return None
    y = np.concatenate([z, np.zeros_like(z)])[None, :]
    outputs = force_outputs(model, y)
    for j, e in springs:
        length = float(outputs[f"{e.name}_length"][0])
        h = e.gas_column + length - e.free_length
        if not h > 0:
            return j, h, length
    return None


def _check_gas_columns(model: Mechanism, z: np.ndarray) -> None:
    """A gas spring whose gas column is used up at the start has no finite force to start from."""
    used = used_up_gas(model, z)
    if used is not None:
        j, h, length = used
        raise SceneError(f"{model.force_field(j)}.gas_column",
                         f"the gas is used up at the start: its column gas_column + length - free_length is "
                         f"{h:.4g} m at the start's length {length:.4g} m; a gas spring needs a positive column")


def closure_warnings(model: Mechanism, t: np.ndarray, closure_error: np.ndarray) -> list[str]:
    """Warning lines for a loop open beyond :data:`CLOSURE_WARNING` of the mechanism's size: at the start, and after.

    The penalty method starts from the scene's coordinates as they are (the exact
    one assembles them first), so a start that is only a sketch is open at t = 0.
    """
    if not model.closures or not len(t):
        return []
    size = mechanism_size(model)
    unit = "m" if all(c.kind == "revolute" for c in model.closures) else "m or rad"
    out = []
    for where, errors, times in (("start", closure_error[:1], t[:1]), ("run", closure_error[1:], t[1:])):
        if not len(errors):
            continue
        k = int(np.argmax(errors))
        worst = float(errors[k])
        if worst <= CLOSURE_WARNING * size:  # (a NaN warns too)
            continue
        share = f"{100 * worst / size:.3g} % of the mechanism's size {size:.3g} m (tolerance {100 * CLOSURE_WARNING:g} %)"
        if where == "start":
            out.append(f"closure: the start is open by {worst:.3g} {unit}, {share}: the penalty method starts from "
                       "the scene's coordinates as they are, so what follows at first is the loop snapping shut")
        else:
            out.append(f"closure: the loop opened by up to {worst:.3g} {unit} at t = {times[k]:.4g} s, {share}: the "
                       "motion does not describe the linkage; use the exact method, or a stiffer closure.gain")
    return out


def _check_actuator_lengths(model: Mechanism, z: np.ndarray) -> None:
    """An actuator of zero length at the start has no line for its force to act along."""
    if not model.actuators:
        return
    y = np.concatenate([z, np.zeros(model.n_free)])[None, :]
    lengths = actuator_lines(model, y)[0, :, 0]
    for j, (act, length) in enumerate(zip(model.actuators, lengths)):
        if not length > 1e-9 * mechanism_size(model):
            raise SceneError(f"actuator[{j}].to_point",
                             f"{act.name}'s two points coincide at the start (length {length:.3g} m): its force "
                             "has no line to act along; move from_point or to_point")


def default_integrator(method: str) -> str:
    """The integrator a closure method runs with unless told: the penalty springs make the equations stiff."""
    return "radau" if method == PENALTY else "dop853"


def _check_penalty_inertia(model: Mechanism, z: np.ndarray) -> None:
    """The penalty springs act through inertia: every real coordinate needs some."""
    dyn = forward_dynamics(model, z, np.zeros(model.n_free), Inputs(), EXACT)
    w, V = np.linalg.eigh(dyn.M)
    if w[0] <= 1e-12 * w[-1]:
        i = int(np.argmax(np.abs(V[:, 0])))
        name = model.free_names[i]
        link = f"link{i + 2}"
        raise SceneError(
            "method",
            f"the penalty closure cannot move {name}: it carries no inertia ({link} has I = 0 and its "
            f"mass centre on its joint), so the imaginary joint's spring would accelerate it without "
            f"bound; give {link}.I a positive value or use the exact closure")


@dataclass
class Simulator:
    """One run of a mechanism: state, inputs and integrator over a fixed model.

    Parameters
    ----------
    model : Mechanism
    method : {'exact', 'penalty'}
    rtol, atol : float
        Integration tolerances (adaptive integrators).
    integrator : {'dop853', 'rk45', 'rk4'}
    step : float
        Fixed step for 'rk4', s.
    z0, zd0 : ndarray, optional
        Initial joint coordinates and rates; default from the model's q_ref.
        The exact method assembles them (holding the drive coordinate).
    t0 : float
        Start time, s.
    max_step : float
        Largest internal step, s.

    Examples
    --------
    >>> import grubler
    >>> sim = grubler.Simulator(grubler.load_scene("thesis-fourbar").mechanism)
    >>> sim.set_inputs(drive=3.0)
    >>> sim.advance_to(0.1)
    >>> round(sim.t, 6), sim.z.round(4)
    (0.1, array([-0.0518,  1.1117, -2.0939]))
    >>> round(sim.outputs(["state"])["theta2"], 4)      # 3 N m does not hold the crank up against gravity
    -0.0518
    """

    model: Mechanism
    method: str = EXACT
    rtol: float = DEFAULT_RTOL
    atol: float = DEFAULT_ATOL
    integrator: str | None = None
    step: float = 1e-3
    z0: np.ndarray | None = None
    zd0: np.ndarray | None = None
    t0: float = 0.0
    max_step: float = math.inf
    inputs: Inputs = field(default_factory=Inputs)
    drive_function: Callable[[float], float] | None = None

    def __post_init__(self):
        if self.method not in METHODS:
            raise SceneError("method", f"must be one of {', '.join(METHODS)}, got {self.method!r}")
        if self.integrator is None:
            self.integrator = default_integrator(self.method)
        m = self.model
        z = m.z_from_q(m.q_ref) if self.z0 is None else np.asarray(self.z0, float)
        zd = np.zeros(m.n_free) if self.zd0 is None else np.asarray(self.zd0, float)
        if self.method == EXACT:
            z, zd = assemble(m, z, zd)
        elif m.n_constraints:
            _check_penalty_inertia(m, z)
        _check_actuator_lengths(m, z)
        _check_gas_columns(m, z)
        self._n = m.n_free
        ode = StateEquation(m, self.method, self.inputs.drive, self.inputs.load, drive_function=self.drive_function,
                            project_state=self.method == EXACT and m.n_constraints > 0,
                            scale=max([1.0] + [abs(l.a) for l in m.links]))
        self._integ = Integrator(ode, self.t0, np.concatenate([z, zd]), method=self.integrator,
                                 rtol=self.rtol, atol=self.atol, h=self.step if self.integrator == "rk4" else 0.0,
                                 h_max=self.max_step)
        ode.set_actuator_forces(actuator_forces(m, self.inputs))

    # -- the ODE -------------------------------------------------------------
    def _inputs_at(self, t: float) -> Inputs:
        if self.drive_function is None:
            return self.inputs
        return Inputs(float(self.drive_function(t)), self.inputs.load, self.inputs.actuators)

    def _rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """The state equation at (t, y): ``(zd, zdd)``."""
        return self._integ.ode(t, y)

    # -- state ---------------------------------------------------------------
    @property
    def t(self) -> float:
        return self._integ.t

    @property
    def z(self) -> np.ndarray:
        return self._integ.y[: self._n]

    @property
    def zd(self) -> np.ndarray:
        return self._integ.y[self._n :]

    def joint_state(self, i: int) -> tuple[float, float]:
        """Coordinate and rate of real coordinate ``i``, as floats (what a motor model reads)."""
        y = self._integ.y
        return float(y[i]), float(y[self._n + i])

    def set_inputs(self, drive: float | None = None, load: float | None = None, actuators=None) -> None:
        """Change the efforts (``actuators``: every actuator's force, N, in the model's order); they hold until
        changed again."""
        drive = self.inputs.drive if drive is None else float(drive)
        load = self.inputs.load if load is None else float(load)
        forces = self.inputs.actuators if actuators is None else tuple(float(f) for f in actuators)
        if drive != self.inputs.drive or load != self.inputs.load or forces != self.inputs.actuators:
            self.inputs = Inputs(drive, load, forces)
            self._integ.ode.drive, self._integ.ode.load = drive, load
            self._integ.ode.set_actuator_forces(actuator_forces(self.model, self.inputs))
            self._integ.reset_derivative()

    def advance_to(self, t: float) -> None:
        """Integrate to time ``t`` (it sub-steps to its own tolerance)."""
        ode = self._integ.ode
        ode.drive, ode.load = self.inputs.drive, self.inputs.load
        self._integ.advance_to(t)

    def advance_through(self, times: Iterable[float]) -> tuple[np.ndarray, np.ndarray]:
        """Integrate through increasing ``times``; the joint coordinates and rates at each.

        One call into the compiled integrator for the whole grid (``simulate`` uses
        it).  DOP853 takes the steps of one :meth:`advance_to` to the last time and
        interpolates the others (its continuous extension, then projected onto the
        closures), so a fine grid costs interpolations, not steps; so do scipy's
        Radau and BDF on the penalty closure.  RK45, RK4, and scipy's solvers on the
        exact closure (projected where they stop) end a step at each time.

        Returns
        -------
        z, zd : ndarray, shape (len(times), N)
        """
        ode = self._integ.ode
        ode.drive, ode.load = self.inputs.drive, self.inputs.load
        states = self._integ.advance_through(np.asarray(list(times) if not isinstance(times, np.ndarray) else times,
                                                        dtype=float))
        return states[:, : self._n].copy(), states[:, self._n :].copy()

    def outputs(self, groups: Iterable[str] = DEFAULT_GROUPS) -> dict[str, float]:
        return evaluate(self.model, self.method, self.t, self.z, self.zd, self._inputs_at(self.t), groups,
                        self._integ.ode.work)

    def snapshot(self) -> dict:
        """The whole run state, for rollback."""
        return {"integ": self._integ.snapshot(),
                "inputs": (self.inputs.drive, self.inputs.load, self.inputs.actuators)}

    def restore(self, snap: dict) -> None:
        self._integ.restore(snap["integ"])
        self.inputs = Inputs(*snap["inputs"])
        self._integ.ode.set_actuator_forces(actuator_forces(self.model, self.inputs))

    @property
    def stats(self) -> dict[str, int]:
        i = self._integ
        return {"steps": i.n_steps, "rejected": i.n_rejected, "rhs_evals": i.n_evals,
                "passages": list(i.passages), "passage_count": i.n_passages,
                "charts": i.n_charts}


@dataclass
class Result:
    """A trajectory: joint states at output times, outputs computed on demand.

    Index it by column name (``res['theta2']``) to get an array.  Coordinates
    and rates are read from the stored states; the other columns of a group
    ('state', 'dynamics', 'energy', 'reactions') are computed on first use, in
    one pass of the kernel over every output time.

    ``warnings`` lists, one line each (``field: reason``), what makes the run
    less than it was asked to be: a loop left open beyond
    :data:`CLOSURE_WARNING` of the mechanism's size, a step that was not the
    one given.  ``grubler simulate`` prints them as ``warning:`` lines.

    Examples
    --------
    >>> import grubler
    >>> res = grubler.simulate("thesis-fourbar", t_end=0.1, dt_out=0.05)
    >>> res.t
    array([0.  , 0.05, 0.1 ])
    >>> res["theta2"].round(4), res.columns[:4]
    (array([ 0.    , -0.0291, -0.1153]), ['t', 'B1', 'theta2', 'B2'])
    >>> bool(res["closure_error"].max() < 1e-10), res.warnings
    (True, [])
    """

    model: Mechanism
    method: str
    t: np.ndarray
    z: np.ndarray
    zd: np.ndarray
    inputs_at: Callable[[float], Inputs]
    stats: dict
    constant_inputs: Inputs | None = None  # the efforts when they do not change with time
    warnings: list[str] = field(default_factory=list)  # why the result may not be what was asked, one line each
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def columns(self) -> list[str]:
        return output_columns(self.model, DEFAULT_GROUPS)

    def _group_of(self, column: str) -> str:
        for g in GROUPS:
            if column in output_columns(self.model, (g,)):
                return g
        raise KeyError(f"{column!r}: no such output; columns are {', '.join(output_columns(self.model, GROUPS))}")

    def _coordinate(self, column: str) -> np.ndarray | None:
        """A coordinate or rate column straight from the stored states (None for others)."""
        names = self.model.coordinate_names
        base, rate = (column[:-2], True) if column.endswith("_d") else (column, False)
        if base not in names:
            return None
        i = names.index(base)
        S = self.model.S[i]
        if rate:
            return self.zd @ S
        return self.model.q_from_z(np.zeros(self.model.n_free))[i] + self.z @ S

    def compute(self, groups: Iterable[str]) -> None:
        """Evaluate output groups at every output time (cached): one kernel pass."""
        todo = [g for g in groups if g not in self._cache]
        if not todo:
            return
        m, n, rows = self.model, self.model.n_links, len(self.t)
        y = np.ascontiguousarray(np.hstack([self.z, self.zd]), dtype=float)
        width = 9 * n + 11
        values, work = np.zeros((rows, width)), binding.work(n, len(m.closures))
        # the actuators' forces are constant through a run (only the drive may follow a function of time)
        held = self.constant_inputs or (self.inputs_at(float(self.t[0])) if rows else Inputs())
        forces = actuator_forces(m, held)
        if "actuators" in todo:
            lines = actuator_lines(m, y, work)
            self._cache["actuators"] = {}
            for a, act in enumerate(m.actuators):
                self._cache["actuators"].update({
                    f"{act.name}_length": lines[:, a, 0].copy(), f"{act.name}_rate": lines[:, a, 1].copy(),
                    f"{act.name}_force": np.full(rows, forces[a]), f"{act.name}_power": forces[a] * lines[:, a, 1]})
            todo = [g for g in todo if g != "actuators"]
            if not todo:
                return
        if "forces" in todo:
            self._cache["forces"] = force_outputs(m, y, work) if m.forces else {}
            todo = [g for g in todo if g != "forces"]
            if not todo:
                return
        put_actuator_forces(m, work, held)
        if self.constant_inputs is not None:
            tau, drive, load = None, float(self.constant_inputs.drive), float(self.constant_inputs.load)
        else:
            inputs = [self.inputs_at(float(t)) for t in self.t]
            tau = np.ascontiguousarray([i.drive for i in inputs], dtype=float)
            drive, load = 0.0, float(inputs[0].load) if inputs else 0.0
        status = binding.library().grb_observe_rows(
            m.arrays.c, METHOD_CODE[self.method], rows, binding.address(y),
            None if tau is None else binding.address(tau), drive, load, "reactions" in todo,
            binding.address(work), binding.address(values))
        if status != binding.OK and set(todo) & {"dynamics", "energy", "reactions"}:
            raise np.linalg.LinAlgError("Singular matrix")
        index = {name: i for i, name in enumerate(observation_names(n))}
        for g in todo:
            cols = [c for c in output_columns(m, (g,)) if c != "t" and c in index]
            self._cache[g] = {c: values[:, index[c]].copy() for c in cols}
        if "reactions" in todo and len(m.closures) > 1:
            inputs = [self.constant_inputs or self.inputs_at(float(t)) for t in self.t]
            forces = np.array([closure_forces(m, self.method, z, zd, i)
                               for z, zd, i in zip(self.z, self.zd, inputs)])
            for j in range(1, len(m.closures)):
                for c, name in enumerate(("Fx", "Fy", "Mz")):
                    self._cache["reactions"][f"closure{j}_{name}"] = forces[:, j, c].copy()

    def __getitem__(self, column: str) -> np.ndarray:
        if column == "t":
            return self.t
        g = self._group_of(column)
        if g not in self._cache:
            values = self._coordinate(column)
            if values is not None:
                return values
        self.compute([g])
        return self._cache[g][column]

    def table(self, groups: Iterable[str] = DEFAULT_GROUPS) -> tuple[list[str], np.ndarray]:
        groups = list(groups)
        self.compute(groups)
        cols = output_columns(self.model, groups)
        return cols, np.column_stack([self[c] for c in cols])

    def to_csv(self, path, groups: Iterable[str] = DEFAULT_GROUPS) -> None:
        from grubler.records import column_heading

        cols, data = self.table(groups)
        with open_output(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([column_heading(c, unit_of(c)) for c in cols])
            for row in data:
                w.writerow([repr(float(x)) for x in row])


def simulate(
    scene: Scene | str,
    t_end: float | None = None,
    dt_out: float | None = None,
    method: str | None = None,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    integrator: str | None = None,
    step: float | None = None,
    torque: TorqueLike | None = None,
    load_torque: float | None = None,
    cancel=None,
    actuator_forces: dict[str, float] | None = None,
) -> Result:
    """Simulate a scene and return its trajectory.

    Parameters
    ----------
    scene : Scene or str
        A scene, or a preset name / TOML file path.
    t_end, dt_out : float, optional
        Run length and output interval, s (default: the scene's).
    method : {'exact', 'penalty'}, optional
        Closure method (default: the scene's).
    rtol, atol : float
        Integration tolerances.
    integrator : {'dop853', 'rk45', 'rk4', 'radau', 'bdf'}, optional
        Default: 'dop853' for the exact closure, 'radau' for the stiff penalty one.
    step : float, optional
        Fixed step for 'rk4', s (default 1 ms).  RK4 ends a step at every output
        time, so a step longer than ``dt_out`` is cut to it (a warning says so);
        the other integrators choose their own steps (given one, a warning says
        it was not used).
    torque : float or callable, optional
        Drive effort (N m, or N on a slide), constant or a function of time.
    load_torque : float, optional
    cancel : threading.Event, optional
        Anything with ``is_set()``, read between output steps (slices of the
        grid some :data:`CANCEL_SLICE` long: see :func:`_advance_cancellable`):
        once it is set, the run stops with :class:`grubler.errors.Cancelled`.
    actuator_forces : dict, optional
        A constant force (N, positive pushing the points apart) per actuator
        name; an actuator not named pushes with 0.

    Returns
    -------
    Result
        Its ``warnings`` say what makes it less than was asked (a loop the
        penalty method left open, a step not taken as given).

    Examples
    --------
    >>> import grubler
    >>> res = grubler.simulate("thesis-fourbar", t_end=0.2, dt_out=0.1, torque=3.0)
    >>> res["theta2"].round(4)
    array([ 0.    , -0.0518, -0.2073])
    >>> float(res["tau_drive"][0])
    3.0
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    t_end = scene.t_end if t_end is None else float(t_end)
    dt_out = scene.dt_out if dt_out is None else float(dt_out)
    if not (t_end > 0 and math.isfinite(t_end)):
        raise SceneError("t_end", f"must be positive and finite, got {t_end}")
    if not (dt_out > 0 and math.isfinite(dt_out)):
        raise SceneError("dt_out", f"must be positive and finite, got {dt_out}")
    # refuse before allocating: the output grid's size is known now
    check_size(t_end / dt_out + 2, 8 * len(output_columns(scene.mechanism, GROUPS)), "the output grid",
               "dt_out or t_end (--dt-out, --t-end)")
    method = scene.method if method is None else method
    torque = scene.torque if torque is None else torque
    load = scene.load_torque if load_torque is None else float(load_torque)
    if scene.mechanism.drive is None and (callable(torque) or torque != 0.0):
        raise SceneError("torque", f"{scene.name or 'this scene'} has no drive joint to apply it to")
    warnings = _step_warnings(integrator, method, step, dt_out)
    forces = named_actuator_forces(scene.mechanism, actuator_forces or {})
    warnings += [unforced_warning(name) for name in scene.mechanism.actuator_names
                 if name not in (actuator_forces or {})]
    sim = Simulator(scene.mechanism, method=method, rtol=rtol, atol=atol, integrator=integrator,
                    step=1e-3 if step is None else step, zd0=scene.initial_rates,
                    inputs=Inputs(0.0 if callable(torque) else float(torque), load, forces),
                    drive_function=torque if callable(torque) else None)
    n_out = int(math.floor(t_end / dt_out + 1e-9)) + 1
    times = np.arange(n_out) * dt_out
    if times[-1] < t_end - 1e-12:
        times = np.append(times, t_end)
    try:
        if cancel is None:
            zs, zds = sim.advance_through(times)
        else:
            zs, zds = _advance_cancellable(sim, times, cancel)
    except StepBudgetError as exc:
        # refused at its pace, long before the step budget itself is spent: name what sets the pace
        efforts = (f"the drive torque {torque:g} N m (--torque) and " if not callable(torque) and torque else "") + \
                  (f"the load torque {load:g} N m and " if load else "")
        raise LimitError("t_end (--t-end)", f"the run cannot finish: {exc.reason}; {efforts}the tolerance rtol "
                                            f"{rtol:g} (--rtol) set that pace: shorten the run, lower the efforts "
                                            "or loosen the tolerance") from None
    except IntegrationError:
        # a scene whose start cannot be solved: name the field at fault when one is
        why = explain_singular_start(scene.mechanism, sim.z, sim.zd, method) if sim.t == 0.0 else ""
        if why:
            field, _, reason = why.partition(": ")
            raise SceneError(field, reason) from None
        raise
    res = Result(scene.mechanism, method, times, zs, zds, sim._inputs_at, sim.stats,
                 constant_inputs=None if callable(torque) else sim.inputs, warnings=warnings)
    if scene.mechanism.closures and method == PENALTY:
        # only the penalty closure can open: the exact one assembles the start and
        # projects every step onto the loop (and computing the closure column here
        # would cost every run a pass over all its rows that it may never read)
        res.warnings += closure_warnings(scene.mechanism, times, res["closure_error"])
    return res


def unforced_warning(name: str, field: str = "actuator_forces") -> str:
    """What a run (and a report of it, naming its column) says of an actuator given no force: it pushes with
    0 N (a cylinder's boom falls).

    Examples
    --------
    >>> unforced_warning("lift")[:60]
    'actuator_forces: lift was given no force and pushed with 0 N'
    """
    return (f"{field}: {name} was given no force and pushed with 0 N throughout, holding nothing "
            f"(--actuator-force {name}=N gives one; a cylinder's own force: co-simulate it, docs/cylinders.md)")


CANCEL_SLICE = 0.05  # s of wall time a slice of a cancellable run aims at: a cancel waits about that long


def _advance_cancellable(sim: Simulator, times: np.ndarray, cancel) -> tuple[np.ndarray, np.ndarray]:
    """``sim.advance_through(times)`` in slices, ``cancel.is_set()`` read between them.

    A compiled call cannot be interrupted, so the flag is read between calls:
    a slice starts one output step long and doubles while a call takes less
    than :data:`CANCEL_SLICE` (the calls' own cost then stays small), halving
    when one takes longer; so a cancel is honoured within an output step or
    some :data:`CANCEL_SLICE`, however long the run.
    """
    import time

    parts, k, n = [], 0, 1
    while k < len(times):
        if cancel.is_set():
            raise Cancelled("run", f"cancelled at t = {sim.t:.6g} s")
        began = time.perf_counter()
        parts.append(sim.advance_through(times[k:k + n]))
        k += n
        took = time.perf_counter() - began
        n = min(2 * n, 1 << 16) if took < CANCEL_SLICE / 2 else (max(1, n // 2) if took > CANCEL_SLICE else n)
    return np.vstack([p[0] for p in parts]), np.vstack([p[1] for p in parts])


def named_actuator_forces(model: Mechanism, forces: dict[str, float]) -> tuple[float, ...]:
    """Every actuator's force in the model's order from ``{name: force}`` (0 for one not named).

    Raises
    ------
    SceneError
        Naming ``actuator_forces`` for a name the mechanism has no actuator of,
        or a force that is not a finite number.
    """
    names = model.actuator_names
    for name in forces:
        if name not in names:
            have = ", ".join(names) if names else "none"
            raise SceneError("actuator_forces", f"no actuator named {name!r}; the mechanism's actuators: {have}")
    return tuple(number(forces.get(name, 0.0), f"actuator_forces.{name}", unit="N") for name in names)


def _step_warnings(integrator: str | None, method: str, step: float | None, dt_out: float) -> list[str]:
    """What becomes of a fixed step given to :func:`simulate`: cut to the output interval, or unused."""
    if step is None:
        return []
    used = integrator or default_integrator(method)
    if used != "rk4":
        return [f"step: {step:g} s is rk4's fixed step; {used} chooses its own steps to the tolerances, "
                "so it was not used"]
    if step > dt_out * (1 + 1e-9):
        return [f"step: {step:g} s is longer than the output interval {dt_out:g} s; rk4 ends a step at every "
                f"output time, so it stepped {dt_out:g} s (an output interval of {step:g} s or more keeps the step)"]
    return []


__all__ = ["Simulator", "Result", "simulate", "actuator_lines", "named_actuator_forces", "unforced_warning", "CLOSURE_WARNING", "mechanism_size", "evaluate", "closure_forces", "output_columns", "unit_of", "GROUPS",
           "POSITION_TOL", "PENALTY", "EXACT"]
