"""Transducer between plant and controller: noise, encoder quantisation, delay, speed estimate.

At each sample ``k`` (period Ts) of the true position ``x_k``:

1. additive Gaussian noise: ``x_k + w_k``, ``w_k ~ N(0, noise_std^2)`` from a
   seeded generator (numpy PCG64), so a run is reproducible and a restored FMU
   state replays the same noise;
2. quantisation of an incremental encoder with ``counts_per_rev`` counts per
   revolution: ``floor(x / q) q`` with ``q = 2 pi / counts_per_rev`` (0: none);
3. a pure delay of ``delay`` samples (the first sample fills the history);
4. speed estimate by differencing the delayed counts: ``(m_k - m_{k-1}) / Ts``
   (0 at the first sample).

Any stage is off at its neutral value (``noise_std = 0``, ``counts_per_rev = 0``,
``delay = 0``).

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

import math
from collections import deque

import numpy as np

from grubler.errors import SceneError

from grubler.controllers.law import Law, Parameter, check_count, check_number, check_sample_time

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
        self.noise_std = check_number(noise_std, "noise_std", low=0.0)
        self.seed = int(seed)
        self.delay = check_count(delay, "delay", MAX_DELAY)
        self.Ts = check_sample_time(Ts)
        self.reset()

    @property
    def resolution(self) -> float:
        """One count, rad (0 without quantisation)."""
        return 2 * math.pi / self.counts_per_rev if self.counts_per_rev else 0.0

    def reset(self) -> None:
        self.rng = np.random.Generator(np.random.PCG64(self.seed))
        self.history: deque[float] = deque(maxlen=self.delay + 1)
        self.last: float | None = None

    def measure(self, x: float) -> float:
        """Noise and quantisation of one reading (advances the noise generator)."""
        if self.noise_std > 0:
            x = x + self.noise_std * float(self.rng.standard_normal())
        q = self.resolution
        return math.floor(x / q) * q if q else x

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        m = self.measure(inputs["position"])
        if not self.history:
            self.history.extend([m] * self.delay)
        self.history.append(m)
        out = self.history[0]
        speed = 0.0 if self.last is None else (out - self.last) / self.Ts
        self.last = out
        return {"measured_position": out, "measured_speed": speed}


__all__ = ["Encoder"]
