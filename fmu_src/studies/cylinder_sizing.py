"""Cylinder sizing: which hydraulic cylinder bore and supply pressure a linkage's duty cycle needs.

The drive joint's duty cycle (the one :mod:`grubler.studies.sizing` takes) is
carried out by the scene's actuator instead of a motor.  For a mechanism of one
degree of freedom, virtual power says what force the actuator must give: the
drive effort the motion needs (:func:`grubler.studies.sizing.required_drive`)
over the actuator's lever, ``F = tau / (dL/dx)``, and its speed is
``L' = (dL/dx) x'``.  ``dL/dx`` comes from the kinematics at each sample (the
actuator's rate at a unit drive rate).

Each candidate (bore, supply pressure; rod a fixed fraction of the bore; the
valve, pump, stroke and seals as given) is held against the cycle, a margin per
limit (what is available over what is needed; 1 is exactly enough):

- **force**: the piston must give F plus its seals' friction (b v + F_c
  sign v).  Driving (force and speed of one sign, or at rest), the supply feeds
  the pressurised chamber through one metering edge of the fully open valve
  and the other chamber drains through another: ``p_in <= p_s - (A_in v / K)^2``,
  ``p_out >= p_T + (A_out v / K)^2`` with ``K = Q_N / sqrt(dp_N)``.  Overrunning
  (the load drives the piston), the chamber that holds it may rise to the
  supply pressure, the rating taken for the circuit;
- **flow**: the pump's flow over the peak flow into the moving chamber;
- **stroke**: the stroke over the length the cycle sweeps;
- **buckling**: Euler's load of the rod (pinned at both ends, the actuator's
  longest length, steel) over ``BUCKLING_SAFETY`` times the peak push.

Feasible candidates are ranked by the hydraulic power they install,
``p_s x`` the peak flow (the least that does the job first), the others
follow with their reasons, fewest broken limits first.

Examples
--------
>>> from grubler import load_scene
>>> from grubler.controllers.trajectory import Trajectory
>>> boom = load_scene("luffing-boom").mechanism           # the jib lifted 0.1 rad in 2.25 s
>>> move = Trajectory("trapezoid", distance=0.1, v_max=0.05, a_max=0.2)
>>> cycle = DutyCycle.from_trajectory(move, move.move_time + 0.5, n=101, start=boom.q_ref[1])
>>> study = size_cylinder(boom, "lift", cycle, bores=[0.05, 0.063], pressures=[100e5, 160e5])
>>> study.best.candidate.label
'63 mm bore, 100 bar'
>>> study.rejected[0].failures[0][:44]   # Euler on the 28 mm rod, 3.5 times the push
'buckling: the 28 mm rod at 1.31 m buckles at'
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from grubler.errors import SceneError
from grubler.mechanism.inverse import drive_demand
from grubler.mechanism.model import Mechanism
from grubler.studies.ranking import RankedStudy
from grubler.studies.sizing import DutyCycle, required_drive

STEEL_MODULUS = 2.1e11  # Pa, the rod's Young's modulus
BUCKLING_SAFETY = 3.5  # the usual factor on Euler's load for a cylinder's rod
LIMITS = ("force", "flow", "stroke", "buckling")
# the candidates held against a cycle unless told otherwise (`grubler size --cylinder`'s defaults, the app's
# Size): bores in mm and supply pressures in bar as the options are typed, the rod over the bore, the stroke in m
CANDIDATE_DEFAULTS = {"bores": "32,40,50,63,80,100", "pressures": "100,160,210", "rod_ratio": 0.56, "stroke": 0.3}
# the units of the study table's numbers (CylinderAssessment.summary), as people size a cylinder
SUMMARY_UNITS = {"bore": "mm", "rod": "mm", "supply_pressure": "bar", "installed_power": "kW"}


@dataclass
class ActuatorDemand:
    """What the actuator must do over one cycle, sample by sample.

    Attributes
    ----------
    t, length, rate, force : ndarray
        Time (s), the actuator's length (m), its rate (m/s) and the force it
        must give along its line (N, positive pushing apart).
    lever : ndarray
        dL/dx: how its length changes with the drive joint (m/rad, or m/m).

    Examples
    --------
    >>> from grubler import load_scene
    >>> from grubler.controllers.trajectory import Trajectory
    >>> boom = load_scene("luffing-boom").mechanism           # the jib lifted 0.1 rad
    >>> move = Trajectory("trapezoid", distance=0.1, v_max=0.05, a_max=0.2)
    >>> cycle = DutyCycle.from_trajectory(move, move.move_time + 0.5, n=101, start=boom.q_ref[1])
    >>> d = actuator_demand(boom, "lift", cycle)
    >>> round(float(d.length.min()), 3), round(float(d.length.max()), 3)     # m: the cylinder's lengths
    (1.226, 1.311)
    >>> round(float(abs(d.force).max()) / 1e3, 1)                            # kN: the peak force it must give
    11.7
    """

    t: np.ndarray
    length: np.ndarray
    rate: np.ndarray
    force: np.ndarray
    lever: np.ndarray


def actuator_demand(model: Mechanism, actuator: str, cycle: DutyCycle) -> ActuatorDemand:
    """The force, length and rate the actuator ``actuator`` needs to carry out ``cycle``.

    Raises
    ------
    SceneError
        Naming ``actuator`` for one the mechanism does not have, or
        ``duty_cycle`` where the actuator's length does not change with the
        drive joint (it cannot drive the mechanism there).

    Examples
    --------
    >>> from grubler import load_scene
    >>> from grubler.controllers.trajectory import Trajectory
    >>> boom = load_scene("luffing-boom").mechanism
    >>> move = Trajectory("trapezoid", distance=0.1, v_max=0.05, a_max=0.2)
    >>> cycle = DutyCycle.from_trajectory(move, move.move_time + 0.5, n=101, start=boom.q_ref[1])
    >>> d = actuator_demand(boom, "lift", cycle)
    >>> round(float(d.lever[0]), 3)           # m/rad: the cylinder lengthens 0.86 m per radian of the jib
    0.864
    >>> actuator_demand(boom, "tilt", cycle)
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: actuator: no actuator named 'tilt'; the mechanism's: lift
    """
    from grubler.mechanism.simulate import actuator_lines

    if actuator not in model.actuator_names:
        raise SceneError("actuator", f"no actuator named {actuator!r}; the mechanism's: "
                                     f"{', '.join(model.actuator_names) or 'none'}")
    a = model.actuator_names.index(actuator)
    demand = required_drive(model, cycle)
    # the actuator's rate at a unit drive rate: dL/dx, at rest too
    unit = drive_demand(model.replace(drive_inertia=0.0), cycle.position, np.ones_like(cycle.t),
                        np.zeros_like(cycle.t), cycle.load)
    lever = actuator_lines(model, np.hstack([unit.z, unit.zd]))[:, a, 1]
    lines = actuator_lines(model, np.hstack([demand.z, demand.zd]))[:, a, :]
    size = max(abs(link.a) for link in model.links) or 1.0
    weak = np.abs(lever) < 1e-6 * size
    if np.any(weak):
        k = int(np.argmax(weak))
        raise SceneError("duty_cycle", f"at t = {cycle.t[k]:.4g} s the actuator {actuator}'s length does not change "
                                       "with the drive joint (dL/dx = 0: a dead point of the actuator): it cannot "
                                       "drive the mechanism there; give a motion that stays clear of it")
    return ActuatorDemand(cycle.t.copy(), lines[:, 0].copy(), lines[:, 1].copy(), demand.torque / lever, lever)


@dataclass(frozen=True)
class CylinderCandidate:
    """A hydraulic cylinder's bore and supply pressure, with what is fixed around it.

    ``constants`` are :class:`grubler.motors.hydraulic.HydraulicCylinder` fields
    (the valve, pump, seals, stroke); the rod is ``rod_ratio`` of the bore and
    the supply pressure is the relief valve's cracking pressure.

    Examples
    --------
    >>> c = CylinderCandidate(bore=0.063, pressure=100e5)
    >>> c.label
    '63 mm bore, 100 bar'
    >>> cyl = c.cylinder()                      # a HydraulicCylinder: the rod 0.56 of the bore, relief at the pressure
    >>> round(cyl.rod * 1e3, 2), cyl.relief_pressure
    (35.28, 10000000.0)
    """

    bore: float
    pressure: float
    rod_ratio: float = 0.56
    constants: dict = field(default_factory=dict)

    @property
    def label(self) -> str:
        return f"{self.bore * 1e3:g} mm bore, {self.pressure / 1e5:g} bar"

    def cylinder(self, retracted_length: float | None = None):
        """The :class:`~grubler.motors.hydraulic.HydraulicCylinder` of this candidate."""
        from grubler.motors.hydraulic import HydraulicCylinder

        extra = {} if retracted_length is None else {"retracted_length": retracted_length}
        return HydraulicCylinder(**{**self.constants, "bore": self.bore, "rod": self.rod_ratio * self.bore,
                                    "relief_pressure": self.pressure, **extra})


@dataclass
class CylinderAssessment:
    """One candidate held against a demand: its margins and, where they fall short, why.

    Examples
    --------
    >>> from grubler import load_scene
    >>> from grubler.controllers.trajectory import Trajectory
    >>> boom = load_scene("luffing-boom").mechanism
    >>> move = Trajectory("trapezoid", distance=0.1, v_max=0.05, a_max=0.2)
    >>> cycle = DutyCycle.from_trajectory(move, move.move_time + 0.5, n=101, start=boom.q_ref[1])
    >>> a = assess_cylinder(actuator_demand(boom, "lift", cycle), CylinderCandidate(0.063, 100e5))
    >>> a.feasible, a.binding                   # every margin at least 1; the rod's buckling is the nearest
    (True, 'buckling')
    >>> {k: round(m, 2) for k, m in a.margins.items()}
    {'force': 2.56, 'flow': 3.72, 'stroke': 3.53, 'buckling': 2.19}
    """

    candidate: CylinderCandidate
    margins: dict[str, float]
    reasons: dict[str, str]
    power: float  # W: the supply pressure times the peak flow into the moving chamber
    # N, at each sample of the demand: the force the piston must give (friction included) and what the
    # candidate gives there in that direction (the study's figure draws one over the other)
    needed: np.ndarray | None = None
    available: np.ndarray | None = None

    @property
    def feasible(self) -> bool:
        return all(m >= 1.0 for m in self.margins.values())

    @property
    def min_margin(self) -> float:
        return min(self.margins.values())

    @property
    def binding(self) -> str:
        return min(self.margins, key=self.margins.get)

    @property
    def failures(self) -> list[str]:
        """Each broken limit in words, the worst first."""
        return [self.reasons[k] for k in sorted(self.margins, key=self.margins.get) if self.margins[k] < 1.0]

    def summary(self) -> dict[str, float | str | bool]:
        """The study table's row for this candidate, each number in its :data:`SUMMARY_UNITS` unit."""
        c = self.candidate
        row = {"bore": c.bore * 1e3, "rod": c.rod_ratio * c.bore * 1e3, "supply_pressure": c.pressure / 1e5,
               "installed_power": self.power / 1e3}
        row.update({f"margin_{k}": v for k, v in self.margins.items()})
        row.update(feasible=self.feasible, binding=self.binding, why_not="; ".join(self.failures))
        return row


