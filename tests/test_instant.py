"""The analysis on the drawing (grubler.mechanism.instant) against references that share no code with it.

- velocities and accelerations: central finite differences of positions (the
  kernel's ``link_points``, no Jacobian) along z(t) = z + t zd + t^2/2 zdd;
- instant centres: the velocity field, by finite differences too: the centre's
  point has the same velocity on both bodies;
- joint forces: the ``R<k>_*``, ``Fx``... columns of ``grubler simulate
  --reactions`` run as a separate process, and Newton's law for each link
  (the forces on it and its weight give its mass times its centre's
  finite-difference acceleration);
- the transmission angle: the four-bar's law of cosines, the slider-crank's rod
  against its guide;
- toggles: where crank and coupler line up.
"""

import csv
import itertools
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import grubler
from grubler.mechanism.assembly import assemble
from grubler.mechanism.dynamics import Inputs
from grubler.mechanism.instant import (
    analyse_instant,
    instant_centres,
    joint_forces,
    kennedy_residual,
    kinematic_rates,
    mechanical_advantage,
    motion,
    transmission_angles,
    turn_analysis,
)
from grubler.mechanism.kinematics import chain_kinematics, link_points, point_on_link

PRESETS = ["fourbar-crank-rocker", "thesis-fourbar", "slider-crank", "offset-slider-crank", "thesis-quick-return",
           "watt-ii", "stephenson-iii", "watt-i", "triple-pendulum", "thesis-scotch-yoke"]
H = 1e-4  # s, the finite-difference step along the motion
GRAVITY = 9.80665


def closed(name, turn=0.0):
    """The preset's mechanism at its sketch, the drive turned by ``turn`` (rad) from it, closed."""
    m = grubler.load_scene(name).mechanism
    z = m.z_from_q(m.q_ref)
    z = assemble(m, z)[0]
    if turn:
        z = z.copy()
        z[m.free_index(m.drive)] += turn
        z = assemble(m, z)[0]
    return m, z


def frames(m, zs):
    """Each body's origin and unit axes at positions zs (rows, N), from link_points alone: (rows, B, 3, 2)."""
    n = m.n_links
    pts = link_points(m, zs, [k for k in range(n) for _ in range(3)], [(0, 0), (1, 0), (0, 1)] * n)
    pts = pts.reshape(len(zs), n, 3, 2)
    ground = np.broadcast_to(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), (len(zs), 1, 3, 2))
    return np.concatenate([ground, pts], axis=1)


def fixed_point(m, z, body, p):
    """The coordinates, in ``body``'s frame, of the point now at world ``p`` (from link_points)."""
    f = frames(m, [z])[0, body - 1]
    o, ex, ey = f[0], f[1] - f[0], f[2] - f[0]
    return (float(np.dot(p - o, ex)), float(np.dot(p - o, ey)))


def path_of(m, z, zd, zdd, body, local, h=H):
    """The world positions at t = -h, 0, h of a point fixed to ``body`` along z + t zd + t^2/2 zdd."""
    zs = [z + t * zd + 0.5 * t * t * zdd for t in (-h, 0.0, h)]
    f = frames(m, zs)[:, body - 1]
    return f[:, 0] + local[0] * (f[:, 1] - f[:, 0]) + local[1] * (f[:, 2] - f[:, 0])


def fd_velocity(m, z, zd, zdd, body, local):
    p = path_of(m, z, zd, zdd, body, local)
    return (p[2] - p[0]) / (2 * H), (p[2] - 2 * p[1] + p[0]) / H ** 2


def test_a_points_jacobian_counts_its_predecessors_joints():
    # grb_point_on_link read a workspace whose "which joints move which link" was never set in that call: the
    # coupler's and the rocker's points got a Jacobian of zeros for the crank's joint
    m, z = closed("fourbar-crank-rocker", 0.7)
    zd = np.array([1.0, -0.4, 0.3])
    kin = chain_kinematics(m, z, zd)
    for k, local in ((1, (0.3, 0.1)), (2, (0.2, -0.05))):
        _, J, _ = point_on_link(kin, k, local)
        v, _ = fd_velocity(m, z, zd, np.zeros(3), k + 2, local)
        assert np.allclose(J @ zd, v, atol=1e-7), (k, J @ zd, v)


@pytest.mark.parametrize("name", PRESETS)
def test_velocities_and_accelerations_are_the_positions_derivatives(name):
    m, z = closed(name, 0.4)
    rng = np.random.default_rng(3)
    # any state: rates and accelerations that need not satisfy the closures, the fields are linear in them
    zd, zdd = rng.normal(size=m.n_links), rng.normal(size=m.n_links)
    mo = motion(m, z, zd, zdd)
    for body in range(1, m.n_links + 2):
        for local in ((0.0, 0.0), (0.3, -0.2)):
            p = path_of(m, z, zd, zdd, body, local)[1]
            v, a = fd_velocity(m, z, zd, zdd, body, local)
            assert np.allclose(mo.velocity(body, p), v, atol=1e-6), (body, local)
            assert np.allclose(mo.acceleration(body, p), a, atol=1e-4), (body, local)


