"""Cascaded position, speed and current loops, the servo drive's structure.

The outer loop, P or PI on the position error, gives a speed setpoint; the
trajectory's velocity may be added to it (speed feedforward), and the sum is
limited to ``±speed_limit``.  The speed loop, PI on the speed error, gives the
output ``u`` (a voltage, current or torque command, limited to
``[u_min, u_max]`` with back-calculation anti-windup).  With ``K_current > 0``
a current loop is innermost: the speed loop's output, limited to
``±current_limit``, is the current setpoint, and PI on the current error (the
measured winding current, input ``current``) gives ``u``, the voltage, limited
to ``[u_min, u_max]``.  The loops are
:class:`~grubler.controllers.pid.PID` loops sampled together at ``Ts``;
each outer one is limited with its own anti-windup, so a long move at the
limit does not wind its integral up.  The cascade runs in C
(``controllers/kernel/ctl_cascade.c`` over ``ctl_pid.c``), as the native
CascadeController.fmu does.

Examples
--------
>>> ctl = CascadeController(K_position=20.0, K_speed=0.5, Ti_speed=0.05, Ts=1e-3)
>>> out = ctl.update(0.0, {"position_setpoint": 0.1, "velocity_setpoint": 0.0, "position": 0.0, "speed": 0.0})
>>> round(out["u"], 12)            # K_speed * (K_position * 0.1)
1.0
>>> inner = CascadeController(K_position=20.0, K_speed=0.5, K_current=4.0, current_limit=0.8, Ts=1e-3)
>>> out = inner.update(0.0, {"position_setpoint": 0.1, "velocity_setpoint": 0.0, "position": 0.0, "speed": 0.0,
...                          "current": 0.3})
>>> round(out["u"], 12)            # K_current * (min(1.0, current_limit) - 0.3)
2.0
"""

from __future__ import annotations

import ctypes

from grubler.controllers import native
from grubler.controllers.law import Law, Parameter, check_number


class CascadeController(Law):
    """Outer position loop (P or PI) feeding a speed loop (PI), and optionally a current loop (PI).

    Parameters
    ----------
    K_position : float
        Position gain, (rad/s)/rad.
    Ti_position : float
        Integral time of the position loop, s; 0 for a P position loop.
    K_speed : float
        Speed gain, (unit of u)/(rad/s).
    Ti_speed : float
        Integral time of the speed loop, s; 0 for a P speed loop.
    velocity_feedforward : float
        Weight of the trajectory's velocity added to the speed setpoint (1: full).
    speed_limit : float
        Limit of the speed setpoint, rad/s (> 0).
    u_min, u_max : float
        Output limits.
    Tt_speed : float
        Tracking time of the speed loop's anti-windup, s; 0 for Ti_speed.
    Ts : float
        Sample time of the loops, s.
    K_current : float
        Current loop gain, (unit of u)/A, >= 0; 0 (default): no current loop.
    Ti_current : float
        Integral time of the current loop, s; 0 for a P current loop.
    current_limit : float
        Limit of the current setpoint, A (> 0; with a current loop).

    Examples
    --------
    >>> from grubler.controllers import CascadeController
    >>> c = CascadeController(K_position=10.0, K_speed=0.5, Ts=1e-3)
    >>> c.update(0.0, {"position_setpoint": 0.1, "velocity_setpoint": 0.0, "position": 0.0, "speed": 0.0,
    ...                "current": 0.0})        # 0.1 rad short: speed setpoint 1 rad/s, voltage 0.5 x 1
    {'u': 0.5}
    """

    inputs = {"position_setpoint": "position setpoint [rad]",
              "velocity_setpoint": "velocity of the setpoint, for speed feedforward [rad/s]",
              "position": "measured position [rad]", "speed": "measured speed [rad/s]",
              "current": "measured winding current, read when K_current > 0 [A]"}
    outputs = {"u": "controller output [any]"}
    parameters = {
        "K_position": Parameter(10.0, "position loop gain, (rad/s)/rad [1/s]"),
        "Ti_position": Parameter(0.0, "position loop integral time, 0 for a P loop [s]"),
        "K_speed": Parameter(1.0, "speed loop gain, unit of u per rad/s [any]"),
        "Ti_speed": Parameter(0.0, "speed loop integral time, 0 for a P loop [s]"),
        "velocity_feedforward": Parameter(1.0, "weight of the setpoint velocity added to the speed setpoint [1]"),
        "speed_limit": Parameter(1e300, "limit of the speed setpoint [rad/s]"),
        "u_min": Parameter(-1e300, "lower output limit [any]"),
        "u_max": Parameter(1e300, "upper output limit [any]"),
        "Tt_speed": Parameter(0.0, "speed loop tracking time, 0 for Ti_speed [s]"),
        "Ts": Parameter(1e-3, "sample time of the loops [s]"),
        "K_current": Parameter(0.0, "current loop gain, unit of u per A; 0: no current loop [any]"),
        "Ti_current": Parameter(0.0, "current loop integral time, 0 for a P loop [s]"),
        "current_limit": Parameter(1e300, "limit of the current setpoint (with a current loop) [A]"),
    }

    def __init__(self, K_position: float = 10.0, Ti_position: float = 0.0, K_speed: float = 1.0,
                 Ti_speed: float = 0.0, velocity_feedforward: float = 1.0, speed_limit: float = 1e300,
                 u_min: float = -1e300, u_max: float = 1e300, Tt_speed: float = 0.0, Ts: float = 1e-3,
                 K_current: float = 0.0, Ti_current: float = 0.0, current_limit: float = 1e300):
        given = {"K_position": K_position, "Ti_position": Ti_position, "K_speed": K_speed, "Ti_speed": Ti_speed,
                 "velocity_feedforward": velocity_feedforward, "speed_limit": speed_limit, "u_min": u_min,
                 "u_max": u_max, "Tt_speed": Tt_speed, "Ts": Ts, "K_current": K_current,
                 "Ti_current": Ti_current, "current_limit": current_limit}
        values = {name: check_number(v, name) for name, v in given.items()}  # numbers; the C judges their range
        self._params = native.CascadeParams(**values)
        native.refuse_bad("cascade", self._params)
        for name, v in values.items():
            setattr(self, name, v)
        self._u = ctypes.c_double()
        self.reset()

    def reset(self) -> None:
        """Both loops back to the start."""
        self._state = native.CascadeState()
        native.call("ctl_cascade_reset", self._params, self._state)

    @property
    def speed_setpoint(self) -> float:
        """The last speed setpoint the position loop gave, rad/s."""
        return self._state.speed_setpoint

    @property
    def current_setpoint(self) -> float:
        """The last current setpoint the speed loop gave, A (0 without a current loop)."""
        return self._state.current_setpoint

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        # the current is read only by a current loop: a cascade without one needs no current sensor
        current = inputs["current"] if self.K_current > 0.0 else inputs.get("current", 0.0)
        native.call("ctl_cascade_sample", self._params, self._state, inputs["position_setpoint"],
                    inputs["velocity_setpoint"], inputs["position"], inputs["speed"], current, self._u)
        return {"u": self._u.value}

    def initial_outputs(self, t0: float) -> dict[str, float]:
        native.call("ctl_cascade_initial_output", self._params, self._u)
        return {"u": self._u.value}

    def get_state(self) -> dict:
        """The loops' states and the last speed and current setpoints, as plain numbers."""
        return native.as_plain(self._state)

    def set_state(self, state: dict) -> None:
        self._state = native.checked_state("cascade", self._params, native.CascadeState, state)


__all__ = ["CascadeController"]
