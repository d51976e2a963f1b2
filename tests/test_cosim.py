"""The co-simulation runner and SSP files: checks, ordering, initialisation, runs.

Runs that load FMUs happen in a child process (``grubler cosim``), judged by the
CSV it wrote, so a crash at interpreter exit (PythonFMU issue 228) cannot hide or
fake a result.  Checking and ordering read model descriptions only.
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import grubler
from grubler import cosim, ssp
from grubler.mechanism.dynamics import Inputs, forward_dynamics

ROOT = Path(__file__).parent.parent


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def mechanism_fmu(tmp_path_factory):
    sys.path.insert(0, str(ROOT))
    import builds

    (path,) = builds.dist(tmp_path_factory.mktemp("dist"), ["Mechanism"])
    return path


def run_cli(*args, timeout=600):
    return subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def read_csv(path):
    """The columns by name: each heading is the name, then its unit in brackets (mechanism.Fx [N])."""
    with open(path) as fh:
        names = [h.split(" [")[0] for h in fh.readline().strip().split(",")]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {n: data[:, j] for j, n in enumerate(names)}


def test_an_ssd_round_trips_and_fmpy_reads_it(mechanism_fmu, tmp_path):
    from fmpy.ssp.ssd import read_ssd

    s = ssp.System("pair", description="two four-bars", start_time=0.0, stop_time=2.5, step=2e-3)
    s.add("a", mechanism_fmu, **{"link2.m": 2.0, "mechanism": "thesis-fourbar", "rtol": 1e-8})
    s.add("b", mechanism_fmu)
    s.connect("a.drive_angle", "b.load_torque")
    s.components["b"].units["load_torque"] = "any"
    s.plots.append(ssp.Plot("angles", ["a.theta2", "b.theta2"]))
    back = ssp.read(s.write(tmp_path / "pair.ssd"))
    assert back.components["a"].parameters == {"link2.m": 2.0, "mechanism": "thesis-fourbar", "rtol": 1e-8}
    assert back.connections == s.connections
    assert (back.start_time, back.stop_time, back.step) == (0.0, 2.5, 2e-3)
    assert back.plots == s.plots
    assert back.source_path(back.components["a"]).resolve() == Path(mechanism_fmu).resolve()
    # the archive carries one copy of the FMU, and fmpy's reader (schema-validated) opens it
    archive = s.write(tmp_path / "pair.ssp")
    ssd = read_ssd(str(archive), validate=True)
    names = [e.name for e in ssd.system.elements]
    assert names == ["a", "b"]
    assert {e.source for e in ssd.system.elements} == {"resources/Mechanism.fmu"}
    assert len(ssd.system.connections) == 1
    params = ssd.system.elements[0].parameterBindings[0].parameterValues[0].parameters
    assert float({p.name: p.value for p in params}["link2.m"]) == 2.0
    again = ssp.read(archive)
    assert again.source_path(again.components["b"]).is_file()


def test_bad_systems_are_reported_by_name_before_anything_runs(mechanism_fmu):
    s = ssp.System("bad")
    s.add("a", mechanism_fmu, **{"link9.m": 1.0, "theta2": 0.3, "link2.mas": 1.0})
    s.add("b", mechanism_fmu)
    s.connect("a.theta2", "ghost.motor_torque")  # no such component
    s.connect("a.no_such_output", "b.motor_torque")  # no such variable
    s.connect("a.theta2", "b.theta3")  # output to output
    s.connect("a.drive_speed", "b.load_torque")  # rad/s to N m
    s.connect("a.Fx", "b.load_torque")  # fed twice
    with pytest.raises(ssp.SystemDescriptionError) as err:
        cosim.run(s, t_end=0.1)
    msg = str(err.value)
    for expected in ("dangling connection a.theta2 -> ghost.motor_torque: no component 'ghost'",
                     "has no variable 'no_such_output'",
                     "b.theta3 is a output, the end of a connection must be an input",
                     "unit mismatch a.drive_speed -> b.load_torque: [rad/s or m/s] to [N m, or N on a slide]",
                     "input b.load_torque is fed twice",
                     "parameter a.link9.m: Mechanism.fmu has no variable 'link9.m'",
                     "parameter a.theta2: it is an output, not a parameter",
                     "parameter a.link2.mas: Mechanism.fmu has no variable 'link2.mas'; did you mean 'link2.m'?",
                     "has no variable 'no_such_output'"):
        assert expected in msg, expected
    missing = ssp.System("missing")
    missing.add("m", "/nonexistent/Mechanism.fmu")
    with pytest.raises(ssp.SystemDescriptionError, match="component m: FMU /nonexistent/Mechanism.fmu not found"):
        cosim.run(missing)


def test_a_loop_is_cut_at_a_state_and_an_algebraic_loop_is_named(mechanism_fmu):
    s = ssp.System("loop")
    s.add("a", mechanism_fmu)
    s.add("b", mechanism_fmu)
    s.connect("b.theta2_dd", "a.motor_torque")  # depends on b's torque now
    s.connect("a.drive_angle", "b.motor_torque")  # a state: the loop is cut here
    s.components["a"].units["motor_torque"] = "any"
    s.components["b"].units["motor_torque"] = "any"
    itf = {n: cosim.FmuInterface.of(Path(mechanism_fmu)) for n in "ab"}
    # the edge out of a's state is the one cut; b's acceleration is fed forward to a
    assert cosim.order(s, itf) == ["b", "a"]
    s.connections[1] = ssp.Connection("a", "theta3_dd", "b", "motor_torque")
    with pytest.raises(ssp.SystemDescriptionError, match="algebraic loop") as err:
        cosim.order(s, itf)
    assert "b.theta2_dd -> a.motor_torque" in str(err.value) and "a.theta3_dd -> b.motor_torque" in str(err.value)


def test_one_mechanism_co_simulated_is_the_library_run(mechanism_fmu, tmp_path):
    s = ssp.System("alone", stop_time=1.0, step=0.01)
    s.add("m", mechanism_fmu, **{"link2.m": 1.5})
    path = s.write(tmp_path / "alone.ssd")
    # the same system as an .ssp archive (FMU inside) runs the same
    archive = s.write(tmp_path / "alone.ssp")
    proc = run_cli(archive, "--csv", tmp_path / "alone_ssp.csv", "--record", "m.theta2")
    assert proc.returncode == 0, proc.stderr
    from_archive = read_csv(tmp_path / "alone_ssp.csv")
    proc = run_cli(path, "--csv", tmp_path / "alone.csv", "--record", "m.theta2,m.Fx")
    assert proc.returncode == 0, proc.stderr
    assert "alone: 1 s at step 0.01 s (gauss-seidel, order m)" in proc.stdout
    got = read_csv(tmp_path / "alone.csv")
    assert list(got) == ["t", "m.theta2", "m.Fx"]
    scene = grubler.load_scene("thesis-fourbar")
    m = scene.mechanism
    from dataclasses import replace
    scene = grubler.mechanism.scene.with_overrides(scene, mechanism=m.replace(
        links=(replace(m.links[0], m=1.5),) + m.links[1:]))
    lib = grubler.simulate(scene, t_end=1.0, dt_out=0.01)
    assert np.allclose(got["t"], lib.t, atol=1e-12)
    assert np.max(np.abs(got["m.theta2"] - lib["theta2"])) < 1e-8  # the library interpolates, the FMU steps to each point
    assert np.max(np.abs(got["m.Fx"] - lib["Fx"])) < 1e-6
    assert np.array_equal(from_archive["m.theta2"], got["m.theta2"])


def test_coupled_inputs_start_consistent_not_at_zero(mechanism_fmu, tmp_path):
    # b's load torque is a's initial crank rate (given as a parameter): b's first
    # accelerations must already feel it
    s = ssp.System("init", stop_time=0.01, step=0.01)
    s.add("a", mechanism_fmu, **{"initial.theta2_d": 2.0})
    s.add("b", mechanism_fmu, load_joint="theta2")
    s.connect("a.drive_speed", "b.load_torque")
    s.components["b"].units["load_torque"] = "any"
    proc = run_cli(s.write(tmp_path / "init.ssd"), "--csv", tmp_path / "init.csv")
    assert proc.returncode == 0, proc.stderr
    got = read_csv(tmp_path / "init.csv")
    sc = grubler.load_scene("thesis-fourbar")
    model = sc.mechanism.replace(load="theta2")
    z0, _ = grubler.assemble(model, model.z_from_q(model.q_ref))
    dyn = forward_dynamics(model, z0, np.zeros(len(z0)), Inputs(0.0, 2.0))
    qdd = model.S @ dyn.zdd
    names = model.coordinate_names
    assert got["b.theta4_dd"][0] == pytest.approx(qdd[names.index("theta4")], rel=1e-6)
    zero = forward_dynamics(model, z0, np.zeros(len(z0)), Inputs(0.0, 0.0))
    assert abs((model.S @ zero.zdd)[names.index("theta4")] - got["b.theta4_dd"][0]) > 1e-3


def test_the_cli_names_the_problem_and_exits_2(mechanism_fmu, tmp_path):
    s = ssp.System("bad")
    s.add("a", mechanism_fmu)
    s.connect("a.drive_speed", "a.motor_torque")
    proc = run_cli(s.write(tmp_path / "bad.ssd"))
    assert proc.returncode == 2
    assert "unit mismatch a.drive_speed -> a.motor_torque" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_bad_parameter_is_named_by_the_fmu_that_refused_it(mechanism_fmu, tmp_path):
    # each instance logs through callbacks of its own: the reason reaches the error of the
    # component it belongs to, not of whichever instance was created last
    s = ssp.System("badparam", stop_time=0.01, step=1e-3)
    s.add("a", mechanism_fmu, **{"link2.m": -2.0})
    s.add("b", mechanism_fmu)
    proc = run_cli(s.write(tmp_path / "badparam.ssd"))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("grubler: error: a: "), proc.stderr
    assert "a: link2.m: mass must be positive" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_report_and_animation_read_a_cosim_csv(mechanism_fmu, tmp_path):
    from grubler.views.runs import coordinates, read_run_csv

    s = ssp.System("alone", stop_time=0.5, step=0.01)
    s.add("arm", mechanism_fmu)
    proc = run_cli(s.write(tmp_path / "alone.ssd"), "--csv", tmp_path / "run.csv")
    assert proc.returncode == 0, proc.stderr
    scene = grubler.load_scene("thesis-fourbar")
    cols = read_run_csv(str(tmp_path / "run.csv"), scene.mechanism)
    lib = grubler.simulate(scene, t_end=0.5, dt_out=0.01)
    assert np.max(np.abs(coordinates(cols, scene.mechanism) - lib.z)) < 1e-8  # the library interpolates, the FMU steps to each point
    assert np.max(np.abs(cols["E"] - lib["E"])) < 1e-8
    for cmd in (["report", tmp_path / "run.csv", "--scene", "thesis-fourbar", "--out", tmp_path / "r.png"],
                ["animate", tmp_path / "run.csv", "--scene", "thesis-fourbar", "--out", tmp_path / "a.gif",
                 "--fps", "10"]):
        p = subprocess.run([sys.executable, "-m", "grubler.cli", *map(str, cmd)], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
    assert (tmp_path / "r.png").stat().st_size > 10_000 and (tmp_path / "a.gif").stat().st_size > 10_000


def test_a_bad_order_or_record_is_named(mechanism_fmu):
    s = ssp.System("two")
    s.add("a", mechanism_fmu)
    s.add("b", mechanism_fmu)
    with pytest.raises(ssp.SystemDescriptionError, match="order a: must name every component once"):
        cosim.run(s, t_end=0.01, step_order=["a"])
    with pytest.raises(ssp.SystemDescriptionError, match="record 'a.nope': not an output of a component"):
        cosim.run(s, t_end=0.01, record=["a.nope"])


@pytest.mark.parametrize("params, status", [({}, 0), ({"link2.m": -1.0}, 2)])
def test_a_cosim_leaves_nothing_in_the_temporary_folder(mechanism_fmu, tmp_path, params, status):
    # issue 13: the archive's and the FMU's extraction folders go, on success and on error
    s = ssp.System("alone")
    s.add("m", mechanism_fmu, **params)
    archive = s.write(tmp_path / "alone.ssp")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", str(archive), "--t-end", "0.01"],
                          capture_output=True, text=True, timeout=600, env={**os.environ, "TMPDIR": str(tmp)})
    assert proc.returncode == status, proc.stderr
    assert list(tmp.iterdir()) == []


def test_a_run_can_be_cancelled_between_steps_and_runs_again_after(mechanism_fmu, tmp_path):
    # the flag is read before each communication step; a stand-in that turns
    # true on its 31st reading stops the run at the start of step 31 (t = 0.3 s)
    from grubler.errors import Cancelled

    class SetOnReading:
        def __init__(self, n):
            self.readings, self.n = 0, n

        def is_set(self):
            self.readings += 1
            return self.readings >= self.n

    s = ssp.System("alone", stop_time=1.0, step=0.01)
    s.add("m", mechanism_fmu)
    path = s.write(tmp_path / "alone.ssd")
    flag = SetOnReading(31)
    with pytest.raises(Cancelled, match=r"^run: cancelled at t = 0\.3 s$"):
        cosim.run(path, cancel=flag)
    assert flag.readings == 31
    # the FMUs were freed: the same system runs to its end right after
    res = cosim.run(path, cancel=SetOnReading(10 ** 9))
    assert res.t[-1] == pytest.approx(1.0)


def test_fmus_unpacked_once_serve_every_run_until_the_file_changes(mechanism_fmu, tmp_path):
    import shutil

    fmu = tmp_path / "M.fmu"
    shutil.copy(mechanism_fmu, fmu)
    s = ssp.System("alone", stop_time=0.2, step=0.01)
    s.add("m", fmu)
    path = s.write(tmp_path / "alone.ssd")
    with cosim.UnpackedFMUs() as unpacked:
        first = cosim.run(path, unpacked=unpacked)
        folder = unpacked[fmu]
        again = cosim.run(path, unpacked=unpacked)
        assert unpacked[fmu] == folder and folder.is_dir()  # not unpacked again
        np.testing.assert_array_equal(first.data, again.data)
        os.utime(fmu, ns=(fmu.stat().st_atime_ns, fmu.stat().st_mtime_ns + 10 ** 9))  # the file changed
        cosim.run(path, unpacked=unpacked)
        assert unpacked[fmu] != folder
    assert not folder.exists() and not unpacked._folders  # close removed every folder


@pytest.mark.parametrize("master", cosim.MASTERS)
def test_a_step_an_fmu_refuses_is_named_with_its_time_and_message(mechanism_fmu, master):
    # the stepping loop is C: a refusal inside it reaches the user as the FMU's own words
    s = ssp.System("refused", stop_time=0.1, step=0.01)
    s.add("calm", mechanism_fmu)
    s.add("m", mechanism_fmu, motor_torque=float("nan"))
    with pytest.raises(cosim.CosimError, match=r"^m: doStep from t = 0 s failed \(status discard\): "
                                               r"m: motor_torque is nan at t = 0 s: inputs must be finite$"):
        cosim.run(s, master=master)


def test_a_profiled_run_times_each_call_and_changes_no_result(mechanism_fmu):
    s = ssp.System("profiled", stop_time=0.2, step=0.01)
    s.add("a", mechanism_fmu, **{"initial.theta2_d": 2.0})
    s.add("b", mechanism_fmu, load_joint="theta2")
    s.connect("a.drive_speed", "b.load_torque")
    s.components["b"].units["load_torque"] = "any"
    plain = cosim.run(s)
    timed = cosim.run(s, profile=True)
    assert plain.profile == {} and np.array_equal(plain.data, timed.data) and np.array_equal(plain.t, timed.t)
    assert set(timed.profile) == {"a", "b"}
    set_a, step_a, get_a = timed.profile["a"]
    set_b, step_b, get_b = timed.profile["b"]
    assert set_a == 0.0 and set_b > 0  # a has no connected input: the loop makes no setReal call for it
    assert min(step_a, step_b, get_a, get_b) > 0 and step_a + step_b < timed.wall_time


def test_an_fmi3_component_is_refused_by_name_not_at_its_binary(mechanism_fmu, tmp_path):
    # an FMI 3.0 FMU keeps its binary under x86_64-linux/...: the FMI 2.0 loader would look
    # for linux64/ and report a missing library, which says nothing of the reason
    from grubler.system.container import export_system

    inner = ssp.System("inner", stop_time=0.01, step=0.01)
    inner.add("m", mechanism_fmu)
    fmi3 = export_system(inner, tmp_path / "Inner3.fmu", fmi_version=3)
    s = ssp.System("outer", stop_time=0.01, step=0.01)
    s.add("nested", fmi3)
    with pytest.raises(ssp.SystemDescriptionError, match=r"component nested: 'Inner3.fmu' is an FMI 3.0 FMU; this "
                                                         r"master runs FMI 2.0 co-simulation FMUs"):
        cosim.run(s)


def test_an_fmu_that_refuses_its_start_time_is_named_and_freed(mechanism_fmu, monkeypatch):
    # (a foreign FMU may refuse fmi2SetupExperiment) the run is refused naming the component, and the instance,
    # which the run never got to hold, is freed at once: not left instantiated, pointing at callbacks that go
    # with the half-made instance, its library loaded
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    plain_setup, plain_free = FMU2Slave.setupExperiment, FMU2Slave.freeInstance
    freed = []

    def setup(self, *args, **kw):
        if self.instanceName == "late":
            raise FMICallException("fmi2SetupExperiment", 3)
        return plain_setup(self, *args, **kw)

    def free(self):
        freed.append(self.instanceName)
        return plain_free(self)

    monkeypatch.setattr(FMU2Slave, "setupExperiment", setup)
    monkeypatch.setattr(FMU2Slave, "freeInstance", free)
    s = ssp.System("refused start", stop_time=0.1, step=0.01)
    s.add("early", mechanism_fmu)
    s.add("late", mechanism_fmu)
    with pytest.raises(cosim.CosimError, match=r"^late: setupExperiment at t = 0 s failed"):
        cosim.run(s)
    assert sorted(freed) == ["early", "late"]
