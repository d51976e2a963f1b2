"""The app's 3D view of the spatial presets (issue 34 item 4): the server's answer, and the page in Chromium."""

import base64
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from grubler.app.spatial_view import spatial_view
from grubler.mechanism.spatial_scene import load_spatial_scene, spatial_preset_names
from grubler.views.perspective import SpatialSketch


def test_the_view_sends_the_sketch_and_every_frame_of_the_run():
    view = spatial_view({"name": "rssp", "t_end": 0.3})
    scene = load_spatial_scene("rssp")
    res = scene.mechanism.simulate(scene.start(), 0.3, 0.02, tau=scene.tau())
    sketch = SpatialSketch(scene.mechanism, res.z)
    assert view["t"] == pytest.approx(res.t)
    np.testing.assert_allclose(np.array(view["frames"]), sketch.positions(res.y), atol=1e-6)
    n = len(view["links"])
    assert all(0 <= i < n and 0 <= j < n for i, j, *_ in view["segments"])
    assert {k for *_, k in view["markers"]} >= {"ball", "slide", "revolute", "pin"}
    assert view["grid"] and all(len(line) == 6 for line in view["grid"])


def test_the_app_answers_the_3d_actions_and_refuses_bad_requests(app):
    from test_app import call, post

    cat, _ = post(app, "spatial_catalog", {})
    assert [p["name"] for p in cat["presets"]] == spatial_preset_names()
    out, _ = post(app, "spatial", {"name": "spherical-fourbar", "t_end": 0.1})
    assert len(out["t"]) == 6
    out, _ = post(app, "spatial", {"name": "thesis-fourbar"})
    assert out["error"]["field"] == "name" and "not a spatial preset" in out["error"]["reason"]
    out, _ = post(app, "spatial", {"name": "rssr", "t_end": 1e6})
    assert out["error"]["field"] == "t_end"
    status, page, _ = call(app, "GET", "/static/view3d.html")
    assert status == 200 and "view3d.js" in page


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


@pytest.mark.slow
@pytest.mark.skipif(_chromium() is None, reason="no Chromium found (Debian: apt-get install chromium)")
def test_the_3d_view_draws_turns_and_zooms_in_a_browser(app, tmp_path):
    sync = pytest.importorskip("playwright.sync_api", reason="playwright is not installed").sync_playwright
    shots = Path(os.environ.get("GRUBLER_APP_SCREENSHOTS") or tmp_path)
    with sync() as p:
        browser = p.chromium.launch(executable_path=_chromium(), args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1100, "height": 860})
        errors = []
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(app.url)
        page.click("text=3D view")
        page.wait_for_selector("#preset3d option[value=rssr]", state="attached")
        page.select_option("#preset3d", "rssr")
        page.wait_for_selector("#notice3d:has-text('frames')")
        page.click("#play3d")  # paused: the pictures below differ by the camera alone

        def picture():
            data = page.evaluate("document.getElementById('view3d').toDataURL('image/png')")
            return base64.b64decode(data.split(",", 1)[1])

        def inked(png: bytes) -> int:
            from io import BytesIO

            from PIL import Image

            rgb = np.asarray(Image.open(BytesIO(png)).convert("RGB")).astype(int)
            alpha = np.asarray(Image.open(BytesIO(png)).convert("RGBA"))[..., 3]
            return int(((alpha > 0) & (np.abs(rgb - 255).sum(axis=2) > 60)).sum())

        first = picture()
        (shots / "view3d_rssr.png").write_bytes(first)
        assert inked(first) > 2000  # tubes and joints, not a blank canvas
        box = page.locator("#view3d").bounding_box()
        cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        page.mouse.move(cx, cy)
        page.mouse.down()
        page.mouse.move(cx + 120, cy + 40, steps=6)
        page.mouse.up()
        turned = picture()
        (shots / "view3d_rssr_turned.png").write_bytes(turned)
        assert turned != first and inked(turned) > 2000
        page.mouse.wheel(0, 400)  # farther: a smaller picture
        page.wait_for_timeout(100)
        assert inked(picture()) < inked(turned)
        page.click("#reset3d")
        assert picture() == first
        assert errors == []
        browser.close()


def _spatial_toml(name: str) -> str:
    from grubler.mechanism.spatial_scene import _folder

    return (_folder() / f"{name}.toml").read_text()


