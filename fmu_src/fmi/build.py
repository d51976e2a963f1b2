"""Compile and package a native FMI 2.0 or 3.0 co-simulation FMU.

The FMU holds the C sources in ``sources/`` (the kernel, the generic wrapper
with the adapter of its FMI version, the model file, the generated
``config.h`` and ``model_variables.c``, and the FMI headers fmpy ships), listed
in the model description (FMI 3.0: in ``sources/buildDescription.xml``), and
the binaries compiled from exactly those files (:data:`TARGETS`): with the
``cross`` extra (the zig C compiler), ``linux64`` (for glibc 2.17 and later),
``win64``, ``darwin64`` (one universal binary for Intel and Apple silicon) and
``aarch64-linux`` (FMI 3.0: ``x86_64-linux``, ``x86_64-windows``,
``x86_64-darwin`` and ``aarch64-darwin``, ``aarch64-linux``); without it, this
machine's own platform with ``cc``, and ``win64`` when a MinGW-w64 cross
compiler is installed (Debian: ``apt-get install gcc-mingw-w64-x86-64``).  Only
the ``fmi2*`` (``fmi3*``) functions are exported; a binary needs the C library
and its maths, no Python.

Examples
--------
:func:`export` makes a scene's FMU, :func:`build_fmu` any model's; the
binaries are for the :data:`TARGETS` a compiler here builds:

>>> [t.fmi2 for t in TARGETS]                    # FMI 2.0's folders (both macOS targets in darwin64)
['linux64', 'win64', 'darwin64', 'darwin64', 'aarch64-linux']
>>> host_target() in select_targets()            # this machine's own, always (with cc)
True
"""

from __future__ import annotations

import importlib.util
import os
import platform
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from grubler.errors import GrublerError, InputError, SceneError
from grubler.fmi.description import fmi3_build_description, fmi3_model_description, model_description
from grubler.fmi.header import config_header, variables_source
from grubler.limits import PATH_CHARS, brief, output_file
from grubler.mechanism.scene import Scene, load_scene
from grubler.mechanism.simulate import Simulator
from grubler.fmi.mechanism import STANDARD_SCENE, fmu_parameters, mechanism_spec, same_shape, scene_parameters
from grubler.fmi.variables import ModelSpec

