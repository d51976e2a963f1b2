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
is the derivative of position and acceleration that of velocity.  It is
planned and evaluated in C (``controllers/kernel/ctl_trajectory.c``), the code
the native Trajectory.fmu compiles.

Examples
--------
>>> tr = Trajectory("trapezoid", distance=1.0, v_max=2.0, a_max=8.0)
>>> tr.move_time                          # 0.25 s up to 2 rad/s, 0.25 s at it, 0.25 s down
0.75
>>> [round(x, 12) for x in tr.evaluate(0.4)]
[0.55, 2.0, 0.0]
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass

import numpy as np

from grubler.errors import SceneError
from grubler.limits import PATH_CHARS, brief, clip

from grubler.controllers import native
from grubler.controllers.law import Law, Parameter, check_number

KINDS = ("constant", "trapezoid", "scurve", "sine", "table")
# what a kind does not use still reaches the C as a valid number
TRAJECTORY_DEFAULTS = {"speed": 1.0, "distance": 1.0, "v_max": 1.0, "a_max": 1.0, "j_max": 10.0, "dwell": 0.0,
                       "repeat": 1, "reverse": 0.0, "amplitude": 1.0, "frequency": 1.0}


@dataclass(frozen=True)
class Segment:
    """Constant jerk over ``duration`` from the state (p0, v0, a0) at its start (``struct ctl_segment``)."""

    t0: float
    duration: float
    p0: float
    v0: float
    a0: float
    jerk: float

    def at(self, tau: float) -> tuple[float, float, float]:
        """Position, velocity and acceleration ``tau`` seconds into the segment (``ctl_segment_at``)."""
        out = (ctypes.c_double * 3)()
        native.call("ctl_segment_at", native.Segment(self.t0, self.duration, self.p0, self.v0, self.a0, self.jerk),
                    float(tau), out)
        return out[0], out[1], out[2]


def _params(kind: str, distance: float, v_max: float, a_max: float, j_max: float) -> native.TrajectoryParams:
    return native.TrajectoryParams(kind=KINDS.index(kind), distance=distance, v_max=v_max, a_max=a_max, j_max=j_max)


def _phases(p: native.TrajectoryParams) -> list[tuple[float, float, float]]:
    out, n = (ctypes.c_double * 21)(), ctypes.c_int()
    native.call("ctl_move_phases", p, out, ctypes.byref(n))
    return [(out[3 * k], out[3 * k + 1], out[3 * k + 2]) for k in range(n.value)]


def trapezoid_phases(distance: float, v_max: float, a_max: float) -> list[tuple[float, float, float]]:
    """Accelerate at a_max, cruise at v_max, brake: the shortest move with those limits.

    Phases as (duration, acceleration at start, jerk), from ``ctl_move_phases``.
    """
    return _phases(_params("trapezoid", distance, v_max, a_max, 0.0))


def scurve_phases(distance: float, v_max: float, a_max: float, j_max: float) -> list[tuple[float, float, float]]:
    """Seven phases of jerk +J, 0, -J, 0, -J, 0, +J (Biagiotti and Melchiorri, 3.4)."""
    return _phases(_params("scurve", distance, v_max, a_max, j_max))


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


# a profile's points: a cam table of 100 000 rows is a typing error, not a motion
MAX_PROFILE_ROWS = 100_000


def read_profile(path) -> tuple[np.ndarray, np.ndarray]:
    """A table or cam profile from a CSV file: times, s, and positions, rad.

    Two columns, time and position, one point a row, strictly increasing
    times; a first row of names (``time,position``) and lines starting with
    ``#`` are skipped.

    Raises
    ------
    SceneError
        One line naming the file, the row and the column of what is wrong.
    """
    import csv

    name = clip(str(path), PATH_CHARS)
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(line for line in f if not line.lstrip().startswith("#")))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise SceneError("profile", f"{name}: cannot be read as a UTF-8 CSV file ({type(exc).__name__})") from None
    numbered = [(k + 1, r) for k, r in enumerate(rows) if any(c.strip() for c in r)]
    if numbered and not _numeric(numbered[0][1][0]):
        numbered = numbered[1:]  # a row of names
    if len(numbered) > MAX_PROFILE_ROWS:
        raise SceneError("profile", f"{name}: {len(numbered)} rows; a profile has at most {MAX_PROFILE_ROWS}")
    times, positions = [], []
    for row_number, row in numbered:
        if len(row) != 2:
            raise SceneError("profile", f"{name}: row {row_number}: {len(row)} columns; a profile has two, "
                                        "time [s] and position [rad]")
        values = []
        for column, (cell, what) in enumerate(zip(row, ("time", "position")), start=1):
            try:
                x = float(cell)
            except ValueError:
                raise SceneError("profile", f"{name}: row {row_number}, column {column} ({what}): not a number, "
                                            f"got {brief(cell.strip())}") from None
            if not math.isfinite(x):
                raise SceneError("profile", f"{name}: row {row_number}, column {column} ({what}): must be finite, "
                                            f"got {cell.strip()}")
            values.append(x)
        if times and values[0] <= times[-1]:
            raise SceneError("profile", f"{name}: row {row_number}, column 1 (time): times must increase, got "
                                        f"{values[0]:g} after {times[-1]:g}")
        times.append(values[0])
        positions.append(values[1])
    if len(times) < 2:
        raise SceneError("profile", f"{name}: {len(times)} points; a profile needs at least two")
    return np.array(times), np.array(positions)


