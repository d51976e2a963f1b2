"""Compile and package a native FMI 2.0 co-simulation FMU.

The FMU holds the C sources in ``sources/`` (the kernel, the generic wrapper,
the model file, the generated ``config.h`` and ``model_variables.c``, and the
FMI 2.0 headers fmpy ships), listed in the model description, and the binaries
compiled from exactly those files: ``binaries/linux64`` with ``cc`` and, when a
MinGW-w64 cross compiler is installed (Debian: ``apt-get install
gcc-mingw-w64-x86-64``), ``binaries/win64``.  Only the ``fmi2*`` functions are
exported; the binary needs libc and libm, no Python.

Examples
--------
>>> from grubler.scene import load_scene
>>> from grubler.fmi.mechanism import mechanism_spec
>>> import tempfile, zipfile, pathlib
>>> with tempfile.TemporaryDirectory() as d:
...     path = build_fmu(mechanism_spec(load_scene("thesis-fourbar")), pathlib.Path(d) / "M.fmu", win64=False)
...     names = zipfile.ZipFile(path).namelist()
>>> "binaries/linux64/Mechanism.so" in names and "sources/fmi2_wrapper.c" in names
True
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import replace
from pathlib import Path

from ..errors import GrublerError, SceneError
from .description import model_description
from .header import config_header, variables_source
from .variables import ModelSpec

HERE = Path(__file__).resolve().parent
C_DIR = HERE / "c"
WRAPPER = ("fmi2_wrapper.c", "fmi2_model.h")
FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
# not part of an FMU: the Python module entry of grubler._kernel; the complex-step
# twins of the equations (*_cs.c, C99 complex arithmetic, which not every
# importer's compiler has) only in a model that provides directional derivatives
NOT_IN_FMU = {"_module.c"}
DIRECTIONAL = "MODEL_DIRECTIONAL_DERIVATIVE"
CFLAGS = ["-O2", "-std=c99", "-fvisibility=hidden", "-Wall", "-Wno-unused-function"]
MINGW = "x86_64-w64-mingw32-gcc"


class BuildError(GrublerError, RuntimeError):
    """A compiler is missing or failed (its output attached)."""


def _kernel_dirs() -> dict[str, Path]:
    """Where the C sources sit: in this source tree, or the installed package."""
    import grubler.motors as motors  # its kernel sits beside it, in a source tree or installed

    return {"kernel": HERE.parent / "kernel", "motor": Path(motors.__file__).resolve().parent / "kernel"}


def fmi_headers_dir() -> Path:
    """fmpy's copy of the FMI standard headers (fmpy/c-code)."""
    import fmpy
    return Path(fmpy.__file__).resolve().parent / "c-code"


def stage_sources(spec: ModelSpec, sources: Path) -> list[str]:
    """Write an FMU's ``sources/`` folder; the C files to compile, in order."""
    sources.mkdir(parents=True, exist_ok=True)
    dirs = _kernel_dirs()
    for key in spec.kernel_sources:
        for f in sorted([*dirs[key].glob("*.[ch]"), *dirs[key].glob("*.inc")]):
            if f.name not in NOT_IN_FMU and (spec.defines.get(DIRECTIONAL) or not f.name.endswith("_cs.c")):
                shutil.copy2(f, sources / f.name)
    for name in (*WRAPPER, spec.model_source):
        shutil.copy2(C_DIR / name, sources / name)
    headers = fmi_headers_dir()
    for name in FMI_HEADERS:
        shutil.copy2(headers / name, sources / name)
    (sources / "config.h").write_text(config_header(spec))
    (sources / "model_variables.c").write_text(variables_source(spec))
    return sorted(p.name for p in sources.glob("*.c"))


