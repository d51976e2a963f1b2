"""grubler.controllers: each law against an independent reference, then its FMU against the law.

References: python-control's own discrete-time simulation (PID, linear
controller), the analytic profile limits (trajectories), the quantisation and
seed definitions (encoder), and the library's forward simulation (computed
torque).  The FMUs are built once per module; one child process drives them all
through fmpy (tests/controller_scenarios.py) and the tests judge what it wrote.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import control
import numpy as np
import pytest

import controller_scenarios as sc
import grubler
from grubler.controllers import (PID, CascadeController, ComputedTorque, Encoder, LinearController, Sampler,
                                 Trajectory)

HERE = Path(__file__).parent
ROOT = HERE.parent
NAMES = ["PID", "CascadeController", "LinearController", "ComputedTorque", "Trajectory", "Encoder"]


# -- PID ---------------------------------------------------------------------------
def discrete_pid_tf(K, Ti, Td, N, b, c, Ts):
    """The PID's two transfer functions in z (from r and from y), written from its docstring."""
    z = control.tf([1, 0], [1], Ts)
    Tf = Td / N
    integral = (Ts / Ti) / (z - 1)
    derivative = Td * (z - 1) / ((Tf + Ts) * z - Tf)
    return K * (b + integral + c * derivative), K * (1 + integral + derivative)


def test_pid_matches_python_control_on_a_discrete_loop():
    K, Ti, Td, N, b, c, Ts = 3.0, 0.6, 0.08, 8.0, 0.6, 0.3, 0.01
    plant = control.sample_system(control.tf([2.0], [0.5, 1.5, 1.0]), Ts, method="zoh")
    Cr, Cy = discrete_pid_tf(K, Ti, Td, N, b, c, Ts)
    n = 400
    r = np.ones(n)
    r[0] = 0.0  # start at rest: the PID's first sample has no derivative history
    t = np.arange(n) * Ts
    # state-space realisations: the product of the transfer functions loses digits
    P, Cr, Cy = control.ss(plant), control.ss(Cr), control.ss(Cy)
    y_ref = control.forced_response(control.feedback(P, Cy) * Cr, t, r).outputs
    u_ref = control.forced_response(Cr, t, r).outputs - control.forced_response(Cy, t, y_ref).outputs
    A, B, C = np.asarray(P.A), np.asarray(P.B)[:, 0], np.asarray(P.C)[0]
    assert np.all(np.asarray(P.D) == 0.0)
    pid = PID(K=K, Ti=Ti, Td=Td, N=N, b=b, c=c, Ts=Ts)
    x = np.zeros(A.shape[0])
    y, u = np.empty(n), np.empty(n)
    for k in range(n):
        y[k] = C @ x
        u[k] = pid.compute(r[k], y[k])
        x = A @ x + B * u[k]
    assert np.max(np.abs(y - y_ref)) < 1e-11
    assert np.max(np.abs(u - u_ref)) < 1e-10
    assert abs(y[-1] - 1.0) < 1e-2  # and the loop settles: integral action


def windup_run(anti_windup: str, n: int = 12000) -> tuple[np.ndarray, np.ndarray]:
    """A PI on a first-order speed loop (w' = u - w), stepped to 2.5 with |u| <= 3.

    Linear, the loop is s^2 + 3 s + 4: about 4 % overshoot; the limit slows the
    rise and an unprotected integral winds up meanwhile.
    """
    e = math.exp(-1e-3)
    pid = PID(K=2.0, Ti=0.5, Ts=1e-3, u_min=-3.0, u_max=3.0, anti_windup=anti_windup)
    w = 0.0
    ws, us = np.empty(n), np.empty(n)
    for k in range(n):
        us[k] = pid.compute(2.5, w)
        w = e * w + (1 - e) * us[k]  # the plant discretised exactly under a zero-order hold
        ws[k] = w
    return ws, us


def test_anti_windup_recovers_faster_and_limits_hold():
    runs = {aw: windup_run(aw) for aw in ("none", "back-calculation", "conditional")}
    overshoot = {aw: w.max() - 2.5 for aw, (w, _) in runs.items()}
    settle = {aw: (np.nonzero(np.abs(w - 2.5) > 0.025)[0][-1] + 1) * 1e-3 for aw, (w, _) in runs.items()}
    for aw, (w, u) in runs.items():
        assert u.min() >= -3.0 and u.max() <= 3.0 and u.max() == 3.0, aw  # limited, and the limit was hit
        assert abs(w[-1] - 2.5) < 1e-4, aw
    assert overshoot["none"] > 0.4
    for aw in ("back-calculation", "conditional"):
        assert overshoot[aw] < 0.25 * overshoot["none"], overshoot
        assert settle[aw] < 0.7 * settle["none"], settle


