"""The spatial chain (kernel/spatial, grubler.mechanism.spatial) against references that share no code with it.

- the thesis four-bar written as spatial against the planar kernel (grubler.simulate);
- the RSSR's closed-form input-output equation (Freudenstein-type: A cos psi + B sin psi = C);
- the spherical four-bar's closed-form input-output relation (u(phi) . v(psi) = cos alpha3);
- energy conservation on free runs;
- a body-coordinate spatial model (tests/spatial_bodies.py: Newton-Euler on quaternions, joint
  constraints, scipy) on the RSSR: motion and the closure's reaction;
- the overconstrained loops' determinacy reports; the joint reactions' own balance;
- bad models refused with the field named.
"""

import math

import numpy as np
import pytest

import grubler
from grubler.errors import InputError
from grubler.mechanism import spatial as sp

from spatial_bodies import Body, BodySystem, GroundRevolute, Revolute, Spherical, Torque, rotation

TIGHT = dict(rtol=1e-12, atol=1e-12)


# -- the planar four-bar written as spatial ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def planar_run():
    return grubler.simulate("thesis-fourbar", t_end=2.0, dt_out=0.01, method="exact", **TIGHT)


@pytest.mark.parametrize("closure", ["revolute", "spherical", "cylindrical"])
def test_planar_fourbar_written_as_spatial_equals_the_planar_kernel(planar_run, closure):
    m = sp.planar_fourbar(closure)
    res = m.simulate(m.assembled_start(), t_end=2.0, dt_out=0.01, **TIGHT)
    absolute = np.cumsum(res.z, axis=1)  # the planar kernel reports absolute angles theta2..4
    rates = np.cumsum(res.zd, axis=1)
    for k, name in enumerate(("theta2", "theta3", "theta4")):
        assert np.abs(absolute[:, k] - planar_run[name]).max() < 1e-10, name
        assert np.abs(rates[:, k] - planar_run[name + "_d"]).max() < 1e-10, name
    # the closure force on link 4 (the ground's, in the ground's x, y) is the planar kernel's Fx, Fy
    forces = np.array([m.reactions(y)[0][0, :2] for y in res.y[::20]])
    assert np.abs(forces[:, 0] - planar_run["Fx"][::20]).max() < 1e-8
    assert np.abs(forces[:, 1] - planar_run["Fy"][::20]).max() < 1e-8


def quick_return_as_spatial(planar):
    """The thesis quick-return (joints R, R, P: link 4 slides across link 3's end and turns with it) as a
    spatial chain: the slide is a massless link whose z axis is link 3's y (alpha -pi/2), then link 4 a
    fixed row turning that frame back into the plane (alpha pi/2) at the locked relative angle."""
    links_table = planar.arrays.links if hasattr(planar.arrays, "links") else planar.arrays[0]
    (m2, _, p2, _, a2, *_), (m3, _, p3, _, a3, *_), (m4, _, p4, _, a4, *_) = links_table[:, :5].tolist()
    theta_locked = links_table[2, 9]  # link 4's angle relative to link 3 (the table's locked angle)
    links = [sp.SpatialLink("link2", mass=m2, com=(p2, 0, 0)),
             sp.SpatialLink("link3", a=a2, parent=0, mass=m3, com=(p3, 0, 0)),
             sp.SpatialLink("slide", a=a3, alpha=-math.pi / 2, joint="P", parent=1),
             sp.SpatialLink("link4", alpha=math.pi / 2, theta=theta_locked, joint="F", parent=2, mass=m4,
                            com=(p4, 0, 0))]
    closure = sp.SpatialClosure("revolute", link=3, point=(a4, 0, 0), to_point=(0.6, 0.7, 0))
    return sp.SpatialMechanism(links, [closure], gravity=(0, -9.81, 0))


def test_a_slide_written_as_spatial_equals_the_planar_kernel():
    # the P joint, the fixed row and point masses (no inertia at all) against the planar kernel's quick-return
    scene = grubler.load_scene("thesis-quick-return")
    planar = grubler.simulate(scene, t_end=1.0, dt_out=0.01, method="exact", **TIGHT)
    m = quick_return_as_spatial(scene.mechanism)
    assert m.coordinate_names == ("link2.theta", "link3.theta", "slide.d")
    res = m.simulate(np.concatenate([planar.z[0], planar.zd[0]]), t_end=1.0, dt_out=0.01, **TIGHT)
    assert np.abs(res.z - planar.z).max() < 1e-10
    assert np.abs(res.zd - planar.zd).max() < 1e-9