def _numeric(cell: str) -> bool:
    try:
        float(cell)
        return True
    except ValueError:
        return False


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
    profile : path, optional
        'table': a CSV file of the points instead (:func:`read_profile`).

    Examples
    --------
    >>> from grubler.controllers import Trajectory
    >>> move = Trajectory(kind="trapezoid", distance=1.0, v_max=1.0, a_max=2.0)   # 1 rad, 1 rad/s, 2 rad/s2
    >>> [tuple(round(x, 4) for x in move.evaluate(t)) for t in (0.25, 0.75, 1.25, 2.0)]  # (pos, vel, acc)
    [(0.0625, 0.5, 2.0), (0.5, 1.0, 0.0), (0.9375, 0.5, -2.0), (1.0, 0.0, 0.0)]
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
                 frequency: float = 1.0, times="0 1", positions="0 0", profile=None):
        if kind not in KINDS:
            raise SceneError("kind", f"must be one of {', '.join(KINDS)}, got {kind!r}")
        self.kind = kind
        given = {"start": start, "delay": delay, "speed": speed, "distance": distance, "v_max": v_max,
                 "a_max": a_max, "j_max": j_max, "dwell": dwell, "amplitude": amplitude, "frequency": frequency}
        used = {"constant": ("speed",), "sine": ("amplitude", "frequency"), "table": (),
                "trapezoid": ("distance", "v_max", "a_max", "dwell"),
                "scurve": ("distance", "v_max", "a_max", "j_max", "dwell")}[kind]
        # the numbers its kind uses (the C judges their range); the others keep their defaults
        values = {name: check_number(given[name], name) for name in ("start", "delay", *used)}
        if kind in ("trapezoid", "scurve"):
            if isinstance(repeat, bool) or int(repeat) != repeat or repeat < 0:
                raise SceneError("repeat", f"must be a whole number >= 0, got {repeat!r}")
            values.update(repeat=int(repeat), reverse=1.0 if reverse else 0.0)
        self._params = native.TrajectoryParams(**{**TRAJECTORY_DEFAULTS, **values, "kind": KINDS.index(kind)})
        self._table = None
        if kind == "table":
            if profile is not None:
                t, p = read_profile(profile)
            else:
                t, p = _floats(times, "times"), _floats(positions, "positions")
            if len(t) != len(p) or len(t) < 2:
                raise SceneError("positions", f"needs one position per time and at least two points, got "
                                              f"{len(p)} positions for {len(t)} times")
            self._table_arrays = (t, p, np.zeros(len(t)))
            self._table = native.Table(len(t), *(a.ctypes.data_as(native.DOUBLES) for a in self._table_arrays))
        native.refuse_bad("trajectory", self._params, self._table and ctypes.byref(self._table))
        for name, v in values.items():
            setattr(self, name, v)
        if kind in ("trapezoid", "scurve"):
            self.reverse = bool(reverse)
            self._plan = native.Move()
            native.call("ctl_move_plan", self._params, self._plan)
            self._move = [Segment(*(getattr(sg, f) for f, _ in native.Segment._fields_))
                          for sg in self._plan.seg[:self._plan.n]]
            self.move_time = self._plan.move_time
        if kind == "table":
            native.call("ctl_table_prepare", self._table, np.zeros(len(t)).ctypes.data_as(native.DOUBLES))
        self.Ts = 0.0
        self._out = (ctypes.c_double * 3)()

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
            out += [self.delay + float(x) for x in self._table_arrays[0][:100_000]]
        return [x for x in out if 0.0 <= x <= t_end]

    def evaluate(self, t: float) -> tuple[float, float, float]:
        """Position, velocity and acceleration at time ``t``."""
        plan = self._plan if self.kind in ("trapezoid", "scurve") else None
        native.call("ctl_trajectory_evaluate", self._params, plan, self._table, float(t), self._out)
        return self._out[0], self._out[1], self._out[2]

    def initial_outputs(self, t0: float) -> dict[str, float]:
        return self.update(t0, {})

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        p, v, a = self.evaluate(t)
        return {"position": p, "velocity": v, "acceleration": a}

    def get_state(self):
        return None  # a function of time alone

    def set_state(self, state) -> None:
        pass


__all__ = ["Trajectory", "KINDS", "Segment", "read_profile", "scurve_phases", "trapezoid_phases"]
