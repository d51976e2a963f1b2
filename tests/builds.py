"""The suite's builds, each made once: build_fmu.py's FMUs, preset exports, controller FMUs, the C host,
sanitizer and strict-C builds.

Compiling is much of what the FMU tests wait for, and a dozen test files need the
same FMUs.  Each build here is made once and kept on disk in the pytest cache
(``.pytest_cache/d/grubler-fmus/``; ``pytest --cache-clear`` or deleting that
folder clears it), in a folder named after a key hashed from everything that goes
into it:

* an FMU (``fmu``, ``dist``, ``export``, ``spatial``): every source file of the package
  (``fmu_src/``, ``motors/``, ``controllers/``: the C, the headers, the Python
  exporters that write modelDescription.xml, the presets and data they read) and
  ``build_fmu.py``, the compiler's identity (``cc --version``), grubler's compiler
  flags, the platforms built, the FMI version, the versions of fmpy (and its FMI
  headers' bytes), pythonfmu and Python, and the FMU's name;
* a controller FMU (pythonfmu, ``controller_fmu``): that, plus the law's own module file;
* a system's one native FMU (``system_fmu``): the package's key, the SSD's bytes and the export's
  arguments;
* the C host and a compile of an FMU's sources (``host``, ``shared_library``,
  ``sanitized_binary``, and ``compile_check``'s pass of a warning check): the exact files compiled (every file in the FMU's
  ``sources/``, or ``tests/fmi_host.c``, ``c_host.py`` and the FMI headers), the
  compiler's identity and the flags.

A rerun with nothing changed reuses the builds; a changed byte in any of those, another
compiler or other flags is another key, hence a fresh build (tests/test_builds.py
holds that).  A build that fails is not kept: its error is raised each time.  Some
tests still build from scratch on purpose, as their subject is the build: the CLI's
export tests, test_platforms' per-model builds, fmpy's CMake build of the sources,
the exports of test_sixbar_fmu and test_native_laws.

Callers get their own copy (``dist``, ``export``, ``controller_fmu``,
``shared_library``, ``sanitized_binary``) or a path to only read or run (``fmu``,
``host``): the cached files are never handed out to be changed.  Where a test file
used to call ``build_fmu.build(dest, names)``, ``builds.dist(dest, names)`` is the same
call.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
# what goes into an FMU (relative to the checkout): the package and the build script
PACKAGE_SOURCES = ("fmu_src", "motors", "controllers", "build_fmu.py")
# build products and caches that lie among the sources but are not sources
NOT_SOURCES = {".so", ".pyd", ".pyc", ".o", ".dll", ".dylib"}
# set by conftest.py from pytest's own cache folder; this default is where that lies
CACHE = ROOT / ".pytest_cache" / "d" / "grubler-fmus"
# per kind of build, how many keys a cache keeps (a few: switching branches reuses them)
KEEP = 3
SANITIZE = ["-std=c99", "-O1", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
            "-fno-sanitize-recover=undefined"]


# -- keys ------------------------------------------------------------------------------

def digest(*parts) -> str:
    """A hex SHA-256 over ``parts`` (str, bytes, or a Path: its name and its bytes), each delimited."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, Path):
            data = part.name.encode() + b"\0" + part.read_bytes()
        elif isinstance(part, bytes):
            data = part
        else:
            data = str(part).encode()
        h.update(len(data).to_bytes(8, "little") + data)
    return h.hexdigest()


def tree_digest(root: Path, paths=PACKAGE_SOURCES) -> str:
    """A digest of every source file under ``paths`` (relative to ``root``): their relative names and bytes."""
    parts = []
    for rel in paths:
        top = root / rel
        files = [top] if top.is_file() else sorted(p for p in top.rglob("*") if p.is_file())
        for p in files:
            if p.suffix in NOT_SOURCES or "__pycache__" in p.parts or ".egg-info" in str(p):
                continue
            parts += [p.relative_to(root).as_posix(), p.read_bytes()]
    return digest(*parts)


