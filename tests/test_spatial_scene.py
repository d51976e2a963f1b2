"""Spatial scenes (TOML), the perspective camera and the CLI on spatial mechanisms (issue 34, items 2 and 4)."""

import math

import numpy as np
import pytest

from grubler.errors import SceneError
from grubler.mechanism import spatial
from grubler.mechanism.spatial_scene import (is_spatial, load_spatial_scene, rod_inertia, spatial_preset_names,
                                             spatial_scene_from_dict)
from grubler.mechanism.scene import load_scene, preset_names, preset_text

# one registry of the spatial presets' names: the builders' (spatial.PRESETS); every shipped scene file is one
# of them and reproduces it (the tests below), so the two lists cannot drift
BUILDERS = spatial.PRESETS


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


def test_every_shipped_spatial_preset_has_a_builder_and_every_builder_a_file():
    assert sorted(spatial_preset_names()) == sorted(BUILDERS)


def test_spatial_preset_names_are_apart_from_the_planar_ones():
    # one namespace on the command line: a spatial preset named as a planar one would hide it
    # (grubler simulate NAME reads the spatial preset first)
    assert set(spatial_preset_names()).isdisjoint(preset_names())
    assert "planar-fourbar-3d" in spatial_preset_names() and "planar-fourbar" not in spatial.PRESETS


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


# -- the perspective view -------------------------------------------------------------------------------------
from grubler.cli import run  # noqa: E402
from grubler.views.perspective import (SpatialSketch, draw_list, fit_camera, orbit_camera, parse_camera,  # noqa: E402
                                       up_direction)


def test_projection_of_known_points():
    cam = orbit_camera(0.0, 0.0, 2.0, target=(0, 0, 0), up=(0, 0, 1), size=(200, 100), focal=100.0)
    uv, depth = cam.project([[0, 0, 0], [0, 0.5, 0.5], [-1, 0.5, 0], [3, 0, 0]])
    assert uv[0] == pytest.approx([100, 50])
    assert uv[1] == pytest.approx([100 + 100 * 0.5 / 2, 50 - 100 * 0.5 / 2])  # right and up, at depth 2
    assert uv[2] == pytest.approx([100 + 100 * 0.5 / 3, 50])                  # farther: nearer the middle
    assert depth[:3] == pytest.approx([2, 2, 3])
    assert depth[3] < 0 and np.isnan(uv[3]).all()                            # behind the camera: nowhere
    # from +y (azimuth 90 deg) world x runs to the left; from above (elevation 60 deg) z still points up
    side = orbit_camera(math.pi / 2, 0.0, 2.0, (0, 0, 0), (0, 0, 1), (200, 100), 100.0)
    assert side.project([[0.5, 0, 0]])[0][0] == pytest.approx([75, 50])
    high = orbit_camera(0.0, math.radians(60), 2.0, (0, 0, 0), (0, 0, 1), (200, 100), 100.0)
    assert high.position == pytest.approx([1.0, 0, math.sqrt(3)])
    assert high.project([[0, 0, 0.1]])[0][0][1] < 50
    # gravity sets up: the planar four-bar's -y gravity makes y the view's up
    assert up_direction((0, -9.81, 0)) == pytest.approx([0, 1, 0])


@pytest.mark.parametrize("name", sorted(BUILDERS))
def test_the_fit_puts_every_point_of_the_motion_inside_the_picture(name):
    scene = load_spatial_scene(name)
    res = scene.mechanism.simulate(scene.start(), 1.0, 0.05, tau=scene.tau())
    sketch = SpatialSketch(scene.mechanism, res.z)
    frames = sketch.positions(res.y)
    size = (640, 480)
    cam = fit_camera(frames.reshape(-1, 3), up=up_direction(scene.mechanism.gravity), size=size)
    uv, depth = cam.project(frames.reshape(-1, 3))
    assert np.all(depth > 0)
    assert np.all(uv >= 0) and np.all(uv[:, 0] <= size[0]) and np.all(uv[:, 1] <= size[1])
    # and it fills the picture: the points' image spans (1 - margin) of one side, centred
    span = uv.max(axis=0) - uv.min(axis=0)
    assert max(span[0] / size[0], span[1] / size[1]) == pytest.approx(0.94, abs=1e-6)
    assert (uv.max(axis=0) + uv.min(axis=0)) / 2 == pytest.approx(np.array(size) / 2, abs=1e-6)


