"""Analog sensors between plant and controller: a tachometer and a current sensor.

At each sample ``k`` (period Ts) of the true value ``x_k``:

1. gain error: ``(1 + gain_error) x_k``;
2. a first-order response of ``bandwidth`` Hz (its -3 dB frequency), sampled
   exactly for an input that steps just after a sample: ``y_k = a y_{k-1} +
   (1 - a) (1 + gain_error) x_k`` with ``a = exp(-2 pi bandwidth Ts)`` (0: none,
   the reading follows at once); the first sample starts settled;
3. offset and additive Gaussian noise: ``y_k + offset + w_k``,
   ``w_k ~ N(0, noise_std^2)`` from the seeded generator the encoder uses
   (SplitMix64 and Box-Muller, in C), so the library and the FMU draw the same
   numbers and a restored FMU state replays them.

The stages run in C (``controllers/kernel/ctl_sensor.c``), the code the native
Tachometer.fmu and CurrentSensor.fmu compile.

Examples
--------
>>> tacho = Tachometer(gain_error=0.02, offset=0.5, Ts=1e-3)
>>> tacho.update(0.0, {"speed": 10.0})                 # 1.02 x 10 + 0.5
{'measured_speed': 10.7}
>>> slow = CurrentSensor(bandwidth=100.0, Ts=1e-3)
>>> slow.update(0.0, {"current": 0.0})["measured_current"], round(slow.update(1e-3, {"current": 1.0})["measured_current"], 6)
(0.0, 0.466512)
"""

from __future__ import annotations

import ctypes
from typing import ClassVar

from grubler.errors import SceneError

from grubler.controllers import native
from grubler.controllers.law import Law, Parameter, check_number


def _parameters(unit: str) -> dict[str, Parameter]:
    return {
        "gain_error": Parameter(0.0, "relative gain error: it reads (1 + gain_error) x [1]"),
        "offset": Parameter(0.0, f"offset added to the reading [{unit}]"),
        "noise_std": Parameter(0.0, f"standard deviation of the additive Gaussian noise [{unit}]"),
        "seed": Parameter(0, "seed of the noise generator [1]"),
        "bandwidth": Parameter(0.0, "-3 dB frequency of the first-order response, 0 for none [Hz]"),
        "Ts": Parameter(1e-3, "sample time [s]"),
    }


class AnalogSensor(Law):
    """A sampled analog sensor: gain error, first-order bandwidth, offset and seeded noise.

    Subclasses name the measured quantity (``quantity``, ``unit``).

    Parameters
    ----------
    gain_error : float
        Relative gain error (> -1): it reads ``(1 + gain_error) x``.
    offset : float
        Added to the reading, in the quantity's unit.
    noise_std : float
        Standard deviation of the additive Gaussian noise, in the quantity's unit.
    seed : int
        Seed of the noise generator.
    bandwidth : float
        -3 dB frequency of the first-order response, Hz; 0 for none.
    Ts : float
        Sample time, s.
    """

    quantity: ClassVar[str] = "value"

    def __init__(self, gain_error: float = 0.0, offset: float = 0.0, noise_std: float = 0.0, seed: int = 0,
                 bandwidth: float = 0.0, Ts: float = 1e-3):
        if isinstance(seed, bool) or int(seed) != seed or seed < 0:
            raise SceneError("seed", f"must be a whole number >= 0, got {seed!r}")
        given = {"gain_error": gain_error, "offset": offset, "noise_std": noise_std, "bandwidth": bandwidth,
                 "Ts": Ts}
        values = {name: check_number(v, name) for name, v in given.items()}  # numbers; the C judges their range
        self._params = native.SensorParams(**values, seed=int(seed))
        native.refuse_bad("sensor", self._params)
        for name, v in values.items():
            setattr(self, name, v)
        self.seed = int(seed)
        self._measured = ctypes.c_double()
        self.reset()

    def reset(self) -> None:
        """Back to the start: the noise generator seeded again, the response at rest."""
        self._state = native.SensorState()
        native.call("ctl_sensor_reset", self._params, self._state)

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        native.call("ctl_sensor_sample", self._params, self._state, inputs[self.quantity], self._measured)
        return {f"measured_{self.quantity}": self._measured.value}

    def get_state(self) -> dict:
        """Whether a sample ran, the response's output and the generator's state."""
        return native.as_plain(self._state)

    def set_state(self, state: dict) -> None:
        self._state = native.checked_state("sensor", self._params, native.SensorState, state)


class Tachometer(AnalogSensor):
    """A speed sensor (tachogenerator or resolver speed): gain error, bandwidth, offset, noise.

    Examples
    --------
    >>> from grubler.controllers import Tachometer
    >>> Tachometer(gain_error=0.01, Ts=1e-3).update(0.0, {"speed": 100.0})   # reads 1 % high
    {'measured_speed': 101.0}
    """

    quantity = "speed"
    inputs = {"speed": "true speed [rad/s]"}
    outputs = {"measured_speed": "measured speed [rad/s]"}
    parameters = _parameters("rad/s")


class CurrentSensor(AnalogSensor):
    """A current sensor (shunt or Hall): gain error, bandwidth, offset, noise.

    Examples
    --------
    >>> from grubler.controllers import CurrentSensor
    >>> CurrentSensor(offset=0.05, Ts=1e-3).update(0.0, {"current": 2.0})   # 50 mA offset
    {'measured_current': 2.05}
    """

    quantity = "current"
    inputs = {"current": "true current [A]"}
    outputs = {"measured_current": "measured current [A]"}
    parameters = _parameters("A")


__all__ = ["AnalogSensor", "CurrentSensor", "Tachometer"]
