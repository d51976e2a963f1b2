"""The hydraulic cylinder against references that share no code with it.

- the same circuit written again here from its stated equations and integrated
  by scipy's Radau at a tight tolerance;
- a steady extension at full valve opening worked by hand (orifice law and
  continuity; the relief valve takes the pump's excess);
- the power balance of that steady state: the pump's power is the rod's power
  plus the seals' friction, the valve's throttling and the relief valve's loss;
- a cylinder pushed in against a closed valve: the pressure follows the bulk
  modulus, p = p0 + beta ln(V0 / V);
- the entrained air's stiffness against the isothermal gas law;
- bad parameters refused by name, in the library and in the FMU.
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from grubler.errors import SceneError
from grubler.motors.hydraulic import DEFAULT, FIELDS, CylinderSimulator, HydraulicCylinder

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cylinder_reference import ATM, circuit_derivatives  # noqa: E402


# -- the circuit written again, from hydraulic_cylinder.h's equations (tests/cylinder_reference.py) -------
def reference_rhs(c: HydraulicCylinder, command: float, length_at, rate: float):
    return lambda t, y: circuit_derivatives(c, y, command, length_at(t), rate)


def scenario(n=300, dt=1e-3):
    """Valve commands and piston rates held over each step; lengths piecewise linear."""
    t = np.arange(n) * dt
    command = np.where(t < 0.02, 0.0, np.where(t < 0.15, 0.8, -0.6))
    rate = 0.05 * np.sin(2 * np.pi * t / 0.3)
    length = 0.65 + np.concatenate([[0.0], np.cumsum(rate[:-1] * dt)])
    return dt, command, length, rate


def test_the_circuit_follows_a_separate_radau_solution_of_its_equations():
    dt, command, length, rate = scenario()
    runs = {tol: CylinderSimulator(replace(DEFAULT, tolerance=tol)) for tol in (DEFAULT.tolerance, 1e-6)}
    worst = {tol: 0.0 for tol in runs}
    y = [0.0, 0.0, 0.0, 0.0, DEFAULT.relief_pressure]
    for k in range(len(command)):
        sol = solve_ivp(reference_rhs(DEFAULT, command[k], lambda t, k=k: length[k] + rate[k] * t, rate[k]),
                        (0.0, dt), y, method="Radau", rtol=1e-11, atol=[1e-14, 1e-10, 1e-4, 1e-4, 1e-4])
        y = sol.y[:, -1]
        for tol, sim in runs.items():
            out = sim.step(command[k], length[k], rate[k], dt)
            err = [abs(out[name] - y[i]) / scale for name, i, scale in (
                ("spool", 0, 1.0), ("pressure_a", 2, DEFAULT.relief_pressure),
                ("pressure_b", 3, DEFAULT.relief_pressure), ("supply_pressure", 4, DEFAULT.relief_pressure))]
            worst[tol] = max(worst[tol], *err)
    # relative to the relief pressure (and the spool's full travel), measured:
    # 1.5e-4 at the default tolerance 1e-4 per sub-step, 2e-6 at 1e-6 (a
    # second-order method); a wrong sign or factor anywhere costs 1e-2 or more
    assert worst[DEFAULT.tolerance] < 1e-3, worst
    assert worst[1e-6] < 1e-5, worst


def hand_cylinder(**kw) -> HydraulicCylinder:
    """Sharp-edged orifices (laminar transition 1 Pa), no leakage, no air: the hand formulas hold exactly."""
    base = dict(transition_pressure=1.0, valve_leakage=0.0, leakage=0.0, air_fraction=0.0,
                relief_gradient=DEFAULT.pump_flow / 50e5, coulomb_friction=150.0, viscous_friction=3000.0)
    base.update(kw)
    return replace(DEFAULT, **base)


def steady(c: HydraulicCylinder, command: float, v: float, t_end: float = 0.6):
    sim = CylinderSimulator(c)
    length = c.retracted_length + 0.05
    out = None
    for _ in range(int(round(t_end / 1e-3))):
        out = sim.step(command, length, v, 1e-3)
        length += v * 1e-3
    return out, length


def test_a_steady_extension_at_full_opening_is_the_orifice_and_load_balance_worked_by_hand():
    c = hand_cylinder()
    v = 0.08  # m/s: 9.4 L/min into the cap side, well within the valve and the pump
    out, _ = steady(c, 1.0, v)
    K = c.nominal_flow / math.sqrt(c.nominal_pressure_drop)
    Aa, Ab = c.areas
    # the pump's excess leaves through the relief valve: Q_pump - Aa v = g (p_S - p_crack)
    p_s = c.relief_pressure + (c.pump_flow - Aa * v) / c.relief_gradient
    p_a = p_s - (Aa * v / K) ** 2          # P->A: Q = K sqrt(dp)
    p_b = c.tank_pressure + (Ab * v / K) ** 2  # B->T
    force = p_a * Aa - p_b * Ab - c.viscous_friction * v - c.coulomb_friction * math.tanh(v / c.smoothing_speed)
    assert out["supply_pressure"] == pytest.approx(p_s, rel=1e-7)
    assert out["pressure_a"] == pytest.approx(p_a, rel=1e-7)
    assert out["pressure_b"] == pytest.approx(p_b, rel=1e-6)
    assert out["force"] == pytest.approx(force, rel=1e-7)
    assert out["flow_a"] == pytest.approx(Aa * v, rel=1e-7)
    assert out["flow_b"] == pytest.approx(-Ab * v, rel=1e-7)


def test_the_steady_power_balance_holds():
    c = hand_cylinder()
    v = 0.08
    out, _ = steady(c, 1.0, v)
    K = c.nominal_flow / math.sqrt(c.nominal_pressure_drop)
    Aa, Ab = c.areas
    p_s, p_a, p_b = out["supply_pressure"], out["pressure_a"], out["pressure_b"]
    pump = p_s * c.pump_flow
    rod = out["force"] * v
    friction = (c.viscous_friction * v + c.coulomb_friction * math.tanh(v / c.smoothing_speed)) * v
    # each edge loses dp x Q, the relief valve p_S x its flow
    throttling = (p_s - p_a) * Aa * v + p_b * Ab * v + p_s * (c.pump_flow - Aa * v)
    assert pump == pytest.approx(rod + friction + throttling, rel=1e-7)
    # and the model's own power outputs say the same
    assert out["pump_power"] == pytest.approx(out["mechanical_power"] + friction + out["throttling_loss"] +
                                              out["compression_power"], rel=1e-9)


def test_a_cylinder_pushed_in_against_a_closed_valve_follows_the_bulk_modulus():
    # the overlap keeps every edge shut at the centre; no leakage, no air
    c = hand_cylinder(overlap=0.2)
    v, dt, p0 = -0.02, 1e-3, 20e5
    sim = CylinderSimulator(c, pressure_a=p0, pressure_b=p0)
    s0 = 0.2
    length = c.retracted_length + s0
    Aa, Ab = c.areas
    Va0 = c.dead_volume_a + Aa * s0
    for k in range(1, 301):
        out = sim.step(0.0, length, v, dt)
        length += v * dt
        Va = c.dead_volume_a + Aa * (s0 + v * k * dt)
        # dp = -beta dV / V, integrated: the exact pressure of a compressed volume
        assert out["pressure_a"] == pytest.approx(p0 + c.bulk_modulus * math.log(Va0 / Va), rel=1e-6)
    assert out["pressure_a"] > 300e5  # 6 mm into 0.44 L of oil: some 280 bar


def test_entrained_air_softens_the_oil_as_the_isothermal_gas_law_says():
    c = hand_cylinder(overlap=0.2, air_fraction=0.01)
    dt, v = 1e-4, -0.01
    sim = CylinderSimulator(c, pressure_a=0.0, pressure_b=0.0)
    s0 = 0.2
    length = c.retracted_length + s0
    Aa, _ = c.areas
    total0 = c.dead_volume_a + Aa * s0
    for k in range(1, 201):
        out = sim.step(0.0, length, v, dt)
        length += v * dt
    # oil (compressible) and air (p V = const) share the shrinking volume
    V = total0 + Aa * v * 200 * dt
    from scipy.optimize import brentq

    def volume_at(pg):
        pa = pg + ATM
        air = 0.01 * total0 * ATM / pa
        oil = 0.99 * total0 * math.exp(-pg / c.bulk_modulus)
        return air + oil - V

    expected = brentq(volume_at, 0.0, 1e8)
    # the model's mixture law is the linearised compliance of this one: equal to
    # the oil's compressibility over the pressure times the volume's change
    # (measured 9e-5: the mixture's fractions neglect the oil's own compression)
    assert out["pressure_a"] == pytest.approx(expected, rel=5e-4)


@pytest.mark.parametrize("change, field, reason", [
    ({"bore": -0.05}, "bore", "must be positive"),
    ({"rod": 0.06}, "rod", "must be narrower than the bore"),
    ({"bulk_modulus": 0.0}, "bulk_modulus", "must be positive"),
    ({"air_fraction": 0.7}, "air_fraction", "must be below 0.5"),
    ({"overlap": 1.0}, "overlap", "must be below 1"),
    ({"tank_pressure": 170e5}, "relief_pressure", "must be above the tank pressure"),
    ({"stroke": float("nan")}, "stroke", "must be finite"),
    ({"bore": "50 mm"}, "bore", "must be a number"),
])
def test_bad_parameters_are_refused_by_name(change, field, reason):
    with pytest.raises(SceneError, match=rf"^{field}: {reason}"):
        replace(DEFAULT, **change)


def test_a_non_finite_input_is_refused_by_name():
    sim = CylinderSimulator(DEFAULT)
    with pytest.raises(SceneError, match="^rate: must be a finite number"):
        sim.step(0.0, 0.6, float("inf"), 1e-3)


def test_stable_at_a_1_ms_communication_step():
    # a valve slammed open and shut against a moving piston: 1 ms steps agree
    # with 0.1 ms steps to the tolerance (the stepping inside is implicit)
    c = DEFAULT
    results = []
    for dt in (1e-3, 1e-4):
        sim = CylinderSimulator(c)
        n = int(round(0.5 / dt))
        length, last = 0.65, None
        for k in range(n):
            t = k * dt
            command = 1.0 if (t // 0.1) % 2 == 0 else -1.0
            rate = 0.02 if command > 0 else -0.02
            last = sim.step(command, length, rate, dt)
            length += rate * dt
        results.append(last)
    for key in ("pressure_a", "pressure_b", "supply_pressure"):
        assert results[0][key] == pytest.approx(results[1][key], rel=1e-4, abs=1e2)


# -- the native FMU: the same C behind the FMI wrapper ----------------------------------
@pytest.fixture(scope="module")
def cylinder_fmu(tmp_path_factory):
    import sys
    import zipfile
    from pathlib import Path

    from fmpy import read_model_description

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root))
    import builds

    (path,) = builds.dist(tmp_path_factory.mktemp("dist"), ["HydraulicCylinder"])
    d = tmp_path_factory.mktemp("unzipped")
    zipfile.ZipFile(path).extractall(d)
    return path, d, read_model_description(str(path))


def _slave(cylinder_fmu, name="c", messages=None):
    from fmpy.fmi2 import FMU2Slave
    from fmi_child import recording_callbacks

    path, d, md = cylinder_fmu
    s = FMU2Slave(guid=md.guid, unzipDirectory=str(d), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=name)
    if messages is None:
        s.instantiate()
    else:
        def log(env, instance, status, category, message):
            messages.append(message.decode())
        s.instantiate(loggingOn=True, callbacks=recording_callbacks(log))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return s, vr


@pytest.mark.slow
def test_the_fmu_validates_and_steps_exactly_as_the_library(cylinder_fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(cylinder_fmu[0])) == []
    s, vr = _slave(cylinder_fmu)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    sim = CylinderSimulator(DEFAULT)
    dt, command, length, rate = scenario(120)
    names = ["force", "pressure_a", "pressure_b", "supply_pressure", "flow_a", "throttling_loss"]
    for k in range(len(command)):
        s.setReal([vr["command"], vr["length"], vr["rate"]], [command[k], length[k], rate[k]])
        s.doStep(k * dt, dt)
        got = s.getReal([vr[n] for n in names])
        want = sim.step(command[k], length[k], rate[k], dt)
        assert got == [want[n] for n in names]  # one C implementation: bit for bit
    s.terminate()
    s.freeInstance()


@pytest.mark.slow
def test_the_fmu_refuses_a_bad_parameter_by_name_and_a_nan_input_with_discard(cylinder_fmu):
    from fmpy.fmi1 import FMICallException

    messages = []
    s, vr = _slave(cylinder_fmu, "bad", messages)
    s.setupExperiment(startTime=0.0)
    s.setReal([vr["rod"]], [0.08])
    with pytest.raises(FMICallException):
        s.enterInitializationMode()
        s.exitInitializationMode()
    assert any(m.startswith("rod: must be narrower than the bore") for m in messages), messages
    s.freeInstance()
    messages.clear()
    s, vr = _slave(cylinder_fmu, "nan", messages)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    s.setReal([vr["rate"]], [float("nan")])
    with pytest.raises(FMICallException):
        s.doStep(0.0, 1e-3)
    assert any("rate is nan" in m for m in messages), messages
    s.freeInstance()


def test_the_python_structures_name_the_c_fields_in_order():
    # ctypes maps by position: a field out of order would read another number
    from grubler.motors.native import HydParams

    assert tuple(FIELDS) == tuple(name for name, _ in HydParams._fields_)
    for k, name in enumerate(FIELDS):
        with pytest.raises(SceneError, match=f"^{name}: "):
            replace(DEFAULT, **{name: float("inf")})
