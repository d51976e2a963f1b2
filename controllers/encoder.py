"""Transducer between plant and controller: noise, encoder quantisation, delay, speed estimate.

At each sample ``k`` (period Ts) of the true position ``x_k``:

1. additive Gaussian noise: ``x_k + w_k``, ``w_k ~ N(0, noise_std^2)`` from a
   seeded generator (SplitMix64 and Box-Muller, in C), so a run is
   reproducible, the library and the Encoder FMU draw the same numbers, and a
   restored FMU state replays the same noise;
2. quantisation of an incremental encoder with ``counts_per_rev`` counts per
   revolution: ``floor(x / q) q`` with ``q = 2 pi / counts_per_rev`` (0: none);
3. a pure delay of ``delay`` samples (the first sample fills the history);
4. speed estimate by differencing the delayed counts: ``(m_k - m_{k-1}) / Ts``
   (0 at the first sample).

Any stage is off at its neutral value (``noise_std = 0``, ``counts_per_rev = 0``,
``delay = 0``).  The stages run in C (``controllers/kernel/ctl_encoder.c``), the
code the native Encoder.fmu compiles.

Examples
--------
>>> enc = Encoder(counts_per_rev=4, Ts=0.1)      # quarter turns: q = pi/2
>>> enc.update(0.0, {"position": 1.0})
{'measured_position': 0.0, 'measured_speed': 0.0}
>>> out = enc.update(0.1, {"position": 1.7})
>>> round(out["measured_position"], 12), round(out["measured_speed"], 12)
(1.570796326795, 15.707963267949)
"""

from __future__ import annotations

import ctypes
import math

import numpy as np

from grubler.errors import SceneError
from grubler.limits import brief

from grubler.controllers import native
from grubler.controllers.law import Law, Parameter, check_count, check_number

# the delay line holds delay + 1 readings: a million samples is 1000 s at 1 kHz
MAX_DELAY = 1_000_000


class Encoder(Law):
    """A position sensor: seeded noise, quantisation, delay and a differencing speed estimate.

    Parameters
    ----------
    counts_per_rev : int
        Encoder counts per revolution, 0 for no quantisation.
    noise_std : float
        Standard deviation of the additive Gaussian noise, rad.
    seed : int
        Seed of the noise generator.
    delay : int
        Pure delay, samples (at most ``MAX_DELAY``).
    Ts : float
        Sample time, s.

    Examples
    --------
    >>> import math
    >>> from grubler.controllers import Encoder
    >>> enc = Encoder(counts_per_rev=1024, Ts=1e-3)
    >>> first = enc.update(0.0, {"position": 0.01})
    >>> round(first["measured_position"] / (2 * math.pi / 1024), 6)         # one count
    1.0
    >>> round(enc.update(1e-3, {"position": 0.02})["measured_speed"], 3)    # two counts in 1 ms, rad/s
    12.272
    """

    inputs = {"position": "true position [rad]"}
    outputs = {"measured_position": "measured position [rad]",
               "measured_speed": "speed estimated by differencing the measured position [rad/s]"}
    parameters = {
        "counts_per_rev": Parameter(0, "encoder counts per revolution, 0 for no quantisation [1]"),
        "noise_std": Parameter(0.0, "standard deviation of the additive Gaussian noise [rad]"),
        "seed": Parameter(0, "seed of the noise generator [1]"),
        "delay": Parameter(0, "pure delay in samples [1]"),
        "Ts": Parameter(1e-3, "sample time [s]"),
    }

    def __init__(self, counts_per_rev: int = 0, noise_std: float = 0.0, seed: int = 0, delay: int = 0,
                 Ts: float = 1e-3):
        for name, value in (("counts_per_rev", counts_per_rev), ("seed", seed)):
            if isinstance(value, bool) or int(value) != value or value < 0:
                raise SceneError(name, f"must be a whole number >= 0, got {value!r}")
        self.counts_per_rev = int(counts_per_rev)
        self.noise_std = check_number(noise_std, "noise_std")
        self.seed = int(seed)
        self.delay = check_count(delay, "delay", MAX_DELAY)
        self.Ts = check_number(Ts, "Ts")
        self._params = native.EncoderParams(self.counts_per_rev, self.noise_std, self.seed, self.delay, self.Ts)
        native.refuse_bad("encoder", self._params, float(MAX_DELAY + 1))
        self._position, self._speed = ctypes.c_double(), ctypes.c_double()
        self.reset()

    @property
    def resolution(self) -> float:
        """One count, rad (0 without quantisation)."""
        return 2 * math.pi / self.counts_per_rev if self.counts_per_rev else 0.0

    def reset(self) -> None:
        """Back to the start: the noise generator seeded again, the delay line empty."""
        self._state = native.EncoderState()
        self._history = np.zeros(self.delay + 1)
        native.call("ctl_encoder_reset", self._params, self._state)

    def measure(self, x: float) -> float:
        """Noise and quantisation of one reading (advances the noise generator)."""
        native.call("ctl_encoder_measure", self._params, self._state, x, self._position)
        return self._position.value

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        native.call("ctl_encoder_sample", self._params, self._state, self._history.ctypes.data_as(native.DOUBLES),
                    inputs["position"], self._position, self._speed)
        return {"measured_position": self._position.value, "measured_speed": self._speed.value}

    def get_state(self) -> dict:
        """The delay line, the last reading, the generator's state and whether a sample ran."""
        s = self._state
        return {"started": s.started, "last": s.last, "rng": [s.rng.hi, s.rng.lo], "head": s.head,
                "history": self._history.tolist()}

    def set_state(self, state: dict) -> None:
        keys = ["head", "history", "last", "rng", "started"]
        if not isinstance(state, dict) or sorted(state) != keys or len(state["history"]) != self.delay + 1 \
                or len(state["rng"]) != 2:
            raise ValueError(f"a state of another law: {brief(repr(state))}")
        s = native.EncoderState(float(state["started"]), float(state["last"]), native.Rng(*map(float, state["rng"])),
                                float(state["head"]))
        history = np.array(state["history"], dtype=float)
        bad = native.check("encoder", self._params, s, history.ctypes.data_as(native.DOUBLES), state=True)
        if bad:
            raise ValueError(f"state.{bad[0]}: {bad[1]}")
        self._state, self._history = s, history


__all__ = ["Encoder"]
