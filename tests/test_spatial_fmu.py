"""The native spatial mechanism FMU (c/spatial_model.c over kernel/spatial): the same kernel as
SpatialMechanism, behind the FMI 2.0 and 3.0 wrappers.

References: SpatialMechanism.simulate (the library, the same kernel through ctypes) on the RSSR and the
spherical four-bar, run at communication points that are powers of two so that the FMU's t + h and the
library's output grid are the same doubles; the reactions against SpatialMechanism.reactions; the
directional derivatives against central differences of the outputs; the FMI contract through fmpy,
fmpy's validator and the C host (tests/fmi_host.c) in an empty environment.  Each FMU is built once
(tests/builds.py).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))

import builds  # noqa: E402
from test_native_fmu import ERROR, DISCARD, OK, Host, craft, refused_and_usable, saved_state  # noqa: E402

from grubler.fmi.spatial import fmu_name, spatial_preset  # noqa: E402

# slow: FMU builds and C hosts (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow

PRESETS = ("rssr", "spherical_fourbar")
H = 2.0 ** -7  # a communication step whose multiples are exact: the FMU's t + h is the library's grid
STEPS = 128
TORQUE = {"rssr": 0.5, "spherical_fourbar": 0.2}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(preset, fmi) -> (fmu path, unzipped folder, model description), linux64 binaries."""
    from fmpy import read_model_description

    out = {}
    for preset in PRESETS:
        for fmi in (2, 3):
            d = tmp_path_factory.mktemp(f"{preset}{fmi}")
            path = builds.spatial(preset, d / f"{fmu_name(preset)}.fmu", "linux64", fmi)
            zipfile.ZipFile(path).extractall(d / "x")
            out[preset, fmi] = (path, d / "x", read_model_description(str(path)))
    return out


def slave(built, preset: str, fmi: int = 2, params: dict | None = None):
    """An fmpy slave of the build, its Real parameters set, initialised; and its value references."""
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    path, _, md = built[preset, fmi]
    s = (FMU2Slave if fmi == 2 else FMU3Slave)(guid=md.guid, unzipDirectory=extract(str(path)),
                                               modelIdentifier=md.coSimulation.modelIdentifier, instanceName="s")
    s.instantiate()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    if fmi == 2:
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
    else:
        s.enterInitializationMode(startTime=0.0)
    for name, value in (params or {}).items():
        (s.setReal if fmi == 2 else s.setFloat64)([vr[name]], [value])
    s.exitInitializationMode()
    return s, vr


def get(s, fmi, refs):
    return np.array((s.getReal if fmi == 2 else s.getFloat64)(refs))


def state_refs(m, vr):
    return [vr[x] for x in m.coordinate_names] + [vr[f"{x}_d"] for x in m.coordinate_names]


def run(built, preset: str, fmi: int, names, n: int = STEPS, torque: float | None = None):
    """n steps of H with motor_torque held (and max_step the run's length, as simulate's h_max), the
    outputs ``names`` read after each: the start state and the rows."""
    m = spatial_preset(preset)
    s, vr = slave(built, preset, fmi, {"max_step": n * H})
    y0 = get(s, fmi, state_refs(m, vr))
    (s.setReal if fmi == 2 else s.setFloat64)([vr["motor_torque"]], [TORQUE[preset] if torque is None else torque])
    rows = []
    for i in range(n):
        s.doStep(i * H, H)
        rows.append(get(s, fmi, [vr[x] for x in names]))
    s.terminate()
    s.freeInstance()
    return y0, np.array(rows)


# -- the library's numbers ---------------------------------------------------------------------------

