"""A co-simulation master on fmpy: runs an SSP system of FMI 2.0 co-simulation FMUs.

What it does that a bare loop does not:

- checks the system before running it: every connection's ends exist, run from
  an output to an input of the same type and a compatible unit, no input is fed
  twice, every parameter exists; each problem is reported by name;
- orders the components (Gauss-Seidel by default): a component steps after the
  components whose outputs it reads, so it sees their values at the end of the
  step.  A feedback loop is cut where an output does not depend on its
  component's inputs at the same instant (a state: the mechanism's angle and
  rate); a loop with no such output is algebraic and reported by name;
- initialises coupled inputs consistently, in that same order, during the FMUs'
  initialisation mode, instead of starting every connector at zero;
- reads the FMUs' outputs in one call per component and sets inputs through
  preallocated buffers, and makes the communication steps' FMI calls from a C
  loop (system/c/master.c), so the master's own cost per step is small;
- reports a failed step with the FMU's own logged message, and frees every FMU.

Examples
--------
>>> from grubler.system.ssp import System
>>> s = System("empty")
>>> check(s, {}) == []
True

:func:`run`'s ``master`` is one of :data:`MASTERS`:

>>> MASTERS == (GAUSS_SEIDEL, JACOBI, EXTRAPOLATE, NEWTON) == ("gauss-seidel", "jacobi", "extrapolate", "newton")
True
"""

from __future__ import annotations

import ctypes
import math
import time as _time
from pathlib import Path

import numpy as np

from grubler.errors import Cancelled
from grubler.limits import MAX_STEPS, brief, check_count, check_size
from grubler.system.interface import FmuInterface, generic_unit, units_compatible
from grubler.system.ssp import System, SystemDescriptionError, read
from grubler.system.coupling import NEWTON_MAX_ITER, NEWTON_TOL, NewtonPlan, adaptive_plan, input_modes, newton_plan
from grubler.system.instance import CosimError, UnpackedFMUs, _call, _Instance, _last_message, interfaces_of
from grubler.system.plan import check, order
from grubler.system import coupling_energy
from grubler.system.result import CosimResult
from grubler.system.time_scales import TimeScale, step_warnings, time_scales

GAUSS_SEIDEL = "gauss-seidel"
JACOBI = "jacobi"
EXTRAPOLATE = "extrapolate"  # Gauss-Seidel's order, continuous inputs at the step's midpoint (system/coupling.py)
NEWTON = "newton"  # each step iterated to its fixed point with rollback, a Newton update (system/coupling.py)
MASTERS = (GAUSS_SEIDEL, JACOBI, EXTRAPOLATE, NEWTON)
_SCHEME = {GAUSS_SEIDEL: 0, JACOBI: 1, EXTRAPOLATE: 2, NEWTON: 3}  # system/c/master.c's grb_scheme
_CHUNK = 1000  # communication steps per call of the C loop when nothing is to be read between steps


