"""Integration of a mechanism's state equation: the kernel's explicit Runge-Kutta
methods, and scipy's implicit ones for stiff penalty closures.

A closed loop needs two things a general ODE solver does not give: a projection
back onto the closure after every accepted step (the exact method's drift
control), and an integrator state that can be saved and restored whole, as an
FMU's rollback requires.  The explicit methods (Dormand-Prince 8(5,3) with its
continuous extension, the 5(4) pair, classic RK4 at a fixed step) are therefore
the compiled kernel's own (``kernel/integrate.c``): one :meth:`Integrator.advance_to`
is one call into compiled code however many steps it takes, and the
integrator's state is plain data (time, step, state, derivative).  The implicit
methods (stiff penalty closures) are scipy's, calling the kernel's right-hand
side once per evaluation.

Examples
--------
>>> from grubler import Link, Mechanism
>>> pendulum = Mechanism(links=(Link("R", a=1.0, p=1.0, m=1.0),), q_ref=(0.0, -1.5))
>>> integ = Integrator(StateEquation(pendulum), 0.0, [-1.5, 0.0], rtol=1e-10, atol=1e-10)
>>> integ.advance_to(2.0)
>>> import numpy as np, scipy.integrate  # the same pendulum as a plain ODE
>>> ref = scipy.integrate.solve_ivp(lambda t, y: [y[1], -9.81 * np.cos(y[0])], (0.0, 2.0), [-1.5, 0.0],
...                                 rtol=1e-12, atol=1e-12)
>>> integ.t, bool(abs(integ.y[0] - ref.y[0, -1]) < 1e-8)
(2.0, True)
"""

from __future__ import annotations

import contextlib
import functools
import math
import signal
import threading
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from grubler import binding
from grubler.mechanism.dynamics import EXACT, METHOD_CODE
from grubler.errors import IntegrationError
from grubler.mechanism.model import Mechanism

# the kernel's explicit methods, and the implicit ones for stiff problems (high
# penalty gains), run by scipy
EXPLICIT = tuple(binding.TABLEAU_CODE)
IMPLICIT = ("radau", "bdf")
METHODS = EXPLICIT + IMPLICIT
_advance_fn = binding.library().grb_advance
PASSAGE_LOG = 65536  # change-point passage times one advance keeps (all are counted)
MAX_STEPS = 10_000_000  # steps one advance may take (the kernel's guard)
# An advance that needs more than PACE_STEPS steps is run again watched: the steps
# taken so far, at their average pace per simulated second, are extrapolated to the
# end, and a run that could not finish within its step budget is refused as soon
# as that projection passes it, not after the budget itself (minutes) is spent.
# The average pace only underestimates a run that speeds up (a constant torque
# spinning a mechanism ever faster); a run whose steps crowd at its start can be
# refused that the budget would have let finish.
PACE_STEPS = 50_000
PACE_CHECK = 4096  # evaluations between two looks at the pace


class StepBudgetError(IntegrationError):
    """A run that, at the pace of its steps so far, would need more steps than it may take.

    Attributes ``steps`` (taken so far, estimated), ``reached`` (s), ``target`` (s),
    ``projected`` (steps to reach the target) and ``budget`` give the numbers.
    """

    def __init__(self, reason: str, steps: float = math.nan, reached: float = math.nan, target: float = math.nan,
                 projected: float = math.nan, budget: int = 0):
        super().__init__(reason)
        self.steps, self.reached, self.target, self.projected, self.budget = steps, reached, target, projected, budget

    def __reduce__(self):  # sweep workers send errors back pickled
        return (type(self), (self.reason, self.steps, self.reached, self.target, self.projected, self.budget))


@dataclass
class _Pace:
    """What a watched advance has seen: evaluations and the furthest time they reached."""

    t0: float
    target: float
    budget: int
    evals_per_step: float  # twice what an accepted step's stages cost: the steps counted are an undercount
    min_steps: float  # the pace is judged only over at least this many steps
    evals: int = 0
    reached: float = -math.inf


