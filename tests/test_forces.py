"""Force elements in a scene: springs, dampers, gas springs, joint springs and friction, point loads.

The references share no code with the kernel: closed forms of a mass on a
spring and a damped torsional pendulum, the polytropic gas law written here
from the points' positions (computed here from the angles), moment balances
about a pivot, and energy balances whose dissipated work is integrated here
(cumulative Simpson's rule over a dense record) from the elements' own outputs.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson

import grubler
from grubler.errors import SceneError
from grubler.mechanism.scene import load_scene
from grubler.mechanism.simulate import evaluate, simulate
from grubler.mechanism.dynamics import Inputs

# a block of 2 kg on a horizontal slide (theta1 = -90 deg turns the slide axis to +x), tied to a ground point
# 1 m to its left by a spring whose free length is 1 m: x = B1 is the spring's stretch
SLIDE = """
name = "spring-mass"
gravity = 0.0
[ground]
theta1 = "-90 deg"
[link2]
joint = "P"
a = 0.0
m = 2.0
[closure]
type = "none"
[initial]
B1 = 0.1
[[spring]]
name = "coil"
from_link = "ground"
from_point = [-1.0, 0.0]
to_link = "link2"
to_point = [0.0, 0.0]
stiffness = 50.0
free_length = 1.0
"""


def _slide(extra: str = "") -> str:
    return SLIDE.replace('free_length = 1.0', 'free_length = 1.0\n' + extra)


def test_spring_mass_on_a_slide_swings_as_its_closed_form():
    # m x'' = -k x: x = x0 cos(w t), w = sqrt(k / m) = 5 rad/s, period 2 pi / 5
    res = simulate(load_scene(SLIDE), t_end=3.0, dt_out=0.01, rtol=1e-11, atol=1e-12)
    w = math.sqrt(50.0 / 2.0)
    assert np.max(np.abs(res["B1"] - 0.1 * np.cos(w * res.t))) < 1e-8
    # the period and amplitude read off the record: upward zero crossings of the velocity are the troughs
    v = res["B1_d"]
    ups = [res.t[i] - v[i] * (res.t[i + 1] - res.t[i]) / (v[i + 1] - v[i])
           for i in range(len(v) - 1) if v[i] < 0 <= v[i + 1]]
    assert abs(np.mean(np.diff(ups)) - 2 * math.pi / w) < 1e-6
    # the amplitude at every sample: sqrt(x^2 + (v / w)^2)
    assert np.max(np.abs(np.hypot(res["B1"], v / w) - 0.1)) < 1e-8
    # its force and stored energy: -k x and k x^2 / 2
    assert np.max(np.abs(res["coil_force"] + 50.0 * res["B1"])) < 1e-12
    assert np.max(np.abs(res["coil_energy"] - 25.0 * res["B1"] ** 2)) < 1e-12


def test_damped_preloaded_spring_mass_decays_as_its_closed_form():
    # m x'' + c x' + k x = P: about x_eq = P / k, x - x_eq = A e^(-zeta w t) (cos wd t + zeta w / wd sin wd t)
    m, k, c, P, x0 = 2.0, 50.0, 0.4, 1.5, 0.1
    res = simulate(load_scene(_slide(f"damping = {c}\npreload = {P}")), t_end=4.0, dt_out=0.01, rtol=1e-11,
                   atol=1e-12)
    w = math.sqrt(k / m)
    zeta = c / (2 * m * w)
    wd = w * math.sqrt(1 - zeta**2)
    x_eq = P / k
    expected = x_eq + (x0 - x_eq) * np.exp(-zeta * w * res.t) * (np.cos(wd * res.t)
                                                                  + zeta * w / wd * np.sin(wd * res.t))
    assert np.max(np.abs(res["B1"] - expected)) < 1e-8
    # the damper dissipates c v^2; the energy the run lost is the work it took
    assert np.max(np.abs(res["coil_dissipation"] - c * res["B1_d"] ** 2)) < 1e-12
    lost = res["E"][0] - res["E"]
    taken = cumulative_simpson(res["coil_dissipation"], x=res.t, initial=0.0)
    assert np.max(np.abs(lost - taken)) < 1e-7


# a 1.2 m boom on a ground pivot, held up by a gas spring from a ground point below it, with a coil spring and a
# damper in parallel: released from rest, it swings and settles
BOOM = """
name = "gas-boom"
[link2]
joint = "R"
a = 1.2
p = 0.6
m = 8.0
I = 0.96
[closure]
type = "none"
[initial]
theta2 = "20 deg"
[[spring]]
name = "strut"
from_link = "ground"
from_point = [0.3, -0.4]
to_link = "link2"
to_point = [0.5, 0.05]
stiffness = 300.0
free_length = 0.75
preload = 20.0
damping = 12.0
gas_force = 180.0
gas_column = 0.25
gas_exponent = 1.3
"""


def _boom_line(theta, theta_d):
    """The strut's length and rate from the boom's angle, written here: its ends in world axes."""
    px, py = 0.5, 0.05
    x = px * np.cos(theta) - py * np.sin(theta) - 0.3
    y = px * np.sin(theta) + py * np.cos(theta) + 0.4
    xd = (-px * np.sin(theta) - py * np.cos(theta)) * theta_d
    yd = (px * np.cos(theta) - py * np.sin(theta)) * theta_d
    length = np.hypot(x, y)
    return length, (x * xd + y * yd) / length, (x, y)


def test_gas_spring_force_follows_its_polytropic_law():
    res = simulate(load_scene(BOOM), t_end=2.0, dt_out=0.01)
    length, rate, _ = _boom_line(res["theta2"], res["theta2_d"])
    assert np.max(np.abs(res["strut_length"] - length)) < 1e-12
    assert np.max(np.abs(res["strut_rate"] - rate)) < 1e-10
    # p V^n = p0 V0^n over the gas column h = h0 + L - L0; p0 A = 180 N at L0
    h = 0.25 + length - 0.75
    gas = 180.0 * (0.25 / h) ** 1.3
    expected = gas + 20.0 - 300.0 * (length - 0.75) - 12.0 * rate
    assert np.ptp(h) > 0.05  # the strut really works its gas column
    assert np.max(np.abs(res["strut_force"] - expected)) < 1e-9 * np.max(np.abs(expected))
    # its stored energy: the gas's -int F_gas dL from L0, the coil's and the preload's
    gas_energy = 180.0 * 0.25 / 0.3 * ((0.25 / h) ** 0.3 - 1.0)
    stored = gas_energy + 150.0 * (length - 0.75) ** 2 - 20.0 * (length - 0.75)
    assert np.max(np.abs(res["strut_energy"] - stored)) < 1e-9


def test_isothermal_gas_spring_stores_the_logarithm():
    scene = load_scene(BOOM.replace("gas_exponent = 1.3", "gas_exponent = 1.0").replace("stiffness = 300.0",
                                                                                      "stiffness = 0.0"))
    res = simulate(scene, t_end=0.5, dt_out=0.05)
    length, _, _ = _boom_line(res["theta2"], res["theta2_d"])
    h = 0.25 + length - 0.75
    stored = 180.0 * 0.25 * np.log(0.25 / h) - 20.0 * (length - 0.75)
    assert np.max(np.abs(res["strut_energy"] - stored)) < 1e-10


def test_energy_balance_of_springs_dampers_and_gas():
    # conservative parts in E, the dampers' loss integrated here: E(t) + int dissipation = E(0)
    scene = load_scene(BOOM)
    res = simulate(scene, t_end=2.0, dt_out=0.002, rtol=1e-11, atol=1e-12)
    assert res["E"][0] - res["E"][-1] > 1.0  # the damper took joules, not rounding
    taken = cumulative_simpson(res["strut_dissipation"], x=res.t, initial=0.0)
    residue = res["E"] + taken - res["E"][0]
    assert np.max(np.abs(residue)) < 1e-6
    # the report's balance (the CLI's) says the same
    from grubler.views.report import energy_balance

    columns = {c: res[c] for c in res.columns}
    assert np.max(np.abs(energy_balance(columns, scene.mechanism))) < 1e-3


def test_spring_force_enters_the_pivot_reaction():
    # at rest, the boom's angular acceleration is its moments about the pivot over I_O, and the pivot's
    # reaction is m a_c - m g - F, F the strut's force on the boom: all written here
    scene = load_scene(BOOM.replace("damping = 12.0", "damping = 0.0"))
    m = scene.mechanism
    theta = math.radians(20.0)
    length, _, (dx, dy) = _boom_line(np.array(theta), np.array(0.0))
    h = 0.25 + length - 0.75
    force = 180.0 * (0.25 / h) ** 1.3 + 20.0 - 300.0 * (length - 0.75)
    fx, fy = force * dx / length, force * dy / length  # on the boom, at its point, pushing away from the ground
    px, py = 0.5 * math.cos(theta) - 0.05 * math.sin(theta), 0.5 * math.sin(theta) + 0.05 * math.cos(theta)
    cx, cy = 0.6 * math.cos(theta), 0.6 * math.sin(theta)
    alpha = (px * fy - py * fx - 8.0 * 9.81 * cx) / (0.96 + 8.0 * 0.6**2)
    out = evaluate(m, "exact", 0.0, m.z_from_q(m.q_ref), np.zeros(1), Inputs(), ["dynamics", "reactions"])
    assert out["theta2_dd"] == pytest.approx(alpha, rel=1e-12)
    assert out["R1_Fx"] == pytest.approx(8.0 * (-alpha * cy) - fx, rel=1e-11)
    assert out["R1_Fy"] == pytest.approx(8.0 * (alpha * cx) + 8.0 * 9.81 - fy, rel=1e-11)
    assert abs(out["R1_Mz"]) < 1e-11


# a double pendulum with a spring between its two links: the spring's force reaches the reaction link 2 exerts
# on link 3 (and cancels in the ground's on link 2)
DOUBLE = """
name = "double-spring"
[link2]
joint = "R"
a = 1.0
p = 0.5
m = 1.0
I = 0.1
[link3]
joint = "R"
a = 0.8
p = 0.4
m = 1.5
I = 0.08
[closure]
type = "none"
[initial]
theta2 = -0.3
theta3 = -1.2
[[spring]]
name = "tie"
from_link = "link2"
from_point = [0.3, 0.0]
to_link = "link3"
to_point = [0.5, 0.0]
stiffness = 80.0
free_length = 0.4
"""


def test_spring_between_links_enters_both_reactions():
    m = load_scene(DOUBLE).mechanism
    t2, t3 = -0.3, -1.2
    out = evaluate(m, "exact", 0.0, m.z_from_q(m.q_ref), np.zeros(2), Inputs(), ["dynamics", "reactions"])
    a2, a3 = out["theta2_dd"], out["theta3_dd"]  # absolute angular accelerations, at rest
    e = lambda t: np.array([math.cos(t), math.sin(t)])
    perp = lambda t: np.array([-math.sin(t), math.cos(t)])
    ac2 = 0.5 * a2 * perp(t2)
    ac3 = 1.0 * a2 * perp(t2) + 0.4 * a3 * perp(t3)
    g = np.array([0.0, -9.81])
    p2, p3 = 0.3 * e(t2), 1.0 * e(t2) + 0.5 * e(t3)
    d = p3 - p2
    force = -80.0 * (np.linalg.norm(d) - 0.4) * d / np.linalg.norm(d)  # on link 3
    r2 = 1.5 * (ac3 - g) - force  # what link 2 exerts on link 3 at their joint
    r1 = 1.0 * (ac2 - g) + 1.5 * (ac3 - g)  # the ground's on link 2: the spring is internal
    assert (out["R2_Fx"], out["R2_Fy"]) == pytest.approx(tuple(r2), rel=1e-10, abs=1e-10)
    assert (out["R1_Fx"], out["R1_Fy"]) == pytest.approx(tuple(r1), rel=1e-10, abs=1e-10)
    # a pin carries no moment: the spring's moment is in the forces' arms
    assert abs(out["R2_Mz"]) < 1e-10


def test_spring_mass_linearises_to_its_natural_frequency():
    # the complex-step twin of the dynamics carries the spring: the eigenvalues are +-i sqrt(k / m)
    from grubler.studies.linearize import linearize

    sys_ = linearize(load_scene(SLIDE.replace("[closure]", '[drive]\njoint = "B1"\n[closure]')))
    poles = np.sort_complex(np.linalg.eigvals(sys_.A))
    assert poles == pytest.approx([-5j, 5j], abs=1e-9)


@pytest.mark.parametrize("change, field, words", [
    ("stiffness = 50.0", "spring[0].stiffness", "stiffness must be >= 0, got -5.0"),
    ('to_link = "link2"', "spring[0].to_link", "does not exist"),
    ('from_link = "ground"', "spring[0].to_link", "must be another link than from_link (2)"),
    ("free_length = 1.0", "spring[0].free_length", "free length must be >= 0, got -1.0"),
    ("stiffness = 50.0", "spring[0].gas_column", "gas column"),
])
def test_bad_spring_is_refused_by_name(change, field, words):
    bad = {"stiffness = 50.0": "stiffness = -5.0", 'to_link = "link2"': 'to_link = "link7"',
           'from_link = "ground"': 'from_link = "link2"', "free_length = 1.0": "free_length = -1.0"}[change]
    if field.endswith("gas_column"):
        bad = "stiffness = 50.0\ngas_force = 10.0"
    with pytest.raises(SceneError) as err:
        load_scene(SLIDE.replace(change, bad))
    assert err.value.field == field and words in str(err.value)


def test_cli_refuses_a_negative_stiffness_in_one_line(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text(SLIDE.replace("stiffness = 50.0", "stiffness = -5.0"))
    run = subprocess.run([sys.executable, "-m", "grubler.cli", "simulate", str(scene)], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 2
    assert run.stderr.strip() == "grubler: error: spring[0].stiffness: stiffness must be >= 0, got -5.0"


def test_cli_writes_the_spring_columns(tmp_path):
    scene, csv = tmp_path / "slide.toml", tmp_path / "run.csv"
    scene.write_text(SLIDE)
    run = subprocess.run([sys.executable, "-m", "grubler.cli", "simulate", str(scene), "--t-end", "0.2", "--csv",
                          str(csv)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    heading = csv.read_text().splitlines()[0]
    assert "coil_force [N]" in heading and "coil_energy [J]" in heading and "coil_dissipation [W]" in heading


# -- the native mechanism FMU --------------------------------------------------------------------------

# every kind of element on one double pendulum: a gas strut from the ground to link 3, a torsion spring with
# friction at link 3's joint, a constant force and moment on link 2
ALL_KINDS = DOUBLE.replace("""[[spring]]
name = "tie\"""", """[[joint_spring]]
name = "hinge"
joint = "theta3"
stiffness = 15.0
free = 0.4
preload = 1.0
friction = 0.3
friction_speed = 0.5

[[point_load]]
name = "push"
link = "link2"
point = [0.7, 0.1]
force = [4.0, -2.0]
moment = 0.5

[[spring]]
name = "tie\"""").replace("""stiffness = 80.0
free_length = 0.4""", """stiffness = 40.0
free_length = 0.5
damping = 3.0
gas_force = 30.0
gas_column = 0.3
gas_exponent = 1.4""").replace('from_link = "link2"', 'from_link = "ground"').replace(
    "from_point = [0.3, 0.0]", "from_point = [0.6, -0.9]")


