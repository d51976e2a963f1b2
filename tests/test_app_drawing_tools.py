"""The browser app as a drawing tool (issue 33 item 4), in a real browser (headless Chromium, Playwright):
undo and redo over every kind of edit, the links' names and lengths on the drawing, a grid that dragged
joints snap to, units chosen once (deg or rad, m or mm) and read everywhere on the page, and the servo run
played on the drawing.  One app server and one page serve the module's tests; each starts from a preset.

Screenshots land in ``$GRUBLER_APP_SCREENSHOTS`` when set (else the test's temporary folder).
"""

import json
import math
import os
from pathlib import Path

import pytest

from grubler.app import actions

from test_app_browser import (CHROMIUM, drag_handle, pick_preset, playwright_api, screen_of, servo_app,  # noqa: F401
                              watch_console)

pytestmark = [pytest.mark.skipif(CHROMIUM is None, reason="no Chromium found (Debian: apt-get install chromium)"),
              pytest.mark.slow]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    import threading

    from grubler.app.server import AppServer

    srv = AppServer("127.0.0.1", 0, tmp_path_factory.mktemp("app"))
    thread = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    yield srv
    srv.shutdown()
    srv.server_close()


@pytest.fixture(scope="module")
def browser():
    with playwright_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield b
        b.close()


@pytest.fixture(scope="module")
def shared(server, browser):
    """One page on the app for the module; each test picks its preset, and resets the units and tools."""
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = watch_console(page)
    page.goto(server.url)
    page.wait_for_selector("#drawing circle.handle")
    yield page, errors
    page.close()


@pytest.fixture
def page(shared):
    page, errors = shared
    page.evaluate("() => window.scrollTo(0, 0)")
    page.select_option("#unit-length", "m")
    page.select_option("#unit-angle", "deg")
    for box in ("#show-grid", "#show-dims"):
        page.uncheck(box)
    errors.clear()
    yield page
    assert errors == []


@pytest.fixture
def shots(tmp_path):
    folder = Path(os.environ.get("GRUBLER_APP_SCREENSHOTS") or tmp_path / "shots")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def scene(page) -> dict:
    return page.evaluate("() => state.scene")


def settled(page, test: str) -> None:
    """Wait until ``test`` (a JS expression) holds and no history step, edit or drag is under way."""
    page.wait_for_function(f"() => !sceneHistory.pending && !state.pendingEdits && !state.inflight && ({test})")


def undo(page, keys: bool = True) -> None:
    if keys:
        page.evaluate("() => document.activeElement && document.activeElement.blur()")
        page.keyboard.press("Control+z")
    else:
        page.click("#undo")


def redo(page) -> None:
    page.evaluate("() => document.activeElement && document.activeElement.blur()")
    page.keyboard.press("Control+Shift+z")


def test_undo_and_redo_step_over_drags_form_edits_presets_and_opened_files(page, shots, tmp_path):
    pick_preset(page, "fourbar-crank-rocker")
    start = scene(page)
    # a drag, undone with Ctrl+Z and redone with Ctrl+Shift+Z
    drag_handle(page, "O4", 1.4, 0.0)
    assert page.input_value('[data-key="mechanism.ground"]') == "1.4"
    undo(page)
    settled(page, """document.querySelector('[data-key="mechanism.ground"]').value === '1'""")
    assert scene(page) == start
    assert page.evaluate("() => state.analysis.frame.fixed[1][0]") == pytest.approx(1.0)  # the drawing too
    redo(page)
    settled(page, """document.querySelector('[data-key="mechanism.ground"]').value === '1.4'""")
    assert scene(page)["mechanism"]["ground"] == 1.4
    # a form edit, undone with the button
    page.fill('[data-key="mechanism.coupler"]', "0.95")
    page.press('[data-key="mechanism.coupler"]', "Enter")
    settled(page, "state.scene.mechanism.coupler === 0.95")
    undo(page, keys=False)
    settled(page, """document.querySelector('[data-key="mechanism.coupler"]').value === '0.9'""")
    assert scene(page)["mechanism"] == {**start["mechanism"], "ground": 1.4}
    # another preset: undone, the four-bar is back with its menus
    pick_preset(page, "watt-ii")
    undo(page)
    settled(page, "state.scene.name === 'fourbar-crank-rocker' && state.analysis.scene === state.scene")
    assert page.input_value("#preset") == "fourbar-crank-rocker"
    assert page.inner_text("#type >> option:checked") == "four-bar"
    assert page.inner_text("#kind").startswith("four-bar")
    # an opened TOML file: undone too
    f = tmp_path / "oldham.toml"
    f.write_text(actions.scene_toml(actions.preset_data("oldham")))
    page.set_input_files("#upload", str(f))
    settled(page, "state.scene.name === 'oldham' && state.analysis.scene === state.scene")
    undo(page)
    settled(page, "state.scene.name === 'fourbar-crank-rocker' && state.analysis.scene === state.scene")
    undo(page)  # the coupler's edit was undone already: before it, the drag
    undo(page)
    settled(page, """document.querySelector('[data-key="mechanism.ground"]').value === '1'""")
    assert scene(page) == start
    assert page.is_enabled("#redo")
    page.screenshot(path=str(shots / "20-undone.png"))
    # the history is bounded: it keeps the last HISTORY_LIMIT scenes
    limit = page.evaluate("() => HISTORY_LIMIT")
    page.evaluate("(n) => { for (let k = 0; k < n + 20; k++) noteScene({ ...state.scene, note: k }); }", limit)
    assert page.evaluate("() => sceneHistory.past.length") == limit


