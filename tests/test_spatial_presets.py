"""The spatial presets of issue 34's second stage (the Hooke joint, the Bennett and the Bricard linkages)
against references that share no code with the kernel:

- the Hooke joint's speed ratio omega_out / omega_in = cos(beta) / (1 - sin^2(beta) sin^2(theta));
- the Bennett linkage's closed-form input-output equation
  tan(theta1 / 2) tan(theta2 / 2) = sin((alpha2 + alpha1) / 2) / sin((alpha2 - alpha1) / 2),
  theta1 + theta3 = theta2 + theta4 = 2 pi (mod 2 pi);
- IFToMM benchmark A04 (the Bricard mechanism): its start and the reference motion of P3 as the
  benchmark library plots it;
- the body-coordinate Newton-Euler model of tests/spatial_bodies.py on every new preset: motion, and the
  reactions where the motion fixes them;
- energy conservation on every free run, the closure at rounding through long runs.
"""

import math

import numpy as np
import pytest

from grubler.errors import InputError
from grubler.mechanism import spatial as sp

from spatial_bodies import Body, BodySystem, Revolute, Torque, rotation

TIGHT = dict(rtol=1e-12, atol=1e-12)


def wrapped(angle):
    """An angle brought to (-pi, pi]."""
    return np.angle(np.exp(1j * np.asarray(angle)))


# -- the body-coordinate reference, built from the drawing: joint points and axes in the world at the start ------
def bodies_at_start(m, z0, joints, torques=()):
    """Each moving link a free body placed where the kernel's start puts it (its frame, its mass centre); the
    joints, (body i, body j or -1, world point, world axis) at the start, become revolutes between the bodies'
    own points and axes: nothing of the chain, its rows or its closures is used."""
    origins, frames = m.frames(z0)
    bodies, centres = [], []
    for k, link in enumerate(m.links):
        c = origins[k] + frames[k] @ np.array(link.com)
        centres.append(c)
        bodies.append(Body(link.mass, np.array(link.inertia), c, frames[k]))

    def local(i, point, axis):
        if i < 0:
            return np.asarray(point, float), np.asarray(axis, float)
        return frames[i].T @ (np.asarray(point, float) - centres[i]), frames[i].T @ np.asarray(axis, float)

    revolutes = []
    for i, j, point, axis in joints:
        a, u = local(i, point, axis)
        b, v = local(j, point, axis)
        revolutes.append(Revolute(i, a, j, b, u, v))
    return BodySystem(bodies, revolutes, np.array(m.gravity), [Torque(i, np.asarray(w, float), value)
                                                               for i, w, value in torques])


def worst_frame_error(m, res, system, ys):
    worst = 0.0
    for y_kernel, y_body in zip(res.y, ys):
        _, frames = m.frames(y_kernel[:m.n_coords])
        for k, part in enumerate(system.unpack(y_body)):
            worst = max(worst, np.abs(frames[k] - rotation(part[1])).max())
    return worst


def joint_moments_of_the_body_model(system, y_body):
    """Per body-model joint: the force and the moment (world) of body j on body i from its multipliers (a
    revolute's rows: the point's three, then u . n1 and u . n2, whose multipliers act as moments lam (u x n))."""
    _, lam = system.accelerations(y_body)
    parts = system.unpack(y_body)
    out, r = [], 0
    for jt in system.joints:
        force = lam[r:r + 3]
        u = rotation(parts[jt.i][1]) @ jt.u
        Rj = np.eye(3) if jt.j < 0 else rotation(parts[jt.j][1])
        v = Rj @ (jt.v / np.linalg.norm(jt.v))
        e = np.array([1.0, 0, 0]) if abs(v[0]) < 0.9 else np.array([0, 1.0, 0])  # spatial_bodies' n1, n2
        n1 = e - (e @ v) * v
        n1 /= np.linalg.norm(n1)
        moment = lam[r + 3] * np.cross(u, n1) + lam[r + 4] * np.cross(u, np.cross(v, n1))
        out.append((force, moment))
        r += 5
    return out