def run(system: System | str | Path, t_end: float | None = None, step: float | None = None,
        start_time: float | None = None, master: str | None = None, record: list[str] | None = None,
        record_every: int = 1, step_order: list[str] | None = None, cancel=None,
        unpacked: "UnpackedFMUs | None" = None, profile: bool = False, tol: float | None = None) -> CosimResult:
    """Co-simulate a system with a fixed communication step.

    Parameters
    ----------
    system : System or path of a .ssd / .ssp
    t_end, step, start_time : float, optional
        Default to the system's DefaultExperiment and grubler annotation
        (``t_end`` 1 s, ``step`` 1 ms, ``start_time`` 0 when neither says).
    master : {'gauss-seidel', 'jacobi', 'extrapolate', 'newton'}
        Default: Gauss-Seidel, or extrapolate when ``tol`` is given.
        Newton (strong coupling) iterates each communication step to its fixed point: the continuous
        components are rolled back through their FMU state and stepped again, their coupled inputs held at
        the mean of the step's start value and a guess of the end value, the guess moved by a Newton update
        whose Jacobian comes from perturbed steps (:func:`grubler.system.coupling.newton_plan`): stable on a
        coupling stiff at the step (the cylinder slider-crank at 10 ms, where Gauss-Seidel and extrapolate
        diverge), second order.  A component that cannot roll back leaves the run on Gauss-Seidel, with a
        warning, and the result's ``master`` says so.
        Extrapolate steps in Gauss-Seidel's order, but holds each continuous
        input of a continuous component at its value at the step's midpoint,
        interpolated or extrapolated from its source's communication points
        (:mod:`grubler.system.coupling`): second order in the step where
        Gauss-Seidel is first (the servo four-bar's crank at 1 ms, quantisation
        off: docs/cosim.md).  Jacobi steps every FMU on the previous step's values (what
        ``fmpy.ssp.simulate_ssp`` does), for comparison: every connection then
        adds a step of delay, and a feedback loop through it loses accuracy
        (the servo four-bar's crank at 1 ms: 27 times further from a monolithic
        reference than Gauss-Seidel's, docs/cosim.md).  Its order does not matter.
    record : list of str, optional
        ``'component.variable'`` outputs to record (default: every output of
        every component).  Fewer recorded outputs is less work for FMUs that
        compute outputs only when read.
    record_every : int
        Record every n-th communication point (the first and last always).
    step_order : list of str, optional
        Stepping order of the components (default: the system's own, else
        :func:`order`'s).  A sampled controller reads its inputs at the start of
        a step, so it is best stepped before the components that feed it
        continuous values (the mechanism, a trajectory), and after a sampled
        component that feeds it (an encoder).
    cancel : threading.Event, optional
        Read between communication steps: once set, the run stops with
        :class:`grubler.errors.Cancelled` and every FMU is freed (an app's
        cancel button, a new run that replaces this one).
    unpacked : UnpackedFMUs, optional
        Where the FMUs are unpacked and kept for later runs (default: unpacked
        for this run alone and removed after it).
    profile : bool
        Time each component's setReal, doStep and getReal calls of the
        communication steps (the result's ``profile``: seconds by component;
        the clock readings add a little to the run).
    tol : float, optional
        The extrapolating master with error control: the sampled components
        step once per communication step, the continuous ones in sub-steps
        whose error estimate (step doubling, relative to max(1, |value|) over
        the coupled values) stays within ``tol`` (:mod:`grubler.system.coupling`).
        The result's ``coupling`` counts the sub-steps.  A continuous component
        that cannot roll back (no FMU state) leaves the fixed step, with a warning.

    Returns
    -------
    CosimResult
        Its ``warnings`` name every time scale the step exceeds (:func:`time_scales`).

    Raises
    ------
    Cancelled
        When ``cancel`` was set during the run.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from grubler.system.ssp import System
    >>> from grubler.controllers.native_fmu import trajectory_spec
    >>> from grubler.fmi.build import build_fmu, host_target
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> _ = build_fmu(trajectory_spec("Trajectory"), d / "Trajectory.fmu", host_target().fmi2)  # compiles: ~2 s
    >>> s = System("move", base=d)
    >>> _ = s.add("move", "Trajectory.fmu", kind="trapezoid", distance=1.0, v_max=2.0, a_max=4.0)
    >>> r = run(s, t_end=1.0, step=0.01)
    >>> r.columns, len(r.t), r.warnings
    (['move.position', 'move.velocity', 'move.acceleration'], 101, [])
    >>> round(float(r["move.position"][-1]), 6), r.units["move.position"]   # the 1 rad move done in 1 s
    (1.0, 'rad')
    >>> run(s, t_end=1.0, master="newtn")
    Traceback (most recent call last):
    ...
    grubler.errors.SystemDescriptionError: master: must be one of gauss-seidel, jacobi, extrapolate, newton, got 'newtn'
    >>> tmp.cleanup()
    """
    if not isinstance(system, System):
        system = read(system)
    t0 = start_time if start_time is not None else (system.start_time or 0.0)
    t_end = t_end if t_end is not None else (system.stop_time if system.stop_time is not None else 1.0)
    step = step if step is not None else (system.step if system.step is not None else 1e-3)
    for name, v in (("t_end", t_end), ("step", step), ("start_time", t0)):
        if not math.isfinite(v):
            raise SystemDescriptionError(f"{name}: must be finite, got {v}")
    if not step > 0:
        raise SystemDescriptionError(f"step: must be positive, got {step}")
    if t_end <= t0:
        raise SystemDescriptionError(f"t_end: {t_end} must be after the start time {t0}")
    if tol is not None and not (isinstance(tol, (int, float)) and math.isfinite(tol) and 1e-14 <= tol <= 0.5):
        raise SystemDescriptionError(f"tol: must be a number from 1e-14 to 0.5, got {brief(tol)}")
    master = master if master is not None else (EXTRAPOLATE if tol is not None else GAUSS_SEIDEL)
    if tol is not None and master != EXTRAPOLATE:
        raise SystemDescriptionError(f"tol: the adaptive step is the extrapolating master's (master 'extrapolate'), "
                                     f"got master {brief(master)}")
    if master not in MASTERS:
        raise SystemDescriptionError(f"master: must be one of {', '.join(MASTERS)}, got {brief(master)}")
    if not (isinstance(record_every, int) and record_every >= 1):
        raise SystemDescriptionError(f"record_every: must be a whole number >= 1, got {brief(record_every)}")
    if not system.components:
        raise SystemDescriptionError(f"system {brief(system.name)}: has no components")
    own = unpacked is None  # each FMU unpacked once, into a folder removed on the way out
    unzipped = UnpackedFMUs() if own else unpacked
    try:
        return _run(system, t0, t_end, step, master, record, int(record_every), step_order, unzipped, cancel,
                    profile, tol)
    finally:
        if own:
            unzipped.close()


