"""The hydraulic cylinder FMU's variables (``c/hydraulic_model.c`` over ``motors/kernel/hydraulic_cylinder.c``).

Every constant of the cylinder, its valve and its supply is a parameter; the
defaults are :data:`grubler.motors.hydraulic.DEFAULT` (a 50/28 mm cylinder of
300 mm stroke behind a 40 L/min proportional valve, 30 L/min at 160 bar). The
inputs are the valve command and the actuator's length and rate (the
mechanism's outputs); the outputs are the force on the rod (the mechanism's
input), the pressures, flows and powers.

Examples
--------
>>> spec = hydraulic_spec()
>>> spec.variables[spec.vr("bulk_modulus") - 1].unit
'Pa'
>>> [v.name for v in spec.variables if v.causality == "input"]
['command', 'length', 'rate']
"""

from __future__ import annotations

from dataclasses import asdict

from grubler.fmi.variables import INPUT, OUTPUT, PARAMETER, REAL, ModelSpec, Variable
from grubler.motors.hydraulic import DEFAULT, FIELDS, HydraulicCylinder

# after hyd_params' fields: the start state
START = {
    "initial_pressure_a": ("cap-side pressure at the start (gauge)", "Pa", 0.0),
    "initial_pressure_b": ("rod-side pressure at the start (gauge)", "Pa", 0.0),
    "initial_supply_pressure": ("supply pressure at the start (gauge; default: the relief valve's cracking "
                                "pressure)", "Pa", None),
}
INPUTS = {"command": ("valve command in [-1, 1]: +1 opens P->A and B->T fully (extends), -1 P->B and A->T", "1"),
          "length": ("actuator length between its attachment points (the mechanism's actuator_length)", "m"),
          "rate": ("its rate, positive extending (the mechanism's actuator_rate)", "m/s")}
# hyd_outputs' fields in order: name -> (description, unit, inputs it depends on now)
OUTPUTS = {
    "force": ("force on the rod, positive pushing the attachment points apart", "N", ["length", "rate"]),
    "pressure_a": ("cap-side chamber pressure (gauge)", "Pa", []),
    "pressure_b": ("rod-side chamber pressure (gauge)", "Pa", []),
    "supply_pressure": ("supply pressure at the valve's P port (gauge)", "Pa", []),
    "flow_a": ("flow from the valve into chamber A", "m3/s", ["length"]),
    "flow_b": ("flow from the valve into chamber B", "m3/s", ["length"]),
    "relief_flow": ("flow through the relief valve", "m3/s", []),
    "position": ("piston position s = length - retracted_length", "m", ["length"]),
    "spool": ("spool position, fraction of full opening", "1", []),
    "pump_power": ("hydraulic power the pump delivers, (p_S - p_T) Q_pump", "W", []),
    "piston_power": ("power the fluid does on the piston (pressures above tank)", "W", ["length", "rate"]),
    "mechanical_power": ("power the rod does on the mechanism, force x rate", "W", ["length", "rate"]),
    "throttling_loss": ("power lost in the valve's edges, the relief valve and the internal leakage", "W",
                        ["length"]),
    "compression_power": ("rate of the energy stored in the compressed fluid", "W", ["length", "rate"]),
}


def hydraulic_parameters(cylinder: HydraulicCylinder = DEFAULT) -> dict[str, float]:
    """A cylinder's constants as HydraulicCylinder.fmu parameters."""
    return {k: float(v) for k, v in asdict(cylinder).items()}


def hydraulic_spec(cylinder: HydraulicCylinder = DEFAULT, identifier: str = "HydraulicCylinder") -> ModelSpec:
    """The variables of a hydraulic cylinder FMU whose parameters default to ``cylinder``'s."""
    start = hydraulic_parameters(cylinder)
    v = []
    for name, (text, unit, lo) in FIELDS.items():
        v.append(Variable(name, REAL, PARAMETER, text, start[name], unit, lo))
    for name, (text, unit, value) in START.items():
        v.append(Variable(name, REAL, PARAMETER, text, cylinder.relief_pressure if value is None else value, unit))
    for name, (text, unit) in INPUTS.items():
        v.append(Variable(name, REAL, INPUT, text, cylinder.retracted_length if name == "length" else 0.0, unit))
    for k, (name, (text, unit, deps)) in enumerate(OUTPUTS.items()):
        v.append(Variable(name, REAL, OUTPUT, text, unit=unit, level=1, feedthrough=bool(deps), slot=k,
                          depends_on=tuple(deps)))
    defines = {f"SLOT_{n.upper()}": k for k, n in enumerate([*FIELDS, *START, *INPUTS])}
    return ModelSpec(identifier, "Valve-controlled double-acting hydraulic cylinder with pump, relief valve and "
                                 "tank; inputs valve command and actuator length and rate, output the force on the "
                                 "rod",
                     tuple(v), "hydraulic_model.c", defines, len(OUTPUTS), (), (), ("hydraulic",))
