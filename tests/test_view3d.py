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