def minimum_norm_and_effort_checks(m, y, tau=None):
    """The kernel's reactions are a solution the loop can carry: about each revolute's own axis only the
    joint's effort passes, and the closure multipliers have no part in the null space of J^T (numpy's SVD,
    not the kernel's): the minimum-norm one.  (Every link of these presets turns on one revolute: coordinate k
    is link k's.)"""
    _, joints = m.reactions(y, tau)
    efforts = np.zeros(len(m.links)) if tau is None else np.asarray(tau)
    effort_error = np.abs(joints[:, 5] - efforts).max()
    _, lam, _ = m.dynamics(y, tau)
    _, J = m.constraint(y[:m.n_coords])
    U, s, _ = np.linalg.svd(J)
    null = U[:, np.sum(s > 1e-9 * s[0]):]  # directions no motion reaches: internal loads
    return effort_error, np.abs(null.T @ lam).max() / max(1.0, np.abs(lam).max())


# -- the Hooke joint ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def hooke_driven():
    m = sp.hooke_joint()
    tau = np.array([0.02, 0.0, 0.0])  # N m on the input shaft: from rest past five turns in 1 s
    return m, m.simulate(m.assembled_start(), t_end=1.0, dt_out=0.01, tau=tau, **TIGHT), tau


def test_hooke_joint_follows_its_speed_ratio(hooke_driven):
    m, res, _ = hooke_driven
    beta = sp.hooke_joint_geometry().shaft_angle
    shaft_in, shaft_out = np.array([0, 0, 1.0]), np.array([0, -math.sin(beta), math.cos(beta)])
    normal = np.cross(shaft_in, shaft_out) / math.sin(beta)  # square to the shafts' plane
    assert res.z[-1, 0] - res.z[0, 0] > 4 * 2 * np.pi
    worst = 0.0
    for y in res.y[1:]:
        _, frames = m.frames(y[:3])
        pin = frames[1][:, 2]  # the input yoke's pin: the cross's first axis
        theta = math.atan2(pin @ np.cross(shaft_in, normal), pin @ normal)  # from the shafts' plane's normal
        ratio = y[3 + 2] / y[3 + 0]
        worst = max(worst, abs(ratio - math.cos(beta) / (1 - math.sin(beta) ** 2 * math.sin(theta) ** 2)))
    assert worst < 1e-10
    # the output runs slow and fast by the classic factor: cos(beta) .. 1 / cos(beta)
    ratios = res.zd[1:, 2] / res.zd[1:, 0]
    assert ratios.min() == pytest.approx(math.cos(beta), abs=1e-3)
    assert ratios.max() == pytest.approx(1 / math.cos(beta), abs=1e-3)


def spherical_loop_against_bodies(m, res, tau, closing_axis):
    """A spherical four-bar (input, coupler, output; every axis through the origin) against the body model:
    the largest frame error, and the largest error of its determinate reactions (the moments square to each
    pin: every axis through the centre, no force is determinate) against the body model's multipliers."""
    z0 = res.z[0]
    _, frames = m.frames(z0)
    centre = np.zeros(3)
    joints = [(0, -1, centre, frames[0][:, 2]), (1, 0, centre, frames[1][:, 2]), (2, -1, centre, frames[2][:, 2]),
              (1, 2, centre, frames[1] @ closing_axis)]
    system = bodies_at_start(m, z0, joints, [(0, frames[0][:, 2], tau[0])])
    ys = system.run(res.t, rtol=1e-11, atol=1e-11)
    worst = 0.0
    for y_kernel, y_body in zip(res.y[1:], ys[1:]):
        z = y_kernel[:3]
        assert m.determinacy_report(z)[0] == "closure 0 (revolute): determinate My, Mx; indeterminate Fx, Fy, Fz"
        closure, joint = m.reactions(y_kernel, tau)
        _, frames = m.frames(z)
        body = joint_moments_of_the_body_model(system, y_body)
        # the closure: the output's moment on the coupler, in the closure frame on the output
        kernel = frames[2] @ (m.closure_frame(0).T @ closure[0, 3:])
        worst = max(worst, np.abs(kernel - body[3][1]).max())
        for k in range(3):  # the tree's joints: the moment of the parent (or the ground) on link k
            axis = frames[k][:, 2]
            kernel = frames[k] @ joint[k, 3:]
            kernel = kernel - (kernel @ axis) * axis  # about its own axis only the effort passes
            worst = max(worst, np.abs(kernel - body[k][1]).max())
    return worst_frame_error(m, res, system, ys), worst


