"""The browser app's server without a browser: its safety rules, its answers, its sessions.

Each test talks HTTP to a real server on 127.0.0.1 (a free port), as the page
does; tests/test_app_browser.py drives the page itself.
"""

import http.client
import json
import math
import threading
import time
import tomllib

import numpy as np
import pytest

from grubler import cli
from grubler.app import actions
from grubler.app.server import AppServer
from grubler.errors import Cancelled
from grubler.mechanism.scene import preset_names, scene_from_dict
from grubler.mechanism.simulate import simulate


def call(server, method, path, body=None, headers=None, cookie=None):
    """(status, parsed JSON or text, the cookie the server set)."""
    conn = http.client.HTTPConnection("127.0.0.1", server.server_address[1], timeout=60)
    h = {"Host": f"127.0.0.1:{server.server_address[1]}"}
    if body is not None:
        h["Content-Type"] = "application/json"
    if cookie:
        h["Cookie"] = f"grubler_session={cookie}"
    h.update(headers or {})
    conn.request(method, path, None if body is None else json.dumps(body), h)
    r = conn.getresponse()
    data = r.read()
    set_cookie = r.getheader("Set-Cookie") or ""
    token = set_cookie.split(";")[0].split("=", 1)[1] if set_cookie else cookie
    ctype = r.getheader("Content-Type") or ""
    conn.close()
    return r.status, (json.loads(data) if ctype.startswith("application/json") else data.decode()), token


def post(server, action, body, cookie=None):
    status, out, token = call(server, "POST", f"/api/{action}", body, cookie=cookie)
    assert status == 200, out
    return out, token


# -- safety -------------------------------------------------------------------------------------------
def test_a_foreign_host_is_refused_dns_rebinding(app):
    status, out, _ = call(app, "GET", "/", headers={"Host": "attacker.example:80"})
    assert status == 403 and out["error"]["field"] == "Host"
    status, out, _ = call(app, "POST", "/api/preset", {"name": "thesis-fourbar"},
                          headers={"Host": f"attacker.example:{app.server_address[1]}"})
    assert status == 403


def test_a_request_from_another_site_is_refused(app):
    status, out, _ = call(app, "POST", "/api/files", {}, headers={"Origin": "http://evil.example"})
    assert status == 403 and out["error"]["field"] == "Origin"
    port = app.server_address[1]
    status, out, _ = call(app, "POST", "/api/files", {}, headers={"Origin": f"http://127.0.0.1:{port}"})
    assert status == 200 and "files" in out


def test_only_json_posts_are_taken(app):
    # a plain HTML form from another page can post text/plain without a preflight
    status, out, _ = call(app, "POST", "/api/save", None,
                          headers={"Content-Type": "text/plain", "Content-Length": "2"})
    assert out["error"]["field"] == "request"


def test_it_listens_on_the_loopback_only_by_default(app):
    import socket

    assert app.server_address[0] == "127.0.0.1"
    assert cli.build_parser().parse_args(["app"]).host == "127.0.0.1"
    # told to listen everywhere, it answers to this machine's names, still not to any name
    wide = AppServer("0.0.0.0", 0)
    try:
        port = wide.server_address[1]
        assert {f"127.0.0.1:{port}", f"{socket.gethostname()}:{port}"} <= wide.allowed_hosts
        assert f"attacker.example:{port}" not in wide.allowed_hosts
    finally:
        wide.server_close()


def test_files_outside_the_folder_are_neither_read_nor_written(app, tmp_path):
    data = actions.preset_data("thesis-fourbar")
    for name in ("../outside.toml", "/etc/passwd", "sub/../../outside.toml"):
        out, _ = post(app, "open", {"file": name})
        assert out["error"]["field"] == "file" and "outside the folder" in out["error"]["reason"]
        out, _ = post(app, "save", {"file": name, "scene": data})
        assert out["error"]["field"] == "file"
    assert not (tmp_path.parent / "outside.toml").exists()
    out, _ = post(app, "save", {"file": "mine.toml", "scene": data})
    assert out == {"saved": "mine.toml"}
    # what was saved is the CLI's format: the CLI reads it as the same scene
    assert tomllib.loads((tmp_path / "mine.toml").read_text()) == data
    out, _ = post(app, "files", {})
    assert out["files"] == ["mine.toml"]
    out, _ = post(app, "open", {"file": "mine.toml"})
    assert out["scene"] == data


def test_a_bad_value_gets_the_cli_message_next_to_its_field_never_a_traceback(app, tmp_path, capsys):
    data = actions.preset_data("fourbar-crank-rocker")
    out, _ = post(app, "edit", {"scene": data, "key": "mechanism.crank", "value": "-0.3"})
    assert out["error"]["field"] == "mechanism.crank"
    assert out["scene"]["mechanism"]["crank"] == -0.3  # kept, so the user sees what was refused
    bad = tmp_path / "bad.toml"
    bad.write_text(actions.scene_toml(out["scene"]))
    assert cli.run(["info", str(bad)]) == 2
    assert capsys.readouterr().err.strip() == f"grubler: error: mechanism.crank: {out['error']['reason']}"
    for body in ({"scene": data, "key": "mechanism.crank", "value": "1e999"},
                 {"scene": data, "key": "__class__", "value": 1},
                 {"scene": "not a table"}, {"scene": data, "handle": "nowhere", "x": 0, "y": 0}):
        out, _ = post(app, "edit" if "key" in body else "drag", body)
        assert set(out["error"]) == {"field", "reason"} and "Traceback" not in out["error"]["reason"]
    status, out, _ = call(app, "POST", "/api/nothing", {})
    assert status == 200 and out["error"]["field"] == "action"


# -- entering a mechanism -----------------------------------------------------------------------------------
def test_dragging_the_rocker_pivot_past_the_grashof_limit_and_past_closing(app, tmp_path, capsys):
    data = actions.preset_data("fourbar-crank-rocker")
    out, _ = post(app, "analyse", {"scene": data})
    assert out["class"]["grashof"]["kind"] == "crank-rocker" and out["class"]["mobility"] == 1
    assert out["branch"]["count"] == 2 and out["branch"]["drive"] == "theta2"
    # the branch by its angles, as `grubler info` lists it; the crossed one differs
    crossed, _ = post(app, "edit", {"scene": data, "key": "mechanism.branch", "value": "crossed"})
    assert len(out["branch"]["angles"]) == 2 and crossed["branch"]["angles"] != out["branch"]["angles"]
    assert out["branch"]["angles"][0] in capture_info(data)
    assert {h["id"] for h in out["handles"]} == {"A", "B", "O4"}
    out, _ = post(app, "drag", {"scene": data, "handle": "O4", "x": 1.4, "y": 0.3})
    assert out["scene"]["mechanism"]["ground"] == 1.4
    assert out["class"]["grashof"]["kind"] == "triple-rocker" and out["closed"]
    out, _ = post(app, "drag", {"scene": data, "handle": "O4", "x": 2.1, "y": 0})
    assert not out["closed"] and out["curve"] == []
    # the same words as `grubler info`
    scene = tmp_path / "far.toml"
    scene.write_text(actions.scene_toml(out["scene"]))
    assert cli.run(["info", str(scene)]) == 2
    err = capsys.readouterr().err
    assert f"{out['problem']['field']}: {out['problem']['reason']}" in err
    assert "the longest link (2.1 m) is not shorter than the other three together" in out["problem"]["reason"]


def capture_info(data) -> str:
    import contextlib
    import io
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scene.toml"
        path.write_text(actions.scene_toml(data))
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            assert cli.run(["info", str(path)]) == 0
    return out.getvalue()