@pytest.mark.parametrize("preset", PRESETS)
def test_the_fmu_in_fmpy_runs_as_spatial_mechanism_simulate(built, preset):
    m = spatial_preset(preset)
    names = [*m.coordinate_names, *(f"{x}_d" for x in m.coordinate_names)]
    joints = [f"{l.name}.{c}" for l in m.links for c in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")]
    y0, rows = run(built, preset, 2, names + ["KE", "PE", "closure_error"] + joints)
    # the start: the preset's sketch closed holding the crank, as assembled_start closes it
    assert np.abs(y0 - m.assembled_start()).max() <= 1e-12
    tau = np.zeros(m.n_coords)
    tau[0] = TORQUE[preset]
    ref = m.simulate(y0, t_end=STEPS * H, dt_out=H, tau=tau)
    n = 2 * m.n_coords
    # the same kernel, steps and output times: the same doubles (measured: 0 on both presets)
    assert np.abs(rows[:, :n] - ref.y[1:]).max() <= 1e-12
    assert np.abs(rows[:, n:n + 2] - ref.energy()[1:]).max() <= 1e-9
    assert rows[:, n + 2].max() < 1e-10  # closed all along
    assert abs(ref.y[-1, 0] - y0[0]) > 1.0  # the crank did turn
    # every joint's reaction at the last state, the library's (the same code over the same state)
    _, library_joints = m.reactions(rows[-1, :n], tau)
    np.testing.assert_allclose(rows[-1, n + 3:], library_joints.ravel(), rtol=0, atol=1e-9 * np.abs(library_joints).max())


@pytest.mark.parametrize("preset", PRESETS)
def test_fmi2_and_fmi3_builds_give_the_same_bits(built, preset):
    m = spatial_preset(preset)
    names = [*m.coordinate_names, "KE", "closure.Fx", f"{m.links[0].name}.Mz"]
    a = run(built, preset, 2, names, n=40)[1]
    b = run(built, preset, 3, names, n=40)[1]
    assert np.array_equal(a, b)


def test_the_model_description_gives_units_and_inputs_on_every_real_joint(built):
    md = built["rssr", 2][2]
    by = {v.name: v for v in md.modelVariables}
    m = spatial_preset("rssr")
    assert [v.name for v in md.modelVariables if v.causality == "input"] == \
        ["motor_torque", *(f"effort.{x}" for x in m.coordinate_names)]
    assert by["effort.crank.theta"].unit == "N.m" and by["crank.theta_d"].unit == "rad/s"
    for link in m.links:
        assert [by[f"{link.name}.{c}"].unit for c in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")] == ["N"] * 3 + ["N.m"] * 3
    assert by["closure.Fz"].unit == "N" and by["KE"].unit == "J" and by["crank.I_zz"].unit == "kg.m2"
    assert by["crank.dh.d"].start == "0.12" and by["coupler.mass"].start == "1.0"
    assert md.coSimulation.providesDirectionalDerivative and md.coSimulation.canSerializeFMUstate


@pytest.mark.parametrize("fmi", [2, 3])
def test_fmpy_validates_it(built, fmi):
    from fmpy.validation import validate_fmu

    for preset in PRESETS:
        assert validate_fmu(str(built[preset, fmi][0])) == [], preset


def test_a_tuned_parameter_is_the_model_the_library_builds_with_it(built):
    # a longer crank set on the FMU: the library's rssr with that crank (its pin, the ball's a, moves out)
    import dataclasses

    from grubler.mechanism import spatial

    m0 = spatial_preset("rssr")
    links = list(m0.links)
    links[1] = dataclasses.replace(links[1], a=0.12)
    links[0] = dataclasses.replace(links[0], com=(0.06, 0.0, 0.0), mass=0.7)
    m = spatial.SpatialMechanism(links, m0.closures, m0.gravity)
    y0 = m.assemble(m0.sketch)
    p = {"coupler1.dh.a": 0.12, "crank.com_x": 0.06, "crank.mass": 0.7, "max_step": 32 * H,
         **{f"initial.{x}": float(v) for x, v in zip(m.coordinate_names, y0)}}
    s, vr = slave(built, "rssr", 2, p)
    start = get(s, 2, state_refs(m, vr))
    s.setReal([vr["motor_torque"]], [0.5])
    for i in range(32):
        s.doStep(i * H, H)
    end = get(s, 2, state_refs(m, vr))
    tau = np.zeros(m.n_coords)
    tau[0] = 0.5
    ref = m.simulate(start, t_end=32 * H, dt_out=H, tau=tau)
    assert np.abs(end - ref.y[-1]).max() <= 1e-12


def test_the_rssr_fmu_set_to_a_change_point_geometry_passes_its_change_points(built):
    # the RSSR FMU's rocker shaft moved to offset 0.26 m and its plane through the shaft's foot (rocker.dh.a,
    # rocker.dh.d): at crank angle 0 the loop has a change point (test_spatial_change_points' change-point RSSR),
    # which the crank passes once a turn; with the coupler's spin an idle freedom the FMU's advance passes it
    # on a chart (before: Discard at the first, "... a change point")
    import dataclasses

    from grubler.mechanism import spatial

    from test_spatial import rssr_equation

    g = dataclasses.replace(spatial.rssr_geometry(), offset=0.26, rocker_d=0.0)
    m = spatial.rssr(geometry=g)
    y0 = m.assemble(spatial._rssr_sketch(g, -2.0))
    n_steps = 256  # 2 s
    p = {"rocker.dh.a": 0.26, "rocker.dh.d": 0.0, "max_step": 0.1,
         **{f"initial.{x}": float(v) for x, v in zip(m.coordinate_names, y0)}}
    s, vr = slave(built, "rssr", 2, p)
    start = get(s, 2, state_refs(m, vr))
    s.setReal([vr["motor_torque"]], [0.2])
    rows = []
    for i in range(n_steps):
        s.doStep(i * H, H)  # fmpy raises on Discard
        rows.append(get(s, 2, state_refs(m, vr) + [vr["KE"], vr["PE"], vr["closure_error"]]))
    s.terminate()
    s.freeInstance()
    rows = np.array(rows)
    phi, psi = rows[:, 0], rows[:, 4]
    assert np.sum(np.diff(np.floor(np.append(start[0], phi) / (2 * np.pi))) != 0) >= 5  # measured 8 in 2 s
    A, B, C = rssr_equation(g, phi)
    assert np.abs(A * np.cos(psi) + B * np.sin(psi) - C).max() < 1e-10  # measured 3.4e-13
    assert rows[:, 12].max() < 1e-10  # measured 4.0e-13
    tau = np.zeros(m.n_coords)
    tau[0] = 0.2
    balance = rows[:, 10] + rows[:, 11] - 0.2 * (phi - start[0])
    assert np.ptp(balance) < 1e-8 * rows[:, 10].max()  # measured 3.1e-9 J of 12.4 J
    ref = m.simulate(start, t_end=n_steps * H, dt_out=H, tau=tau, rtol=1e-10, atol=1e-10)
    assert np.abs(rows[:, :10] - ref.y[1:]).max() <= 1e-12  # the library's advance, its chart kept between steps: measured 0


def test_the_planar_fourbar_as_spatial_runs_as_the_planar_mechanism_fmu(tmp_path):
    # two native FMUs over two kernels that share no equations: the thesis four-bar in Mechanism.fmu and
    # written as spatial (relative angles, gravity along -y) in its spatial FMU, both at 1e-12, 3 N m
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    tight = {"rtol": 1e-12, "atol": 1e-12}
    planar_path = builds.fmu("Mechanism")
    md = read_model_description(str(planar_path))
    pv = {v.name: v.valueReference for v in md.modelVariables}
    p = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(planar_path)), modelIdentifier="Mechanism",
                  instanceName="planar")
    p.instantiate()
    p.setupExperiment(startTime=0.0)
    p.enterInitializationMode()
    p.setReal([pv["rtol"], pv["atol"]], [1e-12, 1e-12])
    p.exitInitializationMode()
    angles = ["theta2", "theta3", "theta4"]
    start = np.array(p.getReal([pv[x] for x in angles] + [pv[f"{x}_d"] for x in angles]))
    relative = np.concatenate([np.diff(start[:3], prepend=0.0), np.diff(start[3:], prepend=0.0)])
    path = builds.spatial("planar-fourbar-3d", tmp_path / "PlanarFourbar.fmu", "linux64")
    m = spatial_preset("planar-fourbar-3d")
    names = list(m.coordinate_names)
    s, sv = slave({("planar-fourbar-3d", 2): (path, None, read_model_description(str(path)))}, "planar-fourbar-3d", 2,
                  {**tight, **{f"initial.{x}": relative[i] for i, x in enumerate(names)},
                   **{f"initial.{x}_d": relative[3 + i] for i, x in enumerate(names)}})
    for x, v in ((p, pv), (s, sv)):
        x.setReal([v["motor_torque"]], [3.0])
    worst = np.zeros(3)
    for i in range(64):
        p.doStep(i * H, H)
        s.doStep(i * H, H)
        planar = np.array(p.getReal([pv[x] for x in angles] + [pv["Fx"], pv["Fy"]]))
        z = np.array(s.getReal([sv[x] for x in names] + [sv["closure.Fx"], sv["closure.Fy"]]))
        worst = np.maximum(worst, [np.abs(np.cumsum(z[:3]) - planar[:3]).max(), abs(z[3] - planar[3]),
                                   abs(z[4] - planar[4])])
    assert abs(planar[0] - start[0]) > 1.0  # the crank turned
    # measured 1.3e-14 rad and 8.2e-14 N over 64 steps of 2^-7 s
    assert worst[0] < 1e-11 and max(worst[1:]) < 1e-9, worst
    for x in (p, s):
        x.terminate()
        x.freeInstance()