@dataclass
class StateEquation:
    """A mechanism's state equation ``ydot = (zd, zdd(z, zd, efforts))``, ``y = (z, zd)``.

    What the integrator integrates: the model, the closure method, the efforts
    (set between advances) and whether each step is projected onto the closures.
    Calling it evaluates the compiled right-hand side once, as scipy's implicit
    methods do.

    Parameters
    ----------
    model : Mechanism
    method : {'exact', 'penalty'}
    drive, load : float
        Efforts on the drive and load joints (N m, or N on a slide).
    drive_function : callable, optional
        The drive effort as a function of time (replaces ``drive``); the kernel
        calls it back at every evaluation.
    project_state : bool
        Project onto the closures after every step (the exact method).
    scale : float
        Length scale of the projection's position tolerance, m.
    """

    model: Mechanism
    method: str = EXACT
    drive: float = 0.0
    load: float = 0.0
    drive_function: Callable[[float], float] | None = None
    project_state: bool = False
    scale: float = 1.0

    def __post_init__(self):
        self.method_code = METHOD_CODE[self.method]
        self.work = binding.work(self.model.n_links, len(self.model.closures))
        # scipy's implicit solvers call this once per evaluation: buffers and
        # their addresses made once (numpy's .ctypes costs about a microsecond)
        self.actuator_forces = np.zeros(len(self.model.actuators))
        n = 2 * self.model.n_links
        self._y, self._out = np.zeros(n), np.zeros(n)
        self._call = (binding.library().grb_rhs, self.model.arrays.c, binding.address(self._y),
                      binding.address(self.work), binding.address(self._out))

    def set_actuator_forces(self, forces) -> None:
        """The actuators' forces (N, in the model's order), held in the kernel's workspace until set again."""
        self.actuator_forces = np.array(forces, dtype=float)
        if self.model.actuators:
            binding.set_actuator_forces(self.model.arrays.c, self.work, self.actuator_forces)

    def drive_at(self, t: float) -> float:
        return self.drive if self.drive_function is None else float(self.drive_function(t))

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        rhs, model, a_y, a_work, a_out = self._call
        self._y[:] = y
        rhs(model, self.method_code, a_y, self.drive_at(float(t)), float(self.load), a_work, a_out)
        return self._out.copy()

    def jacobian(self, t: float, y: np.ndarray) -> np.ndarray:
        """d(ydot)/dy at (t, y), exact to rounding: the kernel's complex-step twin
        (``grb_cs_rhs_at``), one evaluation per column; what scipy's implicit
        methods would otherwise estimate by differences."""
        n2 = 2 * self.model.n_links
        if not hasattr(self, "_cs"):
            self._cs = (np.zeros(n2, dtype=complex), np.zeros(n2, dtype=complex),
                        np.zeros(self.work.size, dtype=complex), np.zeros(2, dtype=complex))
        yc, out, work, efforts = self._cs
        efforts[:] = (self.drive_at(float(t)), self.load)
        if self.model.actuators:
            binding.set_actuator_forces(self.model.arrays.c, work, self.actuator_forces.astype(complex))
        jac = np.empty((n2, n2))
        rhs = binding.complex_step("grb_cs_rhs_at")
        h = 1e-30 * max(1.0, float(np.max(np.abs(y))))
        for k in range(n2):
            yc[:] = y
            yc[k] += 1j * h
            rhs(self.model.arrays.c, self.method_code, binding.address(yc), binding.address(efforts),
                binding.address(work), binding.address(out))
            jac[:, k] = out.imag / h
        return jac

    def project(self, y: np.ndarray) -> np.ndarray:
        """``y`` put back onto the closures (a new array)."""
        y = np.array(y, dtype=float)
        binding.library().grb_project(self.model.arrays.c, float(self.scale), binding.address(y),
                                      binding.address(self.work))
        return y


