"""The C motor model's own contract (motors/kernel/dc_motor.h), as the native FMU relies on it.

The physics is tested in test_motor.py against closed forms; here: the C checks
refuse what the library refuses and name the same field, a refused step changes
nothing, the torque law inverts over arrays, and the source builds and runs with
a C compiler and libm alone.
"""

from __future__ import annotations

import ctypes
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from grubler.errors import SceneError
from grubler.motors import (DCMotor, Drive, Gearbox, MotorState, current_for_torque, initial_state, load_motor,
                            native, shaft_torque, step)

KERNEL = Path(__file__).resolve().parent.parent / "motors" / "kernel"
RE40 = "maxon-re40-148877"


def motor() -> DCMotor:
    return DCMotor(load_motor(RE40).replace(viscous_friction=2e-5), Gearbox(8.0, 0.85), Drive(36.0, 4.0),
                   ambient_temperature=30.0)


def params(**changes) -> native.Params:
    p = native.Params.from_buffer_copy(motor()._params)
    for k, v in changes.items():
        setattr(p, k, v)
    return p


# (field, bad value, how the library is given the same value)
BAD = [
    ("resistance", -1.0, lambda: load_motor(RE40).replace(resistance=-1.0)),
    ("inductance", math.nan, lambda: load_motor(RE40).replace(inductance=math.nan)),
    ("back_emf_constant", 0.07, lambda: load_motor(RE40).replace(back_emf_constant=0.07)),
    ("coulomb_friction", -0.1, lambda: load_motor(RE40).replace(coulomb_friction=-0.1)),
    ("smoothing_speed", 0.0, lambda: load_motor(RE40).replace(smoothing_speed=0.0)),
    ("thermal_time_constant", math.inf, lambda: load_motor(RE40).replace(thermal_time_constant=math.inf)),
    ("reference_temperature", math.nan, lambda: load_motor(RE40).replace(reference_temperature=math.nan)),
    ("gear_ratio", 0.5, lambda: Gearbox(ratio=0.5)),
    ("gear_efficiency", 1.2, lambda: Gearbox(efficiency=1.2)),
    ("gear_efficiency", 0.0, lambda: Gearbox(efficiency=0.0)),
    ("supply_voltage", 0.0, lambda: Drive(0.0)),
    ("current_limit", -1.0, lambda: Drive(24.0, -1.0)),
    ("current_limit", math.nan, lambda: Drive(24.0, math.nan)),
    ("ambient_temperature", -400.0, lambda: DCMotor(load_motor(RE40), ambient_temperature=-400.0)),
    ("ambient_temperature", 1e6, lambda: DCMotor(load_motor(RE40), ambient_temperature=1e6)),
    ("max_substep", 0.0, lambda: DCMotor(load_motor(RE40), max_substep=0.0)),
]


@pytest.mark.parametrize("field, value, library", BAD, ids=[f"{b[0]}={b[1]}" for b in BAD])
def test_the_c_check_refuses_what_the_library_refuses_and_names_the_same_field(field, value, library):
    assert native.check("params", params()) is None
    bad = native.check("params", params(**{field: value}))
    assert bad is not None and bad[0] == field, bad
    with pytest.raises(SceneError) as exc:
        library()
    assert exc.value.field == field


def test_the_c_check_and_the_library_bound_the_ambient_temperature_alike():
    # DCMotor.fmu checks its parameter with the C model's rule, the library and
    # the CLI with AMBIENT_RANGE: the same figures, inclusive at both ends
    from grubler.motors.motor_data import AMBIENT_RANGE

    lo, hi = AMBIENT_RANGE
    for t in (lo, hi):
        assert native.check("params", params(ambient_temperature=t)) is None
    for t in (math.nextafter(lo, -math.inf), math.nextafter(hi, math.inf)):
        assert native.check("params", params(ambient_temperature=t))[0] == "ambient_temperature"


def test_no_current_limit_is_infinity_and_the_state_check_names_its_field():
    assert native.check("params", params(current_limit=math.inf)) is None
    p = params()
    for state, field in ((native.State(4.5, 25.0), "current"), (native.State(math.nan, 25.0), "current"),
                         (native.State(0.0, math.inf), "temperature"), (native.State(0.0, -300.0), "temperature")):
        assert native.check("state", p, state)[0] == field
    assert native.check("state", p, native.State(-4.0, 150.0)) is None