@pytest.mark.parametrize("name", [n for n in PRESETS if n != "triple-pendulum"])
def test_the_steady_drive_keeps_every_loop_closed_to_second_order(name):
    m, z = closed(name, 0.4)
    zd, zdd = kinematic_rates(m, z)
    assert zd[m.free_index(m.drive)] == pytest.approx(1.0) and zdd[m.free_index(m.drive)] == pytest.approx(0.0)
    for cl in m.closures:
        # the closing point as a point of each of its two bodies: same velocity and acceleration
        p = path_of(m, z, zd, zdd, cl.link, cl.point)[1]
        there = fixed_point(m, z, cl.to_link, p)
        v1, a1 = fd_velocity(m, z, zd, zdd, cl.link, cl.point)
        v2, a2 = fd_velocity(m, z, zd, zdd, cl.to_link, there)
        if cl.kind == "revolute":
            assert np.allclose(v1, v2, atol=1e-6) and np.allclose(a1, a2, atol=1e-4)


@pytest.mark.parametrize("name", PRESETS)
def test_instant_centres_are_where_the_two_bodies_velocities_agree(name):
    m, z = closed(name, 0.4)
    zd, zdd = kinematic_rates(m, z)
    mo = motion(m, z, zd, zdd)
    centres = instant_centres(mo)
    bodies = m.n_links + 1
    assert len(centres) == bodies * (bodies - 1) // 2
    scale = max(float(np.abs(mo.v).max()), 1.0)
    checked = 0
    for ic in centres:
        if ic.point is not None:
            vi, _ = fd_velocity(m, z, zd, zdd, ic.i, fixed_point(m, z, ic.i, ic.point))
            vj, _ = fd_velocity(m, z, zd, zdd, ic.j, fixed_point(m, z, ic.j, ic.point))
            assert np.allclose(vi, vj, atol=1e-6 * scale * max(1.0, np.abs(ic.point).max())), ic.label
            checked += 1
        elif ic.direction is not None:
            # at infinity: the two only translate relative to each other, across the centre's direction
            rel = []
            for p in (np.zeros(2), np.array([0.5, 0.3])):
                vi, _ = fd_velocity(m, z, zd, zdd, ic.i, fixed_point(m, z, ic.i, p))
                vj, _ = fd_velocity(m, z, zd, zdd, ic.j, fixed_point(m, z, ic.j, p))
                rel.append(vi - vj)
            assert np.allclose(rel[0], rel[1], atol=1e-6) and abs(rel[0] @ ic.direction) < 1e-6, ic.label
            assert np.linalg.norm(rel[0]) > 1e-6
            checked += 1
        else:  # no centre: no relative motion at all
            p = np.array([0.5, 0.3])
            vi, _ = fd_velocity(m, z, zd, zdd, ic.i, fixed_point(m, z, ic.i, p))
            vj, _ = fd_velocity(m, z, zd, zdd, ic.j, fixed_point(m, z, ic.j, p))
            assert np.allclose(vi, vj, atol=1e-6), ic.label
    assert checked >= bodies - 1  # every link has its centre with the ground (or moves with it)
    # Kennedy: any three bodies' centres on one line
    by = {(ic.i, ic.j): ic for ic in centres}
    for i, j, k in itertools.combinations(range(1, bodies + 1), 3):
        three = (by[i, j], by[j, k], by[i, k])
        if all(c.point is not None or c.direction is not None for c in three):
            assert kennedy_residual(*three) < 1e-8, [c.label for c in three]


def test_a_slider_has_its_centre_with_the_ground_at_infinity_across_its_guide():
    m, z = closed("slider-crank", 0.4)
    mo = motion(m, z, *kinematic_rates(m, z))
    i14 = next(c for c in instant_centres(mo) if (c.i, c.j) == (1, 4))
    assert i14.point is None and np.allclose(i14.direction, [0.0, 1.0])  # the guide is along x


def fourbar_mu(m, theta2):
    """The four-bar's transmission angle by the law of cosines, acute, deg."""
    a, b, c = (l.a for l in m.links)
    d = math.dist((0.0, 0.0), m.closures[0].to_point)
    cos = (b * b + c * c - d * d - a * a + 2 * a * d * np.cos(theta2)) / (2 * b * c)
    mu = np.degrees(np.arccos(cos))
    return np.minimum(mu, 180.0 - mu)


