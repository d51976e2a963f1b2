"""Motor sizing: which motor and gear ratio a linkage's duty cycle needs, with what margin.

The drive joint's duty cycle (a move profile repeated, a constant speed, or a
recorded trajectory) and the loads give, by :func:`grubler.mechanism.inverse.drive_demand`,
the torque and speed the drive joint needs over the cycle.  For each candidate
motor and gear ratio the motor side follows without another simulation, because
the rotor inertia enters the drive joint's equation linearly (``J N² a``) and the
gearbox and winding are algebraic:

- motor speed ``N w``, current from :func:`grubler.motors.current_for_torque`
  (gearbox efficiency in the direction of power flow, motor friction);
- terminal voltage ``R(T) i + k_e N w + L di/dt`` with the winding at its hottest;
- winding temperature: the periodic steady state of the one-node thermal model
  over endlessly repeated cycles (with R(T)), solved exactly cycle by cycle;
- margins, each a limit over what the cycle needs (1 is exactly enough): peak
  current (the drive's current limit, or the stall current), RMS torque against
  the continuous (nominal) torque, peak speed, peak voltage against the supply,
  peak winding temperature rise against the allowed one.  A speed or
  temperature limit the motor's data set does not give cannot be checked, and
  the candidate is not called feasible on it (without a nominal torque, the
  thermal check stands for the continuous one).

With a :class:`Control` (the servo's PID, encoder and feedforward, as
``grubler size`` uses) the current is not the perfect drive's but the position
loop's: :func:`closed_loop_current` adds what the PID does on top of the ideal
trajectory's torque (chiefly its derivative's kicks at every encoder count), and
the peak current, RMS torque, voltage and temperature are judged on that.

Feasible combinations are ranked by their smallest margin (most headroom
first); the others follow, fewest broken limits first, each saying which limits
it breaks and by how much.

Examples
--------
>>> import numpy as np
>>> from grubler import load_scene
>>> from grubler.motors import load_motor
>>> m = load_scene("thesis-fourbar").mechanism
>>> cycle = DutyCycle.constant_speed(2 * np.pi, n=200)
>>> study = size(m, cycle, [load_motor("maxon-re40-148877")], ratios=[20, 50], supply_voltage=48.0)
>>> [(a.candidate.ratio, a.feasible) for a in study.assessments]
[(20, False), (50, True)]
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from grubler.errors import SceneError
from grubler.limits import check_count, check_size, number, open_output
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


@dataclass(frozen=True)
class Candidate:
    """A motor, a gear ratio and the power stage it would run on.

    Examples
    --------
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import Candidate
    >>> c = Candidate(load_motor("maxon-re40-148877"), ratio=50.0, supply_voltage=48.0, current_limit=10.0)
    >>> c.label, c.efficiency
    ('maxon-re40-148877 x 50', 0.9)
    """

    motor: object  # grubler.motors.MotorData
    ratio: float
    efficiency: float = 0.9
    supply_voltage: float = 48.0
    current_limit: float = math.inf

    @property
    def label(self) -> str:
        return f"{self.motor.name} x {self.ratio:g}"


RPM = 30.0 / math.pi  # rpm per rad/s: motor speeds are given in rpm, as on a motor's datasheet
# the unit of each number in a study's table (Assessment.summary, the CSV's headings); margins are ratios
SUMMARY_UNITS = {"peak_motor_torque": "N m", "rms_motor_torque": "N m", "peak_motor_speed": "rpm",
                 "mean_motor_speed": "rpm", "peak_current": "A", "rms_current": "A", "peak_current_ideal_drive": "A",
                 "rms_current_ideal_drive": "A", "peak_voltage": "V", "winding_temperature_max": "degC",
                 "temperature_rise": "K"}


@dataclass
class Assessment:
    """What one candidate needs over the cycle and its margins.

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import Candidate, DutyCycle, assess, required_drive
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> cycle = DutyCycle.constant_speed(2 * np.pi, n=200)
    >>> a = assess(required_drive(m, cycle), cycle, Candidate(load_motor("maxon-re40-148877"), 50.0))
    >>> a.feasible, a.binding, round(a.min_margin, 3)
    (True, 'continuous torque', 2.052)
    >>> s = a.summary()
    >>> round(s["peak_current"], 3), round(s["peak_voltage"], 2), round(s["temperature_rise"], 2)
    (2.748, 22.41, 18.71)
    """

    candidate: Candidate
    motor_torque: np.ndarray  # at the motor shaft, N m
    motor_speed: np.ndarray  # rad/s
    current: np.ndarray  # A
    voltage: np.ndarray  # V
    temperature: np.ndarray  # winding, periodic steady state, degC
    margins: dict[str, float]
    needs: dict[str, tuple[float, float, str]]  # name -> (needed, limit, unit)
    ambient: float
    closed_loop: ClosedLoop | None = None  # the position loop's currents, when predicted with one
    t: np.ndarray | None = None  # the cycle's sample instants (current, torque, speed, voltage)

    @property
    def feasible(self) -> bool:
        return all(v >= 1.0 for v in self.margins.values())

    @property
    def binding(self) -> str:
        return min(self.margins, key=self.margins.get)

    @property
    def min_margin(self) -> float:
        return min(self.margins.values())

    @property
    def failures(self) -> list[str]:
        out = []
        for k, v in self.margins.items():
            if v < 1.0:
                need, limit, unit = self.needs[k]
                if math.isnan(need):
                    out.append(f"{k}: could not be computed for this cycle (not a number)")
                    continue
                if self.closed_loop is not None and not self.closed_loop.stable and k == "peak current":
                    out.append("peak current: the servo's position loop is unstable with this motor and ratio "
                               "(its predicted current grows without bound)")
                    continue
                if k == "temperature rise" and math.isinf(need):
                    out.append(f"temperature rise: runaway (the winding's i² R(T) outgrows its cooling), "
                               f"limit {limit:.4g} {unit}")
                    continue
                if k == "ambient":
                    lo, hi = self.candidate.motor.min_ambient_temperature, self.candidate.motor.max_ambient_temperature
                    out.append(f"ambient: {need:.4g} degC is outside the motor's rated "
                               f"{'-inf' if lo is None else f'{lo:g}'} to {'inf' if hi is None else f'{hi:g}'} degC")
                    continue
                out.append(f"{k}: needs {need:.4g} {unit}, " + (
                    "the data set gives no limit to check it against" if math.isnan(limit)
                    else f"limit {limit:.4g} {unit}"))
        return out

    def summary(self) -> dict[str, float | str]:
        """The study table's row for this candidate, each number in its :data:`SUMMARY_UNITS` unit."""
        tq, w = self.motor_torque, self.motor_speed
        loop = self.closed_loop
        i = loop.current if loop is not None else self.current
        rms = loop.rms_current if loop is not None else _rms(i, self.t)
        kt = self.candidate.motor.torque_constant
        row = {"motor": self.candidate.motor.name, "ratio": self.candidate.ratio,
               "peak_motor_torque": kt * float(np.max(np.abs(i))), "rms_motor_torque": kt * rms,
               "peak_motor_speed": float(np.max(np.abs(w))) * RPM, "mean_motor_speed": float(np.mean(np.abs(w))) * RPM,
               "peak_current": float(np.max(np.abs(i))), "rms_current": rms,
               "peak_current_ideal_drive": float(np.max(np.abs(self.current))),
               "rms_current_ideal_drive": _rms(self.current, self.t),
               "peak_voltage": self.needs["voltage"][0],
               "winding_temperature_max": float(np.max(self.temperature)),
               "temperature_rise": float(np.max(self.temperature) - self.ambient)}
        row.update({f"margin_{k.replace(' ', '_')}": v for k, v in self.margins.items()})
        row["current_prediction"] = "perfect drive" if loop is None else (
            f"position loop, {loop.method}" + ("" if loop.stable else ", unstable"))
        row["feasible"] = self.feasible
        row["binding"] = self.binding
        row["why_not"] = "; ".join(self.failures)
        return row


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