# -- state -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("fmi", [2, 3])
def test_a_saved_and_serialised_state_restores_bit_identically(built, fmi):
    m = spatial_preset("rssr")
    s, vr = slave(built, "rssr", fmi)
    refs = state_refs(m, vr) + [vr["crank.Fx"], vr["closure.Fz"]]
    setr = s.setReal if fmi == 2 else s.setFloat64
    setr([vr["motor_torque"]], [0.5])
    for i in range(20):
        s.doStep(i * H, H)
    saved = s.getFMUstate() if fmi == 2 else s.getFMUState()
    blob = s.serializeFMUstate(saved) if fmi == 2 else s.serializeFMUState(saved)
    first = []
    for i in range(20, 40):
        s.doStep(i * H, H)
        first.append(get(s, fmi, refs))
    (s.setFMUstate if fmi == 2 else s.setFMUState)(saved)
    again = []
    for i in range(20, 40):
        s.doStep(i * H, H)
        again.append(get(s, fmi, refs))
    assert np.array_equal(np.array(first), np.array(again))
    # a fresh instance from the serialised bytes steps on the same
    t, _ = slave(built, "rssr", fmi)
    restored = t.deSerializeFMUstate(blob) if fmi == 2 else t.deserializeFMUState(blob)
    (t.setFMUstate if fmi == 2 else t.setFMUState)(restored)
    (t.setReal if fmi == 2 else t.setFloat64)([vr["motor_torque"]], [0.5])
    third = []
    for i in range(20, 40):
        t.doStep(i * H, H)
        third.append(get(t, fmi, refs))
    assert np.array_equal(np.array(first), np.array(third))
    for x in (s, t):
        x.terminate()
        x.freeInstance()