def test_a_planar_loop_seen_as_spatial_reports_which_reactions_are_determinate():
    m = sp.planar_fourbar("revolute")
    z = m.assembled_start()[:3]
    free, rank = m.determinacy(z)
    assert rank == 2
    # Fx, Fy are fixed by the motion; Fz and the moments about x and y are not (Wojtyra 2005)
    assert np.all(free[:2] < 1e-9) and np.all(free[2:] > 1 - 1e-9)
    assert m.determinacy_report(z)[0] == "closure 0 (revolute): determinate Fx, Fy; indeterminate Fz, My, Mx"
    # the minimum-norm multipliers leave the indeterminate ones at zero
    _, lam, _ = m.dynamics(m.assembled_start())
    assert np.abs(lam[2:]).max() < 1e-12
    # and through the loop every joint's out-of-plane reactions (Fz, Mx, My) are as free; the in-plane ones not
    joints = m.joint_determinacy(z)
    assert np.all(joints[:, [0, 1, 5]] < 1e-9) and np.all(joints[:, 2:5] > 0.5)
    assert m.determinacy_report(z)[2] == "joint of link2: indeterminate Fz, Mx, My (link axes)"


def test_joint_reactions_of_the_planar_fourbar_as_spatial_equal_the_planar_kernels(planar_run):
    # Newton-Euler from the tips back over the spatial frames against the planar kernel's reactions
    # (world x, y components of the predecessor's force on each link)
    m = sp.planar_fourbar()
    res = m.simulate(m.assembled_start(), t_end=2.0, dt_out=0.01, **TIGHT)
    planar_run.compute(["reactions"])
    worst = 0.0
    for i in range(0, len(res.t), 20):
        _, joints = m.reactions(res.y[i])
        _, frames = m.frames(res.z[i])
        for k in range(3):
            world = frames[k] @ joints[k, :3]
            worst = max(worst, abs(world[0] - planar_run[f"R{k + 1}_Fx"][i]), abs(world[1] - planar_run[f"R{k + 1}_Fy"][i]),
                        abs(joints[k, 5] - planar_run[f"R{k + 1}_Mz"][i]))
    assert worst < 1e-8


# -- RSSR: the Freudenstein-type equation ---------------------------------------------------------------------------
def rssr_equation(g, phi):
    """A, B, C of A cos psi + B sin psi = C for the preset's shafts at right angles, derived by hand.

    Crank pin P = (r1 cos phi, r1 sin phi, h); rocker pin Q = (a + r3 cos psi, -d, r3 sin psi) (its shaft
    along -y through (a, 0, 0), its plane at y = -d); |P - Q| = L.
    """
    r1, a, d, h, r3, L = g.crank, g.offset, g.rocker_d, g.height, g.rocker, g.coupler
    X, Y = r1 * np.cos(phi) - a, r1 * np.sin(phi) + d
    return -2 * r3 * X, -2 * r3 * h * np.ones_like(phi), L * L - X * X - Y * Y - h * h - r3 * r3


def test_rssr_preset_is_a_crank_rocker_between_skew_shafts():
    m = sp.rssr()
    z = m.assembled_start()[:m.n_coords]
    assert m.determinacy(z)[1] == 3 and np.all(m.joint_determinacy(z) < 1e-9)  # not overconstrained
    g = sp.rssr_geometry()
    assert g.twist == pytest.approx(math.pi / 2)
    A, B, C = rssr_equation(g, np.linspace(0, 2 * np.pi, 721))
    assert np.all(np.abs(C) < 0.95 * np.hypot(A, B))  # the crank turns fully


