"""The chain length and the closures are data: a six-bar with two loops needs
no new code, only a description (the thesis's Watt/Stephenson future work).

The reference is tests/planar_bodies.py: bodies in absolute coordinates tied by
pins, which shares no code with the library's chain."""

import math

import numpy as np

import grubler
from grubler import Closure, Link, Mechanism, Simulator
from planar_bodies import Bodies, Body, Pin, rot

LINKS = (  # a, p, m, I of the crank, coupler, rocker, link 5, link 6
    (0.3, 0.15, 0.5, 0.004),
    (0.9, 0.45, 1.0, 0.07),
    (0.7, 0.35, 0.8, 0.03),
    (0.6, 0.3, 0.6, 0.02),
    (0.5, 0.25, 0.5, 0.01),
)
ROCKER_PIVOT, OUTPUT_PIVOT, SIDE = (1.0, 0.0), (1.4, 0.9), 0.3
SKETCH = np.radians([80, 10, -60, 40, -20])  # absolute angles of links 2..6


def watt_six_bar(gain=1e4):
    # ground - crank - coupler - rocker (pinned to the ground at (1, 0)) - link 5
    # - link 6 (pinned to the ground at (1.4, 0.9)).  Link 5 hangs off the rocker
    # 0.3 m to the side of the rocker's ground pivot: the rocker is ternary, and
    # that offset is the locked slide B4 of link 5's joint on the rocker.
    links = tuple(Link("R", a=a, p=p, m=m, I=i) for a, p, m, i in LINKS)
    closures = (
        Closure("revolute", link=4, point=(0.7, 0.0), to_point=ROCKER_PIVOT, gain=gain),
        Closure("revolute", link=6, point=(0.5, 0.0), to_point=OUTPUT_PIVOT, gain=gain),
    )
    # a rough sketch of the start: assembly makes it exact, holding the crank
    q_ref = (0.0, SKETCH[0], 0.0, SKETCH[1], 0.0, SKETCH[2], SIDE, SKETCH[3], 0.0, SKETCH[4])
    return Mechanism(links=links, closures=closures, q_ref=q_ref, drive="theta2", name="watt")


def reference():
    """The same six-bar as five bodies and seven pins, drawn from its geometry."""
    bodies = []
    for k, (a, p, m, i) in enumerate(LINKS):
        pts = {"start": (-p, 0.0), "end": (a - p, 0.0)}
        if k == 2:
            pts["side"] = (a - p, SIDE)
        bodies.append(Body(f"link{k + 2}", m, i, pts))
    pins = [Pin(0, "start", None, (0.0, 0.0)), Pin(0, "end", 1, "start"), Pin(1, "end", 2, "start"),
            Pin(2, "end", None, ROCKER_PIVOT), Pin(3, "start", 2, "side"), Pin(3, "end", 4, "start"),
            Pin(4, "end", None, OUTPUT_PIVOT)]
    return Bodies(bodies, pins)


def sketch_pose(ref, angles):
    # mass centres of the sketch, each link laid from the previous joint
    x, joint = np.zeros(15), np.zeros(2)
    for k, (a, p, _, _) in enumerate(LINKS):
        x[3 * k:3 * k + 2] = joint + rot(angles[k]) @ np.array([p, 0.0])
        x[3 * k + 2] = angles[k]
        joint = joint + rot(angles[k]) @ np.array([a, 0.0])
        if k == 2:
            joint = joint + rot(angles[k]) @ np.array([0.0, SIDE])
    return x



def run_closed(sim, m, times):
    """Absolute angles and total energy at each time, every output checked closed."""
    angles, energies = [], []
    for t in times:
        sim.advance_to(t)
        out = sim.outputs()
        assert out["closure_error"] < 1e-10
        angles.append(m.q_from_z(sim.z)[1::2])
        energies.append(out["E"])
    return np.array(angles), energies

def test_six_bar_mobility_and_assembly():
    m = watt_six_bar()
    assert m.mobility == 1 == grubler.kutzbach_mobility(6, 7)
    assert m.free_names == ["theta2", "theta3", "theta4", "theta5", "theta6"]
    z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    assert z[0] == m.z_from_q(m.q_ref)[0]  # the crank was held
    ref = reference()
    x = ref.close(sketch_pose(ref, SKETCH), hold=0)
    assert np.abs(ref.phi(x)).max() < 1e-12
    q = m.q_from_z(z)
    assert np.max(np.abs(np.array(q[1::2]) - x[2::3])) < 1e-10


