"""The cylinder FMUs' variables (``c/cylinder_model.c`` over ``motors/kernel/``).

Two FMUs of one shape: HydraulicCylinder.fmu (a proportional valve, a
double-acting cylinder, pump and relief valve) and PneumaticCylinder.fmu (a
proportional valve and a double-acting cylinder on a constant supply). Every
constant is a parameter, defaulting to :data:`grubler.motors.hydraulic.DEFAULT`
or :data:`grubler.motors.pneumatic.DEFAULT`. The inputs are the valve command
and the actuator's length and rate (the mechanism's outputs); the outputs are
the force on the rod (the mechanism's input), pressures, flows and powers.

Examples
--------
>>> spec = hydraulic_spec()
>>> spec.variables[spec.vr("bulk_modulus") - 1].unit
'Pa'
>>> [v.name for v in spec.variables if v.causality == "input"]
['command', 'length', 'rate']
>>> pneumatic_spec().variables[pneumatic_spec().vr("sonic_conductance") - 1].unit
'm3/(s.Pa)'
"""

from __future__ import annotations

from dataclasses import asdict

from grubler.fmi.variables import INPUT, OUTPUT, PARAMETER, REAL, ModelSpec, Variable
from grubler.motors import hydraulic, pneumatic

INPUTS = {"command": ("valve command in [-1, 1]: +1 opens the supply to A and B to the return fully (extends), "
                      "-1 the supply to B and A to the return", "1"),
          "length": ("actuator length between its attachment points (the mechanism's actuator_length)", "m"),
          "rate": ("its rate, positive extending (the mechanism's actuator_rate)", "m/s")}
_MOVING = ["length", "rate"]

# the start state after the constants, and the outputs in the C struct's order:
# name -> (description, unit, start or None) and name -> (description, unit, inputs it depends on now)
HYDRAULIC_START = {
    "initial_pressure_a": ("cap-side pressure at the start (gauge)", "Pa", 0.0),
    "initial_pressure_b": ("rod-side pressure at the start (gauge)", "Pa", 0.0),
    "initial_supply_pressure": ("supply pressure at the start (gauge; default: the relief valve's cracking "
                                "pressure)", "Pa", None),
}
HYDRAULIC_OUTPUTS = {
    "force": ("force on the rod, positive pushing the attachment points apart", "N", _MOVING),
    "pressure_a": ("cap-side chamber pressure (gauge)", "Pa", []),
    "pressure_b": ("rod-side chamber pressure (gauge)", "Pa", []),
    "supply_pressure": ("supply pressure at the valve's P port (gauge)", "Pa", []),
    "flow_a": ("flow from the valve into chamber A", "m3/s", ["length"]),
    "flow_b": ("flow from the valve into chamber B", "m3/s", ["length"]),
    "relief_flow": ("flow through the relief valve", "m3/s", []),
    "position": ("piston position s = length - retracted_length", "m", ["length"]),
    "spool": ("spool position, fraction of full opening", "1", []),
    "pump_power": ("hydraulic power the pump delivers, (p_S - p_T) Q_pump", "W", []),
    "piston_power": ("power the fluid does on the piston (pressures above tank)", "W", _MOVING),
    "mechanical_power": ("power the rod does on the mechanism, force x rate", "W", _MOVING),
    "throttling_loss": ("power lost in the valve's edges, the relief valve and the internal leakage", "W",
                        ["length"]),
    "compression_power": ("rate of the energy stored in the compressed fluid", "W", _MOVING),
}
PNEUMATIC_START = {
    "initial_pressure_a": ("cap-side pressure at the start (gauge)", "Pa", 0.0),
    "initial_pressure_b": ("rod-side pressure at the start (gauge)", "Pa", 0.0),
}
PNEUMATIC_OUTPUTS = {
    "force": ("force on the rod, positive pushing the attachment points apart", "N", _MOVING),
    "pressure_a": ("cap-side chamber pressure (gauge)", "Pa", []),
    "pressure_b": ("rod-side chamber pressure (gauge)", "Pa", []),
    "mass_flow_a": ("air mass flow from the valve into chamber A", "kg/s", []),
    "mass_flow_b": ("air mass flow from the valve into chamber B", "kg/s", []),
    "air_consumption": ("air mass flow drawn from the supply", "kg/s", []),
    "position": ("piston position s = length - retracted_length", "m", ["length"]),
    "spool": ("spool position, fraction of full opening", "1", []),
    "mechanical_power": ("power the rod does on the mechanism, force x rate", "W", _MOVING),
}


