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
from grubler.fmi.build import TARGETS, zig_compiler
from grubler.fmi.mechanism import fmu_parameters

HERE = Path(__file__).parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import builds  # noqa: E402
from fmi_child import instance  # noqa: E402

SCENES = ["thesis-fourbar", "slider-crank", "stephenson-iii", "watt-ii"]
# (scene, closure method): a four-bar both ways, a slider, two loops of each kind
CASES = [("thesis-fourbar", "exact"), ("thesis-fourbar", "penalty"), ("slider-crank", "exact"),
         ("stephenson-iii", "exact"), ("watt-ii", "exact")]
STRICT = ["-std=c99", "-pedantic", "-Werror", "-Wall", "-Wvla", "-Wno-unused-function"]


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


def importer_build(unzipped: Path, label: str, *flags: str) -> Path:
    """Compile the FMU's sources/ (the files its model description lists) with cc into binaries/linux64.

    (Once per sources, flags and compiler: builds.py; ``label`` names the build in its cache.)
    """
    from fmpy import read_model_description

    md = read_model_description(str(unzipped))
    ident, src = md.coSimulation.modelIdentifier, unzipped / "sources"
    return builds.shared_library(f"strict-{label}", src, md.buildConfigurations[0].sourceFileSets[0].sourceFiles,
                                 ["-O2", "-fvisibility=hidden", *flags], unzipped / "binaries" / "linux64" / f"{ident}.so",
                                 capture=True)


@pytest.fixture(scope="module")
def two_builds(tmp_path_factory):
    """Per scene: the FMU's sources compiled with and without C99 complex, unzipped side by side."""
    out = {}
    for name in SCENES:
        d = tmp_path_factory.mktemp(name)
        fmu = builds.export(name, d / "M.fmu", platforms="linux64")
        pair = {}
        for kind, flags in (("complex", []), ("no_complex", ["-D__STDC_NO_COMPLEX__"])):
            zipfile.ZipFile(fmu).extractall(d / kind)
            try:
                pair[kind] = importer_build(d / kind, f"{name}-{kind}", *STRICT, *flags)
            except subprocess.CalledProcessError as exc:
                pytest.fail(f"{name} sources ({kind}) do not compile as strict C99:\n{exc.stderr}")
        out[name] = pair
    return out


@pytest.mark.parametrize("name", ["DCMotor", "HydraulicCylinder", "PneumaticCylinder"])
def test_every_native_fmus_sources_are_strict_c99_without_complex(name, tmp_path):
    # (the mechanism's: two_builds) what Visual Studio's C lacks: complex arithmetic, arrays sized at run time
    sys.path.insert(0, str(ROOT))
    import build_fmu

    fmu = build_fmu.build(tmp_path, [name], "linux64")[0]
    zipfile.ZipFile(fmu).extractall(tmp_path / "u")
    try:
        importer_build(tmp_path / "u", f"{name}-no_complex", *STRICT, "-D__STDC_NO_COMPLEX__")
    except subprocess.CalledProcessError as exc:
        pytest.fail(f"{name} sources do not compile as strict C99 without complex:\n{exc.stderr}")


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


# -- without the cross extra ---------------------------------------------------------

def test_without_zig_the_host_builds_its_own_and_one_line_names_the_rest(monkeypatch):
    from grubler.errors import InputError
    from grubler.fmi import build

    monkeypatch.setattr(build, "zig_compiler", lambda: None)
    monkeypatch.setattr(build, "cross_compiler", lambda: None)  # nor MinGW-w64
    assert build.buildable() == [build.host_target()]
    note = build.platforms_note()
    assert note is not None and "\n" not in note and "pip install 'grubler[cross]'" in note
    assert all(folder in note for folder in ("win64", "darwin64", "aarch64-linux"))
    with pytest.raises(InputError, match=r"darwin64: no compiler here builds for it; pip install 'grubler\[cross\]'"):
        build.select_targets("darwin64")


