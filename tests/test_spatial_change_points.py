"""Change points in the spatial chain: the advance carries the motion across positions where two assembly
branches meet, on a chart of the branch it came along (kernel/spatial/sp_chart.c), as the planar kernel does
(tests/test_change_points.py), with the closure at rounding and the energy kept.

References share no code with the spatial kernel: the planar kernel on the same four-bars (its own chart,
chain and closure code); the driven parallelogram's one-degree-of-freedom equation solved by scipy; the
equilateral Bennett linkage's two branches and the spherical four-bar's input-output relation in closed
form; energy balances from the outputs.  Before the
chart every run here stopped at its first change point (IntegrationError, "... a change point"; the FMU
answered Discard).
"""

import dataclasses
import math
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate

import grubler
from grubler.mechanism import spatial as sp

from test_spatial import rssp_slide, rssr_equation, spherical_equation

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))

G = 9.81
TIGHT = dict(rtol=1e-11, atol=1e-11)


def spatial_from_planar(planar) -> sp.SpatialMechanism:
    """A planar four-bar (grubler.Mechanism: three R links, a revolute closure on the ground) as a spatial
    chain in the x-y plane: revolutes on parallel z axes, each link's a the previous one's length, its mass
    centre along x, its planar I about z (as sp.planar_fourbar writes the thesis four-bar)."""
    links, previous = [], 0.0
    for k, link in enumerate(planar.links):
        I = link.I
        links.append(sp.SpatialLink(f"link{k + 2}", a=previous, parent=k - 1, mass=link.m, com=(link.p, 0, 0),
                                    inertia=((I, 0, 0), (0, I, 0), (0, 0, I))))
        previous = link.a
    cl = planar.closures[0]
    closure = sp.SpatialClosure("revolute", link=2, point=(*cl.point, 0.0), to_point=(*cl.to_point, 0.0))
    return sp.SpatialMechanism(links, [closure], gravity=(0.0, -G, 0.0))


def energy_drift(res, tau=None):
    """The spread of kinetic + potential energy less the efforts' work (constant efforts), J."""
    ke, pe = res.energy().T
    work = 0.0 if tau is None else (res.z - res.z[0]) @ tau
    return np.ptp(ke + pe - work)


# -- the planar four-bars written as spatial ---------------------------------------------------------------------
def test_a_driven_parallelogram_keeps_its_branch_through_twenty_turns():
    # the thesis parallelogram (fourbar-parallelogram: 1 m links, 1 kg point masses at the crank tip, the
    # coupler's middle and its far end) driven by 40 N m: every half turn its links lie along the ground,
    # where the antiparallelogram branch crosses.  The coupler translates on the physical branch, and the
    # crank follows 3 theta'' = tau - 3 g cos(theta) (the planar test's reference)
    m = spatial_from_planar(grubler.load_scene("fourbar-parallelogram").mechanism)
    theta0, tau = -math.pi / 3, np.array([40.0, 0.0, 0.0])
    y0 = m.assemble(np.array([theta0, math.pi / 3, 2 * math.pi / 3]), np.zeros(3))
    res = m.simulate(y0, t_end=5.0, dt_out=0.01, tau=tau, **TIGHT)
    crank, coupler = res.z[:, 0], res.z[:, 0] + res.z[:, 1]
    assert (crank[-1] - theta0) / (2 * math.pi) > 20  # measured 22.7 turns
    aligned = int(np.floor(crank[-1] / math.pi) - np.floor(theta0 / math.pi))  # crank at k pi, passed forwards
    assert res.passages == aligned == 46  # 0, pi, .., 45 pi: a chart at each
    assert np.ptp(coupler) < 1e-9  # measured 7.8e-12
    ref = scipy.integrate.solve_ivp(lambda t, y: [y[1], tau[0] / 3 - G * math.cos(y[0])], (0, 5.0), [theta0, 0.0],
                                    method="DOP853", rtol=1e-13, atol=1e-13, t_eval=res.t)
    assert np.abs(crank - ref.y[0]).max() < 1e-8  # measured 2.3e-9
    assert res.closure_error().max() < 1e-11  # measured 8.9e-13
    assert energy_drift(res, tau) < 1e-8 * tau[0] * (crank[-1] - theta0)  # measured 1.5e-6 J of 5702 J