def test_a_refused_step_changes_neither_state_nor_outputs():
    lib, p = native.functions(), params()
    s, out = native.State(1.5, 60.0), native.Outputs(*[7.0] * 7)
    for args, status in (((math.nan, 0.0, 1e-3), native.BAD_VOLTAGE), ((1.0, -math.inf, 1e-3), native.BAD_SHAFT_SPEED),
                         ((1.0, 0.0, -1e-3), native.BAD_STEP_SIZE), ((1.0, 0.0, math.nan), native.BAD_STEP_SIZE),
                         ((1.0, 0.0, 1e9), native.BAD_STEP_SIZE)):  # 1e11 sub-steps of 10 ms
        assert lib.dcm_step(ctypes.byref(p), ctypes.byref(s), *args, ctypes.byref(out)) == status
        assert (s.current, s.temperature) == (1.5, 60.0)
        assert list(bytes(out)) == list(bytes(native.Outputs(*[7.0] * 7)))
    assert lib.dcm_step(ctypes.byref(p), None, 1.0, 0.0, 1e-3, None) == native.BAD_ARGUMENT
    assert lib.dcm_step(ctypes.byref(p), ctypes.byref(s), 1.0, 0.0, 1e-3, None) == native.OK  # outputs optional
    assert s.current != 1.5


def test_a_winding_where_r_vanishes_is_refused_mid_run():
    m = motor()
    with pytest.raises(SceneError) as exc:
        step(m, MotorState(0.0, -300.0), 1.0, 0.0, 1e-3)
    assert exc.value.field == "winding_temperature"


def test_current_for_torque_inverts_shaft_torque_over_broadcast_arrays():
    m = motor()
    rng = np.random.default_rng(3)
    torque = rng.uniform(-5.0, 5.0, (50, 1))
    w = np.concatenate([[0.0, 1e-9, -1e-9], rng.uniform(-800.0, 800.0, 7)])  # motor speeds
    i = current_for_torque(m, torque, w)
    assert i.shape == (50, 10)
    back = np.array([[shaft_torque(m, i[r, c], w[c]) for c in range(10)] for r in range(50)])
    assert np.max(np.abs(back - torque)) < 1e-13 * np.max(np.abs(torque))
    assert isinstance(current_for_torque(m, 1.0, 2.0), np.floating)
    fresh = np.asfortranarray(np.broadcast_to(torque, (50, 10)))  # not C-contiguous: copied, not misread
    assert np.array_equal(current_for_torque(m, fresh, w), i)


HOST = r"""
#include <stdio.h>
#include "dc_motor.h"
int main(void) {
    dcm_params p = {1.16, 0.33e-3, 0.0603, 0.0604, 134e-7, 2e-5, 0.0041607, 10.0, 6.58, 1000.0, 0.0039, 25.0,
                    8.0, 0.85, 36.0, 4.0, 30.0, 0.01};
    int field = -1; const char *why = 0;
    if (dcm_check_params(&p, &field, &why) != DCM_OK) { printf("bad %s %s\n", dcm_field_name(field), why); return 1; }
    dcm_state s = {0.0, 30.0};
    dcm_outputs o;
    for (int k = 0; k < 2000; k++)
        if (dcm_step(&p, &s, 30.0, k < 1000 ? 20.0 : -70.0, 1e-3, &o) != DCM_OK) return 2;
    printf("%.17g %.17g %.17g %.17g\n", s.current, s.temperature, o.shaft_torque, o.terminal_voltage);
    return 0;
}
"""


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (cc) on PATH")
def test_the_source_builds_with_libm_alone_and_runs_as_the_library_does(tmp_path):
    (tmp_path / "host.c").write_text(HOST)
    exe = tmp_path / "host"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2", f"-I{KERNEL}",
                    str(tmp_path / "host.c"), str(KERNEL / "dc_motor.c"), "-lm", "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    got = [float(x) for x in subprocess.run([str(exe)], check=True, capture_output=True, text=True,
                                            env={}).stdout.split()]
    d = load_motor(RE40).replace(resistance=1.16, inductance=0.33e-3, torque_constant=0.0603,
                                 back_emf_constant=0.0604, rotor_inertia=134e-7, viscous_friction=2e-5,
                                 coulomb_friction=0.0041607, smoothing_speed=10.0, thermal_resistance=6.58,
                                 thermal_time_constant=1000.0, temperature_coefficient=0.0039,
                                 reference_temperature=25.0)
    m = DCMotor(d, Gearbox(8.0, 0.85), Drive(36.0, 4.0), ambient_temperature=30.0, max_substep=0.01)
    s = initial_state(m)
    for k in range(2000):
        s, o = step(m, s, 30.0, 20.0 if k < 1000 else -70.0, 1e-3)
    assert abs(s.current) == 4.0  # the run ends at the limit: the limiter's branch ran in both builds
    want = [s.current, s.temperature, o.shaft_torque, o.terminal_voltage]
    assert got == pytest.approx(want, rel=1e-13, abs=1e-13)


def test_chatter_free_step_is_where_held_speed_makes_the_friction_damper_unstable():
    d = load_motor(RE40)
    # the smoothed friction is a damper tau_c / omega_s on the rotor; an explicit
    # step of J w' = -c w is stable for h < 2 J / c
    assert DCMotor(d).chatter_free_step == pytest.approx(2 * d.rotor_inertia * d.smoothing_speed
                                                         / d.coulomb_friction, rel=1e-15)
    assert DCMotor(d.replace(coulomb_friction=0.0)).chatter_free_step == math.inf
