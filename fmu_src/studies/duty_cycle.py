"""A drive's duty cycle and what it asks of the drive joint.

One period of the drive joint's motion (a move profile repeated, a constant
speed, or a recorded trajectory) and its load; :func:`required_drive` gives the
torque and speed the joint needs over it (the inverse dynamics,
:func:`grubler.mechanism.inverse.drive_demand`), :func:`drive_inertia` the
inertia the joint sees there.  :mod:`grubler.studies.sizing` judges motors on it.

Examples
--------
>>> import numpy as np
>>> cycle = DutyCycle.constant_speed(2 * np.pi, n=200)
>>> round(float(cycle.t[-1]), 6), round(float(cycle.velocity.max()), 6)
(1.0, 6.283185)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grubler.errors import SceneError
from grubler.limits import check_count
from grubler.mechanism.inverse import DriveDemand, drive_demand
from grubler.mechanism.model import Mechanism


MAX_SAMPLES = 1e6  # samples of one duty cycle


@dataclass
class DutyCycle:
    """One period of the drive joint's motion, repeated endlessly, and its load.

    Attributes
    ----------
    t, position, velocity, acceleration, load : ndarray
        Samples over one period (``t`` from 0 to the period, both ends).
    name : str

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.studies.sizing import DutyCycle, required_drive
    >>> cycle = DutyCycle.constant_speed(2 * np.pi, n=5)     # one turn at 1 rev/s, 5 samples
    >>> cycle.t, cycle.position.round(3), cycle.period, cycle.name
    (array([0.  , 0.25, 0.5 , 0.75, 1.  ]), array([0.   , 1.571, 3.142, 4.712, 6.283]), 1.0, 'constant 6.28319 rad/s')
    >>> from grubler.controllers import Trajectory             # a half-turn move and back, from a setpoint generator
    >>> move = Trajectory(kind="trapezoid", distance=np.pi, v_max=2 * np.pi, a_max=8 * np.pi, dwell=0.25,
    ...                   reverse=True, repeat=0)                     # 0.75 s moving, 0.25 s still, then back
    >>> back_and_forth = DutyCycle.from_trajectory(move, period=2.0, n=201)
    >>> round(float(back_and_forth.position.max()), 4), round(float(back_and_forth.velocity.max()), 4)
    (3.1416, 6.2832)
    >>> rec = DutyCycle.recorded(np.linspace(0, 1, 11), np.sin(np.linspace(0, 1, 11)))  # measured positions
    >>> round(float(rec.velocity[0]), 2)                       # d/dt sin(t) at 0, from the spline
    1.0
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    load: np.ndarray
    name: str = ""

    @property
    def period(self) -> float:
        """Length of one period, s."""
        return float(self.t[-1] - self.t[0])

    @staticmethod
    def from_trajectory(trajectory, period: float, n: int = 1001, load=0.0, start: float | None = None,
                        name: str = "") -> "DutyCycle":
        """Sample anything with ``evaluate(t) -> (position, velocity, acceleration)``.

        E.g. a :class:`grubler.controllers.Trajectory` move with its dwell,
        ``period`` = move time + dwell (twice that for a back-and-forth move).
        ``start`` is the position offset added (default: none).
        """
        if not (period > 0 and math.isfinite(period)):
            raise SceneError("duty_cycle.period", f"must be positive and finite, got {period}")
        t = sample_times(period, int(n), getattr(trajectory, "breakpoints", lambda _: [])(period))
        pva = np.array([trajectory.evaluate(float(tk)) for tk in t])
        load = np.broadcast_to(np.asarray(load, float), t.shape).copy()
        return DutyCycle(t, pva[:, 0] + (start or 0.0), pva[:, 1], pva[:, 2], load, name)

    @staticmethod
    def constant_speed(speed: float, n: int = 721, load=0.0, start: float = 0.0) -> "DutyCycle":
        """One turn (2 pi) of the drive joint at constant ``speed`` (rad/s)."""
        if not (speed != 0 and math.isfinite(speed)):
            raise SceneError("duty_cycle.speed", f"must be non-zero and finite, got {speed}")
        t = np.linspace(0.0, 2 * math.pi / abs(speed), int(n))
        load = np.broadcast_to(np.asarray(load, float), t.shape).copy()
        return DutyCycle(t, start + speed * t, np.full_like(t, speed), np.zeros_like(t), load,
                         f"constant {speed:g} rad/s")

    @staticmethod
    def recorded(t, position, load=0.0, name: str = "recorded") -> "DutyCycle":
        """A recorded trajectory, differentiated through a periodic-free cubic spline."""
        from scipy.interpolate import CubicSpline

        t, position = np.asarray(t, float), np.asarray(position, float)
        if len(t) < 4 or len(t) != len(position) or np.any(np.diff(t) <= 0):
            raise SceneError("duty_cycle.t", "needs at least 4 samples at increasing times, one position each")
        spline = CubicSpline(t, position)
        load = np.broadcast_to(np.asarray(load, float), t.shape).copy()
        return DutyCycle(t - t[0], position, spline(t, 1), spline(t, 2), load, name)