@pytest.fixture(scope="module")
def forces_fmu(tmp_path_factory):
    from grubler.fmi.build import export

    return export(load_scene(ALL_KINDS), tmp_path_factory.mktemp("fmu") / "Forces.fmu")


def _slave(path, name="forces", messages=None):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmi_child import recording_callbacks

    md = read_model_description(str(path))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    if messages is None:
        slave.instantiate()
    else:
        slave.instantiate(loggingOn=True, callbacks=recording_callbacks(
            lambda env, inst, status, cat, msg: messages.append(msg.decode())))
    return md, {v.name: v.valueReference for v in md.modelVariables}, slave


GROUPS = ("state", "dynamics", "energy", "reactions", "forces")


def test_fmu_equals_the_library_with_every_kind_of_element(forces_fmu):
    res = simulate(load_scene(ALL_KINDS), t_end=1.0, dt_out=0.1)
    columns = [c for c in res.columns if c.startswith(("tie_", "hinge_", "push_"))]
    assert len(columns) == 13  # six of the spring's, six of the joint spring's, the load's power
    md, vr, slave = _slave(forces_fmu)
    names = ["theta2", "theta3", "theta2_dd", "KE", "PE", "R1_Fx", "R2_Mz", *columns]
    rows = []
    try:
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        rows.append(slave.getReal([vr[c] for c in names]))
        for k in range(10):
            slave.doStep(0.1 * k, 0.1)
            rows.append(slave.getReal([vr[c] for c in names]))
    finally:
        slave.terminate()
        slave.freeInstance()
    got = np.array(rows)
    # the library stepped as the FMU steps: advance_to each communication point, then its outputs
    import grubler

    scene = load_scene(ALL_KINDS)
    sim = grubler.Simulator(scene.mechanism, method=scene.method, zd0=scene.initial_rates)
    want = [[sim.outputs(GROUPS)[c] for c in names]]
    for k in range(10):
        sim.advance_to((0.1 * k) + 0.1)
        want.append([sim.outputs(GROUPS)[c] for c in names])
    want = np.array(want)
    assert np.max(np.abs(got - want)) < 1e-10
    assert np.max(np.abs(want[:, : len(names)] - np.column_stack([res[c] for c in names]))) < 1e-6
    assert np.ptp(want[:, names.index("tie_force")]) > 1.0  # the strut works
    # its parameters are the scene's, named by the element; its outputs are states, with no feedthrough
    deps = {o.variable.name: o.dependencies for o in md.outputs}
    assert deps["tie_force"] == [] and deps["hinge_effort"] == []
    start = {v.name: v.start for v in md.modelVariables if v.causality == "parameter"}
    assert float(start["tie.gas_exponent"]) == 1.4 and int(start["hinge.link"]) == 3 and float(start["push.moment"]) == 0.5


