"""A cylinder-driven linkage as ONE simulation: the reference its co-simulation is judged by.

The mechanism, the hydraulic cylinder with its valve and supply, and the PID are
one ODE, integrated by scipy (Radau, tight tolerances) between the controller's
sample instants; at each instant the PID reads the actuator's length and the
trajectory's setpoint and sets the valve command, held until the next one (as
the PID law samples).  Nothing here calls an FMU or the C cylinder model: the
circuit is written out from docs/cylinders.md's equations
(:func:`circuit_derivatives`, :func:`rod_force`), the mechanism's dynamics are
the library's forward dynamics with the actuator's force as an input, and the
sampled blocks (trajectory, PID) are the project's Python laws.  What differs
from the co-simulation is only the coupling: here the cylinder sees the
piston's length and rate as they change within a step, and the mechanism the
force as it changes; there each holds the other's values over a step.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.integrate

ATM = 101325.0


# -- the circuit, from docs/cylinders.md (hydraulic_cylinder.h's equations), in gauge pressures ---------------
def circuit_derivatives(c, y, command: float, length: float, rate: float) -> list[float]:
    """d/dt of (spool, spool rate, p_A, p_B, p_S) of HydraulicCylinder ``c`` at the piston's length and rate."""
    K = c.nominal_flow / math.sqrt(c.nominal_pressure_drop)
    Aa, Ab = math.pi * c.bore ** 2 / 4, math.pi * (c.bore ** 2 - c.rod ** 2) / 4

    def beta(pg):
        pa = max(pg + ATM, 100.0)  # at a vacuum, as soft as at 100 Pa
        b = c.bulk_modulus
        if c.air_fraction:
            air = c.air_fraction * ATM / pa
            x = air / (air + 1 - c.air_fraction)
            b = 1 / ((1 - x) / c.bulk_modulus + x / pa)
        return b * pa ** 2 / (pa ** 2 + 1000.0 ** 2)  # cavitation near a vacuum

    def orifice(a, dp):
        return K * a * dp / (dp * dp + c.transition_pressure ** 2) ** 0.25 + c.valve_leakage * dp

    x, xd, pa, pb, ps = y
    s = length - c.retracted_length
    s_vol = min(max(s, 0.0), c.stroke)
    v = 0.0 if (s <= 0 and rate < 0) or (s >= c.stroke and rate > 0) else rate
    Va, Vb = c.dead_volume_a + Aa * s_vol, c.dead_volume_b + Ab * (c.stroke - s_vol)
    xo = min(max(x, -1.0), 1.0)
    plus = max(xo - c.overlap, 0) / (1 - c.overlap)
    minus = max(-xo - c.overlap, 0) / (1 - c.overlap)
    q_pa, q_at = orifice(plus, ps - pa), orifice(minus, pa - c.tank_pressure)
    q_pb, q_bt = orifice(minus, ps - pb), orifice(plus, pb - c.tank_pressure)
    q_l = c.leakage * (pa - pb)
    q_r = c.relief_gradient * max(ps - c.relief_pressure, 0.0)
    w = c.valve_frequency
    u = min(max(command, -1.0), 1.0)
    return [xd, w * w * (u - x) - 2 * c.valve_damping * w * xd,
            beta(pa) / Va * (q_pa - q_at - q_l - Aa * v),
            beta(pb) / Vb * (q_pb - q_bt + q_l + Ab * v),
            beta(ps) / c.supply_volume * (c.pump_flow - q_r - q_pa - q_pb)]


def rod_force(c, y, length: float, rate: float) -> float:
    """The rod's force on the mechanism, N (pushing apart): the pressures, the seals' friction, the end stops."""
    Aa, Ab = math.pi * c.bore ** 2 / 4, math.pi * (c.bore ** 2 - c.rod ** 2) / 4
    s = length - c.retracted_length
    stop = 0.0
    if s < 0:
        stop = -c.stop_stiffness * s - c.stop_damping * min(rate, 0.0)
    elif s > c.stroke:
        stop = -c.stop_stiffness * (s - c.stroke) - c.stop_damping * max(rate, 0.0)
    friction = c.viscous_friction * rate + c.coulomb_friction * math.tanh(rate / c.smoothing_speed)
    return y[2] * Aa - y[3] * Ab - friction + stop


