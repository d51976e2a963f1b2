"""A linear actuator in the mechanism: its line, its generalised force, its work, its statics, its FMU.

The references share no code with the kernel: the points' positions are
written here from the absolute angles (a serial chain of revolutes), the
generalised force is the virtual work of the force over finite-difference
displacements, and the static equilibrium is a moment balance about the pivot
solved by bisection.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from grubler.errors import SceneError
from grubler.mechanism.dynamics import Inputs, forward_dynamics, joint_reactions
from grubler.mechanism.assembly import assemble
from grubler.mechanism.scene import load_scene, preset_text
from grubler.mechanism.simulate import simulate

# the thesis four-bar with a cylinder from a ground point to its coupler
FOURBAR = preset_text("thesis-fourbar") + """
[[actuator]]
name = "lift"
from_link = "ground"
from_point = [0.5, -0.5]
to_link = "link3"
to_point = [0.4, 0.1]
"""

# a triple pendulum with a strut between its first and third links
PENDULUM = """
name = "pendulum-strut"
[link2]
joint = "R"
a = 1.0
p = 0.5
m = 1.0
I = 0.05
[link3]
joint = "R"
a = 0.8
p = 0.4
m = 1.5
I = 0.08
[link4]
joint = "R"
a = 0.6
p = 0.3
m = 0.5
I = 0.02
[initial]
theta2 = 0.3
theta3 = -0.4
theta4 = 0.9
[[actuator]]
name = "strut"
from_link = 2
from_point = [0.3, 0.1]
to_link = "link4"
to_point = [0.5, -0.05]
"""

# one link on a ground pivot, held up by a cylinder from a ground point below it
BOOM = """
name = "boom"
[link2]
joint = "R"
a = 2.0
p = 1.0
m = 10.0
I = 3.0
damping = 40.0
[initial]
theta2 = 0.2
[[actuator]]
name = "cylinder"
from_link = "ground"
from_point = [0.6, -0.8]
to_link = "link2"
to_point = [1.2, -0.1]
"""


def _e(th):
    return np.array([math.cos(th), math.sin(th)])


def _eperp(th):
    return np.array([-math.sin(th), math.cos(th)])


def point_position(a: list[float], angles, link: int, local) -> np.ndarray:
    """World position of ``local`` on ``link`` (thesis numbering, 1 the ground) of a serial chain of
    revolutes from the origin with vectors ``a``, from the absolute angles: written here, not the kernel's."""
    if link == 1:
        return np.asarray(local, dtype=float)
    o = np.zeros(2)
    for k in range(2, link):
        o = o + a[k - 2] * _e(angles[k - 2])
    th = angles[link - 2]
    return o + local[0] * _e(th) + local[1] * _eperp(th)


def actuator_length(model, angles) -> float:
    act = model.actuators[0]
    a = [link.a for link in model.links]
    p = point_position(a, angles, act.from_link, act.from_point)
    q = point_position(a, angles, act.to_link, act.to_point)
    return float(np.hypot(*(q - p)))


def absolute_angles(z) -> np.ndarray:
    """A serial chain of revolutes from the ground at theta1 = 0: theta_k is the sum of the relative angles."""
    return np.cumsum(z)


@pytest.mark.parametrize("text", [FOURBAR, PENDULUM])
def test_length_and_rate_against_finite_differences_of_the_positions(text):
    scene = load_scene(text)
    m = scene.mechanism
    res = simulate(scene, t_end=0.6, dt_out=0.1, actuator_forces={m.actuator_names[0]: 40.0})
    name = m.actuator_names[0]
    h = 1e-6
    for i in range(len(res.t)):
        th = np.array([res[f"theta{k}"][i] for k in range(2, m.n_links + 2)])
        w = np.array([res[f"theta{k}_d"][i] for k in range(2, m.n_links + 2)])
        length = actuator_length(m, th)
        rate = (actuator_length(m, th + h * w) - actuator_length(m, th - h * w)) / (2 * h)
        assert res[f"{name}_length"][i] == pytest.approx(length, abs=1e-12)
        assert res[f"{name}_rate"][i] == pytest.approx(rate, abs=1e-7 * max(1.0, abs(rate)))
    assert np.ptp(res[f"{name}_rate"]) > 0.1  # the actuator moved: the comparison means something


