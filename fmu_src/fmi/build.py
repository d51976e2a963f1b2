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
>>> from grubler.mechanism.scene import load_scene
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

from grubler.errors import GrublerError, InputError, SceneError
from grubler.fmi.description import model_description
from grubler.fmi.header import config_header, variables_source
from grubler.limits import PATH_CHARS, brief, output_file
from grubler.mechanism.scene import Scene, load_scene
from grubler.mechanism.simulate import Simulator
from grubler.fmi.mechanism import STANDARD_SCENE, fmu_parameters, mechanism_spec, same_shape, scene_parameters
from grubler.fmi.variables import ModelSpec

HERE = Path(__file__).resolve().parent
C_DIR = HERE / "c"
WRAPPER = ("fmi2_wrapper.c", "fmi2_model.h", "scene_slots.h")
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


def _kernel_dirs() -> dict[str, tuple[Path, tuple[str, ...]]]:
    """Where each model's C sources sit (folder, file patterns): in this source tree, or the installed package."""
    import grubler.motors as motors  # the drives' kernels sit beside them, in a source tree or installed

    drives = Path(motors.__file__).resolve().parent / "kernel"
    # the control laws' C sits in grubler.controllers, beside grubler.motors in a source tree and installed
    laws = drives.parent.parent / "controllers" / "kernel"
    return {"kernel": (HERE.parent / "kernel", ("*",)), "motor": (drives, ("dc_motor.*",)),
            "controllers": (laws, ("ctl_*",)), "law": (C_DIR, ("law_model.c", "law.h", "law_struct.h")),
            "user_law": (C_DIR, ("grubler_law.h",)),
            "hydraulic": (drives, ("hydraulic_cylinder.*", "cylinder.*", "rosenbrock.*")),
            "pneumatic": (drives, ("pneumatic_cylinder.*", "cylinder.*", "rosenbrock.*"))}


def fmi_headers_dir() -> Path:
    """fmpy's copy of the FMI standard headers (fmpy/c-code)."""
    import fmpy
    return Path(fmpy.__file__).resolve().parent / "c-code"


def stage_sources(spec: ModelSpec, sources: Path) -> list[str]:
    """Write an FMU's ``sources/`` folder; the C files to compile, in order."""
    sources.mkdir(parents=True, exist_ok=True)
    dirs = _kernel_dirs()
    for key in spec.kernel_sources:  # a name of _kernel_dirs, or a (folder, patterns) of the caller's own
        folder, patterns = dirs[key] if isinstance(key, str) else key
        for f in sorted(f for pattern in patterns for f in folder.glob(pattern) if f.suffix in (".c", ".h", ".inc")):
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


def export(scene, dest: Path | None = None, win64: bool | None = None, field: str = "output") -> Path:
    """Export a scene as a native mechanism FMU whose parameters default to the scene's values.

    Parameters
    ----------
    scene : Scene or str
        A scene, a preset name or a scene TOML path.
    dest : path, optional
        The ``.fmu`` to write (default: ``<scene name>.fmu`` in the working folder).
    field : str
        The name a refused ``dest`` is reported under (the CLI's option).
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    dest = Path(dest) if dest is not None else Path(f"{scene.name or 'mechanism'}.fmu")
    if dest.suffix != ".fmu":
        raise SceneError("output", f"an FMU's file name ends in .fmu, got {dest.name!r}")
    check_destination(dest, field)
    # a scene that cannot start is refused as simulate refuses it (the loop that
    # does not close, a penalty closure without inertia), not found out by the importer
    Simulator(scene.mechanism, method=scene.method, zd0=scene.initial_rates)
    return build_fmu(mechanism_spec(scene, identifier_for(dest)), dest, win64)


def scene_fmu(scene: Scene, fmu_dir) -> tuple:
    """The mechanism FMU in ``fmu_dir`` that runs ``scene``, and the parameters that make it so.

    ``Mechanism.fmu`` (``python build_fmu.py``) serves every scene of its shape
    (three moving links, one closure: every four-link preset) through its
    parameters.  A scene of another shape gets its own FMU, exported into
    ``fmu_dir`` as ``Mechanism_<scene>.fmu``.

    Returns
    -------
    path : Path
    parameters : dict
        Every scene quantity, by FMU variable name (:func:`fmu_parameters`).
    """
    d = Path(fmu_dir)
    if same_shape(scene.mechanism, load_scene(STANDARD_SCENE).mechanism):
        return d / "Mechanism.fmu", fmu_parameters(scene)
    path = d / f"{identifier_for(Path('Mechanism_' + (scene.name or 'scene')))}.fmu"
    export(scene, path)
    return path, fmu_parameters(scene)


def computed_torque_fmu(scene: Scene, fmu_dir) -> tuple:
    """The ComputedTorque FMU in ``fmu_dir`` that serves ``scene``, and the parameters that make it so.

    ``ComputedTorque.fmu`` (``python build_fmu.py``) serves every scene of
    ``Mechanism.fmu``'s shape through its parameters; a scene of another shape
    needs its own, ``ComputedTorque_<scene>.fmu``, which
    :func:`grubler.controllers.native_fmu.export_computed_torque` builds there.

    Returns
    -------
    path : Path
    parameters : dict
        The scene's quantities, by FMU variable name (:func:`scene_parameters`).
    """
    d = Path(fmu_dir)
    if same_shape(scene.mechanism, load_scene(STANDARD_SCENE).mechanism):
        return d / "ComputedTorque.fmu", scene_parameters(scene)
    return d / f"{identifier_for(Path('ComputedTorque_' + (scene.name or 'scene')))}.fmu", scene_parameters(scene)


def check_destination(dest: Path, field: str = "output") -> None:
    """Refuse, before compiling, an FMU path that cannot be written.

    As every command checks a file to write (:func:`grubler.limits.output_file`:
    the folder exists, the name is a file's), and besides: the name of the
    partial file written first (``NAME.fmu.part``) fits the file system, and
    the folder is writable.

    Raises
    ------
    InputError
    """
    dest = output_file(str(dest), field, (".fmu",))
    folder = dest.parent if str(dest.parent) else Path(".")
    where = brief(str(dest), PATH_CHARS)
    try:
        longest = os.pathconf(folder, "PC_NAME_MAX")
    except (AttributeError, ValueError, OSError):  # no pathconf (Windows): the usual limit
        longest = 255
    partial = dest.name + ".part"
    if len(partial.encode("utf-8", "surrogateescape")) > longest:
        raise InputError(field, f"{where}: the file name is {len(dest.name)} characters; the file system takes "
                                f"{longest - len('.part')} at most here (the export writes NAME.part first)")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(field, f"{where}: the folder {brief(str(folder), PATH_CHARS)} is not writable")
