"""Explicit Runge-Kutta integrators with error control and manifold projection.

Written here rather than borrowed from ``scipy.integrate.solve_ivp`` because a
closed loop needs two things solve_ivp does not offer: a projection back onto the
closure after every accepted step (the exact method's drift control), and an
integrator state (time, state, step size) that can be saved and restored whole, as
an FMU's rollback requires.  The Dormand-Prince 8(5,3) coefficients are read from
scipy's own table; the 5(4) pair and classic RK4 are the published tableaux.

The stepping loop (stages, error control, step-size control, projection, DOP853's
continuous extension for output times between steps) is one compiled kernel,
:func:`advance`, that calls the compiled state equation
(:func:`grubler.dynamics.rhs_into`) directly: an :meth:`Integrator.advance_to` is
one call into compiled code however many steps it takes.  The implicit methods
(stiff penalty closures) are scipy's, calling the same state equation.

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

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .assembly import project_into
from .dynamics import EXACT, METHOD_CODE, rhs_into, workspace
from .errors import IntegrationError
from .jit import jit
from .model import Mechanism


@dataclass(frozen=True)
class Tableau:
    name: str
    A: np.ndarray
    b: np.ndarray
    c: np.ndarray
    order: int  # of the propagated solution
    error_order: int  # of the embedded estimate; step factor uses 1/(error_order+1)
    adaptive: bool = True
    e: np.ndarray | None = None  # weights of the error estimate (incl. the FSAL stage)
    e3: np.ndarray | None = None  # DOP853's second, 3rd-order estimate
    # continuous extension: DENSE_STAGES more stages (their A rows over all
    # s + 1 + DENSE_STAGES derivatives, and c) and the interpolant's D (DOP853's)
    dense_a: np.ndarray | None = None
    dense_c: np.ndarray | None = None
    dense_d: np.ndarray | None = None

    @property
    def packed(self) -> tuple:
        """The tableau as :func:`advance` takes it: two tables and flags.

        The (s + 4, s + 1) table holds A in rows 0..s-1, then b, c, e and e3
        (zeros where absent); the dense table the extra stages' A rows, their c
        and the interpolant's D (one zero row when there is no dense output).
        """
        s = len(self.c)
        table = np.zeros((s + 4, s + 1))
        table[:s, :s] = self.A
        table[s, :s] = self.b
        table[s + 1, :s] = self.c
        if self.e is not None:
            table[s + 2, :len(self.e)] = self.e
        if self.e3 is not None:
            table[s + 3, :len(self.e3)] = self.e3
        dense = np.zeros((1, 1))
        if self.dense_d is not None:
            dense = np.zeros((DENSE_STAGES + 1 + DENSE_D_ROWS, s + 1 + DENSE_STAGES))
            dense[:DENSE_STAGES] = self.dense_a
            dense[DENSE_STAGES, :DENSE_STAGES] = self.dense_c
            dense[DENSE_STAGES + 1:] = self.dense_d
        return (table, bool(self.adaptive), int(self.error_order), self.e3 is not None, dense,
                self.dense_d is not None)


def _dopri5() -> Tableau:
    A = np.zeros((7, 7))
    A[1, :1] = [1 / 5]
    A[2, :2] = [3 / 40, 9 / 40]
    A[3, :3] = [44 / 45, -56 / 15, 32 / 9]
    A[4, :4] = [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729]
    A[5, :5] = [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]
    A[6, :6] = [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]
    b = A[6, :6].copy()
    b4 = np.array([5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40])
    e = np.append(b, 0.0) - b4
    c = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1])
    return Tableau("rk45", A[:6, :6], b, c, 5, 4, True, e)


def _dop853() -> Tableau:
    from scipy.integrate._ivp import dop853_coefficients as dc

    s = dc.N_STAGES
    assert dc.N_STAGES_EXTENDED == s + 1 + DENSE_STAGES and dc.D.shape[0] == DENSE_D_ROWS
    return Tableau("dop853", dc.A[:s, :s], dc.B, dc.C[:s], 8, 7, True, dc.E5, dc.E3,
                   dense_a=dc.A[s + 1:], dense_c=dc.C[s + 1:], dense_d=dc.D)


def _rk4() -> Tableau:
    A = np.zeros((4, 4))
    A[1, 0] = 0.5
    A[2, 1] = 0.5
    A[3, 2] = 1.0
    return Tableau("rk4", A, np.array([1 / 6, 1 / 3, 1 / 3, 1 / 6]), np.array([0, 0.5, 0.5, 1.0]), 4, 4, False)


TABLEAUS: dict[str, Callable[[], Tableau]] = {"dop853": _dop853, "rk45": _dopri5, "rk4": _rk4}
# implicit methods for stiff problems (high penalty gains), run by scipy
IMPLICIT = ("radau", "bdf")
METHODS = tuple(TABLEAUS) + IMPLICIT
_cache: dict[str, Tableau] = {}


def tableau(name: str) -> Tableau | None:
    """Butcher tableau by name: 'dop853' (default), 'rk45', 'rk4' (fixed step).

    None for the implicit methods, which scipy runs.
    """
    if name in IMPLICIT:
        return None
    if name not in TABLEAUS:
        raise ValueError(f"integrator: unknown {name!r}; choose one of {', '.join(METHODS)}")
    if name not in _cache:
        _cache[name] = TABLEAUS[name]()
    return _cache[name]


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
    drive_key : int
        Key of a drive effort given as a function of time
        (:func:`grubler.dynamics.register_drive`); -1 for the constant ``drive``.
    project_state : bool
        Project onto the closures after every step (the exact method).
    scale : float
        Length scale of the projection's position tolerance, m.
    """

    model: Mechanism
    method: str = EXACT
    drive: float = 0.0
    load: float = 0.0
    drive_key: int = -1
    project_state: bool = False
    scale: float = 1.0

    def __post_init__(self):
        self.method_code = METHOD_CODE[self.method]
        self.work = workspace(self.model.n_links, len(self.model.closures))

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        y = np.ascontiguousarray(y, dtype=float)
        out = np.empty_like(y)
        rhs_into(self.model.arrays.packed, self.method_code, float(t), y, self.drive_key, float(self.drive),
                 float(self.load), self.work, out)
        return out

    def project(self, y: np.ndarray) -> np.ndarray:
        """``y`` put back onto the closures (a new array)."""
        y = np.array(y, dtype=float)
        project_into(self.model.arrays.packed, float(self.scale), y, self.work)
        return y


SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
# what advance() reports
OK, NONFINITE_DERIVATIVE, STEP_UNDERFLOW, TOO_MANY_STEPS, NONFINITE_FIXED_STEP, BRANCH_JUMP_STATUS = range(6)
BRANCH_JUMP = 1e-2  # fraction of the joint speeds one projection may remove
# DOP853's continuous extension (Hairer, Norsett & Wanner, Solving ODEs I, II.6):
# three more stages and a 7th-degree interpolant with 4 rows of coefficients
DENSE_STAGES, DENSE_D_ROWS = 3, 4


# rows of the integrator's state table Y, after the s + 1 stage derivatives (the
# last one is f at the step's end) and the dense output's extra stages: stage
# state, proposed state, projected state, current state, current derivative
@jit(inline=True)
def _y_rows(s):
    k = s + 1 + DENSE_STAGES
    return k, k + 1, k + 2, k + 3, k + 4


@jit(inline=True)
def _copy_row(dst, i, src, j):
    # a slice assignment would need reference counting, which the loop goes without
    for r in range(src.shape[1]):
        dst[i, r] = src[j, r]


@jit(inline=True)
def _all_finite(x):
    for v in x:
        if not math.isfinite(v):
            return False
    return True


@jit(inline=True)
def _error_norm(tab, h, Y, rtol, atol):
    """Scaled error estimate of the step in ``Y``; <= 1 accepts it."""
    E, _, _, has_e3, _, _ = tab
    s = E.shape[1] - 1
    _, new, _, cur, _ = _y_rows(s)
    N = Y.shape[1]
    e5_sum = 0.0
    e3_sum = 0.0
    for r in range(N):
        scale = atol + rtol * max(abs(Y[cur, r]), abs(Y[new, r]))
        acc5 = 0.0
        acc3 = 0.0
        for j in range(s + 1):
            acc5 += E[s + 2, j] * Y[j, r]
            acc3 += E[s + 3, j] * Y[j, r]
        e5_sum += (acc5 / scale) ** 2
        e3_sum += (acc3 / scale) ** 2
    if not has_e3:
        return abs(h) * math.sqrt(e5_sum / N)
    # Hairer's DOP853 estimate, mixing the 5th- and 3rd-order errors
    if e5_sum == 0.0 and e3_sum == 0.0:
        return 0.0
    return abs(h) * e5_sum / math.sqrt((e5_sum + 0.01 * e3_sum) * N)


