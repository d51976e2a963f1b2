"""The servo-driven linkage as ONE simulation: the reference a co-simulation is judged by.

Mechanism, motor and gearbox are one ODE integrated by scipy (DOP853, tight
tolerances) between the controller's sample instants; at each instant the
encoder reads the crank and the PID sets the voltage, held until the next one.
The motor's equations are written out here from its data set, not taken from
grubler.motors, so this also checks that model; the sampled blocks (trajectory,
encoder, PID) are the project's Python laws, stepped at their sample instants.
What differs from the co-simulation is only the coupling: here the motor sees the
crank's speed as it changes within a step, there it holds it over a step.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.integrate

from grubler import Inputs, forward_dynamics, load_scene
from grubler.mechanism.assembly import assemble, project
from grubler.controllers import PID, Encoder, Trajectory
from grubler.motors import load_motor
from grubler.system.servo import ServoDesign


def monolithic(design: ServoDesign, t_end: float, rtol: float = 1e-10) -> dict[str, np.ndarray]:
    """Samples (every controller period) of the servo run in one integrator."""
    data = load_motor(design.motor)
    N, eta = design.gear_ratio, design.gear_efficiency
    V_s, I_max = design.supply_voltage, design.current_limit
    scene = load_scene(design.scene)
    model = scene.mechanism.replace(drive_inertia=data.rotor_inertia * N**2)
    d = model.free_index(model.drive)
    z, zd = assemble(model, model.z_from_q(model.q_ref), scene.initial_rates)
    n = model.n_free
    Ts = design.pid.get("Ts", 1e-3)
    assert design.encoder.get("Ts", Ts) == Ts, "the reference samples encoder and PID together"
    traj = Trajectory(**{"start": float(z[d]), **design.trajectory})
    enc = Encoder(**design.encoder)
    pid = PID(**design.pid)
    R_ref, L, kt, ke = data.resistance, data.inductance, data.torque_constant, data.back_emf_constant
    b, tc, ws = data.viscous_friction, data.coulomb_friction, data.smoothing_speed
    alpha, T_ref = data.temperature_coefficient, data.reference_temperature
    C_th, R_th, T_amb = data.thermal_capacity, data.thermal_resistance, 25.0

    def rhs(t, y, v_cmd):
        z, zd, i, T = y[:n], y[n:2 * n], y[2 * n], y[2 * n + 1]
        w_m = N * zd[d]
        R = R_ref * (1 + alpha * (T - T_ref))
        v = min(max(v_cmd, -V_s), V_s)
        di = (v - R * i - ke * w_m) / L
        if (i >= I_max and di > 0) or (i <= -I_max and di < 0):
            di = 0.0  # the drive's current loop holds the limit
        tau_m = kt * i - b * w_m - tc * math.tanh(w_m / ws)
        tau = N * tau_m * eta ** math.tanh(math.copysign(1.0, tau_m) * w_m / ws)
        zdd = forward_dynamics(model, z, zd, Inputs(tau, 0.0)).zdd
        dT = (i * i * R - (T - T_amb) / R_th) / C_th
        return np.concatenate([zd, zdd, [di, dT]])

    y = np.concatenate([z, zd, [0.0, T_amb]])
    steps = int(round(t_end / Ts))
    out = {k: np.empty(steps + 1) for k in ("t", "drive_angle", "drive_speed", "current", "voltage", "setpoint")}
    for k in range(steps + 1):
        t = k * Ts
        setpoint = traj.evaluate(t)[0]
        measured = enc.update(t, {"position": float(y[d])})["measured_position"]
        u = pid.update(t, {"setpoint": setpoint, "measurement": measured, "feedforward": 0.0})["u"]
        for key, val in (("t", t), ("drive_angle", y[d]), ("drive_speed", y[n + d]), ("current", y[2 * n]),
                         ("voltage", u), ("setpoint", setpoint)):
            out[key][k] = val
        if k == steps:
            break
        sol = scipy.integrate.solve_ivp(rhs, (t, t + Ts), y, method="DOP853", rtol=rtol, atol=rtol, args=(u,))
        if not sol.success:
            raise RuntimeError(f"reference integration failed at t = {t:g}: {sol.message}")
        y = sol.y[:, -1].copy()
        y[:n], y[n:2 * n] = project(model, y[:n], y[n:2 * n])
    return out