def assess_cylinder(demand: ActuatorDemand, candidate: CylinderCandidate) -> CylinderAssessment:
    """Margins of one candidate over the demand (see the module's notes).

    Examples
    --------
    >>> from grubler import load_scene
    >>> from grubler.controllers.trajectory import Trajectory
    >>> boom = load_scene("luffing-boom").mechanism
    >>> move = Trajectory("trapezoid", distance=0.1, v_max=0.05, a_max=0.2)
    >>> cycle = DutyCycle.from_trajectory(move, move.move_time + 0.5, n=101, start=boom.q_ref[1])
    >>> a = assess_cylinder(actuator_demand(boom, "lift", cycle), CylinderCandidate(0.04, 100e5))
    >>> a.feasible
    False
    >>> a.failures                              # the 22 mm rod of a 40 mm bore buckles
    ['buckling: the 22.4 mm rod at 1.31 m buckles at 14.9 kN, 3.5 times the peak push 11.95 kN needs more (margin 0.356)']
    """
    c = candidate.cylinder()
    area_a, area_b = c.areas
    k = c.nominal_flow / math.sqrt(c.nominal_pressure_drop)
    v, f = demand.rate, demand.force
    piston = f + c.viscous_friction * v + c.coulomb_friction * np.tanh(v / c.smoothing_speed)
    push = piston >= 0.0
    # the chamber the force needs pressurised, and the other
    a_in, a_out = np.where(push, area_a, area_b), np.where(push, area_b, area_a)
    driving = piston * v >= 0.0
    meter_in = (c.relief_pressure - (a_in * np.abs(v) / k) ** 2) * a_in - (
        c.tank_pressure + (a_out * np.abs(v) / k) ** 2) * a_out
    available = np.where(driving, meter_in, c.relief_pressure * a_in)
    need = np.abs(piston)
    ratio = np.where(need > 0, available / np.maximum(need, 1e-300), np.inf)
    i = int(np.argmin(ratio))
    margins, reasons = {}, {}
    margins["force"] = float(ratio[i])
    how = "driving" if driving[i] else "holding back an overrunning load"
    reasons["force"] = (f"force: needs {need[i] / 1e3:.4g} kN ({'push' if push[i] else 'pull'}, {how}) at "
                        f"{v[i]:+.3g} m/s, t = {demand.t[i]:.4g} s; {candidate.label} gives "
                        f"{max(available[i], 0.0) / 1e3:.4g} kN (margin {ratio[i]:.3g})")
    flow_in = np.where(v >= 0.0, area_a, area_b) * np.abs(v)
    peak_flow = float(flow_in.max())
    margins["flow"] = c.pump_flow / peak_flow if peak_flow > 0 else math.inf
    reasons["flow"] = (f"flow: needs {peak_flow * 6e4:.4g} L/min at the peak speed, the pump gives "
                       f"{c.pump_flow * 6e4:.4g} L/min (margin {margins['flow']:.3g})")
    sweep = float(np.ptp(demand.length))
    margins["stroke"] = c.stroke / sweep if sweep > 0 else math.inf
    reasons["stroke"] = (f"stroke: the cycle sweeps {sweep * 1e3:.4g} mm of length, the stroke is "
                         f"{c.stroke * 1e3:.4g} mm (margin {margins['stroke']:.3g})")
    peak_push = float(np.max(np.where(push, need, 0.0)))
    euler = math.pi ** 2 * STEEL_MODULUS * (math.pi * c.rod ** 4 / 64) / float(demand.length.max()) ** 2
    margins["buckling"] = euler / (BUCKLING_SAFETY * peak_push) if peak_push > 0 else math.inf
    reasons["buckling"] = (f"buckling: the {c.rod * 1e3:.3g} mm rod at {demand.length.max():.3g} m buckles at "
                           f"{euler / 1e3:.4g} kN, {BUCKLING_SAFETY:g} times the peak push {peak_push / 1e3:.4g} kN "
                           f"needs more (margin {margins['buckling']:.3g})")
    return CylinderAssessment(candidate, margins, reasons, c.relief_pressure * peak_flow, need,
                              np.maximum(available, 0.0))


