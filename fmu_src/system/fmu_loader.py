"""Which copy of a package a pythonfmu FMU runs: its own, or an identical one, never another.

A pythonfmu FMU runs inside the importer's Python, and Python holds one module
per name: the first FMU (or the host itself) that imports ``grubler`` decides
which ``grubler`` every later FMU in that process gets.  Two FMUs built from
different versions of the package would then silently run one version's code,
and an FMU instantiated again after its first extraction folder was deleted
would run modules whose files (scene presets, lazily imported submodules) are
gone.

Renaming the bundled package per build is not open to us: the package and every
user's law import it as ``grubler``.  So the slave script of every FMU built by
:func:`grubler.controllers.fmu.build_controller_fmu` calls :func:`prepare` before
its first import of the package, with the content digests of what it carries:

- a module not loaded yet is imported from the FMU's own resources folder
  (pythonfmu puts it first on ``sys.path``);
- a module loaded from a folder that no longer exists (an earlier extraction of
  an FMU) is dropped from ``sys.modules`` and imported again from this FMU;
- a module loaded from elsewhere with the same content digest is shared (it is
  the same code);
- a module loaded with another digest is refused: instantiation fails with an
  ImportError that names both copies and what to do, which pythonfmu logs.

This module uses the standard library only: the FMU copies it into its resources
under a name carrying the build digest and imports it before the package.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import sys
from pathlib import Path

_SKIP_DIRS = {"__pycache__"}
_SKIP_SUFFIXES = (".pyc", ".pyo")
_DIGESTS: dict[tuple, str] = {}


def package_files(root: Path, subpackages: dict[str, Path] | None = None) -> dict[str, Path]:
    """Relative path -> file of a module or package, as a staged copy lays it out.

    Parameters
    ----------
    root : Path
        A module file, or a package folder.
    subpackages : dict of str to Path, optional
        Subpackage name -> its folder, for subpackages that an installation may
        keep outside ``root`` (grubler's ``motors`` and ``controllers``); they
        are listed under ``name/`` wherever they live, so a source checkout and
        an FMU's copy of it list the same paths.
    """
    root = Path(root)
    if root.is_file():
        return {root.name: root}
    subpackages = {name: Path(folder).resolve() for name, folder in (subpackages or {}).items()}
    inner = set(subpackages.values())
    files: dict[str, Path] = {}

    def walk(folder: Path, prefix: str) -> None:
        for dirpath, dirnames, filenames in os.walk(folder):
            here = Path(dirpath)
            dirnames[:] = sorted(d for d in dirnames
                                 if d not in _SKIP_DIRS and (here / d).resolve() not in inner)
            for f in filenames:
                if not f.endswith(_SKIP_SUFFIXES):
                    files[prefix + (here / f).relative_to(folder).as_posix()] = here / f

    walk(root, "")
    for name, folder in subpackages.items():
        walk(folder, name + "/")
    return dict(sorted(files.items()))


def tree_digest(files: dict[str, Path]) -> str:
    """SHA-256 over the relative paths and contents of ``files`` (hex)."""
    h = hashlib.sha256()
    for rel, path in sorted(files.items()):
        data = path.read_bytes()
        h.update(f"{rel}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()


def _origin(module) -> Path | None:
    """The file of a plain module, or the folder of a package (None if neither)."""
    file = getattr(module, "__file__", None)
    if file is None:
        return None
    file = Path(file)
    return file.parent if file.name == "__init__.py" else file


def module_digest(name: str, subpackages: tuple[str, ...] = ()) -> str:
    """Content digest of the loaded module ``name`` (and the named subpackages), as :func:`tree_digest`."""
    module = sys.modules[name]
    subs = {s: _origin(importlib.import_module(f"{name}.{s}")) for s in subpackages}
    root = _origin(module)
    key = (name, root, tuple(sorted((s, str(p)) for s, p in subs.items())))
    if key not in _DIGESTS:
        _DIGESTS[key] = tree_digest(package_files(root, subs))
    return _DIGESTS[key]


def _forget(name: str) -> None:
    for key in [k for k in sys.modules if k == name or k.startswith(name + ".")]:
        del sys.modules[key]
    importlib.invalidate_caches()


def prepare(script: str, expected: dict[str, tuple[str, tuple[str, ...]]]) -> Path:
    """Make the modules an FMU carries importable as its own copy, or refuse (ImportError).

    Called by the FMU's slave script while pythonfmu instantiates it, when its
    resources folder is first on ``sys.path``.

    Parameters
    ----------
    script : str
        The slave script's module name (as in the FMU's ``slavemodule.txt``).
    expected : dict
        Top-level module name -> (content digest of the FMU's copy, subpackages
        listed as :func:`package_files` lists them).

    Returns
    -------
    Path
        The FMU's resources folder (the script's own folder when pythonfmu's
        builder imports it to write the model description: nothing is checked then).
    """
    resources = Path(sys.path[0])
    marker = resources / "slavemodule.txt"
    if not marker.is_file():
        # imported by pythonfmu's builder to write the model description, not run as an FMU
        return resources
    if marker.read_text().strip() != script:
        raise ImportError(f"FMU slave {script}: the resources folder first on sys.path ({str(resources)!r}) "
                          "belongs to another FMU; instantiate this one through its own FMI binary")
    for name, (digest, subpackages) in expected.items():
        module = sys.modules.get(name)
        if module is None:
            continue
        origin = _origin(module)
        if origin is None or not origin.exists():
            # an earlier extraction of an FMU, since deleted: its modules cannot load their files
            _forget(name)
            continue
        try:
            loaded = module_digest(name, subpackages)
        except (ImportError, OSError) as exc:
            loaded = f"unreadable ({exc})"
        if loaded != digest:
            version = getattr(module, "__version__", "?")
            raise ImportError(
                f"FMU slave {script}: module {name} {version} is already loaded in this process from {origin} "
                f"and differs from the copy this FMU carries in {resources / name} (content {loaded[:12]}, "
                f"this FMU's {digest[:12]}); one Python process holds one version of a module: run this FMU "
                f"in a process of its own, or rebuild it from the loaded version")
    return resources


__all__ = ["module_digest", "package_files", "prepare", "tree_digest"]