def test_every_type_and_preset_analyses_and_writes_back_as_the_same_toml():
    cat = actions.catalog()
    assert {t["type"] for t in cat["types"]} >= {"four-bar", "slider-crank", "watt-i", "watt-ii", "stephenson-i",
                                                "stephenson-ii", "stephenson-iii"}
    assert [p["name"] for p in cat["presets"]] == preset_names()
    for name in preset_names():
        data = actions.preset_data(name)
        assert tomllib.loads(actions.scene_toml(data)) == data, name
        out = actions.analyse(data)
        assert out["closed"], name
        if out["drive"] and scene_from_dict(data).mechanism.closures:
            assert len(out["curve"]) > 10, name


def test_a_coupler_curve_is_the_traced_point_over_a_full_turn_of_a_crank():
    import math

    data = actions.preset_data("fourbar-crank-rocker")
    out = actions.analyse(data, trace="link3:0.45,0.225")
    curve = out["curve"]
    assert len(curve) == actions.SWEEP_STEPS + 1 and curve[0] == curve[-1]  # a crank turns fully
    # the reference: the four-bar closed by hand (two circles), no kernel; the sweep starts at the
    # scene's 30 deg and steps a whole turn evenly, on the sketch's ('open') branch
    g, a, b, c = 1.0, 0.3, 0.9, 0.7
    for k, (x, y) in enumerate(curve[:-1]):
        t = math.radians(30) + 2 * math.pi * k / actions.SWEEP_STEPS
        ax, ay = a * math.cos(t), a * math.sin(t)
        dx, dy = g - ax, -ay
        d = math.hypot(dx, dy)
        along = (b * b - c * c + d * d) / (2 * d)
        h = math.sqrt(b * b - along * along)
        bx, by = ax + (along * dx - h * dy) / d, ay + (along * dy + h * dx) / d  # left of A -> O4
        ex, ey = (bx - ax) / b, (by - ay) / b
        px, py = ax + 0.45 * ex - 0.225 * ey, ay + 0.45 * ey + 0.225 * ex
        assert math.hypot(x - px, y - py) < 2e-6, k
    assert out["frame"]["fixed"] == [[0.0, 0.0], [1.0, 0.0]]


def test_the_drag_applies_to_each_handle_what_it_stands_for():
    data = actions.preset_data("stephenson-iii")
    moved = actions.drag(data, "output_pivot", 0.5, -0.1)
    assert moved["mechanism"]["output_pivot"] == [0.5, -0.1]
    moved = actions.drag(data, "A", 0.0, 0.12)
    assert moved["mechanism"]["crank"] == 0.12 and moved["mechanism"]["input_angle"] == "90 deg"
    del data["mechanism"]["input_angle"]  # a six-bar's crank angle is its input angle, written or not
    assert actions.drag(data, "A", 0.0, 0.12)["mechanism"]["input_angle"] == "90 deg"
    for preset, handle, xy, key, value in (("swinging-block", "pivot", (0.35, 0.02), "ground", 0.35),
                                           ("quick-return", "pivot", (0.01, -0.3), "ground", 0.3),
                                           ("pendulum-pump", "slide", (0.25, 0.1), "offset", 0.25)):
        out = actions.analyse(actions.drag(actions.preset_data(preset), handle, *xy))
        moved = actions.drag(actions.preset_data(preset), handle, *xy)
        assert moved["mechanism"][key] == value and out["closed"], preset
        assert any(h["id"] == handle and h["sets"] == f"mechanism.{key}" for h in out["handles"])
    data = actions.preset_data("thesis-fourbar")
    moved = actions.drag(data, "closure.point", 1.1, 0.05)
    assert moved["closure"]["point"] == [1.1, 0.05]
    moved = actions.drag(data, "link2.end", 0.0, 0.25)
    assert moved["link2"]["a"] == 0.25 and moved["initial"]["theta2"] == "90 deg"
    assert actions.analyse(moved)["closed"]


def test_the_branch_search_finds_what_assembling_each_start_alone_finds():
    """branches() closes its 256 starts with buffers made once; the reference assembles each start by itself."""
    import numpy as np

    from grubler.errors import AssemblyError
    from grubler.mechanism.assembly import assemble, branches, held_coordinates

    for name in ("stephenson-ii", "watt-i", "fourbar-triple-rocker", "thesis-quick-return", "conchoidal"):
        m = scene_from_dict(actions.preset_data(name)).mechanism
        z0 = m.z_from_q(m.q_ref)
        found, default = branches(m, z0, starts=64, seed=3)
        free = np.ones(m.n_free, bool)
        free[held_coordinates(m, z0)] = False
        turns, slides = free & m.arrays.revolute, free & ~m.arrays.revolute
        rng, reference = np.random.default_rng(3), [assemble(m, z0)[0]]
        for _ in range(64):
            z = z0.copy()
            z[turns] = rng.uniform(-np.pi, np.pi, int(turns.sum()))
            z[slides] = z0[slides] + rng.uniform(-max(1.0, max(abs(l.a) for l in m.links)),
                                                  max(1.0, max(abs(l.a) for l in m.links)), int(slides.sum()))
            try:
                z = assemble(m, z)[0]
            except AssemblyError:
                continue
            d = np.array(reference) - z
            d[:, m.arrays.revolute] = (d[:, m.arrays.revolute] + np.pi) % (2 * np.pi) - np.pi
            if np.all(np.abs(d).max(axis=1) >= 1e-6):
                reference.append(z)
        assert default == 0 and len(found) == len(reference), name
        assert np.abs(np.array(found) - np.array(reference)).max() < 1e-9, name  # each closed to 1e-12


# handles held to a line or a circle (a pivot on its axis, a block on its slide, a length along its
# link): dragged off it, they come nearer the pointer without reaching it
ON_A_LINE = {"O4", "pivot", "slide", "shaft2", "slot", "block1", "arm", "rod", "lever"}


def test_every_handle_of_every_preset_follows_the_pointer():
    import math

    for name in preset_names():
        data = actions.preset_data(name)
        start = actions.analyse(data)
        assert start["handles"], f"{name}: nothing to drag"
        if name == "coupling-rod":
            continue  # three equal parallel cranks: any pivot moved alone breaks the parallel, and the loop opens
        span = max(max(abs(v) for h in start["handles"] for v in h["xy"]), 0.05)
        for h in start["handles"]:
            target = (h["xy"][0] + 0.03 * span, h["xy"][1] + 0.02 * span)
            moved = actions.drag(data, h["id"], *target)
            out = actions.analyse_drag(data, moved, h["id"], *target)
            assert out["closed"] and out["problem"] is None, (name, h["id"])
            sx, sy = out.get("shift") or (0.0, 0.0)  # (a six-bar's origin: its answer is drawn shifted)
            now = next([g["xy"][0] + sx, g["xy"][1] + sy] for g in out["handles"] if g["id"] == h["id"])
            if h["id"] in ON_A_LINE:
                assert math.dist(now, target) < math.dist(h["xy"], target), (name, h["id"])
            else:  # to a tenth of a millimetre, the scene's rounding of what a drag sets
                assert math.dist(now, target) < 3e-4, (name, h["id"], now, target)