def test_pid_feedforward_is_added_before_the_limits():
    pid = PID(K=1.0, Ts=0.1, u_max=2.0)
    assert pid.update(0.0, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.5})["u"] == 1.5
    assert pid.update(0.1, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 5.0})["u"] == 2.0


@pytest.mark.parametrize("kwargs, field", [({"Ts": 0.0}, "Ts"), ({"u_min": 1.0, "u_max": 0.0}, "u_max"),
                                           ({"Ti": -1.0}, "Ti"), ({"anti_windup": "clamp"}, "anti_windup"),
                                           ({"K": math.nan}, "K")])
def test_bad_pid_parameters_name_the_field(kwargs, field):
    with pytest.raises(grubler.SceneError) as err:
        PID(**kwargs)
    assert err.value.field == field


# -- sample-time semantics ------------------------------------------------------------
class Count(sc.Law):
    inputs = {"x": "input [any]"}
    outputs = {"n": "samples so far [1]", "t": "time of the last sample [s]"}

    def __init__(self, Ts):
        self.Ts, self.n = Ts, 0

    def update(self, t, inputs):
        self.n += 1
        return {"n": float(self.n), "t": t}


def test_sampler_runs_samples_on_their_own_grid_and_holds_between():
    s = Sampler(Count(1e-3))
    for k in range(10):  # h = 5 Ts: five samples per step, on held inputs
        out = s.step(k * 5e-3, 5e-3, {"x": 0.0})
    assert out == {"n": 50.0, "t": pytest.approx(49e-3, abs=1e-15)}
    s = Sampler(Count(1e-2))
    ns = [s.step(k * 1e-3, 1e-3, {"x": 0.0})["n"] for k in range(30)]  # h = Ts / 10: hold
    assert ns == [1.0] * 10 + [2.0] * 10 + [3.0] * 10
    s = Sampler(Count(1e-2))
    times = []
    t = 0.0
    for h in (3e-3, 7e-3, 4e-3, 2.5e-2):  # irregular steps: the samples stay on 0, 10 ms, 20 ms, ...
        out = s.step(t, h, {"x": 0.0})
        t += h
        times.append(out["t"])
    assert times == pytest.approx([0.0, 0.0, 0.01, 0.03])
    with pytest.raises(ValueError, match="inputs must be finite"):
        s.step(t, 1e-3, {"x": math.inf})


# -- cascade -----------------------------------------------------------------------
def test_cascade_follows_a_move_within_its_limits():
    traj = Sampler(Trajectory(**sc.TRAJ))
    rows = np.array(sc.cascade_loop(Sampler(CascadeController(**sc.CASCADE)), traj, 1e-3, 2400))
    u, pos, ref = rows[:, 1], rows[:, 2], rows[:, 3]
    assert np.all(np.abs(u) <= 10.0)
    assert np.max(np.abs(pos - ref)) < 0.01  # tracks the S-curve move there and back within 10 mrad
    assert abs(pos[-1] - ref[-1]) < 1e-3 and ref[-1] == 0.0 and ref.max() == pytest.approx(1.2)


def test_cascade_speed_feedforward_reduces_the_tracking_error():
    errs = {}
    for ff in (0.0, 1.0):
        ctl = CascadeController(**{**sc.CASCADE, "velocity_feedforward": ff})
        rows = np.array(sc.cascade_loop(Sampler(ctl), Sampler(Trajectory(**sc.TRAJ)), 1e-3, 1000))
        errs[ff] = np.max(np.abs(rows[:, 2] - rows[:, 3]))
    assert errs[1.0] < 0.1 * errs[0.0], errs