@pytest.mark.parametrize("name", ["hooke-joint", "bricard"])
def test_the_film_and_the_app_keep_the_title_band_free(name):
    # the title is written in the top TITLE_PX of a film's frame and of the app's canvas: the fit is below it
    from grubler.app.spatial_view import CANVAS, spatial_view
    from grubler.views.perspective import TITLE_PX, Camera
    from grubler.views.spatial_film import FRAME_SIZE, film_camera

    scene = load_spatial_scene(name)
    res = scene.mechanism.simulate(scene.start(), 1.0, 0.05, tau=scene.tau())
    sketch = SpatialSketch(scene.mechanism, res.z)
    frames = sketch.positions(res.y)
    cam = film_camera(sketch, frames)
    uv, _ = cam.project(frames.reshape(-1, 3))
    below = FRAME_SIZE[1] - TITLE_PX
    assert uv[:, 1].min() >= TITLE_PX + 0.03 * below - 1e-6 and uv[:, 1].max() <= FRAME_SIZE[1] + 1e-6
    span = uv.max(axis=0) - uv.min(axis=0)
    assert max(span[0] / FRAME_SIZE[0], span[1] / below) == pytest.approx(0.94, abs=1e-6)
    # the app's camera, rebuilt as view3d.js rebuilds it from the answer, leaves its band free too
    view = spatial_view({"name": name, "t_end": 1.0})
    c = view["camera"]
    lens = c["zoom"] * CANVAS[1] / 2 / math.tan(c["fov"] / 2)
    position = np.array(c["target"]) + c["distance"] * (cam.position - cam.target) / np.linalg.norm(
        cam.position - cam.target)
    page = Camera(position, np.array(c["target"]), np.array(c["up"]), lens, CANVAS,
                  (c["centre"][0] * CANVAS[0], c["centre"][1] * CANVAS[1]))
    v = page.project(np.array(view["frames"]).reshape(-1, 3))[0][:, 1]
    assert v.min() >= TITLE_PX


def test_a_set_distance_is_kept_and_parts_are_drawn_far_to_near():
    scene = load_spatial_scene("rssr")
    y0 = scene.start()
    sketch = SpatialSketch(scene.mechanism, y0[None, :scene.mechanism.n_coords])
    frame = sketch.positions(y0[None])[0]
    cam = fit_camera(frame, math.radians(30), math.radians(20), distance=3.0)
    assert np.linalg.norm(cam.position - cam.target) == pytest.approx(3.0)
    parts = draw_list(cam, sketch, frame)
    depths = [p[4] for p in parts]
    assert depths == sorted(depths, reverse=True)
    # each joint is drawn after (over) every tube that ends at it
    _, d = cam.project(frame)
    order = {("marker", p[4]): n for n, p in enumerate(parts) if p[0] == "marker"}
    for i, body, kind in sketch.markers:
        marker_at = order[("marker", d[i] * (1 - 1e-9))]
        ends = [n for n, p in enumerate(parts) if p[0] == "segment"
                and any(i in s[:2] and p[4] == d[list(s[:2])].max() for s in sketch.segments)]
        assert all(n < marker_at for n in ends)