def test_a_six_bar_joint_dragged_keeps_every_other_joint_where_it_was():
    import math

    from grubler.mechanism.builders import SIX_BARS

    for kind, sb in SIX_BARS.items():
        data = actions.preset_data(kind)
        start = {h["id"]: h["xy"] for h in actions.analyse(data)["handles"]}
        moving = set(sb.joints[1:]) - set(sb.pivots) - {sb.pin}
        assert moving | {"O2"} < set(start) and len(start) == 7, kind  # every joint has its handle
        for joint in moving | {"O2"}:
            target = (start[joint][0] - 0.02, start[joint][1] + 0.015)
            out = actions.analyse_drag(data, actions.drag(data, joint, *target), joint, *target)
            assert out["closed"] and out["class"]["mobility"] == 1 and out["branch"]["count"] >= 1, (kind, joint)
            assert len(out["curve"]) > 10
            # the origin dragged: the answer is measured from where it went, and drawn shifted back by that
            sx, sy = out.get("shift") or (0.0, 0.0)
            assert (joint == "O2") == ("shift" in out)
            for h in out["handles"]:
                at = (h["xy"][0] + sx, h["xy"][1] + sy)
                assert math.dist(at, target if h["id"] == joint else start[h["id"]]) < 3e-4, (kind, joint, h)
    # which numbers a joint stands for: the lengths it ends, the sides it decides (Watt II's rocker triangle)
    moved = actions.drag(actions.preset_data("watt-ii"), "C", 0.6, 0.1)["mechanism"]  # O4 (0.3, 0), B above it
    assert moved["rocker_side"] == "right" and moved["rocker_arm"] == round(math.hypot(0.3, 0.1), 4)


def test_a_six_bar_pivot_beyond_its_links_shows_where_the_loop_opens_in_the_words_of_info(app, tmp_path, capsys):
    data = actions.preset_data("stephenson-i")
    out, _ = post(app, "drag", {"scene": data, "handle": "rocker_pivot", "x": 0.9, "y": 0.0, "live": True})
    assert out["scene"]["mechanism"]["rocker_pivot"] == [0.9, 0.0] and "error" not in out
    assert not out["closed"] and out["curve"] == [] and out["class"]["mobility"] == 1
    assert {"id": "rocker_pivot", "xy": [0.9, 0.0], "sets": "mechanism.rocker_pivot"} in out["handles"]
    assert "triangle A-B-O4: its ends are 0.814933 m apart" in out["problem"]["reason"]
    scene = tmp_path / "far.toml"
    scene.write_text(actions.scene_toml(out["scene"]))
    assert cli.run(["info", str(scene)]) == 2
    assert capsys.readouterr().err.strip() == f"grubler: error: {out['problem']['field']}: {out['problem']['reason']}"


def test_the_branches_the_page_counts_are_those_grubler_info_lists():
    """One computation: the live count is `grubler info`'s (a sample of 16 starts found 3 of Stephenson I's 4)."""
    import re

    for name in preset_names():
        data = actions.preset_data(name)
        out = actions.analyse(data, live=True)
        if out["branch"] is None:
            continue
        info = capture_info(data)
        count = int(re.search(r"^branches +(\d+) with", info, re.M).group(1))
        assert out["branch"]["count"] == count, name
        default = re.search(r"^  \[\d+\] (.*)  <- the scene's", info, re.M).group(1)
        assert ", ".join(out["branch"]["angles"]) == default, name


def test_a_double_clicked_point_is_traced_on_the_link_under_it(app):
    data = actions.preset_data("fourbar-crank-rocker")
    point = actions.analyse(data, trace="link3:0.45,0.225")["curve"][0]  # where that coupler point is now
    out, _ = post(app, "pick", {"scene": data, "x": point[0], "y": point[1]})
    assert out == {"trace": "link3:0.45,0.225"}
    out, _ = post(app, "pick", {"scene": data, "x": 1.0, "y": 0.35})  # beside the rocker, 1 m from the origin
    assert out["trace"].startswith("link4:")
    out, _ = post(app, "pick", {"scene": data, "x": "nan", "y": 0})
    assert out["error"]["field"] == "trace"


def test_the_form_names_each_value_as_the_toml_does_with_its_unit():
    f = {x["key"]: x for x in actions.fields(actions.preset_data("thesis-fourbar"))}
    assert f["link2.a"]["unit"] == "m" and f["link2.m"]["unit"] == "kg" and f["link2.I"]["unit"] == "kg m^2"
    assert f["initial.theta3"]["value"] == "pi/3" and f["initial.theta3"]["unit"].startswith("rad")
    assert f["closure.point"]["value"] == [1.0, 0.0]
    edited = actions.edit(actions.preset_data("thesis-fourbar"), "closure.point", "[1.2, 0.1]")
    assert edited["closure"]["point"] == [1.2, 0.1]
    menus = {x["key"]: x.get("choices") for x in actions.fields(actions.preset_data("stephenson-iii"))}
    assert menus["mechanism.branch1"] == ["open", "crossed"] and menus["mechanism.coupler_side"] == ["left", "right"]
    assert "stephenson-iii" in menus["mechanism.type"] and menus["mechanism.crank"] is None
    assert actions.describe("theta3_d") == "angular rate of link 3 (theta3_d), rad/s"
    assert actions.describe("E") == "total energy (E), J"


def test_a_shared_scene_is_checked_as_the_cli_checks_a_file(app):
    out, _ = post(app, "parse", {"toml": "[link2]\na = 'x'\n"})
    assert out["error"]["field"] == "link2.a"
    out, _ = post(app, "parse", {"toml": "this is = not toml ["})
    assert out["error"]["field"] == "scene" and "TOML" in out["error"]["reason"]


# -- runs: sessions, cancel -------------------------------------------------------------------------------
def test_one_browser_session_never_sees_another_s_run(app):
    data = actions.preset_data("thesis-fourbar")
    status, page, alice = call(app, "GET", "/")
    assert status == 200 and "<title>grubler</title>" in page and alice
    view, _ = post(app, "simulate", {"scene": data, "t_end": 0.5}, cookie=alice)
    assert view["t"][-1] == 0.5 and view["columns"][0]["name"] == "t"
    status, text, _ = call(app, "GET", "/api/result.csv", cookie=alice)
    assert status == 200 and text.startswith("t [s],B1 [m],theta2 [rad]")  # the CLI's own CSV, units in the headings
    status, _, bob = call(app, "GET", "/")
    assert bob != alice
    status, out, _ = call(app, "GET", "/api/result.csv", cookie=bob)
    assert status == 404 and out["error"]["reason"] == "simulate first"
    status, out, _ = call(app, "GET", "/api/result.csv", cookie="made-up")  # a guessed token is a new session
    assert status == 404


def test_a_long_run_can_be_cancelled_and_the_server_keeps_serving_meanwhile(app):
    data = actions.preset_data("thesis-fourbar")
    _, _, token = call(app, "GET", "/")
    answer = {}

    def run():
        try:
            # some hours of motion on few rows: the integration is the long part, however fast the machine
            answer["out"] = call(app, "POST", "/api/simulate", {"scene": data, "t_end": 20000, "dt_out": 10},
                                 cookie=token)[1]
        except Exception as exc:  # noqa: BLE001 (shown by the assertion below)
            answer["out"] = exc

    worker = threading.Thread(target=run)
    worker.start()
    time.sleep(0.5)
    assert worker.is_alive()
    status, out, _ = call(app, "POST", "/api/preset", {"name": "oldham"})  # served while the run goes on
    assert status == 200 and out["scene"]["name"] == "oldham"
    for _ in range(60):  # a cancel that lands before the run has begun is no cancel: ask until it ends
        post(app, "cancel", {}, cookie=token)
        worker.join(0.5)
        if not worker.is_alive():
            break
    assert not worker.is_alive()
    out = answer["out"]
    assert isinstance(out, dict), out
    assert out["error"]["field"] == "run" and "cancelled at t =" in out["error"]["reason"]


def test_simulate_stops_when_its_cancel_flag_is_set():
    flag = threading.Event()
    flag.set()
    with pytest.raises(Cancelled, match="run: cancelled at t = 0 s"):
        simulate("thesis-fourbar", t_end=1.0, cancel=flag)
    # unset, the sliced run gives the unsliced one's answer (the same steps, the grid read in slices)
    a = simulate("thesis-fourbar", t_end=1.0, cancel=threading.Event())
    b = simulate("thesis-fourbar", t_end=1.0)
    assert abs(a["theta2"] - b["theta2"]).max() < 1e-8