@pytest.fixture(scope="module")
def host():
    return builds.host()


def host_of(host, built, preset: str) -> Host:
    _, d, md = built[preset, 2]
    ident = md.coSimulation.modelIdentifier
    return Host(host, d / "binaries" / "linux64" / f"{ident}.so", md.guid,
                {v.name: v.valueReference for v in md.modelVariables})


def spec_of(preset: str, identifier: str):
    from grubler.fmi.spatial import spatial_spec

    return spatial_spec(spatial_preset(preset), identifier)


def test_crafted_states_are_refused_naming_the_field(host, built, tmp_path):
    h, md = host_of(host, built, "rssr"), built["rssr", 2][2]
    spec = spec_of("rssr", md.coSimulation.modelIdentifier)
    assert spec.guid == md.guid
    good = saved_state(h, md, tmp_path / "good.bin", {"motor_torque": 0.5})
    y = spec.state_slot("y")
    blob = good.read_bytes()
    z0 = np.frombuffer(blob[48 + 8 * y:48 + 8 * (y + 1)], "<f8")[0]
    cases = [
        ({y + 4: z0 + 0.3}, "state.y: the joint state does not close the loops"),  # the rocker moved off the ball
        ({y + 1: float("nan")}, "state.coupler1.theta: the joint state must be finite"),
        ({y + 5 + 4: 1e300}, "state.rocker.theta_d: the joint state must be finite and in range"),
        ({spec.state_slot("h"): -1.0}, "state.h: the next step must be >= 0"),
        ({spec.state_slot("started"): 0.5}, "state.started: must be 0 or 1"),
        ({spec.slot("crank.mass"): -2.0}, "crank.mass: a mass must be >= 0"),
        ({spec.slot("drive_joint"): 9.0}, "drive_joint must be the index of one of its 5 accepted values"),
        ({spec.slot("crank.I_xx"): 5.0}, "crank.I_xx .. crank.I_zz: not a real body's inertia tensor"),
    ]
    for values, field in cases:
        refused_and_usable(h, md, good, tmp_path / "bad.bin", values, field, "crank.theta")