def test_cascade_current_loop_is_the_innermost_pi_as_python_control_has_it():
    # no limits reached: u = C_i(z) (C_s(z) (C_p(z) e_position - speed) - current), each C a discrete PI
    # K (1 + (Ts/Ti) / (z - 1)) as the PID module's docstring writes it; python-control composes them
    Ts, n = 1e-3, 200
    gains = dict(K_position=20.0, Ti_position=0.05, K_speed=0.5, Ti_speed=0.02, K_current=4.0, Ti_current=0.004)
    ctl = CascadeController(**gains, velocity_feedforward=0.0, Ts=Ts)
    rng = np.random.default_rng(7)
    e_pos, speed, current = rng.normal(0, 0.1, n), rng.normal(0, 1.0, n), rng.normal(0, 0.5, n)
    u = np.array([ctl.update(k * Ts, {"position_setpoint": e_pos[k], "velocity_setpoint": 0.0, "position": 0.0,
                                      "speed": speed[k], "current": current[k]})["u"] for k in range(n)])
    z = control.tf([1, 0], [1], Ts)

    def pi(K, Ti):
        return K * (1 + (Ts / Ti) / (z - 1))

    Cp, Cs, Ci = pi(20.0, 0.05), pi(0.5, 0.02), pi(4.0, 0.004)
    t = np.arange(n) * Ts
    ref = sum(control.forced_response(G, t, x).outputs
              for G, x in ((Ci * Cs * Cp, e_pos), (-Ci * Cs, speed), (-Ci, current)))
    assert np.max(np.abs(u - ref)) < 1e-9 * np.max(np.abs(ref))
    assert ctl.current_setpoint != 0.0


def test_cascade_current_setpoint_is_held_to_the_current_limit():
    ctl = CascadeController(K_position=100.0, K_speed=10.0, K_current=2.0, current_limit=1.5, u_min=-24.0,
                            u_max=24.0, Ts=1e-3)
    out = ctl.update(0.0, {"position_setpoint": 1.0, "velocity_setpoint": 0.0, "position": 0.0, "speed": 0.0,
                           "current": 0.5})
    assert ctl.current_setpoint == 1.5 and out["u"] == pytest.approx(2.0 * (1.5 - 0.5))
    with pytest.raises(KeyError):  # a current loop needs its measurement
        ctl.update(1e-3, {"position_setpoint": 1.0, "velocity_setpoint": 0.0, "position": 0.0, "speed": 0.0})
    with pytest.raises(grubler.SceneError, match="K_current: must be finite and >= 0"):
        CascadeController(K_current=-1.0)
    with pytest.raises(grubler.SceneError, match="current_limit: must be finite and > 0"):
        CascadeController(K_current=1.0, current_limit=0.0)


# -- linear controller --------------------------------------------------------------
@pytest.mark.parametrize("method", ["zoh", "tustin", "foh", "backward_diff"])
def test_linear_controller_matches_python_control(method):
    C = control.tf([0.5, 2.0, 1.0], [0.02, 1.0, 0.0])  # PID with a filtered derivative
    Ts = 1e-2
    ctl = LinearController(C, Ts, method)
    inputs = sc.linear_inputs(300)
    u = np.array([ctl.update(k * Ts, i)["u"] for k, i in enumerate(inputs)])
    e = np.array([i["setpoint"] - i["measurement"] for i in inputs])
    ref = control.forced_response(control.sample_system(C, Ts, method=method), np.arange(300) * Ts, e).outputs
    assert np.max(np.abs(u - ref)) < 1e-9 * np.max(np.abs(ref))


def test_matched_refuses_a_pole_or_zero_at_s_0_where_python_control_gives_nan():
    """'matched' scales the gain at s = 0: python-control's matrices are NaN for a PI (pole there) or a
    washout (zero there); the controller refuses at construction, naming the method and the root."""
    Ts = 1e-2
    for C, kind in ((control.tf([2.0, 20.0], [1.0, 0.0]), "pole"), (control.tf([1.0, 0.0], [1.0, 10.0]), "zero")):
        with np.errstate(divide="ignore", invalid="ignore"):
            ref = control.ss(control.sample_system(C, Ts, method="matched"))
        assert not all(np.all(np.isfinite(m)) for m in (ref.A, ref.B, ref.C, ref.D))  # why it is refused
        with pytest.raises(grubler.SceneError, match=rf"'matched' cannot discretise a controller with a {kind} "
                                                     r"at s = 0") as err:
            LinearController(C, Ts, "matched")
        assert err.value.field == "method"
        with pytest.raises(grubler.SceneError, match=f"{kind} at s = 0"):  # the FMU's parameters: the same rule
            LinearController.from_parameters(num=" ".join(map(str, C.num[0][0])), den=" ".join(map(str, C.den[0][0])),
                                             method="matched", Ts=Ts)
    # without a root at s = 0, 'matched' is python-control's, sample for sample
    C = control.tf([2.0, 20.0], [1.0, 0.5])  # a lag: the PI's integrator moved off s = 0
    ctl = LinearController(C, Ts, "matched")
    inputs = sc.linear_inputs(200)
    u = np.array([ctl.update(k * Ts, i)["u"] for k, i in enumerate(inputs)])
    e = np.array([i["setpoint"] - i["measurement"] for i in inputs])
    ref = control.forced_response(control.sample_system(C, Ts, method="matched"), np.arange(200) * Ts, e).outputs
    assert np.all(np.isfinite(u)) and np.max(np.abs(u - ref)) < 1e-9 * np.max(np.abs(ref))