@jit(inline=True)
def _try_step(tab, P, method, inputs, W, t, h, Y, rtol, atol):
    """One Runge-Kutta step of size h from the current state, f(t, y) in ``Y[0]``.

    Fills the proposed state and, for an adaptive tableau, ``Y[s]`` = its
    derivative.  Returns the scaled error (0 for a fixed-step tableau, inf when the
    step made a non-finite number) and the number of evaluations.
    """
    E, adaptive, _, _, _, _ = tab
    drive_key, tau_drive, tau_load = inputs
    s = E.shape[1] - 1
    stage, new, _, cur, _ = _y_rows(s)
    N = Y.shape[1]
    for i in range(1, s):
        for r in range(N):
            acc = 0.0
            for j in range(i):
                acc += E[i, j] * Y[j, r]
            Y[stage, r] = Y[cur, r] + h * acc
        rhs_into(P, method, t + E[s + 1, i] * h, Y[stage], drive_key, tau_drive, tau_load, W, Y[i])
    for r in range(N):
        acc = 0.0
        for j in range(s):
            acc += E[s, j] * Y[j, r]
        Y[new, r] = Y[cur, r] + h * acc
    if not adaptive:
        return 0.0, s - 1
    rhs_into(P, method, t + h, Y[new], drive_key, tau_drive, tau_load, W, Y[s])
    if not (_all_finite(Y[new]) and _all_finite(Y[s])):
        return math.inf, s
    return _error_norm(tab, h, Y, rtol, atol), s


@jit(inline=True)
def _initial_step(tab, P, method, inputs, W, t, Y, h_max, rtol, atol):
    # Hairer, Norsett & Wanner, Solving ODEs I, II.4
    E, _, error_order, _, _, _ = tab
    drive_key, tau_drive, tau_load = inputs
    s = E.shape[1] - 1
    stage, _, _, cur, der = _y_rows(s)
    N = Y.shape[1]
    d0 = 0.0
    d1 = 0.0
    for r in range(N):
        scale = atol + rtol * abs(Y[cur, r])
        d0 += (Y[cur, r] / scale) ** 2
        d1 += (Y[der, r] / scale) ** 2
    d0 = math.sqrt(d0 / N)
    d1 = math.sqrt(d1 / N)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    for r in range(N):
        Y[stage, r] = Y[cur, r] + h0 * Y[der, r]
    rhs_into(P, method, t + h0, Y[stage], drive_key, tau_drive, tau_load, W, Y[s])
    d2 = 0.0
    for r in range(N):
        d2 += ((Y[s, r] - Y[der, r]) / (atol + rtol * abs(Y[cur, r]))) ** 2
    d2 = math.sqrt(d2 / N) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (error_order + 1))
    return min(100.0 * h0, h1, h_max)


@jit(inline=True)
def _dense_stages(X, s, P, method, inputs, W, t, h, Y):
    """The continuous extension's extra stages of the step just accepted, into
    ``Y[s + 1:s + 1 + DENSE_STAGES]``; returns the evaluations made."""
    drive_key, tau_drive, tau_load = inputs
    stage, _, _, cur, _ = _y_rows(s)
    N = Y.shape[1]
    for k in range(DENSE_STAGES):
        for r in range(N):
            acc = 0.0
            for j in range(s + 1 + k):
                acc += X[k, j] * Y[j, r]
            Y[stage, r] = Y[cur, r] + h * acc
        rhs_into(P, method, t + X[DENSE_STAGES, k] * h, Y[stage], drive_key, tau_drive, tau_load, W,
                 Y[s + 1 + k])
    return DENSE_STAGES