@dataclass
class CylinderStudy(RankedStudy):
    """Every candidate's assessment; ``ranked`` the feasible ones, least installed power first.

    Examples
    --------
    >>> from grubler import load_scene
    >>> from grubler.controllers.trajectory import Trajectory
    >>> boom = load_scene("luffing-boom").mechanism
    >>> move = Trajectory("trapezoid", distance=0.1, v_max=0.05, a_max=0.2)
    >>> cycle = DutyCycle.from_trajectory(move, move.move_time + 0.5, n=101, start=boom.q_ref[1])
    >>> study = size_cylinder(boom, "lift", cycle, bores=[0.05, 0.063], pressures=[100e5, 160e5])
    >>> [a.candidate.label for a in study.ranked]     # least installed power first
    ['63 mm bore, 100 bar', '63 mm bore, 160 bar']
    >>> [a.candidate.label for a in study.rejected]
    ['50 mm bore, 100 bar', '50 mm bore, 160 bar']
    """

    summary_units: ClassVar[dict] = SUMMARY_UNITS  # each table column's unit

    demand: ActuatorDemand
    assessments: list[CylinderAssessment]

    @property
    def ranked(self) -> list[CylinderAssessment]:
        return sorted((a for a in self.assessments if a.feasible), key=lambda a: (a.power, -a.min_margin))

    @property
    def best(self) -> CylinderAssessment | None:
        ranked = self.ranked
        return ranked[0] if ranked else None

    def plot(self, path) -> None:
        """Save the study's figure (:func:`grubler.views.sizing.cylinder_sizing_figure`) to ``path``."""
        from grubler.views.sizing import save_cylinder_sizing

        save_cylinder_sizing(self, path)