def test_linear_controller_parameters_coefficients_state_space_and_discrete():
    inputs = sc.linear_inputs(100)
    run = lambda ctl: np.array([ctl.update(k * 1e-2, i)["u"] for k, i in enumerate(inputs)])  # noqa: E731
    base = run(LinearController(control.tf([0.5, 2.0, 1.0], [0.02, 1.0, 0.0]), 1e-2, "tustin"))
    assert np.allclose(run(LinearController.from_parameters(**sc.LIN)), base, rtol=0, atol=1e-10)
    ss = control.ss(control.tf([0.5, 2.0, 1.0], [0.02, 1.0, 0.0]))
    toml = "\n".join(f"{k} = {np.asarray(getattr(ss, k)).tolist()}" for k in "ABCD")
    assert np.allclose(run(LinearController.from_parameters(state_space=toml, method="tustin", Ts=1e-2)), base,
                       rtol=0, atol=1e-9)
    zd = control.sample_system(control.tf([0.5, 2.0, 1.0], [0.02, 1.0, 0.0]), 1e-2, "tustin")
    num, den = (" ".join(repr(float(v)) for v in np.ravel(a)) for a in (zd.num[0][0], zd.den[0][0]))
    assert np.allclose(run(LinearController.from_parameters(num=num, den=den, method="none", Ts=1e-2)), base,
                       rtol=0, atol=1e-9)
    for kw, field in (({"num": "1 x"}, "num"), ({"num": "1 2 3", "den": "1 2"}, "num"),
                      ({"method": "warp"}, "method"), ({"state_space": "A = [[1]]"}, "state_space.B")):
        with pytest.raises(grubler.SceneError) as err:
            LinearController.from_parameters(**kw)
        assert err.value.field == field


# -- trajectories --------------------------------------------------------------------
def sampled(tr, t_end, n=40001):
    t = np.linspace(0.0, t_end, n)
    return t, np.array([tr.evaluate(x) for x in t]).T


def integral(t, f):
    return np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))])


def jump_tol(t, f):
    """Trapezoidal-rule error allowed for an integrand with jumps (each costs |jump| dt / 2)."""
    return 1e-6 + np.sum(np.abs(np.diff(f))[np.abs(np.diff(f)) > 1e-3]) * (t[1] - t[0]) / 2


@pytest.mark.parametrize("kw", [
    dict(kind="trapezoid", distance=2.0, v_max=1.5, a_max=4.0),      # reaches v_max
    dict(kind="trapezoid", distance=0.3, v_max=1.5, a_max=4.0),      # triangle
    dict(kind="scurve", distance=2.0, v_max=1.5, a_max=4.0, j_max=40.0),
    dict(kind="scurve", distance=0.3, v_max=1.5, a_max=4.0, j_max=40.0),   # neither v_max nor a_max
    dict(kind="scurve", distance=0.8, v_max=1.5, a_max=2.0, j_max=80.0),   # a_max, not v_max
    dict(kind="scurve", distance=-1.0, v_max=1.0, a_max=4.0, j_max=10.0, start=0.5),
])
def test_moves_cover_the_distance_within_their_limits(kw):
    tr = Trajectory(**kw)
    t, (p, v, a) = sampled(tr, tr.move_time + 0.2)
    start = kw.get("start", 0.0)
    assert p[0] == start and abs(p[-1] - (start + kw["distance"])) < 1e-12
    assert np.max(np.abs(v)) <= kw["v_max"] * (1 + 1e-12)
    assert np.max(np.abs(a)) <= kw["a_max"] * (1 + 1e-12)
    # velocity is the derivative of position, acceleration that of velocity
    assert np.max(np.abs(start + integral(t, v) - p)) < 1e-6
    assert np.max(np.abs(integral(t, a) - v)) < jump_tol(t, a)
    if kw["kind"] == "scurve":
        jerk = np.diff(a) / np.diff(t)
        assert np.max(np.abs(jerk)) <= kw["j_max"] * (1 + 1e-6)
    if kw["distance"] == 2.0:  # long enough to cruise: the limit is reached
        assert np.max(np.abs(v)) == pytest.approx(kw["v_max"])