@dataclass
class Integrator:
    """One integration of a mechanism's state equation: everything needed to continue it, or replay it.

    Parameters
    ----------
    ode : StateEquation
        The mechanism, closure method, efforts and whether to project.
    t, y : float, ndarray
        Initial time and state ``(z, zd)``.
    method : str
        Tableau name, or 'radau' / 'bdf' (scipy).
    rtol, atol : float
        Error tolerances (adaptive integrators).
    h : float
        Fixed step (rk4) or first step (adaptive; 0 picks one).
    h_max : float
        Largest step.
    """

    ode: StateEquation
    t: float
    y: np.ndarray
    method: str = "dop853"
    rtol: float = 1e-8
    atol: float = 1e-10
    h: float = 0.0
    h_max: float = math.inf
    f: np.ndarray | None = None
    n_steps: int = 0
    n_rejected: int = 0
    n_evals: int = 0
    passages: list = field(default_factory=list)  # times of the change points the motion crossed, s
    n_passages: int = 0  # how many (the list keeps the last PASSAGE_LOG of any one advance)
    n_charts: int = 0  # change-point charts built (one per zone: a chart is kept between advances)
    _explicit: bool = field(init=False, repr=False)

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"integrator: unknown {self.method!r}; choose one of {', '.join(METHODS)}")
        self._explicit = self.method in EXPLICIT
        self.y = np.array(self.y, dtype=float)
        for name in ("rtol", "atol"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"{name}: must be positive and finite, got {v}")
        if self.method == "rk4" and not (self.h > 0 and math.isfinite(self.h)):
            raise ValueError(f"step: the fixed-step {self.method} needs a positive step, got {self.h}")
        if not self.h_max > 0:
            raise ValueError(f"max_step: must be positive, got {self.h_max}")
        if self._explicit:
            ode, n = self.ode, self.y.size
            self._settings = binding.Settings(
                tableau=binding.TABLEAU_CODE[self.method], method=ode.method_code, project=bool(ode.project_state),
                scale=float(ode.scale), rtol=float(self.rtol), atol=float(self.atol), h_max=float(self.h_max),
                h_fixed=float(self.h) if self.method == "rk4" else 0.0)
            self._stepper = np.zeros(binding.library().grb_stepper_size(binding.TABLEAU_CODE[self.method], n))
            self._passage_log = np.zeros(PASSAGE_LOG)
            self._settings.passage_log = binding.address(self._passage_log)
            self._settings.passage_capacity = PASSAGE_LOG
            self._ybuf, self._fbuf = np.zeros(n), np.zeros(n)
            self._t1, self._out1 = np.zeros(1), np.zeros((1, n))  # advance_to's target and result
            # the addresses of buffers that live as long as the integrator, taken
            # once: numpy's .ctypes costs about a microsecond a call
            self._addr = tuple(binding.address(a) for a in (self._ybuf, self._fbuf, self.ode.work, self._stepper,
                                                           self._t1, self._out1))
            self._clock, self._why = binding.Clock(), binding.Failure()
            self._callback_error: BaseException | None = None
            # the drive callback, held here (a watched run swaps another in, then this back)
            self._drive_fn = (binding.DRIVE_FN(self._drive_callback) if ode.drive_function is not None
                              else binding.DRIVE_FN())
            self._settings.drive_fn = self._drive_fn

    def _drive_callback(self, _ctx, t: float) -> float:
        # an exception cannot cross the C stack: keep it, hand the kernel a nan
        # (which stops the step), and raise it once the kernel has returned
        try:
            return float(self.ode.drive_function(t))
        except BaseException as exc:  # noqa: BLE001 - re-raised by _advance
            self._callback_error = exc
            return math.nan

    def _paced_callback(self, ctx, t: float) -> float:
        # the kernel calls the drive effort at every evaluation: where a watched run is seen
        if self._callback_error is not None:
            return math.nan
        # (a signal's handler, run as this is entered, is kept by _signals_kept)
        pace = self._pace
        pace.evals += 1
        if t > pace.reached:
            pace.reached = t
        if pace.evals % PACE_CHECK == 0 and pace.reached > pace.t0:
            steps = pace.evals / pace.evals_per_step
            projected = steps * (pace.target - pace.t0) / (pace.reached - pace.t0)
            if steps >= pace.min_steps and projected > pace.budget:
                self._callback_error = _over_budget(steps, pace.t0, pace.reached, pace.target, pace.budget)
                return math.nan
        return self.ode.drive if self.ode.drive_function is None else self._drive_callback(ctx, t)

    # -- state ----------------------------------------------------------------
    def snapshot(self) -> dict:
        """Everything that determines the rest of the run (for rollback).

        The arrays are shared, not copied: the integrator never writes into ``y``
        or ``f`` in place, it rebinds them to new arrays at every advance (the
        kernel writes into buffers of its own).  The kernel's stepper buffer is
        copied: it keeps the change-point chart being followed from one advance
        to the next.
        """
        return {"t": self.t, "y": self.y, "h": self.h, "f": self.f,
                "counts": (self.n_steps, self.n_rejected, self.n_evals), "passages": list(self.passages),
                "n_passages": self.n_passages, "n_charts": self.n_charts,
                "kappa_seen": self._clock.kappa_seen if self._explicit else 0.0,
                "stepper": self._stepper.copy() if self._explicit else None}

    def restore(self, snap: dict) -> None:
        self.t, self.y, self.h = snap["t"], snap["y"].copy(), snap["h"]
        self.f = None if snap["f"] is None else snap["f"].copy()
        self.n_steps, self.n_rejected, self.n_evals = snap["counts"]
        self.passages = list(snap["passages"])
        self.n_passages = snap["n_passages"]
        self.n_charts = snap["n_charts"]
        if self._explicit:
            self._clock.kappa_seen = snap["kappa_seen"]
            self._stepper[:] = snap["stepper"]

    def reset_derivative(self) -> None:
        """Forget the cached derivative (after an input changed)."""
        self.f = None

    # -- stepping -------------------------------------------------------------
    def _advance_implicit(self, times: np.ndarray, max_steps: int = MAX_STEPS) -> np.ndarray:
        """scipy's solver from ``t`` to the last of ``times``, the others from its dense output.

        One solver for the whole grid: a multistep method restarted at every output
        time would start again from first order each time.  A fresh solver per call,
        because the efforts may have changed at ``t``.
        """
        import scipy.integrate

        cls = {"radau": scipy.integrate.Radau, "bdf": scipy.integrate.BDF}[self.method]
        out = np.empty((len(times), self.y.size))
        done = 0
        while done < len(times) and times[done] <= self.t:  # already there
            out[done] = self.y
            done += 1
        if done == len(times):
            return out
        first = min(self.h, times[-1] - self.t) if self.h > 0 else None
        solver = cls(self.ode, self.t, self.y, times[-1], rtol=self.rtol, atol=self.atol,
                     first_step=first, max_step=self.h_max, jac=self.ode.jacobian)
        steps, t_start = 0, self.t
        while solver.status == "running":
            msg = solver.step()
            if solver.status == "failed":
                raise IntegrationError(f"{self.method} failed at t = {solver.t:.6g} s: {msg}")
            steps += 1
            if steps >= PACE_STEPS / 10 and steps % 64 == 0:  # the pace watch, on exact step counts
                projected = steps * (times[-1] - t_start) / max(solver.t - t_start, 1e-300)
                if projected > max_steps:
                    raise _over_budget(steps, t_start, solver.t, float(times[-1]), max_steps)
            inside = done
            while inside < len(times) - 1 and (times[inside] < solver.t or solver.status == "finished"):
                inside += 1
            if inside > done:
                states = solver.dense_output()(times[done:inside])
                for k in range(done, inside):
                    y = states[:, k - done]
                    out[k] = self.ode.project(y) if self.ode.project_state else y
                done = inside
        y = self.ode.project(solver.y) if self.ode.project_state else solver.y
        out[len(times) - 1] = y
        self.n_steps += steps
        self.n_evals += solver.nfev
        self.t, self.y, self.h, self.f = float(times[-1]), y, solver.step_size or self.h, None
        return out

    def advance_to(self, t_target: float, max_steps: int = MAX_STEPS) -> None:
        """Step until ``t`` reaches ``t_target`` exactly.

        All or nothing: if it fails, the integrator is left where it started, so a
        caller (an FMU asked to retry with a shorter step) can go on from there.
        """
        t_target = float(t_target)
        # (NaN fails the comparison too)
        if not (math.isfinite(t_target) and t_target >= self.t - 1e-12 * max(1.0, abs(self.t))):
            raise ValueError(f"t: must be finite and not before the integrator's time {self.t:.12g} s, "
                             f"got {t_target!r}")
        if not self._explicit:
            self._advance_implicit(np.array([t_target]), max_steps)
            return
        self._t1[0] = t_target
        self._advance(self._t1, max_steps)

    def advance_through(self, times: np.ndarray, max_steps: int = MAX_STEPS) -> np.ndarray:
        """Step through increasing ``times``, returning the state at each (one row per time).

        All or nothing, like :meth:`advance_to`.  With DOP853 (and scipy's solvers on
        the penalty closure) the steps are those of ``advance_to(times[-1])`` and the
        earlier times are interpolated.
        """
        times = np.ascontiguousarray(times, dtype=float)
        if times.ndim != 1 or times.size == 0:
            raise ValueError(f"times: must be a non-empty 1-D sequence, got shape {times.shape}")
        if not np.all(np.isfinite(times)):
            raise ValueError(f"times: must be finite, got {times[~np.isfinite(times)][0]!r}")
        if np.any(np.diff(times) < 0) or times[0] < self.t - 1e-12 * max(1.0, abs(self.t)):
            raise ValueError(f"times: must increase from the integrator's time {self.t:.12g} s "
                             f"(got {times[0]:.12g} ... {times[-1]:.12g} s, not in order)")
        if not self._explicit and self.ode.project_state:
            # the exact closure's drift is removed only where scipy's solver is
            # restarted from a projected state: at every output time
            out = np.empty((len(times), self.y.size))
            start = self.snapshot()
            try:
                for i in range(len(times)):
                    self._advance_implicit(times[i:i + 1], max_steps)
                    out[i] = self.y
            except BaseException:
                self.restore(start)
                raise
            return out
        if not self._explicit:
            return self._advance_implicit(times, max_steps)
        return self._advance(times, max_steps)

    def _advance(self, times: np.ndarray, max_steps: int) -> np.ndarray:
        """The kernel's grb_advance through ``times``; the states there (a buffer of
        the integrator's own when ``times`` is advance_to's).

        A run longer than ``PACE_STEPS`` steps is run again, watched (see ``PACE_STEPS``).
        """
        if max_steps <= PACE_STEPS:
            return self._run(times, max_steps)
        try:
            return self._run(times, PACE_STEPS)
        except IntegrationError as exc:
            if getattr(exc, "status", None) != binding.TOO_MANY_STEPS:
                raise
        tab = binding.library().grb_tableau(binding.TABLEAU_CODE[self.method]).contents
        # an accepted step costs its stages and its dense output's; rejected ones only add
        # (so the steps counted from the evaluations are never more than were taken)
        self._pace = _Pace(self.t, float(times[-1]), int(max_steps), float(2 * (tab.stages + tab.dense_stages)),
                           min_steps=PACE_STEPS / 10)
        paced = binding.DRIVE_FN(self._paced_callback)  # (alive as long as this call)
        self._settings.drive_fn = paced
        try:
            return self._run(times, max_steps)
        finally:
            self._settings.drive_fn = self._drive_fn

    def _run(self, times: np.ndarray, max_steps: int) -> np.ndarray:
        ode, st, clock, n = self.ode, self._settings, self._clock, self.y.size
        st.tau_drive, st.tau_load, st.max_steps = float(ode.drive), float(ode.load), int(max_steps)
        clock.t, clock.h, clock.have_f = self.t, self.h if self.method != "rk4" else 0.0, self.f is not None
        clock.steps = clock.rejected = clock.evals = clock.passages = clock.charts = 0
        self._ybuf[:] = self.y
        if self.f is not None:
            self._fbuf[:] = self.f
        a_y, a_f, a_work, a_stepper, a_t1, a_out1 = self._addr
        if times is self._t1:
            out, a_times, a_out = self._out1, a_t1, a_out1
        else:
            out = np.empty((times.shape[0], n))
            a_times, a_out = binding.address(times), binding.address(out)
        self._callback_error = None
        args = (ode.model.arrays.c, st, clock, a_y, a_f, a_times, times.shape[0], a_out, a_work, a_stepper, self._why)
        if st.drive_fn:  # the kernel calls back into Python: signals are kept for the call
            with _signals_kept(self):
                status = _advance_fn(*args)
        else:  # (a co-simulation step's hot path: no context manager to enter)
            status = _advance_fn(*args)
        if self._callback_error is not None:
            raise self._callback_error
        if status != binding.OK:
            exc = IntegrationError(_failure(status, self._why.where, self._why.limit))
            exc.status = status  # for _advance: a probe that ran out of steps is run again, watched
            raise exc
        self.t, self.y = clock.t, self._ybuf.copy()
        self.f = self._fbuf.copy() if clock.have_f else None
        if self.method != "rk4":
            self.h = clock.h
        self.n_steps += clock.steps
        self.n_rejected += clock.rejected
        self.n_evals += clock.evals
        # (a ring: an advance with more passages than it holds keeps the last ones)
        self.n_passages += clock.passages
        self.n_charts += clock.charts
        self.passages += [float(self._passage_log[k % PASSAGE_LOG])
                          for k in range(max(0, clock.passages - PASSAGE_LOG), clock.passages)]
        return out