def test_the_cli_refuses_a_bad_port_or_scene_in_one_line_before_listening(capsys, tmp_path):
    assert cli.run(["app", "--port", "70000"]) == 2
    assert "--port" in capsys.readouterr().err
    assert cli.run(["app", str(tmp_path / "nosuch.toml"), "--no-browser"]) == 2
    out = capsys.readouterr()
    assert out.err.startswith("grubler: error: scene: ") and out.out == ""  # no URL: nothing listens
    bad = tmp_path / "bad.toml"
    bad.write_text("[link2]\na = -1\n")
    assert cli.run(["app", str(bad), "--no-browser"]) == 2
    assert "link2" in capsys.readouterr().err


def test_exports_are_what_the_cli_writes(app):
    import io
    import zipfile

    data = actions.preset_data("thesis-fourbar")
    _, _, token = call(app, "GET", "/")
    status, out, _ = call(app, "POST", "/api/export", {"kind": "pdf", "scene": data}, cookie=token)
    assert out["error"] == {"field": "report", "reason": "simulate first: the report is of the last run"}
    post(app, "simulate", {"scene": data, "t_end": 0.5}, cookie=token)
    conn = http.client.HTTPConnection("127.0.0.1", app.server_address[1], timeout=120)
    for kind, name, head in (("pdf", "thesis_fourbar-report.pdf", b"%PDF"), ("fmu", "thesis_fourbar.fmu", b"PK")):
        conn.request("POST", "/api/export", json.dumps({"kind": kind, "scene": data}),
                     {"Host": f"127.0.0.1:{app.server_address[1]}", "Content-Type": "application/json",
                      "Cookie": f"grubler_session={token}"})
        r = conn.getresponse()
        body = r.read()
        assert r.status == 200 and f'filename="{name}"' in r.getheader("Content-Disposition")
        assert body.startswith(head)
    assert "modelDescription.xml" in zipfile.ZipFile(io.BytesIO(body)).namelist()
    # the servo's FMUs come from dist/ in the app's folder: without them, the command that builds them
    for action, body in (("export", {"kind": "ssp", "scene": data, "servo": {}}),
                         ("servo", {"scene": data, "servo": {}})):
        status, out, _ = call(app, "POST", f"/api/{action}", body)
        assert out["error"]["field"] == "servo" and "python3 build_fmu.py" in out["error"]["reason"]


def test_servo_settings_are_checked_by_name(app):
    data = actions.preset_data("thesis-fourbar")
    for servo, field in (({"K": "-1"}, "servo.K"), ({"motor": "maxon-re41"}, "servo.motor"),
                         ({"step": "0"}, "servo.step"), ({"kind": "sine"}, "servo.kind")):
        out, _ = post(app, "sizing", {"scene": data, "servo": servo})
        assert out["error"]["field"] == field, out
    out, _ = post(app, "sizing", {"scene": {**data, "drive": {}}, "servo": {}})
    assert out["error"]["field"] == "drive.joint"
    out, _ = post(app, "sizing", {"scene": actions.preset_data("triple-pendulum"), "servo": {}})
    assert out["error"]["field"] == "mechanism" and "3" in out["error"]["reason"]  # the library's words


def test_the_sizing_table_ranks_as_grubler_size_does(app, capsys):
    data = actions.preset_data("thesis-fourbar")
    out, _ = post(app, "sizing", {"scene": data, "servo": {}})
    fits = [r for r in out["rows"] if r["fits"]]
    assert fits and out["rows"][:len(fits)] == fits  # the ones that fit first, best first
    assert [r["margin"] for r in fits] == sorted((r["margin"] for r in fits), reverse=True)
    assert cli.run(["size", "thesis-fourbar", "--move", "trapezoid", "--distance", "3.141592653589793",
                    "--reverse", "--supply", "48", "--current-limit", "10"]) == 0
    best = capsys.readouterr().out.split("best first")[1].splitlines()[1]
    assert fits[0]["motor"] in best and f"{fits[0]['ratio']}" in best


def test_a_cancel_while_the_outputs_are_computed_is_honoured_too():
    import sys

    class LateFlag:  # clear through every slice of the integration, set once it is over (read by the app's check)
        def is_set(self):
            return sys._getframe(1).f_code.co_name == "_check_cancel"

    with pytest.raises(Cancelled, match="its outputs were being computed"):
        actions.run_simulation(actions.preset_data("thesis-fourbar"), 2.0, None, None, cancel=LateFlag())


def test_every_builder_owns_its_geometry_both_ways_and_the_app_names_none():
    """A builder registers beside its build where its handles are and what a drag sets (builders.HANDLES,
    MOVES); the app reads those and keeps no branch of its own per mechanism type."""
    import inspect

    from grubler.mechanism.builders import BUILDERS, HANDLES, MOVES

    assert set(HANDLES) == set(BUILDERS) == set(MOVES)
    from pathlib import Path

    source = "".join(p.read_text() for p in Path(inspect.getfile(actions)).parent.glob("*.py"))
    named = [kind for kind in BUILDERS if f'"{kind}"' in source]
    assert named == [], f"the app branches on builder types: {named}"


# -- clients that leave, lie or dawdle -----------------------------------------------------------------------
@pytest.fixture
def app_process(tmp_path):
    """``grubler app`` as a user starts it: its own process (the CLI's signal settings), its stderr's lines."""
    import queue
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-m", "grubler.cli", "app", "--no-browser", "--port", "0"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert line.startswith("grubler app: http://127.0.0.1:"), line + proc.stderr.read()
    lines = queue.Queue()
    threading.Thread(target=lambda: [lines.put(x) for x in proc.stderr], daemon=True).start()
    proc.port = int(line.split()[2].rsplit(":", 1)[1].strip("/"))
    proc.lines = lines
    yield proc
    proc.send_signal(__import__("signal").SIGINT)
    assert proc.wait(30) == 130


def send_and_leave(port: int, action: str, body: bytes, headers: dict, stay: float) -> None:
    """A client that sends its request and closes its connection ``stay`` s later, answered or not."""
    import socket

    head = "".join(f"{k}: {v}\r\n" for k, v in {"Host": f"127.0.0.1:{port}", "Content-Type": "application/json",
                                                  **headers}.items())
    with socket.create_connection(("127.0.0.1", port)) as sock:
        sock.sendall(f"POST /api/{action} HTTP/1.1\r\n{head}\r\n".encode() + body)
        time.sleep(stay)


def answers(port: int) -> bool:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    conn.request("POST", "/api/files", "{}", {"Host": f"127.0.0.1:{port}", "Content-Type": "application/json"})
    r = conn.getresponse()
    return r.status == 200 and "files" in json.loads(r.read())


def test_a_client_that_leaves_mid_run_cancels_the_run_and_the_app_serves_on(app_process):
    port = app_process.port
    data = json.dumps(actions.preset_data("thesis-fourbar"))
    # some 11 days of motion on few rows: hours of integration, unless the run stops when its page leaves
    body = f'{{"scene": {data}, "t_end": 1e6, "dt_out": 100}}'.encode()
    send_and_leave(port, "simulate", body, {"Content-Length": len(body)}, stay=0.5)
    line = app_process.lines.get(timeout=120)  # what the terminal is told of the run that was stopped
    assert line.startswith("grubler app: the page of a simulate run left before its answer; cancelled at t = ")
    assert float(line.split("t = ")[1].split()[0]) < 1e6
    assert app_process.poll() is None and answers(port)
    # a run that ends after its client left: the answer is written to a closed connection (SIGPIPE,
    # which the CLI lets end `grubler ... | head`, ended the app here); a client that says it sends
    # -1 bytes, or more than it sends, and leaves
    body = f'{{"scene": {data}, "t_end": 2000}}'.encode()
    send_and_leave(port, "simulate", body, {"Content-Length": len(body)}, stay=0.3)
    send_and_leave(port, "files", b"{}", {"Content-Length": "-1"}, stay=0.3)
    send_and_leave(port, "files", b"{}", {"Content-Length": "1000"}, stay=0.3)
    for _ in range(3):  # after the 2000 s run has ended or been cancelled: every client is done with
        status, out, _ = call(type("S", (), {"server_address": ("127.0.0.1", port)}), "POST", "/api/simulate",
                              {"scene": json.loads(data), "t_end": 0.1})
        assert status == 200 and out["t"][-1] == 0.1
    assert app_process.poll() is None and answers(port)
    while not app_process.lines.empty():  # nothing but the runs stopped: no traceback
        assert app_process.lines.get().startswith("grubler app: the page of a simulate run left")


