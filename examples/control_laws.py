"""The two controllers of examples/control_design.py, as user laws (grubler.controllers.Law).

Each law is written twice on purpose, in two forms that must agree: its
difference equations (``update``, what the FMU runs) and its transfer function or
closed-loop matrices for python-control (what the design predicts).  The design
script checks the two against each other before it builds the FMUs
(:func:`grubler.controllers.fmu.build_controller_fmu` bundles this file).
"""

from __future__ import annotations

import control
import numpy as np

from grubler.controllers import Law, Parameter
from grubler.controllers.law import check_number, check_sample_time


class LoopShapedPID(Law):
    """Series PID K (1 + 1/(Ti s)) (1 + Td s) / (1 + Td s / N), backward Euler, with a bias and limits."""

    inputs = {"setpoint": "position setpoint [rad]", "measurement": "measured position [rad]"}
    outputs = {"u": "motor voltage command [V]"}
    parameters = {
        "K": Parameter(100.0, "gain [V/rad]"),
        "Ti": Parameter(0.2, "integral time [s]"),
        "Td": Parameter(0.02, "lead time constant [s]"),
        "N": Parameter(10.0, "lead ratio: the lead's pole sits N / Td [1]"),
        "bias": Parameter(0.0, "voltage added to the output: the operating point's [V]"),
        "u_max": Parameter(48.0, "output limit, symmetric [V]"),
        "Ts": Parameter(1e-3, "sample time [s]"),
    }

    def __init__(self, K=100.0, Ti=0.2, Td=0.02, N=10.0, bias=0.0, u_max=48.0, Ts=1e-3):
        self.K = check_number(K, "K")
        self.Ti = check_number(Ti, "Ti", low=0.0, low_open=True)
        self.Td = check_number(Td, "Td", low=0.0)
        self.N = check_number(N, "N", low=0.0, low_open=True)
        self.bias = check_number(bias, "bias")
        self.u_max = check_number(u_max, "u_max", low=0.0, low_open=True)
        self.Ts = check_sample_time(Ts)
        self.integral = 0.0  # sum of Ts e
        self.p_prev = 0.0  # the PI part's last output
        self.y_prev = 0.0  # the lead's last output

    def update(self, t, inputs):
        e = inputs["setpoint"] - inputs["measurement"]
        Ts, Td, Tf = self.Ts, self.Td, self.Td / self.N
        integral = self.integral + Ts * e
        p = e + integral / self.Ti
        y = (Tf * self.y_prev + (Ts + Td) * p - Td * self.p_prev) / (Tf + Ts)
        u = self.bias + self.K * y
        if abs(u) <= self.u_max:  # integrate only while unsaturated (anti-windup)
            self.integral = integral
        self.p_prev, self.y_prev = p, y
        return {"u": float(np.clip(u, -self.u_max, self.u_max))}

    @staticmethod
    def transfer_function(K, Ti, Td, N, Ts):
        """The law's linear part (error to voltage) as a discrete transfer function: s -> (z - 1) / (Ts z)."""
        z = control.tf([1.0, 0.0], [1.0], Ts)
        Tf = Td / N
        pi = 1 + Ts * z / (Ti * (z - 1))
        lead = ((Ts + Td) * z - Td) / ((Tf + Ts) * z - Tf)
        return K * pi * lead


class LQRServo(Law):
    """LQR state feedback with integral action: position, speed by differencing it, and motor current."""

    inputs = {"setpoint": "position setpoint [rad]", "position": "measured position [rad]",
              "current": "measured winding current [A]"}
    outputs = {"u": "motor voltage command [V]"}
    parameters = {
        "k_position": Parameter(0.0, "gain on the position error [V/rad]"),
        "k_speed": Parameter(0.0, "gain on the speed [V s/rad]"),
        "k_current": Parameter(0.0, "gain on the current's deviation [V/A]"),
        "k_integral": Parameter(0.0, "gain on the integrated position error [V/(rad s)]"),
        "current0": Parameter(0.0, "the operating point's current [A]"),
        "bias": Parameter(0.0, "the operating point's voltage [V]"),
        "u_max": Parameter(48.0, "output limit, symmetric [V]"),
        "Ts": Parameter(1e-3, "sample time [s]"),
    }

    def __init__(self, k_position=0.0, k_speed=0.0, k_current=0.0, k_integral=0.0, current0=0.0, bias=0.0,
                 u_max=48.0, Ts=1e-3):
        self.k = [check_number(v, name) for v, name in ((k_position, "k_position"), (k_speed, "k_speed"),
                                                        (k_current, "k_current"), (k_integral, "k_integral"))]
        self.current0 = check_number(current0, "current0")
        self.bias = check_number(bias, "bias")
        self.u_max = check_number(u_max, "u_max", low=0.0, low_open=True)
        self.Ts = check_sample_time(Ts)
        self.integral = 0.0
        self.prev = None

    def update(self, t, inputs):
        pos, r = inputs["position"], inputs["setpoint"]
        speed = 0.0 if self.prev is None else (pos - self.prev) / self.Ts
        e = pos - r
        kp, kw, ki, kz = self.k
        u = self.bias - kp * e - kw * speed - ki * (inputs["current"] - self.current0) - kz * self.integral
        if abs(u) <= self.u_max:
            self.integral += self.Ts * e
        self.prev = pos
        return {"u": float(np.clip(u, -self.u_max, self.u_max))}

    @staticmethod
    def closed_loop(plant_d, gains, Ts):
        """The sampled loop of this law on a discrete plant (outputs position, current): setpoint to position.

        States: the plant's, the last position (the speed's difference) and the integral.
        """
        kp, kw, ki, kz = gains
        A, B, C = np.asarray(plant_d.A), np.asarray(plant_d.B), np.asarray(plant_d.C)
        c_pos, c_cur = C[0], C[1]
        n = A.shape[0]
        # u = kp r - (kp + kw / Ts) c_pos x + (kw / Ts) theta_prev - ki c_cur x - kz z
        ux = -(kp + kw / Ts) * c_pos - ki * c_cur
        Acl = np.zeros((n + 2, n + 2))
        Acl[:n, :n] = A + np.outer(B[:, 0], ux)
        Acl[:n, n] = B[:, 0] * kw / Ts
        Acl[:n, n + 1] = -B[:, 0] * kz
        Acl[n, :n] = c_pos
        Acl[n + 1, :n] = Ts * c_pos
        Acl[n + 1, n + 1] = 1.0
        Bcl = np.zeros((n + 2, 1))
        Bcl[:n, 0] = B[:, 0] * kp
        Bcl[n + 1, 0] = -Ts
        Ccl = np.zeros((1, n + 2))
        Ccl[0, :n] = c_pos
        return control.ss(Acl, Bcl, Ccl, 0, Ts)