@pytest.mark.parametrize("name, value, expected", [
    ("tie.stiffness", -1.0, "tie.stiffness: stiffness must be >= 0, got -1.0"),
    ("hinge.friction_speed", 0.0, "hinge.friction_speed: friction's regularising speed must be positive"),
    ("tie.to_link", 1, "tie.to_link: must be another link than from_link (1)"),
    ("tie.gas_column", 0.0, "tie.gas_column: a gas spring's gas column (V0 / A at the free length) must be "
                            "positive, got 0.0"),
    ("push.link", 1, "push.link must be in 2 .. 3, got 1"),  # the ground: the variable's range refuses it when set
    # the issue's three: a negative stiffness, a point on a link that does not exist, both ends on one link
    ("hinge.stiffness", -1.0, "hinge.stiffness: stiffness must be >= 0, got -1.0"),
    ("tie.to_link", 9, "tie.to_link must be in 1 .. 3, got 9"),
    ("hinge.link", 9, "hinge.link must be in 2 .. 3, got 9"),
    ("push.link", 9, "push.link must be in 2 .. 3, got 9"),
    ("tie.from_link", 3, "tie.to_link: must be another link than from_link (3)"),
])
def test_fmu_refuses_a_bad_element_by_its_parameter(forces_fmu, name, value, expected):
    messages = []
    md, vr, slave = _slave(forces_fmu, "bad", messages)
    try:
        slave.setupExperiment(startTime=0.0)
        with pytest.raises(Exception):
            if name.endswith("link"):
                slave.setInteger([vr[name]], [value])
            else:
                slave.setReal([vr[name]], [value])
            slave.enterInitializationMode()
            slave.exitInitializationMode()
    finally:
        slave.freeInstance()
    assert any(expected in m for m in messages), messages