def test_a_state_of_another_spatial_fmu_is_refused(host, built, tmp_path):
    h, md = host_of(host, built, "rssr"), built["rssr", 2][2]
    other = saved_state(host_of(host, built, "spherical_fourbar"), built["spherical_fourbar", 2][2],
                        tmp_path / "other.bin", {})
    t = h.run(h.start(md=md) + [f"deser 1 {other}", "free"])
    assert t.statuses("deser") == [ERROR] and t.logged("the state belongs to another model"), t.logs


# -- bad parameters and inputs -------------------------------------------------------------------------

@pytest.mark.parametrize("name, value, field", [
    ("crank.mass", -1.0, "crank.mass: a mass must be >= 0, got -1"),
    ("coupler.damping_r", -0.1, "coupler.damping_r: a damping must be >= 0"),
    ("crank.I_zz", 1.0, "crank.I_xx .. crank.I_zz: not a real body's inertia tensor"),
    ("rocker.dh.a", float("inf"), "rocker.dh.a: must be finite"),
    ("gravity_z", 1e300, "gravity_z: magnitude above"),
    ("rtol", 0.0, "rtol: must be positive"),
    ("closure.point_z", 5.0, "initial: the loops cannot be closed near this sketch with crank.theta = 0 held"),
    ("drive.inertia", -1.0, "drive.inertia: must be >= 0"),
])
def test_a_bad_parameter_is_an_error_naming_it(host, built, name, value, field):
    h, md = host_of(host, built, "rssr"), built["rssr", 2][2]
    t = h.run(["new 0 m", "setup 0.0", "enter", f"setr {h.vr[name]} {value!r}", "exit", "free"])
    assert t.statuses("exit") == [ERROR] and t.logged(field), t.logs


def test_a_non_unit_closure_axis_is_refused_naming_its_three_parameters(host, built):
    h, md = host_of(host, built, "spherical_fourbar"), built["spherical_fourbar", 2][2]
    t = h.run(["new 0 m", "setup 0.0", "enter", f"setr {h.vr['closure.axis_x']} 0.5", "exit", "free"])
    assert t.statuses("exit") == [ERROR]
    assert t.logged("closure.axis_x, closure.axis_y, closure.axis_z: an axis must be a unit vector"), t.logs


def test_a_non_finite_input_discards_the_step_and_the_run_goes_on(host, built):
    h, md = host_of(host, built, "rssr"), built["rssr", 2][2]
    t = h.run(h.start(md=md) + [f"setr {h.vr['effort.rocker.theta']} nan", "step 0.0 0.01",
                                f"setr {h.vr['effort.rocker.theta']} 0.0", h.run_steps(0.0, 0.01, 3, "crank.theta"),
                                "free"])
    assert t.statuses("step") == [DISCARD] and t.logged("effort.rocker.theta is nan at t = 0 s"), t.logs
    assert t.statuses("run") == [OK] and len(t.rows()) == 3


def test_the_drive_inertia_is_a_disc_on_the_drive_joint(built):
    # J on the crank's axis: the crank's own inertia about its axis grows by J, and the response to a torque
    # is the library's with the crank's tensor given J about z and J / 2 across
    import dataclasses

    from grubler.mechanism import spatial

    J = 0.01
    m0 = spatial_preset("rssr")
    I = np.array(m0.links[0].inertia) + np.diag([J / 2, J / 2, J])
    links = [dataclasses.replace(m0.links[0], inertia=tuple(map(tuple, I))), *m0.links[1:]]
    m = spatial.SpatialMechanism(links, m0.closures, m0.gravity)
    s, vr = slave(built, "rssr", 2, {"drive.inertia": J, "max_step": 16 * H})
    y0 = get(s, 2, state_refs(m, vr))
    s.setReal([vr["motor_torque"]], [0.5])
    for i in range(16):
        s.doStep(i * H, H)
    tau = np.zeros(m.n_coords)
    tau[0] = 0.5
    assert np.abs(get(s, 2, state_refs(m, vr)) - m.simulate(y0, 16 * H, H, tau).y[-1]).max() <= 1e-12


