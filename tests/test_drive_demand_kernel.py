"""The kernel's drive demand (grb_drive_demand): against the numpy computation it replaced, against
an energy balance written from scratch, and its refusals."""

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson

import grubler
from grubler import binding
from grubler.mechanism.assembly import SINGULAR_RCOND
from grubler.mechanism.inverse import drive_demand

from drive_demand_reference import numpy_drive_demand
from reference import RefChain


def quintic(t, stroke):
    # a rest-to-rest move over [0, 1] s: position, rate and acceleration
    s = np.clip(t, 0.0, 1.0)
    return (stroke * (10 * s**3 - 15 * s**4 + 6 * s**5), stroke * (30 * s**2 - 60 * s**3 + 30 * s**4),
            stroke * (60 * s - 180 * s**2 + 120 * s**3))


def move(m, n, stroke):
    pos, vel, acc = quintic(np.linspace(0.0, 1.0, n), stroke)
    return pos + m.z_from_q(m.q_ref)[m.free_index(m.drive)], vel, acc


@pytest.mark.parametrize("preset, stroke", [("thesis-fourbar", 2 * math.pi), ("thesis-fourbar-damped", 1.0),
                                            ("slider-crank", 2 * math.pi), ("thesis-double-slider", 0.8),
                                            ("stephenson-iii", 0.5), ("watt-ii", 0.5), ("quick-return", 3.0)])
def test_the_kernel_gives_what_the_numpy_computation_it_replaced_gave(preset, stroke):
    m = grubler.load_scene(preset).mechanism.replace(drive_inertia=0.01)
    m = m.replace(load=m.drive)
    pos, vel, acc = move(m, 201, stroke)
    load = 0.3 * np.sin(3 * pos)
    d = drive_demand(m, pos, vel, acc, load=load)
    tau, z, zd, zdd, force = numpy_drive_demand(m, pos, vel, acc, load)
    scale = 1.0 + np.max(np.abs(tau))
    # the same equations solved by other least-squares codes: rounding apart
    assert np.max(np.abs(d.torque - tau)) < 1e-9 * scale
    assert np.max(np.abs(d.z - z)) < 1e-10
    assert np.max(np.abs(d.zd - zd)) < 1e-9 * (1 + np.max(np.abs(zd)))
    assert np.max(np.abs(d.zdd - zdd)) < 1e-8 * (1 + np.max(np.abs(zdd)))
    assert np.max(np.abs(d.closing_force - force)) < 1e-9 * (1 + np.max(np.abs(force)))


@pytest.mark.parametrize("preset, stroke", [("thesis-fourbar-damped", 2 * math.pi), ("slider-crank", 2 * math.pi),
                                            ("elliptic-trammel", 1.0), ("quick-return", 3.0)])
def test_the_drive_work_is_the_energy_gained_and_the_damping_losses(preset, stroke):
    # drive power = d/dt (kinetic + potential energy) + sum of damping c zd^2, written from the
    # reference's own complex-number kinematics (no kernel call), integrated over the move
    m = grubler.load_scene(preset).mechanism.replace(drive_inertia=0.02)
    pos, vel, acc = move(m, 4001, stroke)
    d = drive_demand(m, pos, vel, acc)
    t = np.linspace(0.0, 1.0, pos.size)
    ref = RefChain.of(m)
    zero = m.q_from_z(np.zeros(m.n_free))
    energy = np.empty(pos.size)
    for k in range(pos.size):
        ke, pe = ref.energy(m.q_from_z(d.z[k]), m.q_from_z(d.zd[k]) - zero)
        energy[k] = ke + pe + 0.5 * m.drive_inertia * vel[k] ** 2
    damping = np.array([link.damping for link in m.links])
    losses = cumulative_simpson((d.zd**2) @ damping, x=t, initial=0.0)
    work = cumulative_simpson(d.torque * vel, x=t, initial=0.0)
    exchanged = np.max(np.abs(work)) + np.ptp(energy)
    # measured 7e-12 to 4e-11 of it (Simpson's rule and the reference's finite-difference rates);
    # leaving out the drive inertia's energy or the damping costs 2e-3 to 0.5
    assert np.max(np.abs(work - (energy - energy[0]) - losses)) < 1e-8 * exchanged


def test_the_change_point_threshold_is_one_number():
    header = (Path(grubler.__file__).parent / "kernel" / "grubler.h").read_text()
    assert float(re.search(r"#define GRB_CHANGE_POINT_RCOND (\S+)", header).group(1)) == SINGULAR_RCOND


def test_the_kernel_refuses_what_it_cannot_do():
    m = grubler.load_scene("thesis-fourbar").mechanism
    z0 = m.z_from_q(m.q_ref)
    one = np.zeros(1)
    run = binding.drive_demand(grubler.load_scene("triple-pendulum").mechanism.arrays, 1.0, one, one, one, one,
                               np.zeros(3))
    assert (run.status, run.at) == (binding.BAD_ARGUMENT, -1)  # mobility three
    run = binding.drive_demand(m.arrays, 1.0, np.array([0.0, 0.1, 0.2]), np.array([0.0, 1.0, np.inf]),
                               np.zeros(3), np.zeros(3), z0)
    assert (run.status, run.at) == (binding.BAD_ARGUMENT, 2)  # a sample that is not finite
    assert np.all(np.isfinite(run.torque[:2]))  # the samples before it are done


def test_a_drive_position_the_loop_cannot_reach_is_refused_naming_the_sample():
    m = grubler.load_scene("fourbar-double-rocker").mechanism
    d = m.free_index(m.drive)
    z0 = m.z_from_q(m.q_ref)
    pos = z0[d] + np.linspace(0.0, math.pi, 7)
    with pytest.raises(grubler.AssemblyError, match=r"trajectory at sample \d .*the loop cannot be closed with"):
        drive_demand(m, pos, np.zeros(7), np.zeros(7))


def test_a_drive_motion_through_a_dead_centre_is_refused_as_a_change_point():
    m = grubler.load_scene("fourbar-change-point").mechanism
    pos = np.array([math.pi - 0.02, math.pi - 0.01, math.pi])
    with pytest.raises(grubler.SceneError, match=r"trajectory at sample 2 \(drive 3.14159\): the drive passes a "
                                                 r"change point"):
        drive_demand(m, pos, np.ones(3), np.zeros(3))
    with pytest.raises(ValueError, match="change point at sample 2"):
        numpy_drive_demand(m, pos, np.ones(3), np.zeros(3), np.zeros(3))