# -- the whole system ------------------------------------------------------------------------------------
def monolithic(design, t_end: float, rtol: float = 1e-9, Ts: float | None = None) -> dict[str, np.ndarray]:
    """Samples (every controller period) of a :class:`CylinderServoDesign`'s run as one ODE.

    Returns ``t``, ``length`` and ``rate`` (the actuator's), ``force``, ``pressure_a``, ``pressure_b``,
    ``command`` and ``setpoint`` at each sample instant.
    """
    from grubler.controllers import PID, Trajectory
    from grubler.mechanism.assembly import assemble, project
    from grubler.mechanism.dynamics import Inputs, forward_dynamics
    from grubler.mechanism.scene import load_scene
    from grubler.mechanism.simulate import actuator_lines
    from grubler.motors.hydraulic import HydraulicCylinder
    from grubler.system.cylinder_servo import holding_force, start_length

    if design.cylinder != "hydraulic":
        raise ValueError(f"the reference models the hydraulic cylinder, not a {design.cylinder} one")
    scene = replace(load_scene(design.scene), load_torque=float(design.load_torque))
    model = scene.mechanism
    act = design.actuator or model.actuator_names[0]
    ia = model.actuator_names.index(act)
    length0 = start_length(scene, act)
    c = HydraulicCylinder(**{"retracted_length": length0 - design.start_position, **design.constants})
    hold = holding_force(scene, act)
    Aa, Ab = c.areas
    n = model.n_free
    z, zd = assemble(model, model.z_from_q(model.q_ref), scene.initial_rates)
    Ts = Ts or design.pid.get("Ts", 1e-3)
    move = dict(kind="trapezoid", start=length0, delay=design.delay, distance=design.move, v_max=design.speed,
                a_max=design.acceleration, repeat=1)
    traj = Trajectory(**(design.setpoint or move))
    pid = PID(**design.pid)

    def line(z, zd):
        return actuator_lines(model, np.concatenate([z, zd])[None, :])[0, ia]

    def rhs(t, y, u):
        z, zd, h = y[:n], y[n:2 * n], y[2 * n:]
        length, rate = line(z, zd)
        forces = [0.0] * len(model.actuator_names)
        forces[ia] = rod_force(c, h, length, rate)
        zdd = forward_dynamics(model, z, zd, Inputs(load=scene.load_torque, actuators=tuple(forces)),
                               scene.method).zdd
        return np.concatenate([zd, zdd, circuit_derivatives(c, h, u, length, rate)])

    y = np.concatenate([z, zd, [0.0, 0.0, max(hold, 0.0) / Aa, max(-hold, 0.0) / Ab, c.relief_pressure]])
    steps = int(round(t_end / Ts))
    keys = ("t", "length", "rate", "force", "pressure_a", "pressure_b", "command", "setpoint")
    out = {k: np.empty(steps + 1) for k in keys}
    # the pressures' scale is bars, the spool's its travel, the mechanism's its coordinates
    atol = np.concatenate([np.full(2 * n, rtol), [rtol, rtol * c.valve_frequency, 1e5 * rtol, 1e5 * rtol,
                                                  1e5 * rtol]])
    for k in range(steps + 1):
        t = k * Ts
        length, rate = line(y[:n], y[n:2 * n])
        setpoint = float(traj.evaluate(t)[0])
        u = pid.update(t, {"setpoint": setpoint, "measurement": float(length), "feedforward": 0.0})["u"]
        for key, val in zip(keys, (t, length, rate, rod_force(c, y[2 * n:], length, rate), y[2 * n + 2],
                                   y[2 * n + 3], u, setpoint)):
            out[key][k] = val
        if k == steps:
            break
        sol = scipy.integrate.solve_ivp(rhs, (t, t + Ts), y, method="Radau", rtol=rtol, atol=atol, args=(u,))
        if not sol.success:
            raise RuntimeError(f"reference integration failed at t = {t:g}: {sol.message}")
        y = sol.y[:, -1].copy()
        y[:n], y[n:2 * n] = project(model, y[:n], y[n:2 * n])
    return out