def _run(system: System, t0: float, t_end: float, step: float, master: str, record, record_every: int,
         step_order, unzipped: "UnpackedFMUs", cancel=None, profile: bool = False,
         tol: float | None = None) -> CosimResult:
    """Plan (interfaces, order, what to record), set up and initialise every FMU, then step and record."""
    interfaces = interfaces_of(system, unzipped)
    seq = _stepping_order(system, interfaces, step_order)
    scales = time_scales(system, interfaces)
    sampled: set[str] = set()
    said: list[str] = []
    newton: NewtonPlan | None = None
    if tol is not None:
        seq, sampled, said, can_adapt = adaptive_plan(system, interfaces, seq, step, tol)
        tol = tol if can_adapt else None
    if master == NEWTON:
        newton, said = newton_plan(system, interfaces, seq)
        if newton is None:  # a component cannot roll back: the run says which scheme it ran
            master = GAUSS_SEIDEL
        else:
            seq, sampled = newton.order, newton.sampled
    if tol is not None or newton is not None:
        # the continuous components sub-step or iterate: only the sampled ones' times bound the step
        scales = [sc for sc in scales if sc.component in sampled]
    warnings = step_warnings(step, scales) + said
    recorded = _recorded_outputs(system, interfaces, record)
    slot = _slots(system)
    values = (ctypes.c_double * max(1, len(slot)))()  # the C loop reads and writes them
    wall0 = _time.perf_counter()
    insts: dict[str, _Instance] = {}
    loop = None
    try:
        table = _Recording()
        for name in seq:
            itf = interfaces[name]
            rec = recorded.get(name, [p.name for p in itf.ports.values() if p.causality == "output" and p.type == "Real"])
            table.add_outputs(system, itf, name, _set_up(insts, system, itf, name, unzipped, t0, slot, rec), rec)
        _initialise_all(insts, seq, values, t0)
        table.add_connected_inputs(system, interfaces, slot)
        n_steps = _communication_steps(t0, t_end, step)
        n_rec = check_size(n_steps // record_every + 2, 8 * (len(table.columns) + 1), "the recorded table",
                           "t_end, step or record_every (--t-end, --step, --dt-out)")
        times, data = np.empty(n_rec), np.empty((n_rec, len(table.columns)))
        # the first row, after initialisation with the inputs consistent; then the C loop steps and records
        for name in seq:
            insts[name].publish(values, True)
        times[0] = t0
        for j, (c, i) in enumerate(table.sources):
            data[0, j] = insts[c].read_buf[i] if c else values[i]
        modes = newton.modes if newton else input_modes(system, interfaces, seq) if master == EXTRAPOLATE else None
        loop = _Loop([insts[n] for n in seq], values, master, t0, step, t_end, n_steps, record_every,
                     [seq.index(c) if c else -1 for c, _ in table.sources], [i for _, i in table.sources], times,
                     data, profile, modes and [modes[n] for n in seq], tol, [n in sampled for n in seq],
                     newton and ([n in newton.iterated for n in seq], [slot[u] for u in newton.unknowns]))
        loop.slot_names = {s: name for name, s in slot.items()}
        try:
            _step_through(loop, n_steps, cancel, 1 if tol is not None else _CHUNK)
        except CosimError as exc:  # what the rows before the failure show (a coupling making energy) is added
            k = loop.row.value
            note = coupling_energy.diagnosis(CosimResult(times[:k], table.columns, data[:k], system, seq, master,
                                                         step, 0.0, table.units), record_every == 1)
            if note:
                raise CosimError(f"{note}; then {exc}") from exc  # the cause first: a long line keeps its head
            raise
        k = loop.row.value
        wall = _time.perf_counter() - wall0
        warnings += loop.iteration_warnings()
        messages = [m for inst in insts.values() for m in inst.messages]
        result = CosimResult(times[:k].copy(), table.columns, data[:k].copy(), system, seq, master, step, wall,
                             table.units, messages, warnings, loop.profile(seq), loop.coupling())
        coupling_energy.judge(result, record_every == 1)  # the power at each mechanical connection; divergence
        return result
    finally:
        if loop is not None:
            loop.free_states()
        for inst in insts.values():
            inst.free()