def test_hooke_joint_agrees_with_a_body_coordinate_model_with_its_determinate_reactions(hooke_driven):
    m, res, tau = hooke_driven
    rows = slice(0, 41, 5)  # 0.4 s: the Python body model is slow
    frames, moments = spherical_loop_against_bodies(m, sp.SpatialResult(m, res.t[rows], res.y[rows]), tau,
                                                    np.array([0, -1.0, 0]))
    assert frames < 1e-7 and moments < 1e-8


def test_spherical_fourbar_determinate_reactions_agree_with_the_body_model():
    m, g = sp.spherical_fourbar(), sp.spherical_fourbar_geometry()
    tau = np.array([0.1, 0.0, 0.0])
    res = m.simulate(m.assembled_start(), t_end=0.3, dt_out=0.05, tau=tau, **TIGHT)
    frames, moments = spherical_loop_against_bodies(m, res, tau, np.array([0, -math.sin(g.coupler),
                                                                           math.cos(g.coupler)]))
    assert frames < 1e-7 and moments < 1e-8


def test_hooke_joint_reactions_are_minimum_norm_and_pass_only_the_efforts(hooke_driven):
    m, res, tau = hooke_driven
    for y in res.y[::20]:
        effort, null = minimum_norm_and_effort_checks(m, y, tau)
        assert effort < 1e-10 and null < 1e-10


def test_hooke_joint_refuses_a_shaft_angle_it_cannot_carry():
    with pytest.raises(InputError) as info:
        sp.hooke_joint(shaft_angle=math.radians(85))
    assert info.value.field == "shaft_angle"


# -- the Bennett linkage ------------------------------------------------------------------------------------------
def test_bennett_preset_is_a_bennett_linkage_and_overconstrained():
    g = sp.bennett_geometry()
    assert g.a1 / math.sin(g.alpha1) == pytest.approx(g.a2 / math.sin(g.alpha2), rel=1e-15)
    m = sp.bennett()
    z = m.assembled_start()[:3]
    free, rank = m.determinacy(z)
    assert rank == 2  # 5 closure rows, 3 coordinates, 1 freedom: a general 4R loop would be rigid
    # three internal loads: no component of the closure's reaction is fixed by the motion
    assert m.determinacy_report(z)[0] == "closure 0 (revolute): determinate none; indeterminate Fx, Fy, Fz, My, Mx"


def bennett_residual(g, theta1, theta2):
    """tan(theta1/2) tan(theta2/2) = sin((a2+a1)/2) / sin((a2-a1)/2), multiplied out (bounded where theta = pi)."""
    s, d = math.sin((g.alpha2 + g.alpha1) / 2), math.sin((g.alpha2 - g.alpha1) / 2)
    return (np.sin(theta1 / 2) * np.sin(theta2 / 2) * d - np.cos(theta1 / 2) * np.cos(theta2 / 2) * s) / math.hypot(s, d)


@pytest.fixture(scope="module")
def bennett_free():
    m = sp.bennett()
    zd = np.array([6.0, 0.0, 0.0])
    return m, m.simulate(m.assemble(m.sketch, zd), t_end=3.0, dt_out=0.01, **TIGHT)


def test_bennett_follows_its_closed_form_over_full_turns(bennett_free):
    m, res = bennett_free
    g = sp.bennett_geometry()
    assert res.z[:, 0].max() - res.z[:, 0].min() > 4 * np.pi  # the input turns fully, again and again
    assert np.abs(bennett_residual(g, res.z[:, 0], res.z[:, 1])).max() < 1e-11
    assert np.abs(wrapped(res.z[:, 0] + res.z[:, 2])).max() < 1e-11  # theta1 + theta3 = 2 pi
    # theta4, at the ground joint, from the frames: from link 3's common normal to the ground's (the world x)
    theta4 = []
    for z in res.z:
        _, frames = m.frames(z)
        x3 = frames[2][:, 0]
        theta4.append(math.atan2(np.cross(x3, [1.0, 0, 0]) @ [0, 0, 1.0], x3[0]))
    assert np.abs(wrapped(res.z[:, 1] + np.array(theta4))).max() < 1e-10  # theta2 + theta4 = 2 pi


