"""Short forms of the stress cases of benchmarks/stress.py (docs/stress.md).

Each case is built and measured by the benchmark's own code, so CI runs the same
mechanisms; closure error and energy come from tests/reference.py (independent
complex-number kinematics), never from grubler's outputs.  The assertions are
physics: the loop stays closed, energy is conserved (or balanced against the
drive's work and the dampers' losses), and a run that cannot go on stops with one
of grubler's errors whose message says where and why.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import grubler

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import stress  # noqa: E402

# a hang is a failure with a message, not a stuck CI job; no timing is asserted
BUDGET = 120.0
# the reference differentiates numerically: its energies are good to ~1e-10 relative
CLOSURE = 1e-11  # m per m of the longest link


def finished(case: stress.Case) -> stress.Outcome:
    out = stress.run_case(case, BUDGET)
    assert out.status == "finished", out.message
    assert out.closure < CLOSURE * out.length_scale
    return out


def test_long_run_keeps_energy_and_closure_at_checkpoints():
    # the full form runs 1000 s; tests/test_physics.py has a 100 s one
    out = finished(stress.long_run(10.0, dt_out=1.0, checkpoints=(1.0, 5.0, 10.0)))
    assert [c[0] for c in out.checkpoints] == [1.0, 5.0, 10.0]
    assert out.balance < 2e-8
    assert out.ke_max > 5.0  # it really swings (7.9 J of kinetic energy at the bottom)


def test_free_spinning_crank_at_3000_rpm_keeps_its_kinetic_energy():
    out = finished(stress.high_speed_free(0.1))
    z = out.samples["z"]
    # the crank slows as it drives the rocker: 3.4 turns in 0.1 s from 3000 rpm
    assert (z[-1, 0] - z[0, 0]) / (2 * math.pi) > 3.0
    assert out.balance < 1e-8


def test_drive_holding_3000_rpm_balances_damper_losses():
    t_end = 0.05
    out = finished(stress.high_speed_held(t_end))
    assert out.balance < 1e-7  # Simpson's rule on the damper losses bounds it
    turns = (out.samples["z"][-1, 0] - out.samples["z"][0, 0]) / (2 * math.pi)
    assert turns / t_end * 60 == pytest.approx(3000, rel=0.05)


def test_thesis_four_bar_crosses_its_dead_centres_with_energy_balanced():
    out = finished(stress.dead_centre(0.3))
    z = out.samples["z"]
    assert (z[-1, 0] - z[0, 0]) / (2 * math.pi) > 1.0  # at least one turn: both dead centres
    assert out.balance < 1e-7  # E(t) - E(0) = 50 N m x crank turn


@pytest.fixture(scope="module")
def change_point_run():
    # past the first arrival at the aligned position (t = 0.571 s)
    return stress.run_case(stress.change_point(0.6), BUDGET)


def test_change_point_four_bar_stops_clearly_or_stays_closed(change_point_run):
    out = change_point_run
    assert out.status in ("finished", "stopped"), out.message
    if out.status == "stopped":
        assert isinstance(out.error, grubler.IntegrationError)
        assert "t = " in str(out.error)
    assert out.closure < CLOSURE * out.length_scale


def test_change_point_four_bar_passes_its_aligned_position_with_its_energy(change_point_run):
    # At the change point two assembly branches meet.  Landing on the other one
    # used to take the kinetic energy away silently (6.5 of 6.6 J), then the run
    # stopped there by name; now it goes on along its branch with the energy intact.
    out = change_point_run
    assert out.status == "finished", out.message
    assert out.balance < 1e-6


@pytest.mark.parametrize("which", list(stress.MASS_RATIOS))
def test_extreme_mass_ratios_conserve_energy(which):
    out = finished(stress.mass_ratio(which, 0.5))
    assert out.balance < 1e-8


@pytest.mark.parametrize("which, t_end", [
    ("four-bar crank 1e-3 m", 0.1),
    ("four-bar 1 m crank, 1e3 m links", 1.0),
    ("slider-crank 1e-3 m crank, 1 m rod", 0.1),
    ("slider-crank 1 m crank, 1e3 m rod", 1.0),
])
def test_extreme_length_ratios_conserve_energy(which, t_end):
    out = finished(stress.length_ratio(which, t_end))
    assert out.balance < 1e-7


def test_stiff_penalty_closure_stretches_by_force_over_gain():
    # Released unstretched under load, a lightly damped spring overshoots to twice its
    # static extension F / G (a suddenly applied load), whatever G: the extension
    # scales as 1 / G and G x extension stays near 2 x the exact closing force.
    t_end = 0.01
    force = float(np.max(stress.exact_closing_force(t_end, dt_out=0.001)))
    closure = {}
    for gain in (1e6, 1e8):
        out = stress.run_case(stress.penalty(gain, t_end, dt_out=0.001), BUDGET)
        assert out.status == "finished", out.message
        assert out.rise < 1e-9  # spring + damper: E never grows
        assert 1.5 < gain * out.closure / force < 2.05
        closure[gain] = out.closure
    assert closure[1e6] / closure[1e8] == pytest.approx(100, rel=0.15)


@pytest.mark.parametrize("offset", [1e-6, 1e-9])
def test_four_bar_released_next_to_its_toggle(offset):
    out = finished(stress.near_toggle(offset, 1.0))
    assert out.balance < 1e-8


def test_four_bar_just_past_its_toggle_cannot_assemble_and_says_why():
    out = stress.run_case(stress.near_toggle(-1e-6, 1.0), BUDGET)
    assert out.status == "stopped"
    assert isinstance(out.error, grubler.AssemblyError)
    assert out.error.field == "initial"
    assert "triangle inequality" in out.error.reason


@pytest.mark.parametrize("angle", [1e-9, math.pi - 1e-9])
def test_slider_crank_released_at_a_dead_centre(angle):
    out = finished(stress.slider_dead_centre(angle, 1.0))
    assert out.balance < 1e-8


@pytest.mark.parametrize("case", stress.random_cases("four-bar", 4, 0.3, dt_out=0.005)
                         + stress.random_cases("slider-crank", 4, 0.3, dt_out=0.005), ids=lambda c: c.name)
def test_random_mechanisms(case):
    out = finished(case)
    if "damped" in case.name:
        assert out.rise < 1e-9  # dampers only take energy out
        # E(t) - E(0) + damper losses; Simpson's rule on the 1 ms grid bounds it (it falls as dt_out^4)
        assert out.balance < 1e-4
    else:
        assert out.balance < 1e-8


def test_random_unclosable_four_bars_are_refused_by_name():
    rng = np.random.default_rng(7)
    for _ in range(5):
        lengths = rng.uniform(0.1, 1.0, 3)
        longest = float(lengths.sum() * rng.uniform(1.01, 2.0))
        out = stress.run_case(stress.Case("unclosable", "errors", stress.four_bar(longest, *lengths, 0.3),
                                          1.0, 0.1), BUDGET)
        assert out.status == "stopped"
        assert isinstance(out.error, grubler.AssemblyError)
        assert "longest link" in str(out.error)


def test_a_non_finite_drive_stops_with_an_integration_error():
    sim = grubler.Simulator(grubler.load_scene("thesis-fourbar").mechanism)
    sim.set_inputs(drive=math.nan)
    with pytest.raises(grubler.IntegrationError, match="non-finite"):
        sim.advance_to(0.1)
    assert sim.t == 0.0  # left where it was, for a retry


def test_an_absurd_drive_stops_with_an_integration_error():
    sim = grubler.Simulator(grubler.load_scene("thesis-fourbar").mechanism)
    sim.set_inputs(drive=1e30)
    with pytest.raises(grubler.IntegrationError, match="step size fell below"):
        sim.advance_to(0.1)
    assert np.all(np.isfinite(sim.z))
