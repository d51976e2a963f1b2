"""Every preset and every thesis tuning runs; the classifications are right."""

import numpy as np
import pytest

import grubler
from grubler import classify, grashof, kutzbach_mobility, load_scene, preset_names

THESIS = ["thesis-fourbar", "thesis-slider-crank", "thesis-quick-return", "thesis-swinging-block",
          "thesis-scotch-yoke", "thesis-oldham", "thesis-double-slider", "thesis-conchoidal"]


def test_the_thesis_names_are_all_there():
    names = preset_names()
    for n in THESIS + ["triple-pendulum"]:
        assert n in names


# a change-point linkage stops, by name, where its branches meet (test_physics)
@pytest.mark.parametrize("name", [n for n in preset_names() if n != "fourbar-change-point"])
def test_every_preset_runs_five_seconds_exactly_closed(name):
    res = grubler.simulate(name, t_end=5.0, dt_out=0.05)
    assert np.all(np.isfinite(res["E"]))
    assert np.max(res["closure_error"]) < 1e-10


@pytest.mark.parametrize("name", [n for n in THESIS if n != "thesis-slider-crank"])
def test_every_thesis_tuning_runs_five_seconds_with_the_penalty_closure(name):
    res = grubler.simulate(name, t_end=5.0, dt_out=0.05, method="penalty", rtol=1e-6, atol=1e-8)
    assert np.all(np.isfinite(res["theta2"]))
    # after the springs pull the unclosed starts in, the violation is millimetres
    assert np.max(res["closure_error"][20:]) < 0.05


@pytest.mark.parametrize("name, chain, kind", [
    ("thesis-fourbar", "RRRR", "crank-rocker"),
    ("fourbar-double-crank", "RRRR", "double-crank"),
    ("fourbar-double-rocker", "RRRR", "double-rocker"),
    ("fourbar-triple-rocker", "RRRR", "triple-rocker"),
    ("fourbar-change-point", "RRRR", "change-point"),
    ("fourbar-parallelogram", "RRRR", "parallelogram"),
    ("slider-crank", "RRRP", "slider-crank"),
    ("pendulum-pump", "RRRP", None),
    ("quick-return", "RRRP", "quick-return"),
    ("scotch-yoke", "RRPP", "Scotch yoke"),
    ("oldham", "RRPP", "Oldham"),
    ("elliptic-trammel", "RRPP", "elliptic trammel"),
    ("double-slider", "RRPP", "double slider"),
    ("conchoidal", "RPRP", "conchoidal"),
    ("triple-pendulum", "open", None),
])
def test_classification(name, chain, kind):
    c = classify(load_scene(name).mechanism)
    assert c.chain == chain
    if kind:
        assert kind in c.name or (c.grashof and c.grashof.kind == kind)
    assert c.mobility == (3 if chain == "open" else 1)


def test_grashof_and_mobility_by_hand():
    assert kutzbach_mobility(4, 4) == 1
    assert kutzbach_mobility(6, 7) == 1  # Watt and Stephenson six-bars
    assert kutzbach_mobility(5, 5) == 2  # five-bar
    g = grashof(ground=1.0, crank=0.3, coupler=0.8, rocker=0.6)
    assert (g.kind, g.s_plus_l, g.p_plus_q) == ("crank-rocker", 1.3, 1.4)
    assert grashof(0.3, 1.0, 0.8, 0.6).kind == "double-crank"
    assert grashof(1.0, 0.8, 0.3, 0.9).kind == "double-rocker"
    assert grashof(1.0, 0.5, 0.9, 0.55).kind == "triple-rocker"
    with pytest.raises(ValueError, match="crank"):
        grashof(1.0, -0.3, 0.8, 0.6)


def test_builders_close_their_own_start():
    # a builder's start is already (nearly) closed: assembly moves it by little
    for name in ["fourbar-crank-rocker", "slider-crank", "offset-slider-crank", "quick-return",
                 "swinging-block", "pendulum-pump", "scotch-yoke", "oldham", "elliptic-trammel",
                 "double-slider", "conchoidal"]:
        m = load_scene(name).mechanism
        z0 = m.z_from_q(m.q_ref)
        z, _ = grubler.assemble(m, z0)
        assert np.max(np.abs(z - z0)) < 1e-9, name


