"""The picture is right: joint centres where independent kinematics puts them,
the whole motion in view, and the trammel's classic traces."""

import re
import shutil

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import scipy.ndimage  # noqa: E402

import grubler  # noqa: E402
from grubler.views.animation import JOINT_COLOUR, Drawer, fit_view, frame_geometry, trace_path  # noqa: E402
from grubler.cli import main  # noqa: E402
from reference import RefChain  # noqa: E402


def render(model, z, xlim, ylim):
    fig, ax = plt.subplots(figsize=(6.4, 5.2), dpi=100)
    drawer = Drawer(ax, model, xlim, ylim)
    drawer.draw(frame_geometry(model, z))
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[:, :, :3].astype(int)
    return fig, ax, img


def joint_centroids(img):
    target = np.array(matplotlib.colors.to_rgb(JOINT_COLOUR)) * 255
    mask = np.all(np.abs(img - target) < 40, axis=2)
    labels, n = scipy.ndimage.label(mask)
    centres = scipy.ndimage.center_of_mass(mask, labels, range(1, n + 1))
    # pixel (row, col) covers [col, col + 1) x [row, row + 1): its centre is at +0.5
    return np.array([(c[1] + 0.5, c[0] + 0.5) for c in centres])  # (x, y) in image pixels, y down


def expected_joints(model, z):
    """Revolute centres from the independent complex-number kinematics."""
    ref = RefChain.of(model)
    q = model.q_from_z(z)
    origins = ref.origins(q)
    pts = [origins[k] for k, l in enumerate(model.links) if l.joint == "R"]
    for cl in model.closures:
        if cl.kind == "revolute":
            pts.append(ref.point(q, cl.link - 2, *cl.point))
    return np.array([(p.real, p.imag) for p in pts])


@pytest.mark.parametrize("preset, torque", [("thesis-fourbar", 3.0), ("fourbar-double-crank", None),
                                            ("thesis-quick-return", None)])
def test_drawn_joint_centres_sit_on_the_kinematics_to_a_pixel(preset, torque):
    res = grubler.simulate(preset, t_end=2.0, dt_out=0.05, torque=torque)
    m = res.model
    xlim, ylim = fit_view(m, res.z)
    for i in (0, 13, 27, 40):
        fig, ax, img = render(m, res.z[i], xlim, ylim)
        expected = ax.transData.transform(expected_joints(m, res.z[i]))
        expected[:, 1] = img.shape[0] - expected[:, 1]
        found = joint_centroids(img)
        assert len(found) == len(expected)
        for e in expected:
            assert np.min(np.hypot(*(found - e).T)) < 1.0
        plt.close(fig)


@pytest.mark.parametrize("preset, t_end", [("fourbar-double-crank", 5.0), ("slider-crank", 5.0),
                                           ("thesis-trammel-driven", 5.0)])
def test_the_view_holds_every_point_of_the_motion(preset, t_end):
    res = grubler.simulate(preset, t_end=t_end, dt_out=0.02)
    m = res.model
    (x0, x1), (y0, y1) = fit_view(m, res.z)
    ref = RefChain.of(m)
    pts = []
    for z in res.z:
        q = m.q_from_z(z)
        pts += ref.origins(q) + [ref.tip(q)]
    pts = np.array(pts)
    assert np.all((pts.real > x0) & (pts.real < x1) & (pts.imag > y0) & (pts.imag < y1))
    if preset == "thesis-trammel-driven":  # it really visits all four quadrants
        mid = np.array([ref.point(m.q_from_z(z), 1, 0.4, 0.0) for z in res.z])
        assert {(np.sign(p.real), np.sign(p.imag)) for p in mid} >= {(1, 1), (-1, 1), (-1, -1), (1, -1)}
    if preset == "fourbar-double-crank":  # both cranks turn fully
        assert np.ptp(res["theta2"]) > 2 * np.pi and np.ptp(res["theta4"]) > 2 * np.pi


