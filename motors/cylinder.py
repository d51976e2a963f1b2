"""What the hydraulic and the pneumatic cylinder share in Python: checked constants and a stepped run.

The models themselves are C (``motors/kernel/``): :mod:`grubler.motors.native`
declares them; this module checks a cylinder's constants through the C check
(so the library and the FMU refuse the same values with the same words) and
steps a run with held inputs, as a co-simulation master does.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import astuple, fields

from grubler.errors import IntegrationError, SceneError
from grubler.motors.native import CylinderBinding, CylinderInputs

OK = 0  # enum hyd_status / pnc_status


class Piston:
    """What either cylinder's constants say of its piston (``bore`` and ``rod`` fields, m)."""

    @property
    def areas(self) -> tuple[float, float]:
        """Cap-side and rod-side piston areas [m2] (as motors/kernel/cylinder.c computes them)."""
        return 0.25 * math.pi * self.bore ** 2, 0.25 * math.pi * (self.bore ** 2 - self.rod ** 2)


def check_constants(binding: CylinderBinding, constants) -> None:
    """Raise :class:`grubler.SceneError` naming the first field the C check refuses (a dataclass of numbers)."""
    for f in fields(constants):
        v = getattr(constants, f.name)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SceneError(f.name, f"must be a number, got {v!r}")
    field, why = ctypes.c_int(-1), ctypes.c_char_p()
    if binding.call("check_params", ctypes.byref(binding.params(*astuple(constants))), ctypes.byref(field),
                    ctypes.byref(why)) != OK:
        name = binding.call("field_name", field.value).decode()
        raise SceneError(name, f"{why.value.decode()} (got {getattr(constants, name):g})")


class CylinderRun:
    """One run of a cylinder model: its state, stepped with the inputs held over each step."""

    def __init__(self, binding: CylinderBinding, constants, state: tuple):
        self._binding = binding
        self._params = binding.params(*astuple(constants))
        self._state = binding.state(*state)
        field, why = ctypes.c_int(-1), ctypes.c_char_p()
        if binding.call("check_state", ctypes.byref(self._params), ctypes.byref(self._state), ctypes.byref(field),
                        ctypes.byref(why)) != OK:
            raise SceneError(binding.call("field_name", field.value).decode(), why.value.decode())

    def _message(self, status: int) -> str:
        return self._binding.call("status_message", status).decode()

    def _outputs(self, out) -> dict[str, float]:
        return {name: getattr(out, name) for name, _ in out._fields_}

    @property
    def state(self) -> dict[str, float]:
        """The state: spool, its rate, the pressures [Pa gauge] and the last sub-step [s]."""
        return {name: getattr(self._state, name) for name, _ in self._state._fields_}

    def step(self, command: float, length: float, rate: float, dt: float) -> dict[str, float]:
        """Advance by ``dt`` [s] with the inputs held (the length moving at ``rate``); the outputs at the end.

        Raises
        ------
        SceneError
            Naming the input that is not finite, or ``dt``.
        IntegrationError
            When the step size control gives up.
        """
        for name, v in (("command", command), ("length", length), ("rate", rate), ("dt", dt)):
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise SceneError(name, f"must be a finite number, got {v!r}")
        if dt <= 0:
            raise SceneError("dt", f"must be > 0 s, got {dt} s")
        out = self._binding.outputs()
        status = self._binding.call("step", ctypes.byref(self._params), ctypes.byref(self._state),
                                    ctypes.byref(CylinderInputs(command, length, rate)), float(dt), ctypes.byref(out))
        if status != OK:
            raise IntegrationError(self._message(status))
        return self._outputs(out)

    def observe(self, command: float, length: float, rate: float) -> dict[str, float]:
        """The outputs now, for these inputs."""
        out = self._binding.outputs()
        status = self._binding.call("observe", ctypes.byref(self._params), ctypes.byref(self._state),
                                    ctypes.byref(CylinderInputs(command, length, rate)), ctypes.byref(out))
        if status != OK:
            raise SceneError("inputs", self._message(status))
        return self._outputs(out)