def _stepping_order(system: System, interfaces: dict[str, FmuInterface], step_order) -> list[str]:
    """The order given (the call's, else the system's), checked to name every component once; else :func:`order`'s.

    :func:`order` runs either way: it is what finds an algebraic loop.
    """
    seq = order(system, interfaces)
    chosen = step_order if step_order is not None else system.order
    if not chosen:
        return seq
    chosen = list(chosen)
    if sorted(chosen) != sorted(system.components):
        raise SystemDescriptionError(f"order {' '.join(chosen)}: must name every component once "
                                     f"({' '.join(system.components)})")
    return chosen


def _recorded_outputs(system: System, interfaces: dict[str, FmuInterface], record) -> dict[str, list[str]]:
    """The outputs to record by component (every output of a component not named: all of them when
    ``record`` is None, none otherwise); a connected input is recorded anyway, from the output feeding it."""
    if record is None:
        return {}
    out: dict[str, list[str]] = {name: [] for name in system.components}
    connected_inputs = {c.end for c in system.connections}
    for r in record:
        el, _, var = r.partition(".")
        port = interfaces.get(el).ports.get(var) if el in interfaces else None
        if r in connected_inputs:
            continue
        if port is None or port.causality != "output":
            raise SystemDescriptionError(f"record {r!r}: not an output of a component, nor a connected input")
        out[el].append(var)
    return out


class _Recording:
    """The recorded table's columns: each one's source (a component and the index in its read buffer, or
    '' and a value slot for a connected input) and unit."""

    def __init__(self):
        self.columns: list[str] = []
        self.sources: list[tuple[str, int]] = []
        self.units: dict[str, str] = {}

    def add_outputs(self, system: System, itf: FmuInterface, name: str, reads: list[str], recorded) -> None:
        for i, o in enumerate(reads):
            if o in recorded:
                self.columns.append(f"{name}.{o}")
                self.sources.append((name, i))
            self.units[f"{name}.{o}"] = system.components[name].units.get(o, itf.ports[o].unit)

    def add_connected_inputs(self, system: System, interfaces: dict[str, FmuInterface], slot: dict[str, int]):
        # a connected input's value is the output feeding it; a generic unit (a controller's "any") is
        # what its other end says
        for c in system.connections:
            if c.end not in self.units:
                self.columns.append(c.end)
                self.sources.append(("", slot[c.start]))
                declared = system.components[c.end_element].units.get(
                    c.end_connector, interfaces[c.end_element].ports[c.end_connector].unit)
                self.units[c.end] = self.units.get(c.start, "") if generic_unit(declared) else declared
        for c in system.connections:
            if generic_unit(self.units.get(c.start, "")) and not generic_unit(self.units.get(c.end, "")):
                self.units[c.start] = self.units[c.end]


