"""ctypes declarations of the control laws' C (``controllers/kernel/ctl_*.h``).

The laws' equations exist once, in C: :class:`~grubler.controllers.law.Sampler`,
:class:`~grubler.controllers.pid.PID`, :class:`~grubler.controllers.encoder.Encoder`
and :class:`~grubler.controllers.trajectory.Trajectory` call them through the
functions declared here, on the library handle of :func:`grubler.binding.library`
(the compiled ``grubler._kernel``), and the native FMUs compile the same
sources.  The structures mirror the headers field for field, in the FMUs'
parameter order: a field added there must be added here, in the same place.

Examples
--------
>>> p = PidParams(K=2.0, Ti=0.5, Td=0.0, N=10.0, b=1.0, c=1.0, Ts=0.01, u_min=-1e300, u_max=1e300,
...               anti_windup=0.0, Tt=0.0)
>>> check("pid", p) is None
True
>>> p.Ts = 0.0
>>> check("pid", p)
('Ts', 'sample time must be finite and > 0')
"""

from __future__ import annotations

import ctypes
import functools

from grubler.binding import library
from grubler.errors import SceneError
from grubler.limits import brief

# enum ctl_status, in ctl_law.h's order
(OK, BAD_PARAMETER, BAD_STATE, BAD_INPUT, BAD_STEP_SIZE, TOO_MANY_SAMPLES, NOT_FINITE, BAD_ARGUMENT,
 LAW_REFUSED, MECHANISM_REFUSED) = range(10)

_D = ctypes.c_double


def _doubles(*names: str) -> list:
    return [(name, _D) for name in names]


class Clock(ctypes.Structure):
    """struct ctl_clock: when a law samples."""

    _fields_ = [("t0", _D), ("Ts", _D), ("continuous", ctypes.c_int)]


class Rng(ctypes.Structure):
    """struct ctl_rng: the noise generator's 64-bit state as two 32-bit halves."""

    _fields_ = _doubles("hi", "lo")


class PidParams(ctypes.Structure):
    """struct ctl_pid_params (anti_windup: the index in :data:`grubler.controllers.pid.ANTI_WINDUP`)."""

    _fields_ = _doubles("K", "Ti", "Td", "N", "b", "c", "Ts", "u_min", "u_max", "anti_windup", "Tt")


class PidState(ctypes.Structure):
    """struct ctl_pid_state."""

    _fields_ = _doubles("I", "D", "ed_prev", "started")


class CascadeParams(ctypes.Structure):
    """struct ctl_cascade_params."""

    _fields_ = _doubles("K_position", "Ti_position", "K_speed", "Ti_speed", "velocity_feedforward", "speed_limit",
                        "u_min", "u_max", "Tt_speed", "Ts", "K_current", "Ti_current", "current_limit")


class CascadeState(ctypes.Structure):
    """struct ctl_cascade_state: the loops' states and the last speed and current setpoints."""

    _fields_ = [("position_loop", PidState), ("speed_loop", PidState), ("speed_setpoint", _D),
                ("current_loop", PidState), ("current_setpoint", _D)]


class EncoderParams(ctypes.Structure):
    """struct ctl_encoder_params."""

    _fields_ = _doubles("counts_per_rev", "noise_std", "seed", "delay", "Ts")


class EncoderState(ctypes.Structure):
    """struct ctl_encoder_state (the delay line is a separate buffer)."""

    _fields_ = [("started", _D), ("last", _D), ("rng", Rng), ("head", _D)]


class SensorParams(ctypes.Structure):
    """struct ctl_sensor_params."""

    _fields_ = _doubles("gain_error", "offset", "noise_std", "seed", "bandwidth", "Ts")


class SensorState(ctypes.Structure):
    """struct ctl_sensor_state."""

    _fields_ = [("started", _D), ("filtered", _D), ("rng", Rng)]