def test_gas_used_up_at_the_start_is_refused_by_name(forces_fmu):
    # the strut's start length is 0.554 m: a free length of 0.9 m leaves the 0.3 m gas column -0.046 m
    bad = ALL_KINDS.replace("free_length = 0.5", "free_length = 0.9")
    with pytest.raises(SceneError) as err:
        simulate(load_scene(bad), t_end=0.1)
    assert err.value.field == "spring[0].gas_column" and "the gas is used up at the start" in str(err.value)
    messages = []
    md, vr, slave = _slave(forces_fmu, "used-up", messages)
    try:
        slave.setupExperiment(startTime=0.0)
        slave.setReal([vr["tie.free_length"]], [0.9])
        with pytest.raises(Exception):
            slave.enterInitializationMode()
            slave.exitInitializationMode()
    finally:
        slave.freeInstance()
    assert any("tie.gas_column: the gas is used up at the start" in m for m in messages), messages


# -- joint springs: a torsion spring at a revolute, a linear spring at a slide ---------------------------

# a bar on a ground pivot in a horizontal plane (no gravity), held by a torsion spring about theta2 = 0.3 rad,
# with its joint's viscous damper: I_O theta'' + c theta' + k (theta - 0.3) = 0
TORSION = """
name = "torsion-pendulum"
gravity = 0.0
[link2]
joint = "R"
a = 0.5
p = 0.25
m = 2.0
I = 0.04
damping = 0.05
[closure]
type = "none"
[initial]
theta2 = 0.8
[[joint_spring]]
name = "coil"
joint = "theta2"
stiffness = 3.0
free = 0.3
"""


def test_damped_torsional_pendulum_decays_as_its_closed_form():
    res = simulate(load_scene(TORSION), t_end=5.0, dt_out=0.01, rtol=1e-11, atol=1e-12)
    inertia = 0.04 + 2.0 * 0.25**2  # about the pivot
    w = math.sqrt(3.0 / inertia)
    zeta = 0.05 / (2 * inertia * w)
    wd = w * math.sqrt(1 - zeta**2)
    expected = 0.3 + 0.5 * np.exp(-zeta * w * res.t) * (np.cos(wd * res.t) + zeta * w / wd * np.sin(wd * res.t))
    assert np.max(np.abs(res["theta2"] - expected)) < 1e-8
    assert np.max(np.abs(res["coil_effort"] + 3.0 * (res["theta2"] - 0.3))) < 1e-12
    assert np.max(np.abs(res["coil_energy"] - 1.5 * (res["theta2"] - 0.3) ** 2)) < 1e-12
    # what the joint damper took is what the run lost (the spring's energy is in E)
    lost = res["E"][0] - res["E"]
    taken = cumulative_simpson(0.05 * res["theta2_d"] ** 2, x=res.t, initial=0.0)
    assert np.max(np.abs(lost - taken)) < 1e-7
    # the spring's moment is the pair's own: the pivot's reaction moment carries it and the damper's
    out = simulate(load_scene(TORSION), t_end=0.3, dt_out=0.1)
    assert np.max(np.abs(out["R1_Mz"] - (out["coil_effort"] - 0.05 * out["theta2_d"]))) < 1e-9


def test_torsion_spring_on_a_link_of_a_chain_acts_on_the_relative_angle():
    # at link 3 of a double pendulum the spring sees theta3 - theta2, and at rest its moment is the pair's
    scene = load_scene(DOUBLE.replace("""[[spring]]
name = "tie\"""", """[[joint_spring]]
name = "knee"
joint = "theta3"
stiffness = 7.0
free = -0.5
preload = 0.4
[[spring]]
name = "tie\"""").replace("stiffness = 80.0", "stiffness = 0.0"))
    m = scene.mechanism
    out = evaluate(m, "exact", 0.0, m.z_from_q(m.q_ref), np.zeros(2), Inputs(), ["dynamics", "reactions", "forces"])
    assert out["knee_position"] == pytest.approx(-1.2 - (-0.3), abs=1e-15)
    assert out["knee_effort"] == pytest.approx(0.4 - 7.0 * (-0.9 + 0.5), rel=1e-14)
    assert out["R2_Mz"] == pytest.approx(out["knee_effort"], rel=1e-12)  # what link 2 exerts on link 3


def test_linear_spring_at_a_slide_swings_as_the_spring_mass():
    # the block of SLIDE held by a joint spring on B1 instead of a spring between points
    scene = load_scene(SLIDE.split("[[spring]]")[0] + """[[joint_spring]]
name = "coil"
joint = "B1"
stiffness = 50.0
free = "0 m"
""")
    res = simulate(scene, t_end=2.0, dt_out=0.01, rtol=1e-11, atol=1e-12)
    assert np.max(np.abs(res["B1"] - 0.1 * np.cos(5.0 * res.t))) < 1e-8
    assert np.max(np.abs(res["E"] - 0.25)) < 1e-9


@pytest.mark.parametrize("table, field, words", [
    ('joint = "theta2"', "joint_spring[0].joint", "B1 is a locked (fictitious) coordinate"),
    ("stiffness = 3.0", "joint_spring[0].stiffness", "stiffness must be >= 0, got -3.0"),
    ("free = 0.3", "joint_spring[0].friction_speed", "friction's regularising speed must be positive, got 0.0"),
    ('joint = "theta2"', "joint_spring[0].joint", "unknown coordinate 'theta7'"),
])
def test_bad_joint_spring_is_refused_by_name(table, field, words):
    bad = {"stiffness = 3.0": "stiffness = -3.0", "free = 0.3": "free = 0.3\nfriction = 1.0\nfriction_speed = 0.0",
           'joint = "theta2"': 'joint = "B1"' if "B1" in words else 'joint = "theta7"'}[table]
    with pytest.raises(SceneError) as err:
        load_scene(TORSION.replace(table, bad))
    assert err.value.field == field and words in str(err.value)


# -- point loads ----------------------------------------------------------------------------------------

def test_point_load_holds_a_pendulum_where_its_moment_balances_gravity():
    # a bar on a ground pivot, a horizontal force F at its tip and a moment M: at rest where
    # M + r x F = m g p cos(theta) ... solved here by bisection; a damped run settles there
    scene = load_scene(TORSION.split("[[joint_spring]]")[0].replace("gravity = 0.0", "gravity = 9.81")
                       .replace("damping = 0.05", "damping = 0.8").replace("theta2 = 0.8", "theta2 = 0.0") + """
[[point_load]]
name = "wind"
link = "link2"
point = [0.5, 0.0]
force = [6.0, 0.0]
moment = 0.7
""")

    def moment(theta):  # about the pivot, counter-clockwise
        x, y = 0.5 * math.cos(theta), 0.5 * math.sin(theta)
        return 0.7 + (x * 0.0 - y * 6.0) - 2.0 * 9.81 * 0.25 * math.cos(theta)

    lo, hi = -math.pi / 2, math.pi / 2
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if moment(mid) > 0 else (lo, mid)
    res = simulate(scene, t_end=30.0, dt_out=0.5)
    assert res["theta2"][-1] == pytest.approx(lo, abs=1e-8)
    # the pivot holds the rest: R = -(F + m g)
    assert res["R1_Fx"][-1] == pytest.approx(-6.0, abs=1e-7) and res["R1_Fy"][-1] == pytest.approx(2 * 9.81, abs=1e-7)


