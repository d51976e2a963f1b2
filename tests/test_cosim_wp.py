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