def test_bennett_agrees_with_a_body_coordinate_model():
    m, g = sp.bennett(), sp.bennett_geometry()
    tau = np.array([0.05, 0.0, 0.0])
    res = m.simulate(m.assembled_start(), t_end=0.4, dt_out=0.05, tau=tau, **TIGHT)
    assert res.z[-1, 0] - res.z[0, 0] > 1.0
    origins, frames = m.frames(res.z[0])
    axes = [frames[k][:, 2] for k in range(3)]
    # the closing joint: axis 4 is the world z through the origin
    joints = [(0, -1, origins[0], axes[0]), (1, 0, origins[1], axes[1]), (2, 1, origins[2], axes[2]),
              (2, -1, np.zeros(3), np.array([0, 0, 1.0]))]
    system = bodies_at_start(m, res.z[0], joints, [(0, axes[0], tau[0])])
    ys = system.run(res.t, rtol=1e-11, atol=1e-11)
    assert worst_frame_error(m, res, system, ys) < 1e-7
    for y in res.y:
        effort, null = minimum_norm_and_effort_checks(m, y, tau)
        assert effort < 1e-10 and null < 1e-10


def test_bennett_free_run_conserves_energy_and_keeps_its_closure(bennett_free):
    m, res = bennett_free
    ke, pe = res.energy().T
    scale = ke.max() + (pe.max() - pe.min())
    assert pe.max() - pe.min() > 0.05 * scale  # gravity takes a share the check can see
    assert np.abs((ke + pe) - (ke[0] + pe[0])).max() < 1e-9 * scale
    assert res.closure_error().max() < 1e-12


# -- the Bricard linkage: IFToMM A04 ---------------------------------------------------------------------------------
# A04 as the benchmark specifies it (joint points and axes at the start, written here again from the spec)
A04_JOINTS = [((0, 0, 0), (0, 1, 0)), ((1, 0, 0), (0, 0, 1)), ((1, -1, 0), (1, 0, 0)), ((1, -1, 1), (0, 1, 0)),
              ((0, -1, 1), (0, 0, 1)), ((0, 0, 1), (1, 0, 0))]


@pytest.fixture(scope="module")
def a04_run():
    m = sp.bricard()
    return m, m.simulate(m.assembled_start(), t_end=10.0, dt_out=0.01, rtol=1e-11, atol=1e-11)


def test_bricard_starts_where_a04_puts_it():
    m = sp.bricard()
    z = m.assembled_start()[:5]
    assert np.abs(z).max() < 1e-14  # the sketch is closed as it is
    origins, frames = m.frames(z)
    for k in range(5):
        point, axis = A04_JOINTS[k]
        assert np.abs(origins[k] - point).max() < 1e-14 and np.abs(frames[k][:, 2] - axis).max() < 1e-14
        # each rod from its joint to the next, 1 m, 1 kg, its mass centre half-way
        c = origins[k] + frames[k] @ np.array(m.links[k].com)
        assert np.abs(c - (np.array(A04_JOINTS[k][0]) + A04_JOINTS[k + 1][0]) / 2).max() < 1e-14
        assert m.links[k].mass == 1.0
    assert tuple(m.gravity) == (0.0, -9.81, 0.0)
    free, rank = m.determinacy(z)
    assert rank == 4 and m.n_coords == 5  # Grübler: 6 (6 - 1) - 6 * 5 = 0; the axes' layout leaves one freedom


def test_bricard_reproduces_a04s_reference_motion_of_p3(a04_run):
    # A04's reference solution (the benchmark library's plot of P3 over 10 s): from (1, -1, 0) at rest, x falls
    # to -1 at 2.5 s and is back at 1 at 5 s; at 1.25 s P3 is at its lowest z, -0.5, and highest y, -0.866
    m, res = a04_run
    p3 = sp.bricard_p3(m, res.y)
    at = {t: p3[int(round(t / 0.01))] for t in (0.0, 1.25, 2.5, 5.0, 7.5, 10.0)}
    assert np.abs(at[0.0] - (1, -1, 0)).max() < 1e-14
    assert np.abs(at[2.5] - (-1, -1, 0)).max() < 1e-3
    assert np.abs(at[5.0] - (1, -1, 0)).max() < 1e-3
    assert np.abs(at[1.25] - (0, -math.sqrt(3) / 2, -0.5)).max() < 1e-2
    assert p3[:, 2].min() == pytest.approx(-0.5, abs=1e-6) and p3[:, 1].max() == pytest.approx(-math.sqrt(3) / 2,
                                                                                                abs=1e-6)


