"""Physics checks against references that share no arithmetic with grubler:
conservation laws, closed-form solutions, an independent Newton-Euler
free-body solve (tests/reference.py) and a separate static analysis."""

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.interpolate
import scipy.optimize
import scipy.special

import grubler
from grubler import Closure, Link, Mechanism, Simulator
from grubler.mechanism.assembly import assemble
from reference import RefChain


def states(res, i):
    names = res.model.coordinate_names
    q = np.array([res[x][i] for x in names])
    qd = np.array([res[x + "_d"][i] for x in names])
    qdd = np.array([res[x + "_dd"][i] for x in names])
    return q, qd, qdd


def reference_energy(res, idx):
    ref = RefChain.of(res.model)
    out = []
    for i in idx:
        q, qd, _ = states(res, i)
        ke, pe = ref.energy(q, qd)
        out.append(ke + pe)
    return np.array(out)


@pytest.mark.parametrize("preset, t_end", [
    ("triple-pendulum", 10.0),
    ("thesis-fourbar", 20.0),
    ("thesis-slider-crank", 10.0),
    ("thesis-double-slider", 10.0),
    ("fourbar-parallelogram", 10.0),
])
def test_conservative_scenes_keep_their_energy(preset, t_end):
    res = grubler.simulate(preset, t_end=t_end, dt_out=0.05)
    idx = np.linspace(0, len(res.t) - 1, 25).astype(int)
    energy = reference_energy(res, idx)
    swing = max(np.ptp(res["KE"]), 1.0)  # energy exchanged between kinetic and potential
    # the reference differentiates numerically (~1e-9 relative); the drift must be below it
    assert np.max(np.abs(energy - energy[0])) < 2e-7 * swing
    # and the library's own bookkeeping agrees with the reference at each point
    assert np.allclose(res["E"][idx], energy, atol=2e-7 * swing)


def test_long_run_energy_drift_and_closure():
    res = grubler.simulate("thesis-fourbar", t_end=100.0, dt_out=1.0)
    e = res["E"]
    assert np.max(np.abs(e - e[0])) < 1e-7 * e[0]
    assert np.max(res["closure_error"]) < 1e-11


def test_parallelogram_swings_as_a_simple_pendulum():
    # all three masses ride on unit circles with the crank's angle: a 1 m pendulum
    res = grubler.simulate("fourbar-parallelogram", t_end=6.0, dt_out=2e-3)
    amplitude = math.radians(30)
    period = 4 * math.sqrt(1.0 / 9.81) * scipy.special.ellipk(math.sin(amplitude / 2) ** 2)
    rate = scipy.interpolate.CubicSpline(res.t, res["theta2_d"])
    turning = [t for t in rate.roots(extrapolate=False) if t > 0.1]
    assert len(turning) >= 4
    measured = np.diff([0.0] + turning[:4]) * 2
    assert np.allclose(measured, period, rtol=1e-8)
    # and the coupler translates: theta3 stays 0
    assert np.max(np.abs(res["theta3"])) < 1e-10