def test_the_four_bars_transmission_angle_is_the_law_of_cosines_over_a_turn():
    m, z = closed("fourbar-crank-rocker")
    zs = [z]
    for step in range(1, 120):
        guess = zs[-1].copy()
        guess[0] = z[0] + step * 2 * math.pi / 120
        zs.append(assemble(m, guess)[0])
    zs = np.array(zs)
    turn = turn_analysis(m, zs)
    assert np.allclose(turn.angles["mu34"], fourbar_mu(m, zs[:, 0]), atol=1e-9)
    least, row = turn.least["mu34"]
    assert least == pytest.approx(fourbar_mu(m, zs[:, 0]).min(), abs=1e-9)
    # one instant as the sweep's row
    mo = motion(m, zs[17], *kinematic_rates(m, zs[17]))
    assert transmission_angles(m, mo)[0].angle_deg == pytest.approx(turn.angles["mu34"][17], abs=1e-9)
    # the toggles: where crank and coupler line up (the cross product of their vectors changes sign)
    f = frames(m, zs)
    crank, coupler = f[:, 1, 1] - f[:, 1, 0], f[:, 2, 1] - f[:, 2, 0]
    cross = crank[:, 0] * coupler[:, 1] - crank[:, 1] * coupler[:, 0]
    flips = [r for r in range(len(zs) - 1) if cross[r] * cross[r + 1] < 0]
    assert len(turn.toggles) == len(flips) == 2
    assert all(min(abs(t - f_) for f_ in flips) <= 1 for t in turn.toggles)


def test_the_slider_cranks_transmission_angle_is_the_rods_against_the_guides_normal():
    m, z = closed("offset-slider-crank", 0.9)
    mo = motion(m, z, *kinematic_rates(m, z))
    (mu,) = transmission_angles(m, mo)
    f = frames(m, [z])[0]
    rod = f[3, 0] - f[2, 0]  # crank pin to the block's pin
    guide = np.array([math.cos(m.closures[0].angle), math.sin(m.closures[0].angle)])
    beta = math.degrees(math.acos(abs(rod @ guide) / np.linalg.norm(rod)))  # rod against the guide, acute
    assert mu.angle_deg == pytest.approx(90.0 - beta, abs=1e-9)


def test_the_six_bar_has_a_transmission_angle_in_each_of_its_four_bars():
    m, z = closed("watt-ii", 0.4)
    mo = motion(m, z, *kinematic_rates(m, z))
    assert [t.label for t in transmission_angles(m, mo)] == ["mu34", "mu56"]


@pytest.mark.parametrize("name", ["fourbar-crank-rocker", "slider-crank", "watt-ii"])
def test_the_mechanical_advantage_is_the_drives_rate_over_the_outputs(name):
    m, z = closed(name, 0.4)
    zd, zdd = kinematic_rates(m, z)
    ma = mechanical_advantage(m, motion(m, z, zd, zdd), zd)
    zs = [z + t * zd for t in (-H, H)]
    f = frames(m, zs)[:, ma.output - 1]
    if ma.unit == "":
        ex = f[:, 1] - f[:, 0]
        rate = (math.atan2(ex[1, 1], ex[1, 0]) - math.atan2(ex[0, 1], ex[0, 0])) / (2 * H)
    else:  # a block on the ground's guide, along x
        rate = (f[1, 0, 0] - f[0, 0, 0]) / (2 * H)
    assert ma.value == pytest.approx(1.0 / rate, rel=1e-6)


def newton_residual(m, z, zd, zdd, forces, gravity):
    """Per moving link, |sum of the joint forces on it and its weight - m a_C| (finite-difference a_C)."""
    out = []
    for k, link in enumerate(m.links):
        body = k + 2
        total = np.array([0.0, -link.m * gravity])
        for f in forces:
            total += f.force if f.on == body else -f.force if f.by == body else 0.0
        _, a = fd_velocity(m, z, zd, zdd, body, (link.p, link.q))
        out.append(np.linalg.norm(total - link.m * a))
    return np.array(out)