def test_trammel_traces_a_circle_and_an_ellipse():
    res = grubler.simulate("thesis-trammel-driven", t_end=5.0, dt_out=0.02)
    m = res.model
    L = m.links[1].a
    mid = trace_path(m, res.z, (1, (L / 2, 0.0)))
    assert np.allclose(np.hypot(mid[:, 0], mid[:, 1]), L / 2, atol=1e-9)
    d = 0.2
    p = trace_path(m, res.z, (1, (d, 0.0)))
    # block 1 on x, block 2 on y: the point at d from block 1 has semi-axes L - d (x) and d (y)
    assert np.allclose((p[:, 0] / (L - d)) ** 2 + (p[:, 1] / d) ** 2, 1.0, atol=1e-9)
    assert np.max(np.abs(p[:, 0])) == pytest.approx(L - d, rel=1e-2)
    assert np.max(np.abs(p[:, 1])) == pytest.approx(d, rel=1e-2)


def test_animate_cli_from_a_scene_and_from_a_csv(tmp_path, capsys):
    gif = tmp_path / "fb.gif"
    assert main(["animate", "thesis-fourbar", "--t-end", "0.4", "--fps", "10", "--out", str(gif),
                 "--trace", "tip"]) == 0
    from PIL import Image

    im = Image.open(gif)
    assert im.n_frames == 5
    csv = tmp_path / "run.csv"
    assert main(["simulate", "thesis-trammel-driven", "--t-end", "0.4", "--csv", str(csv)]) == 0
    assert main(["animate", str(csv), "--scene", "thesis-trammel-driven", "--fps", "10",
                 "--out", str(tmp_path / "tram.gif"), "--trace", "link3:0.4,0"]) == 0
    capsys.readouterr()
    assert main(["animate", str(csv), "--out", str(tmp_path / "x.gif")]) == 2
    assert "--scene" in capsys.readouterr().err
    assert main(["animate", "thesis-fourbar", "--t-end", "0.2", "--trace", "link9:1,0",
                 "--out", str(tmp_path / "y.gif")]) == 2
    assert "--trace" in capsys.readouterr().err


@pytest.mark.skipif(shutil.which("ffmpeg") is not None, reason="ffmpeg present: MP4 works")
def test_a_record_coarser_than_the_film_is_animated_with_a_warning_not_a_crash(tmp_path, capsys):
    # (the run CSV test_fuzz_animate_csv drew: two rows 1 s apart, filmed at 4 frames a second, so the frames
    # repeat rows and their times advance by 0 s: the frame warning divided by that)
    csv = tmp_path / "r.csv"
    csv.write_text("t,B1,theta2,B2,theta3,B3,theta4,closure_error\n0,0.0,0.0,0.0,0.0,0.0,0.0,0.0\n"
                   "1.0,0.0,0.0,0.0,0.0,0.0,1.0,1.0\n")
    assert main(["animate", str(csv), "--scene", "thesis-fourbar", "--out", str(tmp_path / "a.gif"),
                 "--fps", "4"]) == 0
    err = capsys.readouterr().err
    assert "warning: --dt-out: theta4 turns 0.16 turn per sample (1 s)" in err and "Traceback" not in err


def test_mp4_without_ffmpeg_says_so(tmp_path, capsys):
    assert main(["animate", "thesis-fourbar", "--t-end", "0.2", "--out", str(tmp_path / "a.mp4")]) == 2
    assert "ffmpeg" in capsys.readouterr().err


# -- the film: every point of every frame from one kernel call, a traced point on its plate,
# -- the signals' cursor where the frame's time is -------------------------------------------
from grubler.views.animation import PLATE_COLOUR, CURSOR_COLOUR, Sketch, _Film, frame_rows  # noqa: E402
from grubler.mechanism.kinematics import link_points  # noqa: E402


@pytest.mark.parametrize("preset", ["watt-ii", "thesis-slider-crank", "thesis-trammel-driven"])
def test_link_points_of_a_whole_trajectory_match_the_reference_kinematics(preset):
    res = grubler.simulate(preset, t_end=0.5, dt_out=0.05)
    m = res.model
    ref = RefChain.of(m)
    pts = [(k, 0.0, 0.0) for k in range(m.n_links)] + [(k, 0.13, -0.07) for k in range(m.n_links)]
    got = link_points(m, res.z, [p[0] for p in pts], [p[1:] for p in pts])
    for i, z in enumerate(res.z):
        q = m.q_from_z(z)
        want = ref.origins(q) + [ref.point(q, k, u, v) for k, u, v in pts[m.n_links:]]
        assert np.max(np.abs(got[i] - np.array([(w.real, w.imag) for w in want]))) < 1e-12
    with pytest.raises(IndexError):
        link_points(m, res.z[:1], [m.n_links], [(0.0, 0.0)])


