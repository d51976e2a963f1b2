"""Native FMUs for every platform from one Linux build, and sources any C compiler takes.

Two halves:

* ``sources/`` compiles where C99 complex arithmetic is missing (Visual Studio's
  C, which ``fmpy compile`` uses on Windows): built here as an importer would,
  with ``cc`` and ``-D__STDC_NO_COMPLEX__`` (and strict ISO C99 with no
  variable-length arrays), its directional derivatives are those of the normal
  build (complex step) to rounding.
* With the ``cross`` extra (zig), every binary the FMU carries is checked as a
  file: what it imports (ELF: the C library and its maths at glibc 2.17
  versions or older; PE: KERNEL32 and the C runtime DLLs; Mach-O: libSystem)
  and that it exports the fmi2 functions and nothing else; and the win64 and
  aarch64-linux ones run in tests/fmi_host.c (cross-compiled) under wine and
  qemu-user, matching the linux64 binary.  The file formats are read here
  (tests/binaries.py), not by the tools that wrote them.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import grubler
from grubler.fmi.build import TARGETS, build_fmu, export, zig_compiler
from grubler.fmi.mechanism import fmu_parameters

HERE = Path(__file__).parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from fmi_child import instance  # noqa: E402

SCENES = ["thesis-fourbar", "slider-crank", "stephenson-iii", "watt-ii"]
# (scene, closure method): a four-bar both ways, a slider, two loops of each kind
CASES = [("thesis-fourbar", "exact"), ("thesis-fourbar", "penalty"), ("slider-crank", "exact"),
         ("stephenson-iii", "exact"), ("watt-ii", "exact")]
STRICT = ["-std=c99", "-pedantic", "-Werror", "-Wall", "-Wvla", "-Wno-unused-function"]


def importer_build(unzipped: Path, *flags: str) -> Path:
    """Compile the FMU's sources/ (the files its model description lists) with cc into binaries/linux64."""
    from fmpy import read_model_description

    md = read_model_description(str(unzipped))
    ident, src = md.coSimulation.modelIdentifier, unzipped / "sources"
    out = unzipped / "binaries" / "linux64" / f"{ident}.so"
    out.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(["cc", "-shared", "-fPIC", "-O2", "-fvisibility=hidden", *flags, "-I", str(src), "-o", str(out),
                    *(str(src / f) for f in md.buildConfigurations[0].sourceFileSets[0].sourceFiles), "-lm"], check=True,
                   capture_output=True, text=True)
    return out


@pytest.fixture(scope="module")
def two_builds(tmp_path_factory):
    """Per scene: the FMU's sources compiled with and without C99 complex, unzipped side by side."""
    out = {}
    for name in SCENES:
        d = tmp_path_factory.mktemp(name)
        fmu = export(name, d / "M.fmu", platforms="linux64")
        pair = {}
        for kind, flags in (("complex", []), ("no_complex", ["-D__STDC_NO_COMPLEX__"])):
            zipfile.ZipFile(fmu).extractall(d / kind)
            try:
                pair[kind] = importer_build(d / kind, *STRICT, *flags)
            except subprocess.CalledProcessError as exc:
                pytest.fail(f"{name} sources ({kind}) do not compile as strict C99:\n{exc.stderr}")
        out[name] = pair
    return out


def test_without_complex_the_complex_step_twins_are_left_out(two_builds):
    # the fallback is what the other build measures: no grb_cs_* code in it at all
    for pair in two_builds.values():
        symbols = {k: subprocess.run(["nm", str(so)], capture_output=True, text=True, check=True).stdout
                   for k, so in pair.items()}
        assert "grb_cs_observe_at" in symbols["complex"] and "grb_cs_" not in symbols["no_complex"]


@pytest.mark.parametrize("steps", [0, 150])
@pytest.mark.parametrize("name, method", CASES)
def test_without_complex_the_directional_derivatives_are_the_same(two_builds, name, method, steps):
    from fmpy import read_model_description

    scene = grubler.load_scene(name)
    params = {**fmu_parameters(scene), "method": method}
    params["load_joint"] = params["drive_joint"]  # an effort on each input
    slopes = {}
    for kind, so in two_builds[name].items():
        unzipped = so.parents[2]
        md = read_model_description(str(unzipped))
        messages: list[str] = []
        s = instance(md, str(unzipped), kind, messages, params)
        assert s.init_status == "ok", messages
        vr = {v.name: v.valueReference for v in md.modelVariables}
        outputs = [vr[v.name] for v in md.modelVariables if v.causality == "output"]
        s.setReal([vr["motor_torque"], vr["load_torque"]], [0.7, -0.2])
        for k in range(steps):
            s.doStep(k * 1e-3, 1e-3)
        slopes[kind] = np.array([s.getDirectionalDerivative(outputs, [vr[i]], [1.0])
                                 for i in ("motor_torque", "load_torque")])
        s.terminate()
        s.freeInstance()
    exact, fallback = slopes["complex"], slopes["no_complex"]
    scale = np.abs(exact).max(axis=1, keepdims=True)
    assert np.all(scale > 1e-3)
    # both carry the rounding of one evaluation of the same equations: far below
    # what a finite difference of small step would give (1e-8 relative or worse)
    np.testing.assert_allclose(fallback, exact, rtol=0, atol=1e-12 * scale.max())
    assert np.array_equal(exact == 0.0, fallback == 0.0)  # the states' slopes stay exactly zero