def size_cylinder(model: Mechanism, actuator: str, cycle: DutyCycle, bores, pressures, rod_ratio: float = 0.56,
                  constants: dict | None = None) -> CylinderStudy:
    """Assess every bore x supply pressure for the actuator carrying out the cycle.

    Parameters
    ----------
    model : Mechanism
        One degree of freedom, a drive joint (the cycle's coordinate) and the actuator.
    actuator : str
    cycle : DutyCycle
        The drive joint's motion (and load) over one period.
    bores, pressures : sequence of float
        Candidate bores (m) and supply pressures (Pa, gauge).
    rod_ratio : float
        Rod diameter over bore.
    constants : dict, optional
        Fixed :class:`~grubler.motors.hydraulic.HydraulicCylinder` fields (valve, pump, stroke, seals).

    Raises
    ------
    SceneError
        Naming the field: an empty or non-positive bore or pressure list, a rod
        ratio outside (0, 1), the actuator (see :func:`actuator_demand`).

    Examples
    --------
    >>> from grubler import load_scene
    >>> from grubler.controllers.trajectory import Trajectory
    >>> boom = load_scene("luffing-boom").mechanism
    >>> move = Trajectory("trapezoid", distance=0.1, v_max=0.05, a_max=0.2)
    >>> cycle = DutyCycle.from_trajectory(move, move.move_time + 0.5, n=101, start=boom.q_ref[1])
    >>> study = size_cylinder(boom, "lift", cycle, bores=[0.063], pressures=[100e5, 160e5])
    >>> study.best.candidate.label, round(study.best.power)      # W: the supply pressure times the peak flow
    ('63 mm bore, 100 bar', 1343)
    >>> size_cylinder(boom, "lift", cycle, bores=[0.063], pressures=[])
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: pressures: needs at least one candidate
    """
    from grubler.errors import InputError
    from grubler.limits import number

    try:
        bores = [number(b, "bores", low=0.0, low_open=True, unit="m") for b in bores]
        pressures = [number(p, "pressures", low=0.0, low_open=True, unit="Pa") for p in pressures]
        rod_ratio = number(rod_ratio, "rod_ratio", low=0.0, high=1.0, low_open=True)
    except InputError as exc:
        raise SceneError(exc.field, exc.reason) from None
    if not bores or not pressures:
        raise SceneError("bores" if not bores else "pressures", "needs at least one candidate")
    if rod_ratio >= 1.0:
        raise SceneError("rod_ratio", f"the rod must be narrower than the bore, got {rod_ratio:g}")
    demand = actuator_demand(model, actuator, cycle)
    candidates = [CylinderCandidate(b, p, rod_ratio, dict(constants or {})) for b in bores for p in pressures]
    for c in candidates:
        c.cylinder()  # a constant the cylinder refuses is refused here, naming it
    return CylinderStudy(demand, [assess_cylinder(demand, c) for c in candidates])