def test_rssr_assembles_on_its_closed_form_at_many_crank_angles():
    m, g = sp.rssr(), sp.rssr_geometry()
    for phi in np.linspace(-np.pi, np.pi, 37):
        sketch = m.sketch.copy()
        sketch[0] = phi
        sketch[1:] += np.array([0.15, -0.1, 0.2, 0.2])  # a rough sketch: the kernel's assembly closes it
        z = m.assemble(sketch)[:m.n_coords]
        psi = z[4]
        A, B, C = rssr_equation(g, phi)
        roots = math.atan2(B, A) + np.array([1, -1]) * math.acos(C / math.hypot(A, B))
        assert abs(A * math.cos(psi) + B * math.sin(psi) - C) < 1e-12
        assert np.min(np.abs(np.angle(np.exp(1j * (roots - psi))))) < 1e-10


@pytest.fixture(scope="module")
def rssr_driven():
    m = sp.rssr()
    tau = np.zeros(m.n_coords)
    tau[0] = 0.5  # N m on the crank: from rest past three turns in 1.5 s
    return m, m.simulate(m.assembled_start(), t_end=1.5, dt_out=0.01, tau=tau, **TIGHT), tau


def test_rssr_motion_keeps_its_closed_form_over_full_crank_turns(rssr_driven):
    m, res, _ = rssr_driven
    phi, psi = res.z[:, 0], res.z[:, 4]
    assert phi.max() - phi.min() > 4 * np.pi  # two turns and more
    A, B, C = rssr_equation(sp.rssr_geometry(), phi)
    assert np.abs(A * np.cos(psi) + B * np.sin(psi) - C).max() < 1e-12


# -- RSSP: the slide's closed form ----------------------------------------------------------------------------------
def rssp_slide(g, phi, sign=1):
    """The slide s with |P(phi) - (offset, -s, 0)| = L (the preset's line along -y through (offset, 0, 0)),
    by hand: (r1 cos phi - e)^2 + (r1 sin phi + s)^2 + h^2 = L^2."""
    r1, e, h, L = g.crank, g.offset, g.height, g.coupler
    return -r1 * np.sin(phi) + sign * np.sqrt(L * L - h * h - (r1 * np.cos(phi) - e) ** 2)


def test_rssp_slider_follows_its_closed_form_and_conserves_energy():
    m, g = sp.rssp(), sp.rssp_geometry()
    assert g.twist == pytest.approx(math.pi / 2)
    assert m.coordinate_names[-1] == "slider.d"
    tau = np.zeros(m.n_coords)
    tau[0] = 1.0
    res = m.simulate(m.assembled_start(), t_end=1.0, dt_out=0.01, tau=tau, **TIGHT)
    assert res.z[-1, 0] - res.z[0, 0] > 2 * np.pi
    assert np.abs(res.z[:, 4] - rssp_slide(g, res.z[:, 0])).max() < 1e-11
    zd = np.zeros(m.n_coords)
    zd[0] = 8.0
    free = m.simulate(m.assemble(m.sketch, zd), t_end=1.0, dt_out=0.01, **TIGHT)
    ke, pe = free.energy().T
    scale = ke.max() + (pe.max() - pe.min())
    assert np.abs((ke + pe) - (ke[0] + pe[0])).max() < 1e-9 * scale


# -- the spherical four-bar's input-output relation ----------------------------------------------------------------
def spherical_equation(g, phi):
    """A, B, C of A cos psi + B sin psi = C from u(phi) . v(psi) = cos alpha3 (derived by hand):
    u = (s2 sin phi, -s2 cos phi, c2), v = Rx(alpha1) (s4 sin psi, -s4 cos psi, c4)."""
    s1, c1 = math.sin(g.ground), math.cos(g.ground)
    s2, c2 = math.sin(g.crank), math.cos(g.crank)
    s4, c4 = math.sin(g.rocker), math.cos(g.rocker)
    A = s2 * np.cos(phi) * c1 * s4 - c2 * s1 * s4
    B = s2 * s4 * np.sin(phi)
    C = math.cos(g.coupler) - s2 * np.cos(phi) * s1 * c4 - c2 * c1 * c4
    return A, B, C


