"""The rest of the bad-input round: runs that cannot finish, archives that reach outside
themselves, broken FMUs, output options checked late, contradictory answers, interrupts.

Each test fails without the change it holds.
"""

import json
import math
import os
import signal
import subprocess
import sys
import time
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from grubler import ssp
from grubler.cli import run
from grubler.mechanism.scene import load_scene
from grubler.studies.sweep import _square, grid, run_sweep
from test_reliability import ssd

ROOT = Path(__file__).parent.parent


def test_a_journal_torn_mid_line_is_resumed_on_a_fresh_line(tmp_path):
    out = tmp_path / "s.csv"
    points = grid(x=[1.0, 2.0, 3.0, 4.0])
    run_sweep(_square, points, out=out, workers=1, progress=False)
    journal = tmp_path / "s.csv.journal.jsonl"
    lines = journal.read_text().splitlines()
    # killed while writing the third row: the header, two rows and half a line
    journal.write_text("\n".join(lines[:3]) + "\n" + lines[3][: len(lines[3]) // 2])
    table = run_sweep(_square, points, out=out, workers=1, progress=False)
    assert table.resumed == 2 and table.column("y") == [1.0, 4.0, 9.0, 16.0]
    text = journal.read_text()
    assert text.endswith("\n")
    rows = [json.loads(line) for line in text.splitlines()[1:]]  # every line whole
    assert sorted(r["x"] for r in rows) == [1.0, 2.0, 3.0, 4.0]
    # a third run finds every point in the journal
    assert run_sweep(_square, points, out=out, workers=1, progress=False).resumed == 4


@pytest.mark.parametrize("argv, option", [
    (["linearize", "thesis-fourbar", "--json"], "--json"),
    (["linearize", "thesis-fourbar", "--bode"], "--bode"),
    (["export", "thesis-fourbar", "--out"], "--out"),
])
def test_every_output_option_is_checked_before_the_work_and_named(argv, option, tmp_path, capsys, monkeypatch):
    import importlib

    def no_work(*args, **kwargs):
        raise AssertionError("the work ran before its output path was checked")

    # (the package exports a function of the module's name: reach the modules themselves)
    monkeypatch.setattr(importlib.import_module("grubler.studies.linearize"), "linearize", no_work)
    monkeypatch.setattr(importlib.import_module("grubler.fmi.build"), "export", no_work)
    assert run(argv + [str(tmp_path / "missing" / "x.png")]) == 2
    err = capsys.readouterr().err
    assert option in err and "does not exist" in err and len(err.splitlines()) == 1


def _ssd(source: str) -> str:
    return ssd().replace('source="A.fmu"', f'source="{source}"')


@pytest.mark.parametrize("source, reason", [
    ("../A.fmu", "reaches outside the archive"),
    ("resources/../../A.fmu", "reaches outside the archive"),
    ("/opt/A.fmu", "is outside the archive"),
    ("C:/fmus/A.fmu", "is outside the archive"),
    ("file:///opt/A.fmu", "is outside the archive"),
])
def test_an_ssp_names_no_fmu_outside_itself(source, reason, tmp_path, capsys):
    arch = tmp_path / "s.ssp"
    with zipfile.ZipFile(arch, "w") as zf:
        zf.writestr("SystemStructure.ssd", _ssd(source))
        zf.writestr("resources/A.fmu", "an FMU's bytes")
    with pytest.raises(ssp.SystemDescriptionError, match=f"component a: source .* {reason}"):
        ssp.read(arch)
    assert run(["cosim", str(arch)]) == 2
    err = capsys.readouterr().err
    assert reason in err and len(err.splitlines()) == 1
    # inside the archive is where its FMUs are; a .ssd on disk names FMUs beside it or elsewhere
    with zipfile.ZipFile(arch, "w") as zf:
        zf.writestr("SystemStructure.ssd", _ssd("resources/../resources/A.fmu"))
    assert ssp.read(arch).components["a"].source == "resources/../resources/A.fmu"
    (tmp_path / "s.ssd").write_text(_ssd(source))
    assert ssp.read(tmp_path / "s.ssd").components["a"].source == source


@pytest.fixture(scope="module")
def mechanism_fmu(tmp_path_factory):
    sys.path.insert(0, str(ROOT))
    import builds

    (path,) = builds.dist(tmp_path_factory.mktemp("dist"), ["Mechanism"])
    return path


@pytest.mark.slow
def test_an_fmu_whose_binary_cannot_be_loaded_is_one_line_naming_the_component(mechanism_fmu, tmp_path, capsys):
    bad = tmp_path / "Bad.fmu"
    with zipfile.ZipFile(mechanism_fmu) as src, zipfile.ZipFile(bad, "w") as out:
        for member in src.infolist():
            data = src.read(member)
            if member.filename.startswith("binaries/"):  # a 32-bit ELF header on a 64-bit host
                data = b"\x7fELF\x01\x01\x01" + bytes(9) + data[16:]
            out.writestr(member, data)
    system = ssp.System("bad")
    system.add("mech", bad)
    arch = system.write(tmp_path / "bad.ssp")
    cwd = os.getcwd()
    assert run(["cosim", str(arch), "--t-end", "0.01"]) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [
        "grubler: error: mech: the binary of Bad.fmu cannot be loaded: wrong ELF class: ELFCLASS32"]
    assert os.getcwd() == cwd  # not the removed extraction's binaries folder, where fmpy loads


def test_sizing_through_a_change_point_is_refused_by_its_true_reason(capsys):
    # the crank passes theta2 = pi, where coupler and rocker lie in line and two branches meet
    assert run(["size", "fourbar-change-point", "--speed", "1e3"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "trajectory at sample 180 (drive 3.14159)" in line and "change point" in line
    assert "only span" not in line  # the pin at 1.39999 m is inside the 0.4 to 1.4 m span


def test_the_triangle_explanation_runs_only_when_the_triangle_fails():
    from grubler.mechanism.analysis import explain_unclosable

    m = load_scene("fourbar-change-point").mechanism
    z = m.z_from_q(m.q_ref)
    d = m.free_index(m.drive)
    z[d] = math.pi + math.pi / 360  # the pin 1.39999 m from the rocker pivot: the triangle closes
    why = explain_unclosable(m, z, [d])
    assert "only span" not in why and "nearly in line" in why
    z[d] = math.pi / 2
    assert explain_unclosable(m, z, [d]) == ""  # far from the span's edges: no explanation to give
    longer = m.replace(closures=(replace(m.closures[0], to_point=(1.2, 0.0)),))
    z[d] = math.pi  # the pin 1.6 m from the pivot: coupler and rocker reach 1.4 m at most
    assert "only span 0.4 to 1.4 m" in explain_unclosable(longer, z, [d])


def test_a_drive_trajectory_straddling_a_change_point_stays_on_its_branch():
    from grubler.mechanism.inverse import drive_demand

    m = load_scene("fourbar-change-point").mechanism
    # samples that pass theta2 = pi between two of them, not on it
    pos = np.linspace(math.pi / 2, 3 * math.pi / 2, 301)[:300] + 0.0013
    demand = drive_demand(m, pos, np.full_like(pos, 6.0), np.zeros_like(pos))
    # the dependent angles go on smoothly through it (a jump to the other branch is a kink)
    assert np.max(np.abs(np.diff(demand.z, 2, axis=0))) < 1e-3


def test_a_failure_after_the_start_blames_no_link_for_missing_inertia():
    from grubler import IntegrationError, simulate
    from grubler.mechanism.analysis import explain_singular_start

    scene = load_scene("fourbar-parallelogram")
    m = scene.mechanism
    # link2 has I = 0 but its 1 kg 1 m off its joint: its rotation carries 1 kg m2
    assert m.links[0].I == 0 and m.links[0].p == 1.0
    assert explain_singular_start(m, m.z_from_q(m.q_ref), np.zeros(m.n_free), scene.method) == ""
    with pytest.raises(IntegrationError, match="step size fell below .* at t = 0.0"):
        simulate(scene, t_end=0.1, torque=1e9)


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="POSIX signals")
def test_ctrl_c_inside_an_fmus_python_ends_as_interrupted(tmp_path):
    # Ctrl-C while a pythonfmu FMU runs its Python raises KeyboardInterrupt inside its do_step,
    # which the FMU turns into an error status: it must still end as an interrupt, at any moment
    import builds
    from busy_law import Busy

    started = tmp_path / "started"
    system = ssp.System("busy")
    system.add("busy", builds.controller_fmu(Busy, tmp_path), started=str(started))
    arch = system.write(tmp_path / "busy.ssp")
    for k in range(10):
        started.unlink(missing_ok=True)
        proc = subprocess.Popen([sys.executable, "-m", "grubler.cli", "cosim", str(arch), "--t-end", "1e4",
                                 "--step", "1e-3", "--dt-out", "1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True)
        deadline = time.monotonic() + 120
        while not started.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.0137 * k)  # once it steps, at ten different phases of its 2 ms steps
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        assert (proc.returncode, err.strip().splitlines()) == (130, ["grubler: interrupted"]), (k, err[-2000:])


@pytest.mark.parametrize("method", ["exact", "penalty"])
def test_a_run_that_cannot_finish_is_refused_at_its_pace_naming_what_sets_it(method, capsys):
    # the crank spun ever faster: some 1e7 steps before t = 400 s, 90 s of work before the
    # step budget itself ran out; its pace gives it away within the first few seconds of steps
    from grubler import simulate
    from grubler.errors import LimitError

    with pytest.raises(LimitError) as info:
        simulate("thesis-fourbar", t_end=400.0, dt_out=1.0, torque=-1589.0, method=method)
    assert info.value.field == "t_end (--t-end)"
    assert "cannot finish" in info.value.reason and "more than the 10000000 steps allowed" in info.value.reason
    assert "drive torque -1589 N m (--torque)" in info.value.reason
    assert run(["simulate", "thesis-fourbar", "--t-end", "400", "--torque", "-1589", "--method", method]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("grubler: error: t_end (--t-end): the run cannot finish: ")


def test_a_watched_run_takes_the_steps_an_unwatched_one_takes(monkeypatch):
    # past PACE_STEPS a run is watched through the kernel's drive callback: the same steps, bit for bit
    from grubler.mechanism import integrators
    from grubler.mechanism.simulate import simulate

    def run_it():
        res = simulate("thesis-fourbar", t_end=400.0, dt_out=10.0, torque=lambda t: 0.5 * math.sin(t))
        return res.z, res.stats["steps"]

    z, steps = run_it()
    assert steps > 2 * 2000
    monkeypatch.setattr(integrators, "PACE_STEPS", 2000)  # watched from its 2000th step on
    z_watched, steps_watched = run_it()
    assert steps_watched == steps and np.array_equal(z_watched, z)


def test_an_integrator_goes_on_with_its_drive_function_after_a_watched_advance(monkeypatch):
    from grubler.mechanism import integrators
    from grubler.mechanism.simulate import Simulator

    monkeypatch.setattr(integrators, "PACE_STEPS", 200)
    m = load_scene("thesis-fourbar").mechanism
    calls = []

    def torque(t):
        calls.append(t)
        return 0.5

    sim = Simulator(m, drive_function=torque)
    sim.advance_to(50.0)  # past 200 steps: watched
    assert sim._integ.n_steps > 200
    calls.clear()
    sim.advance_to(51.0)  # the user's function is called again, not the watch's
    assert calls and sim.t == 51.0


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="POSIX signals")
def test_ctrl_c_during_a_watched_run_raises_in_the_library(monkeypatch):
    # a watched run calls back into Python at every evaluation, where Python runs the SIGINT
    # handler; its KeyboardInterrupt must stop the run, not be printed and dropped by ctypes
    import threading

    from grubler.mechanism import integrators
    from grubler.mechanism.simulate import simulate

    monkeypatch.setattr(integrators, "PACE_STEPS", 200)  # watched from the start
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            simulate("thesis-fourbar", t_end=1e5, dt_out=100.0)  # some 3 million steps: minutes
    finally:
        timer.cancel()