def test_frame_rows_show_the_last_record_row_at_or_before_each_frame_time():
    t = np.arange(0.0, 1.0005, 0.001)  # a 1 ms record
    rows = frame_rows(t, fps=25, speed=1.0)
    assert len(rows) == 26 and np.allclose(t[rows], np.arange(26) * 0.04)
    rows = frame_rows(np.array([0.0, 0.3, 0.35, 1.0]), fps=10, speed=1.0)
    assert rows.tolist() == [0, 0, 0, 1, 2, 2, 2, 2, 2, 2, 3]


def _colour_at(im, xy):
    rgb = im.convert("RGB").getpixel((int(round(xy[0])), int(round(xy[1]))))
    return "#%02x%02x%02x" % rgb


def test_a_traced_point_is_drawn_on_its_link_as_a_plate_and_the_cursor_follows_the_time():
    res = grubler.simulate("thesis-fourbar", t_end=1.0, dt_out=0.01, torque=3.0)
    m = res.model
    point = (1, (0.4, 0.1))  # the coupler, off its line
    geo = frame_geometry(m, res.z[0], point)
    pin, end = link_points(m, res.z[:1], [1, 2], [(0, 0), (0, 0)])[0]
    (plate,) = geo.plates
    assert len(plate) == 3 and all(any(np.allclose(c, p) for c in plate) for p in (pin, end, geo.trace))
    sketch = Sketch(m, point)
    rows = frame_rows(res.t, 10, 1.0)
    film = _Film(m, sketch, sketch.positions(res.z[rows]), None, res.t, [("theta2 [rad]", res["theta2"])],
                 "", (960, 720))
    assert film.size[0] == 960
    xs = []
    for f, row in enumerate(rows):
        im = film.frame(f, row)
        corners = film._px(np.array(sketch.geometry(film.pos[f]).plates[0]))
        # the plate is filled: its centroid, and halfway from it to the traced point, are plate-coloured
        c = corners.mean(axis=0)
        tp = film._px(film.pos[f][sketch.trace][None, :])[0]
        assert _colour_at(im, c) == PLATE_COLOUR and _colour_at(im, (c + tp) / 2) == PLATE_COLOUR
        sax, y_top, y_bottom, _ = film.strip_px[0]
        band = np.asarray(im.convert("RGB"))[int(y_top) + 3: int(y_top) + 12]  # above any dot on the curve
        cursor = np.all(band == np.array(matplotlib.colors.to_rgb(CURSOR_COLOUR)) * 255, axis=2).any(axis=0)
        x_expected = sax.transData.transform((res.t[row], 0.0))[0]
        assert abs(np.flatnonzero(cursor).mean() - x_expected) < 1.5
        xs.append(x_expected)
    assert np.all(np.diff(xs) > 0)