def test_energy_balance_counts_a_load_s_work_in():
    scene = load_scene(ALL_KINDS)
    # the torsion spring swings link 3 fast (150 rad/s^2 at the start): a fine record for the quadrature
    res = simulate(scene, t_end=1.0, dt_out=0.0005, rtol=1e-12, atol=1e-12)
    work = cumulative_simpson(res["push_power"] - res["tie_dissipation"] - res["hinge_dissipation"], x=res.t,
                              initial=0.0)
    residue = res["E"] - res["E"][0] - work
    assert np.max(np.abs(cumulative_simpson(res["push_power"], x=res.t, initial=0.0))) > 0.1  # real work
    assert np.max(np.abs(residue)) < 1e-6
    # the load's power written here: F . v of its point + M w of its link
    t2, w2 = res["theta2"], res["theta2_d"]
    vx = (-0.7 * np.sin(t2) - 0.1 * np.cos(t2)) * w2
    vy = (0.7 * np.cos(t2) - 0.1 * np.sin(t2)) * w2
    assert np.max(np.abs(res["push_power"] - (4.0 * vx - 2.0 * vy + 0.5 * w2))) < 1e-10


def test_load_on_the_ground_is_refused_by_name():
    with pytest.raises(SceneError) as err:
        load_scene(TORSION + '[[point_load]]\nlink = "ground"\nforce = [1.0, 0.0]\n')
    assert err.value.field == "point_load[0].link" and "is the ground" in str(err.value)


# -- joint friction: a block on a slope --------------------------------------------------------------------

# a 1 kg block on a slide up a 30 degree slope (theta1 = 30 - 90 deg turns the slide axis up the slope), its
# joint's Coulomb friction regularised over 1 mm/s: gravity pulls it down the slope with m g sin 30 = 4.905 N
SLOPE = """
name = "block-on-slope"
[ground]
theta1 = "-60 deg"
[link2]
joint = "P"
a = 0.0
m = 1.0
[closure]
type = "none"
[[joint_spring]]
name = "contact"
joint = "B1"
friction = FRICTION
friction_speed = 0.001
"""


def test_block_slips_down_a_slope_as_the_hand_calculation():
    # friction 3 N < 4.905 N: it slides with a = -(m g sin 30 - F) / m once its speed dwarfs 1 mm/s
    res = simulate(load_scene(SLOPE.replace("FRICTION", "3.0")), t_end=1.0, dt_out=0.05)
    a = -(9.81 * 0.5 - 3.0)
    late = res.t >= 0.2
    assert np.max(np.abs(res["B1_dd"][late] - a)) < 1e-9
    # exact Coulomb friction gives v = a t; the regularisation lets it start a little faster (friction is below
    # F while |v| < a few v_eps): a constant lead of the order of F v_eps / (m |a|) = 1.6 mm/s
    lead = res["B1_d"][late] - a * res.t[late]
    assert np.ptp(lead) < 1e-9 and abs(lead[0]) < 3.0 * 0.001 / 1.905
    assert np.max(np.abs(res["contact_effort"][late] - 3.0)) < 1e-9  # friction opposes the motion, up the slope


def test_block_sticks_on_a_slope_and_creeps_as_the_regularisation_says():
    # friction 8 N > 4.905 N: exact Coulomb would hold it still; tanh(v / v_eps) holds it at the creep speed
    # where 8 tanh(v / v_eps) = 4.905: v = -v_eps artanh(4.905 / 8) = -0.713 mm/s, down the slope
    res = simulate(load_scene(SLOPE.replace("FRICTION", "8.0")), t_end=2.0, dt_out=0.1)
    creep = -0.001 * math.atanh(9.81 * 0.5 / 8.0)
    late = res.t >= 0.5
    assert np.max(np.abs(res["B1_d"][late] - creep)) < 1e-7  # 0.01 % of it
    # friction carries the load (to 1e-4 N: the explicit integrator rides the stiff friction law within its tolerance)
    assert np.max(np.abs(res["contact_effort"][late] - 4.905)) < 1e-3
    # how far it creeps: 1.4 mm in 2 s (a measure of the regularisation, in docs/scenes.md)
    assert res["B1"][-1] == pytest.approx(creep * 2.0, rel=1e-3)
    # and the friction's dissipation is the work of gravity down the slope
    # (over the steady creep: the record is too coarse for the first millisecond's transient)
    lost = res["E"][late][0] - res["E"][late][-1]
    assert lost == pytest.approx(float(np.trapezoid(res["contact_dissipation"][late], res.t[late])), rel=1e-4)


def test_animation_draws_a_spring_between_its_points(tmp_path):
    from PIL import Image

    from grubler.views.animation import SPRING_COLOUR, animate, frame_geometry, zigzag

    scene = load_scene(BOOM)
    geo = frame_geometry(scene.mechanism, scene.mechanism.z_from_q(scene.mechanism.q_ref))
    (p0, p1), = geo.springs
    theta = math.radians(20.0)
    assert tuple(p0) == (0.3, -0.4)
    assert tuple(p1) == pytest.approx((0.5 * math.cos(theta) - 0.05 * math.sin(theta),
                                       0.5 * math.sin(theta) + 0.05 * math.cos(theta)), abs=1e-15)
    zz = zigzag(p0, p1)
    assert tuple(zz[0]) == tuple(p0) and tuple(zz[-1]) == pytest.approx(tuple(p1))
    # a GIF frame holds the spring's colour
    res = simulate(scene, t_end=0.1, dt_out=0.05)
    out = tmp_path / "boom.gif"
    animate(scene.mechanism, res.t, res.z, str(out), fps=10, speed=1.0)
    frame = Image.open(out).convert("RGB")
    colour = tuple(int(SPRING_COLOUR[i: i + 2], 16) for i in (1, 3, 5))
    assert colour in {c for _, c in frame.getcolors(1 << 16)}


@pytest.mark.parametrize("name, words", [("link2", "is a scene table's name"), ("2bad", "must be a letter"),
                                         ("coil", "names another actuator or force element already")])
