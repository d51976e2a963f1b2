"""Spatial scenes (TOML), the perspective camera and the CLI on spatial mechanisms (issue 34, items 2 and 4)."""

import math

import numpy as np
import pytest

from grubler.errors import SceneError
from grubler.mechanism import spatial
from grubler.mechanism.spatial_scene import (is_spatial, load_spatial_scene, rod_inertia, spatial_preset_names,
                                             spatial_scene_from_dict)
from grubler.mechanism.scene import load_scene, preset_text

BUILDERS = {"rssr": spatial.rssr, "rssp": spatial.rssp, "spherical-fourbar": spatial.spherical_fourbar,
            "planar-fourbar-3d": spatial.planar_fourbar}


def _preset_toml(name: str) -> str:
    from importlib import resources
    return (resources.files("grubler") / "presets" / "spatial" / f"{name}.toml").read_text()


@pytest.mark.parametrize("name", sorted(BUILDERS))
def test_each_spatial_preset_reproduces_its_builder(name):
    scene, built = load_spatial_scene(name), BUILDERS[name]()
    m = scene.mechanism
    assert m.coordinate_names == built.coordinate_names
    assert [l.name for l in m.links] == [l.name for l in built.links]
    np.testing.assert_allclose(m._links, built._links, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(m._closures, built._closures, rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(m.gravity, built.gravity)
    # the sketch is rounded in the file: the assembly lands on the builder's closed start
    np.testing.assert_allclose(scene.start(), built.assembled_start(), atol=1e-10)


def test_every_shipped_spatial_preset_has_a_builder():
    assert sorted(spatial_preset_names()) == sorted(BUILDERS)


def test_a_spatial_scene_runs_as_its_builder():
    scene = load_spatial_scene("rssr")
    res = scene.mechanism.simulate(scene.start(), 0.3, 0.1, tau=scene.tau())
    built = spatial.rssr()
    tau = np.zeros(built.n_coords)
    tau[0] = 0.5
    ref = built.simulate(built.assembled_start(), 0.3, 0.1, tau=tau)
    np.testing.assert_allclose(res.y, ref.y, atol=1e-9)


def test_rod_shortcut_is_the_slender_rod_along_any_direction():
    com, I = rod_inertia(2.0, (0.0, 0.3, 0.4), radius=0.01)
    u = np.array([0.0, 0.6, 0.8])
    assert np.allclose(com, [0, 0.15, 0.2])
    assert I @ u == pytest.approx(2.0 * 0.01 ** 2 / 2 * u)            # about its own axis: m r^2 / 2
    across = np.array([1.0, 0, 0])
    assert across @ I @ across == pytest.approx(2.0 * (3e-4 + 0.25) / 12)  # across: m (3 r^2 + L^2) / 12


def test_angles_and_lengths_by_the_planar_rule():
    sc = spatial_scene_from_dict({"dimension": 3, "link": [
        {"name": "arm", "joint": "C", "alpha": "pi/2", "a": "250 mm", "d": 0.1, "mass": 1.0, "rod": [0.5, 0, 0]}],
        "initial": {"arm.theta": "30 deg", "arm.d": "20 mm", "arm.theta_d": 2.0, "arm.d_d": 0.5}})
    link = sc.mechanism.links[0]
    assert (link.a, link.alpha, link.d) == (0.25, math.pi / 2, 0.1)
    assert sc.sketch == pytest.approx([math.radians(30), 0.02])
    assert sc.rates == pytest.approx([2.0, 0.5])
    assert sc.mechanism.coordinate_names == ("arm.theta", "arm.d")


def _bad(old: str, new: str, base: str = "rssr") -> SceneError:
    text = _preset_toml(base)
    assert old in text, old
    with pytest.raises(SceneError) as exc:
        load_spatial_scene(text.replace(old, new, 1))
    return exc.value


@pytest.mark.parametrize("old, new, field, words", [
    ('alpha = "90 deg"', 'alpha = "90 mm"', "link[2].alpha", "angle"),
    ('a = "350 mm"', 'a = "35 deg"', "link[2].a", "is an angle"),
    ('to = "rocker"', 'to = "rockr"', "closure[0].to", "must name a link"),
    ('joint = "S"', 'joint = "X"', "link[1].joint", "S spherical"),
    ('"rocker.theta" = "42.9 deg"', '"rocker.thet" = 1', "initial.rocker.thet", "did you mean 'rocker.theta'"),
    ('d = "50 mm"', 'd = "50 mm"\nbogus = 1', "link[2].bogus", "unknown key"),
    ('kind = "spherical"', 'kind = "spherical"\naxis = [0, 0, 1]', "closure[0].axis", "no axis"),
    ('kind = "spherical"', 'kind = "ball"', "closure[0].kind", "spherical, revolute, cylindrical"),
    ('a = "350 mm"', 'a = "3500 mm"', "initial", "cannot be closed"),
    ("dimension = 3", "dimension = 2", "dimension", "dimension = 3"),
    ("torque = 0.5 ", 'torque = "0.5 deg" ', "drive.torque", "not a plain number"),
    ('joint = "crank.theta"', 'joint = "crank.d"', "drive.joint", "must name a coordinate"),
    ("mass = 0.8", "mass = -0.8", "link[2].mass", "mass >= 0"),
    ('parent = "crank"', 'parent = "rocker"', "link[1].parent", "an earlier link"),
    ('name = "rocker"', 'name = "crank"', "link[2].name", "earlier link already"),
    ("rod = [0.2, 0, 0]", "rod = [0.2, 0]", "link[2].rod", "3 numbers"),
    ("gravity = [0, 0, -9.81]", "gravity = [0, 0, '9.81 mm']", "gravity[2]", "not a plain number"),
])
def test_bad_spatial_scenes_are_refused_naming_the_field(old, new, field, words):
    exc = _bad(old, new)
    assert exc.field == field and words in exc.reason, str(exc)


def test_the_kernel_check_is_told_as_the_scene_field():
    # the ball's body is the third model link of table 1: its refused inertia is link[1]'s
    exc = _bad('rod = [0, 0, 0.4]       # the coupler runs along its own z axis\nradius = "10 mm"',
               "com = [0, 0, 0.2]\ninertia = [1.0, 0, 0]")
    assert exc.field == "link[1].inertia" and "physical inertia" in exc.reason
    exc = _bad('link = "coupler"\nto = "rocker"', 'link = "coupler"\nto = "coupler"')
    assert exc.field == "closure[0].to"
    exc = _bad("axis = [0, -0.8660254037844386, 0.5]", "axis = [0, 0, 0]", base="spherical-fourbar")
    assert exc.field == "closure[0].axis" and "not zero" in exc.reason


def test_planar_and_spatial_sources_are_told_apart():
    assert is_spatial("rssr") and not is_spatial("thesis-fourbar")
    assert is_spatial(_preset_toml("rssp")) and not is_spatial(preset_text("slider-crank"))
    with pytest.raises(SceneError, match="dimension: a spatial scene"):
        load_scene(_preset_toml("rssr"))
