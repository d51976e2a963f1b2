"""The winding's temperature over a periodic current: the one-node thermal model in its periodic steady state.

A motor's winding heats with i² R(T) (its resistance rising with temperature)
and cools through its thermal resistance to ambient; over endlessly repeated
duty cycles the temperature settles into a periodic steady state, solved here
exactly cycle by cycle.  Sizing judges the peak of it against the allowed rise.

Examples
--------
>>> import numpy as np
>>> from grubler.motors import load_motor
>>> data = load_motor("maxon-re40-148877")
>>> t = np.linspace(0.0, 1.0, 101)
>>> rise = periodic_temperature(t, np.full_like(t, 1.0), data, 25.0) - 25.0
>>> bool(0.0 < rise.min() <= rise.max())
True
"""

from __future__ import annotations

import math

import numpy as np

def periodic_temperature(t: np.ndarray, current: np.ndarray, data, ambient: float) -> np.ndarray:
    """Winding temperature over a cycle repeated forever (one node, R(T) included).

    ``C dT/dt = i² R_ref (1 + alpha (T - T_ref)) - (T - T_amb) / R_th`` is linear
    in T, so each sample interval maps T affinely and the whole cycle too:
    ``T_end = A T_0 + B``; the periodic state is ``T_0 = B / (1 - A)``.

    Examples
    --------
    >>> import numpy as np
    >>> from grubler.motors import load_motor
    >>> from grubler.studies.sizing import periodic_temperature
    >>> motor = load_motor("maxon-re40-148877")
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> T = periodic_temperature(t, np.full(11, 2.0), motor, ambient=25.0)    # 2 A for ever
    >>> round(float(T[0]), 2), bool(np.allclose(T, T[0]))                     # steady: degC, the same all cycle
    (59.66, True)
    """
    R_th, C = data.thermal_resistance, data.thermal_capacity
    alpha, R_ref, T_ref = data.temperature_coefficient, data.resistance, data.reference_temperature
    i2 = current**2
    i2_mid = 0.5 * (i2[1:] + i2[:-1])
    a = i2_mid * R_ref * alpha / C - 1.0 / (R_th * C)
    b = i2_mid * R_ref * (1.0 - alpha * T_ref) / C + ambient / (R_th * C)
    h = np.diff(t)
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is the runaway, tested below
        e = np.exp(a * h)
        gain = np.where(np.abs(a * h) > 1e-12, (e - 1.0) / np.where(a == 0, 1.0, a), h)
        A, B = 1.0, 0.0
        for ek, gk, bk in zip(e, gain, b):  # compose the affine maps
            A, B = ek * A, ek * B + gk * bk
    if not (math.isfinite(A) and math.isfinite(B)) or A >= 1.0:
        return np.full_like(t, np.inf)  # the copper heats faster than it cools: runaway
    temps = np.empty_like(t)
    temps[0] = B / (1.0 - A)
    with np.errstate(over="ignore", invalid="ignore"):  # a peak past the doubles is inf: not feasible
        for k in range(len(h)):
            temps[k + 1] = e[k] * temps[k] + gain[k] * b[k]
    return temps


__all__ = ["periodic_temperature"]