def test_a_request_body_is_framed_as_it_says_or_refused_at_once(app):
    import socket

    port = app.server_address[1]
    app.client_timeout = 0.5  # a body that does not come within this is given up on

    def raw(head: str, body: bytes = b"") -> str:
        with socket.create_connection(("127.0.0.1", port), timeout=60) as sock:
            sock.sendall(f"POST /api/files HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
                         f"Content-Type: application/json\r\n{head}\r\n".encode() + body)
            reply = b""
            while chunk := sock.recv(65536):  # the server closes the connection after a refusal
                reply += chunk
        return reply.decode()

    for head, status, field in (("Content-Length: -1\r\n", 400, "Content-Length"),
                                ("Content-Length: 2x\r\n", 400, "Content-Length"),
                                ("Content-Length: 2\r\nContent-Length: 3\r\n", 400, "Content-Length"),
                                ("Content-Length: 99999999999999\r\n", 413, "Content-Length"),
                                ("Transfer-Encoding: chunked\r\n", 411, "Content-Length"),
                                ("Content-Length: 1000\r\n", 408, "request")):  # 2 bytes of 1000 come
        reply = raw(head, b"{}")
        assert reply.startswith(f"HTTP/1.1 {status} "), (head, reply)
        assert json.loads(reply.split("\r\n\r\n", 1)[1])["error"]["field"] == field
    assert "within 0.5 s (1000 bytes were announced)" in reply
    status, out, _ = call(app, "POST", "/api/files", {})
    assert status == 200 and "files" in out


