"""A valve-controlled pneumatic cylinder (``grubler.motors.pneumatic``).

The equations live once, in C (``motors/kernel/pneumatic_cylinder.c``, stated in
its header): ideal-gas chambers whose change of state is polytropic (exponent
1, isothermal, to 1.4, adiabatic), fed and exhausted through a proportional 5/3
valve whose edges follow ISO 6358 (sonic conductance C and critical pressure
ratio b). The native PneumaticCylinder.fmu (:mod:`grubler.fmi.cylinder`)
compiles the same source.

Examples
--------
>>> sim = PneumaticSimulator(DEFAULT)
>>> out = sim.step(command=1.0, length=0.25, rate=0.0, dt=0.5)    # open towards A, the rod held
>>> round(out["pressure_a"] / 1e5, 2), round(out["pressure_b"] / 1e5, 2)   # A at the supply, B exhausted [bar]
(6.0, 0.0)
>>> round(out["force"])                                             # N: 6 bar on a 32 mm bore, less nothing
483

:data:`FIELDS` describes each constant (description, unit, lower bound) and
:data:`OUTPUT_FIELDS` names what a step returns:

>>> FIELDS["bore"]
('piston diameter D', 'm', 0.0)
>>> OUTPUT_FIELDS[:3]
('force', 'pressure_a', 'pressure_b')
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from grubler.errors import SceneError
from grubler.motors.cylinder import CylinderRun, Piston, check_constants
from grubler.motors.native import PNEUMATIC

# pnc_params' fields in the header's order: name -> (description, unit, lower bound)
FIELDS = {
    "bore": ("piston diameter D", "m", 0.0),
    "rod": ("rod diameter d < D", "m", 0.0),
    "stroke": ("stroke L", "m", 0.0),
    "retracted_length": ("actuator length between its attachment points at s = 0", "m", 0.0),
    "dead_volume_a": ("cap-side volume at s = 0, tubes included", "m3", 0.0),
    "dead_volume_b": ("rod-side volume at s = L, tubes included", "m3", 0.0),
    "viscous_friction": ("viscous friction of the piston and rod seals", "N.s/m", 0.0),
    "coulomb_friction": ("Coulomb friction of the seals", "N", 0.0),
    "smoothing_speed": ("speed over which the Coulomb friction changes sign (tanh)", "m/s", 0.0),
    "stop_stiffness": ("stiffness of the end stops", "N/m", 0.0),
    "stop_damping": ("damping of the end stops while compressed", "N.s/m", 0.0),
    "leakage": ("leakage past the piston, mass flow per pressure difference", "kg/(s.Pa)", 0.0),
    "sonic_conductance": ("ISO 6358 sonic conductance C of one metering edge fully open", "m3/(s.Pa)", 0.0),
    "critical_pressure_ratio": ("ISO 6358 critical pressure ratio b, [0, 1)", "1", 0.0),
    "laminar_ratio": ("pressure ratio above which an edge's flow turns laminar, (b, 1)", "1", 0.0),
    "valve_frequency": ("natural frequency of the spool's second-order response", "rad/s", 0.0),
    "valve_damping": ("damping ratio of the spool's response", "1", 0.0),
    "overlap": ("spool travel before an edge opens, fraction of full travel [0, 1)", "1", 0.0),
    "supply_pressure": ("supply pressure (gauge)", "Pa", 0.0),
    "exhaust_pressure": ("exhaust pressure (gauge)", "Pa", None),
    "supply_temperature": ("temperature of the supplied air, taken for the chambers' too", "K", 0.0),
    "polytropic_exponent": ("the chambers' polytropic exponent: 1 isothermal to 1.4 adiabatic", "1", 1.0),
    "tolerance": ("relative error per internal sub-step (pressures: of 1 bar at least)", "1", 0.0),
}


@dataclass(frozen=True)
class PneumaticCylinder(Piston):
    """The constants of a pneumatic cylinder and its proportional valve (SI, gauge pressures).

    The fields are the C model's ``pnc_params``, described in :data:`FIELDS`.
    The defaults: a 32/12 mm cylinder of 100 mm stroke, a valve of sonic
    conductance 1.2 dm3/(s bar) per edge (b = 0.3), 6 bar supply, polytropic
    exponent 1.2. Checked on creation: a bad value raises
    :class:`grubler.SceneError` naming the field.

    Examples
    --------
    >>> PneumaticCylinder(polytropic_exponent=1.6)
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: polytropic_exponent: must lie in [1, 1.4]: isothermal to adiabatic (got 1.6)
    """

    bore: float = 0.032
    rod: float = 0.012
    stroke: float = 0.100
    retracted_length: float = 0.200
    dead_volume_a: float = 5e-6
    dead_volume_b: float = 5e-6
    viscous_friction: float = 50.0
    coulomb_friction: float = 20.0
    smoothing_speed: float = 1e-3
    stop_stiffness: float = 1e7
    stop_damping: float = 1e3
    leakage: float = 0.0
    sonic_conductance: float = 1.2e-8
    critical_pressure_ratio: float = 0.3
    laminar_ratio: float = 0.999
    valve_frequency: float = 2.0 * math.pi * 30.0
    valve_damping: float = 0.7
    overlap: float = 0.05
    supply_pressure: float = 6e5
    exhaust_pressure: float = 0.0
    supply_temperature: float = 293.15
    polytropic_exponent: float = 1.2
    tolerance: float = 1e-4

    def __post_init__(self):
        check_constants(PNEUMATIC, self)


STATE_FIELDS = tuple(name for name, _ in PNEUMATIC.state._fields_)
OUTPUT_FIELDS = tuple(name for name, _ in PNEUMATIC.outputs._fields_)


class PneumaticSimulator(CylinderRun):
    """One run of a :class:`PneumaticCylinder`: its state, stepped with held inputs.

    Parameters
    ----------
    cylinder : PneumaticCylinder
    pressure_a, pressure_b : float
        Chamber pressures at the start [Pa, gauge]; default the exhaust's.

    Methods ``step(command, length, rate, dt)`` and ``observe(command, length,
    rate)`` return the outputs by name (:data:`OUTPUT_FIELDS`).

    Examples
    --------
    >>> sim = PneumaticSimulator(DEFAULT, pressure_a=3e5)     # 3 bar in the cap side at the start
    >>> out = sim.observe(command=0.0, length=0.25, rate=0.0)  # the outputs now, without stepping
    >>> round(out["force"])                # N: 3 bar on the 32 mm bore
    241
    >>> round(out["position"], 3)          # m: 0.25 m between the attachments, 0.2 m retracted
    0.05
    """

    def __init__(self, cylinder: PneumaticCylinder, pressure_a: float | None = None,
                 pressure_b: float | None = None):
        if not isinstance(cylinder, PneumaticCylinder):
            raise SceneError("cylinder", f"must be a PneumaticCylinder, got {type(cylinder).__name__}")
        self.cylinder = cylinder
        pe = cylinder.exhaust_pressure
        super().__init__(PNEUMATIC, cylinder, (0.0, 0.0, pe if pressure_a is None else pressure_a,
                                               pe if pressure_b is None else pressure_b, 0.0))


DEFAULT = PneumaticCylinder()

__all__ = ["DEFAULT", "FIELDS", "OUTPUT_FIELDS", "PneumaticCylinder", "PneumaticSimulator"]