def test_repeated_moves_dwell_and_reverse():
    tr = Trajectory(kind="trapezoid", distance=1.0, v_max=2.0, a_max=8.0, dwell=0.25, repeat=3, delay=0.5)
    period = tr.move_time + 0.25
    ends = [tr.evaluate(0.5 + k * period + tr.move_time + 0.1)[0] for k in range(3)]
    assert ends == pytest.approx([1.0, 2.0, 3.0])
    assert tr.evaluate(100.0) == (3.0, 0.0, 0.0) and tr.evaluate(0.3) == (0.0, 0.0, 0.0)
    back = Trajectory(kind="trapezoid", distance=1.0, v_max=2.0, a_max=8.0, repeat=0, reverse=True)
    assert [back.evaluate(back.move_time * (k + 1))[0] for k in range(5)] == pytest.approx([1, 0, 1, 0, 1])


def test_sine_constant_and_table():
    s = Trajectory(kind="sine", amplitude=0.5, frequency=2.0, start=1.0)
    t, (p, v, a) = sampled(s, 1.0)
    assert np.allclose(p, 1.0 + 0.5 * np.sin(4 * np.pi * t), atol=1e-14)
    assert np.max(np.abs(1.0 + integral(t, v) - p)) < 1e-6
    assert Trajectory(kind="constant", speed=3.0, delay=1.0).evaluate(3.0) == (6.0, 3.0, 0.0)
    times, pos = [0.0, 0.5, 1.0, 2.0], [0.0, 0.4, 0.5, 2.0]
    tab = Trajectory(kind="table", times="0 0.5 1 2", positions="0, 0.4, 0.5, 2")
    assert [tab.evaluate(x)[0] for x in times] == pytest.approx(pos, abs=1e-14)
    t, (p, v, a) = sampled(tab, 2.5)
    assert np.max(np.abs(integral(t, v) - p)) < 1e-6 and np.max(np.abs(integral(t, a) - v)) < jump_tol(t, a)
    assert tab.evaluate(3.0) == (2.0, 0.0, 0.0)
    with pytest.raises(grubler.SceneError, match="times"):
        Trajectory(kind="table", times="0 1 1", positions="0 1 2")


# -- encoder ---------------------------------------------------------------------
def test_encoder_quantises_to_the_count_below():
    enc = Encoder(counts_per_rev=1000, Ts=1e-3)
    q = 2 * np.pi / 1000
    x = np.linspace(-7.0, 7.0, 2001)
    m = np.array([enc.update(0.0, {"position": v})["measured_position"] for v in x])
    assert np.all((x - m >= -1e-12) & (x - m < q))
    assert np.allclose(m / q, np.round(m / q), atol=1e-9)


def test_encoder_noise_is_seeded_and_delay_and_speed_estimate():
    def run(**kw):
        enc = Encoder(Ts=1e-3, **kw)
        return np.array([[o["measured_position"], o["measured_speed"]]
                         for o in (enc.update(k * 1e-3, i) for k, i in enumerate(sc.encoder_inputs(4000)))])
    a, b, c = run(noise_std=0.01, seed=1), run(noise_std=0.01, seed=1), run(noise_std=0.01, seed=2)
    x = np.array([i["position"] for i in sc.encoder_inputs(4000)])
    assert np.array_equal(a, b) and not np.allclose(a, c)
    assert np.std(a[:, 0] - x) == pytest.approx(0.01, rel=0.05)
    d = run(delay=3)
    assert np.array_equal(d[3:, 0], x[:-3]) and np.all(d[:3, 0] == x[0])
    assert np.allclose(d[4:, 1], np.diff(x[:-3]) / 1e-3, rtol=1e-12, atol=1e-9)