@pytest.mark.parametrize("text", [FOURBAR, PENDULUM])
def test_generalised_force_is_the_virtual_work_of_the_force(text):
    m = load_scene(text).mechanism
    z, zd = assemble(m, m.z_from_q(m.q_ref), np.array([0.7, -0.2, 0.4]))
    force = 123.0
    free = forward_dynamics(m, z, zd, Inputs())
    pushed = forward_dynamics(m, z, zd, Inputs(actuators=(force,)))
    # the virtual work F dL over a small displacement of each joint, by central differences
    h = 1e-6
    g = np.array([force * (actuator_length(m, absolute_angles(z + h * e))
                           - actuator_length(m, absolute_angles(z - h * e))) / (2 * h) for e in np.eye(m.n_free)])
    # M dzdd = g + J^T dlambda: the component along the closures' null space is g's alone
    lhs = free.M @ (pushed.zdd - free.zdd)
    if m.closures:
        J = pushed.ck.J
        null = np.linalg.svd(J)[2][J.shape[0]:].T
        lhs, g = null.T @ lhs, null.T @ g
    assert np.max(np.abs(g)) > 10.0
    np.testing.assert_allclose(lhs, g, rtol=1e-7, atol=1e-7 * force)


@pytest.mark.parametrize("text", [FOURBAR, PENDULUM])
def test_energy_balance_counts_the_actuator_work(text):
    scene = load_scene(text)
    name = scene.mechanism.actuator_names[0]
    force = 60.0
    res = simulate(scene, t_end=2.0, dt_out=0.002, actuator_forces={name: force})
    e, length = res["E"], res[f"{name}_length"]
    # a constant force's work is exact: F (L - L0); the chain is undamped, the drive idle
    work = force * (length - length[0])
    assert np.max(np.abs(work)) > 5.0
    assert np.max(np.abs(e - e[0] - work)) < 1e-6 * np.max(np.abs(work))
    # the library's energy balance (trapezoid rule over the record) agrees to its quadrature error
    from grubler.views.report import energy_balance

    cols = {c: res[c] for c in res.columns}
    assert np.max(np.abs(energy_balance(cols, scene.mechanism))) < 1e-2 * np.max(np.abs(work))
    # without the actuator's work the balance would be off by all of it
    cols[f"{name}_power"] = 0.0 * cols[f"{name}_power"]
    assert np.max(np.abs(energy_balance(cols, scene.mechanism))) > 0.5 * np.max(np.abs(work))


def _boom_moment(theta: float, force: float, model) -> float:
    """Moment about the pivot of gravity and the cylinder on the boom at angle theta (cross products)."""
    link, act = model.links[0], model.actuators[0]
    centre = link.p * _e(theta) + link.q * _eperp(theta)
    tip = act.to_point[0] * _e(theta) + act.to_point[1] * _eperp(theta)
    base = np.asarray(act.from_point)
    u = (tip - base) / np.hypot(*(tip - base))
    def cross(r, f):
        return r[0] * f[1] - r[1] * f[0]

    return cross(centre, [0.0, -link.m * model.gravity]) + cross(tip, force * u)