def test_spherical_fourbar_follows_its_input_output_relation():
    m, g = sp.spherical_fourbar(), sp.spherical_fourbar_geometry()
    A, B, C = spherical_equation(g, np.linspace(0, 2 * np.pi, 721))
    assert np.all(np.abs(C) < 0.95 * np.hypot(A, B))  # a crank-rocker: the input turns fully
    tau = np.array([0.1, 0.0, 0.0])  # N m: past gravity's hold, about eight input turns in 1 s
    res = m.simulate(m.assembled_start(), t_end=1.0, dt_out=0.01, tau=tau, **TIGHT)
    phi, psi = res.z[:, 0], res.z[:, 2]
    assert phi.max() - phi.min() > 2 * np.pi
    A, B, C = spherical_equation(g, phi)
    assert np.abs(A * np.cos(psi) + B * np.sin(psi) - C).max() < 1e-12
    # and at assembly from rough sketches (the last closed pose, turned by 0.2 rad), psi is one of the
    # closed form's two roots
    z = m.assembled_start()[:3]
    for p in np.linspace(0, 2 * np.pi, 25):
        z = m.assemble(np.array([p, z[1] + 0.2, z[2] - 0.2]))[:3]
        A, B, C = spherical_equation(g, p)
        roots = math.atan2(B, A) + np.array([1, -1]) * math.acos(C / math.hypot(A, B))
        assert np.min(np.abs(np.angle(np.exp(1j * (roots - z[2]))))) < 1e-10


def test_spherical_fourbar_force_reactions_are_indeterminate():
    m = sp.spherical_fourbar()
    free, rank = m.determinacy(m.assembled_start()[:3])
    assert rank == 2  # every joint axis through one point: the three force rows vanish identically
    assert np.all(free[:3] > 1 - 1e-9) and np.all(free[3:] < 1e-9)
    # through the loop: every joint's force is as free, its moment about the centre is not
    joints = m.joint_determinacy(m.assembled_start()[:3])
    assert np.all(joints[:, :3] > 0.5) and np.all(joints[:, 3:] < 1e-9)
    assert m.determinacy_report(m.assembled_start()[:3])[0] == \
        "closure 0 (revolute): determinate My, Mx; indeterminate Fx, Fy, Fz"


def test_an_assembly_that_closes_a_revolute_with_its_axes_reversed_is_refused():
    # the closure's rows (u square to n1, n2) hold with u = -v too: from this sketch Newton lands there
    m = sp.spherical_fourbar()
    with pytest.raises(InputError, match="axes reversed"):
        m.assemble(np.array([-3.0, 1.2, 1.6]))


# -- energy ---------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("build, rates", [(sp.rssr, 6.0), (sp.spherical_fourbar, 4.0), (sp.planar_fourbar, 3.0)])
def test_free_runs_conserve_energy(build, rates):
    m = build()
    zd = np.zeros(m.n_coords)
    zd[0] = rates
    res = m.simulate(m.assemble(m.sketch, zd), t_end=2.0, dt_out=0.02, **TIGHT)
    ke, pe = res.energy().T
    scale = ke.max() + (pe.max() - pe.min())  # the energy the run exchanges
    assert ke.max() > 0.05 * scale
    assert np.abs((ke + pe) - (ke[0] + pe[0])).max() < 1e-9 * scale
    assert res.closure_error().max() < 1e-11


def test_an_open_chain_of_cylindrical_revolute_and_slide_joints_conserves_energy():
    # no closure: the slides' Coriolis terms (a slide on a turning axis) and the twisted axes carry it
    body = ((0.02, 0.001, 0.0), (0.001, 0.03, 0.002), (0.0, 0.002, 0.025))
    links = [sp.SpatialLink("column", alpha=0.3, joint="C", mass=1.0, com=(0.1, 0.0, 0.2), inertia=body),
             sp.SpatialLink("arm", a=0.3, alpha=0.7, d=0.1, parent=0, mass=0.8, com=(0.2, 0.05, 0), inertia=body),
             sp.SpatialLink("ram", a=0.25, alpha=-1.1, joint="P", parent=1, mass=0.5, com=(0, 0.1, 0.05),
                            inertia=body)]
    m = sp.SpatialMechanism(links, gravity=(0.5, -1.0, -9.81))
    assert m.coordinate_names == ("column.theta", "column.d", "arm.theta", "ram.d")
    y0 = np.array([0.1, 0.0, 0.5, 0.2, 2.0, 0.3, -1.5, 0.4])
    res = m.simulate(y0, t_end=1.0, dt_out=0.01, **TIGHT)
    ke, pe = res.energy().T
    scale = ke.max() + (pe.max() - pe.min())
    assert np.abs((ke + pe) - (ke[0] + pe[0])).max() < 1e-9 * scale