def test_platforms_are_named_by_either_standards_names():
    from grubler.errors import InputError
    from grubler.fmi.build import select_targets

    from grubler.fmi.build import buildable, host_target

    host = host_target()
    assert select_targets([host.name]) == [host]
    assert select_targets(host.fmi2) == [t for t in buildable() if t.fmi2 == host.fmi2]
    assert select_targets(f"{host.fmi2}, {host.name}") == select_targets(host.fmi2)  # each once
    with pytest.raises(InputError, match="no platform 'macos'"):
        select_targets("macos")


def test_export_refuses_a_platform_it_cannot_build_in_one_line(capsys, monkeypatch, tmp_path):
    from grubler.cli import main
    from grubler.fmi import build

    monkeypatch.setattr(build, "zig_compiler", lambda: None)
    monkeypatch.setattr(build, "cross_compiler", lambda: None)
    other = next(t.fmi2 for t in TARGETS if t.fmi2 not in ("win64", build.host_target().fmi2))
    for value, says in ((other, f"{other}: no compiler here builds for it; pip install"),
                        ("linux64,macos", "no platform 'macos'")):
        code = main(["export", "thesis-fourbar", "-o", str(tmp_path / "M.fmu"), "--platforms", value])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and f"--platforms: {says}" in err, err
    assert list(tmp_path.iterdir()) == []  # refused before compiling


def test_the_universal_macos_binary_holds_each_slice_whole_at_a_page_boundary():
    import struct

    from binaries import read
    from grubler.fmi.build import BuildError, universal_binary

    # two thin 64-bit Mach-O dylibs with no load commands: x86_64 (7) and arm64 (12), each with 64-bit ABI bit
    thin = [struct.pack("<IiIIIIII", 0xFEEDFACF, cpu | 0x01000000, sub, 6, 0, 0, 0, 0) + b"slice %d" % k
            for k, (cpu, sub) in enumerate(((7, 3), (12, 0)))]
    fat = universal_binary(thin)
    assert [arch for arch, _ in read(fat)] == ["x86_64", "aarch64"]
    for k, data in enumerate(thin):
        cpu, sub, offset, size, align = struct.unpack_from(">iIIII", fat, 8 + 20 * k)
        assert fat[offset:offset + size] == data and offset % (1 << align) == 0 and align == 14
    with pytest.raises(BuildError, match="not a 64-bit Mach-O"):
        universal_binary([b"\x7fELF" + bytes(28)])


# -- with it: every platform ---------------------------------------------------------

needs_zig = pytest.mark.skipif(zig_compiler() is None,
                               reason="cross-building needs the cross extra: pip install 'grubler[cross]' (zig)")
NATIVE = ["Mechanism", "DCMotor", "HydraulicCylinder", "PneumaticCylinder"]
FOLDERS = list(dict.fromkeys(t.fmi2 for t in TARGETS))
GLIBC_OLDEST = (2, 17)
RELATIVE = 1e-12  # another platform's binary against linux64's, of each output's size


@pytest.fixture(scope="module")
def cross_built(tmp_path_factory):
    """build_fmu.py's native FMUs, every platform, unzipped."""
    from fmpy import read_model_description

    out = {}
    for path in builds.dist(tmp_path_factory.mktemp("dist"), NATIVE):
        d = tmp_path_factory.mktemp(path.stem)
        zipfile.ZipFile(path).extractall(d)
        out[path.stem] = (d, read_model_description(str(path)))
    return out


def library(cross_built, name: str, folder: str) -> Path:
    suffix = next(t.suffix for t in TARGETS if t.fmi2 == folder)
    return cross_built[name][0] / "binaries" / folder / f"{name}{suffix}"


@needs_zig
@pytest.mark.parametrize("folder", FOLDERS)
@pytest.mark.parametrize("name", NATIVE)
def test_each_binary_needs_only_the_c_library_and_exports_only_fmi2(cross_built, name, folder):
    needs_only_the_c_library(library(cross_built, name, folder), folder)