def _rms(x: np.ndarray, t: np.ndarray | None = None) -> float:
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


@dataclass(frozen=True)
class Control:
    """The position loop that drives the motor: PID and encoder parameters, feedforward.

    The prediction (:func:`closed_loop_current`) and the co-simulated check
    (:func:`closed_loop_check`) both take the controller from here, so they
    judge the same servo.  :meth:`servo` is the servo co-simulation's own
    (:class:`grubler.system.servo.ServoDesign`'s PID and encoder) with feedforward.

    Examples
    --------
    >>> from grubler.studies.sizing import Control
    >>> c = Control.servo()          # the servo co-simulation's PID and encoder, with feedforward
    >>> c.pid["K"], c.pid["Ts"], c.encoder["counts_per_rev"], c.feedforward
    (300.0, 0.001, 16384, True)
    """

    pid: dict
    encoder: dict
    feedforward: bool = True

    @classmethod
    def servo(cls) -> "Control":
        from grubler.system.servo import ServoDesign

        d = ServoDesign()
        return cls(dict(d.pid), dict(d.encoder), True)


@dataclass
class ClosedLoop:
    """What the position loop makes of one candidate's cycle (:func:`closed_loop_current`).

    Samples at the controller's sample instants over the last simulated period,
    sorted by their phase in the cycle (``t`` from 0 to the period).

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import Control, DutyCycle, size
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> cycle = DutyCycle.constant_speed(4 * np.pi, n=100)     # a turn in 0.5 s
    >>> a = size(m, cycle, [load_motor("maxon-re40-148877")], ratios=[50], control=Control.servo()).assessments[0]
    >>> loop = a.closed_loop
    >>> loop.method, loop.stable, bool(loop.rms_current > a.closed_loop.ideal_current.std())
    ('simulated', True, True)
    """

    t: np.ndarray
    current: np.ndarray  # A: the ideal current plus what the loop adds
    extra_voltage: np.ndarray  # V: the loop's voltage beyond the ideal drive's
    tracking_error: np.ndarray  # rad (m on a slide)
    ideal_current: np.ndarray  # A, at the same instants
    period: float  # s, of the cycle
    control: Control | None = None  # the loop that made them
    method: str = "simulated"  # or "bound" (quantisation_bound: too long a cycle to step)
    stable: bool = True  # False: the loop diverges with this motor and ratio

    @property
    def rms_current(self) -> float:
        """RMS over the period, weighted by time (a shortened rest has few samples)."""
        return _rms(np.append(self.current, self.current[0]), np.append(self.t, self.t[0] + self.period))


LOOP_SAMPLES = 400_000
"""Most controller samples :func:`closed_loop_current` steps (all periods, long rests shortened)."""


def _rest_stretches(cycle: DutyCycle, settle: float) -> list[tuple[float, float]]:
    """The phases ``(a, b)`` a loop at rest need not be stepped through: each rest of the drive (speed and
    acceleration exactly 0) longer than ``settle``, but for its first ``settle`` seconds."""
    still = (cycle.velocity == 0.0) & (cycle.acceleration == 0.0)
    t = cycle.t - cycle.t[0]
    out, k = [], 0
    while k < len(t):
        if still[k]:
            j = k
            while j + 1 < len(t) and still[j + 1]:
                j += 1
            if t[j] - t[k] > settle:
                out.append((float(t[k]) + settle, float(t[j])))
            k = j + 1
        else:
            k += 1
    return out


def _sample_times(period: float, periods: int, Ts: float, skip: list[tuple[float, float]]) -> np.ndarray | None:
    """The controller's instants ``k Ts`` over ``periods`` periods, leaving out the phases in ``skip``.

    None when there would be more than ``LOOP_SAMPLES`` of them.
    """
    ranges, lo = [], 0.0
    for a, b in skip:
        ranges.append((lo, a))
        lo = b
    ranges.append((lo, period))
    spans = [(p * period + a, p * period + b) for p in range(periods) for a, b in ranges]
    counts = [max(0.0, math.ceil(hi / Ts) - math.ceil(lo / Ts)) for lo, hi in spans]
    if not sum(counts) <= LOOP_SAMPLES:
        return None
    return np.concatenate([np.arange(math.ceil(lo / Ts), math.ceil(hi / Ts)) * Ts for lo, hi in spans])