@pytest.mark.parametrize("seed", range(12))
def test_random_change_point_four_bars_as_spatial_finish_with_the_planar_kernel(seed):
    # tests/test_change_points.py's random s + l = p + q four-bars (the same seeds and draws), 2 N m on the
    # crank for 4 s at the default tolerances, as spatial: up to 72 passages each
    rng = np.random.default_rng(seed)
    s = rng.uniform(0.2, 0.5)
    l = rng.uniform(0.8, 1.4)
    p = rng.uniform(s + 0.05, l - 0.05)
    q = s + l - p
    scene = grubler.load_scene(
        "\n".join(['[mechanism]', 'type = "four-bar"', f"ground = {l}", f"crank = {s}", f"coupler = {p}",
                   f"rocker = {q}", f"crank_angle = {rng.uniform(0.3, 2.5)}", "[drive]", "torque = 2.0"]))
    planar = grubler.simulate(scene, t_end=4.0, dt_out=0.01, method="exact", torque=2.0)
    m, tau = spatial_from_planar(scene.mechanism), np.array([2.0, 0.0, 0.0])
    res = m.simulate(np.concatenate([planar.z[0], planar.zd[0]]), t_end=4.0, dt_out=0.01, tau=tau)
    assert res.passages == len(planar.stats["passages"])  # 0 (three seeds) to 72
    absolute = np.cumsum(res.z, axis=1)
    for k, name in enumerate(("theta2", "theta3", "theta4")):
        assert np.abs(absolute[:, k] - planar[name]).max() < 1e-5, name  # measured 1.8e-6 at most
    assert res.closure_error().max() < 1e-11  # measured 4.2e-12 at most
    assert energy_drift(res, tau) < 1e-8 * np.max(res.energy()[:, 0])  # measured 1.5e-9 at most


@pytest.fixture(scope="module")
def change_point_four_bar():
    scene = grubler.load_scene("fourbar-change-point")  # s + l = p + q: all four links align at one position
    planar = grubler.simulate(scene, t_end=4.0, dt_out=0.01, method="exact", torque=0.5, **TIGHT)
    m = spatial_from_planar(scene.mechanism)
    tau = np.array([0.5, 0.0, 0.0])
    res = m.simulate(np.concatenate([planar.z[0], planar.zd[0]]), t_end=4.0, dt_out=0.01, tau=tau, **TIGHT)
    return planar, m, res, tau


def test_the_change_point_four_bar_as_spatial_follows_the_planar_kernel_through_each_passage(change_point_four_bar):
    planar, m, res, tau = change_point_four_bar
    assert res.passages == len(planar.stats["passages"]) == 9  # each passed on a chart, as the planar kernel's
    absolute, rates = np.cumsum(res.z, axis=1), np.cumsum(res.zd, axis=1)
    for k, name in enumerate(("theta2", "theta3", "theta4")):
        assert np.abs(absolute[:, k] - planar[name]).max() < 1e-8, name  # measured 7.4e-10 rad
        assert np.abs(rates[:, k] - planar[name + "_d"]).max() < 1e-6, name  # measured 3.2e-8 rad/s
    assert res.closure_error().max() < 1e-11  # measured 8.9e-13
    assert energy_drift(res, tau) < 1e-9 * np.max(res.energy()[:, 0])  # measured 5.4e-10 J of 38.6 J kinetic