def test_a_driven_damped_run_balances_its_energy():
    # E(t) - E(0) = the drive's work less what the dampers take, integrated along the run (Simpson's rule)
    import dataclasses

    from scipy.integrate import simpson
    base = sp.rssr()
    links = list(base.links)
    links[4] = dataclasses.replace(links[4], damping=(0.02, 0.0))  # the rocker's bearing
    links[3] = dataclasses.replace(links[3], damping=(0.001, 0.0))  # the coupler's spin in its ball
    m = sp.SpatialMechanism(links, base.closures, base.gravity)
    tau = np.zeros(m.n_coords)
    tau[0] = 0.5
    res = m.simulate(m.assemble(base.sketch), t_end=1.0, dt_out=0.001, tau=tau, **TIGHT)
    ke, pe = res.energy().T
    power = tau[0] * res.zd[:, 0] - 0.02 * res.zd[:, 4] ** 2 - 0.001 * res.zd[:, 3] ** 2
    work = np.array([simpson(power[:i + 1], x=res.t[:i + 1]) for i in range(100, len(res.t), 100)])
    change = (ke + pe - ke[0] - pe[0])[100::100]
    assert np.abs(change - work).max() < 1e-8 * np.abs(work).max()
    dissipated = simpson(0.02 * res.zd[:, 4] ** 2 + 0.001 * res.zd[:, 3] ** 2, x=res.t)
    assert dissipated > 1e-3 * np.abs(work).max()  # the dampers take a share the check can see


# -- the body-coordinate reference on the RSSR ----------------------------------------------------------------------
def rssr_bodies(m, z0, tau_crank):
    """The RSSR as three free bodies with two ground revolutes and two ball joints, from the preset's geometry
    and the kernel's assembled start (positions only: it starts from rest)."""
    g = sp.rssr_geometry()
    origins, frames = m.frames(z0)
    crank, coupler, rocker = 0, 3, 4
    bodies, com = [], []
    for k in (crank, coupler, rocker):
        link = m.links[k]
        c_local = np.array(link.com)
        com.append(c_local)
        bodies.append(Body(link.mass, np.array(link.inertia), origins[k] + frames[k] @ c_local, frames[k]))
    shaft = np.array([0.0, -math.sin(g.twist), math.cos(g.twist)])
    joints = [GroundRevolute(0, -com[0], np.array([0, 0, g.height]), np.array([0, 0, 1.0]), np.array([0, 0, 1.0])),
              Spherical(0, np.array([g.crank, 0, 0]) - com[0], 1, -com[1]),
              Spherical(1, np.array([0, 0, g.coupler]) - com[1], 2, np.array([g.rocker, 0, 0]) - com[2]),
              GroundRevolute(2, -com[2], np.array([g.offset, 0, 0]) + g.rocker_d * shaft, np.array([0, 0, 1.0]),
                             shaft)]
    return BodySystem(bodies, joints, np.array(m.gravity), [Torque(0, np.array([0, 0, 1.0]), tau_crank)])