def closed_loop_current(model: Mechanism, cycle: DutyCycle, demand: DriveDemand, inertia: np.ndarray,
                        candidate: Candidate, ideal_current: np.ndarray, control: Control,
                        periods: int = 2) -> ClosedLoop:
    """The winding current under the position loop: the ideal drive's plus the loop's reaction.

    A reduced closed-loop model of the drive joint alone, linear about the ideal
    cycle (the perfect drive the rest of the study assumes), stepped at the
    controller's sample time with the project's own :class:`~grubler.controllers.PID`
    and :class:`~grubler.controllers.Encoder` laws and the
    :class:`~grubler.controllers.ComputedTorque` feedforward's voltage formula:

    - the encoder reads the drive at ``reference + e`` (its quantisation is what
      makes the PID's derivative kick by ``K Td / (Tf + Ts)`` per count);
    - the voltage beyond the ideal drive's, ``du = PID + feedforward - (R i + k_e N w
      + L di/dt)`` (ideal, at mid-step: the held voltage's lag is a mismatch too),
      drives the extra current ``L d(di)/dt = du - R di - k_e N de/dt`` over the
      step with the speed held, as the co-simulation's motor does;
    - the extra torque ``(d tau/d i) di`` accelerates the drive joint's inertia
      (the mechanism's along the cycle plus J_rotor N²): ``M_eff e'' = (d tau/d i) di``.

    The winding is at ambient (its resistance is lowest, the kicks largest); the
    drive's current limit and the motor's friction changes are left out.  The
    first ``periods - 1`` periods settle the integral and are dropped.  A rest
    longer than the loop's settling time ``10 max(Ti, Td, Ts)`` is shortened to
    it (the loop is still there, its state kept).  A cycle that would still take
    more than ``LOOP_SAMPLES`` samples gets a bound instead
    (:func:`quantisation_bound`, ``method`` says which).  A loop that diverges
    gives an infinite current (``stable`` False).

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import (Candidate, Control, DutyCycle, assess, closed_loop_current,
    ...                                     drive_inertia, required_drive)
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> cycle = DutyCycle.constant_speed(4 * np.pi, n=100)
    >>> demand = required_drive(m, cycle)
    >>> cand = Candidate(load_motor("maxon-re40-148877"), 50.0)
    >>> ideal = assess(demand, cycle, cand).current                # the perfect drive's current, A
    >>> loop = closed_loop_current(m, cycle, demand, drive_inertia(m, cycle, demand), cand, ideal, Control.servo())
    >>> loop.stable, bool(np.max(np.abs(loop.current)) > np.max(np.abs(ideal)))   # the PID's kicks add current
    (True, True)
    """
    from grubler.motors import DCMotor, Drive, Gearbox, current_for_torque
    from scipy.interpolate import CubicHermiteSpline

    from grubler.controllers import PID, ComputedTorque, Encoder

    data, N = candidate.motor, candidate.ratio
    motor = DCMotor(data, Gearbox(N, candidate.efficiency), Drive(candidate.supply_voltage, candidate.current_limit))
    pid, enc = PID(**control.pid), Encoder(**control.encoder)
    Ts = pid.Ts
    if abs(enc.Ts - Ts) > 1e-12 * Ts:
        raise SceneError("encoder.Ts", f"the prediction samples encoder and PID together: {enc.Ts:g} s "
                                        f"against the PID's {Ts:g} s")
    if not (isinstance(periods, int) and periods >= 2):
        raise SceneError("periods", f"must be a whole number >= 2 (one to settle, one to judge), got {periods!r}")
    period, t0 = cycle.period, cycle.t[0]

    def at(x, values):
        return np.interp(x, cycle.t - t0, values)

    tau = demand.torque + motor.reflected_inertia * cycle.acceleration  # at the drive joint, rotor included
    w = N * cycle.velocity
    # d tau / d i through the gearbox in the direction of power flow (the motor model's own inverse)
    step = 1e-6 * max(1.0, float(np.max(np.abs(tau))))
    with np.errstate(divide="ignore", invalid="ignore"):
        gain = step / (current_for_torque(motor, tau + step, w) - ideal_current)
    R, L, ke = data.resistance_at(data.reference_temperature), data.inductance, data.back_emf_constant
    J_cycle = inertia + motor.reflected_inertia
    plant = _Winding(R, L, ke * N, Ts)
    settle = 10.0 * max(pid.Ti, pid.Td, Ts)
    skipped = _rest_stretches(cycle, settle)
    t = _sample_times(period, periods, Ts, skipped)
    if not np.all(np.isfinite(gain)):  # the gearbox model gives no torque for a current change
        nan = np.full_like(cycle.t, np.nan)
        return ClosedLoop(cycle.t - t0, nan, nan, nan, ideal_current, period, control, "not computed", False)
    if t is None:  # too long a cycle to step: the bound, at the ideal peak's sample
        k = int(np.argmax(np.abs(ideal_current)))
        bound = quantisation_bound(control, R, L, ke * N, float(gain[k]), float(J_cycle[k]))
        tc = cycle.t - t0
        extra = np.full_like(tc, bound)
        return ClosedLoop(tc, np.sign(ideal_current) * (np.abs(ideal_current) + bound), extra * R,
                          np.zeros_like(tc), ideal_current, period, control, "bound", math.isfinite(bound))
    turns, phase = np.divmod(t, period)
    lap = cycle.position[-1] - cycle.position[0]  # a constant-speed cycle gains a turn each period
    position = CubicHermiteSpline(cycle.t - t0, cycle.position, cycle.velocity)
    mid = (phase + 0.5 * Ts) % period
    reference = position(phase) + turns * lap
    ideal_voltage = R * ideal_current + ke * w + L * np.gradient(ideal_current, cycle.t)
    u_ideal = at(mid, ideal_voltage)
    if control.feedforward:
        ct = ComputedTorque(model, drive_inertia=motor.reflected_inertia, gear_ratio=N,
                            efficiency=candidate.efficiency, R=data.resistance, k_t=data.torque_constant,
                            k_e=data.back_emf_constant, Ts=Ts)
        u_ff = at(phase, ct.motor(tau, cycle.velocity)[1])
    else:
        u_ff = np.zeros_like(t)
    g_over_J = at(mid, gain) / at(mid, J_cycle)
    n = len(t)
    e = ed = di = 0.0
    extra, dis, errs = np.empty(n), np.empty(n), np.empty(n)
    stable = True
    for k in range(n):
        y = enc.update(float(t[k]), {"position": float(reference[k] + e)})["measured_position"]
        du = pid.compute(float(reference[k]), y, float(u_ff[k])) - u_ideal[k]
        di, avg = plant.step(di, du, ed)
        ed += Ts * g_over_J[k] * avg
        e += Ts * ed
        extra[k], dis[k], errs[k] = du, di, e
        if not abs(e) < 1e3:  # diverged (or NaN): the loop is unstable with this motor and ratio
            stable = False
            dis[:], extra[:], errs[:] = math.inf, math.inf, math.inf
            break
    # outputs at the end of each step; keep the last period, by phase
    t_end = t + Ts
    last = t_end > periods * period - period
    ph = (t_end[last] - (periods - 1) * period)
    # a shortened rest is bridged by the ideal (holding) current at its ends: the loop is at rest there
    # (the hunting between two counts that a PID with integral keeps up is left out of it)
    bridge = np.array([x for a, b in skipped for x in (a, min(b, period * (1 - 1e-12)))])
    tl = np.concatenate([ph, bridge])
    order = np.argsort(tl)
    tl = tl[order]
    i_ideal = at(tl, ideal_current)
    dis = np.concatenate([dis[last], np.zeros_like(bridge)])[order]
    extra = np.concatenate([extra[last], np.zeros_like(bridge)])[order]
    errs = np.concatenate([errs[last], np.full_like(bridge, np.nan)])[order]
    held = np.maximum.accumulate(np.where(np.isnan(errs), 0, np.arange(len(errs))))
    errs = errs[held]  # the tracking error held over a shortened rest
    return ClosedLoop(tl, i_ideal + dis, extra, errs, i_ideal, period, control, "simulated", stable)


