"""The DC motor (grubler.motors): against closed-form solutions, its data sets, and its FMU.

References do not share the code under test: the motor-plus-inertia step response
is the closed form of the linear second-order system, the thermal responses are
closed-form exponentials, the two-node thermal reduction is checked with numpy's
eigenvalues, and the datasheet conversions by hand arithmetic.

The FMU runs in a child process (this file run as a script, see the bottom) that
writes what it measured to JSON, so a crash at interpreter exit (upstream
PythonFMU issue 228) can neither hide nor fake a result.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from grubler.errors import SceneError
from grubler.motors import (DCMotor, Drive, Gearbox, MotorData, MotorSimulator, MotorState, initial_state,
                            list_motors, load_motor, outputs, shaft_torque, step, two_node_slow_time_constant)

HERE = Path(__file__).parent
ROOT = HERE.parent
RE40 = "maxon-re40-148877"


def linear_re40(**changes) -> MotorData:
    """The RE 40 without the nonlinear parts (dry friction, R(T)), for closed-form checks."""
    return load_motor(RE40).replace(coulomb_friction=0.0, temperature_coefficient=0.0, **changes)


# -- (a) motor + pure inertia against the closed-form second-order response -------------
def closed_form(d: MotorData, J: float, V: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed and current of L i' = V - R i - k w, J w' = k i - b w from rest (k = k_t = k_e)."""
    R, L, k, b = d.resistance, d.inductance, d.torque_constant, d.viscous_friction
    # characteristic polynomial s^2 + (R/L + b/J) s + (R b + k^2)/(L J): two real poles (overdamped)
    p, q = R / L + b / J, (R * b + k * k) / (L * J)
    disc = math.sqrt(p * p / 4 - q)
    l1, l2 = -p / 2 + disc, -p / 2 - disc
    w_ss = k * V / (R * b + k * k)
    w = w_ss * (1 + (l2 * np.exp(l1 * t) - l1 * np.exp(l2 * t)) / (l1 - l2))
    wd = w_ss * l1 * l2 * (np.exp(l1 * t) - np.exp(l2 * t)) / (l1 - l2)
    return w, (J * wd + b * w) / k


def coupled_run(motor: DCMotor, J: float, V: float, t_end: float, dt: float):
    """The test's own inertia, its speed integrated with the motor's torque held over each step."""
    sim, w = MotorSimulator(motor), 0.0
    ts, ws, cs = [0.0], [0.0], [0.0]
    for k in range(int(round(t_end / dt))):
        tau = sim.outputs(V, w).shaft_torque
        out = sim.step(V, w, dt)          # the motor holds this step's speed
        w += dt * tau / J                 # the inertia holds this step's torque
        ts.append((k + 1) * dt)
        ws.append(w)
        cs.append(out.current)
    return np.array(ts), np.array(ws), np.array(cs)


def test_step_response_matches_the_closed_form_and_converges_with_the_step():
    d = linear_re40(back_emf_constant=0.0603, viscous_friction=2e-5)  # k_e = k_t exactly, some damping
    motor = DCMotor(d, drive=Drive(1000.0))
    J = 4 * d.rotor_inertia  # rotor plus a load
    errors = []
    for dt in (4e-4, 1e-4, 2.5e-5):
        t, w, i = coupled_run(motor, J, 24.0, 0.03, dt)
        w_ref, i_ref = closed_form(d, J, 24.0, t)
        errors.append((np.max(np.abs(w - w_ref)) / np.max(w_ref), np.max(np.abs(i - i_ref)) / np.max(i_ref)))
    errors = np.array(errors)
    assert errors[-1, 0] < 2e-3 and errors[-1, 1] < 5e-3, errors
    # first order in the coupling step: 4x smaller step, about 4x smaller error
    ratios = errors[:-1] / errors[1:]
    assert np.all(ratios > 3.0) and np.all(ratios < 5.0), ratios


def test_current_is_exact_over_a_step_far_longer_than_the_electrical_time_constant():
    d = linear_re40()
    motor = DCMotor(d)
    tau_e = d.inductance / d.resistance  # 0.28 ms
    for dt in (1e-4, 1e-3):  # one step of 1 ms covers 3.5 tau_e: no sub-steps for the current
        state, t = initial_state(motor), 0.0
        for _ in range(5):
            state, out = step(motor, state, 12.0, 30.0, dt)
            t += dt
            i_ss = (12.0 - d.back_emf_constant * 30.0) / d.resistance
            assert out.current == pytest.approx(i_ss * (1 - math.exp(-t / tau_e)), rel=1e-12, abs=1e-13)