def test_static_equilibrium_against_a_moment_balance():
    scene = load_scene(BOOM)
    m = scene.mechanism
    force = 100.0
    # the separate statics solve: the moment about the pivot vanishes (bisection over a bracket)
    lo, hi = -0.5, 0.3
    assert _boom_moment(lo, force, m) * _boom_moment(hi, force, m) < 0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _boom_moment(lo, force, m) * _boom_moment(mid, force, m) <= 0:
            hi = mid
        else:
            lo = mid
    theta_star = 0.5 * (lo + hi)
    res = simulate(scene, t_end=30.0, dt_out=0.5, actuator_forces={"cylinder": force})
    assert res["theta2"][-1] == pytest.approx(theta_star, abs=1e-6)
    assert abs(res["theta2_d"][-1]) < 1e-6
    # the pivot carries what the weight and the cylinder leave: R + F u + m g = 0
    th = res["theta2"][-1]
    tip = np.asarray(m.actuators[0].to_point[0]) * _e(th) + m.actuators[0].to_point[1] * _eperp(th)
    u = (tip - np.asarray(m.actuators[0].from_point)) / np.hypot(*(tip - np.asarray(m.actuators[0].from_point)))
    dyn = forward_dynamics(m, res.z[-1], res.zd[-1], Inputs(actuators=(force,)))
    reaction = joint_reactions(m, dyn, Inputs(actuators=(force,)))[0]
    np.testing.assert_allclose(reaction[:2], np.array([0.0, m.links[0].m * m.gravity]) - force * u, atol=1e-5)