class _Winding:
    """The extra current's step over one sample: voltage ``du`` held, back-EMF ``c ed`` held (exact)."""

    def __init__(self, R: float, L: float, c: float, Ts: float):
        self.R, self.c = R, c
        tau_e = L / R
        self.a = math.exp(-Ts / tau_e) if tau_e > 0 else 0.0
        self.mean = (1.0 - self.a) * tau_e / Ts if tau_e > 0 else 0.0  # mean of e^(-s/tau_e) over the step

    def step(self, di: float, du: float, ed: float) -> tuple[float, float]:
        """The current at the step's end, and its mean over the step."""
        target = (du - self.c * ed) / self.R  # where the step's voltage drives it, speed held
        return target + (di - target) * self.a, target + (di - target) * self.mean


def quantisation_bound(control: Control, R: float, L: float, c: float, gain: float, J: float) -> float:
    """Largest extra current the encoder's quantisation can cause, A (a bound, for any motion).

    The quantisation error of a reading is in ``[0, q)``, ``q`` one count; its
    mean is taken up by the integral, the rest is within ``±q/2``.  The loop is
    linear, so the extra current is at most the l1 norm of its response to a
    one-count measurement impulse times ``q/2`` (the worst sign pattern of the
    errors).  The response is stepped from rest on the reduced model of
    :func:`closed_loop_current` (winding ``R``, ``L``, back-EMF ``c``, torque per
    current ``gain``, inertia ``J``) for ``20 max(Ti, Td, Ts)``.
    """
    from grubler.controllers import PID, Encoder

    pid, q = PID(**{**control.pid, "u_min": -1e300, "u_max": 1e300}), Encoder(**control.encoder).resolution
    if q == 0:
        return 0.0
    Ts = pid.Ts
    plant = _Winding(R, L, c, Ts)
    e = ed = di = 0.0
    total = 0.0
    for k in range(math.ceil(20.0 * max(pid.Ti, pid.Td, Ts) / Ts)):
        du = pid.compute(0.0, e + (q if k == 0 else 0.0))
        di, avg = plant.step(di, du, ed)
        ed += Ts * gain * avg / J
        e += Ts * ed
        total += abs(di)
    return total / 2.0 if math.isfinite(total) else math.inf


def periodic_temperature(t: np.ndarray, current: np.ndarray, data, ambient: float) -> np.ndarray:
    """Winding temperature over a cycle repeated forever (one node, R(T) included).

    ``C dT/dt = i² R_ref (1 + alpha (T - T_ref)) - (T - T_amb) / R_th`` is linear
    in T, so each sample interval maps T affinely and the whole cycle too:
    ``T_end = A T_0 + B``; the periodic state is ``T_0 = B / (1 - A)``.

    Examples
    --------
    >>> import numpy as np
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import periodic_temperature
    >>> motor = load_motor("maxon-re40-148877")
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> T = periodic_temperature(t, np.full(11, 2.0), motor, ambient=25.0)    # 2 A for ever
    >>> round(float(T[0]), 2), bool(np.allclose(T, T[0]))                     # steady: degC, the same all cycle
    (59.66, True)
    """
    R_th, C = data.thermal_resistance, data.thermal_capacity
    alpha, R_ref, T_ref = data.temperature_coefficient, data.resistance, data.reference_temperature
    i2 = current**2
    i2_mid = 0.5 * (i2[1:] + i2[:-1])
    a = i2_mid * R_ref * alpha / C - 1.0 / (R_th * C)
    b = i2_mid * R_ref * (1.0 - alpha * T_ref) / C + ambient / (R_th * C)
    h = np.diff(t)
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is the runaway, tested below
        e = np.exp(a * h)
        gain = np.where(np.abs(a * h) > 1e-12, (e - 1.0) / np.where(a == 0, 1.0, a), h)
        A, B = 1.0, 0.0
        for ek, gk, bk in zip(e, gain, b):  # compose the affine maps
            A, B = ek * A, ek * B + gk * bk
    if not (math.isfinite(A) and math.isfinite(B)) or A >= 1.0:
        return np.full_like(t, np.inf)  # the copper heats faster than it cools: runaway
    temps = np.empty_like(t)
    temps[0] = B / (1.0 - A)
    with np.errstate(over="ignore", invalid="ignore"):  # a peak past the doubles is inf: not feasible
        for k in range(len(h)):
            temps[k + 1] = e[k] * temps[k] + gain[k] * b[k]
    return temps


