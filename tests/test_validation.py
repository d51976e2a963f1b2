"""Every bad input gets a clear error naming the field and the reason."""

import math
import textwrap

import numpy as np
import pytest

import grubler
from grubler import AssemblyError, Link, Mechanism, SceneError, load_scene

FOURBAR = """
[link2]
joint = "R"
a = 0.2
m = 1.0
[link3]
joint = "R"
a = 0.8
m = 2.0
[link4]
joint = "R"
a = 0.8
m = 3.0
[closure]
type = "revolute"
point = [1.0, 0.0]
[drive]
joint = "theta2"
[initial]
theta3 = "pi/3"
theta4 = "-pi/3"
"""


def scene_with(old: str, new: str) -> str:
    assert old in FOURBAR
    return FOURBAR.replace(old, new, 1)


def expect(text: str, field: str, *words: str):
    with pytest.raises(SceneError) as info:
        load_scene(text)
    err = info.value
    assert err.field == field, str(err)
    for w in words:
        assert w in str(err), str(err)
    return err


def test_a_valid_scene_loads():
    assert load_scene(FOURBAR).mechanism.mobility == 1


def test_non_positive_mass():
    expect(scene_with("m = 2.0", "m = 0.0"), "link3.m", "mass must be positive")
    expect(scene_with("m = 2.0", "m = -1.0"), "link3.m", "mass must be positive")


def test_negative_length_and_inertia():
    expect(scene_with("a = 0.8", "a = -0.8"), "link3.a", "length must be >= 0")
    expect(scene_with("m = 3.0", "m = 3.0\nI = -0.1"), "link4.I", "moment of inertia must be >= 0")


def test_builder_lengths_must_be_positive():
    text = '[mechanism]\ntype = "four-bar"\nground = 1.0\ncrank = 0.0\ncoupler = 0.8\nrocker = 0.6\n'
    expect(text, "mechanism.crank", "length must be positive")
    expect(text.replace("crank = 0.0\n", ""), "mechanism.crank", "required")
    expect(text.replace("crank = 0.0", "crankk = 0.3"), "mechanism.crankk", "did you mean 'crank'?")


def test_existence_factor_pair_must_be_exactly_one_real_joint():
    expect(scene_with('joint = "R"\na = 0.8\nm = 2.0', "existence = [1, 1]\na = 0.8\nm = 2.0"),
           "link3.existence", "both", "exactly one")
    expect(scene_with('joint = "R"\na = 0.8\nm = 2.0', "existence = [0, 0]\na = 0.8\nm = 2.0"),
           "link3.existence", "neither")
    # the thesis's own notation works
    ok = load_scene(scene_with('joint = "R"\na = 0.8\nm = 2.0', "existence = [0, 1]\na = 0.8\nm = 2.0"))
    assert ok.mechanism.links[1].joint == "R"


def test_parallel_prismatic_axes_on_one_link():
    # link 3 slides on link 2 and link 4 slides on link 3, both axes along e_perp(theta2)
    text = FOURBAR.replace('joint = "R"\na = 0.8\nm = 2.0', 'joint = "P"\na = 0.0\nm = 2.0')
    text = text.replace('joint = "R"\na = 0.8\nm = 3.0', 'joint = "P"\na = 0.8\nm = 3.0')
    text = text.replace('theta3 = "pi/3"\ntheta4 = "-pi/3"', "theta3 = 0.0\ntheta4 = 0.0")
    expect(text, "link4.joint", "parallel axes", "redundant")


def test_double_slider_with_parallel_slides():
    text = ('[mechanism]\ntype = "double-slider"\ncoupler = 0.5\naxes_angle = 0.0\n')
    expect(text, "mechanism.axes_angle", "parallel")


def test_loop_needs_two_revolutes():
    text = """
[ground]
theta1 = "pi/2"
[link2]
joint = "P"
a = 0.0
m = 1.0
[link3]
joint = "P"
a = 0.0
m = 1.0
[link4]
joint = "R"
a = 0.4
m = 1.0
[closure]
type = "prismatic"
point = [1.0, 0.0]
angle = 0.3
[initial]
theta2 = 0.0
"""
    expect(text, "closure.type", "at least two revolutes")