# -- directional derivatives -------------------------------------------------------------------------

@pytest.mark.parametrize("preset", PRESETS)
def test_directional_derivatives_are_the_outputs_slopes(built, preset):
    m = spatial_preset(preset)
    md = built[preset, 2][2]
    s, vr = slave(built, preset, 2)
    s.setReal([vr["motor_torque"]], [TORQUE[preset]])
    for i in range(10):
        s.doStep(i * H, H)
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output"]
    inputs = ["motor_torque", f"effort.{m.coordinate_names[-1]}"]
    for name in inputs:
        slope = np.array(s.getDirectionalDerivative(outs, [vr[name]], [1.0]))
        base = s.getReal([vr[name]])[0]
        delta = 1e-3
        s.setReal([vr[name]], [base + delta])
        up = np.array(s.getReal(outs))
        s.setReal([vr[name]], [base - delta])
        down = np.array(s.getReal(outs))
        s.setReal([vr[name]], [base])
        central = (up - down) / (2 * delta)  # exact but for rounding: the outputs are affine in the efforts
        assert np.abs(slope).max() > 1.0, name
        np.testing.assert_allclose(slope, central, rtol=0, atol=1e-7 * np.abs(central).max())
        # the state's outputs (coordinates, rates, energies) do not move with an input
        states = [k for k, v in enumerate(md.modelVariables[r - 1] for r in outs) if not v.name.endswith(
            ("_dd", "Fx", "Fy", "Fz", "Mx", "My", "Mz"))]
        assert not np.any(slope[states])
    s.terminate()
    s.freeInstance()


# -- outside Python ----------------------------------------------------------------------------------

def test_the_c_host_runs_it_with_an_empty_environment_as_fmpy_does(host, built):
    for preset in PRESETS:
        h, md = host_of(host, built, preset), built[preset, 2][2]
        m = spatial_preset(preset)
        names = [*m.coordinate_names, "closure.Fx", f"{m.links[-1].name}.Mz", "KE"]
        t = h.run(h.start({"max_step": 16 * H}, md=md) + [f"setr {h.vr['motor_torque']} {TORQUE[preset]!r}",
                                                          h.run_steps(0.0, H, 16, *names), "free"])
        assert t.statuses("run") == [OK], t.logs
        _, rows = run(built, preset, 2, names, n=16)
        assert np.array_equal(t.rows()[:, 1:], rows), preset
        so = h.cmd[1]
        undefined = subprocess.run(["nm", "-D", "--undefined-only", so], capture_output=True, text=True,
                                   check=True).stdout
        assert "Py" not in undefined


def test_an_open_chain_with_a_cylindrical_joint_exports_and_runs_as_the_library(tmp_path):
    # no closure (no assembly, no closure outputs), a slide among the coordinates; fmpy's simulate_fmu
    from fmpy import simulate_fmu

    from grubler.fmi.build import export_spatial
    from grubler.mechanism.spatial import SpatialLink, SpatialMechanism

    m = SpatialMechanism([
        SpatialLink("arm", alpha=np.pi / 2, mass=1.0, com=(0.3, 0, 0), inertia=np.diag([1e-3, 0.03, 0.03])),
        SpatialLink("ram", a=0.3, alpha=0.4, joint="C", parent=0, mass=0.5, com=(0, 0.1, 0.05),
                    inertia=np.diag([1e-3, 1e-3, 1e-3]))])
    m.sketch = np.array([0.3, 0.2, 0.1])
    path = export_spatial(m, tmp_path / "Open.fmu", "linux64", name="an open chain")
    r = simulate_fmu(str(path), stop_time=1.0, output_interval=H, output=["arm.theta", "ram.theta", "ram.d", "KE", "PE"])
    ref = m.simulate(np.concatenate([m.sketch, np.zeros(3)]), 1.0, H)
    assert np.array_equal(np.column_stack([r["arm.theta"], r["ram.theta"], r["ram.d"]]), ref.z)
    energy = r["KE"] + r["PE"]
    assert abs(ref.z[-1, 2] - ref.z[0, 2]) > 0.1 and np.ptp(energy) < 1e-9 * np.abs(energy).max()