def assess(demand: DriveDemand, cycle: DutyCycle, candidate: Candidate, ambient: float = 25.0,
           control: Control | None = None, model: Mechanism | None = None,
           inertia: np.ndarray | None = None) -> Assessment:
    """Motor-side needs and margins of one candidate (see the module's notes).

    With a ``control`` (and the ``model``; ``inertia`` from :func:`drive_inertia`,
    computed when not given) the currents are the position loop's
    (:func:`closed_loop_current`): peak current, RMS torque, voltage and winding
    temperature are judged on them.  Without, on the ideal drive's.

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import Candidate, DutyCycle, assess, required_drive
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> cycle = DutyCycle.constant_speed(2 * np.pi, n=200)
    >>> a = assess(required_drive(m, cycle), cycle, Candidate(load_motor("maxon-re40-148877"), 20.0))
    >>> a.feasible, a.failures
    (False, ['continuous torque: needs 0.2271 N m, limit 0.187 N m', 'temperature rise: needs 187.3 K, limit 130 K'])
    """
    from grubler.motors import DCMotor, Drive, Gearbox, current_for_torque

    data = candidate.motor
    motor = DCMotor(data, Gearbox(candidate.ratio, candidate.efficiency),
                    Drive(candidate.supply_voltage, candidate.current_limit), ambient_temperature=ambient)
    N = candidate.ratio
    torque = demand.torque + motor.reflected_inertia * cycle.acceleration
    w = N * cycle.velocity
    i = current_for_torque(motor, torque, w)
    loop = None
    if control is not None:
        if model is None:
            raise SceneError("model", "the closed-loop prediction needs the mechanism")
        if inertia is None:
            inertia = drive_inertia(model, cycle, demand)
        loop = closed_loop_current(model, cycle, demand, inertia, candidate, i, control)
        # the thermal cycle over the loop's samples, closed at one period
        t_heat = np.append(loop.t, loop.t[0] + cycle.period)
        i_heat = np.append(loop.current, loop.current[0])
    else:
        t_heat, i_heat = cycle.t, i
    temps = periodic_temperature(t_heat, i_heat, data, ambient)
    hot = float(np.max(temps))
    # the voltage at the hottest winding the motor may reach (a runaway is the
    # temperature's failure, not the voltage's)
    hottest = min(hot, data.max_winding_temperature if data.max_winding_temperature is not None else hot)
    R_hot = data.resistance_at(hottest if math.isfinite(hottest) else data.reference_temperature)
    didt = np.gradient(i, cycle.t)
    v = R_hot * i + data.back_emf_constant * w + data.inductance * didt
    tau_m = data.torque_constant * i  # electromagnetic torque: what the winding must make
    if loop is None:
        i_need, v_need = i, v
    else:  # the loop's voltage rides on the ideal drive's
        i_need, v_need = loop.current, np.interp(loop.t, cycle.t - cycle.t[0], v) + loop.extra_voltage
    needs: dict[str, tuple[float, float, str]] = {}
    stall_current = candidate.supply_voltage / data.resistance
    i_limit = min(candidate.current_limit, stall_current)
    # a limit the datasheet does not give cannot be checked: its margin is 0
    # (not feasible) and the reason says so, rather than passing unchecked
    unknown = math.nan
    needs["peak current"] = (float(np.max(np.abs(i_need))), i_limit, "A")
    if data.nominal_torque:  # without it, the thermal check below is the continuous one
        rms = _rms(i_need, cycle.t) if loop is None else loop.rms_current
        needs["continuous torque"] = (data.torque_constant * rms, data.nominal_torque, "N m")
    needs["speed"] = (float(np.max(np.abs(w))), data.max_speed or data.no_load_speed or unknown, "rad/s")
    needs["voltage"] = (float(np.max(np.abs(v_need))), candidate.supply_voltage, "V")
    t_max = data.max_winding_temperature
    needs["temperature rise"] = (hot - ambient, unknown if t_max is None else t_max - ambient, "K")
    margins = {k: (0.0 if math.isnan(lim) or math.isnan(need) else lim / need if need > 0 else math.inf)
               for k, (need, lim, _) in needs.items()}
    lo, hi = data.min_ambient_temperature, data.max_ambient_temperature
    if lo is not None or hi is not None:  # the motor's rated surroundings: in or out, no ratio
        inside = (lo is None or ambient >= lo) and (hi is None or ambient <= hi)
        needs["ambient"] = (ambient, hi if hi is not None and ambient > (lo if lo is not None else -math.inf)
                            else lo, "degC")
        margins["ambient"] = math.inf if inside else 0.0
    # a need that could not be computed (NaN) fails like an unknown limit: never "fits" by
    # way of a comparison that is false
    return Assessment(candidate, tau_m, w, i, v, temps, margins, needs, ambient, loop, cycle.t)