@jit(inline=True)
def _interpolate(X, s, x, h, Y, out, o):
    """The state at fraction ``x`` of the step just accepted, into ``out[o]``.

    DOP853's interpolant in Hairer's nested form: ``y0 + x (F0 + (1 - x) (F1 + x
    (F2 + ...))))``, from the step's ends, derivatives and extra stages.
    """
    _, new, _, cur, _ = _y_rows(s)
    N = Y.shape[1]
    d0 = DENSE_STAGES + 1
    n_k = s + 1 + DENSE_STAGES
    for r in range(N):
        dy = Y[new, r] - Y[cur, r]
        acc = 0.0
        for i in range(DENSE_D_ROWS + 3):
            row = DENSE_D_ROWS + 2 - i  # F6 first, F0 last
            if row >= 3:
                f = 0.0
                for j in range(n_k):
                    f += X[d0 + row - 3, j] * Y[j, r]
                f *= h
            elif row == 2:
                f = 2.0 * dy - h * (Y[s, r] + Y[0, r])
            elif row == 1:
                f = h * Y[0, r] - dy
            else:
                f = dy
            acc += f
            acc *= x if i % 2 == 0 else 1.0 - x
        out[o, r] = Y[cur, r] + acc


@jit(nrt=True)
def advance(tab, P, method, project, scale, inputs, t, y0, f0, have_f, h, t_out, h_max, rtol, atol,
            max_steps):
    """Step the mechanism's state equation from ``t`` through the times ``t_out``.

    The state at each time of ``t_out`` (increasing) is recorded: one call
    integrates a whole output grid.  The last time is reached exactly (the
    efforts may change there).  With a continuous extension (DOP853) the steps
    are the controller's own and the times before the last are interpolated,
    then projected like a step's end; without one, every time is a step's end.

    Parameters
    ----------
    tab : tuple
        ``Tableau.packed``.
    P, method : tuple, int
        ``Mechanism.arrays.packed`` and the closure method code (0 exact, 1 penalty).
    project : bool
        Project onto the closures after every accepted step (``scale`` sets the
        position tolerance).
    inputs : (int, float, float)
        Drive-function key (-1: none), drive and load efforts.
    t, y0, f0, have_f, h : float, ndarray, ndarray, bool, float
        The integrator's state; ``f0`` is used only when ``have_f``.
    t_out : ndarray
        Times to stop at.
    max_steps : int
        Steps allowed in this call.

    Returns
    -------
    status, t, Y, out, have_f, h, steps, rejected, evals, where, limit
        ``status`` is OK or the failure; ``Y``'s last two rows the new state and
        derivative, ``out`` the state at each time of ``t_out``; ``where`` and
        ``limit`` the time and the step (or step limit) a failure names.  On
        failure the returned state is not to be used.
    """
    s = tab[0].shape[1] - 1
    _, _, _, cur, der = _y_rows(s)
    N = y0.shape[0]
    # the only allocations; the stepping loop runs without reference counting,
    # which would otherwise cost atomic operations on every stage's array views
    W = workspace(N // 2, P[1].shape[0])
    Y = np.empty((_y_rows(s)[4] + 1, N))
    out = np.empty((t_out.shape[0], N))
    Y[cur] = y0
    Y[der] = f0
    status, t, have_f, h, steps, rejected, evals, where, limit = _advance_in(
        tab, P, method, project, scale, inputs, t, have_f, h, t_out, h_max, rtol, atol, max_steps, W, Y, out)
    return status, t, Y, out, have_f, h, steps, rejected, evals, where, limit


@jit
def _advance_in(tab, P, method, project, scale, inputs, t, have_f, h, t_out, h_max, rtol, atol, max_steps,
                W, Y, out):
    """:func:`advance`'s loop, in the tables it allocated; returns its scalars."""
    E, adaptive, error_order, _, X, dense = tab
    drive_key, tau_drive, tau_load = inputs
    s = E.shape[1] - 1
    _, new, proj, cur, der = _y_rows(s)
    N = Y.shape[1]
    steps = 0
    rejected_total = 0
    evals = 0
    exponent = -1.0 / (error_order + 1)
    last = t_out.shape[0] - 1
    o = 0
    while o <= last:
        # with a continuous extension the steps aim at the last time and the others
        # are interpolated; without, each time is a step's end
        t_target = t_out[last] if dense else t_out[o]
        while t_target - t > 1e-12 * max(1.0, abs(t_target)):
            if not have_f:
                rhs_into(P, method, t, Y[cur], drive_key, tau_drive, tau_load, W, Y[der])
                evals += 1
                if not _all_finite(Y[der]):
                    return NONFINITE_DERIVATIVE, t, have_f, h, steps, rejected_total, evals, t, 0.0
                have_f = True
            _copy_row(Y, 0, Y, der)
            if not adaptive:
                step = min(h, t_target - t)
                _, k = _try_step(tab, P, method, inputs, W, t, step, Y, rtol, atol)
                evals += k
                if not _all_finite(Y[new]):
                    return (NONFINITE_FIXED_STEP, t, have_f, h, steps, rejected_total, evals, t + step,
                            step)
                have_new_f = False
            else:
                if h <= 0.0:
                    h = _initial_step(tab, P, method, inputs, W, t, Y, h_max, rtol, atol)
                    evals += 1
                proposed = min(h, h_max)
                step = min(proposed, t_target - t)
                clipped = step < proposed
                h_min = 1e-13 * max(1.0, abs(t))
                rejected = False
                while True:
                    if step < h_min:
                        return STEP_UNDERFLOW, t, have_f, h, steps, rejected_total, evals, t, h_min
                    err, k = _try_step(tab, P, method, inputs, W, t, step, Y, rtol, atol)
                    evals += k
                    if err <= 1.0:
                        break
                    rejected_total += 1
                    rejected = True
                    if math.isfinite(err):
                        step *= max(MIN_FACTOR, SAFETY * err ** exponent)
                    else:
                        step *= MIN_FACTOR
                    clipped = False
                if err == 0.0:
                    factor = MAX_FACTOR
                else:
                    factor = min(MAX_FACTOR, SAFETY * err ** exponent)
                if rejected:
                    factor = min(1.0, factor)
                # a step shortened only to land on t_target keeps the controller's proposal
                h = max(proposed, step * factor) if clipped else step * factor
                have_new_f = True
                t_end = t + step
                if dense and o < last and t_out[o] < t_end - 1e-12 * max(1.0, abs(t_end)):
                    evals += _dense_stages(X, s, P, method, inputs, W, t, step, Y)
                    while o < last and t_out[o] < t_end - 1e-12 * max(1.0, abs(t_end)):
                        _interpolate(X, s, (t_out[o] - t) / step, step, Y, out, o)
                        if project:
                            project_into(P, scale, out[o], W)
                        o += 1
            if project:
                _copy_row(Y, proj, Y, new)
                project_into(P, scale, Y[proj], W)
                # a step's correction is of the order of the tolerance; one that takes
                # a good part of the speed away means the step crossed a position
                # where two assembly branches meet (a change point) and landed on
                # the other: the motion would go on, closed but with energy gone
                half = N // 2
                dv2 = 0.0
                v2 = 0.0
                for r in range(half, N):
                    dv2 += (Y[proj, r] - Y[new, r]) ** 2
                    v2 += Y[new, r] ** 2
                # (relative to the speed, and far above the tolerance: a resting
                # linkage's last 1e-9 rad/s may well be corrected away)
                if dv2 > BRANCH_JUMP**2 * v2 and dv2 > (1e3 * atol) ** 2:
                    return (BRANCH_JUMP_STATUS, t, have_f, h, steps, rejected_total, evals, t,
                            math.sqrt(dv2 / v2))
                # a correction far below the tolerance leaves the derivative valid
                if have_new_f:
                    d = 0.0
                    for r in range(N):
                        d += ((Y[proj, r] - Y[new, r]) / (atol + rtol * abs(Y[proj, r]))) ** 2
                    if math.sqrt(d / N) > 1e-3:
                        have_new_f = False
                _copy_row(Y, new, Y, proj)
            t += step
            _copy_row(Y, cur, Y, new)
            if have_new_f:
                _copy_row(Y, der, Y, s)
            have_f = have_new_f
            steps += 1
            if steps > max_steps:
                return (TOO_MANY_STEPS, t, have_f, h, steps, rejected_total, evals, t_target,
                        float(max_steps))
            # times the step ended on (to rounding) take its projected state
            while dense and o < last and t_out[o] - t <= 1e-12 * max(1.0, abs(t_out[o])):
                _copy_row(out, o, Y, cur)
                o += 1
        t = t_target
        _copy_row(out, o, Y, cur)
        o += 1
    return OK, t, have_f, h, steps, rejected_total, evals, t, 0.0


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
    _tab: Tableau = field(init=False, repr=False)

    def __post_init__(self):
        self._tab = tableau(self.method)
        self._packed = None if self._tab is None else self._tab.packed
        self.y = np.array(self.y, dtype=float)
        for name in ("rtol", "atol"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"{name}: must be positive and finite, got {v}")
        if self._tab is not None and not self._tab.adaptive and not (self.h > 0 and math.isfinite(self.h)):
            raise ValueError(f"step: the fixed-step {self.method} needs a positive step, got {self.h}")

    # -- state ----------------------------------------------------------------
    def snapshot(self) -> dict:
        """Everything that determines the rest of the run (for rollback).

        The arrays are shared, not copied: the integrator never writes into ``y``
        or ``f`` in place, it rebinds them to new arrays at every advance.
        """
        return {"t": self.t, "y": self.y, "h": self.h, "f": self.f,
                "counts": (self.n_steps, self.n_rejected, self.n_evals)}

    def restore(self, snap: dict) -> None:
        self.t, self.y, self.h = snap["t"], snap["y"].copy(), snap["h"]
        self.f = None if snap["f"] is None else snap["f"].copy()
        self.n_steps, self.n_rejected, self.n_evals = snap["counts"]

    def reset_derivative(self) -> None:
        """Forget the cached derivative (after an input changed)."""
        self.f = None

    # -- stepping -------------------------------------------------------------
    def _advance_implicit(self, times: np.ndarray) -> np.ndarray:
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
                     first_step=first, max_step=self.h_max)
        steps = 0
        while solver.status == "running":
            msg = solver.step()
            if solver.status == "failed":
                raise IntegrationError(f"{self.method} failed at t = {solver.t:.6g} s: {msg}")
            steps += 1
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

    def advance_to(self, t_target: float, max_steps: int = 10_000_000) -> None:
        """Step until ``t`` reaches ``t_target`` exactly.

        All or nothing: if it fails, the integrator is left where it started, so a
        caller (an FMU asked to retry with a shorter step) can go on from there.
        """
        t_target = float(t_target)
        # (NaN fails the comparison too)
        if not (math.isfinite(t_target) and t_target >= self.t - 1e-12 * max(1.0, abs(self.t))):
            raise ValueError(f"t: must be finite and not before the integrator's time {self.t:.12g} s, "
                             f"got {t_target!r}")
        if self._tab is None:
            self._advance_implicit(np.array([t_target]))
            return
        self._advance(np.array([t_target]), max_steps)

    def advance_through(self, times: np.ndarray, max_steps: int = 10_000_000) -> np.ndarray:
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
        if self._tab is None and self.ode.project_state:
            # the exact closure's drift is removed only where scipy's solver is
            # restarted from a projected state: at every output time
            out = np.empty((len(times), self.y.size))
            start = self.snapshot()
            try:
                for i in range(len(times)):
                    self._advance_implicit(times[i:i + 1])
                    out[i] = self.y
            except BaseException:
                self.restore(start)
                raise
            return out
        if self._tab is None:
            return self._advance_implicit(times)
        return self._advance(times, max_steps)

    def _advance(self, times: np.ndarray, max_steps: int) -> np.ndarray:
        ode = self.ode
        have_f = self.f is not None
        status, t, Y, out, have_f, h, steps, rejected, evals, where, limit = advance(
            self._packed, ode.model.arrays.packed, ode.method_code, ode.project_state, ode.scale,
            (ode.drive_key, float(ode.drive), float(ode.load)), float(self.t), self.y,
            self.f if have_f else self.y, have_f, float(self.h), times, float(self.h_max),
            float(self.rtol), float(self.atol), int(max_steps))
        if status != OK:
            raise IntegrationError(_failure(status, where, limit))
        self.t, self.y, self.f, self.h = t, Y[-2], (Y[-1] if have_f else None), h
        self.n_steps += steps
        self.n_rejected += rejected
        self.n_evals += evals
        return out


def _failure(status: int, where: float, limit: float) -> str:
    if status == NONFINITE_DERIVATIVE:
        return f"non-finite derivative at t = {where:.6g} s"
    if status == STEP_UNDERFLOW:
        return (f"step size fell below {limit:.3g} s at t = {where:.6g} s: the motion is too fast or "
                "the mechanism is at a singular (locked) position")
    if status == TOO_MANY_STEPS:
        return f"more than {int(limit)} steps before t = {where:.6g} s"
    if status == BRANCH_JUMP_STATUS:
        return (f"at t = {where:.6g} s keeping the loop closed would take {100 * limit:.3g} % of the joint "
                "speeds away: the linkage is at a position where two of its assembly branches meet (a change "
                "point), and the exact closure cannot tell which one it takes, or a fixed step is too long "
                "for the motion; stopped rather than lose the energy")
    return f"non-finite state at t = {where:.6g} s with fixed step {limit:.3g} s"
