"""The chain length and the closures are data: a six-bar with two loops needs
no new code, only a description (the thesis's Watt/Stephenson future work)."""

import math

import numpy as np

import grubler
from grubler import Closure, Link, Mechanism, Simulator
from reference import RefChain


def watt_six_bar(gain=1e4):
    # ground - crank - coupler - rocker (pinned to the ground at (1, 0)) - link 5
    # - link 6 (pinned to the ground at (1.4, 0.9)); link 5 hangs off the rocker
    # 0.3 m to the side of its pivot (a locked slide), so the rocker is ternary
    links = (
        Link("R", a=0.3, p=0.15, m=0.5, I=0.004),
        Link("R", a=0.9, p=0.45, m=1.0, I=0.07),
        Link("R", a=0.7, p=0.35, m=0.8, I=0.03),
        Link("R", a=0.6, p=0.3, m=0.6, I=0.02),
        Link("R", a=0.5, p=0.25, m=0.5, I=0.01),
    )
    closures = (
        Closure("revolute", link=4, point=(0.7, 0.0), to_point=(1.0, 0.0), gain=gain),
        Closure("revolute", link=6, point=(0.5, 0.0), to_point=(1.4, 0.9), gain=gain),
    )
    # a rough sketch of the start: assembly makes it exact, holding the crank
    q_ref = (0.0, math.radians(80), 0.0, math.radians(10), 0.3, math.radians(-60),
             0.0, math.radians(40), 0.0, math.radians(-20))
    return Mechanism(links=links, closures=closures, q_ref=q_ref, drive="theta2", name="watt")


def test_six_bar_mobility_and_assembly():
    m = watt_six_bar()
    assert m.mobility == 1 == grubler.kutzbach_mobility(6, 7)
    assert m.free_names == ["theta2", "theta3", "theta4", "theta5", "theta6"]
    z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    assert z[0] == m.z_from_q(m.q_ref)[0]  # the crank was held
    ref = RefChain.of(m)
    q = m.q_from_z(z)
    assert abs(ref.point(q, 2, 0.7, 0.0) - 1.0) < 1e-12
    assert abs(ref.point(q, 4, 0.5, 0.0) - (1.4 + 0.9j)) < 1e-12


def test_six_bar_keeps_both_loops_closed_and_conserves_energy():
    m = watt_six_bar()
    sim = Simulator(m)
    ref = RefChain.of(m)
    energies = []
    for t in np.linspace(0.0, 5.0, 11):
        sim.advance_to(t)
        out = sim.outputs()
        assert out["closure_error"] < 1e-10
        q = m.q_from_z(sim.z)
        qd = m.S @ sim.zd
        ke, pe = ref.energy(q, qd)
        energies.append(ke + pe)
    assert np.ptp(energies) < 1e-7 * max(1.0, abs(energies[0]))


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
