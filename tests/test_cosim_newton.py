"""The Newton master (``cosim.run(..., master="newton")``): each step iterated to its fixed point with rollback.

On the cylinder slider-crank (examples/cylinder_systems.py), a hydraulic coupling
stiff at the step, against its monolithic reference (tests/cylinder_reference.py,
written apart from the FMUs) over 1 s: at a 10 ms step Gauss-Seidel stops, having
said the coupling made energy, where the Newton master runs to the end within
7.9e-5 m of the reference; at 1 ms it is 7.3e-8 m from it (Gauss-Seidel: 9.8e-6 m)
and at 0.5 ms 2.2e-8 m.  The bounds below carry a margin of 3 or more over those
measurements (docs/cosim.md).  No timing is checked.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import pytest

from grubler import cosim
from grubler.system import coupling
from grubler.system.instance import UnpackedFMUs, interfaces_of

ROOT = Path(__file__).resolve().parent.parent
T_END = 1.0


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import builds
    import cosim_wp

    d = tmp_path_factory.mktemp("dist")
    builds.dist(d, ["HydraulicCylinder", "PID", "Trajectory"])
    case = cosim_wp.SYSTEMS["cylinder_slider_crank"](d, T_END)
    case.unpacked = cosim.UnpackedFMUs()
    yield cosim_wp, case, d
    case.unpacked.close()


def run(case, step, master, **kw):
    return cosim.run(case.system, t_end=case.t_end, step=step, master=master, record=[case.signal],
                     unpacked=case.unpacked, **kw)


def test_newton_iterates_the_cylinder_and_the_mechanism_on_their_continuous_connections(bench):
    _, case, _ = bench
    with UnpackedFMUs() as unpacked:
        itf = interfaces_of(case.system, unpacked)
    seq = cosim.order(case.system, itf) if not case.system.order else case.system.order
    plan, said = coupling.newton_plan(case.system, itf, seq)
    assert said == []
    assert plan.sampled == {"controller"} and plan.order[0] == "controller"  # the PID samples first
    assert plan.iterated == {"cylinder", "mechanism"}  # the trajectory steps once: nothing iterated feeds it
    assert sorted(plan.unknowns) == ["cylinder.force", "mechanism.cylinder_length", "mechanism.cylinder_rate"]


def test_at_10_ms_gauss_seidel_diverges_and_newton_holds_the_reference(bench):
    cosim_wp, case, _ = bench
    with pytest.raises(cosim.CosimError, match=r"^diverged at cylinder\.force -> mechanism\.cylinder_force"):
        run(case, 1e-2, cosim.GAUSS_SEIDEL)
    r = run(case, 1e-2, cosim.NEWTON)
    assert r.master == "newton" and r.diverged is None
    assert r.t[-1] == pytest.approx(T_END)
    assert cosim_wp.error(case, r.t, r[case.signal]) < 3e-4  # measured 7.9e-5 m
    # the step's iteration met its tolerance at every step, in a few evaluations
    c = r.coupling
    assert c["steps"] == 100 and c["unconverged"] == 0 and c["worst_residual"] <= coupling.NEWTON_TOL
    assert 2 <= c["evaluations"] / c["steps"] <= 6, c  # measured 3.3


def test_newton_converges_at_second_order_far_below_gauss_seidel(bench):
    cosim_wp, case, _ = bench
    gs = cosim_wp.error(case, *(lambda r: (r.t, r[case.signal]))(run(case, 1e-3, cosim.GAUSS_SEIDEL)))
    errors, counts = [], []
    for h in (1e-3, 5e-4):
        r = run(case, h, cosim.NEWTON)
        errors.append(cosim_wp.error(case, r.t, r[case.signal]))
        counts.append(r.coupling)
    assert errors[0] < 3e-7 and errors[0] < gs / 30, (errors, gs)  # measured 7.3e-8 m against 9.8e-6 m
    assert errors[1] < errors[0] / 2.2, errors  # 3.3x for half the step: order 1.7
    for c in counts:
        # a kept Jacobian serves many steps, and a step takes a guess and one or two Newton updates
        assert c["unconverged"] == 0 and c["jacobians"] < c["steps"] / 10, c
        assert 1 < c["evaluations"] / c["steps"] < 4, c  # measured 1.7 and 1.4


def test_the_cli_runs_newton_and_says_what_it_took(bench, tmp_path):
    _, case, _ = bench
    ssd = case.system.write(tmp_path / "slider.ssd")
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", str(ssd), "--t-end", "0.1", "--step", "0.01",
                           "--master", "newton"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    head = proc.stdout.splitlines()[0]
    assert "(newton, order controller -> cylinder -> mechanism -> trajectory; " in head, head
    assert " evaluations a step, " in head and " Jacobians)" in head, head


def test_a_component_without_fmu_state_runs_gauss_seidel_and_says_so(bench, tmp_path):
    from test_coupling import without_fmu_state

    _, case, d = bench
    foreign = without_fmu_state(d / "HydraulicCylinder.fmu", tmp_path / "ForeignCylinder.fmu")
    s = dataclasses.replace(case.system, components=dict(case.system.components))
    s.components["cylinder"] = dataclasses.replace(s.components["cylinder"], source=str(foreign))
    r = cosim.run(s, t_end=0.05, step=1e-3, master="newton", record=[case.signal])
    plain = cosim.run(s, t_end=0.05, step=1e-3, master="gauss-seidel", record=[case.signal])
    assert r.master == "gauss-seidel" and r.coupling == {}
    assert r.warnings == ["master newton: cylinder cannot get and set its FMU state (canGetAndSetFMUstate), which "
                          "iterating a step needs to roll back: running Gauss-Seidel, without iteration"]
    assert (r.data == plain.data).all()
    ssd = s.write(tmp_path / "foreign.ssd")
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", str(ssd), "--t-end", "0.01", "--master",
                           "newton"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("warning: master newton: cylinder cannot get and set its FMU state") == 1, proc.stderr
    assert "(gauss-seidel, order" in proc.stdout and "evaluations" not in proc.stdout, proc.stdout
