"""Explicit Runge-Kutta integrators with error control and manifold projection.

Written here rather than borrowed from ``scipy.integrate.solve_ivp`` because a
closed loop needs two things solve_ivp does not offer: a projection back onto the
closure after every accepted step (the exact method's drift control), and an
integrator state (time, state, step size) that can be saved and restored whole, as
an FMU's rollback requires.  The Dormand-Prince 8(5,3) coefficients are read from
scipy's own table; the 5(4) pair and classic RK4 are the published tableaux.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .errors import IntegrationError


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
    return Tableau("dop853", dc.A[:s, :s], dc.B, dc.C[:s], 8, 7, True, dc.E5, dc.E3)


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


SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0


@dataclass
class Integrator:
    """One integration in progress: everything needed to continue it, or replay it.

    Parameters
    ----------
    fun : callable ``fun(t, y) -> ydot``
    t, y : float, ndarray
        Initial time and state.
    method : str
        Tableau name.
    rtol, atol : float
        Error tolerances (adaptive methods).
    h : float
        Fixed step (rk4) or first step (adaptive; 0 picks one).
    project : callable ``project(y) -> y``, optional
        Called after each accepted step; returns the state put back on the
        constraint manifold.
    h_max : float
        Largest step.
    """

    fun: Callable
    t: float
    y: np.ndarray
    method: str = "dop853"
    rtol: float = 1e-8
    atol: float = 1e-10
    h: float = 0.0
    project: Callable | None = None
    h_max: float = math.inf
    f: np.ndarray | None = None
    n_steps: int = 0
    n_rejected: int = 0
    n_evals: int = 0
    _tab: Tableau = field(init=False, repr=False)

    def __post_init__(self):
        self._tab = tableau(self.method)
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
        or ``f`` in place, it rebinds them to new arrays at every step.
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
    def _eval(self, t, y):
        self.n_evals += 1
        return self.fun(t, y)

    def _scale(self, y, y_new):
        return self.atol + self.rtol * np.maximum(np.abs(y), np.abs(y_new))

    def _initial_step(self) -> float:
        # Hairer, Norsett & Wanner, Solving ODEs I, II.4
        f0 = self.f
        scale = self.atol + self.rtol * np.abs(self.y)
        d0 = np.sqrt(np.mean((self.y / scale) ** 2))
        d1 = np.sqrt(np.mean((f0 / scale) ** 2))
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        f1 = self._eval(self.t + h0, self.y + h0 * f0)
        d2 = np.sqrt(np.mean(((f1 - f0) / scale) ** 2)) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1 / (self._tab.error_order + 1))
        return min(100 * h0, h1, self.h_max)

    def _try_step(self, h: float):
        tab = self._tab
        s = len(tab.c)
        K = np.empty((s + 1, self.y.size))
        K[0] = self.f
        for i in range(1, s):
            K[i] = self._eval(self.t + tab.c[i] * h, self.y + h * (tab.A[i, :i] @ K[:i]))
        y_new = self.y + h * (tab.b @ K[:s])
        if not tab.adaptive:
            return y_new, None, 0.0
        f_new = self._eval(self.t + h, y_new)
        K[s] = f_new
        if not (np.all(np.isfinite(y_new)) and np.all(np.isfinite(f_new))):
            return y_new, f_new, math.inf
        scale = self._scale(self.y, y_new)
        if tab.e3 is None:
            err = np.sqrt(np.mean((h * (tab.e @ K) / scale) ** 2))
        else:
            # Hairer's DOP853 estimate, mixing the 5th- and 3rd-order errors
            e5 = np.sum(((tab.e @ K) / scale) ** 2)
            e3 = np.sum(((tab.e3 @ K) / scale) ** 2)
            err = 0.0 if e5 == 0 and e3 == 0 else abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * y_new.size)
        return y_new, f_new, err

    def step(self, t_limit: float = math.inf) -> None:
        """Take one accepted step, not past ``t_limit``."""
        if self.f is None:
            self.f = self._eval(self.t, self.y)
            if not np.all(np.isfinite(self.f)):
                raise IntegrationError(f"non-finite derivative at t = {self.t:.6g} s")
        tab = self._tab
        if not tab.adaptive:
            h = min(self.h, t_limit - self.t)
            y_new, _, _ = self._try_step(h)
            if not np.all(np.isfinite(y_new)):
                raise IntegrationError(f"non-finite state at t = {self.t + h:.6g} s with fixed step {h:.3g} s")
            self._accept(h, y_new, None)
            return
        if self.h <= 0:
            self.h = self._initial_step()
        proposed = min(self.h, self.h_max)
        h = min(proposed, t_limit - self.t)
        clipped = h < proposed
        h_min = 1e-13 * max(1.0, abs(self.t))
        rejected = False
        while True:
            if h < h_min:
                raise IntegrationError(
                    f"step size fell below {h_min:.3g} s at t = {self.t:.6g} s: the motion is too fast or "
                    "the mechanism is at a singular (locked) position")
            y_new, f_new, err = self._try_step(h)
            if err <= 1.0:
                break
            self.n_rejected += 1
            rejected = True
            factor = MIN_FACTOR if not math.isfinite(err) else max(MIN_FACTOR, SAFETY * err ** (-1 / (tab.error_order + 1)))
            h *= factor
            clipped = False
        if err == 0:
            factor = MAX_FACTOR
        else:
            factor = min(MAX_FACTOR, SAFETY * err ** (-1 / (tab.error_order + 1)))
        if rejected:
            factor = min(1.0, factor)
        # a step shortened only to land on t_limit keeps the controller's proposal
        self.h = max(proposed, h * factor) if clipped else h * factor
        self._accept(h, y_new, f_new)

    def _accept(self, h, y_new, f_new):
        if self.project is not None:
            y_proj = self.project(y_new)
            scale = self.atol + self.rtol * np.abs(y_proj)
            # a correction far below the tolerance leaves the derivative valid
            if f_new is not None and np.sqrt(np.mean(((y_proj - y_new) / scale) ** 2)) > 1e-3:
                f_new = None
            y_new = y_proj
        self.t += h
        self.y = y_new
        self.f = f_new
        self.n_steps += 1

    def _advance_implicit(self, t_target: float) -> None:
        # a fresh scipy solver per call: inputs may have changed at self.t
        import scipy.integrate

        cls = {"radau": scipy.integrate.Radau, "bdf": scipy.integrate.BDF}[self.method]
        first = min(self.h, t_target - self.t) if self.h > 0 else None
        solver = cls(self.fun, self.t, self.y, t_target, rtol=self.rtol, atol=self.atol,
                     first_step=first, max_step=self.h_max)
        while solver.status == "running":
            msg = solver.step()
            if solver.status == "failed":
                raise IntegrationError(f"{self.method} failed at t = {solver.t:.6g} s: {msg}")
            self.n_steps += 1
        y = solver.y
        if self.project is not None:
            y = self.project(y)
        self.n_evals += solver.nfev
        self.t, self.y, self.h, self.f = t_target, y, solver.step_size or self.h, None

    def advance_to(self, t_target: float, max_steps: int = 10_000_000) -> None:
        """Step until ``t`` reaches ``t_target`` exactly.

        All or nothing: if it fails, the integrator is left where it started, so a
        caller (an FMU asked to retry with a shorter step) can go on from there.
        """
        start = self.snapshot()
        try:
            if self._tab is None:
                if t_target > self.t:
                    self._advance_implicit(t_target)
                return
            steps = 0
            while t_target - self.t > 1e-12 * max(1.0, abs(t_target)):
                self.step(t_target)
                steps += 1
                if steps > max_steps:
                    raise IntegrationError(f"more than {max_steps} steps before t = {t_target:.6g} s")
            self.t = t_target
        except BaseException:
            self.restore(start)
            raise