# -- (b) supply clamp and current limit --------------------------------------------------
def test_commanded_voltage_is_clamped_to_the_supply():
    d = linear_re40()
    motor = DCMotor(d, drive=Drive(24.0))
    for cmd, v in ((100.0, 24.0), (-100.0, -24.0), (10.0, 10.0)):
        state, out = step(motor, initial_state(motor), cmd, 0.0, 0.02)
        assert out.terminal_voltage == v
        assert out.current == pytest.approx(v / d.resistance, rel=1e-12)
        assert out.electrical_power == pytest.approx(v * out.current, rel=1e-15)


def test_current_limit_holds_and_is_reached_at_the_exact_instant():
    d = linear_re40()
    motor = DCMotor(d, drive=Drive(48.0, current_limit=5.0))
    tau_e, i_ss = d.inductance / d.resistance, 48.0 / d.resistance  # unlimited: 41 A
    t_hit = -tau_e * math.log(1 - 5.0 / i_ss)
    state, t = initial_state(motor), 0.0
    for _ in range(40):
        state, out = step(motor, state, 48.0, 0.0, 2.5e-5)
        t += 2.5e-5
        assert abs(out.current) <= 5.0
        expected = i_ss * (1 - math.exp(-t / tau_e)) if t < t_hit else 5.0
        assert out.current == pytest.approx(expected, rel=1e-12)
    assert out.terminal_voltage == pytest.approx(5.0 * d.resistance)  # held: di/dt = 0 at the limit
    # turning: the limiter holds with the back-EMF added
    state, out = step(motor, state, 48.0, 200.0, 1e-3)
    assert out.current == 5.0
    assert out.terminal_voltage == pytest.approx(5.0 * d.resistance + d.back_emf_constant * 200.0)
    # full reversal inside one long step: it stops at the other limit, not beyond
    state, out = step(motor, state, -48.0, 200.0, 0.01)
    assert out.current == -5.0
    # a command below the limit is obeyed again
    state, out = step(motor, state, 0.5 * d.resistance, 0.0, 0.01)
    assert out.current == pytest.approx(0.5, rel=1e-9)


def test_back_driven_beyond_the_supply_the_current_exceeds_the_limit_as_documented():
    d = linear_re40()
    motor = DCMotor(d, drive=Drive(24.0, current_limit=5.0))
    w = 600.0  # back-EMF 36 V > 24 V supply: the bridge cannot hold the limit
    state, out = step(motor, initial_state(motor), 0.0, w, 0.01)
    assert out.terminal_voltage == 24.0  # the drive opposes with the whole supply
    assert out.current == pytest.approx((24.0 - d.back_emf_constant * w) / d.resistance, rel=1e-9)
    assert out.current < -5.0


# -- (c) winding temperature ------------------------------------------------------------
def thermal_run(d: MotorData, i: float, times: list[float], dt: float = 1.0):
    # the current limiter holds i whatever R(T) does
    motor = DCMotor(d, drive=Drive(48.0, current_limit=i), ambient_temperature=20.0, max_substep=dt)
    state, t, out = initial_state(motor, current=i), 0.0, {}
    for target in times:
        while t < target - 1e-9:
            state, _ = step(motor, state, 48.0, 0.0, dt)
            t += dt
        out[target] = state.temperature
    return out


def test_constant_current_heats_the_winding_exponentially():
    d = linear_re40()  # alpha = 0: R constant
    i, times = 3.0, [100.0, 1000.0, 3000.0, 20000.0]
    dT = i * i * d.resistance * d.thermal_resistance
    got = thermal_run(d, i, times, dt=2.0)
    for t in times:
        assert got[t] == pytest.approx(20.0 + dT * (1 - math.exp(-t / d.thermal_time_constant)), abs=1e-9)