def test_two_fields_edited_before_the_first_answer_both_hold(page):
    """An edit goes on the scene the one before it answered with: the page used to send the second field on
    the scene without the first, and the first's answer, coming later, undid the second (or the other way)."""
    pick_preset(page, "fourbar-crank-rocker")
    # the first edit's answer held back half a second, as a loaded server may
    page.evaluate("""() => { const f = window.fetch; let first = true; window.realFetch = f;
        window.fetch = async (...a) => { const r = await f(...a);
            if (first && String(a[0]).endsWith('/api/edit')) { first = false; await new Promise((ok) => setTimeout(ok, 500)); }
            return r; }; }""")
    try:
        page.fill('[data-key="mechanism.ground"]', "1.05")
        page.press('[data-key="mechanism.ground"]', "Enter")
        page.fill('[data-key="mechanism.coupler"]', "0.95")
        page.press('[data-key="mechanism.coupler"]', "Enter")
        settled(page, "state.scene.mechanism.coupler === 0.95")
        assert scene(page)["mechanism"]["ground"] == 1.05
        assert page.input_value('[data-key="mechanism.ground"]') == "1.05"
    finally:
        page.evaluate("() => { window.fetch = window.realFetch; }")


def test_units_chosen_once_read_in_the_form_graphs_facts_and_arrows(page, shots):
    pick_preset(page, "fourbar-crank-rocker")
    page.check('#analysis-layer input[data-kind="v"]')
    page.wait_for_selector(".analysis .arrow.vel")
    assert page.input_value('[data-key="mechanism.crank_angle"]') == "30"
    page.select_option("#unit-length", "mm")
    page.select_option("#unit-angle", "rad")
    # the form: values and their units' words
    assert page.input_value('[data-key="mechanism.ground"]') == "1000"
    assert page.input_value('[data-key="mechanism.crank"]') == "300"
    assert page.inner_text('label[for="f-mechanism_ground"] .unit') == "(mm)"
    assert page.input_value('[data-key="mechanism.crank_angle"]') == "0.523599"  # six digits (pi/6)
    assert page.inner_text('label[for="f-mechanism_crank_angle"] .unit') == "(rad)"
    # the facts and the arrows' values
    assert "s + l = 1300 mm" in page.inner_text("#grashof")
    assert "theta3 0.6" in page.inner_text("#branch") and "deg" not in page.inner_text("#branch")  # 37.6 deg
    assert page.text_content(".analysis .alabel.vel >> nth=0").endswith(" mm/s")
    assert "rad" in page.text_content(".analysis .alabel.mu")
    # a value typed in mm reaches the scene in m, an angle in rad as rad
    page.fill('[data-key="mechanism.ground"]', "1050")
    page.press('[data-key="mechanism.ground"]', "Enter")
    settled(page, "state.scene.mechanism.ground === 1.05")
    page.fill('[data-key="mechanism.crank_angle"]', "0.5")
    page.press('[data-key="mechanism.crank_angle"]', "Enter")
    settled(page, "state.scene.mechanism.crank_angle === 0.5")
    page.select_option("#unit-angle", "deg")
    page.fill('[data-key="mechanism.crank_angle"]', "45")
    page.press('[data-key="mechanism.crank_angle"]', "Enter")
    settled(page, "state.scene.mechanism.crank_angle === '45 deg'")
    page.select_option("#unit-angle", "rad")
    # the graphs: the drive angle in rad, a length in mm, their axes saying so and their ticks reading so
    assert page.evaluate("() => state.scene.mechanism.ground") == 1.05
    page.fill("#t_end", "0.5")
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    assert page.text_content("#panels svg >> nth=0 >> text.ylabel") == "theta2, rad"
    page.click("#add-axes")
    page.select_option(".panel >> nth=2 >> select", "tip_x")
    page.wait_for_selector("#panels svg >> nth=2 >> text.ylabel")
    assert page.evaluate("() => state.runScene.mechanism.ground") == 1.05
    assert page.text_content("#panels svg >> nth=2 >> text.ylabel") == "tip_x, mm"
    ticks = [float(t) for t in page.eval_on_selector_all("#panels svg >> nth=2 >> .ytick",
                                                         "(gs) => gs.map((g) => g.textContent)")]
    assert ticks and all(1000 < t < 1100 for t in ticks)  # the tip sits on the rocker's pivot, 1050 mm out
    page.screenshot(path=str(shots / "21-units-mm-rad.png"))  # (a full-page one stalls a shared page's painting)
    page.locator("#graphs").screenshot(path=str(shots / "21-units-mm-rad-graphs.png"))
    # back to m and deg: the same graph reads in m
    page.select_option("#unit-length", "m")
    assert page.text_content("#panels svg >> nth=2 >> text.ylabel") == "tip_x, m"
    ticks = [float(t) for t in page.eval_on_selector_all("#panels svg >> nth=2 >> .ytick",
                                                         "(gs) => gs.map((g) => g.textContent)")]
    assert ticks and max(ticks) < 3  # about 1.05 (a flat line's axis spans one unit either way)
    page.click("#edit-mode")
    page.uncheck('#analysis-layer input[data-kind="v"]')
    # the server's messages read their lengths in the page's unit too
    page.select_option("#unit-length", "mm")
    page.fill('[data-key="mechanism.ground"]', "5000")
    page.press('[data-key="mechanism.ground"]', "Enter")
    page.wait_for_selector("#problem:not([hidden])")
    assert "the longest link (5000 mm)" in page.inner_text("#problem")


