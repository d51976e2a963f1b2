"""grubler.linearize against references that share no code with it.

- the parallelogram's small-oscillation frequency against the simple pendulum's;
- the damped four-bar's poles against a one-degree-of-freedom model derived here by
  hand (closed-form position analysis, energy method, no kernel call);
- the complex-step Jacobians against central differences of the nonlinear model in
  minimal coordinates built from other library code (assembly, forward dynamics);
- the linear model against the nonlinear simulation for small perturbations, the
  error shrinking as the square of the amplitude;
- python-control's feedback and step_response on the result;
- clear errors for operating points that do not exist or are not isolated.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
from dataclasses import replace
from sys import executable as PYTHON

import control
import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
import scipy.optimize

import grubler
from grubler import SceneError
from grubler.mechanism.assembly import assemble, constraint
from grubler.mechanism.dynamics import Inputs, forward_dynamics, joint_reactions
from grubler.studies.linearize import linearize, operating_point, to_json
from grubler.motors import DCMotor, Gearbox, MotorState, load_motor, shaft_torque
from grubler.motors import linearization as motor_linearization
from grubler.motors import step as motor_step

import toggle_scenario

G = 9.81


def _motor(ratio=50.0):
    return DCMotor(load_motor("maxon-re40-148877"), Gearbox(ratio, 0.9))


# -- the parallelogram is a pendulum ------------------------------------------------
@pytest.mark.parametrize("length", [1.0, 0.4])
def test_parallelogram_swings_at_the_pendulum_frequency(tmp_path, length):
    # every moving mass of a parallelogram moves on a circle of the crank's radius,
    # synchronously: a simple pendulum of length l, omega = sqrt(g / l)
    text = (grubler.mechanism.scene.resources.files("grubler").joinpath("presets/fourbar-parallelogram.toml").read_text()
            .replace("a = 1.0", f"a = {length}").replace("p = 1.0", f"p = {length}")
            .replace("p = 0.5", f"p = {length / 2}").replace("point = [1.0, 0.0]", f"point = [{length}, 0.0]"))
    path = tmp_path / "para.toml"
    path.write_text(text)
    sys = linearize(str(path), at="equilibrium")
    poles = sys.poles()
    assert sys.nstates == 2
    np.testing.assert_allclose(np.abs(poles.real), 0.0, atol=1e-9)
    np.testing.assert_allclose(np.sort(poles.imag), [-math.sqrt(G / length), math.sqrt(G / length)], rtol=1e-10)
    assert sys.operating_point.coordinates["theta2"] == pytest.approx(-math.pi / 2, abs=1e-10)


# -- the damped four-bar against a hand-derived one-DOF model ----------------------------
def _hand_fourbar(scene, branch_theta3):
    """Positions of every mass centre as functions of the crank angle, by circle intersection."""
    m = scene.mechanism
    (l2, l3, l4), D = [lk for lk in m.links], np.array(m.closures[0].to_point)
    a2, a3, a4 = l2.a, l3.a, l4.a

    def pose(t2):
        B = a2 * np.array([math.cos(t2), math.sin(t2)])
        d = np.linalg.norm(D - B)
        x = (a3 ** 2 - a4 ** 2 + d ** 2) / (2 * d)
        h = math.sqrt(a3 ** 2 - x ** 2)
        u = (D - B) / d
        best = None
        for sgn in (1, -1):
            C = B + x * u + sgn * h * np.array([-u[1], u[0]])
            t3 = math.atan2(*(C - B)[::-1])
            gap = abs(math.remainder(t3 - branch_theta3, 2 * math.pi))
            if best is None or gap < best[0]:
                best = (gap, C, t3)
        _, C, t3 = best
        t4 = math.atan2(*(D - C)[::-1])
        e = lambda t: np.array([math.cos(t), math.sin(t)])  # noqa: E731
        return [l2.p * e(t2), B + l3.p * e(t3), C + l4.p * e(t4)]

    masses = [l2.m, l3.m, l4.m]
    assert all(lk.I == 0 and lk.q == 0 for lk in m.links)  # point masses: no rotary inertia to add
    V = lambda t: G * sum(mk * r[1] for mk, r in zip(masses, pose(t)))  # noqa: E731

    def J(t, h=1e-6):
        rp, rm = pose(t + h), pose(t - h)
        return sum(mk * np.sum(((a - b) / (2 * h)) ** 2) for mk, a, b in zip(masses, rp, rm))

    return V, J, l2.damping


def test_damped_fourbar_poles_match_a_hand_derived_one_dof_model():
    scene = grubler.load_scene("thesis-fourbar-damped")
    sys = linearize(scene)
    op = sys.operating_point
    V, J, c = _hand_fourbar(scene, op.coordinates["theta3"])
    dV = lambda t, h=1e-5: (V(t + h) - V(t - h)) / (2 * h)  # noqa: E731
    t_star = scipy.optimize.brentq(dV, op.coordinates["theta2"] - 0.2, op.coordinates["theta2"] + 0.2, xtol=1e-14)
    assert op.coordinates["theta2"] == pytest.approx(t_star, abs=1e-8)
    h = 1e-4
    k = (V(t_star + h) - 2 * V(t_star) + V(t_star - h)) / h ** 2
    j = J(t_star)
    hand = np.roots([j, c, k])  # J dd + c d + k x = 0
    np.testing.assert_allclose(np.sort_complex(sys.poles()), np.sort_complex(hand), rtol=1e-6)
    # and the simulation settles where the hand model's potential is least
    res = grubler.simulate(scene, t_end=60.0, dt_out=60.0)
    assert res["theta2"][-1] == pytest.approx(t_star, abs=1e-7)


# -- Jacobians against finite differences -------------------------------------------
def _nonlinear(scene, ind, y_ref):
    """xdot and outputs of the nonlinear model in minimal coordinates, from assembly and forward dynamics."""
    model = scene.mechanism
    n = model.n_links

    def state(x):
        z = y_ref[:n].copy()
        z[ind] = x[:len(ind)]
        z, _ = assemble(model, z)
        _, Jc = constraint(model, z)
        dep = [i for i in range(n) if i not in ind]
        zd = np.zeros(n)
        zd[ind] = x[len(ind):]
        zd[dep] = np.linalg.solve(Jc[:, dep], -Jc[:, ind] @ x[len(ind):])
        return z, zd

    def f(x, drive, load=0.0):
        z, zd = state(x)
        dyn = forward_dynamics(model, z, zd, Inputs(drive, load))
        reac = joint_reactions(model, dyn, Inputs(drive, load))
        q = model.q_from_z(z)
        outputs = np.array([q[model.coordinate_names.index("theta3")], (model.S @ zd)[5], dyn.lam[0],
                            reac[1, 1], (model.S @ dyn.zdd)[3]])
        return np.r_[zd[ind], dyn.zdd[ind]], outputs

    return f


def test_jacobians_match_central_differences_of_the_nonlinear_model():
    scene = grubler.load_scene("thesis-fourbar")
    outputs = ["theta3", "theta4_d", "Fx", "R2_Fy", "theta3_dd"]
    # a moving point: 3 N m for 0.4 s from the initial configuration
    sys = linearize(scene, at="t=0.4", torque=3.0, outputs=outputs)
    op = sys.operating_point
    assert op.kind == "trajectory" and abs(op.zd[0]) > 1.0
    ind = [scene.mechanism.free_names.index(s) for s in op.independent]
    x0 = np.r_[op.z[ind], op.zd[ind]]
    f = _nonlinear(scene, ind, np.r_[op.z, op.zd])
    h = 1e-5  # the central difference's best: truncation (h^2) below 1e-9 here, rounding (1/h) too
    A, C = np.empty((2, 2)), np.empty((len(outputs), 2))
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        (fp, gp), (fm, gm) = f(x0 + e, 3.0), f(x0 - e, 3.0)
        A[:, k], C[:, k] = (fp - fm) / (2 * h), (gp - gm) / (2 * h)
    (fp, gp), (fm, gm) = f(x0, 3.0 + h), f(x0, 3.0 - h)
    B, D = (fp - fm) / (2 * h), (gp - gm) / (2 * h)
    err = lambda exact, fd: np.abs(exact - fd).max() / np.abs(exact).max()  # noqa: E731
    # measured: 9e-10, 5e-10, 2e-10, 6e-10 (the differences' own error)
    assert err(sys.A, A) < 1e-8
    assert err(sys.B[:, 0], B) < 1e-8
    assert err(sys.C, C) < 1e-8
    assert err(sys.D[:, 0], D) < 1e-8


def test_motor_partials_match_the_c_models_own_differences():
    motor = _motor()
    # a slow shaft (motor speed 2.5 rad/s, inside the friction's smoothing band) so
    # that every term of the torque law counts
    speed = 0.05
    lin = motor_linearization(motor, MotorState(2.0, 25.0), speed)
    h, w = 1e-6, motor.gear.ratio * speed
    dtau_di = (shaft_torque(motor, 2.0 + h, w) - shaft_torque(motor, 2.0 - h, w)) / (2 * h)
    dtau_dw = (shaft_torque(motor, 2.0, w + h) - shaft_torque(motor, 2.0, w - h)) / (2 * h) * motor.gear.ratio
    assert lin.dtau_di == pytest.approx(dtau_di, rel=1e-7)
    assert lin.dtau_dspeed == pytest.approx(dtau_dw, rel=1e-6)
    assert abs(lin.dtau_dspeed) > 0.1  # friction and the gearbox's direction blend are in it
    # the winding: the current after a very short step from i, at voltage v and speed w
    dt = 1e-9

    def didt(i, v, speed):
        s, _ = motor_step(motor, MotorState(i, 25.0), v, speed, dt)
        return (s.current - i) / dt

    base = didt(2.0, 10.0, 3.0)
    assert lin.di_di == pytest.approx((didt(2.5, 10.0, 3.0) - base) / 0.5, rel=1e-4)
    assert lin.di_dspeed == pytest.approx((didt(2.0, 10.0, 4.0) - base) / 1.0, rel=1e-4)
    assert lin.di_dvoltage == pytest.approx((didt(2.0, 12.0, 3.0) - base) / 2.0, rel=1e-4)


# -- the linear model against the nonlinear simulation ---------------------------------
def test_linear_model_predicts_small_perturbations_to_second_order():
    scene = grubler.load_scene("thesis-fourbar-damped")
    sys = linearize(scene, outputs=["theta2", "theta3"])
    op = sys.operating_point
    model = scene.mechanism
    t = np.linspace(0.0, 1.5, 31)
    errors = []
    for eps in (2e-2, 1e-2, 5e-3):
        z0 = op.z.copy()
        z0[0] += eps
        z0, _ = assemble(model, z0)
        sim = grubler.Simulator(model, z0=z0, rtol=1e-12, atol=1e-13)
        zs, _ = sim.advance_through(t)
        q = np.array([model.q_from_z(z) for z in zs])
        dx0 = np.array([eps, 0.0])
        lin = np.array([sys.C @ scipy.linalg.expm(sys.A * tk) @ dx0 for tk in t])
        nonlin = q[:, [1, 3]] - [op.coordinates["theta2"], op.coordinates["theta3"]]
        errors.append(np.abs(nonlin - lin).max())
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(3.5 < r < 4.5 for r in ratios), (errors, ratios)
    assert errors[-1] < 5e-3 * 5e-3 * 10


def test_motor_model_predicts_a_small_voltage_step_to_second_order():
    # the gearbox's loss changes direction and the dry friction turns over within
    # omega_s (10 rad/s at the motor, 0.2 rad/s at the crank): a linear range far
    # smaller than any useful step, so they are left out here (their partials are
    # checked above) and what is checked is the coupling of winding and linkage
    data = load_motor("maxon-re40-148877").replace(coulomb_friction=0.0)
    motor = DCMotor(data, Gearbox(50.0, 1.0))
    scene = grubler.load_scene("thesis-fourbar-damped")
    sys = linearize(scene, motor=motor, outputs=["theta2", "current"])
    op = sys.operating_point
    assert sys.state_labels == ["theta2", "theta2_d", "current"]
    assert op.voltage == pytest.approx(data.resistance * op.current, rel=1e-12)  # at rest: v = R i
    # the nonlinear plant as one ODE: the mechanism from assembly and forward
    # dynamics, the winding L di/dt = v - R i - k_e N w from the data sheet's
    # constants, the torque from the C motor model's nonlinear law
    heavy = replace(scene, mechanism=scene.mechanism.replace(drive_inertia=motor.reflected_inertia))
    f = _nonlinear(heavy, [0], np.r_[op.z, op.zd])
    N = motor.gear.ratio

    def rhs(t, s, v):
        tau = shaft_torque(motor, s[2], N * s[1])
        xdot, _ = f(s[:2], tau)
        return [xdot[0], xdot[1], (v - data.resistance * s[2] - data.back_emf_constant * N * s[1]) / data.inductance]

    t = np.linspace(0.0, 0.5, 51)
    errors = []
    for dv in (0.4, 0.2, 0.1):
        sol = scipy.integrate.solve_ivp(rhs, (0, t[-1]), [op.z[0], 0.0, op.current], method="Radau", t_eval=t,
                                        args=(op.voltage + dv,), rtol=1e-11, atol=1e-12)
        lin = control.forced_response(sys[0, 0], t, np.full(t.size, dv)).outputs
        errors.append(float(np.abs(sol.y[0] - op.z[0] - lin).max()))
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(3.5 < r < 4.5 for r in ratios), (errors, ratios)


# -- python-control on the result -----------------------------------------------------
def test_feedback_and_step_response_behave():
    motor = _motor()
    sys = linearize("thesis-fourbar", at={"theta2": 0.5}, motor=motor)
    assert sys.input_labels == ["voltage"] and sys.output_labels == ["theta2"]
    K = 50.0
    loop = control.feedback(K * sys, 1)
    expected = np.linalg.eigvals(sys.A - K * sys.B @ sys.C)
    np.testing.assert_allclose(np.sort_complex(loop.poles()), np.sort_complex(expected), rtol=1e-9)
    assert all(p.real < 0 for p in loop.poles())
    resp = control.step_response(loop, T=np.linspace(0, 2.0, 2001))
    assert resp.outputs[-1] == pytest.approx(float(np.squeeze(loop.dcgain())), rel=1e-4)
    # the closed loop's DC gain is K P(0) / (1 + K P(0)) of the plant's own
    p0 = float(np.squeeze(sys.dcgain()))
    assert float(np.squeeze(loop.dcgain())) == pytest.approx(K * p0 / (1 + K * p0), rel=1e-10)


def test_json_holds_matrices_names_and_operating_point():
    sys = linearize("thesis-fourbar-damped", outputs=["theta2", "Fx"])
    d = to_json(sys)
    assert np.allclose(d["A"], sys.A) and np.allclose(d["C"], sys.C)
    assert d["states"] == ["theta2", "theta2_d"] and d["outputs"] == ["theta2", "Fx"] and d["inputs"] == ["tau_drive"]
    assert d["operating_point"]["kind"] == "equilibrium"
    assert d["units"]["Fx"] == "N" and d["units"]["tau_drive"] == "N m"


def test_open_chain_has_all_its_coordinates_as_states():
    sys = linearize("triple-pendulum", at="equilibrium")
    assert sys.nstates == 6
    # three undamped modes: purely imaginary poles
    np.testing.assert_allclose(sys.poles().real, 0.0, atol=1e-8)


# -- the equilibrium is where a damped release comes to rest ----------------------------
RELEASE_DAMPING = 1.0  # N m s/rad on every joint: overdamped, so the release rolls down into the nearest well
SIX_BARS = ["watt-i", "watt-ii", "stephenson-i", "stephenson-ii", "stephenson-iii"]
FOUR_BARS = ["thesis-fourbar", "thesis-fourbar-damped", "fourbar-crank-rocker", "fourbar-double-rocker",
             "fourbar-triple-rocker", "fourbar-change-point", "fourbar-parallelogram"]


def _released(name):
    """Where the scene, released at rest from its start under no drive effort with every joint
    damped, comes to rest: the integrator's small steps keep the assembly branch, and a crank
    that meets a toggle turns back while the rest swings on."""
    from grubler.mechanism.scene import override

    scene = grubler.load_scene(name)
    damped = override(scene, {f"link{k}.damping": RELEASE_DAMPING for k in range(2, scene.mechanism.n_links + 2)})
    res = grubler.simulate(damped, t_end=60.0, dt_out=60.0, torque=0.0, rtol=1e-10, atol=1e-10)
    assert np.abs(res.zd[-1]).max() < 1e-8  # at rest
    return res.z[-1]


def _same_pose(a, b):
    """Largest difference of two joint-coordinate vectors, angles modulo a turn."""
    return np.abs(np.remainder(np.asarray(a) - np.asarray(b) + math.pi, 2 * math.pi) - math.pi).max()


@pytest.mark.parametrize("name", SIX_BARS)
def test_six_bar_equilibrium_is_where_its_damped_release_rests_with_the_body_models_poles(name):
    # the search walks its steps by continuity, so it stays on the scene's branch
    # (a 0.5 rad crank step closed by Newton from afar took the Stephenson I to
    # another branch, theta2 = -126.5 deg instead of -99.5 deg); the poles are
    # the independent body model's, sqrt(d2PE/dphi2 / v^T M v) at that pose,
    # with v = dx/dphi along its own closed configurations (phi the crank angle)
    from test_sixbar import crank_stiffness, reference, world_of

    sys = linearize(name, torque=0.0)
    op = sys.operating_point
    assert _same_pose(op.z, _released(name)) < 1e-8
    m = grubler.load_scene(name).mechanism
    ref, x_lib = reference(name, world_of(name, m, op.z))
    assert np.abs(ref.rest(x_lib + 1e-3 * np.sin(np.arange(len(x_lib)))) - x_lib).max() < 1e-6
    _, stiffness, inertia = crank_stiffness(name, m, op.z)
    wn = math.sqrt(stiffness / inertia)
    np.testing.assert_allclose(np.sort(sys.poles().imag), [-wn, wn], rtol=1e-6)
    np.testing.assert_allclose(sys.poles().real, 0.0, atol=1e-9 * wn)


def test_stephenson_i_rests_below_its_crank_pivot_on_the_scenes_branch():
    # the figures of the report: -99.530 deg with poles +-20.0313j (the other
    # branch's -126.513 deg swings at 10.64 rad/s)
    sys = linearize("stephenson-i", torque=0.0)
    assert math.degrees(sys.operating_point.coordinates["theta2"]) == pytest.approx(-99.530, abs=1e-3)
    assert np.abs(sys.poles()).max() == pytest.approx(20.0313, abs=1e-4)


@pytest.mark.parametrize("name", FOUR_BARS)
def test_four_bar_equilibrium_is_where_its_damped_release_rests(name):
    # the double-rocker's crank meets a toggle on the way down: the search changes
    # to a coordinate that still determines the others there, as the release
    # swings through it
    op = operating_point(name, torque=0.0)
    assert _same_pose(op.z, _released(name)) < 1e-8


# -- bad operating points ----------------------------------------------------------
def test_no_equilibrium_when_the_torque_beats_gravity():
    with pytest.raises(SceneError, match=r"^at: no equilibrium"):
        linearize("thesis-fourbar-damped", torque=50.0)


def test_neutral_equilibrium_is_not_isolated():
    scene = grubler.load_scene("thesis-fourbar-damped")
    weightless = replace(scene, mechanism=scene.mechanism.replace(gravity=0.0))
    with pytest.raises(SceneError, match=r"^at: .*not isolated"):
        linearize(weightless)


def test_weightless_with_torque_has_no_equilibrium():
    scene = grubler.load_scene("thesis-fourbar-damped")
    weightless = replace(scene, mechanism=scene.mechanism.replace(gravity=0.0))
    with pytest.raises(SceneError, match=r"^at: no equilibrium"):
        linearize(weightless, torque=1.0)


@pytest.mark.parametrize("at, match", [
    ("t=-1", "at: the time must be finite"),
    ("t=abc", "at: cannot read the time"),
    ("somewhere", "at: must be 'equilibrium'"),
    ({"theta3": 0.3}, "at: 'theta3' is not an independent coordinate here"),
    ({"theta9": 0.3}, "at: 'theta9' is not a real joint coordinate"),
])
def test_bad_operating_points_name_the_field(at, match):
    with pytest.raises(SceneError, match=match):
        linearize("thesis-fourbar", at=at)


TOGGLE_REFUSAL = r"^at: .*(singular|cannot be closed)"


def test_toggle_position_is_refused():
    assert re.match(TOGGLE_REFUSAL, toggle_scenario.verdict())
    scene = grubler.load_scene("fourbar-triple-rocker")
    limit = toggle_scenario.toggle_angle(scene)
    # 1e-12 rad inside the limit coupler and rocker are 2e-7 rad from in line: no
    # further than the closure's own tolerance (1e-13 of the size, at a double root
    # sqrt of it) leaves them at the toggle itself, so it is refused the same way
    with pytest.raises(SceneError, match=TOGGLE_REFUSAL):
        linearize(scene, at={"theta2": limit - 1e-12})
    sys = linearize(scene, at={"theta2": limit - 1e-5})  # 7e-4 of conditioning: fine
    assert sys.nstates == 2 and np.all(np.isfinite(sys.A))
    sys = linearize(scene, at={"theta2": limit - 0.3})  # away from it, fine
    assert sys.nstates == 2


# the OpenBLAS kernels this CPU can run, each with the flag it needs (/proc/cpuinfo)
CORE_TYPES = {"Prescott": "sse3", "Sandybridge": "avx", "Haswell": "avx2", "SkylakeX": "avx512bw"}


def _cpu_flags() -> set[str]:
    try:
        with open("/proc/cpuinfo") as fh:
            found = re.search(r"^flags\s*:(.*)$", fh.read(), re.M)
    except OSError:  # not Linux
        return set()
    return set(found.group(1).split()) if found else set()


def test_toggle_verdict_is_the_same_under_every_blas_kernel():
    # numpy's and scipy's OpenBLAS pick their kernels by CPU (OPENBLAS_CORETYPE
    # forces one); each rounds a little differently, and a verdict must not follow
    flags = _cpu_flags()
    runnable = [core for core, flag in CORE_TYPES.items() if flag in flags]
    if not runnable:
        pytest.skip("no x86 OpenBLAS kernel this CPU can run")
    for core in runnable:
        env = dict(os.environ, OPENBLAS_CORETYPE=core)
        proc = subprocess.run([PYTHON, toggle_scenario.__file__], env=env, capture_output=True, text=True,
                              timeout=120)
        assert proc.returncode == 0, (core, proc.stderr[-2000:])
        assert re.match(TOGGLE_REFUSAL, proc.stdout.strip()), (core, proc.stdout)


@pytest.mark.parametrize("kwargs, match", [
    ({"outputs": ["closure_error"]}, "outputs: closure_error"),
    ({"outputs": ["nonsense"]}, "outputs: unknown output 'nonsense'"),
    ({"inputs": ["voltage"]}, "inputs: 'voltage' needs a motor"),
    ({"inputs": ["load"]}, "inputs: the scene has no load joint"),
    ({"torque": float("nan")}, "torque: must be finite"),
    ({"motor": "maxon"}, "motor: must be a grubler.motors.DCMotor"),
])
def test_bad_arguments_name_the_field(kwargs, match):
    with pytest.raises(SceneError, match=match):
        linearize("thesis-fourbar", at="initial", **kwargs)


def test_motor_saturation_is_refused():
    motor = DCMotor(load_motor("maxon-re40-148877"), Gearbox(1.0, 0.9))
    with pytest.raises(SceneError, match=r"^motor: .*(supply|current limit)"):
        linearize("thesis-fourbar", at={"theta2": 0.0}, motor=motor, torque=None)


def test_penalty_scenes_are_refused():
    scene = replace(grubler.load_scene("thesis-fourbar"), method="penalty")
    with pytest.raises(SceneError, match=r"^method: "):
        operating_point(scene)


# -- the command line ------------------------------------------------------------
@pytest.mark.parametrize("value", ["30 deg", "30deg", "30°", f"{math.radians(30)!r} rad", "pi/6", math.radians(30)])
def test_a_held_angle_reads_the_same_from_the_api_as_from_the_command_line(value):
    op = operating_point("thesis-fourbar", at={"theta2": value})
    assert op.coordinates["theta2"] == pytest.approx(math.radians(30), abs=1e-12)


@pytest.mark.parametrize("value", ["30", " 0.5 ", "30 grad"])
def test_an_angle_given_as_text_without_its_unit_is_refused(value):
    # '30' could mean degrees or radians: which one is not guessed
    with pytest.raises(SceneError, match=r"^at\.theta2: .*(no unit|cannot read)"):
        operating_point("thesis-fourbar", at={"theta2": value})


def test_cli_refuses_a_bare_number_for_an_angle(capsys):
    from grubler.cli import main

    for argv in (["linearize", "thesis-fourbar", "--at", "theta2=30"], ["info", "watt-ii", "--at", "120"]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err == ["grubler: error: --at: " + f"'{argv[-1].rpartition('=')[2]}' has no unit: write "
                       f"'{argv[-1].rpartition('=')[2]} deg' or '{argv[-1].rpartition('=')[2]} rad' "
                       "(or a multiple of pi, 'pi/6')"], err


def test_cli_prints_every_number_of_the_operating_point_with_its_unit(capsys):
    from grubler.cli import main

    assert main(["linearize", "thesis-fourbar", "--at", "theta2=30deg"]) == 0
    out = capsys.readouterr().out
    assert ("operating point: equilibrium: theta2 = 30 deg (0.523599 rad); drive effort 3.39523 N m, "
            "load effort 0 N m") in out
    assert "DC gain -0.224239 rad/(N m)" in out
    assert main(["linearize", "thesis-fourbar", "--at", "t=0.2"]) == 0
    out = capsys.readouterr().out
    assert "(not an equilibrium: accelerations theta2 " in out and " rad/s^2)" in out
    # a slide's coordinate is a length and its effort a force
    from grubler.studies.linearize import summary
    from grubler.mechanism.scene import override

    slide = override(grubler.load_scene("elliptic-trammel"), {"drive_joint": "B1"})
    assert summary(linearize(slide, at="initial")).startswith(
        "operating point: initial: B1 = 0.69282 m; drive effort 0 N, load effort 0 N m")


def test_cli_prints_poles_and_writes_json_and_bode(tmp_path, capsys):
    import json

    from grubler.cli import main

    js, png = tmp_path / "lin.json", tmp_path / "bode.png"
    code = main(["linearize", "thesis-fourbar", "--at", "theta2=30deg", "--motor", "maxon-re40-148877",
                 "--ratio", "50", "--output", "theta2,current", "--json", str(js), "--bode", str(png)])
    out = capsys.readouterr().out
    assert code == 0
    assert "poles, rad/s (natural frequency, damping ratio)" in out and "DC gain" in out and "rad/V" in out
    d = json.loads(js.read_text())
    assert d["states"] == ["theta2", "theta2_d", "current"] and d["inputs"] == ["voltage"]
    assert len(d["A"]) == 3 and all(len(row) == 3 for row in d["A"])
    assert d["operating_point"]["coordinates"]["theta2"] == pytest.approx(math.radians(30), abs=1e-12)
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize("argv, field", [
    (["--ratio", "5"], "--ratio"),
    (["--at", "banana"], "--at: cannot read 'banana' as a number or an angle ('60 deg', 'pi/3'); or equilibrium"),
    (["--output", "nope"], "outputs"),
    (["--at", "t=-2"], "at"),
    (["--motor", "no-such-motor"], "motor"),
])
def test_cli_bad_input_exits_2_naming_the_field(argv, field, capsys):
    from grubler.cli import main

    assert main(["linearize", "thesis-fourbar", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"grubler: error: {field}"), err


def test_a_sweep_with_near_stays_on_one_assembly_branch():
    # from the scene's sketch, assembly at a far crank angle may land on the other
    # (crossed) branch; continuing from the neighbour keeps the sketched one
    near, theta3 = None, []
    for a in np.radians(np.arange(0.0, 181.0, 20.0)):
        near = operating_point("thesis-fourbar", at={"theta2": float(a)}, near=near)
        theta3.append(near.coordinates["theta3"])
    steps = np.abs(np.diff(theta3))
    assert steps.max() < 0.2, theta3
    with pytest.raises(SceneError, match="^near: "):
        operating_point("thesis-fourbar", at="initial", near="here")


# -- the design example, co-simulated ----------------------------------------------
@pytest.mark.slow
def test_design_example_predictions_hold_in_cosimulation(tmp_path):
    # the example's designs as FMUs on the nonlinear plant: on the ideal plant
    # (no dry friction, lossless gearbox, no quantisation) the linear prediction
    # holds to a few per cent of the step; with the datasheet motor and the 14-bit
    # encoder within about one encoder count
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    sys.path.insert(0, str(root))
    import builds

    d = tmp_path / "dist"
    builds.dist(d, ["Mechanism", "DCMotor", "Encoder", "Trajectory"])
    out = tmp_path / "rows.json"
    proc = subprocess.run([sys.executable, str(root / "examples" / "control_design.py"), "--fmu-dir", str(d),
                           "--img-dir", str(tmp_path), "--json", str(out)], capture_output=True, text=True,
                          timeout=900)
    assert out.exists(), proc.stderr[-3000:]
    rows = json.loads(out.read_text())
    step, count = 0.008, 2 * math.pi / 16384
    co = [r for r in rows if r["source"] == "co-simulated"]
    assert len(co) == 8
    for r in co:
        pred = next(p for p in rows if p["source"] == "predicted" and
                    all(p[k] == r[k] for k in ("design", "plant", "angle_deg")))
        if r["plant"] == "ideal":
            assert r["gap_rad"] < 0.02 * step, r
            assert abs(r["overshoot_%"] - pred["overshoot_%"]) < 1.0, (r, pred)
            assert abs(r["settling_s"] - pred["settling_s"]) < 0.01, (r, pred)
        else:
            assert r["gap_rad"] < 1.5 * count, r
            assert abs(r["rms_error_rad"] - pred["rms_error_rad"]) < 0.1 * pred["rms_error_rad"], (r, pred)
    assert (tmp_path / "control-pole-map.png").stat().st_size > 20_000


@pytest.mark.parametrize("name", grubler.preset_names())
def test_every_preset_linearises_or_says_why(name):
    # at rest under the preset's own efforts: a finite model whose equilibrium the
    # kernel confirms, or an error naming the operating point
    try:
        sys = linearize(name)
    except SceneError as exc:
        assert exc.field == "at" and ("no equilibrium" in exc.reason or "not isolated" in exc.reason), exc
        return
    assert np.all(np.isfinite(sys.A)) and np.all(np.isfinite(sys.B))
    op = sys.operating_point
    model = grubler.load_scene(name).mechanism
    dyn = forward_dynamics(model, op.z, op.zd, Inputs(op.drive, op.load))
    assert np.abs(dyn.zdd).max() < 1e-7


# -- the Bode plot ------------------------------------------------------------------
def test_bode_phase_starts_where_the_dc_gain_says_and_the_title_says_what_was_linearised():
    from grubler.studies.linearize import bode_figure, frequency_response, phase_deg

    sys = linearize("thesis-fourbar", at={"theta2": "30 deg"}, motor=_motor(), outputs=["theta2", "current"])
    omega = np.logspace(-3, 5, 400)
    G = frequency_response(sys, omega)
    for i in range(2):
        # python-control's DC gain (its own solve): positive, the phase starts near 0 deg,
        # negative, near -180 deg (the winding current's ran from -315 to -450 deg)
        dc = float(np.real(np.squeeze(sys[i, 0].dcgain())))
        assert abs(G[i, 0, 0] - dc) < 1e-2 * abs(dc)  # (1e-3 rad/s is 400 times below the slowest pole)
        assert phase_deg(G[i, 0])[0] == pytest.approx(0.0 if dc > 0 else -180.0, abs=1.0), (i, dc)
    fig = bode_figure(sys)
    try:
        title = fig.get_suptitle()
        assert "theta2 = 30 deg" in title and "maxon-re40-148877 through 50:1" in title and "3.395 N m" in title
        unstable = [p for p in sys.poles() if p.real > 0]
        assert len(unstable) == 1
        assert f"open-loop unstable: pole at {unstable[0].real:+.4g} rad/s" in fig.get_supxlabel()
        for ax in fig.axes[0::2]:  # every magnitude axis reads: four or more labelled levels within it
            lo, hi = ax.get_ylim()
            assert sum(lo <= t <= hi for t in ax.get_yticks()) >= 4, ax.get_yticks()
            assert ax.get_ylabel().startswith("magnitude, dB re 1 ")
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
    # a stable plant says nothing of the kind
    stable = bode_figure(linearize("thesis-fourbar-damped"))
    assert stable.get_supxlabel() == "" and "-112.6 deg" in stable.get_suptitle()


@pytest.mark.parametrize("path, reason", [("out-{tmp}/b.png", "does not exist"),
                                           ("{tmp}/b.xyz", "cannot write a 'xyz' file; use one of .png, .pdf, .svg")])
def test_cli_refuses_a_bode_file_it_cannot_write_before_linearising(tmp_path, capsys, path, reason):
    from grubler.cli import main

    assert main(["linearize", "thesis-fourbar", "--bode", path.format(tmp=tmp_path)]) == 2
    err = capsys.readouterr()
    lines = err.err.strip().splitlines()
    assert len(lines) == 1 and "--bode" in lines[0] and reason in lines[0], lines
    assert err.out == ""  # refused up front, before any model is printed