def test_animate_cli_signals_frames_and_a_scene_that_does_not_fit(tmp_path, capsys):
    from PIL import Image

    csv = tmp_path / "run.csv"
    assert main(["simulate", "thesis-fourbar", "--torque", "3", "--t-end", "1", "--csv", str(csv)]) == 0
    gif = tmp_path / "a.gif"
    assert main(["animate", str(csv), "--scene", "thesis-fourbar", "--fps", "10", "--out", str(gif),
                 "--signals", "theta2,tau_drive", "--trace", "link3:0.4,0.1"]) == 0
    im = Image.open(gif)
    assert im.n_frames == 11 and im.size[0] == 960 and im.size[1] > 720
    capsys.readouterr()
    assert main(["animate", str(csv), "--scene", "thesis-fourbar", "--out", str(gif), "--signals", "theta_2"]) == 2
    assert "--signals: no column 'theta_2' in the run; did you mean 'theta2'?" in capsys.readouterr().err
    assert main(["animate", str(csv), "--scene", "thesis-fourbar", "--out", str(gif),
                 "--signals", "theta2,theta3,theta4,E,KE"]) == 2
    assert "at most 4" in capsys.readouterr().err
    # from a scene, the names are checked before anything is simulated (a million seconds would be refused too)
    assert main(["animate", "thesis-fourbar", "--t-end", "1e6", "--out", str(gif), "--signals", "tau_driv"]) == 2
    assert "--signals: no column 'tau_driv' in the run; did you mean 'tau_drive'?" in capsys.readouterr().err
    assert main(["animate", str(csv), "--scene", "thesis-slider-crank", "--out", str(gif)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--scene: thesis-slider-crank does not fit" in err
    assert re.search(r"open by [0-9.e+-]+ (m|rad) at t = ", err), err


def test_mp4_frames_go_to_ffmpeg_whole(tmp_path, monkeypatch):
    # a stand-in ffmpeg that counts the bytes it is given: the film's plumbing, not H.264
    fake = tmp_path / "bin" / "ffmpeg"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\nfor a; do out=$a; done\nwc -c > \"$out\"\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{fake.parent}:/usr/bin:/bin")
    res = grubler.simulate("thesis-fourbar", t_end=0.4, dt_out=0.01, torque=3.0)
    from grubler.views.animation import animate

    out = tmp_path / "a.mp4"
    n = animate(res.model, res.t, res.z, str(out), fps=10)
    from PIL import Image

    animate(res.model, res.t, res.z, str(tmp_path / "same.gif"), fps=10)  # the same frames, to know their size
    w, h = Image.open(tmp_path / "same.gif").size
    assert int(out.read_text().split()[0]) == n * w * h * 3


def test_the_gif_decodes_to_the_frames_drawn_though_it_stores_only_what_moved(tmp_path):
    from PIL import Image
    from grubler.views.animation import animate, trace_path, trace_point

    res = grubler.simulate("thesis-fourbar", t_end=1.0, dt_out=0.01, torque=3.0)
    m = res.model
    signals = [("theta2 [rad]", res["theta2"])]
    out = tmp_path / "a.gif"
    n = animate(m, res.t, res.z, str(out), fps=10, trace="link3:0.4,0.1", signals=signals)
    # the same film drawn again, frame by frame
    point = trace_point("link3:0.4,0.1", m)
    sketch = Sketch(m, point)
    rows = frame_rows(res.t, 10, 1.0)
    film = _Film(m, sketch, sketch.positions(res.z[rows]), trace_path(m, res.z, point), res.t, signals, "",
                 (960, 720))
    gif = Image.open(out)
    assert gif.n_frames == n == len(rows)
    for f, row in enumerate(rows):
        want = np.asarray(film.frame(f, row).convert("RGB"))
        gif.seek(f)
        assert np.array_equal(np.asarray(gif.convert("RGB")), want), f


def test_a_branching_chain_is_drawn_from_each_links_parent():
    """The Y tree of test_tree: joints placed by hand from each link's parent, link 2 a plate of three joints."""
    from grubler import Link, Mechanism

    # link: (parent, a); each pair's slide across its parent's vector end; absolute angles
    Y = {2: (1, 0.5), 3: (2, 0.4), 4: (2, 0.3), 5: (1, 0.45), 6: (4, 0.35)}
    B = {2: 0.0, 3: 0.0, 4: 0.2, 5: 0.3, 6: 0.0}
    ANGLES = {2: -1.0, 3: -2.1, 4: -0.5, 5: -1.8, 6: 0.2}
    m = Mechanism(links=tuple(Link("R", a=a, m=1.0, I=0.01, parent=p) for p, a in Y.values()),
                  q_ref=tuple(v for k in Y for v in (B[k], ANGLES[k])), name="Y")
    z = m.z_from_q(m.q_ref)

    def rot(a):
        return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])

    joint = {}
    for k, (p, _) in Y.items():
        joint[k] = np.array([0.0, B[k]]) if p == 1 else joint[p] + rot(ANGLES[p]) @ np.array([Y[p][1], B[k]])
    got = link_points(m, z[None, :], [k - 2 for k in Y] * 2, [(0.0, 0.0)] * 5 + [(0.1, -0.05)] * 5)[0]
    for i, k in enumerate(Y):
        assert np.allclose(got[i], joint[k], atol=1e-12)
        assert np.allclose(got[5 + i], joint[k] + rot(ANGLES[k]) @ np.array([0.1, -0.05]), atol=1e-12)
    geo = frame_geometry(m, z)
    (plate,) = geo.plates  # link 2 carries links 3 and 4: its own joint and theirs
    assert sorted(map(tuple, np.round(plate, 12))) == sorted(tuple(np.round(joint[k], 12)) for k in (2, 3, 4))
    # the two links on the ground have their pivots hatched; link 4's offset from link 2's end is a bar
    assert sorted(map(tuple, np.round(geo.fixed, 12))) == sorted(tuple(np.round(joint[k], 12)) for k in (2, 5))
    end2 = joint[2] + rot(ANGLES[2]) @ np.array([0.5, 0.0])
    assert any(np.allclose(a, end2) and np.allclose(b, joint[4]) for a, b in geo.bars)