def test_oldham_shafts_turn_together():
    res = grubler.simulate("oldham", t_end=2.0, dt_out=0.1)
    assert np.allclose(res["theta4"] - res["theta2"], np.pi / 2, atol=1e-12)


def test_scotch_yoke_moves_harmonically():
    res = grubler.simulate("scotch-yoke", t_end=2.0, dt_out=0.05)
    crank = res["theta4"] - np.pi
    assert np.allclose(-res["B1"], 0.1 * np.cos(crank), atol=1e-10)


def test_penalty_refuses_a_coordinate_without_inertia():
    # the thesis's slider-crank block has I = 0 and p = 0: its rotation theta4 has
    # no inertia for the imaginary joint's spring to act on
    with pytest.raises(grubler.SceneError, match="cannot move theta4: it carries no inertia"):
        grubler.simulate("thesis-slider-crank", t_end=0.1, method="penalty")
    # the exact closure handles the same data (the singular mass matrix is augmented)
    assert np.max(grubler.simulate("thesis-slider-crank", t_end=0.1)["closure_error"]) < 1e-12


def _slider_crank(crank, rod, offset):
    return load_scene(f'[mechanism]\ntype = "slider-crank"\ncrank = {crank}\nrod = {rod}\noffset = {offset}\n'
                      'crank_angle = "90 deg"\n').mechanism


@pytest.mark.parametrize("crank, rod, offset, kind", [
    (0.1, 0.35, 0.0, "crank"),           # in-line
    (0.25, 1.0, 0.2, "crank"),           # the thesis's offset
    (0.25, 1.0, -0.2, "crank"),          # offset to the other side
    (0.1, 0.35, 0.25, "change-point"),   # 0.1 + 0.25 = 0.35: square to the slide once a turn
    (0.5, 0.6, 0.3, "rocker"),           # 0.5 + 0.3 > 0.6
    (0.15, 0.3, -0.3, "rocker"),
])
def test_a_slider_crank_is_classed_crank_or_rocker_by_its_offset(crank, rod, offset, kind):
    from grubler.mechanism.analysis import slider_crank_class

    sc = classify(_slider_crank(crank, rod, offset)).slider_crank
    assert sc.kind == kind
    assert (sc.crank, sc.coupler, sc.offset) == pytest.approx((crank, rod, abs(offset)), abs=1e-12)
    assert sc.ratio == pytest.approx(rod / crank)
    # the closed form: the coupler reaches the slide line at every crank angle iff the crank pin's farthest
    # distance from it, |offset - crank sin(theta)| over a turn, is at most the coupler
    theta = np.linspace(0.0, 2 * np.pi, 100_001)
    reach = np.max(np.abs(offset - crank * np.sin(theta)))
    assert (reach <= rod + 1e-12) == (kind in ("crank", "change-point"))
    assert slider_crank_class(crank, rod, offset).kind == kind


def test_the_slider_crank_presets_and_info_say_their_class(capsys):
    from grubler.cli import main

    sc = classify(load_scene("thesis-slider-crank").mechanism).slider_crank
    assert (sc.kind, sc.offset, sc.ratio) == ("crank", pytest.approx(0.2), pytest.approx(4.0))
    # the pendulum pump's crank swings: its pin must stay within 0.3 m of the rod's line at x = 0.3
    assert classify(load_scene("pendulum-pump").mechanism).slider_crank.kind == "rocker"
    assert classify(load_scene("thesis-fourbar").mechanism).slider_crank is None
    assert main(["info", "thesis-slider-crank"]) == 0
    out = capsys.readouterr().out
    assert ("grashof    slider-crank crank: crank + |offset| = 0.45 m, coupler 1 m (crank + |offset| < coupler: "
            "the crank turns fully)") in out
    assert "lengths    crank 0.25 m, coupler 1 m, offset 0.2 m, ratio coupler/crank 4" in out
