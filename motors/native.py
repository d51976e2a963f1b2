"""ctypes declarations of the drives' C models (``motors/kernel/dc_motor.h``, ``hydraulic_cylinder.h``).

The motor's equations exist once, in C; :mod:`grubler.motors.dc_motor` calls
them through the functions declared here, on the library handle of
:func:`grubler.binding.library` (the compiled ``grubler._kernel``), and the
native DCMotor.fmu compiles the same source.  The structures mirror the header's
field for field: a field added there must be added here, in the same place.
"""

from __future__ import annotations

import ctypes
import functools
from dataclasses import dataclass

from grubler.binding import library

# enum dcm_status, in the header's order
OK, BAD_PARAMETER, BAD_STATE, BAD_VOLTAGE, BAD_SHAFT_SPEED, BAD_STEP_SIZE, RESISTANCE_VANISHED, BAD_ARGUMENT = range(8)


class Params(ctypes.Structure):
    """struct dcm_params: the constants of a step (SI units, degC)."""

    _fields_ = [(name, ctypes.c_double) for name in (
        "resistance", "inductance", "torque_constant", "back_emf_constant", "rotor_inertia",
        "viscous_friction", "coulomb_friction", "smoothing_speed", "thermal_resistance",
        "thermal_time_constant", "temperature_coefficient", "reference_temperature", "gear_ratio",
        "gear_efficiency", "supply_voltage", "current_limit", "ambient_temperature", "max_substep")]


class State(ctypes.Structure):
    """struct dcm_state: winding current [A] and temperature [degC]."""

    _fields_ = [("current", ctypes.c_double), ("temperature", ctypes.c_double)]


class Outputs(ctypes.Structure):
    """struct dcm_outputs, in :class:`grubler.motors.dc_motor.MotorOutputs`' field order."""

    _fields_ = [(name, ctypes.c_double) for name in (
        "shaft_torque", "current", "winding_temperature", "electrical_power", "motor_speed", "back_emf",
        "terminal_voltage")]


_P, _S, _O = ctypes.POINTER(Params), ctypes.POINTER(State), ctypes.POINTER(Outputs)
_D, _DP, _I = ctypes.c_double, ctypes.POINTER(ctypes.c_double), ctypes.c_int
_SIGNATURES = {
    "dcm_field_name": (ctypes.c_char_p, [_I]),
    "dcm_status_message": (ctypes.c_char_p, [_I]),
    "dcm_check_params": (_I, [_P, ctypes.POINTER(_I), ctypes.POINTER(ctypes.c_char_p)]),
    "dcm_check_state": (_I, [_P, _S, ctypes.POINTER(_I), ctypes.POINTER(ctypes.c_char_p)]),
    "dcm_step": (_I, [_P, _S, _D, _D, _D, _O]),
    "dcm_observe": (_I, [_P, _S, _D, _D, _O]),
    "dcm_shaft_torque": (_I, [_P, _D, _D, _DP]),
    "dcm_current_for_torque": (_I, [_P, ctypes.c_long, _DP, _DP, _DP]),
    "dcm_linearize": (_I, [_P, _S, _D, _DP]),
    "dcm_reflected_inertia": (_I, [_P, _DP]),
    "dcm_chatter_free_step": (_I, [_P, _DP]),
}


def _declared(signatures: dict) -> ctypes.CDLL:
    """The kernel library with these functions' result and argument types declared."""
    lib = library()
    for name, (restype, argtypes) in signatures.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    return lib


@functools.lru_cache(maxsize=None)
def functions() -> ctypes.CDLL:
    """The kernel library with the motor functions' signatures declared (once)."""
    return _declared(_SIGNATURES)


def check(kind, p: Params, state: State | None = None) -> tuple[str, str] | None:
    """``(field, why)`` of the first field the C model refuses, or None.

    `kind` is ``"params"`` (dcm_check_params) or ``"state"`` (dcm_check_state).
    """
    lib = functions()
    field, why = ctypes.c_int(-1), ctypes.c_char_p()
    if kind == "params":
        status = lib.dcm_check_params(ctypes.byref(p), ctypes.byref(field), ctypes.byref(why))
    else:
        status = lib.dcm_check_state(ctypes.byref(p), ctypes.byref(state), ctypes.byref(field), ctypes.byref(why))
    if status == OK:
        return None
    if status not in (BAD_PARAMETER, BAD_STATE):
        raise RuntimeError(f"dc_motor: {message(status)}")
    return lib.dcm_field_name(field.value).decode(), why.value.decode()


def message(status: int) -> str:
    """dcm_status_message: the C model's sentence for a status."""
    return functions().dcm_status_message(status).decode()


