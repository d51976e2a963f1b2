"""Native FMUs of the shipped control laws: PID, cascade, encoder, tachometer, current sensor, trajectory.

Each is the law's C (``controllers/kernel``) behind a law file
(``grubler/fmi/c/pid_law.c``, ``cascade_law.c``, ...), the generic sampled-law model
(``law_model.c``: the sample-and-hold clock of :mod:`grubler.controllers.law`)
and the one FMI wrapper every native grubler FMU uses: no Python at run time.
The variables are the law's own declaration (its ``inputs``, ``outputs`` and
``parameters``), in the order of the C structures, so the library's class, its
pythonfmu FMU (:func:`grubler.controllers.fmu.build_controller_fmu`) and its
native FMU show the same names, units and defaults.

Examples
--------
>>> spec = pid_spec()
>>> [v.name for v in spec.variables if v.causality == "input"]
['setpoint', 'measurement', 'feedforward']
>>> spec.variables[spec.vr("anti_windup") - 1].choices
('back-calculation', 'conditional', 'none')
"""

from __future__ import annotations

import ctypes
import re
from pathlib import Path

from grubler.controllers import native
from grubler.controllers.cascade import CascadeController
from grubler.controllers.encoder import Encoder
from grubler.controllers.law import Law
from grubler.controllers.pid import ANTI_WINDUP, PID
from grubler.controllers.sensors import AnalogSensor, CurrentSensor, Tachometer
from grubler.controllers.trajectory import KINDS, Trajectory
from grubler.fmi.build import build_fmu
from grubler.fmi.variables import BOOLEAN, INPUT, INTEGER, OUTPUT, PARAMETER, REAL, STRING, UNITS, ModelSpec, Variable

# readings the Encoder FMU's delay line holds (its state grows with it: 80 kB):
# a delay of up to 9999 samples, 10 s at 1 kHz
ENCODER_CAPACITY = 10_000
INT_MAX = 2**31 - 1


def _unit(description: str) -> str | None:
    """The FMI unit of a description ending in ``[unit]`` (None for ``[any]`` and units FMI is not told)."""
    m = re.search(r"\[([^\]]*)\]\s*$", description)
    unit = m[1].replace(" ", ".") if m else None
    return unit if unit in UNITS else None


def _type(value) -> str:
    for py, fmi in ((bool, BOOLEAN), (int, INTEGER), (float, REAL), (str, STRING)):
        if isinstance(value, py):
            return fmi
    raise TypeError(f"parameter default {value!r}: an FMU parameter is a float, int, bool or str")


def law_spec(law: type[Law], identifier: str, model_source: str, n_state: int, n_scratch: int = 0,
             choices: dict | None = None, bounds: dict | None = None, leave_out: tuple[str, ...] = (),
             extra: tuple[Variable, ...] = (), defines: dict | None = None) -> ModelSpec:
    """The ModelSpec of a native law FMU from the law's declaration.

    Parameters
    ----------
    law : type
        The :class:`Law` whose ``parameters`` (in the order of its C
        structure), ``inputs`` and ``outputs`` the FMU shows.
    identifier, model_source : str
        The modelIdentifier and the law file in ``grubler/fmi/c`` (law.h).
    n_state, n_scratch : int
        Doubles of the law's saved state and of its derived constants.
    choices : dict, optional
        A String parameter's accepted values (stored as the index, the C enum).
    bounds : dict, optional
        An Integer parameter's (min, max).
    leave_out : tuple of str
        Parameters the native FMU does not show.
    extra : tuple of Variable
        Parameters after the law's (a table's points).
    """
    choices, bounds = choices or {}, bounds or {}
    v = []
    for name, par in law.parameters.items():
        if name in leave_out:
            continue
        kind = _type(par.fmu_start)
        lo, hi = bounds.get(name, (None, None))
        unit = _unit(par.description) if kind == REAL else None  # FMI gives units to Reals only
        v.append(Variable(name, kind, PARAMETER, par.description, par.fmu_start, unit, lo, hi,
                          choices=tuple(choices.get(name, ()))))
    v += list(extra)
    n_params = len(v)
    for name, text in law.inputs.items():
        v.append(Variable(name, REAL, INPUT, text, 0.0, _unit(text)))
    for k, (name, text) in enumerate(law.outputs.items()):
        v.append(Variable(name, REAL, OUTPUT, text, unit=_unit(text), level=1, slot=k))
    state = (("started", 1), ("t0", 1), ("t", 1), ("samples", 1), ("out", len(law.outputs)), ("law", n_state),
             ("end", 0))
    lines = (law.__doc__ or law.__name__).strip().splitlines()
    # the clock: a law of time alone, or the parameter that holds the sample time
    clock = {"LAW_CONTINUOUS": 1} if law.continuous else {"LAW_CONTINUOUS": 0,
                                                          "LAW_TS_SLOT": [x.name for x in v].index("Ts")}
    return ModelSpec(identifier, lines[0].rstrip("."), tuple(v), model_source,
                     {"LAW_N_PARAMS": n_params, "LAW_N_INPUTS": len(law.inputs), "LAW_N_STATE": n_state,
                      "LAW_N_SCRATCH": n_scratch, **clock, **(defines or {})},
                     len(law.outputs), (), (), ("controllers", "law"), state)