# -- computed torque --------------------------------------------------------------
def test_computed_torque_makes_the_simulated_crank_follow_the_trajectory():
    tr = Trajectory(kind="sine", amplitude=0.8, frequency=1.5, start=0.3)
    ct = ComputedTorque("thesis-fourbar", drive_inertia=0.01)
    start = ct.demand(*tr.evaluate(0.0))
    z0, zd0 = start.z[0], start.zd[0]
    times = np.arange(0.05, 0.6001, 0.05)

    def follow(scale):
        sim = grubler.Simulator(ct.model, z0=z0, zd0=zd0, rtol=1e-10, atol=1e-10,
                                drive_function=lambda t: scale * ct.drive_torque(*tr.evaluate(t)))
        err = []
        for t in times:
            sim.advance_to(t)
            err.append(abs(sim.z[0] - tr.evaluate(t)[0]))
        return max(err)

    assert follow(1.0) < 1e-7
    assert follow(0.95) > 1e-3  # the test can tell: 5 % less torque drifts away
    # the motion it inverts satisfies the closures at position, velocity and acceleration
    d = ct.demand(*tr.evaluate(0.37))
    z, zd, zdd = d.z[0], d.zd[0], d.zdd[0]
    dyn = grubler.forward_dynamics(ct.model, z, zd, grubler.Inputs(float(d.torque[0])))
    assert np.allclose(dyn.zdd, zdd, rtol=0, atol=1e-9)
    assert np.max(np.abs(dyn.ck.phi)) < 1e-12 and np.max(np.abs(dyn.ck.J @ zd)) < 1e-12


def test_computed_torque_motor_side_and_bad_mechanisms():
    ct = ComputedTorque("thesis-fourbar", gear_ratio=10.0, efficiency=0.8, R=2.0, k_t=0.1, k_e=0.1)
    out = ct.update(0.0, {"position": 0.2, "velocity": 3.0, "acceleration": 5.0})
    tau = out["torque"]
    motoring = tau * 3.0 >= 0
    assert out["motor_torque"] == pytest.approx(tau / 8.0 if motoring else tau * 0.08)
    # electrical power in = copper loss + mechanical power at the motor shaft (steady current)
    i = out["motor_torque"] / 0.1
    assert out["voltage"] * i == pytest.approx(2.0 * i**2 + out["motor_torque"] * 30.0)
    with pytest.raises(grubler.SceneError, match="one degree of freedom"):
        ComputedTorque("triple-pendulum")
    with pytest.raises(grubler.SceneError):
        ComputedTorque("thesis-fourbar", efficiency=0.0)


# -- FMUs -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def dist(tmp_path_factory):
    sys.path.insert(0, str(ROOT))
    import builds

    folder = tmp_path_factory.mktemp("controllers_dist")
    builds.dist(folder, [n for n in NAMES if n != "LinearController"])
    # build_fmu.py's LinearController is native, its parameters one controller's matrices
    # (test_native_laws.py); the pythonfmu one takes any controller as num/den or state_space
    builds.controller_fmu(LinearController, folder)
    builds.controller_fmu(sc.RateLimiter, folder)
    return folder


@pytest.fixture(scope="module")
def child(dist, tmp_path_factory):
    out = tmp_path_factory.mktemp("controllers_run") / "out.json"
    proc = subprocess.run([sys.executable, str(HERE / "controller_scenarios.py"), str(dist), str(out)],
                          capture_output=True, text=True, timeout=600, cwd=str(HERE))
    assert out.exists(), f"controller scenarios wrote nothing (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    data = json.loads(out.read_text())
    assert data["done"]
    return data["result"]


@pytest.mark.slow
def test_fmus_validate_and_declare_units(dist):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    for name in NAMES + ["RateLimiter"]:
        fmu = str(dist / f"{name}.fmu")
        assert validate_fmu(fmu) == [], name
        md = read_model_description(fmu)
        assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
        for v in md.modelVariables:
            assert v.description and v.description.endswith("]") and "[" in v.description, (name, v.name)
            if v.causality == "output":  # a pythonfmu output validates only as exact; a native one is calculated
                assert v.initial in ("exact", "calculated"), (name, v.name)
        # every output is a state to a master: no dependency on an input at the same instant
        assert md.outputs and all(out.dependencies == [] for out in md.outputs), name
    md = read_model_description(str(dist / "Encoder.fmu"))
    by_name = {v.name: v for v in md.modelVariables}
    assert by_name["position"].causality == "input"
    assert {"measured_position", "measured_speed"} <= {v.name for v in md.modelVariables if v.causality == "output"}