@contextlib.contextmanager
def _signals_kept(integ: Integrator):
    """While the kernel calls back into Python, keep what a signal handler raises, and stop the run.

    Python runs a signal's handler at the next function it enters, which during a
    run is the kernel's callback: Ctrl-C's KeyboardInterrupt would be raised
    there, where ctypes can only print and drop it, and the run would go on.  The
    handlers are wrapped for the call instead: what they raise is kept as the
    callback's error (the run stops at the next evaluation) and raised once the
    kernel has returned.  Only in the main thread (the one that runs handlers);
    the caller enters it only when the kernel calls back.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = {}
    for sig in (signal.SIGINT, getattr(signal, "SIGTERM", None)):
        handler = signal.getsignal(sig) if sig is not None else None
        if callable(handler):
            saved[sig] = handler
            signal.signal(sig, functools.partial(_keep_raised, integ, handler))
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def _keep_raised(integ: Integrator, handler, signum, frame) -> None:
    try:
        handler(signum, frame)
    except BaseException as exc:  # noqa: BLE001 - raised by _run once the kernel returns
        if integ._callback_error is None:
            integ._callback_error = exc


def _over_budget(steps: float, t0: float, reached: float, target: float, budget: int) -> StepBudgetError:
    pace = steps / (reached - t0)
    return StepBudgetError(f"some {steps:.2g} steps reached t = {reached:.6g} s, {pace:.2g} steps per simulated "
                           f"second: at that pace t = {target:.6g} s needs more than the {budget} steps allowed",
                           steps, reached, target, pace * (target - t0), budget)


def _failure(status: int, where: float, limit: float) -> str:
    if status == binding.BAD_ARGUMENT:
        return f"the kernel refused its arguments at t = {where:.6g} s (a time, tolerance or step out of range)"
    if status == binding.NONFINITE_DERIVATIVE:
        return f"non-finite derivative at t = {where:.6g} s"
    if status == binding.STEP_UNDERFLOW:
        return (f"step size fell below {limit:.3g} s at t = {where:.6g} s: the motion is too fast or "
                "the mechanism is at a singular (locked) position")
    if status == binding.TOO_MANY_STEPS:
        return f"more than {int(limit)} steps before t = {where:.6g} s"
    if status == binding.BRANCH_JUMP:
        return (f"at t = {where:.6g} s keeping the loop closed would take {100 * limit:.3g} % of the joint "
                "speeds away: the linkage is at a position where two of its assembly branches meet (a change "
                "point), and the exact closure cannot tell which one it takes, or a fixed step is too long "
                "for the motion; stopped rather than lose the energy")
    return f"non-finite state at t = {where:.6g} s with fixed step {limit:.3g} s"