def test_loop_that_cannot_close_says_why_in_grashof_terms():
    text = '[mechanism]\ntype = "four-bar"\nground = 1.0\ncrank = 3.0\ncoupler = 0.8\nrocker = 0.6\n'
    with pytest.raises(AssemblyError) as info:
        grubler.simulate(load_scene(text), t_end=0.1)
    assert info.value.field == "initial"
    assert "longest link (3 m) is not shorter than the other three together (2.4 m)" in str(info.value)


def test_initial_state_that_cannot_be_assembled():
    text = ('[mechanism]\ntype = "four-bar"\nground = 1.0\ncrank = 0.8\ncoupler = 0.3\nrocker = 0.9\n'
            'crank_angle = "100 deg"\n')
    with pytest.raises(AssemblyError) as info:
        grubler.simulate(load_scene(text), t_end=0.1)
    msg = str(info.value)
    assert "theta2 = 100 deg (1.74533 rad) held" in msg and "triangle inequality" in msg and "0.6 to 1.2 m" in msg


def test_drive_and_rates_on_a_locked_coordinate():
    expect(FOURBAR.replace('joint = "theta2"', 'joint = "B1"'), "drive.joint", "locked (fictitious)")
    expect(FOURBAR.replace('theta4 = "-pi/3"', 'theta4 = "-pi/3"\nB2_d = 1.0'), "initial.B2_d", "locked")


def test_unknown_keys_types_and_sources():
    expect(scene_with("m = 2.0", "mass = 2.0"), "link3.mass", "unknown key")
    expect(FOURBAR + "\n[simulate]\nmethod = 'magic'\n", "simulate.method", "exact, penalty")
    expect(scene_with("a = 0.8", 'a = "long"'), "link3.a", "cannot read")
    expect(scene_with("a = 0.8", "a = nan"), "link3.a", "finite")
    expect("x = [", "scene", "not valid TOML")
    expect("no-such-preset", "scene", "neither a preset")
    expect(FOURBAR.replace('[drive]\njoint = "theta2"', '[drive]\ntorque = 1.0'), "drive.joint",
           "needs the joint")


def test_model_level_checks_without_toml():
    with pytest.raises(SceneError, match="link2.m: mass must be positive"):
        Mechanism(links=(Link("R", a=1.0, m=0.0),))
    with pytest.raises(SceneError, match="gravity"):
        Mechanism(links=(Link("R", a=1.0),), gravity=-9.81)
    with pytest.raises(SceneError, match="link2.joint"):
        Mechanism(links=(Link("X", a=1.0),))


def test_run_settings_are_checked():
    with pytest.raises(SceneError, match="t_end"):
        grubler.simulate("thesis-fourbar", t_end=-1.0)
    with pytest.raises(SceneError, match="dt_out"):
        grubler.simulate("thesis-fourbar", t_end=1.0, dt_out=math.nan)
    with pytest.raises(SceneError, match="has no drive joint"):
        grubler.simulate(load_scene(FOURBAR.replace('[drive]\njoint = "theta2"', "")), torque=1.0)
    with pytest.raises(ValueError, match="rtol"):
        grubler.simulate("thesis-fourbar", t_end=0.1, rtol=0.0)


def test_angle_strings():
    from grubler.mechanism.scene import parse_angle_or_number as p

    assert p("60 deg", "x") == pytest.approx(math.pi / 3)
    assert p("-2*pi/3", "x") == pytest.approx(-2 * math.pi / 3)
    assert p("pi", "x") == pytest.approx(math.pi)
    assert p(" 1.5 rad", "x") == 1.5
    with pytest.raises(SceneError, match="initial.theta3"):
        p("sixty", "initial.theta3")


def test_docs_example_is_valid():
    # the schema document's full example must load
    import pathlib
    import re

    doc = (pathlib.Path(__file__).parents[1] / "docs" / "scenes.md").read_text()
    blocks = re.findall(r"```toml\n(.*?)```", doc, re.S)
    assert blocks
    from grubler.mechanism.spatial_scene import is_spatial, load_spatial_scene

    for block in blocks:
        text = textwrap.dedent(block)
        (load_spatial_scene if is_spatial(text) else load_scene)(text)  # the spatial form's too