@dataclass
class CylinderCheck:
    """The winner co-simulated: what the prediction said against what the run did.

    Examples
    --------
    >>> check = CylinderCheck(predicted_force=30e3, simulated_force=31e3, peak_pressure=95e5,
    ...                       supply_pressure=100e5, peak_error=0.004, final_error=0.0002, sweep=0.1)
    >>> check.fits                              # at the end, within the supply, the force as predicted to 20 %
    True
    >>> print(check.lines()[0])
    co-simulated: peak cylinder force 31 kN (predicted 30 kN), peak chamber pressure 95 bar of 100, tracking error peak 4 mm, final 0.2 mm over a 100 mm sweep: it fits
    """

    predicted_force: float
    simulated_force: float
    peak_pressure: float
    supply_pressure: float
    peak_error: float
    final_error: float
    sweep: float

    @property
    def fits(self) -> bool:
        """The run reached the cycle's end (final error under 1 % of the sweep) with its chambers within the
        supply, and the peak force it took is the predicted one to 20 % (the lag of the position loop, which
        the peak tracking error shows, is the controller's, not the cylinder's)."""
        return (self.final_error <= 0.01 * self.sweep and self.peak_pressure <= self.supply_pressure * (1 + 1e-6)
                and abs(self.simulated_force - self.predicted_force) <= 0.2 * self.predicted_force)

    def lines(self) -> list[str]:
        return [f"co-simulated: peak cylinder force {self.simulated_force / 1e3:.4g} kN (predicted "
                f"{self.predicted_force / 1e3:.4g} kN), peak chamber pressure {self.peak_pressure / 1e5:.4g} bar of "
                f"{self.supply_pressure / 1e5:.4g}, tracking error peak {self.peak_error * 1e3:.3g} mm, final "
                f"{self.final_error * 1e3:.3g} mm over a {self.sweep * 1e3:.4g} mm sweep: "
                + ("it fits" if self.fits else "it does NOT fit")]