HERE = Path(__file__).resolve().parent
C_DIR = HERE / "c"
WRAPPER = ("fmi_common.c", "fmi_common.h", "fmi_model.h", "fmi2_model.h", "scene_slots.h")
FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
FMI_VERSIONS = (2, 3)
# each FMI version's adapter around the same model files, and its headers
ADAPTER = {2: ("fmi2_wrapper.c", FMI_HEADERS),
           3: ("fmi3_wrapper.c", ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h"))}
# not part of an FMU: the Python module entry of grubler._kernel; the complex-step
# twins of the equations (*_cs.c, C99 complex arithmetic, which not every
# importer's compiler has) only in a model that provides directional derivatives
NOT_IN_FMU = {"_module.c"}
DIRECTIONAL = "MODEL_DIRECTIONAL_DERIVATIVE"
# no variable-length arrays: Visual Studio's C, which compiles sources/ on Windows, has none
CFLAGS = ["-O2", "-std=c99", "-fvisibility=hidden", "-Wall", "-Wno-unused-function", "-Werror=vla"]
MINGW = "x86_64-w64-mingw32-gcc"
# the public names (the API reference's): the rest is the package's inside
__all__ = ["export", "export_spatial", "build_fmu", "scene_fmu", "spatial_fmu", "computed_torque_fmu", "select_targets", "host_target",
           "platforms_note", "check_destination", "BuildError", "TARGETS"]


class BuildError(GrublerError, RuntimeError):
    """A compiler is missing or failed (its output attached).

    Examples
    --------
    >>> from grubler.errors import GrublerError
    >>> issubclass(BuildError, GrublerError)         # a missing or failing compiler: one line from the CLI
    True
    """


def _kernel_dirs() -> dict[str, tuple[Path, tuple[str, ...]]]:
    """Where each model's C sources sit (folder, file patterns): in this source tree, or the installed package."""
    import grubler.motors as motors  # the drives' kernels sit beside them, in a source tree or installed

    drives = Path(motors.__file__).resolve().parent / "kernel"
    # the control laws' C sits in grubler.controllers, beside grubler.motors in a source tree and installed
    laws = drives.parent.parent / "controllers" / "kernel"
    kernel = HERE.parent / "kernel"
    # the spatial chain, and the planar kernel's files it stands on (its status words, small solvers, tableaus)
    spatial_base = ("grubler.h", "workspace.h", "real.h", "status.c", "linalg.c", "tableaus*", "project.h", "chart.h")
    return {"kernel": (kernel, ("*",)), "spatial": (kernel / "spatial", ("*",)),
            "spatial_base": (kernel, spatial_base), "motor": (drives, ("dc_motor.*",)),
            "controllers": (laws, ("ctl_*",)), "law": (C_DIR, ("law_model.c", "law.h", "law_struct.h")),
            "user_law": (C_DIR, ("grubler_law.h",)),
            "hydraulic": (drives, ("hydraulic_cylinder.*", "cylinder.*", "rosenbrock.*")),
            "pneumatic": (drives, ("pneumatic_cylinder.*", "cylinder.*", "rosenbrock.*"))}


def fmi_headers_dir() -> Path:
    """fmpy's copy of the FMI standard headers (fmpy/c-code)."""
    import fmpy
    return Path(fmpy.__file__).resolve().parent / "c-code"


def check_fmi_version(fmi: int, field: str = "fmi") -> int:
    """The FMI version asked for, if this package builds it."""
    if fmi not in FMI_VERSIONS:
        raise InputError(field, f"FMI version {fmi!r}: a native FMU is FMI 2 or FMI 3")
    return fmi


def stage_sources(spec: ModelSpec, sources: Path, fmi: int = 2) -> list[str]:
    """Write an FMU's ``sources/`` folder for FMI version ``fmi``; the C files to compile, in order."""
    adapter, fmi_headers = ADAPTER[check_fmi_version(fmi)]
    sources.mkdir(parents=True, exist_ok=True)
    dirs = _kernel_dirs()
    for key in spec.kernel_sources:  # a name of _kernel_dirs, or a (folder, patterns) of the caller's own
        folder, patterns = dirs[key] if isinstance(key, str) else key
        for f in sorted(f for pattern in patterns for f in folder.glob(pattern) if f.suffix in (".c", ".h", ".inc")):
            if f.name not in NOT_IN_FMU and (spec.defines.get(DIRECTIONAL) or not f.name.endswith("_cs.c")):
                shutil.copy2(f, sources / f.name)
    for name in (*WRAPPER, adapter, spec.model_source):
        shutil.copy2(C_DIR / name, sources / name)
    headers = fmi_headers_dir()
    for name in fmi_headers:
        shutil.copy2(headers / name, sources / name)
    (sources / "config.h").write_text(config_header(spec))
    (sources / "model_variables.c").write_text(variables_source(spec))
    return sorted(p.name for p in sources.glob("*.c"))


@dataclass(frozen=True)
class Target:
    """One platform an FMU can carry a binary for.

    ``name`` is the FMI 3.0 platform tuple; ``fmi2`` the folder an FMI 2.0 FMU
    keeps it in (targets that share one, the two macOS ones, are put together
    in one universal binary there); ``zig`` the target the ``cross`` extra's
    compiler builds it for (for Linux, the oldest glibc it loads on).
    """

    name: str
    fmi2: str
    zig: str
    suffix: str


# FMI 2.0 names win64, linux64 and darwin64 and lets vendors add others: ARM
# Linux takes its FMI 3.0 platform tuple
TARGETS = (
    Target("x86_64-linux", "linux64", "x86_64-linux-gnu.2.17", ".so"),
    Target("x86_64-windows", "win64", "x86_64-windows-gnu", ".dll"),
    Target("x86_64-darwin", "darwin64", "x86_64-macos.11.0", ".dylib"),
    Target("aarch64-darwin", "darwin64", "aarch64-macos.11.0", ".dylib"),
    Target("aarch64-linux", "aarch64-linux", "aarch64-linux-gnu.2.17", ".so"),
)
CROSS_HINT = "pip install 'grubler[cross]' (the zig C compiler, about 400 MB)"


def _folders(targets) -> str:
    """The FMI 2.0 folders of ``targets``, each once, in TARGETS order."""
    return ", ".join(dict.fromkeys(t.fmi2 for t in targets))


def host_target() -> Target | None:
    """The target this machine's own C compiler builds for (None: none of TARGETS).

    Examples
    --------
    >>> host_target() in TARGETS                     # None on a platform no FMU binary is built for
    True
    """
    system = "windows" if sys.platform.startswith("win") else "darwin" if sys.platform == "darwin" else \
        "linux" if sys.platform.startswith("linux") else None
    arch = {"amd64": "x86_64", "x86_64": "x86_64", "arm64": "aarch64", "aarch64": "aarch64"}.get(
        platform.machine().lower())
    return next((t for t in TARGETS if t.name == f"{arch}-{system}"), None)


def zig_compiler() -> list[str] | None:
    """The ``cross`` extra's C compiler (``python -m ziglang cc``), if installed."""
    if importlib.util.find_spec("ziglang") is None:
        return None
    return [sys.executable, "-m", "ziglang", "cc"]


def cross_compiler() -> str | None:
    """The MinGW-w64 cross compiler for win64 binaries, if installed."""
    return shutil.which(MINGW)


def compiler_for(target: Target) -> list[str] | None:
    """The command that compiles ``target``'s binary here, or None when nothing installed can.

    The ``cross`` extra's zig builds every target (and Linux ones for an old
    glibc); without it, the machine's ``cc`` builds its own platform and
    MinGW-w64 win64.
    """
    zig = zig_compiler()
    if zig is not None:
        return [*zig, "-target", target.zig]
    if target == host_target():
        if not sys.platform.startswith("win"):
            return ["cc"]
        return ["gcc"] if shutil.which("gcc") else None  # else Visual Studio, through fmpy (build_fmu)
    if target.fmi2 == "win64" and not sys.platform.startswith("win") and cross_compiler():
        return [cross_compiler()]
    return None


def buildable() -> list[Target]:
    """The targets this machine can build binaries for (on Windows, its own always: see build_fmu)."""
    return [t for t in TARGETS if compiler_for(t) is not None or (t == host_target() and t.fmi2 == "win64")]


def _is_zig(compiler: list[str]) -> bool:
    return compiler[1:3] == ["-m", "ziglang"]


def select_targets(platforms=None, field: str = "platforms") -> list[Target]:
    """The targets named in ``platforms`` (FMI 2.0 folders or FMI 3.0 tuples; None: every one buildable here).

    ``field`` is the name a refusal is reported under (the CLI's option).

    Raises
    ------
    InputError
        A name no target has, or a platform this machine cannot build for.

    Examples
    --------
    >>> [t.name for t in select_targets("linux64")]      # an FMI 2.0 folder or an FMI 3.0 platform tuple
    ['x86_64-linux']
    >>> select_targets("amiga")
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: platforms: no platform 'amiga' (have: linux64, x86_64-linux, win64, x86_64-windows, darwin64, x86_64-darwin, aarch64-darwin, aarch64-linux)
    """
    if platforms is None:
        return buildable()
    if isinstance(platforms, str):
        platforms = [p.strip() for p in platforms.split(",") if p.strip()]
    chosen, names = [], ", ".join(dict.fromkeys(n for t in TARGETS for n in (t.fmi2, t.name)))
    for name in platforms:
        match = [t for t in TARGETS if name in (t.name, t.fmi2)]
        if not match:
            raise InputError(field, f"no platform {name!r} (have: {names})")
        # a folder of two targets (darwin64) takes those built here: a Mac's cc builds its own
        if not [t for t in match if t in buildable()]:
            raise InputError(field, f"{name}: no compiler here builds for it; {CROSS_HINT}")
        chosen += [t for t in match if t in buildable() and t not in chosen]
    if not chosen:
        raise InputError(field, "name at least one platform")
    return [t for t in TARGETS if t in chosen]


def platforms_note() -> str | None:
    """One line naming the platforms a default build leaves out here and how to get them (None: none left out).

    Examples
    --------
    >>> note = platforms_note()                      # None when a default build carries every platform (zig)
    >>> note is None or "left out" in note
    True
    """
    missing = [t for t in TARGETS if t not in buildable()]
    if not missing:
        return None
    return (f"binaries for {_folders(buildable()) or 'no platform'} only; {_folders(missing)} left out: "
            f"{CROSS_HINT} builds them all")


def _run(cmd: list[str]) -> subprocess.Popen:
    try:
        return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    except FileNotFoundError:
        raise BuildError(f"no C compiler {cmd[0]!r} on PATH: a native FMU is compiled from C (install gcc or "
                         "clang)") from None


def compile_command(compiler: list[str], target: Target, sources: Path, files: list[str], out: Path) -> list[str]:
    """The command line that compiles ``files`` into ``target``'s shared library ``out``."""
    cmd = [*compiler, "-shared", *CFLAGS, "-I", str(sources), "-o", str(out), *(str(sources / f) for f in files)]
    if _is_zig(compiler):
        cmd.append("-s")  # no debug information: a tenth of the size
        if target.suffix == ".so":
            # the C library's own sin and cos, as cc's binaries and the library use, not
            # zig's (musl's, a last bit apart now and then); complex products and
            # quotients inline (textbook formulas), as glibc has no __muldc3, __divdc3
            cmd += ["-rtlib=none", "-fcx-limited-range"]
    if target.fmi2 == "win64":
        return cmd + ([] if _is_zig(compiler) else ["-static-libgcc"])
    return cmd + (["-fPIC"] if target.suffix == ".so" else []) + ["-lm"]


def compile_binaries(sources: Path, files: list[str], targets, binaries: Path, identifier: str,
                     folder=lambda t: t.fmi2) -> list[Path]:
    """Compile the C files for each target into ``binaries/<folder(target)>/<identifier><suffix>``.

    The targets compile side by side, each in a scratch folder (a Windows link
    leaves a .pdb and an import library beside the DLL, which the FMU does not
    need); targets that share a folder (FMI 2.0's darwin64: ``folder`` gives
    the FMI 2.0 name by default, ``lambda t: t.name`` the FMI 3.0 one) become
    one universal binary.

    Raises
    ------
    BuildError
        A compiler is missing or failed (its output attached).
    """
    jobs = []
    with tempfile.TemporaryDirectory(prefix="grubler_cc_") as tmp:
        for t in targets:
            compiler = compiler_for(t)
            if compiler is None:
                raise BuildError(f"{t.fmi2}: no compiler here builds for it; {CROSS_HINT}")
            out = Path(tmp) / t.name / f"{identifier}{t.suffix}"
            out.parent.mkdir()
            jobs.append((t, compiler, out, _run(compile_command(compiler, t, sources, files, out))))
        failed = []
        for t, compiler, out, proc in jobs:
            log = proc.communicate()[0]
            if proc.returncode != 0:
                failed.append(f"{'zig cc -target ' + t.zig if _is_zig(compiler) else compiler[0]} failed for "
                              f"{t.name}:\n{log}")
        if failed:
            raise BuildError("\n".join(failed))
        written = []
        for name in dict.fromkeys(folder(t) for t, *_ in jobs):
            parts = [out for t, _, out, _ in jobs if folder(t) == name]
            dest = binaries / name / parts[0].name
            dest.parent.mkdir(parents=True, exist_ok=True)
            if len(parts) > 1:
                dest.write_bytes(universal_binary([p.read_bytes() for p in parts]))
            else:
                shutil.copyfile(parts[0], dest)
            written.append(dest)
    return written


def universal_binary(slices: list[bytes]) -> bytes:
    """One Mach-O universal ("fat") file of thin Mach-O libraries, as Apple's lipo makes it.

    A fat header (big-endian: magic, count; per slice its CPU type and subtype
    from the slice's own header, offset, size, alignment as a power of two),
    then each slice at a 16 KiB boundary: macOS on Intel and on Apple silicon
    loads its own slice from the one darwin64 file.
    """
    align = 14
    header = struct.pack(">II", 0xCAFEBABE, len(slices))
    offset = (len(header) + 20 * len(slices) + (1 << align) - 1) >> align << align
    entries, body = b"", b""
    for data in slices:
        magic, cputype, cpusubtype = struct.unpack_from("<IiI", data)
        if magic != 0xFEEDFACF:
            raise BuildError("a macOS binary is not a 64-bit Mach-O file")
        entries += struct.pack(">iIIII", cputype, cpusubtype, offset + len(body), len(data), align)
        body += data + b"\0" * (-len(data) % (1 << align))
    head = header + entries
    return head + b"\0" * (offset - len(head)) + body


def build_fmu(spec: ModelSpec, dest: Path, platforms=None, fmi: int = 2, stage=None, sources: bool = True) -> Path:
    """Build a native FMU of ``spec`` at ``dest`` (a ``.fmu`` path).

    Parameters
    ----------
    spec : ModelSpec
    dest : path
    platforms : str or list of str, optional
        The binaries to ship, by FMI 2.0 folder (``linux64``, ``win64``,
        ``darwin64``, ``aarch64-linux``) or FMI 3.0 platform tuple (default:
        every one this machine can build; :func:`platforms_note` names the
        others).  With the ``cross`` extra (zig) that is all of them; without
        it, ``cc`` builds this machine's own and MinGW-w64 win64.  On Windows
        without zig the binary is ``win64``: with MinGW's ``gcc`` if on PATH,
        else with Visual Studio through fmpy's CMake project.
    fmi : {2, 3}
        The FMI version of the co-simulation interface: the same model behind
        the FMI 2.0 or the FMI 3.0 adapter.
    stage : callable, optional
        ``stage(spec, sources, fmi)`` writes ``sources/`` and returns the C
        files to compile (default :func:`stage_sources`; a system FMU adds its
        components' models, grubler.system.native).
    sources : bool
        Ship ``sources/`` (default).  Without it the FMU is binary-only (FMI
        allows it): smaller and unpacked faster, but runnable only on the
        platforms whose binaries it carries, and never rebuilt by an importer.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        ``platforms`` names an unknown platform or one no compiler here builds for.
    BuildError
        A compiler failed.

    Examples
    --------
    >>> import pathlib, tempfile, zipfile
    >>> from grubler.controllers.native_fmu import trajectory_spec
    >>> with tempfile.TemporaryDirectory() as d:      # compiles the law kernel: about 2 s
    ...     fmu = build_fmu(trajectory_spec("Trajectory"), pathlib.Path(d) / "Trajectory.fmu", host_target().fmi2)
    ...     names = zipfile.ZipFile(fmu).namelist()
    >>> f"binaries/{host_target().fmi2}/Trajectory{host_target().suffix}" in names   # the binary, and its sources
    True
    >>> "sources/fmi2_wrapper.c" in names, "modelDescription.xml" in names
    (True, True)
    """
    dest = Path(dest)
    targets = select_targets(platforms)
    with tempfile.TemporaryDirectory(prefix="grubler_native_") as tmp:
        root = Path(tmp)
        files = (stage or stage_sources)(spec, root / "sources", fmi)
        if fmi == 3:
            (root / "modelDescription.xml").write_bytes(fmi3_model_description(spec))
            (root / "sources" / "buildDescription.xml").write_bytes(fmi3_build_description(spec, files))
        else:  # (a binary-only FMU lists no source files)
            (root / "modelDescription.xml").write_bytes(model_description(spec, files if sources else []))
        name, src = spec.identifier, root / "sources"
        native_windows = [t for t in targets if compiler_for(t) is None]  # Windows' own, without zig or gcc
        if native_windows:  # Visual Studio, through fmpy's CMake project
            try:
                from fmpy.build import build_platform_binary
            except ImportError:  # fmpy before 0.3.26
                raise BuildError("a win64 binary without MinGW-w64 gcc on PATH is built by fmpy.build, which "
                                 "needs fmpy 0.3.26 or later (and numpy 2.1.3 or later)") from None
            build_platform_binary(root)
        compile_binaries(src, files, [t for t in targets if t not in native_windows], root / "binaries", name,
                         (lambda t: t.fmi2) if fmi == 2 else (lambda t: t.name))
        if not sources:
            shutil.rmtree(src)
        pack_fmu(root, dest)
    return dest


def pack_fmu(root: Path, dest: Path) -> Path:
    """Zip the folder ``root`` into the FMU ``dest``, written whole or not at all."""
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


def export(scene, dest: Path | None = None, platforms=None, field: str = "output", fmi: int = 2) -> Path:
    """Export a scene as a native mechanism FMU whose parameters default to the scene's values.

    Parameters
    ----------
    scene : Scene or str
        A scene, a preset name or a scene TOML path.
    dest : path, optional
        The ``.fmu`` to write (default: ``<scene name>.fmu`` in the working folder).
    platforms : str or list of str, optional
        The binaries to ship (:func:`build_fmu`; default: every one this machine can build).
    field : str
        The name a refused ``dest`` is reported under (the CLI's option).
    fmi : {2, 3}
        The FMI version (:func:`build_fmu`).

    Examples
    --------
    Compiling the mechanism's kernel (with its complex-step twins) takes 5 to 8 s,
    so the export itself is not run here (``tests/test_native_fmu.py`` exports
    and runs one); a refused destination is refused before any compiling:

    >>> import pathlib
    >>> export("thesis-fourbar", pathlib.Path("Fourbar.zip"))
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: output: an FMU's file name ends in .fmu, got 'Fourbar.zip'
    >>> fmu = export("thesis-fourbar", pathlib.Path("Fourbar.fmu"))          # doctest: +SKIP
    >>> from fmpy import read_model_description
    >>> md = read_model_description(str(fmu))                                 # doctest: +SKIP
    >>> md.coSimulation.modelIdentifier, md.coSimulation.needsExecutionTool   # doctest: +SKIP
    ('Fourbar', False)
    >>> [v.start for v in md.modelVariables if v.name == "link2.a"]  # doctest: +SKIP
    ['0.2']
    """
    check_fmi_version(fmi, "fmi")
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    dest = Path(dest) if dest is not None else Path(f"{scene.name or 'mechanism'}.fmu")
    if dest.suffix != ".fmu":
        raise SceneError("output", f"an FMU's file name ends in .fmu, got {dest.name!r}")
    check_destination(dest, field)
    # a scene that cannot start is refused as simulate refuses it (the loop that
    # does not close, a penalty closure without inertia), not found out by the importer
    Simulator(scene.mechanism, method=scene.method, zd0=scene.initial_rates)
    return build_fmu(mechanism_spec(scene, identifier_for(dest)), dest, platforms, fmi)


def export_spatial(mechanism, dest: Path, platforms=None, field: str = "output", fmi: int = 2, y0=None,
                   name: str = "") -> Path:
    """Export a :class:`~grubler.mechanism.spatial.SpatialMechanism` as a native FMU (``c/spatial_model.c``
    over ``kernel/spatial``; :func:`grubler.fmi.spatial.spatial_spec` says its variables).

    Parameters
    ----------
    mechanism : SpatialMechanism
    dest : path
        The ``.fmu`` to write; its name is the model identifier.
    platforms, fmi :
        As :func:`build_fmu`.
    y0 : array, optional
        The start state (default: the preset's sketch, closed, at rest).
    name : str
        The mechanism's name in the FMU's description.

    Examples
    --------
    Compiling takes a few seconds (``tests/test_spatial_fmu.py`` exports and runs
    them); a refused destination is refused before any compiling:

    >>> import pathlib
    >>> from grubler.mechanism.spatial import rssr
    >>> export_spatial(rssr(), pathlib.Path("RSSR.zip"))
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: output: an FMU's file name ends in .fmu, got 'RSSR.zip'
    """
    from grubler.fmi.spatial import spatial_spec

    check_fmi_version(fmi, "fmi")
    dest = Path(dest)
    if dest.suffix != ".fmu":
        raise SceneError(field, f"an FMU's file name ends in .fmu, got {dest.name!r}")
    check_destination(dest, field)
    spec = spatial_spec(mechanism, identifier_for(dest), y0, name or getattr(mechanism, "name", ""))
    return build_fmu(spec, dest, platforms, fmi)


def scene_fmu(scene: Scene, fmu_dir, build_dir=None, reuse: bool = False) -> tuple:
    """The mechanism FMU in ``fmu_dir`` that runs ``scene``, and the parameters that make it so.

    ``Mechanism.fmu`` (``python build_fmu.py``) serves every scene of its shape
    (three moving links, one closure: every four-link preset) through its
    parameters.  A scene of another shape gets its own FMU, exported into
    ``build_dir`` (default ``fmu_dir``) as ``Mechanism_<scene>.fmu``; with
    ``reuse``, one already there is taken as it is (a folder the caller keeps
    for this very scene: the app's, keyed by the scene's text).

    Returns
    -------
    path : Path
    parameters : dict
        Every scene quantity, by FMU variable name (:func:`fmu_parameters`).

    Examples
    --------
    >>> from grubler import load_scene
    >>> path, parameters = scene_fmu(load_scene("slider-crank"), "dist")   # a four-link scene: the shared FMU
    >>> path.name, parameters["method"], parameters["gravity"]
    ('Mechanism.fmu', 'exact', 9.81)
    """
    d = Path(fmu_dir)
    if same_shape(scene.mechanism, load_scene(STANDARD_SCENE).mechanism):
        return d / "Mechanism.fmu", fmu_parameters(scene)
    path = Path(build_dir or d) / f"{identifier_for(Path('Mechanism_' + (scene.name or 'scene')))}.fmu"
    if not (reuse and path.is_file()):
        export(scene, path)
    return path, fmu_parameters(scene)


def spatial_fmu(mechanism, fmu_dir) -> tuple:
    """The spatial FMU in ``fmu_dir`` that runs ``mechanism`` (a spatial preset's), and its parameters.

    ``RSSR.fmu`` for the RSSR (:func:`grubler.fmi.spatial.fmu_name`), what
    ``python build_fmu.py`` builds and ``grubler export rssr`` writes (the path is
    named, not built, as :func:`scene_fmu` names ``Mechanism.fmu``);
    its parameters make it the mechanism (every number of the model is one), so
    one FMU of the preset's shape serves re-tuned copies.

    Examples
    --------
    >>> from grubler.fmi.spatial import spatial_preset
    >>> path, parameters = spatial_fmu(spatial_preset("rssr"), "dist")
    >>> path.name, parameters["drive_joint"]
    ('RSSR.fmu', 'crank.theta')

    Returns
    -------
    path : Path
    parameters : dict
        :func:`grubler.fmi.spatial.spatial_parameters`.
    """
    from grubler.fmi.spatial import fmu_name, spatial_parameters

    path = Path(fmu_dir) / f"{identifier_for(Path(fmu_name(getattr(mechanism, 'name', '') or 'spatial')))}.fmu"
    return path, spatial_parameters(mechanism)


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

    Examples
    --------
    >>> from grubler import load_scene
    >>> path, parameters = computed_torque_fmu(load_scene("thesis-fourbar"), "dist")
    >>> path.name, "link2.a" in parameters
    ('ComputedTorque.fmu', True)
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

    Examples
    --------
    >>> import pathlib
    >>> check_destination(pathlib.Path("no-such-folder") / "M.fmu")
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: output: 'no-such-folder/M.fmu': the folder 'no-such-folder' does not exist
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
    # access() answers for permissions only (and yes to root): /proc says no only when a file is made
    probe = dest.with_name(partial)
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
    except FileExistsError:  # a partial file left by a build that was stopped: the folder takes files
        return
    except OSError as exc:
        raise InputError(field, f"{where}: cannot be written there ({exc.strerror or type(exc).__name__})") \
            from None
    os.unlink(probe)
