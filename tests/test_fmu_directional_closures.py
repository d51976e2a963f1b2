"""fmi2GetDirectionalDerivative of the other closures' forces (closure1_*) in two-loop FMUs.

The first closure's force is part of the kernel's observations; a chain of two
loops publishes the second's as ``closure1_Fx``, ``closure1_Fy`` and
``closure1_Mz``, taken from the multipliers the observations leave behind.  Their
derivatives with respect to the efforts must be those of the very outputs: the
reference is central differences of what the FMU returns for perturbed inputs
(the outputs are affine in the efforts at a fixed state, so the differences carry
only rounding), at the start and 0.2 s into a run, for every two-closure preset.
The native FMU has no Python inside, so it runs in-process (as in
test_fmu_directional.py).
"""

from __future__ import annotations

import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import grubler
from grubler.fmi.mechanism import fmu_parameters, same_shape

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))

import builds  # noqa: E402
from fmi_child import central_difference, instance  # noqa: E402

TWO_LOOPS = [n for n in grubler.mechanism.scene.preset_names() if len(grubler.load_scene(n).mechanism.closures) == 2]


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """One exported FMU per shape of the two-loop presets (the others retune it by its parameters)."""
    from fmpy import read_model_description


    out = []
    for name in TWO_LOOPS:
        scene = grubler.load_scene(name)
        if any(same_shape(scene.mechanism, s.mechanism) for s, _, _ in out):
            continue
        d = tmp_path_factory.mktemp(name)
        path = builds.export(name, d / f"Loops{len(out)}.fmu")
        zipfile.ZipFile(path).extractall(d / "unzipped")
        out.append((scene, str(d / "unzipped"), read_model_description(str(path))))
    return out


def test_every_two_loop_preset_is_covered():
    assert len(TWO_LOOPS) >= 6 and {"stephenson-iii", "watt-ii"} <= set(TWO_LOOPS)


@pytest.mark.parametrize("preset", TWO_LOOPS)
@pytest.mark.parametrize("steps", [0, 200])
def test_closure1_forces_have_the_derivatives_of_the_outputs(exported, preset, steps):
    scene = grubler.load_scene(preset)
    _, unzipped, md = next(e for e in exported if same_shape(e[0].mechanism, scene.mechanism))
    messages: list[str] = []
    params = fmu_parameters(scene)
    params["load_joint"] = params["drive_joint"]  # an effort on each input
    s = instance(md, unzipped, "m", messages, params)
    assert s.init_status == "ok", messages
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    ref = [vr[o] for o in outputs]
    base = {"motor_torque": 0.3, "load_torque": -0.1}
    s.setReal([vr[k] for k in base], list(base.values()))
    for k in range(steps):
        s.doStep(k * 1e-3, 1e-3)
    for input_name in base:
        exact = np.array(s.getDirectionalDerivative(ref, [vr[input_name]], [1.0]))
        fd = central_difference(s, ref, vr[input_name], base[input_name])
        closure1 = [outputs.index(f"closure1_{c}") for c in ("Fx", "Fy")]
        assert np.abs(fd[closure1]).max() > 1e-3, (preset, fd[closure1])  # the second loop's force moves
        scale = np.abs(fd).max()
        np.testing.assert_allclose(exact, fd, rtol=0, atol=1e-9 * scale, err_msg=f"{preset} d/d{input_name}")
    s.terminate()
    s.freeInstance()