def test_grubler_export_takes_a_spatial_preset(tmp_path):
    out = tmp_path / "Wrist.fmu"
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export", "spherical-fourbar", "-o", str(out),
                           "--platforms", "linux64", "--fmi", "3"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    names = zipfile.ZipFile(out).namelist()
    assert "binaries/x86_64-linux/Wrist.so" in names and "sources/spatial_model.c" in names
    assert "sources/sp_chain.c" in names and "sources/chain.c" not in names  # the spatial kernel only


# -- co-simulated with the motor and the laws -------------------------------------------------------------

@pytest.fixture(scope="module")
def servo_dir(tmp_path_factory):
    """The servo's FMUs: build_fmu.py's motor, laws and trajectory, and the RSSR (linux64)."""
    d = tmp_path_factory.mktemp("servo")
    builds.dist(d, ["DCMotor", "PID", "Encoder", "Trajectory"])
    builds.spatial("rssr", d / "RSSR.fmu", "linux64")
    return d


def test_the_motor_drives_the_rssr_crank_under_pid_and_it_tracks(servo_dir):
    # examples/servo_rssr.py: the servo four-bar's system with the spatial FMU as its mechanism, through
    # `grubler cosim`'s Gauss-Seidel master at 1 ms: a half turn of the crank and back
    sys.path.insert(0, str(HERE.parent / "examples"))
    import servo_rssr

    from grubler.system import cosim
    from grubler.system.servo import servo_system

    r = cosim.run(servo_system(servo_rssr.DESIGN, servo_dir, name="servo_rssr"), t_end=3.0)
    error = r["trajectory.position"] - r["mechanism.drive_angle"]
    assert np.ptp(r["mechanism.drive_angle"]) > 3.0  # the half turn was made
    assert np.abs(error).max() < 0.05, np.abs(error).max()  # measured 0.034 rad at 2 pi rad/s
    assert np.abs(r["motor.current"]).max() > 0.1 and r["mechanism.closure_error"].max() < 1e-9
    # the motor's shaft torque is what reaches the crank: its joint's moment about its axis
    k = len(r["t"]) // 2
    assert r["mechanism.crank.Mz"][k] != 0.0 and np.isfinite(r["mechanism.closure.Fx"]).all()
    assert not r.warnings, r.warnings


def test_the_shipped_servo_rssr_ssd_is_what_its_example_script_writes(servo_dir):
    sys.path.insert(0, str(HERE.parent / "examples"))
    import servo_rssr

    from grubler import ssp
    from grubler.system.servo import servo_system

    shipped = ssp.read(HERE.parent / "examples" / "servo_rssr.ssd")
    built = servo_system(servo_rssr.DESIGN, HERE.parent / "dist", name="servo_rssr")
    assert shipped.components.keys() == built.components.keys()
    for name, comp in built.components.items():
        assert shipped.components[name].parameters == comp.parameters, name
        assert shipped.source_path(shipped.components[name]).resolve() == built.source_path(comp).resolve()
    assert shipped.connections == built.connections and shipped.order == built.order


# -- every platform (the cross extra: zig) ------------------------------------------------------------

from test_platforms import GLIBC_OLDEST, SYSROOT, host_build, needs_zig, wine_prefix  # noqa: E402,F401

from grubler.fmi.build import TARGETS  # noqa: E402

# another platform's run against linux64's, of each output's size (at least 1): the aarch64 binary
# (zig's clang fuses a * b + c into one rounding there) and its C library's sin and cos differ in the last
# bits, and over 128 steps the RSSR's coupler spin about its own axis, a coordinate of little inertia,
# carries that to 1.5e-12 (measured under qemu-user 7.2); the planar test's 1e-12 is for 100 steps of its
# four-bar
CROSS_RELATIVE = 1e-11


@pytest.fixture(scope="module")
def cross_built(tmp_path_factory):
    """The RSSR FMU with a binary for every platform, unzipped."""
    from fmpy import read_model_description

    d = tmp_path_factory.mktemp("cross")
    path = builds.spatial("rssr", d / "RSSR.fmu")
    zipfile.ZipFile(path).extractall(d / "x")
    return d / "x", read_model_description(str(path))