def test_the_hooke_joint_is_drawn_as_shafts_yokes_and_a_cross():
    # its joints all meet at the cross's centre: a spherical four-bar's arcs would not show it; each shaft is a
    # tube along its own axis with a yoke whose pins hold the cross's ends, in every frame of the motion
    scene, g = load_spatial_scene("hooke-joint"), spatial.hooke_joint_geometry()
    m = scene.mechanism
    res = m.simulate(scene.start(), 0.8, 0.1, tau=scene.tau(0.02))
    sketch = SpatialSketch(m, res.z)
    frames = sketch.positions(res.y)
    names = [l.name for l in m.links]
    cross, shafts = names.index("cross"), (names.index("input"), names.index("output"))
    bars = [(i, j) for i, j, b, kind in sketch.segments if b == cross and kind == "link"]
    pins = [i for i, b, kind in sketch.markers if b in shafts and kind == "revolute"]
    assert len(bars) == 2 and len(pins) == 4
    beta = g.shaft_angle
    directions = {shafts[0]: np.array([0, 0, -1.0]), shafts[1]: np.array([0, -math.sin(beta), math.cos(beta)])}
    for f in frames:
        ends = np.array([f[k] for bar in bars for k in bar])
        assert np.linalg.norm(ends, axis=1) == pytest.approx([g.cross] * 4, abs=1e-12)  # bars through the centre
        for p in pins:  # each yoke's pin on one of the cross's ends
            assert np.linalg.norm(ends - f[p], axis=1).min() < 1e-12
        for b in shafts:  # the shaft's tube along its bearing's axis, out to its length
            tube = max(((i, j) for i, j, bb, kind in sketch.segments if bb == b and kind == "link"),
                       key=lambda s: np.linalg.norm(f[s[1]] - f[s[0]]))
            for k in tube:
                assert np.linalg.norm(np.cross(f[k], directions[b])) < 1e-12
            assert max(f[k] @ directions[b] for k in tube) == pytest.approx(g.shaft, abs=1e-12)
    # the bearings are on the ground, on the shafts' axes; no arc of a spherical linkage is drawn
    bearings = [i for i, b, kind in sketch.markers if b == -1 and kind == "pin"]
    assert len(bearings) == 2 and not [s for s in sketch.segments if s[3] == "ground"]


@pytest.mark.parametrize("text, field, words", [
    ("30,20", "--camera azimuth", "has no unit"),
    ("30 deg", "--camera", "AZIMUTH,ELEVATION"),
    ("30 deg,90 deg", "--camera elevation", "between -90 and 90"),
    ("30 deg,20 deg,-1 m", "--camera distance", "positive"),
    ("30 deg,20 deg,2 deg", "--camera distance", "is an angle"),
])
def test_bad_camera_is_refused_naming_its_part(text, field, words):
    with pytest.raises(SceneError) as exc:
        parse_camera(text)
    assert exc.value.field == field and words in exc.value.reason


# -- the command line ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(BUILDERS))
def test_animate_writes_a_gif_and_a_png_of_each_preset(name, tmp_path, capsys):
    from PIL import Image

    from grubler.views.spatial_film import _Palette

    gif, png = tmp_path / f"{name}.gif", tmp_path / f"{name}.png"
    assert run(["animate", name, "--t-end", "0.4", "--fps", "10", "--out", str(gif)]) == 0
    assert run(["animate", name, "--out", str(png), "--camera", "20 deg,30 deg"]) == 0
    with Image.open(gif) as im:
        assert im.n_frames == 5 and im.size == (960, 720)
    m = load_spatial_scene(name).mechanism
    pal = _Palette(len(m.links))
    pixels = np.asarray(Image.open(png))
    drawn = set(np.unique(pixels).tolist())
    # every body with a tube of its own shows in its ink (a ball's massless links have none)
    bodies = {b for _, _, b, kind in SpatialSketch(m, np.zeros((1, m.n_coords))).segments if kind == "link"}
    for b in bodies:
        assert drawn & {pal.index[(f"body{b}", s)] for s in range(6)}, b
    assert "wrote" in capsys.readouterr().out