@pytest.mark.parametrize("tilt_deg", [0.0, 30.0])
def test_slide_is_a_free_fall_along_its_axis(tilt_deg):
    tilt = math.radians(tilt_deg)
    mech = Mechanism(links=(Link("P", a=0.1, p=0.05, m=2.0, I=0.01),), q_ref=(0.5, 0.3), theta1=tilt)
    sim = Simulator(mech)
    for t in (0.5, 1.0, 2.0):
        sim.advance_to(t)
        # the slide axis e_perp(theta1) makes angle theta1 with the vertical
        expected = 0.5 - 0.5 * 9.81 * math.cos(tilt) * t**2
        assert sim.z[0] == pytest.approx(expected, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("preset, closure, torque", [
    ("thesis-fourbar", ("revolute", None), 3.0),
    ("thesis-slider-crank", ("prismatic", 0.0), 3.0),
    ("thesis-quick-return", ("revolute", None), 2.0),
    ("thesis-swinging-block", ("revolute", None), 2.0),
    ("thesis-scotch-yoke", ("revolute", None), 1.0),
    ("thesis-oldham", ("revolute", None), 3.0),
    ("thesis-double-slider", ("prismatic", math.pi / 2), 11.38),
    ("thesis-conchoidal", ("prismatic", 0.0), 2.0),
    ("fourbar-crank-rocker", ("revolute", None), None),
])
def test_forward_then_newton_euler_reproduces_the_applied_forces(preset, closure, torque):
    scene = grubler.load_scene(preset)
    res = grubler.simulate(scene, t_end=1.0, dt_out=0.25, torque=torque)
    applied = scene.torque if torque is None else torque
    ref = RefChain.of(scene.mechanism)
    pair = scene.mechanism.free_names.index(scene.mechanism.drive)
    for i in range(1, len(res.t)):
        q, qd, qdd = states(res, i)
        out = ref.newton_euler(q, qd, qdd, closure, pair)
        scale = 1.0 + abs(applied) + np.max(np.abs(out["closure"]))
        assert out["residual"] < 1e-9 * scale
        assert out["drive"] == pytest.approx(applied, abs=1e-5 * scale)
        lib = (res["Fx"][i], res["Fy"][i], res["Mz"][i])
        assert np.allclose(lib, out["closure"], atol=1e-5 * scale)


def test_joint_reactions_match_newton_euler_on_a_four_bar():
    scene = grubler.load_scene("fourbar-crank-rocker")
    res = grubler.simulate(scene, t_end=0.6, dt_out=0.2)
    ref = RefChain.of(scene.mechanism)
    for i in range(1, len(res.t)):
        q, qd, qdd = states(res, i)
        out = ref.newton_euler(q, qd, qdd, ("revolute", None), 0)
        for k in range(3):
            lib = (res[f"R{k + 1}_Fx"][i], res[f"R{k + 1}_Fy"][i])
            assert np.allclose(lib, out["pair_force"][k], atol=1e-5 * (1 + np.abs(lib).max()))
        # the moment a revolute passes on is its own torque: drive minus damping
        assert res["R1_Mz"][i] == pytest.approx(scene.torque - 0.15 * res["theta2_d"][i], abs=1e-9)
        assert abs(res["R2_Mz"][i]) < 1e-9 and abs(res["R3_Mz"][i]) < 1e-9


def test_damped_four_bar_settles_where_a_separate_static_analysis_says():
    scene = grubler.load_scene("thesis-fourbar-damped")
    res = grubler.simulate(scene, t_end=60.0, dt_out=0.5)
    assert abs(res["theta2_d"][-1]) < 1e-6
    ref = RefChain.of(scene.mechanism)

    def closed(th2, guess):
        def residual(x):
            q = [0, th2, 0, x[0], 0, x[1]]
            d = ref.tip(q) - 1.0
            return [d.real, d.imag]
        return scipy.optimize.least_squares(residual, guess, xtol=1e-15, ftol=1e-15, gtol=1e-15).x

    guess = [res["theta3"][-1], res["theta4"][-1]]

    def potential(th2):
        th3, th4 = closed(th2, guess)
        q = [0, th2, 0, th3, 0, th4]
        return sum(l["m"] * 9.81 * ref.centre(q, k).imag for k, l in enumerate(ref.links))

    found = scipy.optimize.minimize_scalar(potential, bracket=(res["theta2"][-1] - 0.05, res["theta2"][-1] + 0.05),
                                           tol=1e-12)
    assert res["theta2"][-1] == pytest.approx(found.x, abs=1e-6)
    th3, th4 = closed(found.x, guess)
    q = np.array([0, found.x, 0, th3, 0, th4])
    static = ref.newton_euler(q, np.zeros(6), np.zeros(6), ("revolute", None), None)
    assert np.allclose((res["Fx"][-1], res["Fy"][-1]), static["closure"][:2], atol=1e-5)


def test_penalty_closure_converges_to_the_exact_one_as_the_gain_grows():
    scene = grubler.load_scene("thesis-fourbar")
    m = scene.mechanism
    z, zd = assemble(m, m.z_from_q(m.q_ref))
    exact = grubler.simulate(scene, t_end=1.0, dt_out=0.01)
    errors, closure = [], []
    for gain in (1e4, 1e5, 1e6):
        cl = m.closures[0]
        stiff = m.replace(closures=(Closure(cl.kind, cl.link, cl.point, cl.to_link, cl.to_point,
                                            gain=gain, damping=100.0),), q_ref=tuple(m.q_from_z(z)))
        res = grubler.simulate(grubler.mechanism.scene.with_overrides(scene, mechanism=stiff), t_end=1.0, dt_out=0.01,
                               method="penalty", rtol=1e-8, atol=1e-10)
        errors.append(np.max(np.abs(res["theta2"] - exact["theta2"])))
        closure.append(np.max(res["closure_error"]))
        # closure error is the constraint force over the gain
        force = np.hypot(res["Fx"], res["Fy"])
        assert np.max(res["closure_error"]) < 2.0 * np.max(force) / gain
    assert errors[0] > 5 * errors[1] > 25 * errors[2]
    assert closure[0] > 5 * closure[1] > 25 * closure[2]


def test_dead_centre_crossings_keep_the_loop_closed():
    res = grubler.simulate("thesis-fourbar-dead-centre", t_end=1.0, dt_out=0.01)
    assert np.all(np.isfinite(res["theta2"]))
    assert res["theta2"][-1] > 4 * math.pi  # it went round, through every dead centre
    assert np.max(res["closure_error"]) < 1e-10


def test_change_point_linkage_passes_its_aligned_positions():
    # s + l = p + q: the links align, the closure's Jacobian loses rank and two
    # assembly branches meet.  The motion goes on along its own branch (it used
    # to stop here by name at t = 0.571 s), and each passage is recorded.
    res = grubler.simulate("fourbar-change-point", t_end=10.0, dt_out=0.01)
    assert np.max(res["closure_error"]) < 1e-10
    passages = res.stats["passages"]
    assert len(passages) >= 2 and abs(passages[0] - 0.571) < 0.01
    # energy: what the 0.5 N m drive put in, nothing lost at the passages
    work = 0.5 * (res["theta2"] - res["theta2"][0])
    balance = res["E"] - res["E"][0] - work
    assert np.max(np.abs(balance)) < 1e-6 * np.max(res["KE"])


def test_a_failed_advance_leaves_the_simulator_where_it_was():
    # a step limit so small that 10 steps cannot reach the target: the advance
    # fails, and the state is the one before it
    scene = grubler.load_scene("thesis-fourbar")
    sim = Simulator(scene.mechanism, max_step=1e-4)
    sim.advance_to(0.01)
    before = (sim.t, sim.z.copy(), sim.zd.copy())
    with pytest.raises(grubler.IntegrationError, match="more than 10 steps"):
        sim._integ.advance_to(0.1, max_steps=10)
    assert (sim.t, list(sim.z), list(sim.zd)) == (before[0], list(before[1]), list(before[2]))
    sim.advance_to(0.02)  # and it goes on from there
    assert sim.t == 0.02


def test_drive_inertia_is_a_flywheel_on_a_ground_pivoted_crank():
    # the crank turns about the ground pivot, so a rotor inertia J reflected onto its
    # joint must act exactly as J added to the crank's own centroidal inertia
    base = grubler.load_scene("thesis-fourbar")
    J = 0.05
    m = base.mechanism
    with_rotor = m.replace(drive_inertia=J)
    heavier_crank = m.replace(links=(replace(m.links[0], I=m.links[0].I + J),) + m.links[1:])
    runs = []
    for model in (with_rotor, heavier_crank):
        sim = Simulator(model, inputs=grubler.Inputs(3.0, 0.0))
        runs.append([sim.advance_to(t) or sim.z.copy() for t in (0.5, 1.0, 2.0)])
    np.testing.assert_allclose(runs[0], runs[1], atol=1e-8)
    # and it really changes the motion
    free = Simulator(m, inputs=grubler.Inputs(3.0, 0.0))
    free.advance_to(1.0)
    assert abs(free.z[0] - runs[0][1][0]) > 1e-2


def test_negative_drive_inertia_is_refused_by_name():
    with pytest.raises(grubler.SceneError, match="drive.inertia"):
        grubler.load_scene("thesis-fourbar").mechanism.replace(drive_inertia=-1.0)


def test_damped_thesis_four_bar_rests_where_its_geometry_puts_the_least_potential():
    """The thesis's damped four-bar (1 kg at B, C and D) comes to rest at the minimum of
    a potential written from the drawing alone: B on the crank circle, C where circles of
    0.8 m about B and 0.6 m about D = (1, 0) meet, D fixed; V = g (y_B + y_C)."""
    scene = grubler.load_scene("thesis-fourbar-damped")
    assert [(lk.a, lk.p, lk.m, lk.I) for lk in scene.mechanism.links] == [
        (0.3, 0.3, 1.0, 0.0), (0.8, 0.8, 1.0, 0.0), (0.6, 0.6, 1.0, 0.0)]
    D = np.array([1.0, 0.0])

    def joints(t2):
        B = 0.3 * np.array([math.cos(t2), math.sin(t2)])
        d = np.linalg.norm(D - B)
        u = (D - B) / d
        along = (0.8 ** 2 - 0.6 ** 2 + d ** 2) / (2 * d)
        # the branch the crank starts in: C above the line B -> D (a crank-rocker never leaves it)
        return B, B + along * u + math.sqrt(0.8 ** 2 - along ** 2) * np.array([-u[1], u[0]])

    def potential(t2):
        B, C = joints(t2)
        return 9.81 * (B[1] + C[1])   # D's kilogram does not move

    grid = np.linspace(-math.pi, math.pi, 721)
    values = [potential(t) for t in grid]
    start = grid[int(np.argmin(values))]
    rest = scipy.optimize.minimize_scalar(potential, bracket=(start - 0.02, start + 0.02), tol=1e-12).x
    assert math.degrees(rest) == pytest.approx(-112.58, abs=0.01)   # MODEL.md: "near -112 deg"
    res = grubler.simulate(scene, t_end=60.0, dt_out=60.0)
    assert abs(res["theta2_d"][-1]) < 1e-6
    assert res["theta2"][-1] == pytest.approx(rest, abs=1e-7)
    B, C = joints(rest)
    assert math.atan2(*(C - B)[::-1]) == pytest.approx(res["theta3"][-1], abs=1e-6)
