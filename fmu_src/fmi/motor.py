"""The DC motor FMU's variables (served by ``c/motor_model.c`` over ``motors/kernel/dc_motor.c``).

The same variables as the pythonfmu DCMotor.fmu had, but the data set is no
string to parse: every datasheet number is a parameter, defaulting to the
default data set's values, and a master sets a data set's numbers
(:func:`motor_parameters`) to make the FMU that motor.

Examples
--------
>>> spec = motor_spec()
>>> spec.variables[spec.vr("torque_constant") - 1].unit
'N.m/A'
>>> round(motor_parameters("maxon-re30-310007")["resistance"], 3)
0.611
"""

from __future__ import annotations

from grubler.errors import SceneError
from grubler.fmi.variables import INPUT, OUTPUT, PARAMETER, REAL, ModelSpec, Variable

DEFAULT_MOTOR = "maxon-re40-148877"

__all__ = ["motor_parameters", "motor_spec"]

# the C model's dcm_params, in its field order: name -> (description, unit, min)
DATA = {
    "resistance": ("winding resistance at reference_temperature", "Ohm", 0.0),
    "inductance": ("winding inductance", "H", 0.0),
    "torque_constant": ("torque constant k_t", "N.m/A", 0.0),
    "back_emf_constant": ("back-EMF constant k_e, within 2 % of k_t", "V.s/rad", 0.0),
    "rotor_inertia": ("rotor inertia J_rotor; it belongs to the mechanism (see reflected_inertia)", "kg.m2", 0.0),
    "viscous_friction": ("viscous friction at the motor shaft", "N.m.s/rad", 0.0),
    "coulomb_friction": ("Coulomb friction at the motor shaft", "N.m", 0.0),
    "smoothing_speed": ("motor speed over which Coulomb friction and the gearbox's efficiency direction change "
                        "sign (tanh)", "rad/s", 0.0),
    "thermal_resistance": ("thermal resistance winding to ambient", "K/W", 0.0),
    "thermal_time_constant": ("thermal time constant of the winding (one node)", "s", 0.0),
    "temperature_coefficient": ("temperature coefficient of the winding resistance (copper 0.0039)", "1/K", None),
    "reference_temperature": ("temperature at which resistance is stated", "degC", None),
}
SETUP = {
    "gear_ratio": ("gearbox ratio N >= 1, motor speed / shaft speed [1]", None, 1.0),
    "gear_efficiency": ("gearbox efficiency in the direction of power flow, (0, 1] [1]", None, 0.0),
    "supply_voltage": ("supply voltage: the terminal voltage is clamped to +-supply_voltage", "V", 0.0),
    "current_limit": ("drive's current limit; 0: none", "A", 0.0),
    "ambient_temperature": ("ambient temperature", "degC", None),
}
# after dcm_params' fields: the start state, the stepping, the datasheet's limit
EXTRA = {
    "max_substep": ("longest internal step (the current is exact for any step; sub-steps refresh R(T) and the "
                    "thermal coupling)", "s", 0.0),
    "initial_current": ("winding current at the start", "A", None),
    "initial_temperature": ("winding temperature at the start (default: ambient_temperature)", "degC", None),
    "max_winding_temperature": ("datasheet's maximum winding temperature: a warning when exceeded (0: none)",
                                "degC", None),
}
INPUTS = {"voltage": ("commanded terminal voltage", "V"),
          "shaft_speed": ("speed of the gearbox output shaft (the mechanism's drive_speed)", "rad/s")}
# dcm_outputs' fields in order, then reflected_inertia
OUTPUTS = {
    "shaft_torque": ("gearbox output torque, without the rotor's inertia torque", "N.m", ["shaft_speed"]),
    "current": ("current through the winding", "A", []),
    "winding_temperature": ("winding temperature", "degC", []),
    "electrical_power": ("terminal voltage x current, negative when generating", "W", ["voltage", "shaft_speed"]),
    "motor_speed": ("motor speed, gear_ratio x shaft_speed", "rad/s", ["shaft_speed"]),
    "back_emf": ("back-EMF k_e x motor_speed", "V", ["shaft_speed"]),
    "terminal_voltage": ("voltage the drive applies: the command clamped and current-limited", "V",
                         ["voltage", "shaft_speed"]),
    "reflected_inertia": ("rotor inertia seen at the shaft, J_rotor x gear_ratio^2: set the mechanism's "
                          "drive.inertia to it", "kg.m2", []),
}