def compile_binary(sources: Path, files: list[str], out: Path, compiler: str = "cc", windows: bool = False) -> Path:
    """Compile the C files into the FMU's shared library ``out`` (a DLL with a MinGW ``compiler``)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = [compiler, "-shared", *CFLAGS, "-I", str(sources), "-o", str(out), *(str(sources / f) for f in files)]
    cmd += ["-static-libgcc"] if windows else ["-fPIC", "-lm"]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True)
    except FileNotFoundError:
        raise BuildError(f"no C compiler {compiler!r} on PATH: a native FMU is compiled from C (install gcc or "
                         "clang)") from None
    if proc.returncode != 0:
        raise BuildError(f"{compiler} failed:\n{proc.stderr}")
    return out


def cross_compiler() -> str | None:
    """The MinGW-w64 cross compiler for win64 binaries, if installed."""
    return shutil.which(MINGW)


def build_fmu(spec: ModelSpec, dest: Path, win64: bool | None = None) -> Path:
    """Build a native FMU of ``spec`` at ``dest`` (a ``.fmu`` path).

    Parameters
    ----------
    spec : ModelSpec
    dest : path
    win64 : bool, optional
        Also cross-compile ``binaries/win64`` (default: when MinGW-w64 is installed).
        On Windows the binary is ``win64`` anyway: with MinGW's ``gcc`` if on
        PATH, else with Visual Studio through fmpy's CMake project.

    Returns
    -------
    Path
    """
    dest = Path(dest)
    if win64 is None:
        win64 = cross_compiler() is not None
    if sys.platform.startswith("win") and not shutil.which("gcc") and spec.defines.get(DIRECTIONAL):
        # Visual Studio's C has no C99 complex arithmetic: no directional derivatives
        spec = replace(spec, defines={**spec.defines, DIRECTIONAL: 0})
    with tempfile.TemporaryDirectory(prefix="grubler_native_") as tmp:
        root = Path(tmp)
        files = stage_sources(spec, root / "sources")
        (root / "modelDescription.xml").write_bytes(model_description(spec, files))
        name, src = spec.identifier, root / "sources"
        if sys.platform.startswith("linux"):
            compile_binary(src, files, root / "binaries" / "linux64" / f"{name}.so")
        elif sys.platform == "darwin":
            compile_binary(src, files, root / "binaries" / "darwin64" / f"{name}.dylib")
        elif sys.platform.startswith("win"):
            if shutil.which("gcc"):  # MinGW-w64 on PATH
                compile_binary(src, files, root / "binaries" / "win64" / f"{name}.dll", "gcc", windows=True)
            else:  # Visual Studio, through fmpy's CMake project
                try:
                    from fmpy.build import build_platform_binary
                except ImportError:  # fmpy before 0.3.26
                    raise BuildError("a win64 binary without MinGW-w64 gcc on PATH is built by fmpy.build, which "
                                     "needs fmpy 0.3.26 or later (and numpy 2.1.3 or later)") from None
                build_platform_binary(root)
        if win64 and not sys.platform.startswith("win"):
            compiler = cross_compiler()
            if compiler is None:
                raise BuildError(f"win64 binaries need the MinGW-w64 cross compiler ({MINGW}); Debian/Ubuntu: "
                                 "apt-get install gcc-mingw-w64-x86-64")
            compile_binary(src, files, root / "binaries" / "win64" / f"{name}.dll", compiler, windows=True)
        dest.parent.mkdir(parents=True, exist_ok=True)
        partial = dest.with_name(dest.name + ".part")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    z.write(path, path.relative_to(root).as_posix())
        os.replace(partial, dest)  # an importer never sees half an FMU
    return dest


def identifier_for(path: Path) -> str:
    """A modelIdentifier (a C identifier) from an FMU's file name."""
    ident = re.sub(r"\W", "_", Path(path).stem)
    if not ident or ident[0].isdigit():
        ident = "M_" + ident
    return ident


def export(scene, dest: Path | None = None, win64: bool | None = None) -> Path:
    """Export a scene as a native mechanism FMU whose parameters default to the scene's values.

    Parameters
    ----------
    scene : Scene or str
        A scene, a preset name or a scene TOML path.
    dest : path, optional
        The ``.fmu`` to write (default: ``<scene name>.fmu`` in the working folder).
    """
    from ..scene import Scene, load_scene
    from .mechanism import mechanism_spec

    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    dest = Path(dest) if dest is not None else Path(f"{scene.name or 'mechanism'}.fmu")
    if dest.suffix != ".fmu":
        raise SceneError("output", f"an FMU's file name ends in .fmu, got {dest.name!r}")
    return build_fmu(mechanism_spec(scene, identifier_for(dest)), dest, win64)
