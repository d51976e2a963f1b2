"""The C motor (motors/kernel/dc_motor.c) against the Python model it replaces, before the switch.

A few hundred random motors, states and inputs: current limit active and not,
back-driven beyond the supply, zero speed, hot winding, steps shorter and far
longer than the electrical and thermal sub-step scales.  Both sides must agree
to 1e-12 relative (absolute 1e-12 of the quantity's scale near zero).
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest

from grubler.motors import DCMotor, Drive, Gearbox, MotorState, load_motor, list_motors
from grubler.motors import dc_motor as dcm
from grubler.motors import native

FIELDS = [f for f, _ in native.Outputs._fields_]


def c_params(m: DCMotor) -> native.Params:
    d = m.data
    return native.Params(d.resistance, d.inductance, d.torque_constant, d.back_emf_constant, d.rotor_inertia,
                         d.viscous_friction, d.coulomb_friction, d.smoothing_speed, d.thermal_resistance,
                         d.thermal_time_constant, d.temperature_coefficient, d.reference_temperature,
                         m.gear.ratio, m.gear.efficiency, m.drive.supply_voltage, m.drive.current_limit,
                         m.ambient_temperature, m.max_substep)


def random_case(rng):
    d = load_motor(rng.choice(list_motors()))
    d = d.replace(viscous_friction=rng.choice([0.0, 1e-5, 3e-4]), coulomb_friction=rng.choice([0.0, d.coulomb_friction]),
                  temperature_coefficient=rng.choice([0.0, 0.0039]))
    supply = float(rng.uniform(6.0, 60.0))
    limit = float(rng.choice([math.inf, rng.uniform(0.5, 8.0)]))
    motor = DCMotor(d, Gearbox(float(rng.choice([1.0, rng.uniform(1.0, 50.0)])), float(rng.uniform(0.5, 1.0))),
                    Drive(supply, limit), ambient_temperature=float(rng.uniform(-20.0, 60.0)),
                    max_substep=float(rng.choice([1e-3, 0.01, 0.5])))
    kind = rng.integers(6)
    lim = limit if math.isfinite(limit) else 10.0
    current = {0: 0.0, 1: limit if math.isfinite(limit) else 3.0, 2: -lim, 3: rng.uniform(-lim, lim),
               4: rng.uniform(-3 * lim, 3 * lim), 5: rng.uniform(-lim, lim)}[kind]
    temperature = float(rng.choice([motor.ambient_temperature, rng.uniform(motor.ambient_temperature, 180.0)]))
    w_noload = supply / d.back_emf_constant / motor.gear.ratio
    speed = float(rng.choice([0.0, rng.uniform(-1.5, 1.5) * w_noload, rng.uniform(-4.0, 4.0) * w_noload]))
    voltage = float(rng.choice([rng.uniform(-1.5, 1.5) * supply, 0.0, supply, -supply]))
    dt = float(rng.choice([1e-5, 1e-4, 1e-3, 0.02, 5.0]))
    return motor, MotorState(float(current), temperature), voltage, speed, dt


def close(a, b, scale):
    return abs(a - b) <= 1e-12 * max(abs(a), abs(b), scale)


@pytest.mark.parametrize("seed", range(4))
def test_c_step_and_outputs_match_the_python_model(seed):
    rng = np.random.default_rng(seed)
    lib, worst, limited, beyond = native.functions(), 0.0, 0, 0
    for _ in range(100):
        motor, state, voltage, speed, dt = random_case(rng)
        p = c_params(motor)
        assert native.check("params", p) is None
        for chain in range(3):  # a few steps in a row: the state leaves the start
            scale = {"shaft_torque": motor.gear.ratio * motor.data.torque_constant * max(1.0, abs(state.current)),
                     "current": 1.0, "winding_temperature": 1.0, "electrical_power": motor.drive.supply_voltage,
                     "motor_speed": 1.0, "back_emf": 1.0, "terminal_voltage": motor.drive.supply_voltage}
            py_out = dcm.outputs(motor, state, voltage, speed)
            s, o = native.State(state.current, state.temperature), native.Outputs()
            assert lib.dcm_observe(ctypes.byref(p), ctypes.byref(s), voltage, speed, ctypes.byref(o)) == 0
            for f in FIELDS:
                assert close(getattr(o, f), getattr(py_out, f), scale[f]), (f, getattr(o, f), getattr(py_out, f))
            py_state, py_out = dcm.step(motor, state, voltage, speed, dt)
            assert lib.dcm_step(ctypes.byref(p), ctypes.byref(s), voltage, speed, dt, ctypes.byref(o)) == 0
            assert close(s.current, py_state.current, 1.0) and close(s.temperature, py_state.temperature, 1.0), \
                (s.current, py_state.current, s.temperature, py_state.temperature)
            for f in FIELDS:
                assert close(getattr(o, f), getattr(py_out, f), scale[f]), (f, getattr(o, f), getattr(py_out, f))
                worst = max(worst, abs(getattr(o, f) - getattr(py_out, f)) / max(abs(getattr(py_out, f)), scale[f]))
            limited += math.isfinite(motor.drive.current_limit) and abs(py_state.current) == motor.drive.current_limit
            beyond += abs(py_state.current) > motor.drive.current_limit  # back-driven past the supply
            state = py_state
            # shaft torque and its inverse at random points
            i, w = float(rng.uniform(-10, 10)), float(rng.choice([0.0, rng.uniform(-1000, 1000)]))
            t = ctypes.c_double()
            assert lib.dcm_shaft_torque(ctypes.byref(p), i, w, ctypes.byref(t)) == 0
            assert close(t.value, dcm.shaft_torque(motor, i, w), motor.gear.ratio * 1e-3)
            tau = np.array([t.value, -t.value, 0.0, 1.5])
            ws = np.array([w, w, w, -w])
            cur = np.empty(4)
            dp = ctypes.POINTER(ctypes.c_double)
            assert lib.dcm_current_for_torque(ctypes.byref(p), 4, tau.ctypes.data_as(dp), ws.ctypes.data_as(dp),
                                              cur.ctypes.data_as(dp)) == 0
            ref = dcm.current_for_torque(motor, tau, ws)
            assert all(close(a, b, 1.0) for a, b in zip(cur, ref)), (cur, ref)
    assert limited > 10 and beyond > 3, (limited, beyond)  # the limiter's branches were exercised
    print(f"seed {seed}: worst relative difference {worst:.3g}, {limited} at the limit, {beyond} beyond")