def test_copper_resistance_raises_the_final_temperature_and_slows_the_approach():
    d = load_motor(RE40)  # alpha = 0.0039 /K at T_ref = 25 degC
    i, times = 3.0, [100.0, 1000.0, 5000.0]
    a, r_th, tau = d.temperature_coefficient, d.thermal_resistance, d.thermal_time_constant
    p = i * i * d.resistance  # loss at T_ref
    g = a * p * r_th
    t_ss = (20.0 + p * r_th * (1 - a * d.reference_temperature)) / (1 - g)
    got = thermal_run(d, i, times)
    for t in times:
        assert got[t] == pytest.approx(t_ss + (20.0 - t_ss) * math.exp(-t * (1 - g) / tau), abs=1e-9)
    assert t_ss - 20.0 > 1.3 * i * i * d.resistance_at(20.0) * r_th  # warmer than with R fixed at ambient


# -- (d) gearbox ------------------------------------------------------------------------
def test_gearbox_efficiency_applies_in_the_direction_of_power_flow():
    d = load_motor(RE40).replace(viscous_friction=1e-5)
    motor = DCMotor(d, Gearbox(ratio=10.0, efficiency=0.7))
    for i, w_out in ((2.0, 50.0), (-2.0, -50.0), (2.0, -50.0), (-2.0, 50.0)):
        w_m = 10.0 * w_out
        tau_m = d.torque_constant * i - d.viscous_friction * w_m - d.coulomb_friction * math.tanh(w_m / 10.0)
        out = outputs(motor, MotorState(i, 25.0), 0.0, w_out)
        p_motor, p_out = tau_m * w_m, out.shaft_torque * w_out
        if p_motor > 0:  # the motor drives the load: the gearbox loses 30 % on the way out
            assert p_out == pytest.approx(0.7 * p_motor, rel=1e-12)
        else:  # the load drives the motor: 30 % lost on the way in
            assert p_motor == pytest.approx(0.7 * p_out, rel=1e-12)
    # continuous through zero speed: no jump for a held speed to chatter on
    lo, hi = shaft_torque(motor, 1.0, -1e-9), shaft_torque(motor, 1.0, 1e-9)
    assert abs(hi - lo) < 1e-9
    assert lo == pytest.approx(10.0 * d.torque_constant, rel=1e-6)  # lossless at standstill


def test_dry_friction_is_smooth_near_zero_speed():
    d = load_motor(RE40)
    motor = DCMotor(d)
    w = np.linspace(-2 * d.smoothing_speed, 2 * d.smoothing_speed, 401)
    tau = np.array([shaft_torque(motor, 0.0, x) for x in w])
    assert np.all(np.diff(tau) < 0)  # friction opposes motion, monotone, no step
    assert np.max(np.abs(np.diff(tau))) < 2 * d.coulomb_friction / 100
    assert shaft_torque(motor, 0.0, 20 * d.smoothing_speed) == pytest.approx(-d.coulomb_friction, rel=1e-12)


def test_reflected_inertia_and_motor_speed_scale_with_the_ratio():
    d = load_motor(RE40)
    motor = DCMotor(d, Gearbox(ratio=12.0, efficiency=0.9))
    assert motor.reflected_inertia == pytest.approx(144.0 * d.rotor_inertia, rel=1e-15)
    out = outputs(motor, initial_state(motor), 0.0, 3.0)
    assert out.motor_speed == 36.0
    assert out.back_emf == pytest.approx(36.0 * d.back_emf_constant, rel=1e-15)


def test_snapshot_and_restore_replay_bit_for_bit():
    sim = MotorSimulator(DCMotor(load_motor(RE40), drive=Drive(48.0, 6.0)))
    for _ in range(10):
        sim.step(30.0, 20.0, 1e-3)
    saved = sim.snapshot()
    first = [sim.step(30.0 - k, 20.0, 1e-3) for k in range(20)]
    sim.restore(saved)
    assert [sim.step(30.0 - k, 20.0, 1e-3) for k in range(20)] == first


def test_bad_step_inputs_name_the_field():
    motor = DCMotor(load_motor(RE40))
    for args, field in (((math.nan, 0.0, 1e-3), "voltage"), ((0.0, math.inf, 1e-3), "shaft_speed"),
                        ((0.0, 0.0, 0.0), "dt")):
        with pytest.raises(SceneError) as exc:
            step(motor, initial_state(motor), *args)
        assert exc.value.field == field


