"""Setpoint trajectories: position, velocity and acceleration as functions of time.

Kinds:

- ``'constant'``: constant speed, ``p = start + speed (t - delay)``;
- ``'trapezoid'``: rest-to-rest move of ``distance`` with velocity limit
  ``v_max`` and acceleration limit ``a_max`` (a triangle when the distance is too
  short to reach ``v_max``);
- ``'scurve'``: the same move with jerk limit ``j_max`` as well (seven phases of
  constant jerk; the peaks are lowered when the move is too short);
- ``'sine'``: ``p = start + amplitude sin(2 pi frequency (t - delay))``;
- ``'table'``: recorded ``times`` and ``positions``, through a cubic spline with
  zero end velocities, so velocity and acceleration are its derivatives.

Moves (trapezoid, scurve) start at ``delay``, are followed by ``dwell`` seconds
at rest and repeat ``repeat`` times (0: forever), each continuing from where
the last stopped, or going back and forth when ``reverse`` is set.  Before
``delay`` every kind holds ``start`` at rest; after a table ends, its last point.

The profile is piecewise polynomial in time and evaluated exactly, so velocity
is the derivative of position and acceleration that of velocity.

Examples
--------
>>> tr = Trajectory("trapezoid", distance=1.0, v_max=2.0, a_max=8.0)
>>> tr.move_time                          # 0.25 s up to 2 rad/s, 0.25 s at it, 0.25 s down
0.75
>>> [round(x, 12) for x in tr.evaluate(0.4)]
[0.55, 2.0, 0.0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grubler.errors import SceneError
from grubler.limits import brief

from grubler.controllers.law import Law, Parameter, check_number

KINDS = ("constant", "trapezoid", "scurve", "sine", "table")


@dataclass(frozen=True)
class Segment:
    """Constant jerk over ``duration`` from the state (p0, v0, a0) at its start."""

    t0: float
    duration: float
    p0: float
    v0: float
    a0: float
    jerk: float

    def at(self, tau: float) -> tuple[float, float, float]:
        j = self.jerk
        return (self.p0 + tau * (self.v0 + tau * (self.a0 / 2 + tau * j / 6)),
                self.v0 + tau * (self.a0 + tau * j / 2),
                self.a0 + tau * j)


def _chain(phases: list[tuple[float, float, float]]) -> list[Segment]:
    """Segments from (duration, acceleration at start, jerk), starting at rest at 0."""
    segs, t, p, v = [], 0.0, 0.0, 0.0
    for duration, a0, jerk in phases:
        if duration <= 0:
            continue
        s = Segment(t, duration, p, v, a0, jerk)
        p, v, _ = s.at(duration)
        t += duration
        segs.append(s)
    return segs


def trapezoid_phases(distance: float, v_max: float, a_max: float) -> list[tuple[float, float, float]]:
    """Accelerate at a_max, cruise at v_max, brake: the shortest move with those limits."""
    v = min(v_max, math.sqrt(distance * a_max))  # a triangle when v_max is out of reach
    ta = v / a_max
    tv = distance / v - ta
    return [(ta, a_max, 0.0), (tv, 0.0, 0.0), (ta, -a_max, 0.0)]


def scurve_phases(distance: float, v_max: float, a_max: float, j_max: float) -> list[tuple[float, float, float]]:
    """Seven phases of jerk +J, 0, -J, 0, -J, 0, +J (Biagiotti and Melchiorri, 3.4)."""

    def accel_time(v: float) -> tuple[float, float]:
        # (jerk time, whole acceleration time) to reach speed v from rest
        if v * j_max >= a_max**2:
            return a_max / j_max, a_max / j_max + v / a_max
        tj = math.sqrt(v / j_max)
        return tj, 2 * tj

    v = v_max
    tj, ta = accel_time(v)
    if v * ta > distance:  # v_max out of reach: the peak speed whose move is exactly the distance
        v = (-a_max / j_max + math.sqrt((a_max / j_max) ** 2 + 4 * distance / a_max)) * a_max / 2
        if v * j_max < a_max**2:
            v = (distance * math.sqrt(j_max) / 2) ** (2 / 3)
        tj, ta = accel_time(v)
    a_peak = j_max * tj
    tv = distance / v - ta
    tc = ta - 2 * tj
    return [(tj, 0.0, j_max), (tc, a_peak, 0.0), (tj, a_peak, -j_max), (tv, 0.0, 0.0),
            (tj, 0.0, -j_max), (tc, -a_peak, 0.0), (tj, -a_peak, j_max)]


def _floats(value, field: str) -> np.ndarray:
    if isinstance(value, str):
        parts = [p for p in value.replace(",", " ").replace(";", " ").strip("[] ").split() if p]
        try:
            value = [float(p) for p in parts]
        except ValueError:
            raise SceneError(field, f"must be numbers separated by spaces or commas, got {brief(value)}") from None
    arr = np.asarray(value, dtype=float)
    if arr.ndim != 1 or not np.all(np.isfinite(arr)):
        raise SceneError(field, "must be a list of finite numbers")
    return arr


class Trajectory(Law):
    """A setpoint generator: position, velocity and acceleration at time t.

    Parameters
    ----------
    kind : {'constant', 'trapezoid', 'scurve', 'sine', 'table'}
    start : float
        Position at rest before the motion, rad.
    delay : float
        Time the motion starts, s.
    speed : float
        'constant': the speed, rad/s.
    distance, v_max, a_max, j_max : float
        Moves: length (signed), rad, and the limits (> 0) of velocity,
        acceleration and (scurve) jerk, rad/s, rad/s2, rad/s3.
    dwell : float
        Moves: rest after each move, s.
    repeat : int
        Moves: number of moves, 0 for endless.
    reverse : bool
        Moves: alternate direction (back and forth) instead of indexing on.
    amplitude, frequency : float
        'sine': rad and Hz.
    times, positions : sequence of float or str
        'table': increasing times, s, and positions, rad (a string of numbers in
        the FMU).
    """

    inputs: dict[str, str] = {}
    outputs = {"position": "position setpoint [rad]", "velocity": "velocity setpoint [rad/s]",
               "acceleration": "acceleration setpoint [rad/s2]"}
    parameters = {
        "kind": Parameter("trapezoid", "constant | trapezoid | scurve | sine | table [1]"),
        "start": Parameter(0.0, "position before the motion [rad]"),
        "delay": Parameter(0.0, "time the motion starts [s]"),
        "speed": Parameter(1.0, "constant: speed [rad/s]"),
        "distance": Parameter(1.0, "moves: length of each move (signed) [rad]"),
        "v_max": Parameter(1.0, "moves: velocity limit [rad/s]"),
        "a_max": Parameter(1.0, "moves: acceleration limit [rad/s2]"),
        "j_max": Parameter(10.0, "scurve: jerk limit [rad/s3]"),
        "dwell": Parameter(0.0, "moves: rest after each move [s]"),
        "repeat": Parameter(1, "moves: number of moves, 0 for endless [1]"),
        "reverse": Parameter(False, "moves: back and forth instead of onwards [1]"),
        "amplitude": Parameter(1.0, "sine: amplitude [rad]"),
        "frequency": Parameter(1.0, "sine: frequency [Hz]"),
        "times": Parameter("0 1", "table: increasing times, numbers separated by spaces [s]"),
        "positions": Parameter("0 0", "table: positions at those times [rad]"),
    }
    continuous = True

    def __init__(self, kind: str = "trapezoid", start: float = 0.0, delay: float = 0.0, speed: float = 1.0,
                 distance: float = 1.0, v_max: float = 1.0, a_max: float = 1.0, j_max: float = 10.0,
                 dwell: float = 0.0, repeat: int = 1, reverse: bool = False, amplitude: float = 1.0,
                 frequency: float = 1.0, times="0 1", positions="0 0"):
        if kind not in KINDS:
            raise SceneError("kind", f"must be one of {', '.join(KINDS)}, got {kind!r}")
        self.kind = kind
        self.start = check_number(start, "start")
        self.delay = check_number(delay, "delay", low=0.0)
        self.Ts = 0.0
        if kind == "constant":
            self.speed = check_number(speed, "speed")
        elif kind in ("trapezoid", "scurve"):
            self.distance = check_number(distance, "distance")
            if self.distance == 0:
                raise SceneError("distance", "a move needs a non-zero distance")
            v = check_number(v_max, "v_max", low=0.0, low_open=True)
            a = check_number(a_max, "a_max", low=0.0, low_open=True)
            self.dwell = check_number(dwell, "dwell", low=0.0)
            if isinstance(repeat, bool) or int(repeat) != repeat or repeat < 0:
                raise SceneError("repeat", f"must be a whole number >= 0, got {repeat!r}")
            self.repeat = int(repeat)
            self.reverse = bool(reverse)
            d = abs(self.distance)
            if kind == "trapezoid":
                phases = trapezoid_phases(d, v, a)
            else:
                phases = scurve_phases(d, v, a, check_number(j_max, "j_max", low=0.0, low_open=True))
            self._move = _chain(phases)
            self.move_time = self._move[-1].t0 + self._move[-1].duration
        elif kind == "sine":
            self.amplitude = check_number(amplitude, "amplitude")
            self.frequency = check_number(frequency, "frequency", low=0.0)
        else:
            from scipy.interpolate import CubicSpline

            t = _floats(times, "times")
            p = _floats(positions, "positions")
            if len(t) != len(p) or len(t) < 2:
                raise SceneError("positions", f"needs one position per time and at least two points, got "
                                              f"{len(p)} positions for {len(t)} times")
            if np.any(np.diff(t) <= 0):
                raise SceneError("times", "must be strictly increasing")
            self._table = (t, p)
            self._spline = CubicSpline(t, p, bc_type="clamped")

    def breakpoints(self, t_end: float) -> list[float]:
        """Times in ``[0, t_end]`` where the motion law changes phase (a move's segments, a table's points).

        A sampler puts samples in every phase (see :func:`grubler.studies.sizing.sample_times`),
        so that a short move in a long dwell is not missed.  At most 100 000 times.
        """
        out = [self.delay]
        if self.kind in ("trapezoid", "scurve"):
            period = self.move_time + self.dwell
            k = 0
            while self.delay + k * period <= t_end and len(out) < 100_000 and (not self.repeat or k < self.repeat):
                start = self.delay + k * period
                out += [start + seg.t0 for seg in self._move] + [start + self.move_time]
                k += 1
        elif self.kind == "table":
            out += [self.delay + float(x) for x in self._table[0][:100_000]]
        return [x for x in out if 0.0 <= x <= t_end]

    def evaluate(self, t: float) -> tuple[float, float, float]:
        """Position, velocity and acceleration at time ``t``."""
        tau = t - self.delay
        kind = self.kind
        if kind == "table":
            times, pos = self._table
            tt = t - self.delay
            if tt <= times[0]:
                return float(pos[0]), 0.0, 0.0
            if tt >= times[-1]:
                return float(pos[-1]), 0.0, 0.0
            s = self._spline
            return float(s(tt)), float(s(tt, 1)), float(s(tt, 2))
        if tau < 0:
            return self.start, 0.0, 0.0
        if kind == "constant":
            return self.start + self.speed * tau, self.speed, 0.0
        if kind == "sine":
            w = 2 * math.pi * self.frequency
            s, c = math.sin(w * tau), math.cos(w * tau)
            return self.start + self.amplitude * s, self.amplitude * w * c, -self.amplitude * w * w * s
        period = self.move_time + self.dwell
        k = int(tau // period) if period > 0 else 0
        if self.repeat and k >= self.repeat:
            k, local = self.repeat - 1, period  # finished: rest at the end of the last move
        else:
            local = tau - k * period
        if self.reverse:
            sign = 1.0 if k % 2 == 0 else -1.0
            base = self.start + (0.0 if k % 2 == 0 else self.distance)
        else:
            sign, base = 1.0, self.start + k * self.distance
        direction = math.copysign(1.0, self.distance) * sign
        if local >= self.move_time:
            return base + direction * abs(self.distance), 0.0, 0.0
        for seg in self._move:
            if local < seg.t0 + seg.duration:
                break
        p, v, a = seg.at(local - seg.t0)
        return base + direction * p, direction * v, direction * a

    def initial_outputs(self, t0: float) -> dict[str, float]:
        return self.update(t0, {})

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        p, v, a = self.evaluate(t)
        return {"position": p, "velocity": v, "acceleration": a}

    def get_state(self):
        return None  # a function of time alone

    def set_state(self, state) -> None:
        pass


__all__ = ["Trajectory", "KINDS", "Segment", "scurve_phases", "trapezoid_phases"]