def test_six_bar_both_loops_move_and_agree_with_a_body_model():
    m = watt_six_bar()
    ref = reference()
    times = np.linspace(0.0, 5.0, 51)
    sim = Simulator(m, rtol=1e-11, atol=1e-11)
    ref_x, _ = ref.simulate(ref.close(sketch_pose(ref, SKETCH), hold=0), np.zeros(15), times)
    angles, energies = run_closed(sim, m, times)
    # the second loop moves: theta5, theta6 swing by tenths of a radian, not 1e-14
    assert np.ptp(angles[:, 3]) > 0.05 and np.ptp(angles[:, 4]) > 0.3
    assert np.max(np.abs(angles - ref_x[:, 2::3])) < 1e-7
    assert np.ptp(energies) < 1e-7 * max(1.0, abs(energies[0]))
    assert abs(energies[0] - ref.potential(ref_x[0])) < 1e-9  # at rest: E = PE


def test_six_bar_penalty_agrees_with_exact_to_the_springs_error():
    m = watt_six_bar(gain=1e6)
    z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    closed = m.replace(q_ref=tuple(m.q_from_z(z)))
    exact = Simulator(closed)
    penalty = Simulator(closed, method="penalty", rtol=1e-8, atol=1e-10)
    for t in (0.25, 0.5):
        exact.advance_to(t)
        penalty.advance_to(t)
    assert np.max(np.abs(exact.z - penalty.z)) < 1e-3
    assert penalty.outputs()["closure_error"] < 1e-4


# -- three loops: the same description, two links and a closure longer ----------------
EIGHT = LINKS + ((0.6, 0.3, 0.5, 0.015), (0.5, 0.25, 0.4, 0.008))
EIGHT_PIVOT, EIGHT_SIDE = (1.9, 1.6), 0.25
EIGHT_SKETCH = np.radians([80, 10, -60, 40, -20, 60, -10])


def eight_bar():
    # the six-bar's output link 6 becomes ternary: link 7 hangs 0.25 m to the
    # side of its ground pivot (B6), and links 7 and 8 close a third loop on the
    # ground at (1.9, 1.6).  No code: two more links and one more closure.
    six = watt_six_bar()
    links = tuple(Link("R", a=a, p=p, m=m, I=i) for a, p, m, i in EIGHT)
    closures = six.closures + (Closure("revolute", link=8, point=(0.5, 0.0), to_point=EIGHT_PIVOT),)
    q_ref = (0.0, EIGHT_SKETCH[0], 0.0, EIGHT_SKETCH[1], 0.0, EIGHT_SKETCH[2], SIDE, EIGHT_SKETCH[3], 0.0,
             EIGHT_SKETCH[4], EIGHT_SIDE, EIGHT_SKETCH[5], 0.0, EIGHT_SKETCH[6])
    return Mechanism(links=links, closures=closures, q_ref=q_ref, drive="theta2", name="eight")


def eight_reference():
    bodies = []
    for k, (a, p, m, i) in enumerate(EIGHT):
        pts = {"start": (-p, 0.0), "end": (a - p, 0.0)}
        if k in (2, 4):
            pts["side"] = (a - p, SIDE if k == 2 else EIGHT_SIDE)
        bodies.append(Body(f"link{k + 2}", m, i, pts))
    pins = [Pin(0, "start", None, (0.0, 0.0)), Pin(0, "end", 1, "start"), Pin(1, "end", 2, "start"),
            Pin(2, "end", None, ROCKER_PIVOT), Pin(3, "start", 2, "side"), Pin(3, "end", 4, "start"),
            Pin(4, "end", None, OUTPUT_PIVOT), Pin(5, "start", 4, "side"), Pin(5, "end", 6, "start"),
            Pin(6, "end", None, EIGHT_PIVOT)]
    ref = Bodies(bodies, pins)
    x, joint = np.zeros(21), np.zeros(2)
    for k, (a, p, _, _) in enumerate(EIGHT):
        x[3 * k:3 * k + 2] = joint + rot(EIGHT_SKETCH[k]) @ np.array([p, 0.0])
        x[3 * k + 2] = EIGHT_SKETCH[k]
        joint = joint + rot(EIGHT_SKETCH[k]) @ np.array([a, 0.0])
        if k in (2, 4):
            joint = joint + rot(EIGHT_SKETCH[k]) @ np.array([0.0, SIDE if k == 2 else EIGHT_SIDE])
    return ref, ref.close(x, hold=0)


def test_an_eight_bar_is_data_too_and_agrees_with_the_body_model():
    m = eight_bar()
    assert m.mobility == 1 == grubler.kutzbach_mobility(8, 10)
    ref, x0 = eight_reference()
    assert np.abs(ref.phi(x0)).max() < 1e-12
    times = np.linspace(0.0, 3.0, 31)
    ref_x, _ = ref.simulate(x0, np.zeros(21), times)
    sim = Simulator(m, rtol=1e-11, atol=1e-11)
    angles, energies = run_closed(sim, m, times)
    assert np.ptp(angles[:, 5]) > 0.05 and np.ptp(angles[:, 6]) > 0.05  # the third loop moves
    assert np.max(np.abs(angles - ref_x[:, 2::3])) < 1e-7
    assert np.ptp(energies) < 1e-7 * max(1.0, abs(energies[0]))