# -- (e) data sets and datasheet conversion ------------------------------------------------
def test_every_shipped_data_set_loads_and_names_its_source():
    names = list_motors()
    assert len(names) >= 4
    for name in names:
        d = load_motor(name)
        assert d.name == name
        assert "maxon motor" in d.source and "data sheet" in d.source
        assert d.notes
        assert abs(d.back_emf_constant / d.torque_constant - 1) < 0.01
        assert 1e-5 < d.electrical_time_constant < 1e-3 < d.mechanical_time_constant < 1e-2


def test_re40_figures_convert_by_hand_arithmetic():
    d = load_motor(RE40)
    assert d.resistance == 1.16
    assert d.inductance == pytest.approx(0.33e-3, rel=1e-15)
    assert d.torque_constant == pytest.approx(0.0603, rel=1e-15)
    assert d.back_emf_constant == pytest.approx(60 / (2 * math.pi * 158), rel=1e-12)  # 1 / (158 rpm/V)
    assert d.rotor_inertia == pytest.approx(134e-7, rel=1e-15)                         # 134 g cm^2
    assert d.coulomb_friction == pytest.approx(0.0603 * 0.069, rel=1e-12)               # k_t I_0
    assert d.thermal_resistance == pytest.approx(1.93 + 4.65, rel=1e-15)
    assert d.no_load_speed == pytest.approx(7580 * 2 * math.pi / 60, rel=1e-12)
    assert d.nominal_torque == pytest.approx(0.187, rel=1e-12)
    assert d.stall_torque == pytest.approx(2.5, rel=1e-12)
    assert d.max_speed == pytest.approx(12000 * math.pi / 30, rel=1e-12)
    assert d.max_winding_temperature == 155.0


def test_two_node_reduction_is_the_slow_eigenvalue_of_the_network():
    r1, r2, tw, tm = 1.93, 4.65, 41.6, 1120.0
    cw, ch = tw / r1, tm / r2  # heat capacities of winding and housing
    A = np.array([[-1 / (cw * r1), 1 / (cw * r1)], [1 / (ch * r1), -1 / (ch * r1) - 1 / (ch * r2)]])
    slow = -1 / np.max(np.linalg.eigvals(A).real)
    assert two_node_slow_time_constant(r1, r2, tw, tm) == pytest.approx(slow, rel=1e-12)
    assert load_motor(RE40).thermal_time_constant == pytest.approx(slow, rel=1e-12)


def test_from_datasheet_converts_units():
    d = MotorData.from_datasheet(
        name="faulhaber-like", source="hand example", nominal_voltage_V=24.0,
        terminal_resistance_ohm=0.8, terminal_inductance_mH=0.2, torque_constant_mNm_per_A=40.0,
        speed_constant_rpm_per_V=239.0, rotor_inertia_gcm2=65.0, friction_torque_mNm=3.0,
        viscous_damping_uNm_per_rpm=1.5, thermal_resistance_K_per_W=7.0, thermal_time_constant_s=900.0,
        max_speed_rpm=6000.0, smoothing_speed_rad_per_s=5.0)
    assert d.coulomb_friction == pytest.approx(3e-3, rel=1e-15)
    assert d.viscous_friction == pytest.approx(1.5e-6 * 60 / (2 * math.pi), rel=1e-12)  # µNm per rpm -> N m s/rad
    assert d.rotor_inertia == pytest.approx(6.5e-6, rel=1e-15)
    assert d.back_emf_constant == pytest.approx(1 / (239.0 * 2 * math.pi / 60), rel=1e-12)
    assert (d.thermal_resistance, d.thermal_time_constant, d.smoothing_speed) == (7.0, 900.0, 5.0)
    assert d.max_speed == pytest.approx(200 * math.pi, rel=1e-12)
    assert "k_e = 1/k_n" in d.notes


BASE = dict(name="x", source="y", terminal_resistance_ohm=1.0, terminal_inductance_mH=0.1,
            torque_constant_mNm_per_A=50.0, rotor_inertia_gcm2=10.0, thermal_resistance_K_per_W=5.0,
            thermal_time_constant_s=500.0)