def test_rssr_agrees_with_a_body_coordinate_newton_euler_model(rssr_driven):
    m, res, tau = rssr_driven
    system = rssr_bodies(m, res.z[0], tau[0])
    rows = slice(0, 81, 10)  # the first 0.8 s (one crank turn), every 0.1 s: the body model runs in Python
    ys = system.run(res.t[rows], rtol=1e-11, atol=1e-11)
    g = sp.rssr_geometry()
    shaft = np.array([0.0, -math.sin(g.twist), math.cos(g.twist)])
    x0, y0 = np.array([1.0, 0, 0]), np.cross(shaft, [1.0, 0, 0])
    worst_angle = worst_frame = worst_force = 0.0
    for y_kernel, y_body in zip(res.y[rows], ys):
        z = y_kernel[:m.n_coords]
        parts = system.unpack(y_body)
        Rc, Rk, Rr = (rotation(p[1]) for p in parts)
        crank = math.atan2(Rc[1, 0], Rc[0, 0])
        rocker = math.atan2(Rr[:, 0] @ y0, Rr[:, 0] @ x0)
        worst_angle = max(worst_angle, abs(np.angle(np.exp(1j * (crank - z[0])))),
                          abs(np.angle(np.exp(1j * (rocker - z[4])))))
        _, frames = m.frames(z)
        worst_frame = max(worst_frame, np.abs(frames[3] - Rk).max(), np.abs(frames[4] - Rr).max())
        # the rocker's ball on the coupler: the kernel's closure reaction (in the rocker's axes) in the world,
        # against the body model's multiplier on the coupler's side of that joint (rows 8..10)
        closure, _ = m.reactions(y_kernel, tau)
        force = frames[4] @ closure[0, :3]
        _, lam = system.accelerations(y_body)
        worst_force = max(worst_force, np.abs(force - lam[8:11]).max() / max(1.0, np.abs(force).max()))
        # the tree's joints (all determinate: the loop is not overconstrained), each the parent's on the link:
        # the crank's bearing (its rows 0..4: the point, then the axis square to n1 = x, n2 = y), the crank-pin
        # ball (rows 5..7, the coupler on the crank: minus it on the coupler), the rocker's bearing (rows 11..15,
        # its n1, n2 as spatial_bodies builds them across the shaft)
        _, joints = m.reactions(y_kernel, tau)
        scale = max(1.0, np.abs(lam).max())
        u = Rc[:, 2]
        moment = lam[3] * np.cross(u, [1.0, 0, 0]) + lam[4] * np.cross(u, [0, 1.0, 0])
        kernel = frames[0] @ joints[0, 3:]
        worst_force = max(worst_force, np.abs(frames[0] @ joints[0, :3] - lam[0:3]).max() / scale,
                          np.abs(kernel - (kernel @ u) * u - moment).max() / scale,
                          np.abs(frames[3] @ joints[3, :3] + lam[5:8]).max() / scale)
        e = np.array([1.0, 0, 0]) if abs(shaft[0]) < 0.9 else np.array([0, 1.0, 0])
        n1 = e - (e @ shaft) * shaft
        n1 /= np.linalg.norm(n1)
        u = Rr[:, 2]
        moment = lam[14] * np.cross(u, n1) + lam[15] * np.cross(u, np.cross(shaft, n1))
        kernel = frames[4] @ joints[4, 3:]
        worst_force = max(worst_force, np.abs(frames[4] @ joints[4, :3] - lam[11:14]).max() / scale,
                          np.abs(kernel - (kernel @ u) * u - moment).max() / scale)
    assert worst_angle < 1e-7
    assert worst_frame < 1e-7
    assert worst_force < 1e-6


def test_spherical_fourbar_agrees_with_a_body_coordinate_newton_euler_model():
    # four revolutes on concurrent axes: the body model's constraints are dependent too (rank 17 of 20)
    m, g = sp.spherical_fourbar(), sp.spherical_fourbar_geometry()
    tau = np.array([0.1, 0.0, 0.0])
    res = m.simulate(m.assembled_start(), t_end=0.3, dt_out=0.05, tau=tau, **TIGHT)
    origins, frames = m.frames(res.z[0])
    com = [np.array(l.com) for l in m.links]
    bodies = [Body(l.mass, np.array(l.inertia), origins[k] + frames[k] @ com[k], frames[k])
              for k, l in enumerate(m.links)]
    ez = np.array([0, 0, 1.0])

    def tilted(angle):
        return np.array([0, -math.sin(angle), math.cos(angle)])

    joints = [Revolute(0, -com[0], -1, np.zeros(3), ez, ez),
              Revolute(1, -com[1], 0, -com[0], ez, tilted(g.crank)),
              Revolute(1, -com[1], 2, -com[2], tilted(g.coupler), tilted(g.rocker)),
              Revolute(2, -com[2], -1, np.zeros(3), ez, tilted(g.ground))]
    system = BodySystem(bodies, joints, np.array(m.gravity), [Torque(0, ez, tau[0])])
    ys = system.run(res.t, rtol=1e-11, atol=1e-11)
    worst = 0.0
    for y_kernel, y_body in zip(res.y, ys):
        _, frames = m.frames(y_kernel[:3])
        for k, part in enumerate(system.unpack(y_body)):
            worst = max(worst, np.abs(frames[k] - rotation(part[1])).max())
    assert res.z[-1, 0] - res.z[0, 0] > 1.0  # the input has turned (5.4 rad)
    assert worst < 1e-7


