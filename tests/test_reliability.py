"""Issue 13: bad input never crashes, hangs, runs code or answers wrongly.

Each test feeds one of the failures the issue lists to the command line (in this
process, through :func:`grubler.cli.run`) or to the library, and checks the
contract: exit 2 with a line naming the field and the reason, or a right answer;
nothing left in the temporary folder.
"""

import functools
import json
import re
import os
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from grubler import GrublerError, SceneError, limits
from grubler.cli import run
from grubler.errors import InputError, LimitError
from grubler.mechanism.scene import load_scene, override, preset_text
from grubler.studies.sweep import run_sweep, scene_point

ROOT = Path(__file__).parent.parent
SSD_HEAD = ('<?xml version="1.0" encoding="UTF-8"?>\n<ssd:SystemStructureDescription '
            'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
            'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
            'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="x">')


@pytest.fixture
def private_tmp(tmp_path, monkeypatch):
    """A temporary folder of this test's own (other processes share /tmp), checked empty at the end."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    yield tmp
    assert not list(tmp.iterdir()), f"left in the temporary folder: {list(tmp.iterdir())}"


def cli(capsys, *args):
    code = run([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def refused(capsys, *args, field: str, reason: str = ""):
    code, out, err = cli(capsys, *args)
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "error:" in lines[0] and field in lines[0], lines[0]
    assert reason in lines[0], lines[0]
    assert len(lines[0]) < 500
    return lines[0]


# -- files ------------------------------------------------------------------------------------
@pytest.mark.parametrize("content, reason", [
    (b"\x00\xff\xfe binary", "a binary file, not text"),
    ("name = 'caf\u00e9'\n".encode("latin-1"), "not UTF-8 text (byte 0xe9"),
    (("a = " + "[" * 3000 + "]" * 3000 + "\n").encode(), "nested 3000 deep"),
    (("[link2]\njoint = 'R'\nm = 1\na = 1" + "0" * 400 + "\n").encode(), "magnitude above 1e+12"),
    (("[link2]\na = 1" + "0" * 5000 + "\n").encode(), "not valid here"),
    (b"[link2\na = 1\n", "not valid TOML"),
])
def test_a_scene_file_that_is_not_a_scene_is_refused_by_name(capsys, tmp_path, content, reason):
    path = tmp_path / "bad.toml"
    path.write_bytes(content)
    refused(capsys, "simulate", path, "--t-end", "0.1", field="", reason=reason)


def test_a_scene_file_whose_name_holds_an_equals_sign_is_read_as_a_file(capsys, tmp_path):
    path = tmp_path / "run=3.toml"
    path.write_text(preset_text("thesis-fourbar").replace('name = "thesis-fourbar"', 'name = "from-the-file"'))
    code, out, _ = cli(capsys, "info", path)
    assert code == 0 and "from-the-file" in out


def test_a_scene_value_too_large_for_a_message_is_not_echoed(capsys, tmp_path):
    path = tmp_path / "big.toml"
    path.write_text(preset_text("thesis-fourbar") + f'\n[link5]\njoint = "R"\nm = 1\na = "{"x" * 10_000_000}"\n')
    line = refused(capsys, "info", path, field="link5.a", reason="cannot read")
    assert "characters)" in line
    path.write_text(preset_text("thesis-fourbar") + f'\n[link5]\na = "{"x" * 24_000_000}"\n')
    refused(capsys, "info", path, field="scene", reason="more than the 16.8 MB this reader accepts")


# -- numbers ----------------------------------------------------------------------------------
def test_a_huge_mass_is_refused_by_its_field_from_a_file_a_sweep_and_the_api(capsys, tmp_path):
    path = tmp_path / "heavy.toml"
    path.write_text(re.sub(r"(\[link3\][^\[]*?\bm = )[^\n]*", r"\g<1>1e308", preset_text("thesis-fourbar")))
    refused(capsys, "simulate", path, field="link3.m", reason="magnitude above 1e+12")
    with pytest.raises(SceneError, match="link2.m: magnitude above"):
        override(load_scene("thesis-fourbar"), {"link2.m": 1e308})
    refused(capsys, "sweep", "thesis-fourbar", "--set", "link2.m=1e308", field="link2.m")


@pytest.mark.parametrize("args, field, reason", [
    (["simulate", "thesis-fourbar", "--rtol", "1e-200"], "--rtol", "must be >= 1e-14"),
    (["simulate", "thesis-fourbar", "--t-end", "1e400"], "--t-end", "finite"),
    (["simulate", "thesis-fourbar", "--torque", "9" * 400], "--torque", "not a number"),
    (["sweep", "thesis-fourbar", "--set", "link2.a=0.2", "--workers", "0"], "--workers", ">= 1"),
    (["size", "thesis-fourbar", "--dwell", "-1"], "--dwell", ">= 0"),
    (["size", "thesis-fourbar", "--efficiency", "1.5"], "--efficiency", "<= 1"),
    (["animate", "thesis-fourbar", "--trace", "link3:nan,0"], "--trace", "expected 'tip'"),
    (["simulate", "thesis-fourbar", "--method", "9" * 400], "--method", "invalid choice"),  # long profile
])
def test_an_option_out_of_range_is_refused_by_name(capsys, args, field, reason):
    refused(capsys, *args, field=field, reason=reason)


# -- sizes ------------------------------------------------------------------------------------
def test_an_output_grid_of_terabytes_is_refused_before_allocating(capsys):
    t0 = time.perf_counter()
    line = refused(capsys, "simulate", "thesis-fourbar", "--t-end", "1e9", "--dt-out", "1e-3",
                   field="--dt-out", reason="TB")
    assert "GRUBLER_MAX_OUTPUT_BYTES" in line
    assert time.perf_counter() - t0 < 5.0


def test_an_animation_of_too_many_frames_is_refused(capsys, tmp_path):
    for source in ("thesis-fourbar", GOOD_CSV(tmp_path)):
        refused(capsys, "animate", source, "--scene", "thesis-fourbar", "--t-end", "0.2", "--speed", "1e-9",
                "--out", tmp_path / "a.gif", field="--speed", reason="frames would take")
    refused(capsys, "animate", "thesis-fourbar", "--fps", "0.001", field="--fps", reason=">= 0.01")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["good.csv"]


def test_a_sweep_grid_too_large_is_refused(capsys):
    refused(capsys, "sweep", "thesis-fourbar", "--set", "link2.a=0.1:0.2:1000000000", field="--set link2.a")
    refused(capsys, "sweep", "thesis-fourbar", "--set", "link2.a=0.1:0.2:1000", "--set", "link3.a=0.5:0.9:1001",
            field="--set", reason="points in the grid")


# -- files to write ---------------------------------------------------------------------------
@pytest.mark.parametrize("args, field, reason", [
    (["simulate", "thesis-fourbar", "--plot", "out.xyz"], "--plot", "cannot write a 'xyz' file"),
    (["simulate", "thesis-fourbar", "--csv", "no/such/folder/x.csv"], "--csv", "does not exist"),
    (["report", "x.csv", "--out", "r.doc"], "--out", "cannot write a 'doc' file"),
    (["animate", "thesis-fourbar", "--out", "a.png"], "--out", "use one of .gif, .mp4"),
    (["sweep", "thesis-fourbar", "--set", "link2.a=0.2", "--out", "t.xlsx"], "--out", ".csv, .parquet"),
])
def test_an_output_the_writer_cannot_make_is_refused_before_the_run(capsys, tmp_path, monkeypatch, args, field,
                                                                    reason):
    monkeypatch.chdir(tmp_path)
    refused(capsys, *args, field=field, reason=reason)
    assert list(tmp_path.iterdir()) == []


# -- run CSVs for animate and report ----------------------------------------------------------
# two closed positions of thesis-fourbar (crank at 1 and 1.1 rad): report and animate
# check that a scene closes the loop a CSV recorded
GOOD = ("t,B1,theta2,B2,theta3,B3,theta4\n0,0,1,0,0.781083538038075,0,-1.1540653915300074\n"
        "0.1,0,1.1,0,0.7595818806141422,0,-1.1467223403571456\n")


def GOOD_CSV(folder: Path) -> Path:
    path = folder / "good.csv"
    path.write_text(GOOD)
    return path


@pytest.mark.parametrize("text, reason", [
    ("", "empty"),
    ("t,theta2\n", "a header and no rows"),
    ("t,theta2\n0,1\n0.1\n", "row 3 has 1 values for 2 columns"),
    ("t,theta2\n0,1\n0.1,nan\n", "row 3, column 'theta2': nan is not a finite number"),
    ("t,theta2\n0,1\n0.1,abc\n", "row 3, column 'theta2': not a number: 'abc'"),
    ("t,theta2\n0,1\n0,2\n", "column 't' must increase, row 3"),
    ("t,t\n0,1\n", "column 't' appears twice"),
    ("x,y\n0,1\n", "no 't' column"),
    ("\x00\x01", "a binary file"),
])
def test_a_run_csv_that_is_not_one_is_refused_by_row_and_column(capsys, tmp_path, text, reason):
    path = tmp_path / "run.csv"
    path.write_text(text)
    refused(capsys, "report", path, "--out", tmp_path / "r.png", field=str(path.name), reason=reason)
    refused(capsys, "animate", path, "--scene", "thesis-fourbar", "--out", tmp_path / "a.gif",
            field=str(path.name), reason=reason)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv"]


def test_a_run_csv_that_is_one_still_makes_a_report(capsys, tmp_path):
    path = tmp_path / "run.csv"
    path.write_text(GOOD)
    code, out, err = cli(capsys, "report", path, "--scene", "thesis-fourbar", "--out", tmp_path / "r.png")
    assert code == 0, err
    assert (tmp_path / "r.png").stat().st_size > 10_000


# -- systems (SSD, SSP) -----------------------------------------------------------------------
def ssd(body: str = "", experiment: str = "", annotation: str = "") -> str:
    ann = (f'<ssd:Annotations><ssc:Annotation type="org.grubler.cosim">{annotation}</ssc:Annotation>'
           '</ssd:Annotations>' if annotation else "")
    return (SSD_HEAD + '<ssd:System name="x"><ssd:Elements><ssd:Component name="a" source="A.fmu">'
            f'{body}</ssd:Component></ssd:Elements></ssd:System>{experiment}{ann}'
            '</ssd:SystemStructureDescription>')


def param(tag: str, value: str) -> str:
    return ('<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" '
            f'name="a"><ssv:Parameters><ssv:Parameter name="k"><ssv:{tag} value="{value}"/></ssv:Parameter>'
            '</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>'
            '</ssd:ParameterBindings>')


@pytest.mark.parametrize("text, field", [
    (ssd(experiment='<ssd:DefaultExperiment startTime="abc"/>'), "DefaultExperiment.startTime: is not a number"),
    (ssd(experiment='<ssd:DefaultExperiment stopTime="1e999"/>'), "DefaultExperiment.stopTime: must be a finite"),
    (ssd(annotation='<Cosim step="0"/>'), "Cosim.step: must be > 0, got 0"),
    (ssd(annotation='<Cosim step="-1e-3"/>'), "Cosim.step: must be > 0"),
    (ssd(param("Real", "fast")), "parameter a.k: 'fast' is not a valid Real"),
    (ssd(param("Integer", "2.5")), "parameter a.k: '2.5' is not a valid Integer"),
    (ssd(param("Boolean", "yes")), "parameter a.k: 'yes' is not a Boolean"),
    ("<" * 100_000, "not valid XML"),
])
def test_an_ssd_attribute_that_is_not_a_number_is_refused_by_name(capsys, private_tmp, tmp_path, text, field):
    path = tmp_path / "s.ssd"
    path.write_text(text)
    refused(capsys, "cosim", path, field=field)


def test_an_ssp_that_is_not_a_zip_is_refused(capsys, private_tmp, tmp_path):
    path = tmp_path / "s.ssp"
    path.write_text("not a zip")
    refused(capsys, "cosim", path, field="s.ssp", reason="not a zip archive")


def test_a_zip_bomb_is_refused_by_ratio_and_by_total_size_and_nothing_stays(capsys, private_tmp, tmp_path,
                                                                           monkeypatch):
    bomb = tmp_path / "bomb.ssp"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("SystemStructure.ssd", ssd())
        zf.writestr("resources/big.bin", b"\0" * (64 * 1024**2))
    assert bomb.stat().st_size < 200_000  # 64 MB in: a ratio near 1000
    refused(capsys, "cosim", bomb, field="bomb.ssp", reason="inflates more than 200 times")
    many = tmp_path / "many.ssp"
    with zipfile.ZipFile(many, "w", zipfile.ZIP_STORED) as zf:
        zf.writestr("SystemStructure.ssd", ssd())
        for k in range(4):
            zf.writestr(f"resources/{k}.bin", os.urandom(300_000))
    monkeypatch.setattr(limits, "ARCHIVE_MAX_BYTES", 1_000_000)
    refused(capsys, "cosim", many, field="many.ssp", reason="more than 1 MB once extracted")


def test_an_archive_member_leaving_the_folder_is_refused(private_tmp, tmp_path):
    evil = tmp_path / "evil.ssp"
    with zipfile.ZipFile(evil, "w") as zf:
        zf.writestr("SystemStructure.ssd", ssd())
        zf.writestr("../../escaped.txt", "x")
    dest = limits.temp_dir("t_")
    try:
        with pytest.raises(InputError, match="would be written outside"):
            limits.extract_zip(evil, dest, "system")
    finally:
        limits.remove_temp_dir(dest)
    assert not (tmp_path / "escaped.txt").exists()


def test_a_cosim_leaves_no_extraction_folder(capsys, private_tmp, tmp_path):
    # an SSP whose FMU is no FMU: read, unpacked, refused; every folder gone
    arch = tmp_path / "s.ssp"
    with zipfile.ZipFile(arch, "w") as zf:
        zf.writestr("SystemStructure.ssd", ssd().replace('source="A.fmu"', 'source="resources/A.fmu"'))
        zf.writestr("resources/A.fmu", "not a zip")
    code, _, err = cli(capsys, "cosim", arch)
    assert code == 2
    assert err.splitlines()[1].strip() == "component a: cannot read resources/A.fmu: not a zip archive"


# -- sweeps ----------------------------------------------------------------------------------
def test_a_sweep_journal_is_of_the_scene_content_not_its_path(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(preset_text("thesis-fourbar"))
    out = tmp_path / "t.csv"
    func = functools.partial(scene_point, str(scene), t_end=0.05)
    first = run_sweep(func, [{"link2.m": 1.0}], out=out, workers=1, progress=False)
    assert first.rows[0]["status"] == "ok"
    scene.write_text(preset_text("thesis-fourbar").replace("[link3]", "[link3]\nm = 7.0", 1))
    with pytest.raises(GrublerError, match="journal is of another sweep"):
        run_sweep(func, [{"link2.m": 1.0}], out=out, workers=1, progress=False)


def header_on_disk(path: Path, x: float) -> dict:
    lines = path.read_text().splitlines()
    return {"header": float(bool(lines) and "sweep" in json.loads(lines[0]))}


def test_the_journal_header_is_on_disk_before_the_first_point(tmp_path):
    out = tmp_path / "t.csv"
    journal = tmp_path / "t.csv.journal.jsonl"
    table = run_sweep(functools.partial(header_on_disk, journal), [{"x": 1.0}], out=out, workers=1, progress=False)
    assert table.rows[0]["header"] == 1.0


def test_an_empty_journal_is_a_fresh_start_and_a_headerless_one_is_named(tmp_path):
    from test_sweep import counted

    out = tmp_path / "t.csv"
    journal = tmp_path / "t.csv.journal.jsonl"
    journal.write_text("")  # killed before the header reached the disk
    run_sweep(counted, [{"x": 1.0}], out=out, workers=1, progress=False)
    again = run_sweep(counted, [{"x": 1.0}, {"x": 2.0}], out=out, workers=1, progress=False)
    assert again.resumed == 1
    journal.write_text('{"x": 1.0, "key": "abc"}\n')
    with pytest.raises(GrublerError, match="not a sweep journal"):
        run_sweep(counted, [{"x": 1.0}], out=out, workers=1, progress=False)


def test_no_resume_keeps_the_finished_points_as_a_backup(tmp_path):
    from test_sweep import counted

    out = tmp_path / "t.csv"
    journal = tmp_path / "t.csv.journal.jsonl"
    run_sweep(counted, [{"x": 1.0}, {"x": 2.0}], out=out, workers=1, progress=False)
    before = journal.read_text()
    run_sweep(counted, [{"x": 3.0}], out=out, workers=1, progress=False, resume=False)
    assert (tmp_path / "t.csv.journal.jsonl.1").read_text() == before
    run_sweep(counted, [{"x": 4.0}], out=out, workers=1, progress=False, resume=False)
    assert (tmp_path / "t.csv.journal.jsonl.2").exists()


def test_a_parameter_set_twice_is_refused_not_dropped(capsys):
    refused(capsys, "sweep", "thesis-fourbar", "--set", "link2.a=0.15", "--set", "link2.a=0.2",
            field="--set link2.a", reason="given twice")


@pytest.mark.parametrize("address", ["tcp://127.0.0.1", "127.0.0.1:8786", "tcp://host:port", "tcp://:8786"])
def test_a_scheduler_address_without_a_port_is_refused(capsys, address):
    refused(capsys, "sweep", "thesis-fourbar", "--set", "link2.a=0.2", "--scheduler", address,
            field="--scheduler", reason="tcp://HOST:PORT")


# -- sizing -----------------------------------------------------------------------------------
def test_a_long_dwell_does_not_hide_the_move(capsys):
    for dwell in ("0.5", "3600"):
        code, out, err = cli(capsys, "size", "thesis-fourbar", "--move", "trapezoid", "--dwell", dwell,
                             "--supply", "48", "--motors", "maxon-re40-148877", "--ratios", "50")
        assert code == 0, err
        assert "speed up to 6.283 rad/s" in out, out


def test_a_need_that_is_not_a_number_never_fits(monkeypatch):
    from grubler.studies import sizing
    from grubler.motors import load_motor
    from grubler.studies.sizing import DutyCycle, size

    m = load_scene("thesis-fourbar").mechanism
    cycle = DutyCycle.constant_speed(2 * np.pi, n=50)
    # a winding temperature that could not be computed (what an overflowing cycle left)
    monkeypatch.setattr(sizing, "periodic_temperature", lambda t, *args: np.full_like(t, np.nan))
    study = size(m, cycle, [load_motor("maxon-re40-148877")], ratios=[50], supply_voltage=48.0)
    (a,) = study.assessments
    assert not a.feasible and study.ranked == []
    assert any("could not be computed" in f for f in a.failures)


def test_a_tiny_speed_limit_is_assessed_without_a_nan_ranked_as_fitting(capsys):
    code, out, err = cli(capsys, "size", "thesis-fourbar", "--move", "trapezoid", "--v-max", "1e-12",
                         "--supply", "48")
    assert code == 0, err
    assert "winding +nan" not in out


# -- Ctrl-C and killed sweeps -----------------------------------------------------------------
def children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(x) for x in out.split()]


def at_a_terminal() -> None:
    """Give a child Ctrl-C's default action, as a terminal's foreground command has.

    A suite started as a background job (``pytest &``, nohup, some CI runners)
    inherits SIGINT ignored, and a program keeps an ignored SIGINT ignored (as
    Python and the shells do): the child would never see the signal these tests send.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def stop(proc: subprocess.Popen, sig: int) -> float:
    """Send ``sig`` and wait for the end; the seconds waited (a child still running after 30 s is killed)."""
    proc.send_signal(sig)
    t0 = time.monotonic()
    try:
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:  # (a sweep of 4000 points must not outlive a failed test)
            proc.kill()
            proc.wait()
    return time.monotonic() - t0


def alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL])
def test_a_sweep_stops_on_ctrl_c_and_its_workers_never_outlive_it(tmp_path, sig):
    # 4000 points, minutes of work on any machine: the signal finds the workers busy
    proc = subprocess.Popen([sys.executable, "-m", "grubler.cli", "sweep", "thesis-fourbar", "--set",
                             "link2.m=1:2:4000", "--t-end", "200", "--workers", "2", "--out", str(tmp_path / "t.csv")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=at_a_terminal)
    deadline = time.monotonic() + 60
    while len(children(proc.pid)) < 2 and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(1.0)  # workers busy with a point
    workers = children(proc.pid)
    assert len(workers) >= 2
    waited = stop(proc, sig)
    _, err = proc.communicate()
    if sig == signal.SIGINT:
        assert proc.returncode == 130 and err.strip().splitlines()[-1] == "grubler: interrupted", err
        assert waited < 1.5
    deadline = time.monotonic() + 5
    while any(alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(alive(w) for w in workers)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="POSIX signals")
def test_ctrl_c_stops_a_long_simulate_within_a_second():
    # the run is inside the C kernel (ctypes releases the GIL): the interrupt watcher ends it, or,
    # past the steps after which the kernel calls back to have its pace watched, the callback;
    # 2e5 s of the free four-bar is some 6 million steps, within the budget (1e6 s is refused)
    proc = subprocess.Popen([sys.executable, "-m", "grubler.cli", "simulate", "thesis-fourbar", "--t-end", "2e5",
                             "--dt-out", "100"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=at_a_terminal)
    time.sleep(5.0)
    assert stop(proc, signal.SIGINT) < 1.5
    err = proc.stderr.read()
    assert (proc.returncode, err.strip().splitlines()) == (130, ["grubler: interrupted"]), err


def test_a_huge_value_is_never_echoed_whole():
    from grubler.controllers import Trajectory

    big = "0 " * 12_000_000 + "x"  # a 24 MB table with one bad entry
    with pytest.raises(SceneError, match="times: must be numbers") as info:
        Trajectory("table", times=big, positions="0 1")
    assert len(str(info.value)) < 1500
    with pytest.raises(SceneError) as info:
        override(load_scene("thesis-fourbar"), {"drive_joint": list(range(3_000_000))})
    assert len(str(info.value)) < 1500


def test_a_link_without_inertia_is_named_not_blamed_on_the_integrator(capsys, tmp_path):
    # found by the fuzz suite: an open chain whose last link is a point mass on its joint
    path = tmp_path / "s.toml"
    path.write_text('[link2]\njoint = "R"\na = 0.25\np = 0.25\nm = 1.0\n[link3]\njoint = "R"\na = 1.0\np = 1.0\n'
                    'm = 2.0\n[link4]\njoint = "R"\na = 0.0\nm = 3.0\n[drive]\njoint = "theta2"\n')
    refused(capsys, "simulate", path, "--t-end", "0.02", field="link4.I", reason="carries no inertia")
    path.write_text(path.read_text().replace("m = 3.0", "m = 3.0\nI = 0.01"))
    assert cli(capsys, "simulate", path, "--t-end", "0.02")[0] == 0


def test_size_check_without_a_current_limit_reaches_the_cosimulation(capsys, tmp_path):
    # 'no current limit' (inf) was coerced to 0 A before the servo system was built, which
    # the drive refused: every --check without --current-limit failed on a field not given
    code, out, err = cli(capsys, "size", "thesis-fourbar", "--supply", "48", "--motors", "maxon-re40-148877",
                         "--ratios", "50", "--check", tmp_path / "no-fmus")
    assert code == 2
    assert "Trajectory.fmu not found" in err and "current_limit" not in err, err


@pytest.mark.parametrize("text, field", [
    ('[mechanism]\ntype = []\n', "mechanism.type"),  # found by the long fuzz profile: a TypeError
    ('[link2]\na = 1\nm = 1\njoint = "R"\n[simulate]\nmethod = ["exact"]\n', "simulate.method"),
])
def test_a_word_given_as_a_list_is_refused_by_name(capsys, tmp_path, text, field):
    path = tmp_path / "s.toml"
    path.write_text(text)
    refused(capsys, "info", path, field=field)


@pytest.mark.parametrize("step, reason", [
    ("2.0", "1 s is shorter than the communication step 2 s"),
    ("1e-320", "communication steps per recorded row"),  # a denormal step: dt_out / step overflowed
])
def test_a_record_interval_against_the_systems_step_is_refused_by_option(capsys, private_tmp, tmp_path, step,
                                                                        reason):
    path = tmp_path / "s.ssd"
    path.write_text(ssd(annotation=f'<Cosim step="{step}"/>'))
    refused(capsys, "cosim", path, "--dt-out", "1.0", field="--dt-out", reason=reason)


def test_an_output_name_too_long_for_the_file_system_is_refused(capsys):
    # found by the long fuzz profile: the OSError escaped argparse's type check
    refused(capsys, "simulate", "thesis-fourbar", "--plot", "out." + "9" * 400, field="--plot",
            reason="File name too long")


def test_a_run_the_integrator_cannot_finish_names_the_integration(capsys, monkeypatch):
    # found by the long fuzz profile: `--t-end 400 --torque -1589` spins the crank so fast that
    # the kernel's 10-million-step guard stops it (after 90 s, too long for here: the guard's
    # message is fed instead, through the same simulate() and CLI layers)
    from grubler import IntegrationError
    from grubler.mechanism.simulate import Simulator

    def stop(self, times):
        self.advance_to(float(times[1]))
        raise IntegrationError("more than 10000000 steps before t = 400 s")

    monkeypatch.setattr(Simulator, "advance_through", stop)
    line = refused(capsys, "simulate", "thesis-fourbar", "--t-end", "400", "--torque", "-1589",
                   field="integration", reason="steps before t = 400 s")
    assert line.startswith("grubler: error: integration: ")


def test_the_output_budget_can_be_raised_and_a_bad_one_is_named(capsys, monkeypatch):
    monkeypatch.setenv("GRUBLER_MAX_OUTPUT_BYTES", "1000")
    refused(capsys, "simulate", "thesis-fourbar", "--t-end", "0.1", field="--dt-out", reason="1 kB budget")
    monkeypatch.setenv("GRUBLER_MAX_OUTPUT_BYTES", "lots")
    refused(capsys, "simulate", "thesis-fourbar", "--t-end", "0.1", field="GRUBLER_MAX_OUTPUT_BYTES")
    monkeypatch.setenv("GRUBLER_MAX_OUTPUT_BYTES", "1e15")
    assert cli(capsys, "simulate", "thesis-fourbar", "--t-end", "0.1")[0] == 0
