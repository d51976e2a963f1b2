"""Change points: the exact closure carries the motion across positions where two
assembly branches meet, along the branch it came on, with the energy kept.

References share no code with the library: the driven parallelogram against its own
one-degree-of-freedom equation (a crank whose coupler translates), solved by scipy;
energy balances from the outputs and the drive's work.
"""

import math

import numpy as np
import pytest
import scipy.integrate

import grubler
from grubler import Closure, Link, Mechanism
from grubler.simulate import Simulator

G = 9.81


def parallelogram_reference(tau, times, theta0):
    # three 1 kg point masses all moving with the crank tip (the coupler
    # translates, the rocker stays parallel to the crank): 3 theta'' = tau - 3 g cos(theta)
    sol = scipy.integrate.solve_ivp(lambda t, y: [y[1], tau / 3.0 - G * math.cos(y[0])], (0.0, times[-1]),
                                    [theta0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13, t_eval=times)
    return sol.y[0]


def test_driven_parallelogram_stays_a_parallelogram_for_twenty_turns():
    m = grubler.load_scene("fourbar-parallelogram").mechanism
    tau, theta0 = 40.0, -math.pi / 3
    times = np.linspace(0.01, 6.0, 600)
    sim = Simulator(m, inputs=grubler.Inputs(tau))
    z, zd = sim.advance_through(times)
    q = np.array([m.q_from_z(zz) for zz in z])
    turns = (q[-1, 1] - theta0) / (2 * math.pi)
    assert turns > 20
    # every turn passes two aligned positions (crank along the ground, both ways)
    assert len(sim.stats["passages"]) >= 2 * int(turns) - 1
    # the coupler never turns: the branch is kept through every passage
    assert np.ptp(q[:, 3]) < 1e-9
    # the crank follows the one-degree-of-freedom model
    assert np.max(np.abs(q[:, 1] - parallelogram_reference(tau, times, theta0))) < 1e-6
    # kinetic + potential - drive work is constant
    energy = 1.5 * zd[:, 0] ** 2 + 3 * G * np.sin(q[:, 1]) - tau * (q[:, 1] - theta0)
    assert np.ptp(energy) < 1e-8 * tau * (q[-1, 1] - theta0)


def test_a_swinging_parallelogram_meets_no_change_point():
    # released at rest it swings below its aligned positions: nothing to pass,
    # the turning points are not mistaken for passages
    res = grubler.simulate("fourbar-parallelogram", t_end=10.0)
    assert res.stats["passages"] == []
    assert np.max(res["closure_error"]) < 1e-12
    assert np.ptp(res["E"]) < 1e-7 * np.max(res["KE"])


@pytest.mark.parametrize("seed", range(6))
def test_random_change_point_four_bars_all_finish(seed):
    # s + l = p + q with random lengths (fixed seeds), driven through several
    # aligned positions from a random crank angle
    rng = np.random.default_rng(seed)
    s = rng.uniform(0.2, 0.5)
    l = rng.uniform(0.8, 1.4)
    p = rng.uniform(s + 0.05, l - 0.05)
    q = s + l - p
    ground, crank, coupler, rocker = l, s, p, q  # crank the shortest: a Grashof crank
    scene = grubler.load_scene(
        "\n".join(['[mechanism]', 'type = "four-bar"', f"ground = {ground}", f"crank = {crank}",
                   f"coupler = {coupler}", f"rocker = {rocker}", f"crank_angle = {rng.uniform(0.3, 2.5)}",
                   "[drive]", "torque = 2.0"]))
    res = grubler.simulate(scene, t_end=4.0, dt_out=0.01)
    assert np.max(res["closure_error"]) < 1e-10
    work = 2.0 * (res["theta2"] - res["theta2"][0])
    assert np.max(np.abs(res["E"] - res["E"][0] - work)) < 1e-6 * np.max(res["KE"])