def test_simulate_writes_coordinates_energy_closure_error_and_reactions(tmp_path, capsys):
    out = tmp_path / "rssr.csv"
    assert run(["simulate", "rssr", "--torque", "0", "--t-end", "0.5", "--csv", str(out), "--reactions",
                "--rtol", "1e-11"]) == 0
    head = out.read_text().splitlines()[0].split(",")
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    data = {h: table[:, k] for k, h in enumerate(head)}
    assert head[:3] == ["t [s]", "crank.theta [rad]", "coupler1.theta [rad]"]
    assert {"E [J]", "closure_error [m]", "closure0.Fz [N]", "rocker.Mz [N m]"} <= set(head)
    E = data["E [J]"]
    assert np.ptp(E) < 1e-8 * np.abs(E).max()                      # a free run keeps its energy
    assert data["closure_error [m]"].max() < 1e-10
    # the reactions are the kernel's at each row
    scene = load_spatial_scene("rssr")
    y = table[-1, 1:1 + 2 * scene.mechanism.n_coords]
    closures, joints = scene.mechanism.reactions(y)
    assert data["closure0.Fz [N]"][-1] == pytest.approx(closures[0, 2], rel=1e-9, abs=1e-9)
    assert data["rocker.Mz [N m]"][-1] == pytest.approx(joints[4, 5], rel=1e-9, abs=1e-9)
    assert "max closure error" in capsys.readouterr().out


@pytest.mark.parametrize("argv, words", [
    (["simulate", "rssr", "--method", "penalty"], "--method: the spatial kernel closes its loops exactly"),
    (["simulate", "rssr", "--integrator", "radau"], "--integrator: the spatial advance has dop853 and rk45"),
    (["simulate", "rssr", "--reactions"], "--reactions:"),
    (["simulate", "rssr", "--t-end", "1e9", "--dt-out", "1e-6"], "--t-end or --dt-out: the run's rows would take"),
    (["simulate", "rssr", "--t-end", "1", "--dt-out", "2"], "--dt-out: 2 s is longer than the run"),
    (["animate", "rssr", "--camera", "30,20"], "--camera azimuth: '30' has no unit"),
    (["animate", "rssr", "--trace", "tip"], "--trace: a trace is a planar film's"),
    (["animate", "thesis-fourbar", "--camera", "30 deg,20 deg"], "--camera: sets the perspective view"),
])
def test_cli_refuses_what_a_spatial_run_cannot_do(argv, words, capsys):
    assert run(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("grubler: error: ") and words in err[0], err


def test_cli_refuses_a_bad_spatial_file_naming_the_field(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(_preset_toml("rssr").replace('alpha = "90 deg"', 'alpha = "90 mm"'))
    assert run(["simulate", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("grubler: error: link[2].alpha:"), err


def test_info_tells_freedoms_start_and_determinacy(capsys):
    assert run(["info", "spherical-fourbar"]) == 0
    out = capsys.readouterr().out
    assert "closure rows 5, of rank 2 here: 1 degree of freedom" in out
    assert "closure 0 (revolute): determinate My, Mx; indeterminate Fx, Fy, Fz" in out
    assert "crank.theta = 0 deg" in out


def test_hold_keeps_the_named_coordinates_and_damping_takes_a_pair():
    text = _preset_toml("rssr").replace('"rocker.theta" = "42.9 deg"', '"rocker.theta" = "50 deg"\n'
                                        'hold = ["rocker.theta"]')
    text = text.replace("mass = 0.8", "mass = 0.8\ndamping = [0.02, 0]")
    scene = load_spatial_scene(text)
    y0 = scene.start()
    names = scene.mechanism.coordinate_names
    assert y0[names.index("rocker.theta")] == pytest.approx(math.radians(50), abs=1e-15)
    assert y0[names.index("crank.theta")] != pytest.approx(0.0, abs=1e-3)   # the crank moved to close it
    assert scene.mechanism.links[4].damping == (0.02, 0.0)
    with pytest.raises(SceneError, match=r"initial\.hold: must list the coordinates"):
        load_spatial_scene(text.replace('hold = ["rocker.theta"]', 'hold = ["rocker"]'))


def test_simulate_plots_a_spatial_run(tmp_path):
    from PIL import Image

    png = tmp_path / "rssp.png"
    assert run(["simulate", "rssp", "--t-end", "0.2", "--plot", str(png)]) == 0
    with Image.open(png) as im:
        assert im.size[0] > 400 and im.size[1] > 400