def needs_only_the_c_library(binary: Path, folder: str) -> None:
    """``binary`` (of the FMI 2.0 platform ``folder``) imports only the C library (glibc 2.17's versions
    or older, KERNEL32 and the C runtime, libSystem) and exports only fmi2 functions."""
    from binaries import read

    slices = read(binary.read_bytes())
    archs = sorted(arch for arch, _ in slices)
    assert archs == sorted(t.name.split("-")[0] for t in TARGETS if t.fmi2 == folder)  # darwin64: both
    for arch, link in slices:
        exports = set(link.exports) - {"_mh_dylib_header", "__dso_handle"}  # every Mach-O dylib's own
        assert "fmi2DoStep" in exports and all(e.startswith("fmi2") for e in exports), (arch, sorted(exports))
        if folder in ("linux64", "aarch64-linux"):
            assert set(link.libraries) <= {"libc.so.6", "libm.so.6"}, link.libraries
            for symbol, version in link.imports.items():
                assert version.startswith("GLIBC_"), (symbol, version)
                assert tuple(int(x) for x in version[6:].split(".")[:2]) <= GLIBC_OLDEST, (symbol, version)
        elif folder == "win64":
            dlls = {d.lower() for d in link.libraries}
            assert "kernel32.dll" in dlls
            assert all(d in ("kernel32.dll", "msvcrt.dll", "ucrtbase.dll") or d.startswith("api-ms-win-crt-")
                       for d in dlls), dlls
        else:
            assert link.libraries == ["/usr/lib/libSystem.B.dylib"] and link.min_os <= (11, 0), (arch, link)


def host_build(tmp_path: Path, target: str) -> Path:
    """tests/fmi_host.c cross-compiled for a zig target."""
    from c_host import compile_host

    return compile_host(tmp_path / f"fmi_host_{target}{'.exe' if 'windows' in target else ''}",
                        compiler=(*zig_compiler(), "-target", target))


