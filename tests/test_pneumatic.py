"""The pneumatic cylinder against references that share no code with it.

- the same circuit written again from its stated equations (ISO 6358 flow,
  polytropic chambers) and integrated by scipy's Radau;
- a closed chamber compressed by the rod: p V^n stays constant, n the
  polytropic exponent given;
- a blocked chamber filled through a choked valve edge: the pressure rises in a
  straight line at n R T_s m' / V, m' = C rho_0 p_s sqrt(T_0 / T_s);
- bad parameters refused by name; the FMU steps as the library does.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from grubler.errors import SceneError
from grubler.motors.pneumatic import DEFAULT, PneumaticCylinder, PneumaticSimulator

ATM, R, RHO0, T0 = 101325.0, 287.05, 1.185, 293.15


def reference_rhs(c: PneumaticCylinder, command: float, length_at, rate: float):
    Aa, Ab = math.pi * c.bore ** 2 / 4, math.pi * (c.bore ** 2 - c.rod ** 2) / 4

    def phi(r):
        b, rl = c.critical_pressure_ratio, c.laminar_ratio
        if r <= b:
            return 1.0
        e = (min(r, rl) - b) / (1 - b)
        f = math.sqrt(1 - e * e)
        return f if r < rl else f * (1 - r) / (1 - rl)

    def mdot(a, p1, p2):
        if a <= 0:
            return 0.0
        up, down = max(p1, p2), min(p1, p2)
        m = a * c.sonic_conductance * RHO0 * up * math.sqrt(T0 / c.supply_temperature) * phi(down / up)
        return m if p1 >= p2 else -m

    def rhs(t, y):
        x, xd, pag, pbg = y
        pa, pb = max(pag + ATM, 0.0), max(pbg + ATM, 0.0)
        ps, pe = c.supply_pressure + ATM, c.exhaust_pressure + ATM
        s = length_at(t) - c.retracted_length
        s_vol = min(max(s, 0.0), c.stroke)
        v = 0.0 if (s <= 0 and rate < 0) or (s >= c.stroke and rate > 0) else rate
        Va, Vb = c.dead_volume_a + Aa * s_vol, c.dead_volume_b + Ab * (c.stroke - s_vol)
        xo = min(max(x, -1.0), 1.0)
        plus = max(xo - c.overlap, 0) / (1 - c.overlap)
        minus = max(-xo - c.overlap, 0) / (1 - c.overlap)
        leak = c.leakage * (pag - pbg)
        ma = mdot(plus, ps, pa) - mdot(minus, pa, pe) - leak
        mb = mdot(minus, ps, pb) - mdot(plus, pb, pe) + leak
        n, RT, w = c.polytropic_exponent, R * c.supply_temperature, c.valve_frequency
        u = min(max(command, -1.0), 1.0)
        return [xd, w * w * (u - x) - 2 * c.valve_damping * w * xd,
                n / Va * (RT * ma - pa * Aa * v), n / Vb * (RT * mb + pb * Ab * v)]

    return rhs


def test_the_circuit_follows_a_separate_radau_solution_of_its_equations():
    c = replace(DEFAULT, leakage=1e-10)
    dt, n = 1e-3, 400
    t = np.arange(n) * dt
    command = np.where(t < 0.02, 0.0, np.where(t < 0.2, 0.7, -0.9))
    rate = 0.2 * np.sin(2 * np.pi * t / 0.4)
    length = c.retracted_length + 0.02 + np.concatenate([[0.0], np.cumsum(rate[:-1] * dt)])
    runs = {tol: PneumaticSimulator(replace(c, tolerance=tol)) for tol in (c.tolerance, 1e-6)}
    worst = {tol: 0.0 for tol in runs}
    y = [0.0, 0.0, 0.0, 0.0]
    for k in range(n):
        sol = solve_ivp(reference_rhs(c, command[k], lambda tt, k=k: length[k] + rate[k] * tt, rate[k]),
                        (0.0, dt), y, method="Radau", rtol=1e-11, atol=[1e-14, 1e-10, 1e-5, 1e-5])
        y = sol.y[:, -1]
        for tol, sim in runs.items():
            out = sim.step(command[k], length[k], rate[k], dt)
            err = [abs(out["spool"] - y[0]), abs(out["pressure_a"] - y[2]) / c.supply_pressure,
                   abs(out["pressure_b"] - y[3]) / c.supply_pressure]
            worst[tol] = max(worst[tol], *err)
    # relative to the supply pressure (and the spool's full travel)
    assert worst[c.tolerance] < 1e-3, worst
    assert worst[1e-6] < 1e-5, worst


@pytest.mark.parametrize("n", [1.0, 1.2, 1.4])
def test_a_closed_chamber_compressed_keeps_p_v_to_the_n(n):
    # the overlap keeps every edge shut at the centre; the rod pushes in
    # at a tight tolerance, so that the check is of the model, not of the stepping
    c = replace(DEFAULT, polytropic_exponent=n, overlap=0.2, tolerance=1e-8)
    sim = PneumaticSimulator(c, pressure_a=1e5, pressure_b=1e5)
    s0, v, dt = 0.09, -0.1, 1e-3
    Aa, Ab = c.areas
    length = c.retracted_length + s0
    invariant_a = (1e5 + ATM) * (c.dead_volume_a + Aa * s0) ** n
    invariant_b = (1e5 + ATM) * (c.dead_volume_b + Ab * (c.stroke - s0)) ** n
    for k in range(1, 801):
        out = sim.step(0.0, length, v, dt)
        length += v * dt
        s = s0 + v * k * dt
        Va, Vb = c.dead_volume_a + Aa * s, c.dead_volume_b + Ab * (c.stroke - s)
        assert (out["pressure_a"] + ATM) * Va ** n == pytest.approx(invariant_a, rel=1e-6)
        assert (out["pressure_b"] + ATM) * Vb ** n == pytest.approx(invariant_b, rel=1e-6)
    assert out["pressure_a"] > 10e5  # 80 mm of a 90 mm column pushed in


def test_a_blocked_chamber_fills_through_a_choked_edge_in_a_straight_line():
    # a fast valve (opened within a millisecond), no overlap, no leakage
    c = replace(DEFAULT, valve_frequency=2e4, valve_damping=1.0, overlap=0.0, leakage=0.0)
    sim = PneumaticSimulator(c)
    length = c.retracted_length + 0.05
    Aa, _ = c.areas
    Va = c.dead_volume_a + Aa * 0.05
    ps = c.supply_pressure + ATM
    mdot = c.sonic_conductance * RHO0 * ps * math.sqrt(T0 / c.supply_temperature)
    slope = c.polytropic_exponent * R * c.supply_temperature * mdot / Va
    times, pressures = [], []
    for k in range(1, 40):
        out = sim.step(1.0, length, 0.0, 2.5e-4)
        times.append(k * 2.5e-4)
        pressures.append(out["pressure_a"])
        if (out["pressure_a"] + ATM) / ps > c.critical_pressure_ratio:
            break
    times, pressures = np.array(times), np.array(pressures)
    # choked once the spool is open: every later step adds the same rise
    rises = np.diff(pressures[4:]) / 2.5e-4
    assert len(rises) >= 3
    np.testing.assert_allclose(rises, slope, rtol=1e-6)
    assert out["mass_flow_a"] == pytest.approx(mdot, rel=1e-7)  # the spool open to its tolerance


@pytest.mark.parametrize("change, field, reason", [
    ({"bore": 0.0}, "bore", "must be positive"),
    ({"rod": 0.04}, "rod", "must be narrower than the bore"),
    ({"polytropic_exponent": 0.9}, "polytropic_exponent", "must lie in \\[1, 1.4\\]"),
    ({"critical_pressure_ratio": 1.0}, "critical_pressure_ratio", "must be below 1"),
    ({"laminar_ratio": 0.2}, "laminar_ratio", "must lie between critical_pressure_ratio and 1"),
    ({"exhaust_pressure": 7e5}, "supply_pressure", "must be above the exhaust pressure"),
    ({"sonic_conductance": -1e-8}, "sonic_conductance", "must be positive"),
])
def test_bad_parameters_are_refused_by_name(change, field, reason):
    with pytest.raises(SceneError, match=rf"^{field}: {reason}"):
        replace(DEFAULT, **change)


@pytest.mark.slow
def test_the_fmu_validates_and_steps_exactly_as_the_library(tmp_path):
    import sys
    import zipfile
    from pathlib import Path

    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.validation import validate_fmu

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import builds

    (path,) = builds.dist(tmp_path, ["PneumaticCylinder"])
    assert validate_fmu(str(path)) == []
    d = tmp_path / "unzipped"
    zipfile.ZipFile(path).extractall(d)
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=str(d), modelIdentifier="PneumaticCylinder", instanceName="p")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    sim = PneumaticSimulator(DEFAULT)
    length, names = 0.22, ["force", "pressure_a", "pressure_b", "air_consumption"]
    for k in range(150):
        command, rate = (1.0, 0.05) if k < 80 else (-1.0, -0.05)
        s.setReal([vr["command"], vr["length"], vr["rate"]], [command, length, rate])
        s.doStep(k * 1e-3, 1e-3)
        want = sim.step(command, length, rate, 1e-3)
        assert s.getReal([vr[n] for n in names]) == [want[n] for n in names]
        length += rate * 1e-3
    s.terminate()
    s.freeInstance()