def test_element_names_that_would_clash_are_refused(name, words):
    text = SLIDE + f'[[joint_spring]]\nname = "{name}"\njoint = "B1"\n'
    with pytest.raises(SceneError) as err:
        load_scene(text)
    assert err.value.field == "joint_spring[0].name" and words in str(err.value)


def test_every_surface_reads_an_element_s_output_from_the_one_table():
    # the CSV headings, the app's menus and the FMU's variables take an element's unit and words from
    # grubler.quantities.FORCE_OUTPUTS
    from grubler.app import actions
    from grubler.fmi.mechanism import mechanism_spec
    from grubler.mechanism.simulate import force_kinds, output_columns, unit_of
    from grubler.quantities import fmi_text, fmi_unit, mechanism_output

    scene = load_scene(ALL_KINDS)
    m = scene.mechanism
    columns = output_columns(m, ("forces",))[1:]
    # the scene's springs, then its joint springs, then its loads, each in file order
    assert columns == ["tie_length", "tie_rate", "tie_force", "tie_energy", "tie_power", "tie_dissipation",
                       "hinge_position", "hinge_speed", "hinge_effort", "hinge_energy", "hinge_power",
                       "hinge_dissipation", "push_power"]
    declared = {v.name: v for v in mechanism_spec(scene).variables}
    for c in columns:
        q = mechanism_output(c, m.actuator_names, force_kinds(m))
        assert q is not None and unit_of(c) == q.unit, c
        assert actions.describe(c, m.actuator_names, force_kinds(m)).startswith(f"{q.label} ({c})"), c
        assert declared[c].unit == fmi_unit(q.unit) and declared[c].description == fmi_text(q), c
    assert mechanism_output("tie_force", (), force_kinds(m)).unit == "N"
    assert mechanism_output("hinge_effort", (), force_kinds(m)).unit == "N m or N"


def test_complex_step_twin_carries_every_kind_of_element():
    # the exact Jacobian of the state equation (linearisation, the implicit integrators) against central
    # differences of the real kernel, at a moving state where the gas, the damper and friction all act
    from grubler.mechanism.integrators import StateEquation

    scene = load_scene(ALL_KINDS)
    res = simulate(scene, t_end=0.3, dt_out=0.3)
    y = np.concatenate([res.z[-1], res.zd[-1]])
    ode = StateEquation(scene.mechanism, method="exact", drive=0.0, load=0.0)
    exact = ode.jacobian(0.3, y)
    h = 1e-6
    diff = np.column_stack([(ode(0.3, y + h * e) - ode(0.3, y - h * e)) / (2 * h) for e in np.eye(y.size)])
    assert np.max(np.abs(exact - diff)) < 1e-5 * np.max(np.abs(exact))
    # and the gas spring alone, whose force is a power of its column: its slope along the column
    without = load_scene(ALL_KINDS.replace("gas_force = 30.0", "gas_force = 0.0"))
    other = StateEquation(without.mechanism, method="exact", drive=0.0, load=0.0).jacobian(0.3, y)
    assert np.max(np.abs(exact - other)) > 1.0  # the gas changes the Jacobian: the twin computes its share
    # the torsion pendulum linearises to I s^2 + c s + k
    from grubler.studies.linearize import linearize

    sys_ = linearize(load_scene(TORSION.replace("[closure]", '[drive]\njoint = "theta2"\n[closure]')))
    inertia = 0.04 + 2.0 * 0.25**2
    assert np.sort_complex(np.linalg.eigvals(sys_.A)) == pytest.approx(
        np.sort_complex(np.roots([inertia, 0.05, 3.0])), abs=1e-9)


@pytest.mark.parametrize("flags", [[], ["-D__STDC_NO_COMPLEX__"]])
def test_fmu_sources_with_elements_are_strict_c99(forces_fmu, tmp_path, flags):
    # what Visual Studio's C lacks (complex arithmetic, arrays sized at run time): the elements' tables and the
    # complex-step twin's exp, log and tanh compile without them
    import zipfile

    from test_platforms import STRICT, importer_build

    zipfile.ZipFile(forces_fmu).extractall(tmp_path / "u")
    try:
        importer_build(tmp_path / "u", *STRICT, *flags)
    except subprocess.CalledProcessError as exc:
        pytest.fail(f"the sources do not compile as strict C99 {flags}:\n{exc.stderr}")


def test_animation_draws_a_load_as_an_arrow_onto_its_point(tmp_path):
    from PIL import Image

    from grubler.views.animation import LOAD_COLOUR, animate, frame_geometry

    scene = load_scene(ALL_KINDS)
    geo = frame_geometry(scene.mechanism, scene.mechanism.z_from_q(scene.mechanism.q_ref))
    (p, u), = geo.loads
    t2 = -0.3
    assert tuple(p) == pytest.approx((0.7 * math.cos(t2) - 0.1 * math.sin(t2), 0.7 * math.sin(t2) + 0.1 * math.cos(t2)))
    assert tuple(u) == pytest.approx((4.0 / math.hypot(4, 2), -2.0 / math.hypot(4, 2)))
    res = simulate(scene, t_end=0.1, dt_out=0.05)
    out = tmp_path / "all.gif"
    animate(scene.mechanism, res.t, res.z, str(out), fps=10, speed=1.0)
    colour = tuple(int(LOAD_COLOUR[i: i + 2], 16) for i in (1, 3, 5))
    assert colour in {c for _, c in Image.open(out).convert("RGB").getcolors(1 << 16)}


# the thesis four-bar with a spring from a ground point to its coupler, a torsion spring with friction at its
# rocker, a load on its rocker: a closed loop carries the elements too
FOURBAR = """
name = "sprung-fourbar"
[link2]
joint = "R"
a = 0.2
p = 0.1
m = 1.0
I = 0.1
[link3]
joint = "R"
a = 0.8
p = 0.4
m = 2.0
I = 0.2
[link4]
joint = "R"
a = 0.8
p = 0.4
m = 3.0
I = 0.3
[closure]
type = "revolute"
point = [1.0, 0.0]
[drive]
joint = "theta2"
torque = 3.0
[initial]
theta3 = "60 deg"
theta4 = "-60 deg"
theta2_d = 2.0
[[spring]]
name = "return"
from_link = "ground"
from_point = [0.5, 0.8]
to_link = "link3"
to_point = [0.4, 0.0]
stiffness = 400.0
free_length = 0.3
damping = 5.0
[[joint_spring]]
name = "hinge"
joint = "theta4"
stiffness = 2.0
free = 1.0
friction = 0.4
friction_speed = 0.2
[[point_load]]
name = "push"
link = "link4"
point = [0.6, 0.0]
force = [0.0, -20.0]
moment = 1.5
"""