@pytest.mark.parametrize("changes, field", [
    (dict(terminal_resistance_ohm=-1.0), "terminal_resistance_ohm"),
    (dict(terminal_inductance_mH=0.0), "terminal_inductance_mH"),
    (dict(rotor_inertia_gcm2=math.nan), "rotor_inertia_gcm2"),
    (dict(speed_constant_rpm_per_V=200.0), "speed_constant_rpm_per_V"),  # 50 mNm/A wants 191 rpm/V
    (dict(nominal_voltage_V=24.0, stall_torque_mNm=900.0), "stall_torque_mNm"),  # 50e-3 x 24 / 1 = 1200 mNm
    (dict(nominal_voltage_V=24.0, speed_constant_rpm_per_V=191.0, no_load_speed_rpm=5000.0), "no_load_speed_rpm"),
    (dict(no_load_current_mA=10.0, friction_torque_mNm=1.0), "friction_torque_mNm"),
    (dict(thermal_time_constant_motor_s=600.0), "thermal_resistance_K_per_W"),
    (dict(nominal_voltage_V=24.0, stall_torque_mNm=1200.0, nominal_torque_mNm=1300.0), "nominal_torque_mNm"),
    (dict(thermal_resistance_K_per_W=None, thermal_time_constant_s=None, thermal_resistance_winding_housing_K_per_W=1.0),
     "thermal_resistance_housing_ambient_K_per_W"),
])
def test_bad_datasheet_figures_name_the_field(changes, field):
    with pytest.raises(SceneError) as exc:
        MotorData.from_datasheet(**{**BASE, **changes})
    assert exc.value.field == field


def test_bad_si_fields_and_setups_name_the_field():
    d = load_motor(RE40)
    for changes, field in ((dict(back_emf_constant=0.07), "back_emf_constant"), (dict(inductance=-1.0), "inductance"),
                           (dict(coulomb_friction=-0.1), "coulomb_friction"), (dict(smoothing_speed=0.0), "smoothing_speed"),
                           (dict(wattage=3.0), "wattage")):
        with pytest.raises(SceneError) as exc:
            d.replace(**changes)
        assert exc.value.field == field
    for make, field in ((lambda: Gearbox(ratio=0.5), "gear_ratio"), (lambda: Gearbox(efficiency=1.2), "gear_efficiency"),
                        (lambda: Drive(0.0), "supply_voltage"), (lambda: Drive(24.0, -1.0), "current_limit"),
                        (lambda: initial_state(DCMotor(d, drive=Drive(24.0, 2.0)), current=3.0), "initial_current"),
                        (lambda: DCMotor(d, ambient_temperature=math.nan), "ambient_temperature")):
        with pytest.raises(SceneError) as exc:
            make()
        assert exc.value.field == field


def test_load_motor_from_a_path_and_from_text_and_its_errors(tmp_path):
    text = (ROOT / "motors" / "data" / f"{RE40}.toml").read_text()
    path = tmp_path / "mine.toml"
    path.write_text(text)
    assert load_motor(str(path)) == load_motor(RE40) == load_motor(text) == load_motor(path)
    cases = [("no-such-motor", "motor"), ("name = ", "motor"),
             (text.replace("rotor_inertia_gcm2", "rotor_inertia"), "datasheet.rotor_inertia"),
             (re.sub(r"rotor_inertia_gcm2 = .*\n", "", text), "datasheet.rotor_inertia_gcm2"),
             (text.replace("terminal_inductance_mH = 0.33", "terminal_inductance_mH = -0.33"),
              "datasheet.terminal_inductance_mH"),
             (text.replace("speed_constant_rpm_per_V = 158.0", "speed_constant_rpm_per_V = 185.0"),
              "datasheet.speed_constant_rpm_per_V"),
             (text + "\n[model]\nsmoothing_speed_rad_per_s = -1.0\n", "model.smoothing_speed_rad_per_s"),
             (re.sub(r"document = .*\n", "", text), "source.document")]
    for spec, field in cases:
        with pytest.raises(SceneError) as exc:
            load_motor(spec)
        assert exc.value.field == field, (field, exc.value)


# -- (f) the FMU ------------------------------------------------------------------------
PARAMS = {"gear_ratio": 5.0, "gear_efficiency": 0.8, "current_limit": 4.0, "supply_voltage": 36.0,
          "ambient_temperature": 30.0, "viscous_friction": 2e-5}


