"""The browser app in a real browser: headless Chromium driven by Playwright, one user journey.

The journey: open the app, pick a preset, drag the rocker's ground pivot past
the Grashof limit (and past where the loop closes) and read the message,
mend a value in the form, simulate, pick a graph, export the scene and the
run; a shared link reopens the scene.  Any console error fails the test.
Screenshots of each stage land in the test's temporary folder (and in
``$GRUBLER_APP_SCREENSHOTS`` when set, to look at).

Chromium comes from the system (Debian's ``chromium`` package, which ``.ci/run``
installs); Playwright never downloads a browser here.
"""

import os
import shutil
import tomllib
from pathlib import Path

import pytest

from grubler.app import actions


playwright_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install -e .[test])")


def chromium_path() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return "/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None


CHROMIUM = chromium_path()
pytestmark = [pytest.mark.skipif(CHROMIUM is None, reason="no Chromium found (Debian: apt-get install chromium)"),
              pytest.mark.slow]  # a browser, and the servo's FMUs


@pytest.fixture
def browser():
    with playwright_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield b
        b.close()


@pytest.fixture
def shots(tmp_path):
    folder = Path(os.environ.get("GRUBLER_APP_SCREENSHOTS") or tmp_path / "shots")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def watch_console(page) -> list:
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    return errors


def screen_of(page, x: float, y: float) -> list:
    """Where the world point (x, y), m, of the drawing is on the screen, px."""
    return page.evaluate("""([x, y]) => {
        const p = new DOMPoint(x, y).matrixTransform(document.querySelector('#drawing g').getScreenCTM());
        return [p.x, p.y];
    }""", [x, y])


def drag_handle(page, handle: str, x: float, y: float) -> None:
    """Drag a handle of the drawing to world point (x, y), m, with the mouse, in steps."""
    start = page.locator(f'circle.handle[data-handle="{handle}"]').bounding_box()
    target = screen_of(page, x, y)
    page.mouse.move(start["x"] + start["width"] / 2, start["y"] + start["height"] / 2)
    page.mouse.down()
    for k in range(1, 9):
        f = k / 8
        page.mouse.move(start["x"] + start["width"] / 2 + f * (target[0] - start["x"] - start["width"] / 2),
                        start["y"] + start["height"] / 2 + f * (target[1] - start["y"] - start["height"] / 2))
        page.wait_for_timeout(30)
    page.mouse.up()
    # the last move's answer is on the page once no request is in flight and the drag has settled
    page.wait_for_function("""() => window.grublerStats.drag.length > 0 && !state.inflight && !state.queued
        && !state.dragging && !state.settling""")


def test_a_user_journey_from_preset_to_exports(app, browser, shots, tmp_path):
    page = browser.new_page(viewport={"width": 1400, "height": 1000}, accept_downloads=True)
    errors = watch_console(page)
    page.goto(app.url)
    page.wait_for_selector("#drawing circle.handle")

    # pick a preset
    page.select_option("#preset", "fourbar-crank-rocker")
    page.wait_for_function("() => document.querySelector('#grashof').textContent.startsWith('crank-rocker')")
    assert page.inner_text("#mobility") == "1"
    assert "one of 2 found with theta2 held" in page.inner_text("#branch")
    # a double click on the rocker traces that point of it
    page.mouse.dblclick(*screen_of(page, 1.0, 0.35))
    page.wait_for_function("() => document.querySelector('#trace').value.startsWith('link4:')")
    page.screenshot(path=str(shots / "1-preset.png"))

    # drag the rocker's ground pivot past the Grashof limit: a triple-rocker, still closing
    drag_handle(page, "O4", 1.4, 0.0)
    page.wait_for_function("() => document.querySelector('#grashof').textContent.startsWith('triple-rocker')")
    assert page.input_value('[data-key="mechanism.ground"]') == "1.4"
    page.screenshot(path=str(shots / "2-triple-rocker.png"))
    # and further, where the loop cannot close: the words of `grubler info`
    drag_handle(page, "O4", 2.1, 0.0)
    page.wait_for_selector("#problem:not([hidden])")
    problem = page.inner_text("#problem")
    assert "the loop cannot be closed" in problem and "the longest link (2.1 m)" in problem
    page.screenshot(path=str(shots / "3-cannot-close.png"))

    # a bad value in the form: its one line sits next to the field
    page.fill('[data-key="mechanism.ground"]', "-1")
    page.press('[data-key="mechanism.ground"]', "Enter")
    page.wait_for_selector('[data-err="mechanism.ground"]:has-text("length must be positive")')
    page.fill('[data-key="mechanism.ground"]', "1.05")
    page.press('[data-key="mechanism.ground"]', "Enter")
    # the answer to 1.05: the loop closes again and the field's message is gone
    page.wait_for_function("""() => document.querySelector('#problem').hidden &&
        document.querySelector('[data-err="mechanism.ground"]').textContent === '' &&
        document.querySelector('#grashof').textContent.startsWith('crank-rocker')""")

    # simulate: the animation plays, the graphs come
    page.fill("#t_end", "3")
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    assert "points to t = 3 s" in page.inner_text("#run-status")
    page.select_option(".panel >> nth=0 >> select", "tau_drive")
    page.wait_for_selector('.chip:has-text("drive torque (tau_drive), N m")')
    page.wait_for_timeout(400)
    page.screenshot(path=str(shots / "4-simulated.png"), full_page=True)
    # zoom: drag across a graph from a quarter to a half of its width; every graph follows
    graph = page.locator("#panels svg >> nth=1")
    graph.scroll_into_view_if_needed()
    box = graph.bounding_box()
    page.mouse.move(box["x"] + 0.25 * box["width"], box["y"] + 100)
    page.mouse.down()
    page.mouse.move(box["x"] + 0.5 * box["width"], box["y"] + 100, steps=5)
    page.mouse.up()
    page.wait_for_function("() => [...document.querySelectorAll('#panels svg')].every((s) => +s.dataset.x1 < 2)")
    span = page.eval_on_selector("#panels svg", "(s) => [+s.dataset.x0, +s.dataset.x1]")
    assert 0.5 < span[0] < span[1] < 1.6
    page.dblclick("#panels svg >> nth=1")
    page.wait_for_function("() => +document.querySelector('#panels svg').dataset.x1 > 2.99")
    page.click("#play")  # pause, then scrub to the end
    page.eval_on_selector("#scrub", "(e) => { e.value = e.max; e.dispatchEvent(new Event('input')); }")
    assert page.inner_text("#clock") == "t = 3.000 s"

    # exports: the scene as TOML (the CLI's format), the run as CSV, the graphs as PNG
    with page.expect_download() as dl:
        page.click("#download")
    scene = tomllib.loads(Path(dl.value.path()).read_text())
    assert scene["mechanism"]["ground"] == 1.05
    with page.expect_download() as dl:
        page.click("#csv")
    assert Path(dl.value.path()).read_text().startswith("t [s],B1 [m],theta2 [rad],")
    with page.expect_download() as dl:
        page.click("#png")
    assert Path(dl.value.path()).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    # saved into the app's folder, under the scene's name, as the CLI reads it
    page.click("#save")
    page.wait_for_selector('#notice:has-text("saved fourbar-crank-rocker.toml")')
    from grubler import load_scene

    assert load_scene(str(tmp_path / "fourbar-crank-rocker.toml")).mechanism.closures[0].to_point == (1.05, 0.0)

    # the URL holds the scene: a second page opened on it shows the same scene
    other = browser.new_page()
    errors += watch_console(other)
    other.goto(page.url)
    other.wait_for_selector('[data-key="mechanism.ground"]')
    assert other.input_value('[data-key="mechanism.ground"]') == "1.05"
    assert errors == []