def agree_with_linux64(cross_built, name, folder, wrapper, exe, env, tmp_path):
    """The script of test_native_fmu (100 steps, outputs read after each) and each output's slope along
    each input at the end, through the C host on ``folder``'s binary and on linux64's: the same to rounding."""
    from test_native_fmu import MATCH, SCRIPTS, Host

    d, md = cross_built[name]
    vr = {v.name: v.valueReference for v in md.modelVariables}
    native = Host(host_build(tmp_path, "x86_64-linux-gnu.2.17"), library(cross_built, name, "linux64"), md.guid, vr)
    other = Host(exe, library(cross_built, name, folder), md.guid, vr, wrapper=wrapper)
    script = native.start(md=md) + SCRIPTS[name](native)
    if md.coSimulation.providesDirectionalDerivative:
        outputs = " ".join(str(v.valueReference) for v in md.modelVariables if v.causality == "output")
        script += [f"ddr {vr[i]} {outputs}" for i in ("motor_torque", "load_torque")]
    ours, theirs = native.run(script), other.run(script, env=env)
    assert ours.rows().shape[0] == 100
    # each platform's maths library rounds sin and cos its own way in the last bit
    # (the Windows binary has zig's, from musl; linux64 glibc's): over 100 steps
    # that leaves 7e-14 of an output's size (measured), so the verdict is relative
    np.testing.assert_allclose(theirs.rows(), ours.rows(), rtol=RELATIVE, atol=MATCH)
    slopes = [np.array(t.values(k), float) for t in (ours, theirs) for k in range(len(t.results))
              if t.results[k][0] == "ddr"]
    for a, b in zip(slopes[:len(slopes) // 2], slopes[len(slopes) // 2:]):
        np.testing.assert_allclose(b, a, rtol=RELATIVE, atol=MATCH * np.abs(a).max())


def wine_program() -> str | None:
    """wine, or wine64 (Debian's wine64 package alone leaves it out of PATH, in /usr/lib/wine)."""
    return shutil.which("wine") or shutil.which("wine64") or next(
        (str(p) for p in (Path("/usr/lib/wine/wine64"),) if p.is_file()), None)


@pytest.fixture(scope="module")
def wine_prefix(tmp_path_factory):
    """One wine prefix for the module's runs (making one takes seconds)."""
    wine = wine_program()
    if wine is None:
        pytest.skip("running win64 binaries here needs wine (Debian: apt-get install wine64)")
    d = tmp_path_factory.mktemp("wine")
    return wine, {"WINEDEBUG": "-all", "WINEPREFIX": str(d / "prefix"), "HOME": str(d), "PATH": "/usr/bin:/bin"}


@needs_zig
@pytest.mark.parametrize("name", ["Mechanism", "DCMotor"])
def test_win64_binary_under_wine_agrees(cross_built, wine_prefix, name, tmp_path):
    wine, env = wine_prefix
    agree_with_linux64(cross_built, name, "win64", [wine], host_build(tmp_path, "x86_64-windows-gnu"), env, tmp_path)


SYSROOT = Path("/usr/aarch64-linux-gnu")


def qemu_wrapper() -> list[str]:
    """The command that runs an aarch64-linux program here (qemu-user on the aarch64 C library), else a skip."""
    qemu = shutil.which("qemu-aarch64") or shutil.which("qemu-aarch64-static")
    if qemu is None or not (SYSROOT / "lib" / "ld-linux-aarch64.so.1").is_file():
        pytest.skip("running aarch64 binaries here needs qemu-user and an aarch64 C library "
                    "(Debian: apt-get install qemu-user libc6-arm64-cross)")
    return [qemu, "-L", str(SYSROOT)]


@needs_zig
@pytest.mark.parametrize("name", ["Mechanism", "DCMotor"])
def test_aarch64_linux_binary_under_qemu_agrees(cross_built, name, tmp_path):
    agree_with_linux64(cross_built, name, "aarch64-linux", qemu_wrapper(),
                       host_build(tmp_path, "aarch64-linux-gnu.2.17"), {}, tmp_path)


def test_the_python_library_loads_a_kernel_compiled_without_complex(tmp_path):
    # Visual Studio's C compiles the kernel without its complex-step twins: the
    # binding declares what is there, simulates with it, and names what is missing
    import ctypes

    from grubler import binding
    from grubler.mechanism.scene import load_scene
    from grubler.mechanism.simulate import Simulator

    # the folders setup.py compiles into grubler._kernel, less its Python module entry
    folders = [ROOT / d for d in ("fmu_src/kernel", "motors/kernel", "controllers/kernel", "fmu_src/system/c")]
    sources = [str(f) for d in folders for f in sorted(d.glob("*.c")) if f.name != "_module.c"]
    out = tmp_path / "kernel_no_complex.so"
    subprocess.run(["cc", "-shared", "-fPIC", "-O2", "-std=c99", "-D__STDC_NO_COMPLEX__",
                    *(f"-I{d}" for d in folders), "-o", str(out), *sources, "-lm"],
                   check=True, capture_output=True, text=True)
    lib = binding.declare(ctypes.CDLL(str(out)))
    assert not hasattr(lib, "grb_cs_rhs_at")
    with pytest.raises(binding.KernelMissing, match="grb_cs_rhs_at: .*without C99 complex arithmetic"):
        binding.complex_step("grb_cs_rhs_at", lib)
    # the real equations are whole: the observed quantities at the assembled start (positions to
    # reactions, through the forward dynamics) agree with the full kernel's to the bit
    model = load_scene("thesis-fourbar").mechanism
    sim = Simulator(model, method="exact")
    z, zd = sim.z, sim.zd
    n = model.n_links
    y = np.concatenate([z, zd])
    observed = []
    for kernel_lib in (binding.library(), lib):
        work = binding.work(n, len(model.closures))
        values = np.zeros(9 * n + 11)
        assert kernel_lib.grb_observe(model.arrays.c, 0, binding.address(y), 1.5, 0.0, 1, binding.address(work),
                                      binding.address(values)) == binding.OK
        observed.append(values)
    assert np.array_equal(observed[0], observed[1]) and np.any(observed[0] != 0.0)