def python_reference(h: float, n: int, voltage, speed: float) -> list[list[float]]:
    d = load_motor(RE40).replace(viscous_friction=PARAMS["viscous_friction"])
    motor = DCMotor(d, Gearbox(PARAMS["gear_ratio"], PARAMS["gear_efficiency"]),
                    Drive(PARAMS["supply_voltage"], PARAMS["current_limit"]),
                    ambient_temperature=PARAMS["ambient_temperature"])
    state, rows = initial_state(motor), []
    for k in range(n):
        state, out = step(motor, state, voltage(k * h), speed, h)
        rows.append([(k + 1) * h, out.shaft_torque, out.current, out.winding_temperature, out.electrical_power,
                     out.motor_speed, out.back_emf])
    return rows


def voltage_step(t: float) -> float:
    return 0.0 if t < 0.01 - 1e-12 else 30.0


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    sys.path.insert(0, str(ROOT))
    import builds

    (path,) = builds.dist(tmp_path_factory.mktemp("dist"), ["DCMotor"])
    return path


def run_child(scenario: str, fmu: Path, tmp_path: Path) -> dict:
    out = tmp_path / f"{scenario}.json"
    proc = subprocess.run([sys.executable, __file__, scenario, str(fmu), str(out)], capture_output=True, text=True,
                          timeout=300)
    assert out.exists(), f"scenario {scenario} wrote nothing (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    data = json.loads(out.read_text())
    assert data["done"]
    return data["result"]


@pytest.mark.slow
def test_fmpy_validate_passes(fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu)) == []


@pytest.mark.slow
def test_model_description_declares_the_interface_with_units(fmu):
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    assert {n for n, v in by_name.items() if v.causality == "input"} == {"voltage", "shaft_speed"}
    assert {n for n, v in by_name.items() if v.causality == "output"} == {
        "shaft_torque", "current", "winding_temperature", "electrical_power", "motor_speed", "back_emf",
        "terminal_voltage", "reflected_inertia"}
    for name in ("resistance", "inductance", "torque_constant", "back_emf_constant", "rotor_inertia",
                 "viscous_friction", "coulomb_friction", "smoothing_speed", "thermal_resistance",
                 "thermal_time_constant", "temperature_coefficient", "reference_temperature", "gear_ratio",
                 "gear_efficiency", "supply_voltage", "current_limit", "ambient_temperature", "initial_current",
                 "initial_temperature", "max_substep"):
        assert by_name[name].causality == "parameter", name
    units = {"shaft_torque": "N m", "current": "A", "winding_temperature": "degC", "electrical_power": "W",
             "motor_speed": "rad/s", "back_emf": "V", "reflected_inertia": "kg m2", "voltage": "V",
             "shaft_speed": "rad/s", "resistance": "Ohm", "inductance": "H", "thermal_resistance": "K/W",
             "thermal_time_constant": "s", "gear_ratio": "1", "ambient_temperature": "degC"}
    for v in md.modelVariables:
        assert re.search(r"\[[^\[\]]+\]$", v.description), v.name
    for name, unit in units.items():
        assert by_name[name].description.endswith(f"[{unit}]"), name
    assert float(by_name["resistance"].start) == 1.16  # the RE 40's numbers by default
    assert float(by_name["supply_voltage"].start) == 48.0
    assert float(by_name["rotor_inertia"].start) == pytest.approx(134e-7)
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate


@pytest.mark.slow
def test_fmu_voltage_step_matches_the_python_model(fmu, tmp_path):
    res = run_child("voltage_step", fmu, tmp_path)
    ref = np.array(python_reference(1e-3, 100, voltage_step, 20.0))
    got = np.array(res["rows"])
    assert got.shape == ref.shape
    assert np.array_equal(got, ref)  # the same code, the same arithmetic
    assert np.max(np.abs(got[:, 2])) == pytest.approx(4.0)  # the limiter acted
    assert res["reflected_inertia"] == pytest.approx(25 * 134e-7)
    assert res["start"] == [0.0, 0.0, 30.0]  # shaft_torque, current, winding_temperature before any step