def test_a_command_piped_into_head_ends_quietly():
    import signal
    import subprocess
    import sys

    # `grubler presets | head -0`: its output's reader has gone before it writes
    proc = subprocess.Popen([sys.executable, "-m", "grubler.cli", "presets"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()
    err = proc.stderr.read()
    assert proc.wait(60) == -signal.SIGPIPE and err == b""


# -- requests no page sends, and sessions ----------------------------------------------------------------------
def raw_post(server, action: str, text: str, cookie: str | None = None):
    """(status, parsed JSON, headers) of a POST whose body is sent as given (JSON the page would never send)."""
    conn = http.client.HTTPConnection("127.0.0.1", server.server_address[1], timeout=120)
    h = {"Host": f"127.0.0.1:{server.server_address[1]}", "Content-Type": "application/json"}
    if cookie:
        h["Cookie"] = f"grubler_session={cookie}"
    conn.request("POST", f"/api/{action}", text, h)
    r = conn.getresponse()
    out = json.loads(r.read())
    conn.close()
    return r.status, out, r.headers


def test_json_nested_deep_or_a_key_of_many_parts_is_refused_by_name(app):
    status, out, _ = raw_post(app, "analyse", "[" * 100_000 + "]" * 100_000)
    assert status == 400 and out["error"]["field"] == "request" and "nested too deep" in out["error"]["reason"]
    status, out, _ = raw_post(app, "analyse", '{"scene": ' + '{"a": ' * 500 + "1" + "}" * 501)
    assert status == 400 and out["error"]["field"] == "scene" and "more than 32 levels" in out["error"]["reason"]
    data = actions.preset_data("thesis-fourbar")
    out, _ = post(app, "edit", {"scene": data, "key": ".".join(["link2"] * 20_000), "value": "1"})
    assert out["error"]["field"] == "field" and "has 20000 parts" in out["error"]["reason"]
    out, _ = post(app, "edit", {"scene": data, "key": "link2.a", "value": "0.25"})  # a scene's key still edits
    assert "error" not in out and out["scene"]["link2"]["a"] == 0.25


def test_a_gravity_that_is_not_a_number_is_refused_under_gravity(app):
    data = actions.preset_data("thesis-fourbar")
    text = json.dumps({"scene": {**data, "gravity": float("nan")}})  # Python writes NaN, as JSON does not
    for action in ("analyse", "simulate"):
        status, out, _ = raw_post(app, action, text)
        assert status == 200 and out["error"] == {"field": "gravity", "reason": "must be a finite number, got nan"}
    out, _ = post(app, "edit", {"scene": data, "key": "gravity", "value": "nan"})
    assert out["error"]["field"] == "gravity" and out["scene"]["gravity"] == "nan"  # shown as typed, and why


def test_the_servo_drives_an_open_chain_s_first_joint(tmp_path):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import builds

    builds.dist(tmp_path / "dist", ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
    server = AppServer("127.0.0.1", 0, tmp_path)
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
    try:
        out, _ = post(server, "servo", {"scene": actions.preset_data("triple-pendulum"), "servo": {"t_end": "1"}})
    finally:
        server.shutdown()
        server.server_close()
    assert "error" not in out, out
    assert out["t"][-1] == pytest.approx(1.0) and out["summary"].startswith("1 s at 0.001 s steps")
    assert [c["name"] for c in out["columns"]][:3] == ["error", "setpoint", "response"]


def test_fresh_sessions_push_out_idle_ones_before_a_page_s_results_and_the_page_is_told(app):
    data = actions.preset_data("thesis-fourbar")
    _, _, alice = call(app, "GET", "/")
    post(app, "simulate", {"scene": data, "t_end": 0.2}, cookie=alice)
    for _ in range(70):  # any local client can open sessions: each new one, idle and empty, goes first
        call(app, "GET", "/")
    status, text, _ = call(app, "GET", "/api/result.csv", cookie=alice)
    assert status == 200 and text.startswith("t [s],")
    # room for three, each with a run: the one used least recently goes, and its page is told
    app.max_sessions = 3
    tokens = [alice]
    for _ in range(2):
        _, _, t = call(app, "GET", "/")
        post(app, "simulate", {"scene": data, "t_end": 0.2}, cookie=t)
        tokens.append(t)
    call(app, "GET", "/api/result.csv", cookie=tokens[0])  # alice's page used again: bob's is now the oldest
    call(app, "GET", "/")
    status, out, headers = raw_post(app, "files", "{}", cookie=tokens[1])
    assert status == 200 and headers["X-Grubler-Session"] == "evicted" and "files" in out
    status, out, _ = call(app, "GET", "/api/result.csv", cookie=tokens[0])
    assert status == 200
    status, out, _ = call(app, "GET", "/api/result.csv", cookie="made-up")  # a restart's, or a guess
    assert status == 404 and "does not know this page's session" in out["error"]["reason"]


# -- the analysis on the drawing ----------------------------------------------------------------------------
def test_the_analysis_comes_with_a_scene_or_a_drag_only_when_asked(app):
    from grubler.mechanism.instant import analyse_instant

    data = actions.preset_data("fourbar-crank-rocker")
    out, _ = post(app, "analyse", {"scene": data})
    assert "analysis" not in out  # a drag's cost stays what it was unless the layer is on
    out, _ = post(app, "analyse", {"scene": data, "kinematics": True})
    a = out["analysis"]
    assert a["state"] == "drive at 1 rad/s, steady" and a["drive"] == "theta2"
    assert [c["label"] for c in a["centres"]] == ["I12", "I13", "I14", "I23", "I24", "I34"]
    # the same numbers as the library's, at the sketch's closed position
    scene = scene_from_dict(data)
    m = scene.mechanism
    from grubler.mechanism.assembly import assemble

    ref = analyse_instant(m, assemble(m, m.z_from_q(m.q_ref))[0])
    i13 = next(c for c in a["centres"] if c["label"] == "I13")
    assert i13["at"] == pytest.approx(ref.centres[1].point.tolist(), abs=1e-8)
    assert a["transmission"][0]["deg"] == pytest.approx(ref.transmission[0].angle_deg, abs=1e-3)
    assert 0 < a["transmission"][0]["least_deg"] <= a["transmission"][0]["deg"]
    assert len(a["toggles"]) == 2 and all(len(t["at"]) == 2 for t in a["toggles"])  # a crank-rocker's two
    assert a["advantage"]["output"] == "link4" and a["advantage"]["value"] == pytest.approx(ref.advantage.value)
    assert [f["label"] for f in a["forces"]] == ["link1-link2", "link2-link3", "link3-link4", "link1-link4"]
    trace = next(p for p in a["points"] if p["name"] == "trace")
    assert trace["at"] == pytest.approx(out["curve"][0], abs=1e-6)  # the traced point, where its curve starts
    moved, _ = post(app, "drag", {"scene": data, "handle": "O4", "x": 1.1, "y": 0.1, "live": True,
                                   "kinematics": True})
    o4 = next(h["xy"] for h in moved["handles"] if h["id"] == "O4")
    assert o4 != [1.0, 0.0] and moved["analysis"]["centres"][2]["at"] == pytest.approx(o4, abs=1e-6)  # I14: the pivot
    moved, _ = post(app, "drag", {"scene": data, "handle": "O4", "x": 1.1, "y": 0.1, "live": True})
    assert "analysis" not in moved


def test_a_six_bar_and_a_slider_crank_get_their_centres_at_infinity_and_both_angles(app):
    out, _ = post(app, "analyse", {"scene": actions.preset_data("watt-ii"), "kinematics": True})
    a = out["analysis"]
    assert len(a["centres"]) == 15 and [t["label"] for t in a["transmission"]] == ["mu34", "mu56"]
    assert len(a["forces"]) == 7
    out, _ = post(app, "analyse", {"scene": actions.preset_data("slider-crank"), "kinematics": True})
    i14 = next(c for c in out["analysis"]["centres"] if c["label"] == "I14")
    assert "at" not in i14 and i14["direction"] == pytest.approx([0.0, 1.0])
    assert out["analysis"]["advantage"]["unit"] == "1/m"


def test_a_runs_instant_is_analysed_at_its_state_and_forces(app):
    data = actions.preset_data("slider-crank")
    status, out, cookie = call(app, "POST", "/api/instant", {"scene": data, "at": 0.1})
    assert status == 200
    assert out["error"] == {"field": "at", "reason": "no run of this scene to analyse: simulate it first"}
    post(app, "simulate", {"scene": data, "t_end": 0.3, "torque": 2}, cookie=cookie)
    out, _ = post(app, "instant", {"scene": data, "at": 0.21}, cookie=cookie)
    a = out["analysis"]
    res = simulate(scene_from_dict(data), t_end=0.3, torque=2.0)
    row = int(abs(res.t - a["t"]).argmin())
    assert a["state"] == "run" and abs(a["t"] - 0.21) <= 0.5 * (res.t[1] - res.t[0]) + 1e-12
    res.compute(["reactions"])
    assert a["forces"][0]["f"] == pytest.approx([res["R1_Fx"][row], res["R1_Fy"][row]], rel=1e-6, abs=1e-9)
    assert a["forces"][-1]["f"] == pytest.approx([res["Fx"][row], res["Fy"][row]], rel=1e-6, abs=1e-9)
    crank_pin = next(p for p in a["points"] if p["name"] == "23")
    w, crank = res["theta2_d"][row], res.model.links[0].a  # the pin at the crank's end: speed crank |w|
    assert math.hypot(*crank_pin["v"]) == pytest.approx(crank * abs(w), rel=1e-6)
    other = actions.preset_data("offset-slider-crank")  # the run is of another scene: refused, not drawn wrong
    status, out, _ = call(app, "POST", "/api/instant", {"scene": other, "at": 0.1}, cookie=cookie)
    assert status == 200 and out["error"]["field"] == "at"
    status, out, _ = call(app, "POST", "/api/instant", {"scene": data, "at": "soon"}, cookie=cookie)
    assert status == 200 and out["error"]["field"] == "at"
# -- issue 33 -------------------------------------------------------------------------------------------------
def test_the_run_report_is_named_after_the_scene_that_was_run(app):
    """The session's run of the luffing boom, exported while the page shows the thesis four-bar: the file
    says whose run it holds (it was thesis_fourbar-report.pdf holding the boom's run)."""
    _, _, token = call(app, "GET", "/")
    post(app, "simulate", {"scene": actions.preset_data("luffing-boom"), "t_end": 0.3}, cookie=token)
    conn = http.client.HTTPConnection("127.0.0.1", app.server_address[1], timeout=120)
    conn.request("POST", "/api/export", json.dumps({"kind": "pdf", "scene": actions.preset_data("thesis-fourbar")}),
                 {"Host": f"127.0.0.1:{app.server_address[1]}", "Content-Type": "application/json",
                  "Cookie": f"grubler_session={token}"})
    r = conn.getresponse()
    assert r.read().startswith(b"%PDF") and 'filename="luffing_boom-report.pdf"' in r.getheader("Content-Disposition")


def test_a_cylinder_scene_s_servo_and_sizing_start_from_its_design(app):
    """The luffing boom's servo form starts from examples/cylinder_systems.py's design (a 50/28 mm hydraulic
    cylinder moving lift 0.1 m), and its sizing move is that move as the drive joint makes it: over the
    sized cycle the lift's length runs 1.226 to 1.326 m, as `grubler size luffing-boom --cylinder lift --move
    trapezoid --distance 0.118 --reverse ...` prints; a motor's scene has no cylinder."""
    from grubler.mechanism.simulate import actuator_lines

    out, _ = post(app, "servo_defaults", {"scene": actions.preset_data("luffing-boom")})
    d = out["cylinder"]
    assert (d["cylinder"], d["bore"], d["rod"], d["move"], d["actuator"]) == ("hydraulic", 0.05, 0.028, 0.1, "lift")
    model = actions.scene_from_dict(actions.preset_data("luffing-boom")).mechanism
    z = actions.assemble(model, model.z_from_q(model.q_ref))[0]
    l0 = actuator_lines(model, np.hstack([z, 0 * z])[None, :])[0, 0, 0]
    z[model.free_index(model.drive)] += d["distance"]
    z = actions.assemble(model, z)[0]
    assert actuator_lines(model, np.hstack([z, 0 * z])[None, :])[0, 0, 0] - l0 == pytest.approx(0.1, abs=2e-4)
    sized, _ = post(app, "sizing", {"scene": actions.preset_data("luffing-boom"), "servo": d})
    assert sized["kind"] == "cylinder" and sized["rows"][0]["cylinder"] == "63 mm bore, 100 bar"
    assert "force 7.151 to 13.41 kN" in sized["cycle"]
    out, _ = post(app, "servo_defaults", {"scene": actions.preset_data("thesis-fourbar")})
    assert out["cylinder"] is None and out["motor"]


def test_an_actuator_s_attachment_dragged_moves_its_point_on_its_link(app):
    data = actions.preset_data("luffing-boom")
    a = actions.analyse(data)
    pin = next(h for h in a["handles"] if h["id"] == "actuator[0].to_point")
    # half a metre further along the crank (link 2, at 50 deg): the point's u grows by 0.5, v stays 0
    x, y = pin["xy"][0] + 0.5 * math.cos(math.radians(50)), pin["xy"][1] + 0.5 * math.sin(math.radians(50))
    out, _ = post(app, "drag", {"scene": data, "handle": "actuator[0].to_point", "x": x, "y": y})
    assert out["scene"]["actuator"][0]["to_point"] == [1.7, 0.0]
    moved = next(h for h in out["handles"] if h["id"] == "actuator[0].to_point")
    assert moved["xy"] == pytest.approx([x, y], abs=1e-4)
    assert out["frame"]["actuators"][0][2:4] == pytest.approx([x, y], abs=1e-4)


# -- the force elements: springs, dampers, gas springs, joint springs and friction, loads --------------------
def test_the_force_elements_are_drawn_from_the_animation_s_own_geometry():
    """One rule: the page's zigzag, coil and arrow are the frames' geometry grubler animate draws."""
    from grubler.views.animation import coil, frame_geometry, zigzag

    data = actions.preset_data("gas-spring-boom")
    out = actions.analyse(data)
    scene = scene_from_dict(data)
    m = scene.mechanism
    z = actions.assemble(m, m.z_from_q(m.q_ref), scene.initial_rates)[0]
    geo = frame_geometry(m, z)
    assert len(geo.springs) == len(geo.coils) == len(geo.loads) == 1
    np.testing.assert_allclose(out["frame"]["springs"][0], zigzag(*geo.springs[0]), atol=1e-6)
    (cx, cy, angle), (centre, link_angle) = out["frame"]["coils"][0], geo.coils[0]
    np.testing.assert_allclose([cx, cy, angle], [*centre, link_angle], atol=1e-6)
    # the hinge is theta3's: at pin A, turned as link 3 (the head) is
    a = next(h["xy"] for h in out["handles"] if h["id"] == "A")
    assert [cx, cy] == pytest.approx(a, abs=1e-6) and angle == pytest.approx(float(z[0] + z[1]), abs=1e-6)
    np.testing.assert_allclose(out["frame"]["loads"][0], [*geo.loads[0][0], 0.0, -1.0, 1962.0], atol=1e-6)
    # the payload hangs past the head's tip: a bar carries it there, in the GIFs as on the page
    assert any(b[2:] == pytest.approx(out["frame"]["loads"][0][:2], abs=1e-6) for b in out["frame"]["bars"])
    np.testing.assert_allclose(actions.coil_shape(), coil((0, 0), 1.0, 0.0), atol=1e-4)
    # a joint spring at a slide is a zigzag along it, from the slide's base to its block
    slide = actions.preset_data("double-slider")
    slide["joint_spring"] = [{"name": "buffer", "joint": "B1", "stiffness": 100.0}]
    frame = actions.analyse(slide)["frame"]
    assert len(frame["springs"]) == 1 and frame["coils"] == []
    assert frame["springs"][0][-1] == pytest.approx(frame["blocks"][0][:2], abs=1e-6)


def test_force_elements_are_added_with_every_field_refused_by_name_and_removed(app):
    data = actions.preset_data("fourbar-crank-rocker")
    for kind in ("spring", "joint_spring", "point_load"):
        data, _ = post(app, "add_element", {"scene": data, "kind": kind})
        assert "error" not in data, data
        data = data["scene"]
    out, _ = post(app, "analyse", {"scene": data})
    assert len(out["frame"]["springs"]) == len(out["frame"]["coils"]) == len(out["frame"]["loads"]) == 1
    # a new element does nothing at the start: the spring at its free length, the torsion spring relaxed
    scene = scene_from_dict(data)
    res = simulate(scene, t_end=0.01)
    res.compute(["energy"])
    assert abs(res["spring1_force"][0]) < 1e-6 and abs(res["joint_spring1_effort"][0]) < 1e-2
    # every field of each, with the unit of its kind (a revolute's torsion spring in N m/rad)
    units = {f["key"]: f["unit"] for f in out["fields"]}
    assert units["spring[0].damping"] == "N s/m" and units["spring[0].gas_force"] == "N"
    assert units["joint_spring[0].stiffness"] == "N m/rad" and units["joint_spring[0].friction"] == "N m"
    assert units["point_load[0].force"] == "N" and units["point_load[0].point"] == "m"
    # a field left out of a table is in the form at the reader's value, and set there
    del data["spring"][0]["damping"]
    out, _ = post(app, "analyse", {"scene": data})
    assert next(f for f in out["fields"] if f["key"] == "spring[0].damping")["value"] == 0.0
    # bad values refused by the scene reader's rules (grb_scene_check), naming the field
    for key, value, words in [("spring[0].stiffness", "-5", "stiffness must be >= 0"),
                              ("spring[0].to_link", "ground", "must be another link than from_link"),
                              ("joint_spring[0].friction", "-1", "friction must be >= 0"),
                              ("point_load[0].link", "9", "")]:
        out, _ = post(app, "edit", {"scene": data, "key": key, "value": value})
        assert out["error"]["field"] == key and words in out["error"]["reason"], out["error"]
    out, _ = post(app, "add_element", {"scene": data, "kind": "rubber_band"})
    assert out["error"]["field"] == "element"
    out, _ = post(app, "remove_element", {"scene": data, "element": "spring[3]"})
    assert out["error"]["field"] == "element"
    out, _ = post(app, "remove_element", {"scene": data, "element": "spring[0]"})
    assert "spring" not in out["scene"] and out["frame"]["springs"] == [] and len(out["frame"]["coils"]) == 1
    assert not any(h["id"].startswith("spring[") for h in out["handles"])


def test_a_spring_s_end_and_a_load_s_point_dragged_move_their_points_on_their_links(app):
    data = actions.preset_data("gas-spring-boom")
    a = actions.analyse(data)
    pin = next(h for h in a["handles"] if h["id"] == "spring[0].to_point")
    # a quarter metre further along the jib (link 2, at 50 deg): the point's u grows by 0.25, v stays 0
    x, y = pin["xy"][0] + 0.25 * math.cos(math.radians(50)), pin["xy"][1] + 0.25 * math.sin(math.radians(50))
    out, _ = post(app, "drag", {"scene": data, "handle": "spring[0].to_point", "x": x, "y": y})
    assert out["scene"]["spring"][0]["to_point"] == [1.45, 0.0]
    assert out["frame"]["springs"][0][-1] == pytest.approx([x, y], abs=1e-4)
    out, _ = post(app, "drag", {"scene": data, "handle": "spring[0].from_point", "x": 1.0, "y": -0.4})
    assert out["scene"]["spring"][0]["from_point"] == [1.0, -0.4]
    load = next(h for h in a["handles"] if h["id"] == "point_load[0].point")
    out, _ = post(app, "drag", {"scene": data, "handle": "point_load[0].point", "x": load["xy"][0],
                                "y": load["xy"][1] + 0.1})
    assert out["frame"]["loads"][0][:2] == pytest.approx([load["xy"][0], load["xy"][1] + 0.1], abs=1e-4)


def test_a_run_s_graphs_have_the_elements_forces_energies_and_the_balance_that_holds_them(app):
    data = actions.preset_data("gas-spring-boom")
    out, _ = post(app, "simulate", {"scene": data, "t_end": 3})
    assert out["elements"] == [{"name": "strut", "kind": "spring"}, {"name": "hinge", "kind": "joint_spring"},
                               {"name": "payload", "kind": "point_load"}]
    cols = {c["name"]: c for c in out["columns"]}
    values = {n: np.frombuffer(__import__("base64").b64decode(c["f32"]), "<f4") for n, c in cols.items()}
    for name in ("strut_force", "strut_energy", "strut_dissipation", "hinge_effort", "hinge_energy",
                 "payload_power"):
        assert name in cols, name
    assert cols["strut_force"]["unit"] == "N" and cols["strut_energy"]["unit"] == "J"
    # a revolute's torsion spring reads in N m (its joint decides: not 'N m or N'), its angle in SI radians
    # as every column the server sends (the page shows it in the angle unit its user chose: static/units.js)
    assert cols["hinge_effort"]["unit"] == "N m" and cols["hinge_effort"]["label"].endswith("(hinge_effort), N m")
    assert cols["hinge_position"]["unit"] == "rad" and cols["hinge_speed"]["unit"] == "rad/s"
    # the library's own numbers, as the CLI writes them
    res = simulate(scene_from_dict(data), t_end=3)
    res.compute(["energy"])
    np.testing.assert_allclose(values["strut_force"], res["strut_force"], rtol=1e-6)
    # the balance holds the elements: E rose by the payload's work (some 100 J), the balance stays at the
    # output grid's quadrature error
    rise = values["E"].max() - values["E"][0]
    assert rise > 100
    assert np.abs(values["energy_balance"]).max() < 1e-3 * rise
    assert cols["energy_balance"]["unit"] == "J" and "energy balance" in cols["energy_balance"]["label"]


def test_every_preset_takes_each_new_element_relaxed_at_its_start():
    for name in preset_names():
        data = actions.preset_data(name)
        for kind, column in (("spring", "_force"), ("joint_spring", "_effort"), ("point_load", "_power")):
            added = actions.add_element(data, kind)
            scene = scene_from_dict(added)  # the reader takes what Add wrote
            element = next(e for e in scene.mechanism.forces if e.name == added[kind][-1]["name"])
            res = simulate(scene, t_end=0.02, dt_out=0.01)
            res.compute(["energy"])
            values = res[element.name + column]
            assert np.all(np.isfinite(values)), (name, kind)
            if kind == "spring":  # at its free length: no force but what its damper gives the start's rate
                assert abs(values[0]) < 1e-6 * element.stiffness, (name, values[0])  # a micrometre off
# -- the drawing tools' server side (issue 33 item 4) ------------------------------------------------------
def test_a_run_s_columns_reach_the_page_in_si_with_their_words():
    """The page converts to the units its user chose (static/units.js): the server sends SI and the words."""
    _, view = actions.run_simulation(actions.preset_data("fourbar-crank-rocker"), 0.1, None, None)
    theta2 = next(c for c in view["columns"] if c["name"] == "theta2")
    assert theta2["unit"] == "rad" and theta2["words"] == "angle of link 2 (theta2)"
    values = np.frombuffer(__import__("base64").b64decode(theta2["f32"]), dtype="<f4")
    assert values[0] == pytest.approx(math.radians(30), abs=1e-6)


def test_a_servo_run_s_frames_are_the_mechanism_at_its_recorded_drive_angles():
    """runs.drive_frames: each frame the sketch assembled with its drive where the run had it, on the sketch's
    branch (the coupler-rocker pin as the kinematics place it), and the frames stop where the loop opens."""
    from grubler.app.runs import drive_frames
    from grubler.mechanism.assembly import assemble
    from grubler.mechanism.kinematics import link_points

    data = actions.preset_data("fourbar-crank-rocker")
    m = scene_from_dict(data).mechanism
    t = np.linspace(0, 1, 11)
    drive = math.radians(30) + np.linspace(0, 2, 11)  # past a turn's third: the crank turns fully
    out = drive_frames(data, t, drive)
    assert out["frame_t"] == pytest.approx(t.tolist()) and len(out["frames"]) == 11
    for row, frame in zip(drive, out["frames"]):
        crank = frame["bars"][0]  # O2 to A
        angle = math.atan2(crank[3] - crank[1], crank[2] - crank[0])
        assert angle == pytest.approx(math.remainder(row, 2 * math.pi), abs=1e-5)  # a frame's points: to a micrometre
    # the last frame's coupler-rocker pin where the kernel places it on the sketch's branch, assembled afresh
    z = assemble(m, m.z_from_q(m.q_ref))[0]
    for row in drive:  # small steps from the sketch, as the run went
        z[m.free_index(m.drive)] = row
        z = assemble(m, z)[0]
    b = link_points(m, z[None, :], [1], [(m.links[1].a, 0.0)])[0, 0]
    assert out["frames"][-1]["bars"][1][2:] == pytest.approx(b.tolist(), abs=2e-6)
    # a Grashof triple-rocker's drive cannot turn fully: its frames stop where the loop opens
    rocker = {**data, "mechanism": {**data["mechanism"], "ground": 1.4}}
    out = drive_frames(rocker, t, math.radians(30) + np.linspace(0, math.pi, 11))
    assert 0 < len(out["frames"]) < 11 and len(out["frame_t"]) == len(out["frames"]) == len(out["path"])


def test_a_force_element_s_links_and_joint_are_menus_of_the_mechanism_s_own(app):
    """The form offers a spring's ends the ground and the moving links, a load the moving links, a torsion
    spring the real joints; a link the mechanism lacks (as a file may say) stays in its menu, refused next to it."""
    data = actions.preset_data("stephenson-i")
    for kind in ("spring", "joint_spring", "point_load"):
        data = actions.add_element(data, kind)
    data["point_load"][0]["link"] = 9
    out, _ = post(app, "analyse", {"scene": data})
    form = {f["key"]: f for f in out["fields"]}
    links = ["link2", "link3", "link4", "link5", "link6"]
    assert form["spring[0].from_link"]["choices"] == ["ground"] + links
    assert form["joint_spring[0].joint"]["choices"] == ["theta2", "theta3", "theta4", "theta5", "theta6"]
    assert form["point_load[0].link"]["choices"] == links + ["link9"]
    assert form["point_load[0].link"]["value"] == "link9" and out["scene"]["point_load"][0]["link"] == 9
    assert out["error"]["field"] == "point_load[0].link"


def test_the_analysis_carries_the_force_elements_forces_and_a_load_s_magnitude(app):
    """A spring's force (the run's <name>_force at that state) at both its ends along its line, a load's force at
    its point, and each drawn load's magnitude in its frame row."""
    data = actions.preset_data("gas-spring-boom")
    out, _ = post(app, "analyse", {"scene": data, "kinematics": True})
    assert out["frame"]["loads"][0][4] == pytest.approx(1962.0)
    strut = [f for f in out["analysis"]["element_forces"] if f["label"] == "strut"]
    payload = [f for f in out["analysis"]["element_forces"] if f["label"] == "payload"]
    assert payload[0]["f"] == [0.0, -1962.0] and payload[0]["at"] == pytest.approx(out["frame"]["loads"][0][:2])
    # at a run's instant, moving (its damper working): the run's own strut_force there
    res = simulate(scene_from_dict(data), t_end=0.5)
    res.compute(["forces"])
    at = actions.run_instant(data, res, 0.25)["analysis"]
    row = int(np.argmin(abs(res.t - at["t"])))
    assert abs(res["strut_rate"][row]) > 0.01
    strut = [f for f in at["element_forces"] if f["label"] == "strut"]
    assert math.hypot(*strut[0]["f"]) == pytest.approx(abs(res["strut_force"][row]), rel=1e-9)
    assert strut[0]["f"] == pytest.approx([-v for v in strut[1]["f"]])
    # pushing apart (a gas strut's force is positive): the to-end's arrow points away from the from-end
    a, b = np.array(strut[1]["at"]), np.array(strut[0]["at"])
    assert res["strut_force"][row] > 0 and np.dot(strut[0]["f"], b - a) > 0