class TrajectoryParams(ctypes.Structure):
    """struct ctl_trajectory_params (kind: the index in :data:`grubler.controllers.trajectory.KINDS`)."""

    _fields_ = _doubles("kind", "start", "delay", "speed", "distance", "v_max", "a_max", "j_max", "dwell", "repeat",
                        "reverse", "amplitude", "frequency")


class Segment(ctypes.Structure):
    """struct ctl_segment: constant jerk from (p0, v0, a0) over duration."""

    _fields_ = _doubles("t0", "duration", "p0", "v0", "a0", "jerk")


class Move(ctypes.Structure):
    """struct ctl_move: a move's segments."""

    _fields_ = [("n", ctypes.c_int), ("seg", Segment * 7), ("move_time", _D)]


_DP = DOUBLES = ctypes.POINTER(_D)  # a numpy buffer: arr.ctypes.data_as(DOUBLES)


class Table(ctypes.Structure):
    """struct ctl_table: a recorded profile and its spline's second derivatives."""

    _fields_ = [("n", ctypes.c_long), ("times", _DP), ("positions", _DP), ("second", _DP)]


_I, _IP, _SP = ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_char_p)
_R = ctypes.c_void_p  # a struct's address (byref)
_SIGNATURES = {
    "ctl_status_message": (ctypes.c_char_p, [_I]),
    "ctl_samples_due": (_I, [_R, _D, _D, _D, _DP]),
    "ctl_sample_instant": (_I, [_R, _D, _D, _D, _D, _DP]),
    "ctl_rng_seed": (_I, [_R, _D]),
    "ctl_rng_normal": (_I, [_R, _DP]),
    "ctl_pid_field_name": (ctypes.c_char_p, [_I]),
    "ctl_pid_check": (_I, [_R, _IP, _SP]),
    "ctl_pid_check_state": (_I, [_R, _R, _IP, _SP]),
    "ctl_pid_tracking_time": (_I, [_R, _DP]),
    "ctl_pid_reset": (_I, [_R, _D, _R]),
    "ctl_pid_sample": (_I, [_R, _R, _D, _D, _D, _DP]),
    "ctl_pid_initial_output": (_I, [_R, _DP]),
    "ctl_cascade_field_name": (ctypes.c_char_p, [_I]),
    "ctl_cascade_check": (_I, [_R, _IP, _SP]),
    "ctl_cascade_check_state": (_I, [_R, _R, _IP, _SP]),
    "ctl_cascade_reset": (_I, [_R, _R]),
    "ctl_cascade_sample": (_I, [_R, _R, _D, _D, _D, _D, _D, _DP]),
    "ctl_cascade_initial_output": (_I, [_R, _DP]),
    "ctl_encoder_field_name": (ctypes.c_char_p, [_I]),
    "ctl_encoder_check": (_I, [_R, _D, _IP, _SP]),
    "ctl_encoder_check_state": (_I, [_R, _R, _DP, _IP, _SP]),
    "ctl_encoder_reset": (_I, [_R, _R]),
    "ctl_encoder_measure": (_I, [_R, _R, _D, _DP]),
    "ctl_encoder_sample": (_I, [_R, _R, _DP, _D, _DP, _DP]),
    "ctl_linear_field_name": (ctypes.c_char_p, [_I]),
    "ctl_linear_check_state": (_I, [ctypes.c_long, _DP, _IP, _SP]),
    "ctl_linear_sample": (_I, [ctypes.c_long, _DP, _DP, _D, _D, _D, _DP, _DP]),
    "ctl_sensor_field_name": (ctypes.c_char_p, [_I]),
    "ctl_sensor_check": (_I, [_R, _IP, _SP]),
    "ctl_sensor_check_state": (_I, [_R, _R, _IP, _SP]),
    "ctl_sensor_reset": (_I, [_R, _R]),
    "ctl_sensor_sample": (_I, [_R, _R, _D, _DP]),
    "ctl_trajectory_field_name": (ctypes.c_char_p, [_I]),
    "ctl_trajectory_check": (_I, [_R, _R, _IP, _SP]),
    "ctl_move_phases": (_I, [_R, _DP, _IP]),
    "ctl_move_plan": (_I, [_R, _R]),
    "ctl_table_prepare": (_I, [_R, _DP]),
    "ctl_segment_at": (_I, [_R, _D, _DP]),
    "ctl_trajectory_evaluate": (_I, [_R, _R, _R, _D, _DP]),
}