def folder_digest(folder: Path) -> str:
    """A digest of every file under ``folder``: relative names and bytes (an FMU's sources/, say)."""
    return digest(*(part for p in sorted(folder.rglob("*")) if p.is_file()
                    for part in (p.relative_to(folder).as_posix(), p.read_bytes())))


@functools.lru_cache(maxsize=None)
def compiler_identity(cc: str = "cc") -> str:
    """``cc --version``'s text: another compiler (or version) is another key."""
    proc = subprocess.run([cc, "--version"], capture_output=True, text=True)
    return f"{cc}: {proc.stdout}{proc.returncode}"


@functools.lru_cache(maxsize=None)
def toolchain() -> str:
    """Everything besides the sources that decides what build_fmu.py writes."""
    import fmpy
    import pythonfmu

    from grubler.fmi import build

    headers = build.fmi_headers_dir()
    return digest(compiler_identity(), sys.version, fmpy.__version__, pythonfmu.__version__, *build.CFLAGS,
                  *(t.name for t in build.buildable()), *sorted(headers.glob("*.h")))


@functools.lru_cache(maxsize=None)
def package_key() -> str:
    """The key of this checkout's package sources under this toolchain (computed once per session)."""
    return digest(tree_digest(ROOT), toolchain())


# -- the cache -------------------------------------------------------------------------

def cached(kind: str, key: str, make: Callable[[Path], Path]) -> Path:
    """The file ``make(folder)`` writes into an empty folder, made once per ``key`` and kept in the cache.

    A build lands in a scratch folder and is renamed into place, so a build that
    fails or is interrupted leaves no entry, and two sessions that build the same
    key at once both end with a whole one.
    """
    entry = CACHE / f"{kind}-{key[:24]}"
    done = entry / "done"  # names the built file: written last
    if done.is_file() and (entry / done.read_text()).exists():
        os.utime(entry)  # the newest entries of a kind are kept
        return entry / done.read_text()
    CACHE.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=f".{kind}-", dir=CACHE))
    try:
        made = make(scratch)
        (scratch / "done").write_text(made.relative_to(scratch).as_posix())
        shutil.rmtree(entry, ignore_errors=True)
        try:
            scratch.rename(entry)
        except OSError:  # another session put it there first: theirs is as good
            if not (entry / "done").is_file():
                raise
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    prune(kind)
    return entry / (entry / "done").read_text()


def prune(kind: str, keep: int = KEEP) -> None:
    """Drop all but the ``keep`` most recently used entries of ``kind`` (old sources' builds)."""
    entries = sorted((p for p in CACHE.glob(f"{kind}-*") if len(p.name) == len(kind) + 25),
                     key=lambda p: p.stat().st_mtime, reverse=True)
    for old in entries[keep:]:
        shutil.rmtree(old, ignore_errors=True)


def copy_to(path: Path, dest: Path) -> Path:
    """A copy of a cached build at ``dest`` (a folder: under the build's name), for the caller to own."""
    dest = Path(dest)
    target = dest / path.name if dest.suffix != path.suffix else dest
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(path, target)
    return target


# -- FMUs ------------------------------------------------------------------------------

def _build_fmu():
    sys.path.insert(0, str(ROOT)) if str(ROOT) not in sys.path else None
    import build_fmu

    return build_fmu


def fmu(name: str, fmi: int = 2) -> Path:
    """build_fmu.py's FMU ``name`` (FMI ``fmi``), built once: the cached file, to read only."""
    return cached(f"{name}-fmi{fmi}", digest(package_key(), name, fmi),
                  lambda d: _build_fmu().build(d, [name], fmi=fmi)[0])