def test_reactions_balance_each_link_with_the_actuator():
    """Newton for the whole open chain: the ground pivot's reaction, the actuator's two forces
    (equal and opposite: internal) and gravity give the mass centres' accelerations."""
    scene = load_scene(PENDULUM)
    m = scene.mechanism
    z = m.z_from_q(m.q_ref)
    zd = np.array([0.5, -0.3, 0.8])
    inputs = Inputs(actuators=(75.0,))
    dyn = forward_dynamics(m, z, zd, inputs)
    reactions = joint_reactions(m, dyn, inputs)
    # mass-centre accelerations by finite differences of their positions along the motion
    a = [link.a for link in m.links]

    def centres(zz):
        th = absolute_angles(zz)
        return np.array([point_position(a, th, k + 2, (link.p, link.q)) for k, link in enumerate(m.links)])

    h = 1e-4
    acc = (centres(z + h * zd + 0.5 * h * h * dyn.zdd) - 2 * centres(z)
           + centres(z - h * zd + 0.5 * h * h * dyn.zdd)) / (h * h)
    total = sum(link.m * acc[k] for k, link in enumerate(m.links))
    weight = np.array([0.0, -m.gravity * sum(link.m for link in m.links)])
    np.testing.assert_allclose(reactions[0][:2] + weight, total, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("change, field", [
    (('to_link = "link3"', 'to_link = "link9"'), "actuator[0].to_link"),
    (('from_link = "ground"', 'from_link = "shed"'), "actuator[0].from_link"),
    (('to_link = "link3"', 'to_link = "ground"'), "actuator[0].to_link"),
    (('name = "lift"', 'name = "2lift"'), "actuator[0].name"),
    (('to_point = [0.4, 0.1]', 'to_point = [0.4]'), "actuator[0].to_point"),
    (('to_point = [0.4, 0.1]', 'to_point = [0.4, "x"]'), "actuator[0].to_point"),
    (('name = "lift"\n', ''), "actuator[0].name"),
])
def test_bad_actuators_are_refused_naming_the_field(change, field):
    with pytest.raises(SceneError) as exc:
        load_scene(FOURBAR.replace(*change))
    assert exc.value.field == field, str(exc.value)


def test_an_actuator_of_zero_length_at_the_start_is_refused():
    # the cylinder's ground point put on the boom's point at the start (theta2 = 0.2)
    tip = 1.2 * _e(0.2) - 0.1 * _eperp(0.2)
    text = BOOM.replace("from_point = [0.6, -0.8]", f"from_point = [{float(tip[0])!r}, {float(tip[1])!r}]")
    with pytest.raises(SceneError) as exc:
        simulate(text, t_end=0.1)
    assert exc.value.field == "actuator[0].to_point" and "coincide" in exc.value.reason


def test_two_actuators_of_one_name_are_refused():
    text = FOURBAR + FOURBAR[FOURBAR.index("[[actuator]]"):]
    with pytest.raises(SceneError) as exc:
        load_scene(text)
    assert exc.value.field == "actuator[1].name"


def test_an_unknown_actuator_force_is_refused():
    with pytest.raises(SceneError) as exc:
        simulate(FOURBAR, t_end=0.1, actuator_forces={"lfit": 3.0})
    assert exc.value.field == "actuator_forces" and "lift" in exc.value.reason


def test_cli_simulate_takes_a_constant_force_and_refuses_bad_ones(tmp_path):
    scene = tmp_path / "lift.toml"
    scene.write_text(FOURBAR)
    out = tmp_path / "run.csv"
    run = [sys.executable, "-m", "grubler.cli", "simulate", str(scene), "--t-end", "0.3"]
    ok = subprocess.run(run + ["--actuator-force", "lift=50", "--csv", str(out)], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    heading = out.read_text().splitlines()[0].split(",")
    assert {"lift_length [m]", "lift_rate [m/s]", "lift_force [N]", "lift_power [W]"} <= set(heading)
    for bad in (["--actuator-force", "lift"], ["--actuator-force", "lift=abc"], ["--actuator-force", "nope=3"]):
        r = subprocess.run(run + bad, capture_output=True, text=True)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    zero = subprocess.run(run + ["--csv", str(out)], capture_output=True, text=True)  # no force given: 0
    assert zero.returncode == 0
    col = heading.index("lift_force [N]")
    assert all(float(row.split(",")[col]) == 0.0 for row in out.read_text().splitlines()[1:])


# -- the native mechanism FMU --------------------------------------------------------------------------

@pytest.fixture(scope="module")
def lift_fmu(tmp_path_factory):
    from grubler.fmi.build import export

    return export(load_scene(FOURBAR), tmp_path_factory.mktemp("fmu") / "FourbarLift.fmu")


def _slave(path, tolerance=None):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="lift")
    slave.instantiate()
    if tolerance is not None:
        vr = {v.name: v.valueReference for v in md.modelVariables}
        slave.setReal([vr["rtol"], vr["atol"]], [tolerance, tolerance])
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    return md, {v.name: v.valueReference for v in md.modelVariables}, slave


@pytest.mark.slow
def test_fmu_takes_the_force_and_gives_length_and_rate_as_the_library(lift_fmu):
    md, vr, slave = _slave(lift_fmu)
    try:
        slave.setReal([vr["lift_force"]], [50.0])
        for k in range(10):
            slave.doStep(0.1 * k, 0.1)
        length, rate, theta2 = slave.getReal([vr["lift_length"], vr["lift_rate"], vr["theta2"]])
    finally:
        slave.terminate()
        slave.freeInstance()
    res = simulate(FOURBAR, t_end=1.0, dt_out=0.1, actuator_forces={"lift": 50.0})
    assert length == pytest.approx(res["lift_length"][-1], abs=1e-8)
    assert rate == pytest.approx(res["lift_rate"][-1], abs=1e-7)
    assert theta2 == pytest.approx(res["theta2"][-1], abs=1e-7)


@pytest.mark.slow
def test_fmu_dependencies_and_directional_derivatives_of_the_force(lift_fmu):
    md, vr, slave = _slave(lift_fmu)
    deps = {o.variable.name: {d.name for d in (o.dependencies or [])} for o in md.outputs}
    assert deps["lift_length"] == set() and deps["lift_rate"] == set()  # kinematics of the state
    assert "lift_force" in deps["theta2_dd"] and "lift_force" in deps["R1_Fx"] and "lift_force" in deps["Fx"]
    try:
        slave.setReal([vr["lift_force"]], [20.0])
        for k in range(3):
            slave.doStep(0.1 * k, 0.1)
        unknowns = [vr["theta2_dd"], vr["Fx"], vr["R2_Mz"], vr["lift_length"]]
        slope = slave.getDirectionalDerivative(unknowns, [vr["lift_force"]], [1.0])
        h = 1e-3
        slave.setReal([vr["lift_force"]], [20.0 + h])
        up = np.array(slave.getReal(unknowns))
        slave.setReal([vr["lift_force"]], [20.0 - h])
        down = np.array(slave.getReal(unknowns))
    finally:
        slave.terminate()
        slave.freeInstance()
    # the outputs are linear in the force at a fixed state: central differences are exact to rounding
    np.testing.assert_allclose(slope, (up - down) / (2 * h), rtol=1e-6, atol=1e-8)
    assert abs(slope[0]) > 1e-3 and slope[3] == 0.0


@pytest.mark.slow
def test_fmu_refuses_an_actuator_on_one_link_or_of_zero_length(lift_fmu):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmi_child import recording_callbacks

    md = read_model_description(str(lift_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    where = extract(str(lift_fmu))
    for name, value, expected in (("lift.from_link", 3, "lift.to_link: must be another link than from_link"),
                                  ("lift.from_point_x", None, "lift.to_point_x: the actuator's two points coincide")):
        messages = []
        slave = FMU2Slave(guid=md.guid, unzipDirectory=where, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName="bad")
        slave.instantiate(loggingOn=True, callbacks=recording_callbacks(
            lambda env, inst, status, cat, msg: messages.append(msg.decode())))
        try:
            slave.setupExperiment(startTime=0.0)
            if value is None:  # the ground point onto the coupler's point at the assembled start
                res = simulate(FOURBAR, t_end=0.01, dt_out=0.01)
                th = res["theta3"][0]
                x = 0.2 * _e(res["theta2"][0]) + 0.4 * _e(th) + 0.1 * _eperp(th)
                slave.setReal([vr["lift.from_point_x"], vr["lift.from_point_y"]], list(x))
            else:
                slave.setInteger([vr[name]], [value])
            with pytest.raises(Exception):
                slave.enterInitializationMode()
                slave.exitInitializationMode()
        finally:
            slave.freeInstance()
        assert any(expected in m for m in messages), messages


@pytest.mark.slow
def test_fmu_rollback_replays_a_step_under_its_actuator_force(lift_fmu):
    """The force a held derivative was computed with is part of the saved state: a restored run that
    steps under another force, then under the first again, repeats the first exactly."""
    md, vr, slave = _slave(lift_fmu, tolerance=1e-3)
    try:
        slave.setReal([vr["lift_force"]], [30.0])
        slave.doStep(0.0, 0.05)
        state = slave.getFMUstate()
        slave.doStep(0.05, 0.05)
        first = slave.getReal([vr["theta2"], vr["lift_length"], vr["lift_rate"]])
        slave.setFMUstate(state)
        slave.setReal([vr["lift_force"]], [-80.0])
        slave.doStep(0.05, 0.05)
        other = slave.getReal([vr["theta2"]])
        slave.setFMUstate(state)
        slave.setReal([vr["lift_force"]], [30.0])
        slave.doStep(0.05, 0.05)
        again = slave.getReal([vr["theta2"], vr["lift_length"], vr["lift_rate"]])
        slave.freeFMUstate(state)
    finally:
        slave.terminate()
        slave.freeInstance()
    assert again == first
    # the step under the other force is the library's: the derivative held from the first force was not reused
    from grubler.mechanism.simulate import Simulator

    m = load_scene(FOURBAR).mechanism
    sim = Simulator(m, rtol=1e-3, atol=1e-3, inputs=Inputs(actuators=(30.0,)))
    sim.advance_to(0.05)
    sim.set_inputs(actuators=[-80.0])
    sim.advance_to(0.1)
    # (at a loose tolerance, where a stale derivative would show)
    assert other[0] == pytest.approx(float(m.q_from_z(sim.z)[1]), abs=1e-12)