def test_bricard_agrees_with_a_body_coordinate_model(a04_run):
    m, res = a04_run
    joints = [(0, -1, *A04_JOINTS[0])] + [(k, k - 1, *A04_JOINTS[k]) for k in range(1, 5)] + [(4, -1, *A04_JOINTS[5])]
    system = bodies_at_start(m, res.z[0], joints)
    rows = slice(0, 101, 10)  # the first second (P3 from x = 1 to 0.2), every 0.1 s
    part = sp.SpatialResult(m, res.t[rows], res.y[rows])
    ys = system.run(part.t, rtol=1e-11, atol=1e-11)
    assert worst_frame_error(m, part, system, ys) < 1e-7
    # P3: the body model's rod 2 end (its mass centre plus half the rod along -y in its start axes)
    start = m.frames(res.z[0])[1][1]  # rod 2's axes at the start
    tip = start.T @ np.array([0, -0.5, 0])  # P3 from rod 2's mass centre, in its own axes
    for y_body, p in zip(ys, sp.bricard_p3(m, part.y)):
        c, q = system.unpack(y_body)[1][:2]
        assert np.abs(c + rotation(q) @ tip - p).max() < 1e-7
    for y in part.y:
        effort, null = minimum_norm_and_effort_checks(m, y)
        assert effort < 1e-10 and null < 1e-10


def test_bricard_conserves_energy_and_its_closure_through_a_long_run():
    # A04's own measure of a run (the benchmark library's: the change of the mechanical energy), over 100 s
    m = sp.bricard()
    res = m.simulate(m.assembled_start(), t_end=100.0, dt_out=0.5, rtol=1e-11, atol=1e-11)
    ke, pe = res.energy().T
    assert ke.max() > 4.0  # 4.55 J at the bottom of each swing
    assert np.abs((ke + pe) - (ke[0] + pe[0])).max() < 1e-9 * ke.max()
    assert res.closure_error().max() < 1e-12


# -- energy on every new preset's free run; the closure through a long run ----------------------------------------
@pytest.mark.parametrize("build, rate", [(sp.hooke_joint, 8.0), (sp.bennett, 4.0), (sp.bricard, 1.0)])
def test_new_presets_conserve_energy_on_free_runs(build, rate):
    m = build()
    zd = np.zeros(m.n_coords)
    zd[0] = rate
    res = m.simulate(m.assemble(m.sketch, zd), t_end=20.0, dt_out=0.1, **TIGHT)
    ke, pe = res.energy().T
    scale = ke.max() + (pe.max() - pe.min())
    assert ke.max() > 0.05 * scale
    assert np.abs((ke + pe) - (ke[0] + pe[0])).max() < 1e-9 * scale
    assert res.closure_error().max() < 1e-12


def test_every_preset_is_in_the_registry_and_builds():
    assert set(sp.PRESETS) >= {"rssr", "rssp", "spherical-fourbar", "planar-fourbar-3d", "hooke-joint", "bennett",
                               "bricard"}
    for name, build in sp.PRESETS.items():
        m = build()
        y0 = m.assembled_start()
        assert np.abs(m.constraint(y0[:m.n_coords])[0]).max() < 1e-12, name


