"""The extrapolating master and its error control, on the servo four-bar with the encoder's quantisation off.

Judged against one monolithic simulation (tests/servo_reference.py), as test_servo.py
judges Gauss-Seidel: the crank angle at every controller sample instant.  The
numbers the bounds come from are in docs/cosim.md (0.2 s here, the bounds with a
margin of 3 or more over what was measured).
"""

import dataclasses
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from servo_reference import monolithic

from grubler import cosim
from grubler.system import coupling
from grubler.system.servo import servo_system

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent / "examples"))
import servo_fourbar  # noqa: E402

T_END = 0.2
DESIGN = dataclasses.replace(servo_fourbar.DESIGN, encoder={"counts_per_rev": 0, "Ts": 1e-3})  # quantisation off
RECORD = ["mechanism.drive_angle", "motor.current"]


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    sys.path.insert(0, str(HERE.parent))
    import build_fmu

    d = tmp_path_factory.mktemp("dist")
    build_fmu.build(d, ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
    return d


@pytest.fixture(scope="module")
def reference():
    return monolithic(DESIGN, T_END)


@pytest.fixture(scope="module")
def system(fmu_dir):
    return servo_system(DESIGN, fmu_dir)


def crank_error(ref, r) -> float:
    t = r.t
    k = np.round(t / 1e-3)
    on = np.abs(t / 1e-3 - k) < 1e-6  # the reference's sample instants
    return float(np.max(np.abs(r["mechanism.drive_angle"][on] - ref["drive_angle"][k[on].astype(int)])))


def test_the_servo_couples_its_motor_and_mechanism_at_the_midpoint_and_its_laws_as_sampled(system, fmu_dir):
    from grubler.system.instance import UnpackedFMUs, interfaces_of

    with UnpackedFMUs() as unpacked:
        itf = interfaces_of(system, unpacked)
    seq = ["encoder", "controller", "motor", "mechanism", "trajectory"]
    assert coupling.sampled_components(system, itf) == {"encoder", "controller"}
    modes = coupling.input_modes(system, itf, seq)
    ends = {name: [c.end_connector for c in system.connections if c.end_element == name] for name in seq}
    by_input = {f"{n}.{i}": m for n in seq for i, m in zip(ends[n], modes[n])}
    assert by_input == {
        "encoder.position": coupling.HELD,             # a sampled law reads the sample instant
        "controller.setpoint": coupling.HELD, "controller.measurement": coupling.HELD,
        "motor.voltage": coupling.HELD,                # a discrete output: piecewise constant, held exactly
        "motor.shaft_speed": coupling.EXTRAPOLATED,    # the mechanism steps after the motor
        "mechanism.motor_torque": coupling.INTERPOLATED,  # the motor stepped first: its end value is known
    }


def test_extrapolate_is_second_order_where_gauss_seidel_is_first(system, reference):
    steps = (5e-4, 2.5e-4, 1.25e-4)
    ext = [crank_error(reference, cosim.run(system, t_end=T_END, step=h, master="extrapolate", record=RECORD))
           for h in steps]
    gs = [crank_error(reference, cosim.run(system, t_end=T_END, step=h, record=RECORD)) for h in steps]
    # halving the step divides the error by 2^p: p = 2 for the midpoint, 1 for the held start value
    for coarse, fine in zip(ext, ext[1:]):
        assert 3.3 < coarse / fine < 4.7, ext
    for coarse, fine in zip(gs, gs[1:]):
        assert 1.6 < coarse / fine < 2.4, gs
    assert ext[-1] < gs[-1] / 10, (ext, gs)


def test_extrapolate_at_1_ms_is_closer_than_gauss_seidel(system, reference):
    gs = crank_error(reference, cosim.run(system, t_end=T_END, step=1e-3, record=RECORD))
    ext = crank_error(reference, cosim.run(system, t_end=T_END, step=1e-3, master="extrapolate", record=RECORD))
    assert ext < gs / 1.5, (ext, gs)


@pytest.mark.parametrize("tol, bound", [(1e-5, 1e-6), (1e-8, 1e-8)])
def test_a_tolerance_holds_the_crank_within_it_at_a_1_ms_step(system, reference, tol, bound):
    gs = crank_error(reference, cosim.run(system, t_end=T_END, step=1e-3, record=RECORD))
    r = cosim.run(system, t_end=T_END, step=1e-3, tol=tol, record=RECORD)
    err = crank_error(reference, r)
    assert r.master == "extrapolate" and r.warnings == []
    assert err < bound and err < gs / 100, (err, gs)
    # the steps of the sampled laws are kept: a row at every millisecond, the sub-steps counted
    assert np.allclose(np.diff(r.t), 1e-3) and r.coupling["substeps"] > len(r.t) - 1
    assert r.coupling["tol"] == tol and 0 < r.coupling["worst_estimate"] <= tol


def test_the_old_masters_are_the_python_gauss_seidel_loop_bit_for_bit(system):
    # the C loop's Gauss-Seidel branch, next to the new one, still makes the calls the Python loop made
    from grubler.system.instance import UnpackedFMUs, interfaces_of

    h, n = 1e-3, 50
    r = cosim.run(system, t_end=n * h, step=h, record=["mechanism.drive_angle"])
    with UnpackedFMUs() as unpacked:
        itf = interfaces_of(system, unpacked)
        seq = r.order
        slot = cosim._slots(system)
        values = (cosim.ctypes.c_double * len(slot))()
        insts = {}
        try:
            for name in seq:
                cosim._set_up(insts, system, itf[name], name, unpacked, 0.0, slot, [])
            cosim._initialise_all(insts, seq, values, 0.0)
            angle = [values[slot["mechanism.drive_angle"]]]
            for k in range(n):
                for name in seq:
                    insts[name].push(values)
                    assert insts[name].fmu.fmi2DoStep(insts[name].fmu.component, k * h, h, True) == 0
                    insts[name].publish(values)
                angle.append(values[slot["mechanism.drive_angle"]])
        finally:
            for inst in insts.values():
                inst.free()
    assert np.array_equal(r["mechanism.drive_angle"], np.array(angle))


def without_fmu_state(fmu: Path, out: Path) -> Path:
    """A copy of an FMU whose model description says it cannot get and set its state (a foreign one's)."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'canGetAndSetFMUstate="true"', b'canGetAndSetFMUstate="false"')
            dst.writestr(item, data)
    return out


def test_a_component_without_fmu_state_runs_the_fixed_step_and_says_so(system, fmu_dir, tmp_path):
    foreign = without_fmu_state(fmu_dir / "DCMotor.fmu", tmp_path / "ForeignMotor.fmu")
    s = dataclasses.replace(system, components=dict(system.components))
    s.components["motor"] = dataclasses.replace(s.components["motor"], source=str(foreign))
    r = cosim.run(s, t_end=0.05, step=1e-3, tol=1e-8, record=RECORD)
    fixed = cosim.run(s, t_end=0.05, step=1e-3, master="extrapolate", record=RECORD)
    assert r.warnings == ["tol 1e-08: motor cannot get and set its FMU state (canGetAndSetFMUstate), which "
                          "sub-steps with an error estimate need to roll back: running the extrapolating master "
                          "at the fixed step 0.001 s, without error control"]
    assert r.coupling == {} and np.array_equal(r.data, fixed.data)
    # the command line says it too, one warning line, and runs on (exit 0)
    ssd = s.write(tmp_path / "foreign.ssd")
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", str(ssd), "--t-end", "0.01", "--tol",
                           "1e-8"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("warning: tol 1e-08: motor cannot get and set its FMU state") == 1, proc.stderr
    assert "(extrapolate, order" in proc.stdout and "sub-steps" not in proc.stdout


@pytest.mark.parametrize("kw, message", [
    ({"tol": 0.0}, "tol: must be a number from 1e-14 to 0.5, got 0.0"),
    ({"tol": float("nan")}, "tol: must be a number from 1e-14 to 0.5, got nan"),
    ({"tol": "1e-6"}, "tol: must be a number from 1e-14 to 0.5, got '1e-6'"),
    ({"tol": 1e-6, "master": "gauss-seidel"},
     "tol: the adaptive step is the extrapolating master's (master 'extrapolate'), got master 'gauss-seidel'"),
])
def test_a_bad_tolerance_is_named(system, kw, message):
    with pytest.raises(cosim.SystemDescriptionError) as exc:
        cosim.run(system, t_end=0.01, **kw)
    assert str(exc.value) == message


def test_the_cli_refuses_a_bad_tolerance_in_one_line(system, tmp_path):
    ssd = system.write(tmp_path / "servo.ssd")
    for args, words in ((["--tol", "2"], "argument --tol: must be <= 0.5, got 2"),
                        (["--tol", "1e-6", "--master", "jacobi"], "tol: the adaptive step is the extrapolating")):
        proc = subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", str(ssd), *args], capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 2 and words in proc.stderr and "Traceback" not in proc.stderr, proc.stderr


def test_a_sample_time_between_communication_points_is_said(system):
    s = dataclasses.replace(system, components=dict(system.components))
    s.components["controller"] = dataclasses.replace(s.components["controller"],
                                                     parameters={**s.components["controller"].parameters, "Ts": 2.5e-3})
    r = cosim.run(s, t_end=0.01, step=1e-3, tol=1e-4, record=RECORD)
    assert r.warnings == ["tol 0.0001: controller's sample time Ts (0.0025 s) is not a whole number of steps "
                          "(0.001 s): its samples fall inside a communication step"]
    assert cosim.run(s, t_end=0.01, step=5e-4, tol=1e-4, record=RECORD).warnings == []


def test_the_cli_runs_a_tolerance_and_says_what_it_took(system, tmp_path):
    ssd = system.write(tmp_path / "servo.ssd")
    out = tmp_path / "servo.csv"
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", str(ssd), "--t-end", "0.02", "--tol", "1e-6",
                           "--csv", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    head = proc.stdout.splitlines()[0]
    assert "(extrapolate, order encoder -> controller -> motor -> mechanism -> trajectory; tol 1e-06: " in head, head
    assert " sub-steps, " in head and " rejected)" in head
    assert len(out.read_text().splitlines()) == 1 + 21  # a row per communication step: the sampled laws' 1 ms


def test_a_step_refused_inside_a_sub_step_is_named_with_its_time_and_message(fmu_dir):
    from grubler import ssp

    s = ssp.System("refused", stop_time=0.1, step=0.01)
    s.add("calm", fmu_dir / "Mechanism.fmu")
    s.add("m", fmu_dir / "Mechanism.fmu", motor_torque=float("nan"))
    with pytest.raises(cosim.CosimError, match=r"^m: doStep from t = 0 s failed \(status discard\): "
                                               r"m: motor_torque is nan at t = 0 s: inputs must be finite$"):
        cosim.run(s, tol=1e-6)


def test_an_fmu_the_master_may_roll_back_is_told_so_at_every_step(system, monkeypatch):
    # FMI 2.0: noSetFMUStatePriorToCurrentPoint true lets an FMU drop what a rollback needs, so a step the
    # adaptive master may undo says false; the fixed-step masters, which never roll back, still say true
    import ctypes

    from grubler.system.instance import _Instance

    flags: dict[str, set[int]] = {}
    keep = []
    do_step_type = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int)
    plain = _Instance.loop_view

    def spied(self, *args, **kw):
        view = plain(self, *args, **kw)
        real = do_step_type(view.do_step)

        def do_step(instance, t, h, no_prior, name=self.name):
            flags.setdefault(name, set()).add(no_prior)
            return real(instance, t, h, no_prior)

        keep.append(do_step_type(do_step))
        view.do_step = ctypes.cast(keep[-1], ctypes.c_void_p).value
        return view

    monkeypatch.setattr(_Instance, "loop_view", spied)
    cosim.run(system, t_end=0.005, tol=1e-6, record=RECORD)
    assert flags == {"encoder": {1}, "controller": {1}, "motor": {0}, "mechanism": {0}, "trajectory": {0}}
    flags.clear()
    cosim.run(system, t_end=0.005, master="extrapolate", record=RECORD)
    assert set(flags) == {"encoder", "controller", "motor", "mechanism", "trajectory"}
    assert all(f == {1} for f in flags.values()), flags


def test_under_a_tolerance_only_a_sample_time_bounds_the_step(system):
    # at 5 ms Gauss-Seidel is warned of the motor's mechanical time constant (the speed held over a step);
    # under a tolerance the motor and the mechanism sub-step, and only the PID's and encoder's 1 ms are said
    plain = cosim.run(system, t_end=0.01, step=5e-3, record=RECORD).warnings
    sub = cosim.run(system, t_end=0.01, step=5e-3, tol=1e-4, record=RECORD).warnings
    assert any("mechanical time constant" in w for w in plain), plain
    assert len(sub) == 2 and all("sample time Ts" in w for w in sub) and not any("mechanical" in w for w in sub), sub