# -- reactions ------------------------------------------------------------------------------------------------------
def test_joint_reactions_carry_exactly_the_joint_efforts(rssr_driven):
    # Newton-Euler from the tips back (grs_reactions) against the forward dynamics: about each revolute's
    # own axis the parent passes on only the joint's effort (the drive on the crank, nothing elsewhere)
    m, res, tau = rssr_driven
    for y in res.y[::30]:
        _, joints = m.reactions(y, tau)
        assert joints[0, 5] == pytest.approx(tau[0], abs=1e-10)
        assert np.abs(joints[1:, 5]).max() < 1e-10


# -- bad input ------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("change, field", [
    (dict(joint="X"), "links[1].joint"),
    (dict(parent=2), "links[1].parent"),
    (dict(mass=-1.0), "links[1].mass"),
    (dict(inertia=((1.0, 0, 0), (0, 1.0, 0), (0, 0, 3.0))), "links[1].inertia"),  # 3 > 1 + 1: no real body
    (dict(inertia=((1.0, 0.5, 0), (0, 1.0, 0), (0, 0, 1.0))), "links[1].inertia"),  # not symmetric
    (dict(a=float("nan")), "links[1].a"),
])
def test_bad_links_are_refused_naming_the_field(change, field):
    links = [sp.SpatialLink("one", mass=1.0), sp.SpatialLink("two", **{"parent": 0, **change})]
    with pytest.raises(InputError) as info:
        sp.SpatialMechanism(links)
    assert info.value.field == field


@pytest.mark.parametrize("change, field", [
    (dict(kind="weld"), "closures[0].kind"),
    (dict(to=1), "closures[0].to"),
    (dict(link=5), "closures[0].link"),
    (dict(kind="revolute", axis=(0, 0, 2.0)), "closures[0].axis"),
])
def test_bad_closures_are_refused_naming_the_field(change, field):
    links = [sp.SpatialLink("one", mass=1.0), sp.SpatialLink("two", parent=0, a=1.0, mass=1.0)]
    closure = dict(kind="spherical", link=1, to=-1)
    closure.update(change)
    with pytest.raises(InputError) as info:
        sp.SpatialMechanism(links, [sp.SpatialClosure(**closure)])
    assert info.value.field == field


@pytest.mark.parametrize("change, field", [
    (dict(y0=[0.0, float("nan"), 0, 0, 0, 0]), "y0"),
    (dict(y0=[0.0] * 5), "y0"),
    (dict(y0=[0.0, 1.0, 0, 0, 0, 0]), "y0"),  # not closed
    (dict(tau=[1.0]), "tau"),
    (dict(t_end=-1.0), "t_end"),
    (dict(dt_out=5.0), "dt_out"),
    (dict(tableau="rk4"), "tableau"),
])
def test_bad_run_requests_are_refused_naming_the_field(change, field):
    m = sp.planar_fourbar()
    request = dict(y0=m.assembled_start(), t_end=1.0, dt_out=0.1)
    request.update(change)
    with pytest.raises(InputError) as info:
        m.simulate(**request)
    assert info.value.field == field


def test_the_kernel_refuses_a_workspace_laid_out_for_another_model():
    import ctypes

    from grubler import binding
    small, big = sp.planar_fourbar(), sp.rssr()
    lib = binding.spatial_library()
    y, out = np.zeros(2 * big.n_coords), np.zeros(2 * big.n_coords)
    status = lib.grs_rhs(ctypes.byref(big._model), binding.address(y), None, binding.address(small._work),
                         binding.address(out))
    assert status == binding.BAD_ARGUMENT


def test_a_model_without_a_real_coordinate_is_refused():
    with pytest.raises(InputError) as info:
        sp.SpatialMechanism([sp.SpatialLink("weld", joint="F", mass=1.0)])
    assert info.value.field == "links[0].joint"


def test_a_loop_that_cannot_close_is_refused():
    links = [sp.SpatialLink("one", mass=1.0), sp.SpatialLink("two", parent=0, a=0.5, mass=1.0)]
    m = sp.SpatialMechanism(links, [sp.SpatialClosure("spherical", link=1, point=(0.5, 0, 0), to_point=(3, 0, 0))])
    with pytest.raises(InputError, match="cannot be closed"):
        m.assemble(np.zeros(2))
