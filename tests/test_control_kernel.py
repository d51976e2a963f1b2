"""The control laws' C (controllers/kernel): the library's classes run it, and
it is held to references that share no code with it (scipy's spline, the
sample grid counted by hand, the noise's moments), and to the Python side's
declarations of its structures and constants.
"""

from __future__ import annotations

import ctypes
import math
import re
from pathlib import Path

import numpy as np
import pytest

import grubler
from grubler.controllers import Encoder, Trajectory, law, native

KERNEL = Path(__file__).resolve().parent.parent / "controllers" / "kernel"


def _c_fields(header: str, struct: str) -> list[str]:
    body = re.search(r"typedef struct %s \{(.*?)\} %s;" % (struct, struct), (KERNEL / header).read_text(), re.S)[1]
    body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
    names = []
    for decl in body.split(";"):
        decl = decl.strip()
        if decl:
            names += [n.strip().split("[")[0] for n in decl.split(None, 1)[1].split(",")]
    return names


@pytest.mark.parametrize("header, struct, py", [
    ("ctl_pid.h", "ctl_pid_params", native.PidParams), ("ctl_pid.h", "ctl_pid_state", native.PidState),
    ("ctl_encoder.h", "ctl_encoder_params", native.EncoderParams),
    ("ctl_encoder.h", "ctl_encoder_state", native.EncoderState),
    ("ctl_trajectory.h", "ctl_trajectory_params", native.TrajectoryParams),
    ("ctl_trajectory.h", "ctl_segment", native.Segment), ("ctl_law.h", "ctl_clock", native.Clock),
    ("ctl_cascade.h", "ctl_cascade_params", native.CascadeParams),
    ("ctl_cascade.h", "ctl_cascade_state", native.CascadeState),
    ("ctl_sensor.h", "ctl_sensor_params", native.SensorParams), ("ctl_sensor.h", "ctl_sensor_state", native.SensorState)])
def test_the_binding_declares_the_headers_structures_field_for_field(header, struct, py):
    assert _c_fields(header, struct) == [name for name, _ in py._fields_]


def test_the_sample_grid_constants_are_the_headers():
    text = (KERNEL / "ctl_law.h").read_text()
    assert float(re.search(r"#define CTL_GRID_TOL (\S+)", text)[1]) == law.GRID_TOL
    assert int(re.search(r"#define CTL_MAX_SAMPLES_PER_STEP (\d+)", text)[1]) == law.MAX_SAMPLES_PER_STEP


def _due(t0, Ts, samples, t, h):
    n = ctypes.c_double()
    status = native.functions().ctl_samples_due(ctypes.byref(native.Clock(t0, Ts, 0)), samples, t, h,
                                                ctypes.byref(n))
    return status, n.value


def test_samples_due_counts_the_grid_instants_in_the_step():
    # by hand: instants t0 + k Ts in [t, t + h), k from the samples run so far
    for t0, Ts, t, h in ((0.0, 1e-3, 0.0, 5e-3), (0.0, 1e-2, 3e-3, 7e-3), (0.5, 0.1, 0.7, 0.25), (0.0, 0.1, 0.0, 0.3)):
        samples = max(0, math.ceil((t - t0) / Ts - 1e-9))
        expected = sum(1 for k in range(samples, samples + 1000) if t0 + k * Ts < t + h - 1e-7 * Ts)
        assert _due(t0, Ts, samples, t, h) == (native.OK, expected), (t0, Ts, t, h)
    assert _due(0.0, 1e-3, 0, 0.0, 0.1 + 0.2)[1] == 300  # 0.1 + 0.2 ends a few ulps past 0.3: not a sample more
    assert _due(0.0, 1e-3, 0, 0.0, math.nan)[0] == native.BAD_STEP_SIZE
    status, n = _due(0.0, 1e-3, 0, 0.0, 1e300)
    assert status == native.TOO_MANY_SAMPLES and n > law.MAX_SAMPLES_PER_STEP


def test_table_spline_matches_scipy():
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(4)
    times = np.cumsum(rng.uniform(0.05, 0.5, 12))
    positions = rng.normal(size=12)
    tab = Trajectory(kind="table", times=list(times), positions=list(positions), delay=0.3)
    ref = CubicSpline(times, positions, bc_type="clamped")
    t = np.linspace(times[0], times[-1], 3001)[1:-1]
    got = np.array([tab.evaluate(x + 0.3) for x in t])
    for d in range(3):
        scale = np.max(np.abs(ref(t, d)))
        assert np.max(np.abs(got[:, d] - ref(t, d))) < 1e-12 * scale, d