def test_a_six_bar_by_type_and_a_refused_link(app, browser, shots):
    page, errors = open_app(browser, app.url)
    page.select_option("#type", label="stephenson-iii")
    page.wait_for_function("() => document.querySelector('#kind').textContent.startsWith('Stephenson III')")
    assert page.inner_text("#branch").endswith("one of 4 found with theta2 held")
    drag_handle(page, "output_pivot", 0.45, -0.05)
    assert page.input_value('[data-key="mechanism.output_pivot"]') == "[0.45, -0.05]"
    # the other branch of the second loop, from the field's menu
    page.select_option('[data-key="mechanism.branch2"]', "crossed")
    page.wait_for_function("""() => document.querySelector('[data-key="mechanism.branch2"]').value === 'crossed'
        && state.scene.mechanism.branch2 === 'crossed'""")
    assert page.is_hidden("#problem")
    page.screenshot(path=str(shots / "5-stephenson-iii.png"))
    # a link whose scene is not a scene: refused where it is opened, in one line
    page.goto(app.url + "#scene=eyJsaW5rMiI6IHsiYSI6ICJ4In19")  # {"link2": {"a": "x"}}
    page.reload()
    page.wait_for_selector('[data-err="link2.a"]:not(:empty)')
    assert "link2.a" not in page.inner_text("#error")
    assert errors == []


def open_app(browser, url: str, **options):
    """A new page on the app, its drawing there, and the console errors it will collect."""
    page = browser.new_page(viewport={"width": 1400, "height": 1000}, **options)
    errors = watch_console(page)
    page.goto(url)
    page.wait_for_selector("#drawing circle.handle")
    return page, errors


def pick_preset(page, name: str) -> None:
    """Pick a preset from the menu and wait until its drawing is on the page (not the one before, even when
    that was the same preset's: the page, run boxes and servo form, is the new scene's once it is drawn)."""
    page.evaluate("() => { window.pickedFrom = state.analysis; }")
    page.select_option("#preset", name)
    page.wait_for_function("""(name) => state.analysis !== window.pickedFrom && state.scene && state.scene.name === name
        && state.analysis.scene === state.scene""", arg=name)


def handle_at(page, handle: str) -> list:
    return page.evaluate(f"() => state.analysis.handles.find((h) => h.id === {handle!r}).xy")


def curve_of(page) -> str:
    return page.get_attribute("#drawing polyline.curve", "points") or ""


# the joints the four-link inversions and a six-bar gained: (preset or type, handle, where to, what the
# feedback then reads: the #id of the line and the text it holds)
NEW_HANDLES = [
    ("scotch-yoke", "A", (0.05, 0.11), "#kind", "Scotch yoke"),
    ("oldham", "shaft2", (0.03, 0.0), "#mobility", "1"),
    ("double-slider", "block2", (0.3, 0.45), "#branch", "one of 1 found with theta3 held"),
    ("conchoidal", "block", (0.35, 0.6), "#branch", "one of 1 found with theta2 held"),
    ("watt-ii", "B", (0.37, 0.26), "#kind", "Watt II six-bar"),
    ("stephenson-ii", "Q", (-0.08, 0.3), "#branch", "one of 2 found with theta2 held"),
    ("watt-i", "O2", (-0.03, 0.02), "#kind", "Watt I six-bar"),
]


