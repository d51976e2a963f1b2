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
from typing import ClassVar

import numpy as np

from grubler.errors import SceneError
from grubler.limits import check_size, number
from grubler.mechanism.inverse import DriveDemand
from grubler.mechanism.model import Mechanism
from grubler.quantities import RPM
from grubler.studies.closed_loop import ClosedLoop, Control, closed_loop_current
from grubler.studies.duty_cycle import DutyCycle, drive_inertia, required_drive, rms
from grubler.studies.ranking import RankedStudy
from grubler.studies.sizing_check import CheckResult, CheckRow, closed_loop_check
from grubler.studies.thermal import periodic_temperature


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
        w = self.motor_speed
        loop = self.closed_loop
        i = loop.current if loop is not None else self.current
        rms_i = loop.rms_current if loop is not None else rms(i, self.t)
        kt = self.candidate.motor.torque_constant
        row = {"motor": self.candidate.motor.name, "ratio": self.candidate.ratio,
               "peak_motor_torque": kt * float(np.max(np.abs(i))), "rms_motor_torque": kt * rms_i,
               "peak_motor_speed": float(np.max(np.abs(w))) * RPM, "mean_motor_speed": float(np.mean(np.abs(w))) * RPM,
               "peak_current": float(np.max(np.abs(i))), "rms_current": rms_i,
               "peak_current_ideal_drive": float(np.max(np.abs(self.current))),
               "rms_current_ideal_drive": rms(self.current, self.t),
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

    @property
    def runaway(self) -> bool:
        """The winding's i² R(T) outgrows its cooling: the temperature need is infinite, its margin none."""
        return any(math.isinf(need) for need, _, _ in self.needs.values())

    @property
    def known_margin(self) -> float:
        """The smallest margin over the limits the data set gives (a figure it lacks cannot rank a motor)."""
        return min((v for k, v in self.margins.items() if not math.isnan(self.needs[k][1])), default=0.0)



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
        rms_i = rms(i_need, cycle.t) if loop is None else loop.rms_current
        needs["continuous torque"] = (data.torque_constant * rms_i, data.nominal_torque, "N m")
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
class SizingStudy(RankedStudy):
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

    summary_units: ClassVar[dict] = SUMMARY_UNITS  # each table column's unit

    demand: DriveDemand
    cycle: DutyCycle
    assessments: list[Assessment]
    ranked: list[Assessment] = field(default_factory=list)

    @property
    def best(self) -> Assessment | None:
        return self.ranked[0] if self.ranked else None

    def plot(self, path) -> None:
        """Save :meth:`figure` to ``path`` (PNG or any format matplotlib writes)."""
        from grubler.views.sizing import save_motor_sizing

        save_motor_sizing(self, path)

    def figure(self):
        """The study drawn (:func:`grubler.views.sizing.motor_sizing_figure`): duty-cycle points over each motor's
        envelopes, margin against gear ratio, and the key."""
        from grubler.views.sizing import motor_sizing_figure

        return motor_sizing_figure(self)



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


__all__ = ["DutyCycle", "Candidate", "Assessment", "SizingStudy", "Control", "ClosedLoop", "CheckRow", "CheckResult",
           "required_drive", "drive_inertia", "closed_loop_current", "assess", "size", "periodic_temperature",
           "closed_loop_check"]