# the model's own part of the persistent block (motor_model.c's P_*): the run's
# flag and time, the dcm_state (winding current, temperature), the warnings given
RUN_STATE = (("started", 1), ("t", 1), ("current", 1), ("temperature", 1), ("warned_chatter", 1),
             ("warned_hot", 1), ("end", 0))


def motor_parameters(motor=DEFAULT_MOTOR) -> dict[str, float]:
    """A data set's numbers as DCMotor.fmu parameters (name, TOML text or MotorData).

    The supply defaults to the motor's nominal voltage, the start to ambient
    temperature and no current.

    Examples
    --------
    >>> from grubler import ssp
    >>> from grubler.fmi.motor import motor_parameters
    >>> p = motor_parameters("maxon-re40-148877")
    >>> p["resistance"], p["torque_constant"], p["supply_voltage"]      # Ohm, N m/A, V
    (1.16, 0.0603, 48.0)
    >>> motor = ssp.System("pair").add("motor", "DCMotor.fmu", **p, gear_ratio=50.0)   # the FMU made that motor
    >>> len(motor.parameters)
    15
    """
    from grubler.motors.motor_data import MotorData, load_motor

    data = motor if isinstance(motor, MotorData) else load_motor(motor)
    p = {name: float(getattr(data, name)) for name in DATA}
    if data.nominal_voltage is None:
        raise SceneError("supply_voltage", f"motor {data.name!r} states no nominal voltage: set it")
    p["supply_voltage"] = float(data.nominal_voltage)
    mx = data.max_winding_temperature
    p["max_winding_temperature"] = float(mx) if mx is not None else 0.0
    return p


def motor_spec(motor=DEFAULT_MOTOR, identifier: str = "DCMotor") -> ModelSpec:
    """The variables of a DC motor FMU whose parameters default to a data set's.

    Examples
    --------
    >>> from grubler.fmi.motor import motor_spec
    >>> spec = motor_spec("maxon-re40-148877")
    >>> spec.identifier, spec.variables[spec.vr("resistance") - 1].start
    ('DCMotor', 1.16)
    """
    start = {"gear_ratio": 1.0, "gear_efficiency": 1.0, "current_limit": 0.0, "ambient_temperature": 25.0,
             "max_substep": 0.01, "initial_current": 0.0, "initial_temperature": 25.0}
    start.update(motor_parameters(motor))
    v = []
    for table in (DATA, SETUP, EXTRA):
        for name, (text, unit, lo) in table.items():
            hi = 1.0 if name == "gear_efficiency" else None
            v.append(Variable(name, REAL, PARAMETER, text, start[name], unit, lo, hi))
    for name, (text, unit) in INPUTS.items():
        v.append(Variable(name, REAL, INPUT, text, 0.0, unit))
    for k, (name, (text, unit, deps)) in enumerate(OUTPUTS.items()):
        v.append(Variable(name, REAL, OUTPUT, text, unit=unit, level=1, feedthrough=bool(deps), slot=k,
                          depends_on=tuple(deps)))
    defines = {f"SLOT_{n.upper()}": k for k, n in enumerate([*DATA, *SETUP, *EXTRA, *INPUTS])}
    return ModelSpec(identifier, "Permanent-magnet DC motor with gearbox, supply clamp, current limiter and winding "
                                 "thermal model; inputs terminal voltage and shaft speed, output shaft torque (rotor "
                                 "inertia excluded: it belongs to the mechanism as drive.inertia = "
                                 "reflected_inertia)",
                     tuple(v), "motor_model.c", defines, len(OUTPUTS), (), (), ("motor",), RUN_STATE)
