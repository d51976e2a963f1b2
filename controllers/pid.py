"""Discrete PID controller in the practitioner's form (Åström and Hägglund).

    u = sat( K (b r - y) + I + D + u_ff ,  u_min, u_max )

with setpoint weights ``b`` (proportional) and ``c`` (derivative), the integral
on the error ``e = r - y`` and the derivative on ``e_d = c r - y`` filtered by a
first-order lag of time constant ``Tf = Td / N``.  At sample ``k`` (period Ts):

- proportional: ``P_k = K (b r_k - y_k)``;
- derivative, backward difference of the filtered derivative
  ``Tf dD/dt + D = K Td de_d/dt``::

      D_k = Tf / (Tf + Ts) D_{k-1} + K Td / (Tf + Ts) (e_d,k - e_d,k-1)

  (stable for any Tf >= 0; ``Tf = 0`` is the plain backward difference); the
  first sample takes ``e_d,-1 = e_d,0``, so starting on a non-zero error gives no
  derivative kick;
- integral, forward Euler: ``I_{k+1} = I_k + K Ts / Ti e_k + (anti-windup)``, so
  ``I_k`` uses errors up to ``k - 1`` and u_k is available at once;
- ``v_k = P_k + I_k + D_k + u_ff,k`` (feedforward before the limits),
  ``u_k = min(max(v_k, u_min), u_max)``.

In z, with b = c = 1 and no limits, this is the transfer function from e to u

    C(z) = K [ 1 + (Ts/Ti) / (z - 1) + Td (z - 1) / ((Tf + Ts) z - Tf) ]

(the tests check it against python-control).  Anti-windup:

- ``'back-calculation'`` (default): ``I_{k+1} += Ts / Tt (u_k - v_k)``, tracking
  time ``Tt`` (default ``sqrt(Ti Td)``, or ``Ti`` without derivative action);
- ``'conditional'``: the integral does not move in a sample where the output is
  limited and the increment would push it further into the limit;
- ``'none'``.

Ti = 0 and Td = 0 switch the integral and derivative actions off.  In
co-simulation the PID samples at its own Ts, several times per communication
step or holding its output between samples (:mod:`grubler.controllers.law`).

Examples
--------
>>> pid = PID(K=2.0, Ti=0.5, Ts=0.01)
>>> pid.update(0.0, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.0})
{'u': 2.0}
>>> pid.update(0.01, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.0})["u"]  # + K Ts/Ti e
2.04
"""

from __future__ import annotations

import ctypes

from grubler.errors import SceneError

from grubler.controllers import native
from grubler.controllers.law import Law, Parameter, check_number

ANTI_WINDUP = ("back-calculation", "conditional", "none")


class PID(Law):
    """Discrete PID with setpoint weights, filtered derivative, anti-windup and limits.

    Parameters
    ----------
    K : float
        Proportional gain (unit of u per unit of the error).
    Ti, Td : float
        Integral and derivative times, s; 0 switches the action off.
    N : float
        Derivative filter: ``Tf = Td / N`` (> 0; typically 5 to 20).
    b, c : float
        Setpoint weights of the proportional and derivative actions.
    Ts : float
        Sample time, s (> 0).
    u_min, u_max : float
        Output limits (``u_min < u_max``; ``±1e300`` for none).
    anti_windup : {'back-calculation', 'conditional', 'none'}
    Tt : float
        Tracking time of the back-calculation, s; 0 takes ``sqrt(Ti Td)``
        (``Ti`` when Td = 0).

    Examples
    --------
    >>> from grubler.controllers import PID
    >>> pid = PID(K=2.0, Ti=0.5, Ts=1e-3)
    >>> pid.update(0.0, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.0})
    {'u': 2.0}
    >>> pid.update(1e-3, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.0})  # the integral grows K Ts / Ti
    {'u': 2.004}
    """

    inputs = {"setpoint": "setpoint r [any]", "measurement": "measured process value y [any]",
              "feedforward": "feedforward added before the limits [any]"}
    outputs = {"u": "controller output [any]"}
    parameters = {
        "K": Parameter(1.0, "proportional gain [any]"),
        "Ti": Parameter(0.0, "integral time, 0 for no integral action [s]"),
        "Td": Parameter(0.0, "derivative time, 0 for no derivative action [s]"),
        "N": Parameter(10.0, "derivative filter Tf = Td/N [1]"),
        "b": Parameter(1.0, "setpoint weight of the proportional action [1]"),
        "c": Parameter(1.0, "setpoint weight of the derivative action [1]"),
        "Ts": Parameter(1e-3, "sample time [s]"),
        "u_min": Parameter(-1e300, "lower output limit [any]"),
        "u_max": Parameter(1e300, "upper output limit [any]"),
        "anti_windup": Parameter("back-calculation", "back-calculation | conditional | none [1]"),
        "Tt": Parameter(0.0, "tracking time of the back-calculation, 0 for sqrt(Ti Td) [s]"),
    }

    def __init__(self, K: float = 1.0, Ti: float = 0.0, Td: float = 0.0, N: float = 10.0, b: float = 1.0,
                 c: float = 1.0, Ts: float = 1e-3, u_min: float = -1e300, u_max: float = 1e300,
                 anti_windup: str = "back-calculation", Tt: float = 0.0):
        given = {"K": K, "Ti": Ti, "Td": Td, "N": N, "b": b, "c": c, "Ts": Ts, "u_min": u_min, "u_max": u_max,
                 "Tt": Tt}
        values = {name: check_number(v, name) for name, v in given.items()}  # numbers; the C judges their range
        if anti_windup not in ANTI_WINDUP:
            raise SceneError("anti_windup", f"must be one of {', '.join(ANTI_WINDUP)}, got {anti_windup!r}")
        self._params = native.PidParams(**values, anti_windup=ANTI_WINDUP.index(anti_windup))
        native.refuse_bad("pid", self._params)
        for name, v in values.items():
            setattr(self, name, v)
        self.anti_windup = anti_windup
        Tt = ctypes.c_double()
        native.call("ctl_pid_tracking_time", self._params, Tt)
        self.Tt = Tt.value
        self._state = native.PidState()
        self._u = ctypes.c_double()
        self.reset()

    def reset(self, integral: float = 0.0) -> None:
        """Back to the start: integral ``integral``, derivative at rest, no history."""
        native.call("ctl_pid_reset", self._params, float(integral), self._state)

    @property
    def integral(self) -> float:
        """The integral action I, unit of u."""
        return self._state.I

    def compute(self, r: float, y: float, u_ff: float = 0.0) -> float:
        """One sample on plain floats: the output u, and the state advanced.

        Raises
        ------
        ValueError
            An input that is not finite, or a sample that overflows.
        """
        native.call("ctl_pid_sample", self._params, self._state, r, y, u_ff, self._u)
        return self._u.value

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        return {"u": self.compute(inputs["setpoint"], inputs["measurement"], inputs.get("feedforward", 0.0))}

    def initial_outputs(self, t0: float) -> dict[str, float]:
        native.call("ctl_pid_initial_output", self._params, self._u)
        return {"u": self._u.value}

    def get_state(self) -> dict:
        """The integral, the filtered derivative, the last derivative error and whether a sample ran."""
        return native.as_plain(self._state)

    def set_state(self, state: dict) -> None:
        self._state = native.checked_state("pid", self._params, native.PidState, state)


__all__ = ["PID", "ANTI_WINDUP"]