@functools.lru_cache(maxsize=None)
def functions() -> ctypes.CDLL:
    """The kernel library with the control laws' signatures declared (once)."""
    lib = library()
    for name, (restype, argtypes) in _SIGNATURES.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    return lib


def message(status: int) -> str:
    """ctl_status_message: the C's sentence for a status."""
    return functions().ctl_status_message(status).decode()


def check(law: str, *args, state: bool = False) -> tuple[str, str] | None:
    """``(field, why)`` of the first field ``ctl_<law>_check`` (``_check_state``) refuses, or None.

    ``law`` is ``"pid"``, ``"encoder"`` or ``"trajectory"``; ``args`` the C
    function's arguments before ``field`` and ``why`` (structures by value).
    """
    lib = functions()
    field, why = ctypes.c_int(-1), ctypes.c_char_p()
    refs = [ctypes.byref(a) if isinstance(a, ctypes.Structure) else a for a in args]
    status = getattr(lib, f"ctl_{law}_check_state" if state else f"ctl_{law}_check")(
        *refs, ctypes.byref(field), ctypes.byref(why))
    if status == OK:
        return None
    if status not in (BAD_PARAMETER, BAD_STATE):
        raise RuntimeError(f"ctl_{law}: {message(status)}")
    name = getattr(lib, f"ctl_{law}_field_name")(field.value)
    return (name.decode() if name else "parameter"), why.value.decode()


def refuse_bad(law: str, params: ctypes.Structure, *args, shown: dict | None = None) -> None:
    """Raise SceneError naming the field ``ctl_<law>_check`` refuses, and the value given for it.

    ``shown`` maps a field to the value to quote (default: the structure's).
    """
    bad = check(law, params, *args)
    if bad is not None:
        field, why = bad
        value = (shown or {}).get(field, getattr(params, field, None))
        raise SceneError(field, why if value is None else f"{why}, got {value!r}")


def as_plain(s: ctypes.Structure) -> dict:
    """A structure of doubles (and nested structures) as a dict of floats, for a law's get_state."""
    return {name: as_plain(getattr(s, name)) if isinstance(getattr(s, name), ctypes.Structure) else getattr(s, name)
            for name, _ in s._fields_}


def _from_plain(kind: type, values) -> ctypes.Structure:
    if not isinstance(values, dict) or sorted(values) != sorted(n for n, _ in kind._fields_):
        raise ValueError(f"a state of another law: {brief(repr(values))}")
    return kind(**{name: _from_plain(t, values[name]) if issubclass(t, ctypes.Structure) else float(values[name])
                   for name, t in kind._fields_})


def checked_state(law: str, params: ctypes.Structure, kind: type, state, *buffers) -> ctypes.Structure:
    """The structure ``kind`` from a get_state dict, checked by ``ctl_<law>_check_state``; ValueError naming the field."""
    s = _from_plain(kind, state)
    bad = check(law, params, s, *buffers, state=True)
    if bad:
        raise ValueError(f"state.{bad[0]}: {bad[1]}")
    return s


def call(name: str, *args) -> None:
    """Call ``name`` (structures by reference); ValueError with the C's sentence when it refuses."""
    refs = [ctypes.byref(a) if isinstance(a, (ctypes.Structure, ctypes.c_double)) else a for a in args]
    status = getattr(functions(), name)(*refs)
    if status != OK:
        raise ValueError(f"{name}: {message(status)}")


__all__ = ["CascadeParams", "CascadeState", "Clock", "DOUBLES", "as_plain", "checked_state", "EncoderParams", "EncoderState", "Move", "PidParams", "PidState", "Rng", "Segment", "SensorParams", "SensorState", "Table",
           "TrajectoryParams", "call", "check", "functions", "message", "refuse_bad"]