def test_dotted_overrides_name_what_is_wrong():
    from grubler.mechanism.scene import override

    scene = grubler.load_scene("thesis-fourbar")
    with pytest.raises(grubler.SceneError, match=r"link7\.m: no such parameter of this scene \(it has: gravity"):
        override(scene, {"link7.m": 1.0})
    with pytest.raises(grubler.SceneError, match=r"link2\.m: mass must be positive"):
        override(scene, {"link2.m": -1.0})
    with pytest.raises(grubler.SceneError, match=r"drive\.torque: a drive torque needs the joint"):
        override(scene, {"drive_joint": "", "drive.torque": 1.0})
    s = override(scene, {"initial.theta2_d": 2.0, "link3.a": 0.9, "gravity": 0.0})
    assert s.mechanism.links[1].a == 0.9 and s.mechanism.gravity == 0.0
    assert s.initial_rates[s.mechanism.free_index("theta2")] == 2.0


def test_a_misspelt_name_gets_a_suggestion_and_a_missing_file_is_called_so():
    from grubler.motors import load_motor

    expect("thesis-forbar", "scene", "did you mean 'thesis-fourbar'")
    expect("nodir/run.toml", "scene", "no such file")
    with pytest.raises(SceneError, match="did you mean 'maxon-re40-148877'"):
        load_motor("maxon-re40-14887")
    with pytest.raises(SceneError, match="no such file"):
        load_motor("nodir/motor.toml")
    expect(scene_with("a = 0.8\nm = 2.0", "a = 0.8\nm = 2.0\ndampign = 0.1"), "link3.dampign", "did you mean 'damping'")


def test_info_on_a_loop_that_closes_nowhere_gives_the_reason_alone(capsys, tmp_path):
    from grubler.cli import run

    scene = tmp_path / "noclose.toml"
    scene.write_text('[mechanism]\ntype = "four-bar"\nground = 1.0\ncrank = 0.8\ncoupler = 0.3\nrocker = 0.9\n'
                     'crank_angle = "100 deg"\n')
    assert run(["info", str(scene)]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # no Grashof class of a mechanism that cannot be assembled
    assert "theta2 = 100 deg (1.74533 rad) held" in err and "0.152 m from its closure" in err


def test_a_sweep_range_written_without_its_count_is_explained():
    from grubler.errors import InputError
    from grubler.studies.sweep import parse_axis

    with pytest.raises(InputError, match="START:STOP:N"):
        parse_axis("link2.a=0.3:0.1")


def test_a_chain_longer_than_the_kernel_takes_is_refused_by_name():
    # the kernel's bound (GRB_MAX_LINKS, a sanity limit: every table is in the caller's workspace) is 1024 links
    text = "\n".join(f'[link{k}]\njoint = "R"\na = 0.1\nm = 1.0\nI = 0.01' for k in range(2, 1027))
    expect(text + '\n[closure]\ntype = "none"\n', "links", "at most 1024 moving links", "got 1025")


def test_a_chain_of_more_than_64_links_loads_and_runs():
    # the kinematic pass once kept each link's path from the ground as one bit of one 64-bit word: link 65 and on
    # had no path (and shifting by 64 or more is undefined); the path is now as many words as the chain needs
    import grubler

    text = "\n".join(f'[link{k}]\njoint = "R"\na = 0.1\np = 0.05\nm = 1.0\nI = 0.01' for k in range(2, 72))
    scene = load_scene(text + '\n[closure]\ntype = "none"\n[initial]\ntheta2 = -0.5\n')
    res = grubler.simulate(scene, t_end=0.05, dt_out=0.05)
    # a chain hanging still from link 2's pivot at rest: gravity alone moves it, and its energy is kept
    cols, table = res.table(("energy",))
    energy = table[:, cols.index("E")]
    assert np.all(np.isfinite(res.z)) and abs(energy[-1] - energy[0]) < 1e-6 * max(1.0, abs(energy[0]))
    # the last link (70th) moves: its joint is on its own path, and gravity reaches it through every ancestor
    assert abs(res.zd[-1, -1]) > 0