def _communication_steps(t0: float, t_end: float, step: float) -> int:
    """How many steps reach t_end (a last, shorter one lands on it)."""
    n_steps = check_count(math.floor((t_end - t0) / step + 1e-9), MAX_STEPS, "communication steps",
                          "t_end or step (--t-end, --step)")
    if t0 + n_steps * step < t_end - 1e-9 * step:
        n_steps += 1
    return n_steps


def _step_through(loop: "_Loop", n_steps: int, cancel, chunk: int = _CHUNK) -> None:
    """Every communication step.  The flag, if any, is read before each; without one the loop returns to
    Python every ``chunk`` steps, where a Ctrl-C is raised (every step under a tolerance: one may take
    thousands of sub-steps)."""
    chunk = 1 if cancel is not None else chunk
    for n in range(0, n_steps, chunk):
        if cancel is not None and cancel.is_set():
            raise Cancelled("run", f"cancelled at t = {loop.t.value:.6g} s")
        loop.steps(n, chunk)


def _slots(system: System) -> dict[str, int]:
    """One value slot per connected output, by ``component.output``."""
    slot: dict[str, int] = {}
    for c in system.connections:
        slot.setdefault(c.start, len(slot))
    return slot


def _set_up(insts: dict[str, _Instance], system: System, itf: FmuInterface, name: str, unzipped: "UnpackedFMUs",
            t0: float, slot: dict[str, int], recorded: list[str]) -> list[str]:
    """Instantiate ``name`` into ``insts``, set its parameters and wire it; returns the outputs it reads.

    The connected outputs come first in what it reads, then the rest of ``recorded``.
    """
    inst = insts[name] = _Instance(name, itf, str(unzipped[itf.path]), t0)  # in insts at once: freed on failure
    _call(inst, "set parameters", lambda: inst.set_parameters(system.components[name].parameters), t0)
    conn_out = list(dict.fromkeys(c.start_connector for c in system.connections if c.start_element == name))
    inputs = [(itf.ports[c.end_connector].vr, slot[c.start]) for c in system.connections if c.end_element == name]
    inst.wire(inputs, [(itf.ports[o].vr, slot[f"{name}.{o}"]) for o in conn_out], [itf.ports[o].vr for o in recorded])
    return list(dict.fromkeys(conn_out + recorded))


def _initialise_all(insts: dict[str, _Instance], seq: list[str], values, t0: float) -> None:
    """Initialisation mode from enter to exit, the coupled inputs settled in between."""
    for inst in insts.values():
        _call(inst, "enter initialisation mode", inst.fmu.enterInitializationMode, t0)
    _initialise(insts, seq, values, t0)
    for inst in insts.values():
        _call(inst, "exit initialisation mode", inst.fmu.exitInitializationMode, t0)


def initial_inputs(system: System, interfaces: dict[str, FmuInterface], unzipped: "UnpackedFMUs",
                   t0: float = 0.0) -> dict[str, float]:
    """The coupled inputs' values once initialisation settles, by ``component.input``: what a run starts from.

    Every FMU is instantiated, initialised as :func:`run` does it, and freed.

    Examples
    --------
    A DC motor through 50:1 driving the four-bar whose crank starts at 2 rad/s
    (``tests/test_container.py``'s system; it needs the built DCMotor.fmu and
    Mechanism.fmu, ``python build_fmu.py``):

    >>> from grubler import ssp
    >>> s = ssp.System("motor_fourbar")
    >>> _ = s.add("motor", "dist/DCMotor.fmu", gear_ratio=50.0, voltage=12.0)
    >>> _ = s.add("mechanism", "dist/Mechanism.fmu", **{"initial.theta2_d": 2.0})
    >>> _ = s.connect("motor.shaft_torque", "mechanism.motor_torque")
    >>> _ = s.connect("mechanism.drive_speed", "motor.shaft_speed")
    >>> with UnpackedFMUs() as unpacked:                              # doctest: +SKIP
    ...     start = initial_inputs(s, interfaces_of(s, unpacked), unpacked)
    >>> start["motor.shaft_speed"]                                    # doctest: +SKIP
    2.0
    """
    seq = order(system, interfaces)
    slot = _slots(system)
    values = (ctypes.c_double * max(1, len(slot)))()  # the C loop reads and writes them
    insts: dict[str, _Instance] = {}
    try:
        for name in seq:
            _set_up(insts, system, interfaces[name], name, unzipped, t0, slot, [])
        _initialise_all(insts, seq, values, t0)
    finally:
        for inst in insts.values():
            inst.free()
    return {c.end: values[slot[c.start]] for c in system.connections}


