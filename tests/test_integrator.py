"""The integrator's dense output: states between steps, and steps that ignore the grid."""

import numpy as np
import pytest
import scipy.integrate

import grubler
from grubler import Link, Mechanism, Simulator
from grubler.mechanism.integrators import Integrator, StateEquation

PENDULUM = Mechanism(links=(Link("R", a=1.0, p=1.0, m=1.0),), q_ref=(0.0, -1.5))


def test_states_between_steps_match_an_independent_integration():
    # a 1 m point pendulum: theta'' = -g cos(theta), integrated by scipy as a plain ODE
    integ = Integrator(StateEquation(PENDULUM), 0.0, [-1.5, 0.0], rtol=1e-10, atol=1e-10)
    times = np.linspace(1e-3, 3.0, 3000)
    out = integ.advance_through(times)
    assert integ.n_steps < 300  # the 3000 outputs did not set the steps
    ref = scipy.integrate.solve_ivp(lambda t, y: [y[1], -9.81 * np.cos(y[0])], (0.0, 3.0), [-1.5, 0.0],
                                    method="DOP853", rtol=1e-13, atol=1e-13, t_eval=times)
    assert np.max(np.abs(out[:, 0] - ref.y[0])) < 1e-8
    assert np.max(np.abs(out[:, 1] - ref.y[1])) < 1e-8


def test_an_output_grid_does_not_change_the_steps():
    m = grubler.load_scene("thesis-fourbar").mechanism
    fine, alone = Simulator(m), Simulator(m)
    z, zd = fine.advance_through(np.arange(1, 2001) * 1e-3)
    alone.advance_to(2.0)
    assert fine.stats["steps"] == alone.stats["steps"]
    assert np.array_equal(fine.z, alone.z) and np.array_equal(fine.zd, alone.zd)
    assert np.array_equal(z[-1], alone.z)


def test_interpolated_states_are_put_back_on_the_closure():
    res = grubler.simulate("thesis-fourbar", t_end=5.0, dt_out=1e-3)
    assert np.max(np.abs(res["closure_error"])) < 1e-11
    # and between steps they are as accurate as at the steps' ends
    tight = grubler.simulate("thesis-fourbar", t_end=5.0, dt_out=1e-3, rtol=1e-13, atol=1e-13)
    assert np.max(np.abs(res["theta2"] - tight["theta2"])) < 1e-7


def test_fixed_step_and_rk45_still_end_a_step_at_every_output():
    m = grubler.load_scene("thesis-fourbar").mechanism
    sim = Simulator(m, integrator="rk45", rtol=1e-6, atol=1e-6)
    sim.advance_through(np.arange(1, 101) * 1e-2)
    assert sim.stats["steps"] >= 100


def test_scipy_solvers_run_one_solver_through_the_grid():
    # the penalty closure's default, Radau: one solver for the whole grid, the
    # output times from its dense output (a restart per output time cost 2x the steps)
    m = grubler.load_scene("thesis-fourbar").mechanism
    times = np.arange(1, 2001) * 1e-3
    radau = Simulator(m, method="penalty", integrator="radau", rtol=1e-8, atol=1e-8)
    z, zd = radau.advance_through(times)
    assert radau.stats["steps"] < len(times)
    assert radau.t == 2.0
    ref = Simulator(m, method="penalty", integrator="dop853", rtol=1e-11, atol=1e-11)
    z_ref, zd_ref = ref.advance_through(times)
    assert np.max(np.abs(z - z_ref)) < 1e-5
    assert np.array_equal(z[-1], radau.z)


def test_times_out_of_order_are_refused_by_name():
    # an interpolant asked for a time outside its step would extrapolate: refuse instead
    m = grubler.load_scene("thesis-fourbar").mechanism
    sim = Simulator(m)
    sim.advance_to(0.5)
    for bad in ([0.8, 0.6, 1.0], [0.2, 1.0], [0.7, np.nan], [0.7, np.inf], []):
        with pytest.raises(ValueError, match="times: must"):
            sim.advance_through(bad)
    for bad in (0.2, np.nan, np.inf):
        with pytest.raises(ValueError, match="t: must be finite and not before"):
            sim.advance_to(bad)
    assert sim.t == 0.5  # untouched
    z, _ = sim.advance_through([0.5, 0.5, 0.75, 1.0])  # repeated and current times are fine
    assert np.array_equal(z[0], z[1])


def test_a_change_point_chart_is_kept_from_one_co_simulation_step_to_the_next():
    # The coupling rod passes a change point near 0.386 s.  Stepped 1 ms at a
    # time (a co-simulation), its zone spans some twenty advances; the chart of
    # the branch through it is built once there, as in one long advance, and
    # taken up again by each next advance (rebuilding it every step made the
    # rod cost ten times a six-bar per step).  A rollback replays bit for bit.
    m = grubler.load_scene("coupling-rod").mechanism
    whole = Simulator(m)
    whole.advance_to(0.5)
    stepped = Simulator(m)
    for i in range(300):
        stepped.advance_to((i + 1) * 1e-3)
    snap = stepped.snapshot()
    for i in range(300, 500):
        stepped.advance_to((i + 1) * 1e-3)
    assert whole.stats["passage_count"] == stepped.stats["passage_count"] == 1
    assert 1 <= stepped.stats["charts"] <= whole.stats["charts"] + 1
    assert abs(whole.stats["passages"][0] - stepped.stats["passages"][0]) < 1e-8
    first = stepped.z.copy(), stepped.zd.copy()
    stepped.restore(snap)
    for i in range(300, 500):
        stepped.advance_to((i + 1) * 1e-3)
    assert stepped.z.tobytes() == first[0].tobytes() and stepped.zd.tobytes() == first[1].tobytes()