def test_the_closure_is_at_rounding_right_at_the_aligned_position(change_point_four_bar):
    # the outputs nearest each passage, and a dense run across the first one
    planar, m, res, tau = change_point_four_bar
    first = planar.stats["passages"][0]
    dense = m.simulate(res.y[0], t_end=first + 0.02, dt_out=1e-4, tau=tau, **TIGHT)
    near = np.abs(dense.t - first) < 0.02
    assert near.sum() > 300
    assert dense.closure_error()[near].max() < 1e-12
    # the crank, coupler and rocker do come into line there: the Jacobian's second singular value falls
    sigmas = np.array([np.linalg.svd(m.constraint(z)[1], compute_uv=False) for z in dense.z[near]])
    assert (sigmas[:, 1] / sigmas[:, 0]).min() < 1e-2


def test_a_free_parallelogram_swings_through_its_aligned_positions_with_its_energy():
    # released with speed, no effort: it used to stop here (a projection on the other branch took 4.9 J of
    # its 21 J); now the coupler stays level (the parallelogram branch) and the energy stays put
    inertia = ((0.01, 0, 0), (0, 0.01, 0), (0, 0, 0.01))
    links = [sp.SpatialLink("crank", mass=1, com=(0.25, 0, 0), inertia=inertia),
             sp.SpatialLink("coupler", a=0.5, parent=0, mass=1, com=(0.5, 0, 0), inertia=inertia),
             sp.SpatialLink("rocker", a=1.0, parent=1, mass=1, com=(0.25, 0, 0), inertia=inertia)]
    m = sp.SpatialMechanism(links, [sp.SpatialClosure("revolute", link=2, point=(0.5, 0, 0), to_point=(1, 0, 0))],
                            gravity=(0, -G, 0))
    y0 = m.assemble(np.array([math.pi / 2, -math.pi / 2, -math.pi / 2]), np.array([3.0, 0, 0]))
    res = m.simulate(y0, t_end=3.0, dt_out=0.01, rtol=1e-10, atol=1e-10)
    crank = res.z[:, 0]
    assert crank.max() - crank.min() > 2 * math.pi  # it goes round: every aligned position on the way
    assert res.passages == int(np.floor(crank[-1] / math.pi) - np.floor(crank[0] / math.pi)) >= 2
    assert np.ptp(res.z[:, 0] + res.z[:, 1]) < 1e-8  # the coupler stays level
    assert res.closure_error().max() < 1e-11
    assert energy_drift(res) < 1e-8 * np.max(res.energy()[:, 0])


# -- a truly spatial change point: the equilateral Bennett linkage -------------------------------------------------
def equilateral_bennett(alpha=math.radians(60), a=0.15, mass=0.5):
    """Four equal links of equal twist on skew axes (sp.bennett's DH loop with a1 = a2, alpha1 = alpha2).
    Bennett's equation tan(theta1/2) tan(theta2/2) = sin((alpha2 + alpha1)/2) / sin((alpha2 - alpha1)/2) has
    an infinite right side: the motion is two branches, theta1 = pi and theta2 = pi, which cross where
    both are pi, a change point of a spatial loop (the preset's general Bennett folds without one)."""
    links = []
    for k, name in enumerate(("link1", "link2", "link3")):
        links.append(sp.SpatialLink(name, a=a, alpha=alpha, parent=k - 1, mass=mass * a,
                                    com=(a / 2, 0, 0), inertia=tuple(map(tuple, sp._rod_inertia(mass * a, a, 0, 0.008)))))
    closure = sp.SpatialClosure("revolute", link=2, point=(a, 0, 0), axis=(0, -math.sin(alpha), math.cos(alpha)))
    return sp.SpatialMechanism(links, [closure], gravity=(0, 0, -G))