@pytest.mark.slow
def test_pid_fmu_matches_the_law_with_several_samples_per_step_and_with_hold(child):
    for key, h, n in (("pid_2_samples_per_step", 2e-3, 150), ("pid_hold", 0.25e-3, 1200)):
        ref = np.array(sc.pid_loop(Sampler(PID(**sc.PID_PARAMS)), h, n))
        fmu = np.array(child[key])
        assert np.array_equal(fmu, ref), key
    # hold: the output changes at most every fourth communication step (Ts = 4 h)
    u = np.array(child["pid_hold"])[:, 1]
    changes = np.nonzero(np.diff(u))[0] + 1
    assert len(changes) > 50 and np.all(changes % 4 == 0)


@pytest.mark.slow
def test_cascade_linear_and_computed_torque_fmus_match_their_laws(child):
    ref = sc.cascade_loop(Sampler(CascadeController(**sc.CASCADE)), Sampler(Trajectory(**sc.TRAJ)), 1e-3, 600)
    assert np.array_equal(np.array(child["cascade"]), np.array(ref))
    ref = sc.open_loop(Sampler(LinearController.from_parameters(**sc.LIN)), 1e-2, sc.linear_inputs(200))
    assert np.allclose(np.array(child["linear"]), np.array(ref), rtol=0, atol=1e-12)
    ref = sc.open_loop(Sampler(ComputedTorque(**sc.CT)), 1e-2, sc.computed_torque_inputs(1e-2, 70))
    assert np.allclose(np.array(child["computed_torque"]), np.array(ref), rtol=0, atol=1e-9)


@pytest.mark.slow
def test_trajectory_fmu_through_simulate_fmu(child):
    res = child["trajectory"]
    tr = Trajectory(**sc.TRAJ)
    for k, t in enumerate(res["time"]):
        assert (res["position"][k], res["velocity"][k], res["acceleration"][k]) == pytest.approx(
            tr.evaluate(t), abs=1e-12)
    assert max(res["position"]) == pytest.approx(1.2) and res["position"][-1] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.slow
def test_encoder_fmu_matches_and_rollback_replays_the_noise(child):
    ref = sc.open_loop(Sampler(Encoder(**sc.ENC)), 1e-3, sc.encoder_inputs(400))
    run = np.array(child["encoder"]["run"])
    assert np.allclose(run, np.array(ref), rtol=0, atol=1e-12)
    assert np.array_equal(np.array(child["encoder"]["replay"]), run[200:])
    assert np.array_equal(np.array(child["encoder"]["replay_serialized"]), run[200:])


@pytest.mark.slow
def test_custom_law_fmu(child):
    ref = sc.open_loop(Sampler(sc.RateLimiter(rate=3.0)), 0.01,
                       [{"target": 1.0 if k < 60 else -0.5} for k in range(120)])
    run = np.array(child["custom"]["run"])
    assert np.allclose(run, np.array(ref), rtol=0, atol=1e-12)
    assert np.array_equal(np.array(child["custom"]["replay"]), run[50:])
    assert child["custom"]["initial"] == {"limited": 0.0, "y": 0.0}
    assert run[:, 1].max() == 1.0 and run[-1, 2] == pytest.approx(-0.5)  # it really limited the rate


@pytest.mark.slow
def test_controller_fmus_report_bad_inputs_and_parameters(child):
    assert "status 2 (discard)" in child["nan_step"]
    assert any("measurement is nan" in m for m in child["messages_nan"])
    assert child["after_nan"] == "ok"
    # a failed initialisation says so, and every later step is refused
    assert "status 3 (error)" in child["bad_param_init"]
    assert "status 3 (error)" in child["bad_param"]
    assert any("u_max: must exceed u_min" in m for m in child["messages_param"])
    assert "status 3 (error)" in child["bad_mechanism_init"]
    assert "status 3 (error)" in child["bad_mechanism"]
    assert any("initial.theta2: the loop cannot be closed at the sketch" in m for m in child["messages_mechanism"])