def cross_library(cross_built, folder: str) -> Path:
    suffix = next(t.suffix for t in TARGETS if t.fmi2 == folder)
    return cross_built[0] / "binaries" / folder / f"RSSR{suffix}"


@needs_zig
@pytest.mark.parametrize("folder", list(dict.fromkeys(t.fmi2 for t in TARGETS)))
def test_each_platforms_binary_needs_only_the_c_library_and_exports_only_fmi2(cross_built, folder):
    # test_platforms' check of build_fmu.py's FMUs, on the spatial one
    from binaries import read

    slices = read(cross_library(cross_built, folder).read_bytes())
    assert sorted(a for a, _ in slices) == sorted(t.name.split("-")[0] for t in TARGETS if t.fmi2 == folder)
    for arch, link in slices:
        exports = set(link.exports) - {"_mh_dylib_header", "__dso_handle"}
        assert "fmi2DoStep" in exports and all(e.startswith("fmi2") for e in exports), (arch, sorted(exports))
        if folder in ("linux64", "aarch64-linux"):
            assert set(link.libraries) <= {"libc.so.6", "libm.so.6"}, link.libraries
            for symbol, version in link.imports.items():
                assert tuple(int(x) for x in version[6:].split(".")[:2]) <= GLIBC_OLDEST, (symbol, version)
        elif folder == "win64":
            dlls = {x.lower() for x in link.libraries}
            assert "kernel32.dll" in dlls and all(
                x in ("kernel32.dll", "msvcrt.dll", "ucrtbase.dll") or x.startswith("api-ms-win-crt-") for x in dlls)
        else:
            assert link.libraries == ["/usr/lib/libSystem.B.dylib"], (arch, link)


def agree_with_linux64(cross_built, folder, wrapper, exe, env, tmp_path):
    """128 steps of H with every output read after each, and each output's slope along the inputs at the
    end, through the C host on ``folder``'s binary and on linux64's: the same to rounding (test_platforms)."""
    d, md = cross_built
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    native = Host(host_build(tmp_path, "x86_64-linux-gnu.2.17"), cross_library(cross_built, "linux64"), md.guid, vr)
    other = Host(exe, cross_library(cross_built, folder), md.guid, vr, wrapper=wrapper)
    script = native.start(md=md) + [f"setr {vr['motor_torque']} 0.5", native.run_steps(0.0, H, STEPS, *outputs)]
    script += [f"ddr {vr[i]} " + " ".join(str(vr[o]) for o in outputs) for i in ("motor_torque", "effort.rocker.theta")]
    ours, theirs = native.run(script), other.run(script, env=env)
    assert ours.rows().shape[0] == STEPS
    scale = np.maximum(np.abs(ours.rows()).max(axis=0), 1.0)
    worst = (np.abs(theirs.rows() - ours.rows()) / scale).max(axis=0)
    assert worst.max() <= CROSS_RELATIVE, sorted(zip(worst, ["t", *outputs]))[-6:]
    slopes = [np.array(t.values(k), float) for t in (ours, theirs) for k in range(len(t.results))
              if t.results[k][0] == "ddr"]
    for a, b in zip(slopes[:2], slopes[2:]):
        np.testing.assert_allclose(b, a, rtol=CROSS_RELATIVE, atol=CROSS_RELATIVE * np.abs(a).max())


@needs_zig
def test_the_win64_binary_under_wine_agrees(cross_built, wine_prefix, tmp_path):
    wine, env = wine_prefix
    agree_with_linux64(cross_built, "win64", [wine], host_build(tmp_path, "x86_64-windows-gnu"), env, tmp_path)


@needs_zig
def test_the_aarch64_linux_binary_under_qemu_agrees(cross_built, tmp_path):
    qemu = shutil.which("qemu-aarch64") or shutil.which("qemu-aarch64-static")
    if qemu is None or not (SYSROOT / "lib" / "ld-linux-aarch64.so.1").is_file():
        pytest.skip("running aarch64 binaries here needs qemu-user and an aarch64 C library "
                    "(Debian: apt-get install qemu-user libc6-arm64-cross)")
    agree_with_linux64(cross_built, "aarch64-linux", [qemu, "-L", str(SYSROOT)],
                       host_build(tmp_path, "aarch64-linux-gnu.2.17"), {}, tmp_path)