# -- the cylinders (motors/kernel/cylinder.h, hydraulic_cylinder.h, pneumatic_cylinder.h) ---
# struct cyl_piston: the first fields of either cylinder's parameters
PISTON_FIELDS = ("bore", "rod", "stroke", "retracted_length", "dead_volume_a", "dead_volume_b", "viscous_friction",
                 "coulomb_friction", "smoothing_speed", "stop_stiffness", "stop_damping")


class HydParams(ctypes.Structure):
    """struct hyd_params, field for field (grubler.motors.hydraulic.FIELDS describes them)."""

    _fields_ = [(name, ctypes.c_double) for name in (
        *PISTON_FIELDS, "bulk_modulus", "air_fraction", "leakage", "nominal_flow", "nominal_pressure_drop",
        "valve_frequency", "valve_damping", "overlap", "valve_leakage", "transition_pressure", "pump_flow",
        "relief_pressure", "relief_gradient", "supply_volume", "tank_pressure", "tolerance")]


class HydState(ctypes.Structure):
    """struct hyd_state: spool, its rate, the three pressures [Pa gauge], the last sub-step [s]."""

    _fields_ = [(name, ctypes.c_double) for name in (
        "spool", "spool_rate", "pressure_a", "pressure_b", "supply_pressure", "substep")]


class CylinderInputs(ctypes.Structure):
    """struct hyd_inputs and pnc_inputs: valve command, actuator length [m] and rate [m/s]."""

    _fields_ = [(name, ctypes.c_double) for name in ("command", "length", "rate")]


class HydOutputs(ctypes.Structure):
    """struct hyd_outputs."""

    _fields_ = [(name, ctypes.c_double) for name in (
        "force", "pressure_a", "pressure_b", "supply_pressure", "flow_a", "flow_b", "relief_flow", "position",
        "spool", "pump_power", "piston_power", "mechanical_power", "throttling_loss", "compression_power")]


class PncParams(ctypes.Structure):
    """struct pnc_params, field for field (grubler.motors.pneumatic.FIELDS describes them)."""

    _fields_ = [(name, ctypes.c_double) for name in (
        *PISTON_FIELDS, "leakage", "sonic_conductance", "critical_pressure_ratio", "laminar_ratio",
        "valve_frequency", "valve_damping", "overlap", "supply_pressure", "exhaust_pressure", "supply_temperature",
        "polytropic_exponent", "tolerance")]


class PncState(ctypes.Structure):
    """struct pnc_state: spool, its rate, the two pressures [Pa gauge], the last sub-step [s]."""

    _fields_ = [(name, ctypes.c_double) for name in ("spool", "spool_rate", "pressure_a", "pressure_b", "substep")]


class PncOutputs(ctypes.Structure):
    """struct pnc_outputs."""

    _fields_ = [(name, ctypes.c_double) for name in (
        "force", "pressure_a", "pressure_b", "mass_flow_a", "mass_flow_b", "air_consumption", "position", "spool",
        "mechanical_power")]


@dataclass(frozen=True)
class CylinderBinding:
    """One cylinder model's C functions (``<prefix>_check_params``, ``_step``, ...) and structures."""

    prefix: str
    params: type
    state: type
    outputs: type

    def functions(self) -> ctypes.CDLL:
        """The kernel library with this model's signatures declared (once)."""
        return _cylinder_functions(self)

    def call(self, name: str, *args):
        return getattr(self.functions(), f"{self.prefix}_{name}")(*args)


@functools.lru_cache(maxsize=None)
def _cylinder_functions(b: CylinderBinding) -> ctypes.CDLL:
    P, S, In, O = (ctypes.POINTER(t) for t in (b.params, b.state, CylinderInputs, b.outputs))
    return _declared({f"{b.prefix}_{name}": sig for name, sig in {
        "field_name": (ctypes.c_char_p, [_I]),
        "status_message": (ctypes.c_char_p, [_I]),
        "check_params": (_I, [P, ctypes.POINTER(_I), ctypes.POINTER(ctypes.c_char_p)]),
        "check_state": (_I, [P, S, ctypes.POINTER(_I), ctypes.POINTER(ctypes.c_char_p)]),
        "step": (_I, [P, S, In, _D, O]),
        "observe": (_I, [P, S, In, O]),
        "derivatives": (_I, [P, S, In, _DP]),
    }.items()})


HYDRAULIC = CylinderBinding("hyd", HydParams, HydState, HydOutputs)
PNEUMATIC = CylinderBinding("pnc", PncParams, PncState, PncOutputs)