def test_inverse_dynamics_gives_back_the_drive_torque_with_elements_in_a_loop():
    from grubler.mechanism.dynamics import forward_dynamics, inverse_dynamics

    scene = load_scene(FOURBAR)
    m = scene.mechanism
    res = simulate(scene, t_end=0.4, dt_out=0.2)
    for z, zd in zip(res.z, res.zd):
        dyn = forward_dynamics(m, z, zd, Inputs(drive=3.0))
        drive, _ = inverse_dynamics(m, z, zd, dyn.zdd)
        assert drive == pytest.approx(3.0, rel=1e-9)
    # and the loop's energy balance: E + losses (the damper's, the friction's) - work in (the drive's, the
    # load's) stays E(0)
    res = simulate(scene, t_end=1.0, dt_out=0.0005, rtol=1e-12, atol=1e-12)
    power = res["P_drive"] + res["push_power"] - res["return_dissipation"] - res["hinge_dissipation"]
    residue = res["E"] - res["E"][0] - cumulative_simpson(power, x=res.t, initial=0.0)
    assert np.max(np.abs(residue)) < 1e-6


def test_a_sweep_sets_an_element_s_numbers_by_its_name():
    from grubler.mechanism.scene import override, parameter, parameter_names
    from grubler.studies.sweep import scene_point_units

    scene = load_scene(FOURBAR)
    names = parameter_names(scene)
    assert {"return.stiffness", "return.gas_column", "hinge.friction", "push.force_y", "push.moment"} <= set(names)
    stiffer = override(scene, {"return.stiffness": 800.0, "return.free_length": "25 cm", "push.force_y": -5.0,
                               "hinge.friction": 0.0})
    spring, hinge, push = stiffer.mechanism.forces
    assert (spring.stiffness, spring.free_length, push.force, hinge.friction) == (800.0, 0.25, (0.0, -5.0), 0.0)
    assert parameter(stiffer, "push.force_y") == -5.0 and parameter(scene, "return.stiffness") == 400.0
    units = scene_point_units(scene, ["return.stiffness", "hinge.stiffness", "hinge.free", "push.moment"])
    assert [units[n] for n in ("return.stiffness", "hinge.stiffness", "hinge.free", "push.moment")] == \
        ["N/m", "N m/rad", "rad", "N m"]
    with pytest.raises(SceneError) as err:  # the values go through the scene's own rules
        override(scene, {"return.stiffness": -1.0})
    assert err.value.field == "spring[0].stiffness"
    with pytest.raises(SceneError) as err:  # a length is a length
        override(scene, {"return.free_length": "30 deg"})
    assert err.value.field == "return.free_length"


def test_a_sweep_point_s_energy_balance_counts_the_elements():
    from grubler.studies.sweep import scene_point

    out = scene_point(FOURBAR, 0.5, **{"return.stiffness": 800.0})
    assert out["energy_balance"] < 0.01  # J: the trapezoid's error on a 10 ms grid (2.7 J with the elements left out)


def test_animation_draws_a_torsion_spring_as_a_coil_at_its_joint_turning_with_its_link(tmp_path):
    # the geometry the GIF and the app's page both draw: the coil at the pin, its outer end along the link
    from PIL import Image

    from grubler.views.animation import SPRING_COLOUR, animate, coil, frame_geometry

    scene = load_scene(TORSION)
    m = scene.mechanism
    geo = frame_geometry(m, m.z_from_q(m.q_ref))
    (centre, angle), = geo.coils
    assert tuple(centre) == (0.0, 0.0) and angle == pytest.approx(0.8) and geo.springs == []
    spiral = coil(centre, 0.1, angle)
    assert spiral[-1] == pytest.approx([0.1 * math.cos(0.8), 0.1 * math.sin(0.8)])
    assert np.hypot(*spiral[0]) == pytest.approx(0.025)  # from a quarter of its radius, at the pin
    res = simulate(scene, t_end=0.1, dt_out=0.05)
    out = tmp_path / "coil.gif"
    animate(m, res.t, res.z, str(out), fps=10, speed=1.0)
    colour = tuple(int(SPRING_COLOUR[i: i + 2], 16) for i in (1, 3, 5))
    assert colour in {c for _, c in Image.open(out).convert("RGB").getcolors(1 << 16)}


# -- the ComputedTorque FMU: the drive's demand holds the elements' efforts -------------------------------

# the thesis four-bar loaded by every kind of element: a spring from a ground point to the coupler, a torsion
# spring with friction at the rocker's joint, a constant force and moment on the crank
SPRUNG_FOURBAR = (Path(grubler.__file__).parent / "presets" / "thesis-fourbar.toml").read_text().replace(
    'name = "thesis-fourbar"', 'name = "sprung-fourbar"') + """
[[spring]]
name = "tie"
from_link = "ground"
from_point = [0.5, 0.9]
to_link = "link3"
to_point = [0.4, 0.0]
stiffness = 300.0
free_length = 0.5
damping = 4.0

[[joint_spring]]
name = "hinge"
joint = "theta4"
stiffness = 20.0
free = -1.0
friction = 0.8
friction_speed = 0.5

[[point_load]]
name = "push"
link = "link2"
point = [0.2, 0.0]
force = [0.0, -30.0]
moment = 1.5
"""


@pytest.fixture(scope="module")
def sprung_ct_fmu(tmp_path_factory):
    from grubler.controllers.native_fmu import export_computed_torque

    path, params = export_computed_torque(load_scene(SPRUNG_FOURBAR), tmp_path_factory.mktemp("ct"))
    return path, params


def test_computed_torque_fmu_holds_the_force_elements_as_the_library_does(sprung_ct_fmu):
    from grubler.controllers import ComputedTorque

    path, params = sprung_ct_fmu
    assert path.name == "ComputedTorque_sprung_fourbar.fmu"
    assert params["tie.stiffness"] == 300.0 and params["hinge.link"] == 4 and params["push.moment"] == 1.5
    scene = load_scene(SPRUNG_FOURBAR)
    z0 = float(scene.mechanism.z_from_q(scene.mechanism.q_ref)[0])
    samples = [(z0 + 0.4 * math.sin(0.3 * k), 4.0 * math.cos(0.3 * k), -12.0 * math.sin(0.3 * k)) for k in range(12)]
    md, vr, slave = _slave(path, "ct")
    got = []
    try:
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        for k, (x, v, a) in enumerate(samples):
            slave.setReal([vr["position"], vr["velocity"], vr["acceleration"]], [x, v, a])
            slave.doStep(0.01 * k, 0.01)
            got.append(slave.getReal([vr["torque"]])[0])
    finally:
        slave.terminate()
        slave.freeInstance()
    ct = ComputedTorque(scene)
    want = np.array([ct.drive_torque(*s) for s in samples])
    assert np.max(np.abs(np.array(got) - want)) < 1e-9
    # the elements matter here: the same four-bar without them needs other torques, by newtons-metres
    bare = ComputedTorque(load_scene("thesis-fourbar"))
    assert np.min(np.abs(want - np.array([bare.drive_torque(*s) for s in samples]))) > 0.5


