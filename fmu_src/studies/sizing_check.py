"""A sizing checked by co-simulation: the chosen motor and ratio run in the servo system, against the prediction.

Examples
--------
>>> CheckRow.__name__, CheckResult.__name__
('CheckRow', 'CheckResult')
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grubler.studies.closed_loop import Control
from grubler.studies.duty_cycle import DutyCycle, rms
from grubler.studies.thermal import periodic_temperature


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


def closed_loop_check(assessment, cycle: DutyCycle, scene: str, trajectory: dict, fmu_dir,
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
             "continuous torque": data.torque_constant * rms(i),
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


__all__ = ["CheckRow", "CheckResult", "closed_loop_check"]
