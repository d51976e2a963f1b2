"""A valve-controlled hydraulic cylinder with its supply (``grubler.motors.hydraulic``).

The equations live once, in C (``motors/kernel/hydraulic_cylinder.c``, stated
in its header); this module declares them to ctypes and steps them, and the
native HydraulicCylinder.fmu (:mod:`grubler.fmi.cylinder`) compiles the same
source. A :class:`HydraulicCylinder` holds the constants (SI units, gauge
pressures); a :class:`CylinderSimulator` holds one run's state and steps it
with the valve command and the actuator's length and rate held over each step,
as a co-simulation master does.

Examples
--------
>>> sim = CylinderSimulator(DEFAULT)
>>> out = sim.step(command=0.0, length=0.6, rate=0.0, dt=0.5)    # valve closed, cylinder at rest
>>> round(out["supply_pressure"] / 1e5)          # the relief valve holds the supply near 160 + 10 bar
170
>>> out = sim.step(command=1.0, length=0.6, rate=0.0, dt=0.2)   # open towards A, the rod held
>>> round(out["pressure_a"] / 1e5), round(out["pressure_b"] / 1e5)  # A at the supply, B at the tank [bar]
(170, 0)
>>> round(out["force"] / 1e3, 1)                                    # kN, p_A times the bore's area
33.3

:data:`FIELDS` describes each constant (description, unit, lower bound) and
:data:`OUTPUT_FIELDS` names what a step returns:

>>> FIELDS["relief_pressure"]
('cracking pressure of the relief valve (gauge)', 'Pa', 0.0)
>>> OUTPUT_FIELDS[:4]
('force', 'pressure_a', 'pressure_b', 'supply_pressure')
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from grubler.errors import SceneError
from grubler.motors.cylinder import CylinderRun, Piston, check_constants
from grubler.motors.native import HYDRAULIC

# hyd_params' fields in the header's order: name -> (description, unit, lower bound)
FIELDS = {
    "bore": ("piston diameter D", "m", 0.0),
    "rod": ("rod diameter d < D", "m", 0.0),
    "stroke": ("stroke L", "m", 0.0),
    "retracted_length": ("actuator length between its attachment points at s = 0", "m", 0.0),
    "dead_volume_a": ("cap-side volume at s = 0, hoses included", "m3", 0.0),
    "dead_volume_b": ("rod-side volume at s = L, hoses included", "m3", 0.0),
    "viscous_friction": ("viscous friction of the piston and rod seals", "N.s/m", 0.0),
    "coulomb_friction": ("Coulomb friction of the seals", "N", 0.0),
    "smoothing_speed": ("speed over which the Coulomb friction changes sign (tanh)", "m/s", 0.0),
    "stop_stiffness": ("stiffness of the end stops", "N/m", 0.0),
    "stop_damping": ("damping of the end stops while compressed", "N.s/m", 0.0),
    "bulk_modulus": ("bulk modulus of the oil", "Pa", 0.0),
    "air_fraction": ("entrained air by volume at atmospheric pressure, [0, 0.5)", "1", 0.0),
    "leakage": ("internal leakage past the piston, per pressure difference", "m3/(s.Pa)", 0.0),
    "nominal_flow": ("valve flow per metering edge, fully open, at nominal_pressure_drop", "m3/s", 0.0),
    "nominal_pressure_drop": ("pressure drop per metering edge at which nominal_flow is stated", "Pa", 0.0),
    "valve_frequency": ("natural frequency of the spool's second-order response", "rad/s", 0.0),
    "valve_damping": ("damping ratio of the spool's response", "1", 0.0),
    "overlap": ("spool travel before an edge opens, fraction of full travel [0, 1)", "1", 0.0),
    "valve_leakage": ("laminar leakage of each metering edge", "m3/(s.Pa)", 0.0),
    "transition_pressure": ("pressure drop below which an orifice's flow turns laminar", "Pa", 0.0),
    "pump_flow": ("pump flow (constant displacement)", "m3/s", 0.0),
    "relief_pressure": ("cracking pressure of the relief valve (gauge)", "Pa", 0.0),
    "relief_gradient": ("relief valve's flow per pressure above cracking", "m3/(s.Pa)", 0.0),
    "supply_volume": ("oil volume between pump and valve", "m3", 0.0),
    "tank_pressure": ("tank pressure (gauge)", "Pa", None),
    "tolerance": ("relative error per internal sub-step (pressures: of 1 bar at least)", "1", 0.0),
}


@dataclass(frozen=True)
class HydraulicCylinder(Piston):
    """The constants of a cylinder, its proportional valve and its supply (SI, gauge pressures).

    The fields are the C model's ``hyd_params``, described in :data:`FIELDS`.
    The defaults: a 50/28 mm cylinder of 300 mm stroke, a 40 L/min (at 35 bar
    per edge) proportional valve of 50 Hz, 30 L/min from the pump, relief at
    160 bar. Checked on creation: a bad value raises :class:`grubler.SceneError`
    naming the field.

    Examples
    --------
    >>> HydraulicCylinder(rod=0.06)
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: rod: must be narrower than the bore (got 0.06)
    """

    bore: float = 0.050
    rod: float = 0.028
    stroke: float = 0.300
    retracted_length: float = 0.500
    dead_volume_a: float = 5e-5
    dead_volume_b: float = 5e-5
    viscous_friction: float = 2000.0
    coulomb_friction: float = 200.0
    smoothing_speed: float = 1e-3
    stop_stiffness: float = 1e8
    stop_damping: float = 1e5
    bulk_modulus: float = 1.4e9
    air_fraction: float = 0.002
    leakage: float = 1e-13
    nominal_flow: float = 40.0 / 60000.0
    nominal_pressure_drop: float = 35e5
    valve_frequency: float = 2.0 * math.pi * 50.0
    valve_damping: float = 0.7
    overlap: float = 0.0
    valve_leakage: float = 2e-13
    transition_pressure: float = 1e5
    pump_flow: float = 30.0 / 60000.0
    relief_pressure: float = 160e5
    relief_gradient: float = (30.0 / 60000.0) / 10e5
    supply_volume: float = 1e-3
    tank_pressure: float = 0.0
    tolerance: float = 1e-4

    def __post_init__(self):
        check_constants(HYDRAULIC, self)


STATE_FIELDS = tuple(name for name, _ in HYDRAULIC.state._fields_)
OUTPUT_FIELDS = tuple(name for name, _ in HYDRAULIC.outputs._fields_)


class CylinderSimulator(CylinderRun):
    """One run of a :class:`HydraulicCylinder`: its state, stepped with held inputs.

    Parameters
    ----------
    cylinder : HydraulicCylinder
    pressure_a, pressure_b : float
        Chamber pressures at the start [Pa, gauge]; default the tank's.
    supply_pressure : float, optional
        Default: the relief valve's cracking pressure.

    Methods ``step(command, length, rate, dt)`` and ``observe(command, length,
    rate)`` return the outputs by name (:data:`OUTPUT_FIELDS`).

    Examples
    --------
    >>> sim = CylinderSimulator(DEFAULT, pressure_a=50e5)     # 50 bar in the cap side at the start
    >>> out = sim.observe(command=0.0, length=0.6, rate=0.0)  # the outputs now, without stepping
    >>> round(out["force"])                # N: 50 bar on the 50 mm bore
    9817
    >>> round(out["position"], 3)          # m: 0.6 m between the attachments, 0.5 m retracted
    0.1
    """

    def __init__(self, cylinder: HydraulicCylinder, pressure_a: float | None = None,
                 pressure_b: float | None = None, supply_pressure: float | None = None):
        if not isinstance(cylinder, HydraulicCylinder):
            raise SceneError("cylinder", f"must be a HydraulicCylinder, got {type(cylinder).__name__}")
        self.cylinder = cylinder
        pt = cylinder.tank_pressure
        super().__init__(HYDRAULIC, cylinder, (0.0, 0.0, pt if pressure_a is None else pressure_a,
                                               pt if pressure_b is None else pressure_b,
                                               cylinder.relief_pressure if supply_pressure is None
                                               else supply_pressure, 0.0))


DEFAULT = HydraulicCylinder()

__all__ = ["CylinderSimulator", "DEFAULT", "FIELDS", "HydraulicCylinder", "OUTPUT_FIELDS"]