@pytest.mark.parametrize("preset, handle, to, line, reads", NEW_HANDLES, ids=[f"{p}-{h}" for p, h, *_ in NEW_HANDLES])
def test_dragging_each_new_kind_of_joint(app, browser, shots, preset, handle, to, line, reads):
    page, errors = open_app(browser, app.url)
    pick_preset(page, preset)
    before = curve_of(page)
    assert before, "a coupler curve to begin with"
    target = screen_of(page, *to)  # where the mouse will leave the handle, on the screen
    pivot = screen_of(page, *handle_at(page, "rocker_pivot")) if handle == "O2" else None
    drag_handle(page, handle, *to)
    assert reads in page.inner_text(line)
    assert page.is_hidden("#problem") and page.inner_text("#error") == ""
    # the handle sits where the mouse left it (a block on its slide as near as the slide lets it); the
    # origin's answer is in the moved origin's coordinates, and the view moved with them: on the screen, the
    # origin is where the mouse left it and every other joint where it was
    at = handle_at(page, handle)
    if handle == "O2":
        assert at == [0.0, 0.0] and page.evaluate("() => state.analysis.shift") is None
        for other, (x, y) in [(handle, target), ("rocker_pivot", pivot)]:
            box = page.locator(f'circle.handle[data-handle="{other}"]').bounding_box()
            assert abs(box["x"] + box["width"] / 2 - x) < 1 and abs(box["y"] + box["height"] / 2 - y) < 1, other
        to = at
    assert abs(at[0] - to[0]) < 2e-3 and (handle == "shaft2" or abs(at[1] - to[1]) < 2e-3), at
    assert curve_of(page) != before  # the coupler curve was drawn again, for the new dimensions
    page.screenshot(path=str(shots / f"7-drag-{preset}-{handle}.png"))
    assert errors == []


def test_a_six_bar_pivot_dragged_beyond_its_links_reads_where_the_loop_opens(app, browser, shots):
    page, errors = open_app(browser, app.url)
    pick_preset(page, "stephenson-i")
    drag_handle(page, "E", 0.1, 0.12)  # a joint of the rocker's triangle: the loop still closes
    assert page.is_hidden("#problem") and "one of" in page.inner_text("#branch")
    drag_handle(page, "rocker_pivot", 0.9, 0.0)
    page.wait_for_selector("#problem:not([hidden])")
    problem = page.inner_text("#problem")
    assert problem.startswith("mechanism.input_angle: loop 1 (crank, coupler, rocker): triangle A-B-O4: its ends are")
    assert page.inner_text("#mobility") == "1" and page.inner_text("#branch") == "the loop does not close"
    assert page.locator("#drawing g.open").count() == 1  # the sketch drawn open
    page.screenshot(path=str(shots / "8-stephenson-i-open.png"))
    drag_handle(page, "rocker_pivot", 0.3, 0.0)  # and back: it closes again
    page.wait_for_function("() => document.querySelector('#problem').hidden")
    assert errors == []


def test_a_page_whose_session_the_app_forgot_is_told_and_forgets_its_run(app, browser, shots):
    import http.client

    app.max_sessions = 1  # room for one page's session: any other client's pushes this page's out
    page, errors = open_app(browser, app.url, accept_downloads=True)
    pick_preset(page, "fourbar-crank-rocker")
    page.fill("#t_end", "1")
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    assert not page.eval_on_selector("#csv", "(a) => a.classList.contains('disabled')")
    other = http.client.HTTPConnection("127.0.0.1", app.server_address[1], timeout=60)
    other.request("GET", "/", headers={"Host": f"127.0.0.1:{app.server_address[1]}"})
    assert other.getresponse().status == 200  # a new session, in the only place there is
    # the page's next request (a value mended in the form) learns it, says so, and starts without a run
    page.fill('[data-key="mechanism.crank"]', "0.31")
    page.press('[data-key="mechanism.crank"]', "Enter")
    page.wait_for_selector("#notice.bad")
    assert page.inner_text("#notice").startswith("the app forgot this page's session to make room")
    assert page.eval_on_selector("#csv", "(a) => a.classList.contains('disabled')")
    assert page.is_disabled("#play") and page.locator("#panels svg").count() == 0
    page.screenshot(path=str(shots / "10-session-forgotten.png"))
    # and a new run is kept again: its CSV downloads
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    with page.expect_download() as dl:
        page.click("#csv")
    assert Path(dl.value.path()).read_text().startswith("t [s],")
    assert errors == []