class _Loop:
    """The communication steps, made by the C loop (system/c/master.c) over the instances in stepping order.

    It makes the FMI calls the Python loop it replaced made, in the same order,
    with the same arithmetic for the time: the same results, bit for bit.
    """

    def __init__(self, insts: list[_Instance], values, master: str, t0: float, step: float, t_end: float,
                 n_steps: int, record_every: int, column_fmu: list[int], column_index: list[int],
                 times: np.ndarray, data: np.ndarray, profile: bool, in_modes: list[list[int]] | None = None,
                 tol: float | None = None, sampled: list[bool] | None = None,
                 newton: tuple[list[bool], list[int]] | None = None):
        from grubler import binding

        self.insts, self.values, self.tol = insts, values, tol
        # the Newton master's iterated components and unknowns' slots, and its counts and work (else None)
        self._newton, self._newton_arrays = None, ()
        if newton is not None:
            iterated, unknowns = newton
            n, nu = len(values), len(unknowns)
            index = np.full(max(1, n), -1, dtype=np.intc)
            index[unknowns] = np.arange(nu)
            arrays = (np.asarray(unknowns or [0], dtype=np.intc), index, np.zeros(3 * n + 3 * nu + nu * nu + 1),
                      np.zeros(max(1, nu), dtype=np.intc))
            self._newton_arrays = arrays  # kept: C holds the pointers
            self._newton = binding.MasterNewton(NEWTON_TOL, NEWTON_MAX_ITER, nu, *(a.ctypes.data for a in arrays),
                                                0, 0, 0, 0, 0, 0.0, -1)
        rollback = iterated if newton is not None else [
            tol is not None and not (sampled and sampled[k]) for k in range(len(insts))]
        self.seconds = np.zeros((len(insts), 3)) if profile else None
        # the extrapolating master's input modes and its history of the values (start, previous point)
        self._modes = [(ctypes.c_int * len(m))(*m) for m in in_modes] if in_modes is not None else None
        self._history = np.zeros((2, len(values))) if in_modes is not None else None
        self.fmus = (binding.MasterFmu * len(insts))(*[
            inst.loop_view(None if self.seconds is None else self.seconds[k].ctypes.data,
                           None if self._modes is None else self._modes[k], bool(sampled and sampled[k]),
                           rollback[k])
            for k, inst in enumerate(insts)])
        # the adaptive master's sub-step clock (its first try: the whole step) and its work buffers
        self._adapt = binding.MasterAdapt(step, 0.0, 0, 0, 0.0, -1)
        self.slot_names: dict[int, str] = {}  # a value slot's output, for messages (set by the caller)
        self._work = np.zeros(4 * len(values)) if tol is not None else None
        self._columns = (np.asarray(column_fmu, dtype=np.intc), np.asarray(column_index, dtype=np.intc))
        history = (0, None, None) if self._history is None else (
            len(values), self._history[0].ctypes.data, self._history[1].ctypes.data)
        self.run = binding.MasterRun(_SCHEME[master], t0, step, t_end, n_steps, record_every, len(column_fmu),
                                     self._columns[0].ctypes.data, self._columns[1].ctypes.data,
                                     times.ctypes.data, data.ctypes.data, *history, tol or 0.0,
                                     None if self._work is None else self._work.ctypes.data,
                                     ctypes.addressof(self._adapt),
                                     None if self._newton is None else ctypes.addressof(self._newton))
        self.t, self.row, self.failure = ctypes.c_double(t0), ctypes.c_long(1), binding.MasterFailure()
        self._steps = binding.library().grb_master_steps

    def steps(self, first: int, count: int) -> None:
        """Communication steps ``first`` .. ``first + count - 1``, each recorded row written."""
        if self._steps(self.fmus, len(self.insts), ctypes.addressof(self.values), ctypes.byref(self.run), first,
                       count, ctypes.byref(self.t), ctypes.byref(self.row), ctypes.byref(self.failure)):
            f = self.failure
            if f.call == 4:
                worst = self.slot_names.get(self._adapt.worst_slot, "?")
                raise CosimError(f"tol {self.tol:g}: the coupling's error estimate stays above the tolerance down to "
                                 f"a sub-step of {self._adapt.h:.3g} s at t = {f.t:.6g} s, largest at {worst} "
                                 "(the FMUs' own accuracy may be the floor): give a larger tol")
            what = ("fmi2SetReal", f"doStep from t = {f.t:.6g} s", "fmi2GetReal",
                    f"fmi2GetFMUstate/fmi2SetFMUstate at t = {f.t:.6g} s")[f.call]
            raise self.insts[f.fmu].refused(what, f.status)

    def coupling(self) -> dict:
        """The adaptive master's counts, or the Newton master's (empty for the other fixed-step masters)."""
        if self._newton is not None:
            nw = self._newton
            return {"newton_tol": NEWTON_TOL, "steps": int(nw.steps), "evaluations": int(nw.evaluations),
                    "jacobians": int(nw.jacobians), "unconverged": int(nw.unconverged),
                    "worst_residual": float(nw.worst) * NEWTON_TOL,
                    "worst_at": self.slot_names.get(int(nw.worst_slot), "")}
        if self.tol is None:
            return {}
        a = self._adapt
        return {"tol": self.tol, "substeps": int(a.substeps), "rejected": int(a.rejected),
                "worst_estimate": float(a.worst) * self.tol}

    def iteration_warnings(self) -> list[str]:
        """The Newton master's word on steps it kept unconverged (none: every step met its tolerance)."""
        c = self.coupling() if self._newton is not None else {}
        if not c.get("unconverged"):
            return []
        return [f"master newton: {c['unconverged']} of {c['steps']} steps kept after {NEWTON_MAX_ITER} evaluations "
                f"with a coupling residual above {NEWTON_TOL:g} (largest {c['worst_residual']:.3g}, relative, at "
                f"{c['worst_at']}): the FMUs' own accuracy may be the floor, or the coupling too nonlinear at the "
                "step (a shorter step)"]

    def free_states(self) -> None:
        """The FMU states the adaptive and Newton masters saved, freed (before the FMUs are)."""
        if self.tol is not None or self._newton is not None:
            from grubler import binding

            binding.library().grb_master_free_states(self.fmus, len(self.insts))

    def profile(self, seq: list[str]) -> dict[str, tuple[float, float, float]]:
        """Seconds in setReal, doStep and getReal by component (empty unless profiled)."""
        if self.seconds is None:
            return {}
        return {name: tuple(float(x) for x in self.seconds[k]) for k, name in enumerate(seq)}


