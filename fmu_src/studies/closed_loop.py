"""The servo's position loop over a duty cycle: the current the PID and encoder really draw.

A :class:`Control` (the servo's PID, encoder and feedforward, as ``grubler size``
uses) adds to the ideal trajectory's torque what the loop does (chiefly its
derivative's kicks at every encoder count); :func:`closed_loop_current`
computes that current over the cycle, :func:`quantisation_bound` bounds the
encoder's share of it.

Examples
--------
>>> c = Control.servo()
>>> c.pid["Ts"] > 0, c.feedforward
(True, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grubler.errors import SceneError
from grubler.mechanism.inverse import DriveDemand
from grubler.mechanism.model import Mechanism
from grubler.studies.duty_cycle import DutyCycle, rms


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
        return rms(np.append(self.current, self.current[0]), np.append(self.t, self.t[0] + self.period))


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
                        candidate, ideal_current: np.ndarray, control: Control,
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


__all__ = ["Control", "ClosedLoop", "closed_loop_current", "quantisation_bound"]