def test_noise_is_standard_normal_and_seeded():
    draws = np.array([Encoder(noise_std=1.0, seed=11).measure(0.0) for _ in range(3)])
    assert np.all(draws == draws[0])  # a fresh encoder of one seed draws the same first number
    enc = Encoder(noise_std=1.0, seed=11)
    z = np.array([enc.measure(0.0) for _ in range(100_000)])
    # moments of N(0, 1) within 5 standard errors
    assert abs(z.mean()) < 5 / math.sqrt(z.size)
    assert abs(z.var() - 1) < 5 * math.sqrt(2 / z.size)
    assert abs(np.mean(z**4) / z.var() ** 2 - 3) < 5 * math.sqrt(24 / z.size)


def test_a_law_state_from_outside_is_checked_by_name():
    pid = grubler.controllers.PID(K=1.0, Ti=0.1)
    state = pid.get_state()
    with pytest.raises(ValueError, match="state.I: must be finite"):
        pid.set_state({**state, "I": math.nan})
    enc = Encoder(delay=2, noise_std=0.1)
    state = enc.get_state()
    with pytest.raises(ValueError, match="state.head: must be a whole number"):
        enc.set_state({**state, "head": 5.0})
    with pytest.raises(ValueError, match="state.rng"):
        enc.set_state({**state, "rng": [2.0**40, 0.0]})
    with pytest.raises(ValueError, match="another law"):
        enc.set_state({**state, "history": [0.0]})


def test_a_sample_that_overflows_is_refused_not_a_nan():
    pid = grubler.controllers.PID(K=1e300, Ti=1e-300, Ts=1.0)
    with pytest.raises(ValueError, match="overflowed"):
        pid.compute(1e300, -1e300)


def test_a_sensors_bandwidth_gain_and_offset_are_the_continuous_sensors():
    from grubler.controllers import CurrentSensor, Tachometer

    f, Ts = 20.0, 1e-4
    tau = 1 / (2 * math.pi * f)
    # a unit step just after the first sample: the continuous first-order response 1 - exp(-t / tau)
    s = CurrentSensor(bandwidth=f, Ts=Ts)
    s.update(0.0, {"current": 0.0})
    got = np.array([s.update(k * Ts, {"current": 1.0})["measured_current"] for k in range(1, 400)])
    assert np.max(np.abs(got - (1 - np.exp(-np.arange(1, 400) * Ts / tau)))) < 1e-12
    # a sine at the bandwidth comes out at 1/sqrt(2) of its amplitude, a quarter turn late at most
    s = Tachometer(bandwidth=f, Ts=Ts)
    t = np.arange(0, 0.5, Ts)
    y = np.array([s.update(x, {"speed": math.sin(2 * math.pi * f * x)})["measured_speed"] for x in t])
    assert np.max(np.abs(y[t > 0.3])) == pytest.approx(1 / math.sqrt(2), rel=5e-3)
    # gain error and offset, and the noise's spread
    s = Tachometer(gain_error=-0.05, offset=0.3, noise_std=0.2, seed=5, Ts=1e-3)
    y = np.array([s.update(k * 1e-3, {"speed": 10.0})["measured_speed"] for k in range(20000)])
    assert np.mean(y) == pytest.approx(0.95 * 10 + 0.3, abs=5 * 0.2 / math.sqrt(y.size))
    assert np.std(y) == pytest.approx(0.2, rel=0.05)
    with pytest.raises(grubler.SceneError, match="gain_error: must be finite and > -1"):
        Tachometer(gain_error=-2.0)


def test_a_moves_segments_chain_end_to_start():
    tr = Trajectory("scurve", distance=1.0, v_max=2.0, a_max=8.0, j_max=100.0)
    for a, b in zip(tr._move, tr._move[1:]):
        p, v, _ = a.at(a.duration)
        assert (p, v) == pytest.approx((b.p0, b.v0), abs=1e-15) and b.t0 == pytest.approx(a.t0 + a.duration)
    last = tr._move[-1]
    assert last.at(last.duration) == pytest.approx((1.0, 0.0, 0.0), abs=1e-12)