def test_the_equilateral_bennett_linkage_swings_through_its_branch_point_on_its_own_branch():
    m = equilateral_bennett()
    # the change point: the closure's Jacobian has rank 1 there (2 on either branch)
    sigmas = np.linalg.svd(m.constraint(np.array([math.pi, math.pi, -math.pi]))[1], compute_uv=False)
    assert sigmas[1] < 1e-12 * sigmas[0]
    # on the branch theta2 = pi (theta3 = -theta1), released at theta1 = 0.5 under gravity: it swings to
    # theta1 = -pi, where the branch theta1 = pi crosses, and on through it, back and forth
    y0 = m.assemble(np.array([0.5, math.pi, -0.5]), np.zeros(3))
    assert abs(y0[1] - math.pi) < 1e-12 and np.linalg.svd(m.constraint(y0[:3])[1], compute_uv=False)[1] > 0.1
    res = m.simulate(y0, t_end=4.0, dt_out=0.01, **TIGHT)
    theta1 = res.z[:, 0]
    crossings = np.sum(np.diff(np.sign(theta1 + math.pi)) != 0)
    assert crossings >= 4  # measured 5 passages in 4 s
    assert res.passages == crossings
    assert np.abs(res.z[:, 1] - math.pi).max() < 1e-10  # its own branch (measured 1.5e-14)
    assert np.abs(res.z[:, 2] + theta1).max() < 1e-10  # theta3 = -theta1 on it (measured 9.3e-15)
    assert res.closure_error().max() < 1e-12  # measured 8.1e-15
    assert energy_drift(res) < 1e-9 * np.max(res.energy()[:, 0])  # measured 6.0e-14 J of 0.12 J