@pytest.fixture(scope="module")
def servo_app(tmp_path_factory):
    """``grubler app`` in a process of its own, started in a folder whose dist/ holds the servo's FMUs.

    (pythonfmu FMUs that ran numpy can corrupt the heap at interpreter exit: the CLI
    leaves without the teardown, and this test's own process never loads them.)
    """
    import subprocess
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import builds

    folder = tmp_path_factory.mktemp("app")
    builds.dist(folder / "dist", ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory", "HydraulicCylinder"])
    proc = subprocess.Popen([sys.executable, "-m", "grubler.cli", "app", "--no-browser", "--port", "0"], cwd=folder,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert line.startswith("grubler app: http://127.0.0.1:"), line + proc.stderr.read()
    yield line.split()[2], folder
    proc.send_signal(__import__("signal").SIGINT)
    assert proc.wait(30) == 130


def test_servo_tuning_sizing_and_the_system_export(servo_app, browser, shots):
    url, folder = servo_app
    page = browser.new_page(viewport={"width": 1400, "height": 1000}, accept_downloads=True)
    errors = watch_console(page)
    page.goto(url)
    page.wait_for_selector("#drawing circle.handle")
    page.select_option("#preset", "thesis-fourbar")
    page.wait_for_function("() => document.querySelector('#kind').textContent.startsWith('four-bar')")
    page.fill('#servo-form [data-key="t_end"]', "2")
    page.click("#servo-run")
    page.wait_for_selector("#servo-plots svg path", timeout=120_000)
    first = page.inner_text("#servo-status")
    assert first.startswith("2 s at 0.001 s steps") and "(limit 10 A)" in first and "(supply 48 V)" in first
    # a softer gain: the response is re-run at once, and follows worse
    page.fill('#servo-form [data-key="K"]', "60")
    page.press('#servo-form [data-key="K"]', "Enter")
    page.wait_for_function("() => (window.grublerStats.servo || []).length >= 2", timeout=120_000)
    error = lambda text: float(text.split("tracking error up to ")[1].split(" deg")[0])  # noqa: E731
    assert error(page.inner_text("#servo-status")) > error(first)
    page.click("#sizing-run")
    page.wait_for_selector("#sizing td", timeout=120_000)
    assert "combinations fit, best first" in page.inner_text("#sizing-status")
    assert page.inner_text("#sizing tr:nth-child(2) td:first-child") == "1"
    page.locator("#servo").screenshot(path=str(shots / "6-servo.png"))
    with page.expect_download(timeout=120_000) as dl:
        page.select_option("#export", "ssp")
    assert dl.value.suggested_filename == "thesis_fourbar_servo.ssp"
    import zipfile

    assert "resources/PID.fmu" in zipfile.ZipFile(dl.value.path()).namelist()
    assert errors == []


def test_the_analysis_layer_draws_arrows_centres_and_angles_live_and_at_a_runs_instant(app, browser, shots):
    page, errors = open_app(browser, app.url)
    page.select_option("#preset", "fourbar-crank-rocker")
    page.wait_for_function("() => document.querySelector('#grashof').textContent.startsWith('crank-rocker')")
    assert page.locator(".analysis").count() == 0  # off until asked for
    for kind in ("v", "ic", "f"):
        page.check(f'#analysis-layer input[data-kind="{kind}"]')
    page.wait_for_function("() => document.querySelectorAll('.analysis .arrow.force').length === 4")
    a = page.evaluate("() => state.analysis.analysis")
    # an arrow per point, drawn along the point's velocity (the page's y is flipped inside the drawing)
    assert page.locator(".analysis .arrow.vel").count() == len([p for p in a["points"] if any(p["v"])])
    pin = next(p for p in a["points"] if p["name"] == "23")
    line = page.evaluate("""(at) => [...document.querySelectorAll('.analysis .arrow.vel line')]
        .map((l) => ['x1', 'y1', 'x2', 'y2'].map((k) => +l.getAttribute(k)))
        .find((l) => Math.abs(l[0] - at[0]) < 1e-9 && Math.abs(l[1] - at[1]) < 1e-9)""", pin["at"])
    d = (line[2] - line[0], line[3] - line[1])
    assert abs(d[0] * pin["v"][1] - d[1] * pin["v"][0]) < 1e-6 * abs(d[0] * pin["v"][0] + d[1] * pin["v"][1])
    labels = page.eval_on_selector_all(".analysis .alabel.ic", "(ts) => ts.map((t) => t.textContent)")
    assert {"I12", "I14", "I23", "I34"} <= {t.split(" ")[0] for t in labels} and len(labels) == 6
    assert page.locator(".analysis .mark.toggle").count() == 2
    facts = page.inner_text("#analysis-facts")
    assert "mechanical advantage (link4 on theta2)" in facts and "transmission angle μ34" in facts
    assert "least" in facts and "toggles at theta2" in facts
    page.screenshot(path=str(shots / "11-analysis-fourbar.png"))
    page.check('#analysis-layer input[data-kind="a"]')  # accelerations too: one more arrow per accelerating point
    page.wait_for_function("() => document.querySelectorAll('.analysis .arrow.acc').length > 0")
    accelerating = len([p for p in page.evaluate("() => state.analysis.analysis.points") if any(p["a"])])
    assert page.locator(".analysis .arrow.acc").count() == accelerating
    assert "m/s²" in page.text_content(".analysis .alabel.acc >> nth=0")

    # live while dragging: the centre of rocker and ground follows the pivot
    drag_handle(page, "O4", 1.2, 0.0)
    i14 = page.evaluate("() => state.analysis.analysis.centres.find((c) => c.label === 'I14').at")
    assert i14 == pytest.approx([1.2, 0.0], abs=1e-6)
    page.screenshot(path=str(shots / "12-analysis-dragged.png"))

    # a six-bar: fifteen centres, those out of view on the view's edge
    page.select_option("#preset", "watt-ii")
    page.wait_for_function("() => document.querySelectorAll('.analysis .alabel.ic').length === 15")
    assert page.locator(".analysis .alabel.mu").count() >= 2
    page.screenshot(path=str(shots / "13-analysis-watt-ii.png"))

    # a run's instant, paused and scrubbed: the run's state and efforts
    page.fill("#t_end", "1")
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    page.click("#play")  # pause
    page.eval_on_selector("#scrub", "(e) => { e.value = 0.5; e.dispatchEvent(new Event('input')); }")
    page.wait_for_function("() => document.querySelector('#analysis-facts').textContent"
                           ".startsWith('the run at t = 0.5')")
    page.wait_for_function("() => document.querySelectorAll('.analysis .arrow.force').length === 7")
    page.screenshot(path=str(shots / "14-analysis-run-instant.png"))
# -- issue 33: the numbers the page shows, and the cylinder presets ------------------------------------------
def tick_labels(page, values) -> list:
    """The y-axis tick labels (text, pixel height) of a graph the page plots of ``values`` over one second."""
    return page.evaluate("""(values) => {
        const svg = document.createElementNS(SVG, "svg");
        svg.style.width = "800px";
        document.body.appendChild(svg);
        const t = values.map((_, i) => i / (values.length - 1));
        plot(svg, t, [{ name: "v", label: "v (v), J", unit: "J", values: Float32Array.from(values) }], 0, 1);
        // the labels left of the plot, right-aligned to it: the value axis's (its name is turned, and centred)
        const out = [...svg.querySelectorAll("text[text-anchor=end]")].filter((e) => +e.getAttribute("x") < 120)
            .map((e) => [e.textContent, +e.getAttribute("y")]);
        svg.remove();
        return out;
    }""", values)


SCALES = [1e-6, 3e-5, 1e-3, 0.2, 1.0, 7.5, 80.0, 999.0, 1000.0, 7500.0, 8000.0, 2e4, 3e5, 1e6, 4e6]


def test_tick_labels_read_the_values_they_mark_from_a_millionth_to_a_million(app, browser):
    """8000 J read '8' and 7500 '75' (trailing zeros of whole numbers dropped): every label now parses back to
    the value at its height, for signals from 1e-6 to 1e6 in size, negative ones too, near zero and offset."""
    page, errors = open_app(browser, app.url)
    for scale in SCALES:
        for values in ([scale * k / 10 for k in range(11)], [-scale * (1 + k / 10) for k in range(11)],
                       [8 * scale + scale * k / 20 for k in range(11)]):
            labels = tick_labels(page, values)
            assert len(labels) >= 3, (scale, labels)
            read = [float(text) for text, _ in labels]  # each label a number, as written
            # the heights are linear in the values the labels say: a label that lost digits is off the line
            (v0, y0), (v1, y1) = (read[0], labels[0][1]), (read[-1], labels[-1][1])
            for v, (text, y) in zip(read, labels):
                assert y == pytest.approx(y0 + (v - v0) * (y1 - y0) / (v1 - v0), abs=0.05), (scale, text, labels)
            step = read[1] - read[0]
            assert all(b - a == pytest.approx(step, rel=1e-6) for a, b in zip(read, read[1:])), labels
            assert read[0] - step <= min(values) and max(values) <= read[-1] + step, (values, labels)
            assert len(set(t for t, _ in labels)) == len(labels)  # no two ticks read alike
    assert errors == []


def test_a_new_preset_brings_its_own_run_length_and_torque_and_angles_read_in_degrees(app, browser):
    page, errors = open_app(browser, app.url)
    page.fill("#t_end", "-1")
    page.click("#simulate")  # refused: said next to the box, and no console error
    page.wait_for_selector('#field-t_end:has-text("t_end: must be > 0 s")')
    page.fill("#t_end", "0.5")
    page.fill("#torque", "3")
    pick_preset(page, "watt-ii")
    assert page.input_value("#t_end") == "" and page.input_value("#torque") == ""
    assert page.input_value('[data-key="drive.torque"]') == "0.05"
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    tau = page.evaluate("() => state.run.columns.find((c) => c.name === 'tau_drive').values[0]")
    assert tau == pytest.approx(0.05)  # the form's torque, not the four-bar's 3 N m
    # the drive angle's graph in degrees, as the form writes the input angle, and its axis says so
    label, start = page.evaluate("() => { const c = state.run.columns.find((c) => c.name === 'theta2'); return [c.label, c.values[0]]; }")
    assert label.endswith(", deg") and start == pytest.approx(30.0, abs=1e-3)
    assert page.text_content("#panels svg >> nth=0 >> text.ylabel") == "theta2, deg"
    assert page.text_content("#panels svg >> nth=1 >> text.ylabel") == "E, J"
    # a loop that cannot close says its held angle in degrees too (and radians, as the CSV has it)
    pick_preset(page, "fourbar-crank-rocker")
    page.fill('[data-key="mechanism.ground"]', "5")
    page.press('[data-key="mechanism.ground"]', "Enter")
    page.wait_for_selector("#problem:not([hidden])")
    page.click("#simulate")
    page.wait_for_selector('#run-status:has-text("cannot be closed")')
    assert "theta2 = 30 deg (0.523599 rad) held" in page.inner_text("#run-status")
    assert errors == []


def test_the_menus_name_the_opened_scene(app, browser, tmp_path):
    page, errors = open_app(browser, app.url)
    assert page.input_value("#preset") == "fourbar-crank-rocker"  # the preset the page opened with, named
    page.select_option("#type", label="stephenson-iii")
    page.wait_for_function("() => document.querySelector('#kind').textContent.startsWith('Stephenson III')")
    assert page.evaluate("() => $('type').selectedOptions[0].textContent") == "stephenson-iii"
    text = actions.scene_toml({**actions.preset_data("watt-ii"), "name": "my-watt"})
    (tmp_path / "my-watt.toml").write_text(text)
    page.set_input_files("#upload", str(tmp_path / "my-watt.toml"))
    page.wait_for_function("() => document.querySelector('#kind').textContent.startsWith('Watt II')")
    assert page.evaluate("() => $('type').selectedOptions[0].textContent") == "watt-ii"
    assert page.input_value("#preset") == ""  # no preset of that name
    assert errors == []


def test_a_second_drag_of_a_six_bar_left_open_keeps_its_facts_and_handles(app, browser, shots):
    page, errors = open_app(browser, app.url)
    pick_preset(page, "stephenson-i")
    drag_handle(page, "rocker_pivot", 0.9, 0.0)
    page.wait_for_selector("#problem:not([hidden])")
    drag_handle(page, "rocker_pivot", 1.0, 0.1)  # from the open scene, further out
    assert page.inner_text("#kind").startswith("Stephenson I six-bar")
    assert page.inner_text("#problem").startswith("mechanism.input_angle: loop 1")
    assert page.input_value('[data-key="mechanism.rocker_pivot"]') == "[1, 0.1]"
    # the handle is where the mouse left it, once: no stray one where the drag began
    box = page.locator('circle.handle[data-handle="rocker_pivot"]').bounding_box()
    x, y = screen_of(page, 1.0, 0.1)
    assert abs(box["x"] + box["width"] / 2 - x) < 1.5 and abs(box["y"] + box["height"] / 2 - y) < 1.5
    assert page.locator("circle.handle").count() == len(page.evaluate("() => state.analysis.handles"))
    page.screenshot(path=str(shots / "11-stephenson-i-second-drag.png"))
    drag_handle(page, "rocker_pivot", 0.3, 0.0)  # and back: it closes again
    page.wait_for_function("() => document.querySelector('#problem').hidden")
    assert errors == []


def test_the_run_report_is_of_this_scene_s_run(app, browser):
    page, errors = open_app(browser, app.url, accept_downloads=True)
    pick_preset(page, "luffing-boom")
    page.fill("#t_end", "0.5")
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    pick_preset(page, "thesis-fourbar")  # the boom's run is still the session's, not this scene's
    page.select_option("#export", "pdf")
    page.wait_for_selector('#notice.bad:has-text("simulate first")')
    page.fill("#t_end", "0.5")
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    with page.expect_download(timeout=120_000) as dl:
        page.select_option("#export", "pdf")
    assert dl.value.suggested_filename == "thesis_fourbar-report.pdf"
    assert errors == []


def test_the_motor_sizing_reads_the_cli_s_motor_speed(app, browser):
    page, errors = open_app(browser, app.url)
    pick_preset(page, "thesis-fourbar")
    page.click("#sizing-run")
    page.wait_for_selector("#sizing td", timeout=120_000)
    rows = page.evaluate("() => [...document.querySelectorAll('#sizing tr')].map((r) => [...r.cells].map((c) => c.textContent))")
    # `grubler size thesis-fourbar --move trapezoid --distance 3.14159265 --v-max 6.2831853 --a-max 20 --dwell 0.5
    # --reverse`: "maxon-re40-148877 x 75 ... peak 3.5 A, 32 V, 4500 rpm" (the page had 42972)
    row = next(r for r in rows if r[1] == "maxon-re40-148877" and r[2] == "75")
    assert row[7] == "4500" and row[3] == "1.499"
    assert errors == []


def test_a_cylinder_preset_is_drawn_dragged_held_and_sized(app, browser, shots):
    page, errors = open_app(browser, app.url)
    pick_preset(page, "luffing-boom")
    # the cylinder drawn, barrel and rod, from the ground point to the crank
    barrel = page.locator("#drawing line.barrel")
    assert barrel.count() == 1 and page.locator("#drawing line.rod").count() == 1
    assert [float(barrel.get_attribute(a)) for a in ("x1", "y1")] == [0.9, -0.3]
    assert "driven by its cylinder lift" in page.inner_text("#drive-note")
    assert page.is_visible("#force-box") and page.inner_text("#force-name") == "lift force"
    page.screenshot(path=str(shots / "12-luffing-boom.png"))
    # Simulate with no force: the boom falls, and the page says why
    page.fill("#t_end", "1")
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    assert "lift was given no force" in page.inner_text("#run-warnings")
    fall = page.evaluate("() => { const v = state.run.columns.find((c) => c.name === 'theta2').values; return v[v.length - 1] - v[0]; }")
    assert fall < -5  # deg
    # with the force that holds it (grubler.system.cylinder_servo.holding_force: 10816 N), it stays
    page.fill("#actuator-force", "10816")
    runs = page.evaluate("() => window.grublerStats.simulate.length")
    page.click("#simulate")
    page.wait_for_function("(n) => window.grublerStats.simulate.length > n", arg=runs)
    assert page.inner_text("#run-warnings") == ""
    drift = page.evaluate("() => { const v = state.run.columns.find((c) => c.name === 'theta2').values; return v[v.length - 1] - v[0]; }")
    assert abs(drift) < 0.05  # deg
    assert all(float(t) >= 1000 for t in page.eval_on_selector_all("#panels svg >> nth=1 >> .ytick",
                                                                    "(gs) => gs.map((g) => g.textContent)"))
    page.screenshot(path=str(shots / "13-luffing-boom-held.png"), full_page=True)
    page.click("#edit-mode")
    # the cylinder's ground point dragged: the form follows
    drag_handle(page, "actuator[0].from_point", 1.0, -0.4)
    assert page.input_value('[data-key="actuator[0].from_point"]') == "[1, -0.4]"
    assert [float(page.locator("#drawing line.barrel").get_attribute(a)) for a in ("x1", "y1")] == [1.0, -0.4]
    # Run servo asks for the cylinder's FMUs (this app's folder has none), not a DC motor's; Size sizes the
    # cylinder as `grubler size --cylinder lift` does
    page.click("#servo-run")
    page.wait_for_selector('#servo-error:has-text("no PID.fmu, Trajectory.fmu, HydraulicCylinder.fmu in")')
    assert "DCMotor" not in page.inner_text("#servo-error")
    pick_preset(page, "luffing-boom")
    page.select_option("#unit-angle", "rad")  # the move typed in the CLI's radians
    for key, v in {"distance": "0.1", "v_max": "0.05", "a_max": "0.2", "dwell": "0.5"}.items():
        page.fill(f'#servo-form [data-key="{key}"]', v)
    page.click("#sizing-run")
    page.wait_for_selector("#sizing td", timeout=120_000)
    assert page.inner_text("#sizing-run") == "Size the cylinder"
    # `grubler size luffing-boom --cylinder lift --move trapezoid --distance 0.1 --v-max 0.05 --a-max 0.2
    # --dwell 0.5 --reverse`: "9 of 18 ... 1. 63 mm bore, 100 bar margin 2.19 (buckling); 1.34 kW"
    first = page.evaluate("() => [...document.querySelectorAll('#sizing tr')[1].cells].map((c) => c.textContent)")
    assert first[:6] == ["1", "63 mm bore, 100 bar", "35.3", "2.192", "buckling", "1.343"]
    assert "9 of 18 bore × pressure combinations fit" in page.inner_text("#sizing-status")
    page.locator("#servo").screenshot(path=str(shots / "14-cylinder-sizing.png"))
    assert errors == []


def test_run_servo_of_a_cylinder_preset_is_its_cylinder_under_position_control(servo_app, browser, shots):
    """The luffing boom's servo is its hydraulic cylinder's valve under a PID on the lift's length, as
    examples/cylinder_systems.py builds it; `grubler cosim examples/luffing_boom.ssd` of that system reads
    (its CSV): tracking error up to 9.567 mm, 0.0431 mm at the end, pressure up to 98.42 bar, force 7.225 to
    13.10 kN.  The page used to put a DC motor on the crank (tracking error up to 6.67 rad, 10 A)."""
    url, folder = servo_app
    page, errors = open_app(browser, url)
    pick_preset(page, "luffing-boom")
    assert page.is_visible('#servo-form [data-key="bore"]') and page.is_hidden("#s-motor")
    assert page.input_value('#servo-form [data-key="bore"]') == "0.05"
    assert page.input_value('#servo-form [data-key="move"]') == "0.1"
    assert page.input_value('#servo-form [data-key="t_end"]') == "4"
    page.click("#servo-run")  # the first run compiles the boom's mechanism FMU
    page.wait_for_selector("#servo-plots svg path", timeout=300_000)
    status = page.inner_text("#servo-status")
    assert "a 50/28 mm hydraulic cylinder moves lift 100 mm" in status and "DC" not in status
    assert "bore/rod in mm whatever the page's unit" in status  # why a page in m reads them in mm

    def read(text, before, after):
        return float(text.split(before)[1].split(after)[0])

    assert read(status, "tracking error up to ", " mm") == pytest.approx(9.567, abs=0.05)
    assert read(status, "mm (", " mm at the end") == pytest.approx(0.0431, abs=0.005)
    assert read(status, "pressure up to ", " bar") == pytest.approx(98.42, abs=0.2)
    assert "(supply 160 bar)" in status and read(status, "force ", " to") == pytest.approx(7.225, abs=0.02)
    assert page.locator("#servo-plots svg").count() == 4
    assert page.text_content("#servo-plots svg >> nth=2 >> text.ylabel") == "bar"
    page.locator("#servo").screenshot(path=str(shots / "15-luffing-boom-servo.png"))
    # the run played on the drawing: the boom lifted by its cylinder, scrubbed to the end
    page.wait_for_selector("#servo-player:not([hidden])")
    page.evaluate("""() => { const s = document.querySelector('#servo-scrub'); s.value = s.max;
        s.dispatchEvent(new Event('input')); }""")
    page.locator("#stage").screenshot(path=str(shots / "16-luffing-boom-servo-drawn.png"))
    # a softer gain re-runs at once (the mechanism FMU kept) and follows worse
    page.fill('#servo-form [data-key="K"]', "10")
    page.press('#servo-form [data-key="K"]', "Enter")
    page.wait_for_function("() => window.grublerStats.servo.length >= 2", timeout=120_000)
    assert read(page.inner_text("#servo-status"), "tracking error up to ", " mm") > 9.567 * 1.5
    # and a revolute drive's scene gets the DC motor back
    pick_preset(page, "thesis-fourbar")
    assert page.is_visible("#s-motor") and page.is_hidden('#servo-form [data-key="bore"]')
    assert page.input_value('#servo-form [data-key="K"]') == "300" and page.inner_text("#k-unit") == "V/rad"
    assert errors == []


def test_a_scene_s_springs_torsion_springs_and_loads_are_drawn_in_the_sketch_and_the_run(app, browser, shots):
    """The gas-spring boom's strut (a zigzag), its head hinge's torsion spring (a coil) and its payload (an
    arrow), drawn from the frames' geometry the GIFs draw (grubler.views.animation), in the sketch and as they
    move in the run; the run's graphs start with their forces, stored energies and the energy balance."""
    page, errors = open_app(browser, app.url)
    pick_preset(page, "gas-spring-boom")
    frame = page.evaluate("() => state.analysis.frame")
    assert len(frame["springs"]) == 1 and len(frame["coils"]) == 1 and len(frame["loads"]) == 1
    spring = page.locator("#drawing polyline.spring")
    assert spring.count() == 1 and page.locator("#drawing polyline.coil").count() == 1
    assert page.locator("#drawing g.load polygon").count() == 1
    points = [[float(v) for v in p.split(",")] for p in spring.get_attribute("points").split()]
    assert points[0] == [0.9, -0.3] and len(points) == 18  # from the ground point, the GIFs' zigzag of 7 a side
    assert points == frame["springs"][0]
    # the coil sits at the head's hinge (pin A), turned with the jib-to-head link
    coil = page.locator("#drawing polyline.coil").get_attribute("transform")
    a = handle_at(page, "A")
    assert coil.startswith(f"translate({a[0]},{a[1]}) rotate(")
    # the payload's arrow ends at its point, pointing down
    tip = page.locator("#drawing g.load polygon").get_attribute("points").split()[0]
    assert [float(v) for v in tip.split(",")] == handle_at(page, "point_load[0].point")
    page.screenshot(path=str(shots / "15-gas-spring-boom.png"))

    page.fill("#t_end", "3")
    page.click("#simulate")
    page.wait_for_selector("#panels svg path")
    page.click("#play")  # paused at a late instant: the strut drawn where the boom has sagged to
    page.evaluate("() => { state.t = 1.0; drawRunFrame(); }")
    moved = [[float(v) for v in p.split(",")] for p in
             page.locator("#drawing polyline.spring").get_attribute("points").split()]
    assert moved[0] == [0.9, -0.3] and moved[-1] != points[-1]
    assert page.locator("#drawing polyline.coil").count() == 1 and page.locator("#drawing g.load").count() == 1
    series = page.evaluate("() => state.panels")
    assert ["strut_force"] in series and ["hinge_effort"] in series and ["strut_energy", "hinge_energy"] in series
    assert ["energy_balance"] in series
    labels = page.eval_on_selector_all("#panels .chip", "(cs) => cs.map((c) => c.textContent)")
    assert any(t.startswith("spring strut force (strut_force), N") for t in labels)
    page.screenshot(path=str(shots / "16-gas-spring-boom-run.png"), full_page=True)
    assert errors == []


def test_force_elements_are_added_edited_dragged_refused_by_name_and_removed(app, browser, shots):
    page, errors = open_app(browser, app.url)
    pick_preset(page, "fourbar-crank-rocker")
    assert page.locator("#drawing polyline.spring").count() == 0
    page.click('#elements-bar button[data-kind="spring"]')
    page.wait_for_selector("#drawing polyline.spring")
    # every field of a spring in the form, with its unit: the damper and the gas law too
    for key in ("stiffness", "free_length", "preload", "damping", "gas_force", "gas_column", "gas_exponent"):
        assert page.locator(f'[data-key="spring[0].{key}"]').count() == 1, key
    assert "(N s/m)" in page.inner_text('label[for="f-spring_0__damping"]')
    # a bad value: refused by the scene reader's words, next to its field
    page.fill('[data-key="spring[0].stiffness"]', "-5")
    page.press('[data-key="spring[0].stiffness"]', "Enter")
    page.wait_for_selector('[data-err="spring[0].stiffness"]:has-text("stiffness must be >= 0")')
    page.fill('[data-key="spring[0].stiffness"]', "800")
    page.press('[data-key="spring[0].stiffness"]', "Enter")
    page.wait_for_function("() => state.scene.spring[0].stiffness === 800 && !state.analysis.error")
    # its ground end dragged: the form and the zigzag follow
    drag_handle(page, "spring[0].from_point", 0.3, -0.2)
    assert page.input_value('[data-key="spring[0].from_point"]') == "[0.3, -0.2]"
    first = page.locator("#drawing polyline.spring").get_attribute("points").split()[0]
    assert [float(v) for v in first.split(",")] == [0.3, -0.2]
    # a torsion spring with friction at a joint, and a load
    page.click('#elements-bar button[data-kind="joint_spring"]')
    page.wait_for_selector("#drawing polyline.coil")
    assert page.input_value('[data-key="joint_spring[0].joint"]') == "theta2"
    page.fill('[data-key="joint_spring[0].friction"]', "0.5")
    page.press('[data-key="joint_spring[0].friction"]', "Enter")
    page.wait_for_function("() => state.scene.joint_spring[0].friction === 0.5")
    page.click('#elements-bar button[data-kind="point_load"]')
    page.wait_for_selector("#drawing g.load")
    page.screenshot(path=str(shots / "17-elements-added.png"))
    # removed: the spring's drawing, fields and handles go
    page.click('button.remove-element[data-element="spring[0]"]')
    page.wait_for_function("() => !state.scene.spring")
    assert page.locator("#drawing polyline.spring").count() == 0
    assert page.locator('[data-key="spring[0].stiffness"]').count() == 0
    assert page.locator('circle.handle[data-handle="spring[0].from_point"]').count() == 0
    assert page.locator("#drawing polyline.coil").count() == 1
    assert errors == []