@pytest.mark.parametrize("name,torque", [("slider-crank", 2.0), ("watt-ii", 0.05), ("fourbar-crank-rocker", 1.0)])
def test_joint_forces_are_grubler_simulate_reactions_and_newtons_law(name, torque, tmp_path):
    out = tmp_path / "run.csv"
    subprocess.run([str(Path(sys.executable).with_name("grubler")), "simulate", name, "--t-end", "0.3", "--dt-out",
                    "0.1", "--torque", str(torque), "--method", "exact", "--reactions", "--csv", str(out)], check=True,
                   capture_output=True)
    rows = list(csv.reader(open(out)))
    head = [h.split(" [")[0] for h in rows[0]]
    row = dict(zip(head, map(float, rows[-1])))
    m = grubler.load_scene(name).mechanism
    names = m.coordinate_names
    z, zd = m.z_from_q([row[c] for c in names]), m.zd_from_qd([row[c + "_d"] for c in names])
    forces = joint_forces(m, z, zd, Inputs(drive=torque))
    expected = [(row[f"R{k}_Fx"], row[f"R{k}_Fy"]) for k in range(1, m.n_links + 1)]
    expected += [(row["Fx"], row["Fy"])] + [(row[f"closure{j}_Fx"], row[f"closure{j}_Fy"])
                                             for j in range(1, len(m.closures))]
    got = [tuple(f.force) for f in forces]
    scale = max(abs(v) for e in expected for v in e)
    assert np.allclose(got, expected, rtol=1e-6, atol=1e-8 * scale)
    # and the moments: a chain pin's is its own torque (the drive's, less the joint's damping); they came out wrong
    # from joint_reactions while the kernel's point Jacobians missed the predecessors' joints
    moments = [row[f"R{k}_Mz"] for k in range(1, m.n_links + 1)]
    assert np.allclose([f.moment for f in forces[:m.n_links]], moments, rtol=1e-6, atol=1e-9 * scale)
    own = [(torque if k == m.free_index(m.drive) else 0.0) - link.damping * zd[k] for k, link in enumerate(m.links)]
    assert np.allclose(moments, own, rtol=1e-6, atol=1e-9 * scale)
    zdd = grubler.forward_dynamics(m, z, zd, Inputs(drive=torque)).zdd
    assert newton_residual(m, z, zd, zdd, forces, m.gravity).max() < 1e-4 * scale


@pytest.mark.parametrize("name", ["fourbar-crank-rocker", "slider-crank", "watt-ii", "stephenson-iii"])
def test_the_drawings_forces_hold_the_steady_drive(name):
    # no run: the drive effort that holds 1 rad/s (inverse dynamics), and the forces of that motion
    m, z = closed(name, 0.4)
    out = analyse_instant(m, z)
    zd, zdd = kinematic_rates(m, z)
    assert np.allclose(out.zd, zd) and np.allclose(out.zdd, zdd, atol=1e-9)
    scale = max(np.linalg.norm(f.force) for f in out.forces)
    assert newton_residual(m, z, out.zd, out.zdd, out.forces, m.gravity).max() < 1e-4 * scale


def test_an_open_chain_has_centres_but_no_transmission_angle_nor_output():
    m, z = closed("triple-pendulum")
    out = analyse_instant(m, z)
    assert out.transmission == [] and out.advantage is None
    i23 = next(c for c in out.centres if (c.i, c.j) == (2, 3))
    assert i23.point is None and i23.direction is None  # the others stand still: link 3 moves with link 2


def test_a_parallelogram_through_its_change_point_has_no_toggle_and_a_clamp_has_its_rocker_as_output():
    from grubler.app.actions import drive_sweep

    # past the change point the sweep may fold the links onto one another: the output stands still there, and
    # rounding flipped its rate's sign from row to row (28 "toggles" were marked)
    m, z = closed("fourbar-parallelogram")
    assert turn_analysis(m, drive_sweep(m, z, 180)).toggles == []
    # a toggle clamp's load is on its crank, the drive's own joint: its output is still the rocker
    m, z = closed("toggle-clamp")
    zd, zdd = kinematic_rates(m, z)
    assert mechanical_advantage(m, motion(m, z, zd, zdd), zd).output == 4


def test_a_drive_that_cannot_turn_fully_has_its_limits_where_the_loop_stops_closing():
    from grubler.app.actions import drive_sweep

    m, z = closed("fourbar-triple-rocker")
    zs = drive_sweep(m, z, 180)
    turn = turn_analysis(m, zs)
    assert turn.limits == [0, len(zs) - 1]
    # a step of the sweep beyond either end, the loop cannot close: the drive stops there
    from grubler.errors import AssemblyError

    step = 2 * math.pi / 180
    for row, sign in ((0, -1), (-1, 1)):
        beyond = zs[row].copy()
        beyond[0] += sign * step
        with pytest.raises(AssemblyError):
            assemble(m, beyond)
    m, z = closed("fourbar-crank-rocker")
    assert turn_analysis(m, drive_sweep(m, z, 180)).limits == []


def test_a_run_at_rest_still_has_its_positions_centres_angle_and_advantage():
    m, z = closed("fourbar-crank-rocker", 0.4)
    at_rest = analyse_instant(m, z, np.zeros(3), Inputs(drive=1.0))
    steady = analyse_instant(m, z)
    assert [t.angle_deg for t in at_rest.transmission] == pytest.approx([t.angle_deg for t in steady.transmission])
    assert at_rest.advantage.value == pytest.approx(steady.advantage.value)
    assert all(a.point is not None and np.allclose(a.point, b.point) for a, b in zip(at_rest.centres, steady.centres))
    assert np.allclose(at_rest.motion.v, 0.0)  # its velocities are the run's: none