def test_a_change_point_spherical_four_bar_passes_every_turn_onto_the_other_circuit():
    # the spherical analogue of s + l = p + q in angular lengths (25 + 70 = 60 + 35 deg): once a turn all four
    # axes lie in one plane and the two circuits of A cos psi + B sin psi = C meet.  The motion's analytic
    # branch goes on to the other circuit there (as the planar change-point four-bar's does, which the planar
    # kernel confirms above), with the rates continuous: the energy balance shows no jump
    g = dataclasses.replace(sp.spherical_fourbar_geometry(), rocker=math.radians(35))
    m = sp.spherical_fourbar(gravity=(0, 0, 0), geometry=g)
    tau = np.array([0.01, 0.0, 0.0])
    res = m.simulate(m.assemble(np.array([0.5, 1.0, 1.0]), np.zeros(3)), t_end=4.0, dt_out=1e-3, tau=tau, **TIGHT)
    phi, psi = res.z[:, 0], res.z[:, 2]
    turns = int((phi[-1] - phi[0]) // (2 * math.pi))
    assert turns >= 10  # measured 12.05
    A, B, C = spherical_equation(g, phi)
    assert np.abs(A * np.cos(psi) + B * np.sin(psi) - C).max() < 1e-12  # measured 1.4e-14
    # the closed form's two roots are psi = atan2(B, A) +- acos(C / hypot(A, B)): the motion changes root
    # once a turn, where the crank lies at pi (the change point), and nowhere else
    side = np.sign(np.sin(psi - np.arctan2(B, A)))
    flips = np.nonzero(np.diff(side))[0]
    passed = np.sum(np.diff(np.floor((phi - math.pi) / (2 * math.pi))) != 0)
    assert len(flips) == passed == res.passages >= turns
    assert np.abs(np.remainder(phi[flips], 2 * math.pi) - math.pi).max() < 0.1  # measured 0.053
    assert res.closure_error().max() < 1e-12  # measured 1.9e-13
    assert energy_drift(res, tau) < 1e-10 * np.max(res.energy()[:, 0])  # measured 1.9e-12 J of 0.76 J


# -- loops with an idle freedom: the coupler's spin about its own S-S axis -----------------------------------------
# The RSSR and RSSP carry a freedom no closure row sees (the coupler turning about the line through its two balls:
# its Jacobian column is zero everywhere), so their mobility is two; the chart follows the branch in the other
# coordinates and leaves the spin to its own equation.  Before, each run here stopped at its first change point
# (IntegrationError, "... a change point").
def test_a_change_point_rssr_spinning_its_coupler_passes_every_turn_on_its_closed_form():
    # offset 0.26 m, the rocker's plane through the crank shaft's foot (rocker_d = 0): at crank angle 0 the crank
    # pin, the rocker shaft and the rocker pin lie on one line square to the crank's motion (|P - centre| = 0.2 m =
    # the rocker, C = hypot(A, B) = 0.08 exactly), the two circuits of A cos psi + B sin psi = C touch and the
    # closure Jacobian loses a rank.  Driven from rest at -2 rad with the coupler spinning at 5 rad/s
    g = dataclasses.replace(sp.rssr_geometry(), offset=0.26, rocker_d=0.0)
    m = sp.rssr(geometry=g)
    rates = np.zeros(m.n_coords)
    rates[3] = 5.0  # coupler.theta: the spin
    y0 = m.assemble(sp._rssr_sketch(g, -2.0), rates, held=(0, 3))
    assert np.linalg.svd(m.constraint(m.assemble(sp._rssr_sketch(g, 0.0))[:5])[1], compute_uv=False)[2] < 1e-12
    tau = np.zeros(m.n_coords)
    tau[0] = 0.2
    res = m.simulate(y0, t_end=3.0, dt_out=1e-3, tau=tau, **TIGHT)
    phi, psi = res.z[:, 0], res.z[:, 4]
    passed = np.sum(np.diff(np.floor(phi / (2 * math.pi))) != 0)
    assert passed >= 10  # measured 16 in 3 s
    assert res.passages == passed
    A, B, C = rssr_equation(g, phi)
    assert np.abs(A * np.cos(psi) + B * np.sin(psi) - C).max() < 1e-10  # measured 5.9e-14
    # the closed form's roots psi = atan2(B, A) +- acos(C / hypot(A, B)): the motion changes root at each
    # passage (the analytic branch goes on to the other circuit, as the planar change-point four-bar's does)
    roots = np.arctan2(B, A)[:, None] + np.array([1, -1]) * np.arccos(np.clip(C / np.hypot(A, B), -1, 1))[:, None]
    side = np.argmin(np.abs(np.angle(np.exp(1j * (roots - psi[:, None])))), axis=1)
    assert np.sum(np.diff(side) != 0) == passed
    assert res.closure_error().max() < 1e-10  # measured 8.9e-13
    assert energy_drift(res, tau) < 1e-9 * np.max(res.energy()[:, 0])  # measured 2.4e-10 J of 22 J
    # the coupler is a rod symmetric about its axis, and the balls (on the axis) and gravity (at its mass centre,
    # on the axis) give no moment about it: Euler's equation keeps its spin, the angular velocity along the axis,
    # at 5 rad/s, on the chart as off it (the coordinate's own rate is not the spin: the ball's angles share it)
    _, frames = zip(*(m.frames(z) for z in res.z))
    spin = [sum(R[k][:, 2] * y[5 + k] for k in range(4)) @ R[3][:, 2] for R, y in zip(frames, res.y)]
    assert np.abs(np.array(spin) - 5.0).max() < 1e-9  # measured 2.4e-11 rad/s
    assert np.ptp(res.z[:, 3]) > 1.0  # and the idle coordinate moved (13 rad)


def test_a_change_point_rssp_passes_every_turn_on_its_closed_form():
    # offset 0.06 m, coupler 0.2 m: at crank angle pi the coupler lies square to both the slide and the crank's
    # motion (the root of rssp_slide's square root is double there) and the two slide circuits touch
    g = dataclasses.replace(sp.rssp_geometry(), offset=0.06, coupler=0.2)
    m = sp.rssp(geometry=g)
    rates = np.zeros(m.n_coords)
    rates[3] = -3.0
    y0 = m.assemble(m.sketch, rates, held=(0, 3))
    tau = np.zeros(m.n_coords)
    tau[0] = 0.2
    res = m.simulate(y0, t_end=3.0, dt_out=1e-3, tau=tau, **TIGHT)
    phi, s = res.z[:, 0], res.z[:, 4]
    passed = np.sum(np.diff(np.floor((phi - math.pi) / (2 * math.pi))) != 0)
    assert passed >= 6  # measured 10 in 3 s
    assert res.passages == passed
    upper, lower = np.abs(s - rssp_slide(g, phi, 1)), np.abs(s - rssp_slide(g, phi, -1))
    assert np.minimum(upper, lower).max() < 1e-10  # measured 5.4e-13
    assert np.sum(np.diff(upper < lower) != 0) == passed  # onto the other root at each passage
    assert res.closure_error().max() < 1e-10  # measured 1.6e-13
    assert energy_drift(res, tau) < 1e-9 * np.max(res.energy()[:, 0])  # measured 5.9e-10 J of 12 J


def test_a_change_point_four_bar_with_a_pendulum_hung_on_its_coupler_passes_its_change_points():
    # a link no closure reaches (a 0.2 kg pendulum on a revolute at the coupler's far end) is idle too: its column
    # is zero at every position.  Driven at 0.5 N m with the pendulum swinging round, the loop passes its change
    # points (before: mobility two, no chart, stopped at 0.59 s with "... a change point")
    scene = grubler.load_scene("fourbar-change-point")
    planar = grubler.simulate(scene, t_end=0.01, dt_out=0.01, method="exact", torque=0.5, **TIGHT)
    base = spatial_from_planar(scene.mechanism)
    inertia = ((1e-4, 0, 0), (0, 1e-4, 0), (0, 0, 1e-4))
    bob = sp.SpatialLink("bob", a=base.links[2].a, parent=1, mass=0.2, com=(0.1, 0, 0), inertia=inertia)
    m = sp.SpatialMechanism([*base.links, bob], list(base.closures), gravity=base.gravity)
    y0 = m.assemble(np.append(planar.z[0], 0.3), np.append(planar.zd[0], 2.0), held=(0, 3))
    tau = np.array([0.5, 0.0, 0.0, 0.0])
    res = m.simulate(y0, t_end=4.0, dt_out=0.01, tau=tau, **TIGHT)
    assert res.passages >= 5  # measured 8
    assert np.ptp(res.z[:, 3]) > 2 * math.pi  # the pendulum goes round (80.8 rad)
    assert res.closure_error().max() < 1e-11  # measured 8.9e-13
    assert energy_drift(res, tau) < 1e-9 * np.max(res.energy()[:, 0])  # measured 1.1e-9 J of 34.5 J


# -- the native FMU ------------------------------------------------------------------------------------------------
H = 2.0 ** -7
# the planar-fourbar-3d FMU's parameters set to a parallelogram (crank and rocker 0.2 m, coupler and ground 1 m),
# released crank up at 3 rad/s: its crank comes along the ground (theta = pi) within a second
PARALLELOGRAM = {"link4.dh.a": 1.0, "closure.point_x": 0.2, "closure.to_point_x": 1.0, "link4.com_x": 0.1,
                 "initial.link2.theta": math.pi / 2, "initial.link3.theta": -math.pi / 2,
                 "initial.link4.theta": -math.pi / 2, "initial.link2.theta_d": 3.0, "max_step": 0.1}
OUTPUTS = ["link2.theta", "link3.theta", "link4.theta", "link2.theta_d", "KE", "PE", "closure_error"]


@pytest.fixture(scope="module")
def planar_fourbar_fmus(tmp_path_factory):
    import builds
    from fmpy import read_model_description

    out = {}
    for fmi in (2, 3):
        path = builds.spatial("planar-fourbar-3d", tmp_path_factory.mktemp(f"pf{fmi}") / "PlanarFourbar3d.fmu",
                              "linux64", fmi)
        out[fmi] = (path, read_model_description(str(path)))
    return out


class Slave:
    """An fmpy slave of the build with the parallelogram's parameters, initialised."""

    def __init__(self, fmus, fmi):
        from fmpy import extract
        from fmpy.fmi2 import FMU2Slave
        from fmpy.fmi3 import FMU3Slave

        path, md = fmus[fmi]
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.s = (FMU2Slave if fmi == 2 else FMU3Slave)(guid=md.guid, unzipDirectory=extract(str(path)),
                                                        modelIdentifier=md.coSimulation.modelIdentifier,
                                                        instanceName="s")
        self.fmi = fmi
        self.set_, self.get_ = (self.s.setReal, self.s.getReal) if fmi == 2 else (self.s.setFloat64, self.s.getFloat64)
        self.s.instantiate()
        if fmi == 2:
            self.s.setupExperiment(startTime=0.0)
            self.s.enterInitializationMode()
        else:
            self.s.enterInitializationMode(startTime=0.0)
        for name, value in PARALLELOGRAM.items():
            self.set_([self.vr[name]], [value])
        self.s.exitInitializationMode()

    def steps(self, first, n):
        rows = []
        for i in range(first, first + n):
            self.s.doStep(i * H, H)  # fmpy raises on Discard (what the step through the aligned position answered)
            rows.append(self.get_([self.vr[x] for x in OUTPUTS]))
        return np.array(rows)

    def free(self):
        self.s.terminate()
        self.s.freeInstance()


@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
def test_a_spatial_fmu_step_through_a_change_point_passes_it(planar_fourbar_fmus, fmi):
    slave = Slave(planar_fourbar_fmus, fmi)
    rows = slave.steps(0, 300)
    slave.free()
    crank, coupler = rows[:, 0], rows[:, 0] + rows[:, 1]
    assert crank.max() > 4 * math.pi  # through four aligned positions (measured: to 14.09 rad)
    assert np.ptp(coupler) < 1e-8  # on the parallelogram's branch (measured 9.3e-13)
    assert rows[:, 6].max() < 1e-11  # measured 5.6e-13
    energy = rows[:, 4] + rows[:, 5]
    assert np.ptp(energy) < 1e-8 * rows[:, 4].max()  # measured 8.5e-10 J of 18 J


@pytest.mark.slow
def test_a_spatial_fmu_state_saved_on_a_chart_steps_on_to_the_same_bits(planar_fourbar_fmus):
    # saved while the motion follows a chart, restored in the instance after it ran on and in a fresh one:
    # the chart and the watch's reference travel in the state (they used to be scratch: a fresh instance
    # started its watch afresh and took the passage without a chart)
    slave = Slave(planar_fourbar_fmus, 2)
    rows = slave.steps(0, 300)
    # the first step whose crank lies within 0.05 rad before the aligned position: on the chart
    k = int(np.argmax((rows[:, 0] > math.pi - 0.05) & (rows[:, 0] < math.pi)))
    assert 0 < k < 250 and rows[k, 0] < math.pi
    slave.free()
    slave = Slave(planar_fourbar_fmus, 2)
    slave.steps(0, k + 1)
    state = slave.s.serializeFMUstate(slave.s.getFMUstate())
    after = slave.steps(k + 1, 40)
    assert np.array_equal(after, rows[k + 1:k + 41])
    slave.s.setFMUstate(slave.s.deSerializeFMUstate(state))
    again = slave.steps(k + 1, 40)
    slave.free()
    fresh = Slave(planar_fourbar_fmus, 2)
    fresh.s.setFMUstate(fresh.s.deSerializeFMUstate(state))
    restored = fresh.steps(k + 1, 40)
    fresh.free()
    assert np.array_equal(again, after)
    assert np.array_equal(restored, after)
    assert np.ptp(restored[:, 0] + restored[:, 1]) < 1e-8 and restored[:, 0].max() > math.pi  # and it passed