def dist(dest: Path, names=None, fmi: int = 2) -> list[Path]:
    """``build_fmu.build(dest, names, fmi=fmi)`` from the cache: copies in ``dest``, in build_fmu's order."""
    bf = _build_fmu()
    if set(names or ()) - set(bf.NATIVE if fmi != 2 else bf.FMUS):  # build_fmu's own refusal
        return bf.build(dest, names, fmi=fmi)
    chosen = [n for n in bf.FMUS if (not names or n in names) and (fmi == 2 or n in bf.NATIVE)]
    return [copy_to(fmu(n, fmi), dest) for n in chosen]


def export(scene: str, dest: Path, platforms=None, fmi: int = 2) -> Path:
    """``grubler.fmi.build.export(scene, dest, ...)`` of a preset, by name, from the cache: a copy at ``dest``.

    (The FMU's model identifier is ``dest``'s name, so that is part of the key.)
    """
    from grubler.fmi.build import export as export_scene
    from grubler.mechanism.scene import preset_names

    if scene not in preset_names():  # a preset is in the package's sources: its key is package_key's
        raise ValueError(f"builds.export takes a preset's name, not {scene!r}")
    dest = Path(dest)
    key = digest(package_key(), scene, dest.name, platforms or "", fmi)
    return copy_to(cached(f"scene-{scene}-{dest.stem}-fmi{fmi}", key,
                          lambda d: export_scene(scene, d / dest.name, platforms=platforms, fmi=fmi)), dest)


def spatial(preset: str, dest: Path, platforms=None, fmi: int = 2) -> Path:
    """``grubler.fmi.build.export_spatial`` of a spatial preset, by name, from the cache: a copy at ``dest``."""
    from grubler.fmi.build import export_spatial
    from grubler.fmi.spatial import spatial_preset

    mechanism = spatial_preset(preset)
    if mechanism is None:
        raise ValueError(f"builds.spatial takes a spatial preset's name, not {preset!r}")
    dest = Path(dest)
    key = digest(package_key(), "spatial", preset, dest.name, platforms or "", fmi)
    return copy_to(cached(f"spatial-{preset}-{dest.stem}-fmi{fmi}", key,
                          lambda d: export_spatial(mechanism, d / dest.name, platforms=platforms, fmi=fmi)), dest)


def system_fmu(ssd: Path, names, dest: Path, platforms: str = "linux64", fmi: int = 2, master: str | None = None,
               tol: float | None = None) -> Path:
    """``export_native_system`` of the system ``ssd`` (its FMUs build_fmu.py's ``names``, in a ``dist/`` beside
    the SSD's folder, as examples/*.ssd name them), from the cache: a copy at ``dest``.

    (The key is the package's, the SSD's bytes and the export's arguments: the component FMUs are
    build_fmu.py's of the same package, so they add nothing to it.)
    """
    from grubler.system.native import export_native_system

    ssd, dest = Path(ssd), Path(dest)
    key = digest(package_key(), ssd, *names, dest.name, platforms, fmi, master or "", repr(tol))

    def make(d: Path) -> Path:
        dist(d / "dist", list(names))
        (d / "examples").mkdir()
        shutil.copy(ssd, d / "examples" / ssd.name)
        made = export_native_system(d / "examples" / ssd.name, d / dest.name, platforms, fmi=fmi, master=master,
                                    tol=tol)
        shutil.rmtree(d / "dist")  # (only the system FMU is kept)
        return made

    return copy_to(cached(f"system-{dest.stem}-fmi{fmi}", key, make), dest)


def controller_fmu(law: type, dest: Path) -> Path:
    """``build_controller_fmu(law, dest)`` from the cache: a copy at ``dest`` (a folder or a ``.fmu``)."""
    import inspect

    from grubler.controllers.fmu import build_controller_fmu

    source = Path(inspect.getsourcefile(law))
    key = digest(package_key(), law.__module__, law.__qualname__, source)
    return copy_to(cached(f"law-{law.__qualname__}", key, lambda d: build_controller_fmu(law, d)), dest)