# -- issue 29, item 18 ----------------------------------------------------------------------------------------
def test_the_films_strips_show_pressures_in_bar_and_no_power_of_ten_over_a_title():
    from grubler.views.animation import still_figure
    from test_report import overlapping_texts

    res = grubler.simulate("luffing-boom", t_end=1.0, dt_out=0.01)
    t = res.t
    signals = [("cylinder.pressure_a [Pa]", 1.0e7 + 2e6 * np.sin(t)),  # a hydraulic chamber, 100 bar
               ("cylinder.force [N]", 12000.0 + 0.5 * np.sin(t)),        # an offset matplotlib would print as +1.2e4
               ("volume [m3]", 1e-7 * (1 + np.sin(t))),                  # a power of ten: into the title
               ("theta2 [rad]", res["theta2"])]
    fig = still_figure(res.model, t, res.z, signals=signals)
    strips = fig.axes[1:]
    titles = [ax.get_title(loc="left") for ax in strips]
    assert titles[0] == "cylinder.pressure_a [bar]" and titles[1] == "cylinder.force [N]"
    assert titles[2].startswith("volume [m3], axis in units of")
    assert max(strips[0].get_lines()[0].get_ydata()) == pytest.approx(100 + 20 * np.sin(1.0))  # bar
    fig.canvas.draw()
    assert all(not ax.yaxis.get_offset_text().get_visible() or not ax.yaxis.get_offset_text().get_text()
               for ax in strips)
    assert overlapping_texts(fig) == []
    plt.close(fig)


def test_a_turning_crank_strip_is_wrapped_and_a_film_too_coarse_for_it_warns_naming_fps(tmp_path, capsys):
    from grubler.views.animation import sampling_warnings, still_figure

    res = grubler.simulate("fourbar-crank-rocker", t_end=6.0, dt_out=0.01)
    fig = still_figure(res.model, res.t, res.z, signals=[("theta2 [rad]", res["theta2"])])
    strip = fig.axes[1]
    assert "wrapped to ±π" in strip.get_title(loc="left")
    y = strip.get_lines()[0].get_ydata()
    assert np.nanmin(y) >= -np.pi - 0.05 and np.nanmax(y) <= np.pi + 0.05
    plt.close(fig)
    # the crank turns some 3.5 turns a second: 1/8 turn is 36 ms; 25 frames a second are 40 ms apart
    assert sampling_warnings(res.model, res.t, res.z, fps=50, speed=1.0) == []
    (warning,) = sampling_warnings(res.model, res.t, res.z, fps=5, speed=1.0)
    assert warning.startswith("--fps: theta2 turns") and "use --fps" in warning
    # through the command line: one line on stderr, the film still written
    out = tmp_path / "f.gif"
    assert main(["animate", "fourbar-crank-rocker", "--t-end", "2", "--fps", "5", "--out", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert out.exists() and any(e.startswith("warning: --fps: theta2 turns") for e in err)


def test_time_label_tells_frames_apart_on_a_short_run():
    # Andrews' squeezer: 0.03 s of motion filmed at speed 0.01 (0.4 ms a frame); to the hundredth every
    # label of a dozen frames running read "t = 0.02 s"
    from grubler.views.animation import time_label

    interval = 0.01 / 25
    labels = [time_label(k * interval, interval) for k in range(76)]
    assert len(set(labels)) == 76
    assert labels[38] == "t = 0.0152 s"
    # a film at the default speed keeps its two decimals
    assert time_label(1.2345, 1.0 / 25) == "t = 1.23 s"