def pid_spec(identifier: str = "PID") -> ModelSpec:
    """PID.fmu: :class:`~grubler.controllers.pid.PID` over ``ctl_pid.c``."""
    return law_spec(PID, identifier, "pid_law.c", ctypes.sizeof(native.PidState) // 8,
                    choices={"anti_windup": ANTI_WINDUP})


def cascade_spec(identifier: str = "CascadeController") -> ModelSpec:
    """CascadeController.fmu: :class:`~grubler.controllers.cascade.CascadeController` over ``ctl_cascade.c``."""
    return law_spec(CascadeController, identifier, "cascade_law.c", ctypes.sizeof(native.CascadeState) // 8)


def encoder_spec(identifier: str = "Encoder") -> ModelSpec:
    """Encoder.fmu: :class:`~grubler.controllers.encoder.Encoder` over ``ctl_encoder.c``."""
    return law_spec(Encoder, identifier, "encoder_law.c", ctypes.sizeof(native.EncoderState) // 8 + ENCODER_CAPACITY,
                    bounds={"counts_per_rev": (0, INT_MAX), "seed": (0, INT_MAX), "delay": (0, ENCODER_CAPACITY - 1)},
                    defines={"ENCODER_CAPACITY": ENCODER_CAPACITY})


def sensor_spec(law: type[AnalogSensor], identifier: str | None = None) -> ModelSpec:
    """Tachometer.fmu or CurrentSensor.fmu: an :class:`~grubler.controllers.sensors.AnalogSensor` over ``ctl_sensor.c``."""
    return law_spec(law, identifier or law.__name__, "sensor_law.c", ctypes.sizeof(native.SensorState) // 8,
                    bounds={"seed": (0, INT_MAX)})


def trajectory_spec(identifier: str = "Trajectory", times=None, positions=None) -> ModelSpec:
    """Trajectory.fmu: :class:`~grubler.controllers.trajectory.Trajectory` over ``ctl_trajectory.c``.

    Without ``times`` the kinds are constant, trapezoid, scurve and sine; with
    them the FMU serves 'table' too, its points parameters ``times[k]`` and
    ``positions[k]`` (k from 1) starting at these values.
    """
    n = 0 if times is None else len(times)
    extra = ()
    if n:
        extra = tuple(Variable(f"times[{k + 1}]", REAL, PARAMETER, "table: time of a point [s]", float(x), "s")
                      for k, x in enumerate(times))
        extra += tuple(Variable(f"positions[{k + 1}]", REAL, PARAMETER, "table: position at that time [rad]",
                                float(x), "rad") for k, x in enumerate(positions))
    plan = (ctypes.sizeof(native.Move) + 7) // 8
    return law_spec(Trajectory, identifier, "trajectory_law.c", 0, plan + 2 * n,
                    choices={"kind": KINDS if n else KINDS[:-1]}, bounds={"repeat": (0, INT_MAX)},
                    leave_out=("times", "positions"), extra=extra, defines={"TRAJECTORY_POINTS": n})


SPECS = {"PID": pid_spec, "CascadeController": cascade_spec, "Encoder": encoder_spec,
         "Tachometer": lambda: sensor_spec(Tachometer), "CurrentSensor": lambda: sensor_spec(CurrentSensor),
         "Trajectory": trajectory_spec}


def build_native_law(name: str, dest: str | Path) -> Path:
    """Build the native FMU of a shipped law (a key of :data:`SPECS`) at ``dest``."""
    dest = Path(dest)
    target = dest if dest.suffix == ".fmu" else dest / f"{name}.fmu"
    return build_fmu(SPECS[name](), target)


__all__ = ["ENCODER_CAPACITY", "SPECS", "build_native_law", "cascade_spec", "encoder_spec", "law_spec", "pid_spec", "sensor_spec",
           "trajectory_spec"]
