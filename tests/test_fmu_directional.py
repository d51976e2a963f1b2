"""fmi2GetDirectionalDerivative of the native Mechanism.fmu against its own outputs.

A co-simulation FMU's partial derivatives are those of its outputs with respect
to its inputs at the present state.  The FMU computes them with the kernel's
complex-step twin (exact); the reference here is central differences of the
very outputs the FMU returns for perturbed inputs, read through fmpy (the
outputs are affine in the efforts at a fixed state, so the differences carry
only rounding).  The native FMU has no Python inside, so it runs in-process.
"""

from __future__ import annotations

import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))

from fmi_child import central_difference, instance  # noqa: E402


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    sys.path.insert(0, str(HERE.parent))
    import builds
    from fmpy import read_model_description

    out = {}
    for path in builds.dist(tmp_path_factory.mktemp("dist"), ["Mechanism", "DCMotor"]):
        d = tmp_path_factory.mktemp(path.stem)
        zipfile.ZipFile(path).extractall(d)
        out[path.stem] = (path, str(d), read_model_description(str(path)))
    return out


def _moving(built, params=None, torque=2.0, load=0.0):
    """An instance 0.3 s into a run under constant efforts (the crank turning)."""
    _, d, md = built["Mechanism"]
    messages: list[str] = []
    s = instance(md, d, "m", messages, params)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s.setReal([vr["motor_torque"], vr["load_torque"]], [torque, load])
    for k in range(300):
        s.doStep(k * 1e-3, 1e-3)
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    return s, vr, outputs, messages


def test_model_descriptions_say_who_provides_it(built):
    assert built["Mechanism"][2].coSimulation.providesDirectionalDerivative is True
    assert built["DCMotor"][2].coSimulation.providesDirectionalDerivative is False
    names = zipfile.ZipFile(built["Mechanism"][0]).namelist()
    assert "sources/chain_cs.c" in names and "sources/chain_cs.c" not in zipfile.ZipFile(built["DCMotor"][0]).namelist()


@pytest.mark.parametrize("input_name", ["motor_torque", "load_torque"])
def test_directional_derivative_matches_differences_of_the_fmus_outputs(built, input_name):
    s, vr, outputs, _ = _moving(built, {"load_joint": "theta4"}, torque=2.0, load=-0.5)
    ref = [vr[o] for o in outputs]
    base = {"motor_torque": 2.0, "load_torque": -0.5}
    exact = np.array(s.getDirectionalDerivative(ref, [vr[input_name]], [1.0]))
    fd = central_difference(s, ref, vr[input_name], base[input_name])
    scale = np.abs(fd).max()
    assert scale > 0.5  # the accelerations and forces do move with the effort
    np.testing.assert_allclose(exact, fd, rtol=0, atol=1e-10 * scale)
    # states do not depend on the input at the same instant: exactly zero
    for name in ("theta2", "theta3_d", "drive_angle", "drive_speed", "KE", "PE"):
        assert exact[outputs.index(name)] == 0.0
    s.terminate()
    s.freeInstance()


def test_a_seed_of_both_inputs_is_the_sum_of_their_columns(built):
    s, vr, outputs, _ = _moving(built, {"load_joint": "theta4"})
    ref = [vr[o] for o in outputs]
    known = [vr["motor_torque"], vr["load_torque"]]
    a = np.array(s.getDirectionalDerivative(ref, known[:1], [1.0]))
    b = np.array(s.getDirectionalDerivative(ref, known[1:], [1.0]))
    both = np.array(s.getDirectionalDerivative(ref, known, [2.0, -3.0]))
    np.testing.assert_allclose(both, 2 * a - 3 * b, rtol=1e-12, atol=1e-12)
    s.terminate()
    s.freeInstance()


@pytest.mark.parametrize("unknown, known, seed, message", [
    ("motor_torque", "motor_torque", 1.0, "motor_torque is not an output"),
    ("theta2_dd", "theta2", 1.0, "theta2 is not an input"),
    ("theta2_dd", "motor_torque", float("nan"), "the seed of motor_torque is nan"),
    ("theta2_dd", "link2.m", 1.0, "link2.m is not an input"),
])
def test_bad_references_are_refused_with_a_logged_reason(built, unknown, known, seed, message):
    s, vr, _, messages = _moving(built)
    with pytest.raises(Exception):
        s.getDirectionalDerivative([vr[unknown]], [vr[known]], [seed])
    assert any(message in m for m in messages), messages
    s.freeInstance()