# -- the RSSP against the body model: motion and every reaction (the loop is not overconstrained) --------------------
def test_rssp_agrees_with_a_body_coordinate_model_in_motion_and_every_reaction():
    from spatial_bodies import GroundPrismatic, GroundRevolute, Spherical

    m, g = sp.rssp(), sp.rssp_geometry()
    tau = np.zeros(m.n_coords)
    tau[0] = 1.0
    res = m.simulate(m.assembled_start(), t_end=0.5, dt_out=0.05, tau=tau, **TIGHT)
    z0 = res.z[0]
    origins, frames = m.frames(z0)
    crank, coupler, slider = 0, 3, 4
    bodies, com = [], []
    for k in (crank, coupler, slider):
        link = m.links[k]
        com.append(np.array(link.com))
        bodies.append(Body(link.mass, np.array(link.inertia), origins[k] + frames[k] @ com[-1], frames[k]))
    ez = np.array([0, 0, 1.0])
    line = np.array([0.0, -math.sin(g.twist), math.cos(g.twist)])
    joints = [GroundRevolute(0, -com[0], np.array([0, 0, g.height]), ez, ez),
              Spherical(0, np.array([g.crank, 0, 0]) - com[0], 1, -com[1]),
              Spherical(1, np.array([0, 0, g.coupler]) - com[1], 2, -com[2]),
              GroundPrismatic(2, -com[2], np.array([g.offset, 0, 0]), line, frames[slider])]
    slider_start = frames[slider]
    system = BodySystem(bodies, joints, np.array(m.gravity), [Torque(0, ez, tau[0])])
    ys = system.run(res.t, rtol=1e-11, atol=1e-11)
    assert res.z[-1, 0] - res.z[0, 0] > 2.0
    worst_motion = worst_reaction = 0.0
    for y_kernel, y_body in zip(res.y, ys):
        z = y_kernel[:m.n_coords]
        (c0, q0, *_), (c1, q1, *_), (c2, q2, *_) = system.unpack(y_body)
        Rc = rotation(q0)
        crank_angle = math.atan2(Rc[1, 0], Rc[0, 0])
        slide = (c2 - np.array([g.offset, 0, 0])) @ line
        _, frames = m.frames(z)
        worst_motion = max(worst_motion, abs(wrapped(crank_angle - z[0])), abs(slide - z[4]),
                           np.abs(frames[coupler] - rotation(q1)).max(), np.abs(frames[slider] - rotation(q2)).max())
        closure, joint = m.reactions(y_kernel, tau)
        _, lam = system.accelerations(y_body)
        scale = max(1.0, np.abs(lam).max())
        # the ball at the coupler's end: the slider on the coupler
        worst_reaction = max(worst_reaction, np.abs(frames[slider] @ closure[0, :3] - lam[8:11]).max() / scale)
        # the crank's bearing: the ground on the crank (about its axis only the drive passes)
        u = Rc[:, 2]
        n1 = np.array([1.0, 0, 0])
        n2 = np.cross(ez, n1)
        moment = lam[3] * np.cross(u, n1) + lam[4] * np.cross(u, n2)
        kernel = frames[crank] @ joint[crank, 3:]
        worst_reaction = max(worst_reaction, np.abs(frames[crank] @ joint[crank, :3] - lam[0:3]).max() / scale,
                             np.abs(kernel - (kernel @ u) * u - moment).max() / scale)
        # the ball at the crank pin: the crank on the coupler is minus the coupler on the crank; no moment
        worst_reaction = max(worst_reaction, np.abs(frames[coupler] @ joint[coupler, :3] + lam[5:8]).max() / scale,
                             np.abs(joint[coupler, 3:]).max() / scale)
        # the slide: the ground on the slider, a force across the line and a moment that holds its axes
        e = np.array([1.0, 0, 0]) if abs(line[0]) < 0.9 else np.array([0, 1.0, 0])  # spatial_bodies' n1, n2
        m1 = e - (e @ line) * line
        m1 /= np.linalg.norm(m1)
        force = lam[11] * m1 + lam[12] * np.cross(line, m1)
        R2 = rotation(q2)  # the rows R e_a . R0 e_b: each multiplier a moment lam (R e_a x R0 e_b)
        moment = sum(lam[13 + r] * np.cross(R2[:, a], slider_start[:, b])
                     for r, (a, b) in enumerate(((0, 1), (0, 2), (1, 2))))
        worst_reaction = max(worst_reaction, np.abs(frames[slider] @ joint[slider, :3] - force).max() / scale,
                             np.abs(frames[slider] @ joint[slider, 3:] - moment).max() / scale)
    assert worst_motion < 1e-7
    assert worst_reaction < 1e-6