# -- the C host and sanitizer builds ---------------------------------------------------

def host(fmi: int = 2, flags=("-std=c99", "-O2")) -> Path:
    """tests/fmi_host.c compiled by c_host.compile_host (FMI ``fmi``, ``flags``): the cached executable, to run only."""
    from c_host import compile_host

    return cached(f"host{fmi}-{digest(*flags)[:8]}", host_key(fmi, flags),
                  lambda d: compile_host(d / ("fmi_host" if fmi == 2 else "fmi3_host"), fmi=fmi, flags=tuple(flags)))


def host_key(fmi: int, flags) -> str:
    """What the host is compiled from: fmi_host.c, c_host.py's command, the FMI headers, the compiler and flags."""
    from c_host import SOURCE

    from grubler.fmi.build import fmi_headers_dir

    return digest(compiler_identity(), fmi, *flags, SOURCE, HERE / "c_host.py", *sorted(fmi_headers_dir().glob("*.h")))


def shared_library(kind: str, src: Path, files, flags, out: Path, capture: bool = False) -> Path:
    """``cc -shared -fPIC <flags> -I src <files> -o out -lm``, once per sources, flags and compiler: a copy at ``out``.

    The key is the exact input: every file in ``src`` (an FMU's sources/), the files
    compiled, the flags and the compiler.  A failing compile raises
    ``subprocess.CalledProcessError`` (with its output when ``capture``) and leaves nothing.
    """
    key = digest(compiler_identity(), *flags, *files, folder_digest(src))

    def make(d: Path) -> Path:
        so = d / Path(out).name
        subprocess.run(["cc", "-shared", "-fPIC", *flags, "-I", str(src), *(str(src / f) for f in files),
                        "-o", str(so), "-lm"], check=True, capture_output=capture, text=True)
        return so

    return copy_to(cached(kind, key, make), out)


def sanitized_binary(unzipped_dir: Path, desc, out: Path) -> Path:
    """An FMU's binary rebuilt from its sources/ with AddressSanitizer and UBSan: a copy at ``out``."""
    files = list(desc.buildConfigurations[0].sourceFileSets[0].sourceFiles)
    kind = f"asan-{desc.coSimulation.modelIdentifier}-fmi{desc.fmiVersion[0]}"
    return shared_library(kind, unzipped_dir / "sources", files, SANITIZE, out)


def compile_check(label: str, src: Path, flags) -> None:
    """Every C file in ``src`` (the sources/ of the FMU ``label``) compiled alone with ``flags`` (a warning made an error:
    ``-Wstack-usage=8192 -Werror``), once per sources, flags and compiler: a pass is kept, a failure raised
    (AssertionError naming the file and the compiler's words) and not kept."""
    cc = flags[0]
    key = digest(compiler_identity(cc), *flags, folder_digest(src))

    def make(d: Path) -> Path:
        for c in sorted(src.glob("*.c")):
            proc = subprocess.run([*flags, "-c", str(c), "-o", str(d / "x.o"), "-I", str(src)], capture_output=True,
                                  text=True)
            assert proc.returncode == 0, f"{src.parent.name}/{c.name}:\n{proc.stderr[-2000:]}"
        (d / "x.o").unlink(missing_ok=True)
        (d / "passed").write_text(" ".join(map(str, flags)))
        return d / "passed"

    cached(f"check-{label}", key, make)


@functools.lru_cache(maxsize=None)
def sanitizer_problem() -> str | None:
    """Why ``cc`` cannot build with the sanitizers here (None: it can)."""
    with tempfile.TemporaryDirectory() as d:
        probe = subprocess.run(["cc", *SANITIZE, "-x", "c", "-", "-o", str(Path(d) / "probe")],
                               input="int main(void){return 0;}", capture_output=True, text=True)
    return None if probe.returncode == 0 else probe.stderr[-300:]