def test_a_spatial_scene_s_toml_opens_in_the_3d_view_and_a_bad_one_is_refused_naming_its_field(app, tmp_path):
    """Open TOML… of a file that says dimension = 3 (the planar page's, or the 3D view's own): the 3D view's run
    of that scene, as of its preset; a bad one refused where it is opened, naming the field."""
    from test_app import post

    text = _spatial_toml("rssr")
    out, _ = post(app, "spatial", {"toml": text, "t_end": 0.1})
    preset, _ = post(app, "spatial", {"name": "rssr", "t_end": 0.1})
    assert out["name"] == "rssr" and out["links"] == preset["links"] and out["frames"] == preset["frames"]
    # the planar page's Open TOML… and its folder's files: told to open it in the 3D view
    opened, _ = post(app, "parse", {"toml": text})
    assert opened == {"spatial": {"toml": text, "name": "rssr"}}
    (tmp_path / "mine.toml").write_text(text.replace('name = "rssr"', 'name = "mine"'))
    opened, _ = post(app, "open", {"file": "mine.toml"})
    assert opened["spatial"]["name"] == "mine"
    # refused, naming the field: an unknown key, a bad link's field, a planar scene sent to the 3D view
    for bad, field in [(text.replace("dimension = 3", "dimension = 3\nspin = 1"), "spin"),
                       (text.replace('joint = "R"', 'joint = "Q"', 1), "link[0].joint"),
                       ('[mechanism]\ntype = "four-bar"\n', "dimension")]:
        out, _ = post(app, "spatial", {"toml": bad})
        assert out["error"]["field"] == field, out["error"]
        if field != "dimension":
            out, _ = post(app, "parse", {"toml": bad})
            assert out["error"]["field"] == field, out["error"]


def test_grubler_app_of_a_spatial_file_starts_the_3d_view_with_it(tmp_path, capsys):
    import threading

    from test_app import post

    from grubler import cli
    from grubler.app.server import serve

    f = tmp_path / "arm.toml"
    f.write_text(_spatial_toml("spherical-fourbar"))
    started = []
    thread = threading.Thread(target=serve, args=(str(f),), kwargs={"port": 0, "open_browser": False,
                                                                    "root": tmp_path, "ready": started.append},
                              daemon=True)
    thread.start()
    for _ in range(200):
        if started:
            break
        thread.join(0.05)
    server = started[0]
    try:
        cat, _ = post(server, "spatial_catalog", {})
        assert cat["start"] == {"toml": f.read_text(), "name": "spherical-fourbar"}
        assert f"grubler app: {server.url}static/view3d.html" in capsys.readouterr().out
    finally:
        server.shutdown()
    # a bad one: refused before the server starts, naming the field (exit 2, one line)
    f.write_text(f.read_text().replace("dimension = 3", "dimension = 3\nspin = 1"))
    assert cli.run(["app", str(f), "--no-browser"]) == 2
    assert "spin" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.skipif(_chromium() is None, reason="no Chromium found (Debian: apt-get install chromium)")
def test_open_toml_of_a_spatial_file_on_the_planar_page_shows_it_in_the_3d_view(app, tmp_path):
    sync = pytest.importorskip("playwright.sync_api", reason="playwright is not installed").sync_playwright
    shots = Path(os.environ.get("GRUBLER_APP_SCREENSHOTS") or tmp_path)
    f = tmp_path / "bennett_mine.toml"
    f.write_text(_spatial_toml("bennett"))
    bad = tmp_path / "bad.toml"
    bad.write_text(_spatial_toml("rssr").replace("dimension = 3", "dimension = 3\nspin = 1"))
    with sync() as p:
        browser = p.chromium.launch(executable_path=_chromium(), args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1100, "height": 860})
        errors = []
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(app.url)
        page.wait_for_selector("#drawing circle.handle")
        # a bad spatial file: refused on the planar page, naming its field; the page stays
        page.set_input_files("#upload", str(bad))
        page.wait_for_selector("#notice.bad")
        assert "spin: unknown key" in page.inner_text("#notice") and "view3d" not in page.url
        page.set_input_files("#upload", str(f))
        page.wait_for_url("**/static/view3d.html")
        page.wait_for_selector("#notice3d:has-text('frames')")
        want = spatial_view({"name": "bennett", "t_end": 0.1})
        got = page.evaluate("() => ({ name: view.data.name, links: view.data.links, bodies: view.data.bodies })")
        assert got == {"name": "bennett", "links": want["links"], "bodies": want["bodies"]}
        page.click("#play3d")
        page.locator("#view3d").screenshot(path=str(shots / "view3d_opened_bennett.png"))
        # the 3D view's own Open TOML…: a bad one named, the scene shown kept
        page.set_input_files("#upload3d", str(bad))
        page.wait_for_selector("#notice3d.bad")
        assert page.inner_text("#notice3d").startswith("spin: unknown key")
        assert errors == []
        browser.close()