def _initialise(insts: dict[str, _Instance], seq: list[str], values, t0: float) -> None:
    """Propagate outputs to inputs in step order until they settle (states first)."""
    for sweep in range(len(seq) + 2):
        change = 0.0
        for name in seq:
            inst = insts[name]
            _call(inst, "set inputs", lambda: inst.push(values), t0)
            buf = _call(inst, "get outputs", lambda: inst.pull(False), t0)
            for i, s in enumerate(inst.out_slots):
                v = buf[i]
                if not math.isfinite(v):
                    raise CosimError(f"{name}: an initial output is {v} at t = {t0:g} s"
                                     + _last_message(inst))
                scale = max(1.0, abs(v), abs(values[s]))
                change = max(change, abs(v - values[s]) / scale)
                values[s] = v
        if sweep > 0 and change < 1e-12:
            return
    raise CosimError("initial values of the coupled inputs did not settle after "
                     f"{len(seq) + 2} sweeps: an algebraic loop the FMUs do not declare?")


__all__ = ["run", "UnpackedFMUs", "check", "order", "interfaces_of", "initial_inputs", "time_scales", "step_warnings", "TimeScale", "units_compatible", "CosimResult", "CosimError", "FmuInterface",
           "GAUSS_SEIDEL", "JACOBI", "EXTRAPOLATE", "NEWTON", "MASTERS"]
