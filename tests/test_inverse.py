"""Drive demand (inverse dynamics along a trajectory) against a forward simulation
and against hand arithmetic."""

import numpy as np
import pytest
import scipy.interpolate

import grubler
from grubler.mechanism.inverse import drive_demand


def smooth_move(t):
    # a quintic rest-to-rest move of the crank by 2 rad in 1 s: position, rate, acceleration
    s = np.clip(t, 0.0, 1.0)
    return (2 * (10 * s**3 - 15 * s**4 + 6 * s**5), 2 * (30 * s**2 - 60 * s**3 + 30 * s**4),
            2 * (60 * s - 180 * s**2 + 120 * s**3))


@pytest.mark.parametrize("preset", ["thesis-fourbar", "thesis-slider-crank"])
def test_the_demanded_torque_drives_a_forward_simulation_along_the_trajectory(preset):
    scene = grubler.load_scene(preset)
    m = scene.mechanism.replace(drive_inertia=0.02)
    m = m.replace(load=m.drive)
    t = np.linspace(0.0, 1.0, 2001)
    pos, vel, acc = smooth_move(t)
    z0 = m.z_from_q(m.q_ref)
    d = m.free_index(m.drive)
    pos = pos + z0[d]
    demand = drive_demand(m, pos, vel, acc, load=0.5)
    spline = scipy.interpolate.CubicSpline(t, demand.torque)
    torque = lambda tt: float(spline(tt))  # noqa: E731
    sim = grubler.Simulator(m, z0=demand.z[0], zd0=demand.zd[0], drive_function=torque,
                            inputs=grubler.Inputs(0.0, 0.5), max_step=1e-3)
    errs = []
    for tk in (0.25, 0.5, 0.75, 1.0):
        sim.advance_to(tk)
        errs.append(abs(sim.z[d] - np.interp(tk, t, pos)))
    # what is left is the interpolation of the torque between samples
    assert max(errs) < 1e-7, errs


def test_a_balanced_crank_at_constant_speed_needs_only_its_friction_and_load():
    # a lone crank with its mass centre on the axis, no gravity effect, damped joint
    link = grubler.Link("R", a=0.3, p=0.0, q=0.0, m=2.0, I=0.05, damping=0.4)
    m = grubler.Mechanism(links=(link,), drive="theta2", load="theta2", gravity=9.81)
    t = np.linspace(0, 2, 9)
    d = drive_demand(m, 5.0 * t, np.full(9, 5.0), np.zeros(9), load=-1.5)
    assert np.allclose(d.torque, 0.4 * 5.0 + 1.5, atol=1e-12)  # damping x speed minus the load
    assert np.allclose(d.power, (0.4 * 5.0 + 1.5) * 5.0)


def test_drive_demand_refuses_what_it_cannot_do():
    m = grubler.load_scene("thesis-fourbar").mechanism
    with pytest.raises(grubler.SceneError, match="trajectory: position, velocity and acceleration"):
        drive_demand(m, [0.0, 1.0], [0.0], [0.0, 0.0])
    with pytest.raises(grubler.SceneError, match="trajectory.velocity: must be finite"):
        drive_demand(m, [0.0], [np.nan], [0.0])
    with pytest.raises(grubler.SceneError, match="load.joint"):
        drive_demand(m, [0.0], [0.0], [0.0], load=1.0)
    with pytest.raises(grubler.SceneError, match="drive.joint"):
        drive_demand(m.replace(drive=None), [0.0], [0.0], [0.0])
    with pytest.raises(grubler.SceneError, match="has 3"):
        drive_demand(grubler.load_scene("triple-pendulum").mechanism.replace(drive="theta2"), [0.0], [0.0], [0.0])
