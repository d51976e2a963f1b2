"""Cascaded position and speed loops, the servo drive's structure.

The outer loop, P or PI on the position error, gives a speed setpoint; the
trajectory's velocity may be added to it (speed feedforward), and the sum is
limited to ``±speed_limit``.  The inner loop, PI on the speed error, gives the
output ``u`` (a voltage, current or torque command, limited to
``[u_min, u_max]`` with back-calculation anti-windup).  Both loops are
:class:`~grubler.controllers.pid.PID` loops sampled together at ``Ts``;
the outer one is limited to the speed limit with its own anti-windup, so a long
move at the limit does not wind its integral up.  The cascade runs in C
(``controllers/kernel/ctl_cascade.c`` over ``ctl_pid.c``), as the native
CascadeController.fmu does.

Examples
--------
>>> ctl = CascadeController(K_position=20.0, K_speed=0.5, Ti_speed=0.05, Ts=1e-3)
>>> out = ctl.update(0.0, {"position_setpoint": 0.1, "velocity_setpoint": 0.0, "position": 0.0, "speed": 0.0})
>>> round(out["u"], 12)            # K_speed * (K_position * 0.1)
1.0
"""

from __future__ import annotations

import ctypes

from grubler.controllers import native
from grubler.controllers.law import Law, Parameter, check_number


class CascadeController(Law):
    """Outer position loop (P or PI) feeding an inner speed loop (PI).

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
        Sample time of both loops, s.
    """

    inputs = {"position_setpoint": "position setpoint [rad]",
              "velocity_setpoint": "velocity of the setpoint, for speed feedforward [rad/s]",
              "position": "measured position [rad]", "speed": "measured speed [rad/s]"}
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
        "Ts": Parameter(1e-3, "sample time of both loops [s]"),
    }

    def __init__(self, K_position: float = 10.0, Ti_position: float = 0.0, K_speed: float = 1.0,
                 Ti_speed: float = 0.0, velocity_feedforward: float = 1.0, speed_limit: float = 1e300,
                 u_min: float = -1e300, u_max: float = 1e300, Tt_speed: float = 0.0, Ts: float = 1e-3):
        given = {"K_position": K_position, "Ti_position": Ti_position, "K_speed": K_speed, "Ti_speed": Ti_speed,
                 "velocity_feedforward": velocity_feedforward, "speed_limit": speed_limit, "u_min": u_min,
                 "u_max": u_max, "Tt_speed": Tt_speed, "Ts": Ts}
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

    def update(self, t: float, inputs: dict[str, float]) -> dict[str, float]:
        native.call("ctl_cascade_sample", self._params, self._state, inputs["position_setpoint"],
                    inputs["velocity_setpoint"], inputs["position"], inputs["speed"], self._u)
        return {"u": self._u.value}

    def initial_outputs(self, t0: float) -> dict[str, float]:
        native.call("ctl_cascade_initial_output", self._params, self._u)
        return {"u": self._u.value}

    def get_state(self) -> dict:
        """Both loops' states and the last speed setpoint, as plain numbers."""
        return native.as_plain(self._state)

    def set_state(self, state: dict) -> None:
        self._state = native.checked_state("cascade", self._params, native.CascadeState, state)


__all__ = ["CascadeController"]