@dataclass
class SizingStudy:
    """Every candidate's assessment; ``ranked`` holds the feasible ones, best first.

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import DutyCycle, size
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> study = size(m, DutyCycle.constant_speed(2 * np.pi, n=200), [load_motor("maxon-re40-148877")], ratios=[20, 50])
    >>> study.best.candidate.label, [a.candidate.label for a in study.rejected]
    ('maxon-re40-148877 x 50', ['maxon-re40-148877 x 20'])
    >>> study.rejected[0].failures[0]
    'continuous torque: needs 0.2271 N m, limit 0.187 N m'
    >>> [(row["rank"], row["ratio"], row["feasible"]) for row in study.table()]
    [(1, 50, True), ('rejected', 20, False)]
    """

    demand: DriveDemand
    cycle: DutyCycle
    assessments: list[Assessment]
    ranked: list[Assessment] = field(default_factory=list)

    @property
    def best(self) -> Assessment | None:
        return self.ranked[0] if self.ranked else None

    @property
    def rejected(self) -> list[Assessment]:
        """The combinations that break a limit: fewest broken limits first, then the closest to fitting."""
        return sorted((a for a in self.assessments if not a.feasible),
                      key=lambda a: (len(a.failures), -a.min_margin))

    def table(self) -> list[dict]:
        """One row per combination: the ranked ones (rank 1, 2, ...), then the rejected ones with their reasons."""
        return ([{"rank": k + 1, **a.summary()} for k, a in enumerate(self.ranked)]
                + [{"rank": "rejected", **a.summary()} for a in self.rejected])

    def write_csv(self, path) -> None:
        """:meth:`table` as CSV, each heading with its unit (``peak_motor_speed [rpm]``)."""
        import csv

        from grubler.records import column_heading

        rows = self.table()
        cols = list(dict.fromkeys(c for r in rows for c in r))
        with open_output(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([column_heading(c, SUMMARY_UNITS.get(c, "")) for c in cols])
            for r in rows:
                w.writerow([repr(v) if isinstance(v, float) else v for v in (r.get(c, "") for c in cols)])

    def plot(self, path) -> None:
        """Save :meth:`figure` to ``path`` (PNG or any format matplotlib writes)."""
        from grubler.views.plotting import plt

        fig = self.figure()
        fig.savefig(path, dpi=110)
        plt.close(fig)

    def figure(self):
        """Duty-cycle points over each motor's envelopes, margin against gear ratio, and the key.

        One panel per motor, the best combination's first, each at that motor's
        best ratio; then the smallest margin of every combination against its
        ratio (log axis; a winding that runs away thermally has no margin and is
        marked on the axis, not drawn as a 0); then one key for all panels and
        the ranking, so that no legend covers data.
        """
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        from grubler.views.plotting import plt

        motors = sorted(dict.fromkeys(a.candidate.motor.name for a in self.assessments),
                        key=lambda name: -max(_known_margin(a) for a in self.assessments
                                              if a.candidate.motor.name == name))
        if self.best is not None:  # the winner first, even where another motor's margin on known limits is larger
            motors.remove(self.best.candidate.motor.name)
            motors.insert(0, self.best.candidate.motor.name)
        panels = len(motors) + 2
        # three columns, but never the key alone on a last row: four panels in two by two, seven in two by four
        ncols = 2 if panels == 4 else 4 if panels % 3 == 1 and panels > 4 else min(panels, 3)
        nrows = -(-panels // ncols)
        fig = plt.figure(figsize=(5.4 * ncols, 4.3 * nrows), layout="constrained")
        grid = fig.add_gridspec(nrows, ncols)
        cells = [grid[k // ncols, k % ncols] for k in range(len(motors) + 1)]
        colours = {name: f"C{i}" for i, name in enumerate(motors)}
        for cell, name in zip(cells, motors):
            ax = fig.add_subplot(cell)
            pick = (self.best if self.best is not None and self.best.candidate.motor.name == name
                    else max((a for a in self.assessments if a.candidate.motor.name == name), key=_known_margin))
            self._envelope_panel(ax, pick, colours[name])
        self._margin_panel(fig.add_subplot(cells[-1]), motors, colours)
        k = len(motors) + 1
        key_ax = fig.add_subplot(grid[k // ncols, k % ncols:])  # the key takes the rest of the last row
        key_ax.axis("off")
        handles = [Line2D([], [], ls="", marker=".", color="C0", label="duty cycle, ideal drive (each motor's colour)"),
                   Line2D([], [], ls="", marker=".", color=LOOP_COLOUR, alpha=0.5,
                          label="with the servo's PID and encoder"),
                   Patch(color="tab:orange", alpha=0.25, label="peak envelope: supply voltage and current limit"),
                   Patch(color="tab:green", alpha=0.3, label="continuous: the nominal torque"),
                   Line2D([], [], ls="", marker="*", ms=11, color="k", label="best combination")]
        handles += [Line2D([], [], color=colours[n], marker="o", ms=3, label=f"{n}: smallest margin") for n in motors]
        handles += [Line2D([], [], ls="", marker="x", color="0.3",
                           label="winding runs away thermally: no margin")]
        key_ax.legend(handles=handles, loc="upper left", fontsize=8, frameon=False, title="key", title_fontsize=9,
                      alignment="left")
        ranked = [f"{k + 1}. {a.candidate.label}: margin {a.min_margin:.2f} ({a.binding})"
                  for k, a in enumerate(self.ranked[:5])] or ["no combination fits"]
        if len(self.ranked) > 5:
            ranked.append(f"... {len(self.ranked) - 5} more")
        key_ax.text(0.0, 0.0, "ranking\n" + "\n".join(ranked), transform=key_ax.transAxes, va="bottom", ha="left",
                    fontsize=8, family="DejaVu Sans Mono")
        fig.suptitle(f"sizing: {self.cycle.name}")
        return fig

    def _envelope_panel(self, ax, pick: Assessment, colour: str) -> None:
        """One motor at its best ratio: the cycle's points over what the supply and the winding allow."""
        c, d = pick.candidate, pick.candidate.motor
        w = np.abs(pick.motor_speed)
        # the envelopes under the points: what the supply and the current limit allow (back-EMF eats the
        # voltage while the motor drives, and adds to it while it brakes), and the continuous torque
        w_top = (d.max_speed or d.no_load_speed or float(np.max(w)) * 1.2)
        ws = np.linspace(-w_top, w_top, 200)
        i_max = min(c.current_limit, c.supply_voltage / d.resistance)
        kt, ke, R, V = d.torque_constant, d.back_emf_constant, d.resistance, c.supply_voltage
        upper = np.clip(kt * (V - ke * ws) / R, -kt * i_max, kt * i_max)
        lower = np.clip(-kt * (V + ke * ws) / R, -kt * i_max, kt * i_max)
        ax.fill_between(ws * RPM, lower * 1e3, upper * 1e3, color="tab:orange", alpha=0.15, lw=0)
        if d.nominal_torque:
            ax.fill_between(ws * RPM, -d.nominal_torque * 1e3, d.nominal_torque * 1e3, color="tab:green", alpha=0.2,
                            lw=0)
        loop = pick.closed_loop
        if loop is not None:  # what the margins judge: the torque the loop's current makes
            speed = np.interp(loop.t, self.cycle.t - self.cycle.t[0], pick.motor_speed)
            ax.plot(speed * RPM, d.torque_constant * loop.current * 1e3, ".", ms=1, color=LOOP_COLOUR, alpha=0.25)
        ax.plot(pick.motor_speed * RPM, pick.motor_torque * 1e3, ".", ms=2, color=colour)
        ax.set_xlabel("motor speed [rpm]")
        ax.set_ylabel("motor torque [mN m]")
        verdict = "fits" if pick.feasible else "fails on " + ", ".join(k for k, v in pick.margins.items() if v < 1.0)
        margin = "none (thermal runaway)" if _runaway(pick) else f"{pick.min_margin:.2f} ({pick.binding})"
        supply = f"{c.supply_voltage:g} V" + (f", {c.current_limit:g} A" if math.isfinite(c.current_limit) else "")
        best = "best: " if pick is self.best else ""
        ax.set_title(f"{best}{d.name} at {c.ratio:g}:1 on {supply}\n{verdict}; smallest margin {margin}",
                     fontsize=9)
        ax.grid(True, alpha=0.3)

    def _margin_panel(self, ax, motors: list[str], colours: dict[str, str]) -> None:
        """The smallest margin of every combination against its gear ratio, per motor."""
        import matplotlib.ticker
        import matplotlib.transforms as mtransforms

        on_axis = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
        for name in reversed(motors):  # the winner's line on top
            mine = sorted((a for a in self.assessments if a.candidate.motor.name == name),
                          key=lambda a: a.candidate.ratio)
            ratios = [a.candidate.ratio for a in mine]
            # a runaway has no margin: a gap in the line, a cross on the axis, never a 0 that looks like data
            margins = [math.nan if _runaway(a) else _known_margin(a) for a in mine]
            ax.plot(ratios, margins, "o-", ms=3, color=colours[name], lw=2.0 if name == motors[0] else 1.2)
            gone = [r for r, a in zip(ratios, mine) if _runaway(a)]
            ax.plot(gone, [0.03] * len(gone), "x", color=colours[name], ms=6, transform=on_axis, clip_on=False)
        if self.best is not None:
            ax.plot([self.best.candidate.ratio], [self.best.min_margin], "*", ms=13, color="k", zorder=5)
        ax.axhline(1.0, color="k", lw=0.8, ls="--")
        ax.set_yscale("log")
        # plain numbers on the log axis: 0.5 and 2 read as margins, 5e-1 and 2e0 do not
        ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("gear ratio")
        ax.set_ylabel("smallest margin (limit / need)")
        ax.set_title("margin against gear ratio (fits above the dashed line)", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)


LOOP_COLOUR = "0.25"  # the closed loop's points: grey under every motor's colour


def _runaway(a: Assessment) -> bool:
    """The winding's i² R(T) outgrows its cooling: the temperature need is infinite, its margin none."""
    return any(math.isinf(need) for need, _, _ in a.needs.values())


def _known_margin(a: Assessment) -> float:
    """The smallest margin over the limits the data set gives (a figure it lacks cannot rank a motor)."""
    return min((v for k, v in a.margins.items() if not math.isnan(a.needs[k][1])), default=0.0)


def size(model: Mechanism, cycle: DutyCycle, motors, ratios, efficiency: float = 0.9,
         supply_voltage: float | None = None, current_limit: float = math.inf,
         ambient: float = 25.0, control: Control | None = None) -> SizingStudy:
    """Assess every motor at every gear ratio and rank the feasible ones.

    Parameters
    ----------
    model : Mechanism
        One degree of freedom, with a drive joint (and a load joint if the
        cycle has a load).
    cycle : DutyCycle
    motors : list of MotorData
    ratios : sequence of float
        Gear ratios (motor turns per drive-joint turn), >= 1.
    efficiency : float
        Gearbox efficiency.
    supply_voltage : float, optional
        Drive supply (default: each motor's nominal voltage).
    current_limit : float
        The drive's current limit, A.
    ambient : float
        Ambient temperature, degC.
    control : Control, optional
        The position loop that will drive the motor (e.g. :meth:`Control.servo`,
        what ``grubler size`` and its ``--check`` use): the currents are then
        predicted with it (:func:`closed_loop_current`).  Default: a perfect drive.

    Returns
    -------
    SizingStudy

    Examples
    --------
    >>> import numpy as np, grubler
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import DutyCycle, size
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> study = size(m, DutyCycle.constant_speed(2 * np.pi, n=200), [load_motor("maxon-re40-148877")],
    ...              ratios=[20, 35, 50], supply_voltage=48.0, current_limit=10.0)
    >>> [a.candidate.ratio for a in study.ranked], round(study.best.min_margin, 2)
    ([50, 35], 2.05)
    """
    if not motors:
        raise SceneError("motors", "name at least one motor")
    ratios = list(ratios)
    for r in ratios:
        number(r, "ratios")
    # each candidate keeps six arrays over the cycle
    check_size(len(motors) * len(ratios) * len(cycle.t), 6 * 8, "the study's arrays",
               "ratios or motors (--ratios, --motors)")
    demand = required_drive(model, cycle)
    inertia = drive_inertia(model, cycle, demand) if control is not None else None
    assessments = []
    for data in motors:
        supply = supply_voltage if supply_voltage is not None else data.nominal_voltage
        if supply is None:
            raise SceneError("supply_voltage", f"{data.name} has no nominal voltage: give the supply voltage")
        for ratio in ratios:  # assess builds the motor, whose gearbox and drive name a bad field
            assessments.append(assess(demand, cycle, Candidate(data, ratio, efficiency, supply, current_limit),
                                      ambient, control, model, inertia))
    ranked = sorted((a for a in assessments if a.feasible), key=lambda a: -a.min_margin)
    return SizingStudy(demand, cycle, assessments, ranked)


@dataclass
class CheckRow:
    """One limit in a closed-loop check: what was predicted, what the co-simulation needed, the verdict.

    Examples
    --------
    >>> from grubler.studies.sizing import CheckRow
    >>> row = CheckRow("peak current", "A", predicted=2.75, cosimulated=2.9, allowed=10.0)
    >>> round(row.difference, 2), round(row.margin, 3), row.fits      # %, limit over the co-simulated need
    (-5.17, 3.448, True)
    """

    limit: str
    unit: str
    predicted: float
    cosimulated: float
    allowed: float  # NaN: the data set gives no limit

    @property
    def difference(self) -> float:
        """(predicted - co-simulated) / co-simulated, in %."""
        return 100.0 * (self.predicted - self.cosimulated) / self.cosimulated if self.cosimulated else math.nan

    @property
    def margin(self) -> float:
        """Limit over the co-simulated need (0 when the limit is unknown)."""
        if math.isnan(self.allowed):
            return 0.0
        return self.allowed / self.cosimulated if self.cosimulated > 0 else math.inf

    @property
    def fits(self) -> bool:
        return self.margin >= 1.0


@dataclass
class CheckResult:
    """The co-simulated check of one candidate (:func:`closed_loop_check`).

    Examples
    --------
    >>> from grubler.studies.sizing import CheckResult, CheckRow
    >>> check = CheckResult("maxon-re40-148877 x 50", [CheckRow("peak current", "A", 2.75, 2.9, 10.0),
    ...                                                CheckRow("voltage", "V", 22.4, 23.0, 48.0)],
    ...                     max_tracking_error=0.004, periods=3, ideal_peak_current=2.75)
    >>> check.fits, check.row("voltage").cosimulated
    (True, 23.0)
    >>> check.lines()[-1]
    '  fits in closed loop; tracking within 0.004 rad'
    """

    label: str
    rows: list[CheckRow]
    max_tracking_error: float  # rad (m on a slide)
    periods: int
    ideal_peak_current: float  # A: a perfect drive's, the prediction without the position loop

    def row(self, limit: str) -> CheckRow:
        return next(r for r in self.rows if r.limit == limit)

    @property
    def fits(self) -> bool:
        return all(r.fits for r in self.rows)

    def lines(self) -> list[str]:
        """The verdict as printed by ``grubler size --check``."""
        out = [f"closed-loop check of {self.label} (servo co-simulation with feedforward, PID and encoder; "
               f"the last {self.periods - 1} of {self.periods} periods):",
               f"  {'limit':<22}{'predicted':>13}{'co-simulated':>15}{'difference':>12}{'limit':>13}{'margin':>8}"
               "  verdict"]
        for r in self.rows:
            lim = "none given" if math.isnan(r.allowed) else f"{r.allowed:.5g} {r.unit}"
            out.append(f"  {r.limit:<22}{f'{r.predicted:.4g} {r.unit}':>13}{f'{r.cosimulated:.4g} {r.unit}':>15}"
                       f"{f'{r.difference:+.1f} %':>12}{lim:>13}{r.margin:8.2f}  {'fits' if r.fits else 'FAILS'}")
        peak = self.row("peak current").cosimulated
        out.append(f"  a perfect drive (no position loop) would need {self.ideal_peak_current:.4g} A peak "
                   f"({100 * (self.ideal_peak_current - peak) / peak:+.1f} %)")
        out.append(f"  {'fits' if self.fits else 'does not fit'} in closed loop; tracking within "
                   f"{self.max_tracking_error:.2g} rad")
        return out


def closed_loop_check(assessment: Assessment, cycle: DutyCycle, scene: str, trajectory: dict, fmu_dir,
                      periods: int = 3, load_joint: str | None = None, load_torque: float = 0.0,
                      step: float = 1e-3) -> CheckResult:
    """Run a candidate in the servo co-simulation and judge it on every limit.

    The servo (:mod:`grubler.system.servo`) follows ``trajectory`` (Trajectory FMU
    parameters describing the same duty cycle) with the controller the
    prediction used (the assessment's :class:`Control`, else
    :meth:`Control.servo`); the first period is the start-up and is left out.
    The winding temperature is the periodic steady state of the thermal model
    under the co-simulated current of the last period (a few periods of
    co-simulation are far shorter than the thermal time constant).

    Returns
    -------
    CheckResult
        Per limit (peak current, continuous torque, speed, voltage, winding
        temperature rise): predicted, co-simulated, their difference, margin
        and verdict.

    Examples
    --------
    Needs the built FMUs (``python3 build_fmu.py`` writes them to ``dist/``) and
    compiles the feedforward's FMU, so it is not run here:

    >>> import numpy as np, grubler
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import DutyCycle, closed_loop_check, size
    >>> cycle = DutyCycle.constant_speed(2 * np.pi, n=200)
    >>> study = size(grubler.load_scene("thesis-fourbar").mechanism, cycle, [load_motor("maxon-re40-148877")], [50])
    >>> check = closed_loop_check(study.best, cycle, "thesis-fourbar",
    ...                           {"kind": "constant", "speed": 2 * np.pi}, "dist")  # doctest: +SKIP
    >>> print("\\n".join(check.lines()))                                           # doctest: +SKIP
    """
    from grubler.controllers.native_fmu import export_computed_torque
    from grubler.mechanism.scene import load_scene
    from grubler.system.cosim import run
    from grubler.system.servo import ServoDesign, servo_system

    c = assessment.candidate
    data = c.motor
    control = assessment.closed_loop.control if assessment.closed_loop is not None else Control.servo()
    design = ServoDesign(scene=scene, motor=data.name, gear_ratio=c.ratio, gear_efficiency=c.efficiency,
                         supply_voltage=c.supply_voltage,
                         current_limit=c.current_limit,  # inf: none (servo_system spells it 0 for the FMU)
                         trajectory=dict(trajectory), pid=dict(control.pid), encoder=dict(control.encoder),
                         feedforward=control.feedforward, load_joint=load_joint,
                         load_torque=load_torque, t_end=periods * cycle.period, step=step)
    if control.feedforward:  # a mechanism of another shape than ComputedTorque.fmu's gets its own
        export_computed_torque(load_scene(scene), fmu_dir)
    res = run(servo_system(design, fmu_dir, name="sizing_check"),
              record=["motor.current", "mechanism.drive_angle", "trajectory.position", "mechanism.drive_speed",
                      "motor.terminal_voltage"])
    late = res.t >= res.t[0] + cycle.period
    i = res["motor.current"][late]
    err = res["mechanism.drive_angle"][late] - res["trajectory.position"][late]
    last = res.t >= res.t[-1] - cycle.period * (1 - 1e-9)
    t_heat = np.append(res.t[last], res.t[last][0] + cycle.period)
    i_heat = np.append(res["motor.current"][last], res["motor.current"][last][0])
    rise = float(np.max(periodic_temperature(t_heat, i_heat, data, assessment.ambient))) - assessment.ambient
    needs = assessment.needs
    cosim = {"peak current": float(np.max(np.abs(i))),
             "continuous torque": data.torque_constant * _rms(i),
             "speed": c.ratio * float(np.max(np.abs(res["mechanism.drive_speed"][late]))),
             "voltage": float(np.max(np.abs(res["motor.terminal_voltage"][late]))),
             "temperature rise": rise}
    units = {"speed": "rpm"}
    rows = []
    for k, value in cosim.items():
        if k not in needs:  # no nominal torque: the temperature rise is the continuous check
            continue
        need, allowed, unit = needs[k]
        scale = 30.0 / math.pi if k == "speed" else 1.0  # speeds shown in rpm
        rows.append(CheckRow(k, units.get(k, unit), need * scale, value * scale, allowed * scale))
    return CheckResult(c.label, rows, float(np.max(np.abs(err))), periods, float(np.max(np.abs(assessment.current))))


__all__ = ["DutyCycle", "Candidate", "Assessment", "SizingStudy", "Control", "ClosedLoop", "CheckRow", "CheckResult",
           "required_drive", "drive_inertia", "closed_loop_current", "assess", "size", "periodic_temperature",
           "closed_loop_check"]