def sample_times(period: float, n: int, breakpoints=(), per_phase: int = 64) -> np.ndarray:
    """``n`` times over ``[0, period]``, and ``per_phase`` more in every phase between breakpoints.

    A uniform grid alone misses a short move in a long dwell (a 0.7 s move in a
    one-hour cycle falls between samples): each phase of the motion law gets its
    own samples, whatever its length.

    Examples
    --------
    >>> t = sample_times(3600.0, 11, [1.0, 2.0], per_phase=4)
    >>> [float(x) for x in t[(t > 0.9) & (t < 2.5)]]
    [1.0, 1.25, 1.5, 1.75, 2.0]
    """
    knots = np.unique(np.clip(np.concatenate([[0.0, period], np.asarray(list(breakpoints), float)]), 0.0, period))
    check_count(len(knots) * per_phase + n, MAX_SAMPLES, "samples of the duty cycle", "the move or its dwell")
    parts = [np.linspace(0.0, period, n)] + [np.linspace(a, b, per_phase + 1) for a, b in zip(knots[:-1], knots[1:])]
    return np.unique(np.concatenate(parts))


def rms(x: np.ndarray, t: np.ndarray | None = None) -> float:
    """Root mean square; over time when the sample instants ``t`` are given (they need not be even)."""
    x = np.asarray(x, float)
    if t is None:
        return float(np.sqrt(np.mean(x**2)))
    x2 = x**2
    return float(np.sqrt(np.sum(0.5 * (x2[1:] + x2[:-1]) * np.diff(t)) / (t[-1] - t[0])))


def required_drive(model: Mechanism, cycle: DutyCycle) -> DriveDemand:
    """The drive joint's torque over the cycle, without any motor's rotor inertia.

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.studies.sizing import DutyCycle, required_drive
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> demand = required_drive(m, DutyCycle.constant_speed(2 * np.pi, n=5))
    >>> demand.torque.round(3)                  # N m at the crank, over one turn at 1 rev/s
    array([ 2.653,  0.129, -6.991,  3.259,  2.653])
    """
    return drive_demand(model.replace(drive_inertia=0.0), cycle.position, cycle.velocity, cycle.acceleration,
                        cycle.load)


def drive_inertia(model: Mechanism, cycle: DutyCycle, demand: DriveDemand) -> np.ndarray:
    """The mechanism's inertia at the drive joint along the cycle, kg m2 (kg on a slide).

    The drive effort is linear in the drive's acceleration at a given position
    and speed (the dependent accelerations are), so one more inverse-dynamics
    pass with the acceleration raised by 1 gives ``M_eff = tau(a + 1) - tau(a)``.

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.studies.sizing import DutyCycle, drive_inertia, required_drive
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> cycle = DutyCycle.constant_speed(2 * np.pi, n=5)
    >>> drive_inertia(m, cycle, required_drive(m, cycle)).round(3)     # kg m2 seen at the crank
    array([0.231, 0.204, 0.186, 0.166, 0.231])
    """
    more = drive_demand(model.replace(drive_inertia=0.0), cycle.position, cycle.velocity, cycle.acceleration + 1.0,
                        cycle.load)
    return more.torque - demand.torque


__all__ = ["DutyCycle", "sample_times", "rms", "required_drive", "drive_inertia"]
