"""The IFToMM benchmark problems shipped in benchmarks/iftomm/, against their references.

A01 (the simple pendulum) against the exact pendulum (Jacobi elliptic functions);
A03 (Andrews' squeezing mechanism) against the Bari test set's published angles at
t = 0.03 s and against an independent reference written in the test set's own
coordinates (benchmarks/iftomm/andrews_reference.py, no grubler code).  The
tolerances are several times what the runs reach here (docs/iftomm.md), so that
no verdict hangs on rounding.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

IFTOMM = Path(__file__).resolve().parents[1] / "benchmarks" / "iftomm"
sys.path.insert(0, str(IFTOMM))

import a01  # noqa: E402
import a03  # noqa: E402
import andrews_reference  # noqa: E402


def test_a01_pendulum_is_in_the_high_band_against_the_exact_pendulum():
    # 2000 s, 4000 output steps: the library's high band is 1e-3 m; at rtol 1e-10 the run reaches 6e-6
    res = a01.run(1e-10)
    assert len(res.t) == a01.STEPS + 1 and res.t[-1] == pytest.approx(2000.0)
    err = a01.errors(res)
    assert err["error"] < 1e-4
    # and the exact pendulum is the one the scene describes: a looser run drifts off it, by far more
    assert a01.errors(a01.run(1e-6))["error"] > 10 * err["error"]


def test_a01_period_read_off_the_run_is_the_elliptic_period():
    # T = 4 K(m) / w, m = sin^2(pi / 4): 2.3678 s, against 2.006 s for the small-swing pendulum
    T = a01.period()
    assert T == pytest.approx(2.367841947576, abs=1e-9)
    res = a01.run(1e-10, t_end=20 * T, dt_out=0.01)
    xd = -np.sin(res["theta2"]) * res["theta2_d"]
    crossings = a01.upward_crossings(res.t, res["tip_x"], xd)
    assert len(crossings) >= 19
    assert abs(np.mean(np.diff(crossings)) - T) < 1e-8


@pytest.fixture(scope="module")
def independent():
    q, _, residual = andrews_reference.solve(0.03)
    assert np.max(np.abs(residual)) < 1e-12  # its own closures hold
    return q


def test_a03_independent_reference_reproduces_the_published_digits(independent):
    # two codes that share only the data: the independent one meets the published angles to 1e-9 rad ...
    assert np.max(np.abs(independent - a03.PUBLISHED)) < 5e-9


def test_a03_andrews_matches_the_independent_reference_and_the_published_one(independent):
    angles = a03.final_angles(a03.run(1e-12))
    # ours and the independent reference: about 3e-12 rad here
    assert np.max(np.abs(angles - independent)) < 1e-10
    # the published angles: 1.4e-9 rad (ten significant digits), the same for both codes
    assert np.max(np.abs(angles - a03.PUBLISHED)) < 5e-9
    assert min(a03.digits(angles, a03.PUBLISHED)) > 9.0
    # and the difference is a time offset: every angle's is its published rate times 1.0e-12 s
    offset = (a03.PUBLISHED - angles) / a03.PUBLISHED_RATES
    assert np.all(np.abs(offset - 1.0e-12) < 0.1e-12)


def test_a03_published_angles_are_the_solution_a_picosecond_later():
    res = a03.run(1e-12, t_end=0.03 + 1.0e-12)
    assert np.max(np.abs(a03.final_angles(res) - a03.PUBLISHED)) < 1e-10


def test_a03_angle_map_reads_the_scene_start_as_the_test_set_start():
    res = a03.simulate(a03.load_scene(a03.SCENE), t_end=1e-6, dt_out=1e-6)
    start = a03.test_set_angles({k: float(res[f"theta{k}"][0]) for k in range(2, 9)})
    assert np.max(np.abs(start - andrews_reference.Q0)) < 1e-14
    # the spring's length at the start, from its column and from the test set's points
    d = andrews_reference.point(andrews_reference.D_, andrews_reference.Q0)
    assert res["spring_length"][0] == pytest.approx(math.hypot(d[0] - 0.014, d[1] - 0.072), abs=1e-14)


def test_a03_script_writes_the_seven_angles_as_json(tmp_path, capsys):
    out = tmp_path / "a03.json"
    assert a03.main(["--repeat", "1", "--json", str(out), "--no-independent"]) == 0
    data = json.loads(out.read_text())
    assert list(data["angles"]) == ["beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon"]
    assert data["t"] == 0.03
    for name, value in data["published"].items():
        assert abs(data["angles"][name] - value) < 5e-9
        assert data["digits_published"][name] > 9.0
    assert data["cpu_s"] > 0 and data["cpu_s_0_05"] > 0
    assert "CPU time" in capsys.readouterr().out


def test_a03_energy_balance_over_the_library_run_of_0_05_s():
    # no damping: E - E(0) is the drive's work, 0.033 N m times the crank's turn (1.12 J by 0.05 s); 8e-13 J here
    assert a03.energy_drift(1e-12) < 1e-9


def test_a03_film_plots_the_spring_force_under_the_squeezer(tmp_path):
    # as a user films it: the spring's force is one of simulate's columns, so --signals takes it
    from grubler.cli import main as cli

    out = tmp_path / "a03.gif"
    assert cli(["animate", str(a03.SCENE), "--out", str(out), "--speed", "0.01", "--fps", "10",
                "--signals", "theta2,spring_force"]) == 0
    assert out.stat().st_size > 0
