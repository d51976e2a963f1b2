"""The command line, used as a person would."""

import csv
import subprocess
import sys

import pytest

from grubler.cli import main


def run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_presets_lists_every_name(capsys):
    code, out, _ = run(capsys, "presets")
    assert code == 0
    for name in ("thesis-fourbar", "thesis-conchoidal", "triple-pendulum", "elliptic-trammel"):
        assert name in out


def test_info_prints_every_angle_in_degrees_with_its_unit(capsys):
    # the branches' angles were bare degrees, the assembled start bare radians
    code, out, _ = run(capsys, "info", "stephenson-i", "--at", "-126.51321969 deg")
    assert code == 0
    assert "drive      theta2  torque 0.05 N m" in out
    assert "branches   4 with theta2 = -126.513 deg" in out
    assert "  [1] theta3 13.9323 deg, theta4 205.27 deg, theta5 85.4599 deg, theta6 233.232 deg" in out
    assert "assembled  B1 = 0 m, theta2 = -126.51322 deg, B2 = 0.0793725393 m, theta3 = 13.9323" in out


def test_info_shows_type_mobility_grashof_and_assembly(capsys):
    code, out, _ = run(capsys, "info", "thesis-fourbar")
    assert code == 0
    assert "crank-rocker" in out and "mobility   1" in out and "s + l = 1.2" in out
    code, out, _ = run(capsys, "info", "thesis-slider-crank")
    assert "theta3 0 deg -> 11.537 deg" in out  # (0.201358 rad)


def test_simulate_writes_the_documented_csv_and_a_plot(capsys, tmp_path):
    csv_path, png = tmp_path / "out.csv", tmp_path / "out.png"
    code, out, _ = run(capsys, "simulate", "thesis-fourbar", "--t-end", "0.5", "--dt-out", "0.1", "--torque", "3",
                       "--csv", str(csv_path), "--plot", str(png), "--reactions")
    assert code == 0
    rows = list(csv.reader(open(csv_path)))
    header = rows[0]  # each heading with its unit
    expected = ["t [s]", "B1 [m]", "theta2 [rad]", "B2 [m]", "theta3 [rad]", "B3 [m]", "theta4 [rad]",
                "B1_d [m/s]", "theta2_d [rad/s]", "B2_d [m/s]", "theta3_d [rad/s]", "B3_d [m/s]", "theta4_d [rad/s]",
                "B1_dd [m/s^2]", "theta2_dd [rad/s^2]", "B2_dd [m/s^2]", "theta3_dd [rad/s^2]", "B3_dd [m/s^2]",
                "theta4_dd [rad/s^2]", "tip_x [m]", "tip_y [m]", "closure_error [m or rad]", "Fx [N]", "Fy [N]",
                "Mz [N m]", "KE [J]", "PE [J]"]
    assert header[: len(expected)] == expected
    assert "R1_Fx [N]" in header and "P_drive [W]" in header
    assert len(rows) == 7
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize("args, field", [
    (["simulate", "no-such-scene"], "scene"),
    (["simulate", "thesis-fourbar", "--t-end", "-1"], "--t-end"),
    (["simulate", "thesis-fourbar", "--torque", "inf"], "--torque"),
    (["simulate", "thesis-fourbar", "--method", "magic"], "--method"),
    (["info", "fourbar-double-rocker", "--bogus"], "--bogus"),
])
def test_bad_input_exits_non_zero_with_one_line(args, field):
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", *args], capture_output=True, text=True)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert field in proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(lines) == 1, proc.stderr