@pytest.mark.parametrize("name, value, expected", [
    ("tie.stiffness", -1.0, "tie.stiffness: stiffness must be >= 0, got -1.0"),
    ("hinge.friction_speed", 0.0, "hinge.friction_speed: friction's regularising speed must be positive"),
    ("tie.to_link", 1, "tie.to_link: must be another link than from_link (1)"),
    ("tie.from_link", 3, "tie.to_link: must be another link than from_link (3)"),
    ("hinge.stiffness", -1.0, "hinge.stiffness: stiffness must be >= 0, got -1.0"),
    ("tie.to_link", 9, "tie.to_link must be in 1 .. 4, got 9"),
    ("push.link", 1, "push.link must be in 2 .. 4, got 1"),
])
def test_computed_torque_fmu_refuses_a_bad_element_by_its_parameter(sprung_ct_fmu, name, value, expected):
    messages = []
    md, vr, slave = _slave(sprung_ct_fmu[0], "bad-ct", messages)
    try:
        slave.setupExperiment(startTime=0.0)
        with pytest.raises(Exception):
            if name.endswith("link"):
                slave.setInteger([vr[name]], [value])
            else:
                slave.setReal([vr[name]], [value])
            slave.enterInitializationMode()
            slave.exitInitializationMode()
    finally:
        slave.freeInstance()
    assert any(expected in m for m in messages), messages


def test_computed_torque_fmu_sources_with_elements_are_strict_c99(sprung_ct_fmu, tmp_path):
    import zipfile

    from test_platforms import STRICT, importer_build

    zipfile.ZipFile(sprung_ct_fmu[0]).extractall(tmp_path / "u")
    try:
        importer_build(tmp_path / "u", *STRICT, "-D__STDC_NO_COMPLEX__")
    except subprocess.CalledProcessError as exc:
        pytest.fail(f"the sources do not compile as strict C99:\n{exc.stderr}")


# a gas strut on the sprung four-bar whose column the sketch has used up: free length 2 m, column 0.1 m, at a
# length of 0.56 m; its force is not finite there, and no demand can be met
USED_UP = SPRUNG_FOURBAR.replace("damping = 4.0", "damping = 4.0\ngas_force = 10.0\ngas_column = 0.1\n"
                                                   "gas_exponent = 1.4").replace("free_length = 0.5",
                                                                                 "free_length = 2.0")


def test_computed_torque_refuses_a_used_up_gas_spring_by_name_not_with_a_nan():
    from grubler.controllers import ComputedTorque
    from grubler.mechanism.inverse import drive_demand

    with pytest.raises(SceneError) as err:
        ComputedTorque(load_scene(USED_UP))
    assert err.value.field == "spring[0].gas_column" and "the gas is used up" in err.value.reason
    # along a crank turn the strut shortens from 0.563 m to 0.462 m (sample 13 of 73): a 0.02 m column, 0.083 m
    # at the start, runs out on the way, and the sample where it does is named
    m = load_scene(SPRUNG_FOURBAR.replace("damping = 4.0", "damping = 4.0\ngas_force = 10.0\ngas_column = 0.02\n"
                                                           "gas_exponent = 1.4")).mechanism
    pos = float(m.z_from_q(m.q_ref)[0]) + np.linspace(0.0, 2 * math.pi, 73)
    with pytest.raises(SceneError) as err:
        drive_demand(m, pos, np.ones_like(pos), np.zeros_like(pos))
    assert err.value.field == "spring[0].gas_column"
    k = int(err.value.reason.split("at trajectory sample ")[1].split()[0])
    assert 0 < k < 13


def test_computed_torque_fmu_refuses_a_used_up_gas_spring_by_its_parameter(sprung_ct_fmu):
    messages = []
    md, vr, slave = _slave(sprung_ct_fmu[0], "gas-ct", messages)
    try:
        slave.setupExperiment(startTime=0.0)
        slave.setReal([vr["tie.gas_force"], vr["tie.gas_column"], vr["tie.gas_exponent"], vr["tie.free_length"]],
                      [10.0, 0.1, 1.4, 2.0])
        with pytest.raises(Exception):
            slave.enterInitializationMode()
            slave.exitInitializationMode()
    finally:
        slave.freeInstance()
    assert any(m.startswith("tie.gas_column: the gas is used up at the sketch") for m in messages), messages


# the issue's three refusals (a negative stiffness, a point on a link that does not exist, both ends on one link),
# for every kind of element, through the command line: exit 2 and one line naming the field
FOURBAR_TEXT = (Path(grubler.__file__).parent / "presets" / "thesis-fourbar.toml").read_text()
SPRING_ROWS = 'from_link = "ground"\nfrom_point = [0.5, 0.9]\nto_link = "link3"\nto_point = [0.4, 0.0]\n'


@pytest.mark.parametrize("element, line", [
    ("[[spring]]\n" + SPRING_ROWS + "stiffness = -5.0\nfree_length = 0.5",
     "spring[0].stiffness: stiffness must be >= 0, got -5.0"),
    ("[[joint_spring]]\njoint = \"theta4\"\nstiffness = -2.0",
     "joint_spring[0].stiffness: stiffness must be >= 0, got -2.0"),
    ("[[spring]]\n" + SPRING_ROWS.replace('"link3"', '"link7"') + "stiffness = 5.0\nfree_length = 0.5",
     "spring[0].to_link: link 7 does not exist"),
    ("[[point_load]]\nlink = \"link7\"\npoint = [0.1, 0.0]\nforce = [1.0, 0.0]",
     "point_load[0].link: link 7 does not exist"),
    ("[[joint_spring]]\njoint = \"theta7\"\nstiffness = 2.0", "joint_spring[0].joint: unknown coordinate 'theta7'"),
    ("[[spring]]\n" + SPRING_ROWS.replace('"ground"', '"link3"') + "stiffness = 5.0\nfree_length = 0.5",
     "spring[0].to_link: must be another link than from_link (3)"),
])
def test_cli_refuses_the_issues_bad_elements_by_name(tmp_path, capsys, element, line):
    from grubler.cli import main as cli

    scene = tmp_path / "bad.toml"
    scene.write_text(FOURBAR_TEXT + "\n" + element + "\n")
    assert cli(["simulate", str(scene), "--t-end", "0.01"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("grubler: error: " + line) and "\n" not in err, err