def check_fmus(scene, fmu_dir, field: str = "fmu_dir") -> None:
    """Refuse, naming ``field``, an ``fmu_dir`` without the FMUs :func:`cylinder_check` runs.

    HydraulicCylinder.fmu and PID.fmu (``python build_fmu.py``), and Mechanism.fmu
    when it serves the scene's shape (another shape's FMU is built, as is the
    setpoint's table).  Cheap: the CLI calls it before any work.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     check_fmus("luffing-boom", d)
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: fmu_dir: no HydraulicCylinder.fmu, PID.fmu in ... build the FMUs there first (python3 build_fmu.py writes them to dist)
    """
    from grubler.errors import InputError
    from grubler.fmi.mechanism import STANDARD_SCENE, same_shape
    from grubler.limits import brief
    from grubler.mechanism.scene import load_scene

    d = Path(fmu_dir)
    if not d.is_dir():
        raise InputError(field, f"{brief(str(d))}: no such folder (the one `python3 build_fmu.py` fills, e.g. dist)")
    model = load_scene(scene).mechanism
    names = ["HydraulicCylinder.fmu", "PID.fmu"]
    if same_shape(model, load_scene(STANDARD_SCENE).mechanism):
        names.append("Mechanism.fmu")
    missing = [n for n in names if not (d / n).is_file()]
    if missing:
        raise InputError(field, f"no {', '.join(missing)} in {brief(str(d))}: build the FMUs there first "
                                "(python3 build_fmu.py writes them to dist)")