def test_bad_scene_file_names_the_field(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[mechanism]\ntype = "four-bar"\nground = 1\ncrank = 3\ncoupler = 0.8\nrocker = 0.6\n')
    code, _, err = run(capsys, "simulate", str(bad))
    assert code == 2
    assert err.startswith("grubler: error: initial: the loop cannot be closed")
    assert "longest link" in err
    with pytest.raises(Exception):
        main(["--debug", "simulate", str(bad)])


def test_sweep_runs_a_grid_writes_a_table_and_names_bad_axes(capsys, tmp_path):
    out = tmp_path / "sweep.csv"
    code, text, _ = run(capsys, "sweep", "thesis-fourbar", "--set", "link2.a=0.15:0.25:3", "--set",
                        "drive.torque=0,3", "--t-end", "0.2", "--workers", "1", "--out", str(out))
    assert code == 0
    assert "6 points (0 from the journal, 0 failed) on 1 process" in text
    rows = list(csv.DictReader(open(out)))  # headings with units, as on the console
    assert [(r["link2.a [m]"], r["drive.torque [N m]"]) for r in rows][:2] == [("0.15", "0.0"), ("0.15", "3.0")]
    assert "peak_closure_force [N]" in rows[0] and "peak_drive_speed [rad/s]" in rows[0]
    assert text.splitlines()[2].split() == ["[m]", "[N", "m]", "[rad]", "[rad/s]", "[N]"]
    assert all(r["status"] == "ok" for r in rows)
    code, _, err = run(capsys, "sweep", "thesis-fourbar", "--set", "link2.mass=1,2")
    assert code == 2 and "link2.mass: no such parameter of this scene" in err


def test_size_ranks_motors_and_says_why_others_fail(capsys, tmp_path):
    code, text, _ = run(capsys, "size", "thesis-fourbar", "--motors", "maxon-re40-148877", "--ratios", "10,50",
                        "--supply", "48", "--current-limit", "10", "--out", str(tmp_path / "s.csv"))
    assert code == 0
    assert "1 of 2 motor x ratio combinations fit" in text
    assert "1. maxon-re40-148877 x 50" in text
    # the current under the servo's loop (13.47 A for a perfect drive)
    assert "x  maxon-re40-148877 x 10     peak current: needs 13.84 A, limit 10 A" in text
    rows = list(csv.DictReader(open(tmp_path / "s.csv")))  # ranked first, the rejected after
    assert [(r["rank"], r["ratio"], r["feasible"]) for r in rows] == [("1", "50.0", "True"),
                                                                      ("rejected", "10.0", "False")]
    code, _, err = run(capsys, "size", "thesis-fourbar", "--motors", "no-such-motor")
    assert code == 2 and "no-such-motor" in err


@pytest.mark.parametrize("args, message", [
    (["simulate", "thesis-fourbar", "--t-end", "-1"], "--t-end: must be > 0 s, got -1 s"),
    (["size", "thesis-fourbar", "--v-max", "0"], "--v-max: must be > 0 rad/s, got 0 rad/s"),
])
def test_a_bound_message_carries_the_unit(args, message):
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", *args], capture_output=True, text=True)
    assert proc.returncode == 2
    assert message in proc.stderr


@pytest.mark.skipif(not __import__("os").path.exists("/proc/version"), reason="no /proc here (Linux only)")
def test_a_file_that_fails_to_be_written_or_read_is_named_with_its_option(capsys, tmp_path):
    # /proc/version opens for writing and then answers EIO: it was "[Errno 5] Input/output error", naming nothing
    for args, why in ((("simulate", "thesis-fourbar", "--t-end", "0.05", "--csv", "/proc/version"),
                       "--csv: '/proc/version': cannot be written (Input/output error)"),
                      (("simulate", "thesis-fourbar", "--t-end", "0.05", "--plot", "/proc/grubler.png"),
                       "--plot: '/proc/grubler.png': cannot be written"),
                      (("report", "/proc/self/mem", "--out", str(tmp_path / "r.png")),
                       "csv: '/proc/self/mem': cannot be read (Input/output error)"),
                      (("animate", "/proc/self/mem", "--out", str(tmp_path / "a.gif")),
                       "'/proc/self/mem': cannot be read (Input/output error)")):
        code, _, err = run(capsys, *args)
        assert code == 2 and len(err.strip().splitlines()) == 1 and why in err, (args, err)
        assert "Errno" not in err


# -- --at: one reading for info and linearize ------------------------------------------------------
@pytest.mark.parametrize("at", ["30 deg", "30deg", "theta2=30deg", "theta2 = 30 deg", "theta2=pi/6"])
def test_at_is_read_alike_by_info_and_linearize(capsys, at):
    code, out, err = run(capsys, "info", "thesis-fourbar", "--at", at)
    assert code == 0, err
    assert "assembled  B1 = 0 m, theta2 = 30 deg, B2 = 0 m, theta3 = 51.7369795 deg" in out
    code, out, err = run(capsys, "linearize", "thesis-fourbar", "--at", at)
    assert code == 0, err
    assert "operating point: equilibrium: theta2 = 30 deg (0.523599 rad)" in out


def test_at_names_what_it_cannot_take(capsys):
    code, _, err = run(capsys, "info", "thesis-fourbar", "--at", "theta3=30deg")
    assert code == 2 and err.strip() == ("grubler: error: --at: theta3 is not the drive joint: info sets the drive's "
                                         "value (theta2=VALUE, or the VALUE alone)")
    for command in ("info", "linearize"):
        code, _, err = run(capsys, command, "thesis-fourbar", "--at", "theta2=30")
        assert code == 2 and err.startswith("grubler: error: --at: '30' has no unit"), err
        code, _, err = run(capsys, command, "thesis-fourbar", "--at", "foo=3 deg")
        assert code == 2 and "'foo' is not a joint coordinate" in err, err


def test_reactions_say_they_are_csv_columns_and_need_a_csv(capsys):
    code, _, err = run(capsys, "simulate", "thesis-fourbar", "--t-end", "0.1", "--reactions")
    assert code == 2 and err.strip() == ("grubler: error: --reactions: adds the joints' reaction columns to the CSV: "
                                         "give --csv FILE (the plot and the printed table do not show them)")
    _, out, _ = run(capsys, "simulate", "--help")
    helptext = " ".join(out.split())
    assert "R1_Fx, R1_Fy, R1_Mz" in helptext and "to the --csv file" in helptext and "not in the plot" in helptext