def _spec(constants, fields: dict, start: dict, outputs: dict, identifier: str, description: str, kind: str,
          defaults_from: dict, n_state: int) -> ModelSpec:
    values = {k: float(v) for k, v in asdict(constants).items()}
    v = [Variable(name, REAL, PARAMETER, text, values[name], unit, lo) for name, (text, unit, lo) in fields.items()]
    for name, (text, unit, value) in start.items():
        v.append(Variable(name, REAL, PARAMETER, text, values[defaults_from[name]] if value is None else value, unit))
    for name, (text, unit) in INPUTS.items():
        v.append(Variable(name, REAL, INPUT, text, constants.retracted_length if name == "length" else 0.0, unit))
    for k, (name, (text, unit, deps)) in enumerate(outputs.items()):
        v.append(Variable(name, REAL, OUTPUT, text, unit=unit, level=1, feedthrough=bool(deps), slot=k,
                          depends_on=tuple(deps)))
    slots = [*fields, *start, *INPUTS]
    defines = {f"SLOT_{n.upper()}": k for k, n in enumerate(slots)}
    defines[f"CYLINDER_{kind.upper()}"] = 1
    for name, source in defaults_from.items():  # a start value that follows a parameter unless set
        defines["SLOT_UNSET_INITIAL"], defines["SLOT_UNSET_INITIAL_FROM"] = slots.index(name), slots.index(source)
    # the model's own part of the block: whether it holds a started run, its time, and
    # the C model's state struct (spool, its rate, the pressures, the last sub-step)
    run_state = (("started", 1), ("t", 1), ("state", n_state), ("end", 0))
    return ModelSpec(identifier, description, tuple(v), "cylinder_model.c", defines, len(outputs), (), (), (kind,),
                     run_state)


def hydraulic_spec(cylinder: hydraulic.HydraulicCylinder = hydraulic.DEFAULT,
                   identifier: str = "HydraulicCylinder") -> ModelSpec:
    """The variables of a hydraulic cylinder FMU whose parameters default to ``cylinder``'s."""
    return _spec(cylinder, hydraulic.FIELDS, HYDRAULIC_START, HYDRAULIC_OUTPUTS, identifier,
                 "Valve-controlled double-acting hydraulic cylinder with pump, relief valve and tank; inputs valve "
                 "command and actuator length and rate, output the force on the rod", "hydraulic",
                 {"initial_supply_pressure": "relief_pressure"}, len(hydraulic.STATE_FIELDS))


def pneumatic_spec(cylinder: pneumatic.PneumaticCylinder = pneumatic.DEFAULT,
                   identifier: str = "PneumaticCylinder") -> ModelSpec:
    """The variables of a pneumatic cylinder FMU whose parameters default to ``cylinder``'s."""
    return _spec(cylinder, pneumatic.FIELDS, PNEUMATIC_START, PNEUMATIC_OUTPUTS, identifier,
                 "Valve-controlled double-acting pneumatic cylinder (ISO 6358 valve, polytropic chambers); inputs "
                 "valve command and actuator length and rate, output the force on the rod", "pneumatic", {},
                 len(pneumatic.STATE_FIELDS))


def cylinder_parameters(cylinder) -> dict[str, float]:
    """A cylinder's constants as its FMU's parameters."""
    return {k: float(v) for k, v in asdict(cylinder).items()}
