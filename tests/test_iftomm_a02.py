"""IFToMM benchmark A02, the N-four-bar, against its exact 1-DOF reference (benchmarks/iftomm/a02.py).

Every window is a parallelogram, so in exact arithmetic the whole mechanism moves
as one crank angle phi: the reference is that ODE, integrated by scipy, sharing no
code with the kernel.  At the horizontal position all N loops are singular at once
(the mobility jumps from 1 to N + 1): the change-point passage must keep every
loop on its parallelogram branch.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

import grubler

IFTOMM = Path(__file__).resolve().parent.parent / "benchmarks" / "iftomm"
sys.path.insert(0, str(IFTOMM))
import a02  # noqa: E402


def _errors(n, t_end):
    result, _ = a02.run(n, t_end)
    ours = a02.b0_of(result)
    ref = a02.reference(n, result.t)
    return result, a02.library_error(ours, ref), float(np.max(np.abs(ours - ref)))


@pytest.mark.parametrize("n", [1, 2])
def test_a02_over_the_library_s_20_s_stays_in_the_high_band(n):
    # 20 s: the crank turns over about ten times, passing the singular horizontal twice a turn
    result, library, largest = _errors(n, 20.0)
    assert len(result.t) == a02.OUTPUT_STEPS + 1
    assert library <= a02.HIGH_BAND
    assert largest < 1e-4  # m, m/s: measured some 1e-6
    assert result.stats["passage_count"] >= 10


def test_a02_with_more_than_64_links_runs_and_passes_the_singular_position():
    # N = 33: 67 links, 33 closures, past the kernel's former 64-link bound; over 1 s the crank passes the
    # horizontal once (t = 0.72 s), where 33 loops lose rank together
    result, library, largest = _errors(33, 1.0)
    assert result.z.shape[1] == 67
    assert result.stats["passage_count"] >= 1
    assert library <= a02.HIGH_BAND
    assert largest < 1e-4


def test_every_loop_is_singular_at_the_horizontal_and_the_mobility_jumps_to_n_plus_1():
    # the closures' rank (grubler.mechanism.assembly.freedom: the eigenvalues of J J^T, 10 rows here, past the
    # Jacobi solver's sizes) is 2N at a vertical crank and N at the horizontal
    from grubler.mechanism.assembly import freedom

    n = 5
    scene = grubler.load_scene(a02.scene_text(n))
    z = grubler.simulate(scene, t_end=0.01, dt_out=0.01).z[0].copy()  # assembled: cranks vertical
    assert freedom(scene.mechanism, z) == 1
    # cranks down a quarter turn to level; each coupler, level still, turns back the quarter against its crank
    z[[a02.crank_link(i) - 2 for i in range(n + 1)]] -= np.pi / 2
    z[[a02.coupler_link(i) - 2 for i in range(1, n + 1)]] += np.pi / 2
    assert freedom(scene.mechanism, z) == n + 1


def test_the_shipped_scene_is_the_generator_s_n_40():
    assert (IFTOMM / "a02_nfourbar.toml").read_text() == a02.scene_text(40)
    scene = grubler.load_scene(IFTOMM / "a02_nfourbar.toml")
    assert scene is not None


@pytest.mark.slow
def test_the_native_fmu_of_a_67_link_a02_passes_the_singular_position(tmp_path):
    # the native FMU runs the same kernel: 67 links, 33 closures, every table in its instance's workspace (no
    # stack array grows with the chain); over 1 s it passes the horizontal (t = 0.72 s) on the parallelogram
    from fmpy import simulate_fmu

    from grubler.fmi.build import export

    path = export(grubler.load_scene(a02.scene_text(33)), tmp_path / "A02n33.fmu", platforms=["linux64"])
    out = simulate_fmu(str(path), stop_time=1.0, output_interval=0.05, output=["theta2", "theta2_d"])
    theta, omega = out["theta2"], out["theta2_d"]
    ours = np.column_stack([np.cos(theta), np.sin(theta), -np.sin(theta) * omega, np.cos(theta) * omega])
    ref = a02.reference(33, out["time"])
    assert np.max(np.abs(ours - ref)) < 1e-4