def test_the_grid_snaps_a_dropped_joint_and_the_links_carry_their_names_and_lengths(page, shots):
    pick_preset(page, "fourbar-crank-rocker")
    page.check("#show-dims")
    dims = page.eval_on_selector_all("#drawing text.dim", "(ts) => ts.map((t) => t.textContent)")
    assert dims == ["ground 1 m", "link2 0.3 m", "link3 0.9 m", "link4 0.7 m"]
    page.select_option("#unit-length", "mm")
    assert page.text_content('#drawing text.dim[data-link="link3"]') == "link3 900 mm"
    page.screenshot(path=str(shots / "22-dimensions-mm.png"))
    page.select_option("#unit-length", "m")
    # a six-bar's pivot dropped off the grid lands on it
    page.select_option("#type", label="stephenson-iii")
    page.wait_for_function("() => document.querySelector('#kind').textContent.startsWith('Stephenson III')")
    page.check("#show-grid")
    pitch = page.evaluate("() => gridPitch()")
    assert page.inner_text("#grid-pitch") == f"pitch {pitch:g} m"
    assert page.locator("#drawing .grid line").count() > 10
    drag_handle(page, "output_pivot", 0.437, -0.061)
    x, y = json.loads(page.input_value('[data-key="mechanism.output_pivot"]'))
    assert (x, y) == (pytest.approx(round(0.437 / pitch) * pitch, abs=1e-9),
                      pytest.approx(round(-0.061 / pitch) * pitch, abs=1e-9))
    assert abs(x - 0.437) + abs(y + 0.061) > 1e-3  # not where the mouse let go
    page.screenshot(path=str(shots / "23-grid-snapped.png"))


def test_the_servo_run_plays_on_the_drawing_scrubbed_and_played(servo_app, browser, shots):
    url, _ = servo_app
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = watch_console(page)
    page.goto(url)
    page.wait_for_selector("#drawing circle.handle")
    pick_preset(page, "thesis-fourbar")
    assert page.is_hidden("#servo-player")
    page.fill('#servo-form [data-key="t_end"]', "1")
    page.click("#servo-run")
    page.wait_for_selector("#servo-player:not([hidden])", timeout=120_000)
    # scrubbed to the middle: the crank drawn at the response's angle then, the graphs' cursors there
    end = page.evaluate("() => state.servo.t[state.servo.t.length - 1]")
    page.evaluate("""(t) => { const s = document.querySelector('#servo-scrub'); s.value = String(t);
        s.dispatchEvent(new Event('input')); }""", end / 2)
    assert page.inner_text("#servo-clock") == f"t = {end / 2:.3f} s"
    crank, response = page.evaluate("""() => {
        const b = document.querySelector('#drawing line.bar-link');
        const [x1, y1, x2, y2] = ['x1', 'y1', 'x2', 'y2'].map((k) => Number(b.getAttribute(k)));
        const v = state.servo, i = search(v.frame_t, state.servoT), c = v.columns.find((c) => c.name === 'response');
        return [Math.atan2(y2 - y1, x2 - x1), c.si[search(v.t, v.frame_t[i])]]; }""")
    assert math.remainder(crank - response, 2 * math.pi) == pytest.approx(0, abs=1e-3)
    start = page.evaluate("() => state.servo.frames[0].bars[0]")
    now = page.evaluate("() => state.servo.frames[search(state.servo.frame_t, state.servoT)].bars[0]")
    assert now != pytest.approx(start, abs=1e-3)  # it moved
    cursor = page.get_attribute("#servo-plots svg >> nth=0 >> line.cursor", "x1")
    page.locator("#servo").screenshot(path=str(shots / "24-servo-scrubbed.png"))
    page.locator("#stage").screenshot(path=str(shots / "25-servo-on-drawing.png"))
    # played: the time runs on to the end, the cursor with it
    page.click("#servo-play")
    page.wait_for_function("(end) => state.servoT >= end", arg=end, timeout=20_000)
    assert float(page.get_attribute("#servo-plots svg >> nth=0 >> line.cursor", "x1")) > float(cursor)
    # Edit: back to the scene with its handles
    page.click("#edit-mode")
    page.wait_for_selector("#drawing circle.handle")
    assert errors == []
    page.close()