def cylinder_check(study: CylinderStudy, scene, actuator: str, fmu_dir, pid: dict | None = None,
                   settle: float = 1.0) -> CylinderCheck:
    """Co-simulate the best candidate following the cycle's actuator length (a table setpoint) under a PID.

    ``fmu_dir`` holds HydraulicCylinder.fmu and PID.fmu (``python build_fmu.py``,
    see :func:`check_fmus`) and is only read: the setpoint's table FMU, and the
    mechanism's FMU where ``Mechanism.fmu`` does not serve the scene, are built in
    a temporary folder, removed afterwards.

    Examples
    --------
    >>> from grubler import load_scene
    >>> from grubler.controllers.trajectory import Trajectory
    >>> boom = load_scene("luffing-boom").mechanism
    >>> move = Trajectory("trapezoid", distance=0.1, v_max=0.05, a_max=0.2)
    >>> cycle = DutyCycle.from_trajectory(move, move.move_time + 0.5, n=101, start=boom.q_ref[1])
    >>> study = size_cylinder(boom, "lift", cycle, bores=[0.063], pressures=[100e5])
    >>> check = cylinder_check(study, "luffing-boom", "lift", "dist")  # doctest: +SKIP
    >>> check.fits                                                       # doctest: +SKIP
    True
    """
    from grubler.limits import remove_temp_dir, temp_dir

    best = study.best
    if best is None:
        raise SceneError("candidates", "no candidate fits: nothing to co-simulate")
    check_fmus(scene, fmu_dir)
    work = temp_dir("grubler-cylinder-check-")
    try:
        return _co_simulate(study, best, scene, actuator, fmu_dir, work, pid, settle)
    finally:
        remove_temp_dir(work)


def _co_simulate(study, best, scene, actuator, fmu_dir, work, pid, settle) -> CylinderCheck:
    """:func:`cylinder_check`'s run, what it builds going to ``work``."""
    from grubler.controllers.native_fmu import export_table
    from grubler.system.cosim import run
    from grubler.system.cylinder_servo import CylinderServoDesign, cylinder_servo_system

    d = study.demand
    # the piston starts where the cycle's shortest length leaves it a tenth of the spare stroke
    stroke = best.candidate.cylinder().stroke
    spare = stroke - float(np.ptp(d.length))
    start_position = float(d.length[0] - d.length.min()) + 0.1 * spare
    t_end = float(d.t[-1]) + settle
    keep = np.concatenate([[True], np.diff(d.t) > 1e-9])  # a sampler's breakpoints may repeat a time
    # the native Trajectory FMU holds a table as parameters of its own build
    table = export_table(d.t[keep], d.length[keep], Path(work) / "Trajectory_cylinder_check.fmu",
                         quantity="length")
    constants = asdict(best.candidate.cylinder())
    del constants["retracted_length"]  # the design sets it from the start
    design = CylinderServoDesign(scene, actuator=actuator, cylinder="hydraulic", constants=constants,
                                 start_position=start_position, setpoint={"kind": "table"},
                                 trajectory_fmu=str(table.resolve()), t_end=t_end,
                                 **({"pid": pid} if pid else {}))
    system = cylinder_servo_system(design, fmu_dir, name="cylinder_check", build_dir=work)
    res = run(system)
    length = res[f"mechanism.{actuator}_length"]
    err = np.abs(res["trajectory.position"] - length)
    return CylinderCheck(float(np.max(np.abs(d.force))), float(np.max(np.abs(res["cylinder.force"]))),
                         float(max(res["cylinder.pressure_a"].max(), res["cylinder.pressure_b"].max())),
                         best.candidate.pressure, float(err.max()), float(err[-1]), float(np.ptp(d.length)))


__all__ = ["ActuatorDemand", "CylinderAssessment", "CylinderCandidate", "CylinderCheck", "CylinderStudy",
           "actuator_demand", "assess_cylinder", "check_fmus", "cylinder_check", "size_cylinder"]