@pytest.mark.slow
def test_fmu_rolls_back_and_refuses_bad_input(fmu, tmp_path):
    res = run_child("rollback_and_errors", fmu, tmp_path)
    assert res["first"] == res["replay"] == res["replay_serialized"]
    assert "status 2 (discard)" in res["nan_step"]
    assert any("voltage is nan" in m for m in res["messages_nan"])
    assert res["after_nan"] == "ok"
    # a bad parameter is an error at initialisation (the instance then refuses every call)
    assert "status 3 (error)" in res["bad_param"]
    assert any("gear_efficiency" in m for m in res["messages_param"])
    assert "status 3 (error)" in res["bad_motor"]
    assert any("resistance:" in m for m in res["messages_motor"])
    assert res["toml_motor"] == pytest.approx(outputs(
        DCMotor(load_motor(RE40)), MotorState(0.0, 25.0), 0.0, 0.0).shaft_torque)
    assert res["toml_current"] > 0
    warnings = res["messages_warnings"]
    assert sum("exceeds the datasheet's maximum 155 degC" in m for m in warnings) == 1  # once, not every step
    assert sum("friction torque may chatter" in m for m in warnings) == 1


# -- child process: drive the FMU through fmpy and write what it measured ------------------------
def _child(scenario: str, fmu: str, out_path: str) -> None:
    from fmpy import extract, read_model_description

    import fmi_child  # beside this file

    md = read_model_description(fmu)
    unzipped = extract(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    messages: list[str] = []

    def instance(name, params):
        return fmi_child.instance(md, unzipped, name, messages, params)

    names = ["shaft_torque", "current", "winding_temperature", "electrical_power", "motor_speed", "back_emf"]

    def run(s, k0, n, h=1e-3, speed=20.0):
        rows = []
        for k in range(k0, k0 + n):
            s.setReal([vr["voltage"], vr["shaft_speed"]], [voltage_step(k * h), speed])
            s.doStep(k * h, h)
            rows.append([(k + 1) * h] + s.getReal([vr[x] for x in names]))
        return rows

    status = fmi_child.status

    if scenario == "voltage_step":
        s = instance("a", PARAMS)
        s.setReal([vr["voltage"], vr["shaft_speed"]], [0.0, 0.0])
        result = {"start": s.getReal([vr[x] for x in names[:3]]),
                  "reflected_inertia": s.getReal([vr["reflected_inertia"]])[0], "rows": run(s, 0, 100)}
    else:
        s = instance("b", PARAMS)
        run(s, 0, 30)
        state = s.getFMUState()
        blob = s.serializeFMUState(state)
        first = run(s, 30, 20)
        s.setFMUState(state)
        replay = run(s, 30, 20)
        s.setFMUState(s.deserializeFMUState(blob))
        replay2 = run(s, 30, 20)
        result = {"first": first, "replay": replay, "replay_serialized": replay2}
        messages.clear()
        s.setReal([vr["voltage"]], [math.nan])
        result["nan_step"] = status(lambda: s.doStep(0.05, 1e-3))
        result["messages_nan"] = list(messages)
        s.setReal([vr["voltage"]], [1.0])
        result["after_nan"] = status(lambda: s.doStep(0.05, 1e-3))
        for key, params in (("param", {"gear_efficiency": 1.5}), ("motor", {"resistance": -1.0})):
            messages.clear()
            result[f"bad_{key}"] = status(lambda: instance(key, params).doStep(0.0, 1e-3))
            result[f"messages_{key}"] = list(messages)
        # a data set given as TOML text: its numbers are the FMU's parameters
        from grubler.fmi.motor import motor_parameters

        text = (ROOT / "motors" / "data" / f"{RE40}.toml").read_text()
        t = instance("toml", motor_parameters(text))
        result["toml_motor"] = t.getReal([vr["shaft_torque"]])[0]
        t.setReal([vr["voltage"]], [5.0])
        t.doStep(0.0, 1e-3)
        result["toml_current"] = t.getReal([vr["current"]])[0]
        messages.clear()
        hot = instance("hot", {"thermal_time_constant": 0.05})  # 41 A stalled, a winding with little heat capacity
        for k in range(50):
            hot.setReal([vr["voltage"]], [48.0])
            hot.doStep(k * 1e-3, 1e-3)
        hot.doStep(0.05, 0.1)  # longer than 2 smoothing_speed rotor_inertia / coulomb_friction = 0.064 s
        result["messages_warnings"] = list(messages)
    with open(out_path, "w") as fh:
        json.dump({"done": True, "result": result}, fh)
        fh.flush()
        os.fsync(fh.fileno())
    os._exit(0)  # skip interpreter shutdown (PythonFMU issue 228)


if __name__ == "__main__":
    _child(*sys.argv[1:4])
