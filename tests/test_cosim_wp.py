"""The co-simulation work-precision benchmark (benchmarks/cosim_wp.py), in quick mode.

The cylinder slider-crank against its monolithic reference (tests/cylinder_reference.py,
written apart from the FMUs) at two communication steps: grubler's Gauss-Seidel
error must fall with the step, about as a first-order coupling's does, and at
0.1 ms the co-simulation and the reference must agree to a micrometre of the
cylinder's length (measured: 9.8e-6 m at 1 ms, 9.7e-7 m at 0.1 ms), which a
wrong sign or constant in either would break.  No timing is checked.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import cosim_wp

    d = tmp_path_factory.mktemp("dist")
    import build_fmu

    build_fmu.build(d, ["HydraulicCylinder", "PID", "Trajectory"])
    case = cosim_wp.SYSTEMS["cylinder_slider_crank"](d, 1.0)
    return cosim_wp, case, tmp_path_factory.mktemp("runs")


def test_gauss_seidel_converges_to_the_monolithic_reference_of_the_cylinder_slider_crank(bench):
    cosim_wp, case, tmp = bench
    coarse, fine = (cosim_wp.measure(case, "grubler, Gauss-Seidel", h, tmp) for h in (1e-3, 1e-4))
    assert not coarse.failure and not fine.failure, (coarse.failure, fine.failure)
    assert fine.error < coarse.error / 4, (coarse.error, fine.error)
    assert fine.error < 2e-6, fine.error
    table = cosim_wp.table([case], [coarse, fine])
    assert "| cylinder_slider_crank | 0.1 ms | grubler, Gauss-Seidel |" in table


def test_a_master_that_fails_is_a_row_that_says_so(bench):
    """At 10 ms the mechanism FMU's step fails under Gauss-Seidel: the point records why, not an error."""
    cosim_wp, case, tmp = bench
    p = cosim_wp.measure(case, "grubler, Gauss-Seidel", 1e-2, tmp)
    assert "mechanism" in p.failure and not p.walls
    assert "failed: " in cosim_wp.table([case], [p])


def test_the_equal_error_table_reads_each_masters_time_off_its_curve():
    """Made-up curves: the coarsest step within the error is interpolated towards the next coarser run, a
    curve that has stopped falling is 'not reached', and the speed-up is the other master's time over ours."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import cosim_wp

    P = cosim_wp.Point
    points = [P("s", "grubler, newton", 1e-2, 1e-5, [0.1]), P("s", "grubler, newton", 1e-3, 1e-7, [1.0]),
              P("s", "slow", 1e-3, 1e-4, [1.0]), P("s", "slow", 1e-4, 1e-5, [10.0]),
              P("s", "stuck", 1e-3, 7e-3, [1.0]), P("s", "stuck", 1e-4, 6.9e-3, [10.0]),
              P("s", "broken", 1e-3, failure="step failed")]
    assert cosim_wp.time_to_reach(points, "s", "slow", 1e-5) == (pytest.approx(10.0), "interpolated")
    w, how = cosim_wp.time_to_reach(points, "s", "grubler, newton", 1e-6)
    assert how == "interpolated" and abs(w - 10 ** -0.5) < 1e-9  # halfway in log between 1e-5 and 1e-7
    assert cosim_wp.time_to_reach(points, "s", "grubler, newton", 1e-3) == (
        0.1, "at most (the coarsest run, 10 ms, is within it)")
    assert cosim_wp.time_to_reach(points, "s", "stuck", 1e-5)[1] == "not reached (best 0.0069 at the steps run)"
    assert cosim_wp.time_to_reach(points, "s", "broken", 1e-5)[1] == "not reached"
    # a coarse run far off that took longer (a diverging one) is no curve to read: fmpy's loop on the cylinder
    odd = [P("s", "odd", 1e-3, 0.5, [5.0]), P("s", "odd", 1e-4, 0.1, [1.0])]
    assert cosim_wp.time_to_reach(odd, "s", "odd", 0.2) == (1.0, "at most (the 0.1 ms run; the coarser one took longer)")
    assert cosim_wp.time_to_reach(odd, "s", "odd", 1e-3)[1] == "not reached (best 0.1 at the steps run)"
    cosim_wp.TARGETS["s"] = (1e-5,)
    try:
        text = cosim_wp.equal_error([cosim_wp.Case("s", None, "", "m", 1.0, None)], points)
    finally:
        del cosim_wp.TARGETS["s"]
    assert "| s | 1e-05 m | slow | 10 s (interpolated) | 100x |" in text, text
    # the table a run wrote reads back as the points it came from
    again = cosim_wp.read_table(cosim_wp.table([cosim_wp.Case("s", None, "", "m", 1.0, None)], points))
    assert [(p.master, p.step, p.error, p.wall, p.failure) for p in again if not p.failure] == [
        (p.master, p.step, float(f"{p.error:.2e}"), p.wall, "") for p in points if not p.failure]
