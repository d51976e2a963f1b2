"""Compilation of the numeric kernels (numba), and where their machine code is kept.

Every function that runs inside the integrator's loop is compiled with :func:`jit`;
the compiled code is cached on disk so that a fresh process (a test, an FMU
instance) loads it instead of compiling again.

Numba's own cache is keyed by the source file's directory and checks only the
file that holds the function, so it misses twice here: an FMU's copy of this
package is extracted to a new temporary directory for every instance (a cold
compile each time), and a kernel that calls a kernel of another module would not
notice when that module changes.  The cache is therefore keyed by a hash of the
package's kernel modules (:data:`KERNEL_MODULES`) instead of by its path:

1. ``$NUMBA_CACHE_DIR/grubler-<hash>`` when the user set ``NUMBA_CACHE_DIR``;
2. otherwise numba's user-wide cache directory (``~/.cache/numba/grubler-<hash>``
   on Linux), shared by the library and every extracted FMU of the same version;
3. otherwise ``__pycache__/grubler-<hash>`` beside the code;
4. and if nothing is writable the kernels are compiled in every process.

Examples
--------
>>> from grubler import kinematics
>>> cache_dir(kinematics.chain_into) is None or "grubler-" in cache_dir(kinematics.chain_into)
True
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Callable

import numba

PACKAGE_DIR = Path(__file__).resolve().parent


# the modules whose compiled kernels call one another (and model.py, whose column
# constants they read): a change to any of them invalidates every kernel
KERNEL_MODULES = ("jit", "linalg", "model", "kinematics", "dynamics", "assembly", "integrators")


def _file_hash(paths) -> str:
    h = hashlib.sha256()
    for path in paths:
        h.update(Path(path).name.encode())
        h.update(Path(path).read_bytes())
    return h.hexdigest()[:20]


def _source_hash() -> str:
    return _file_hash(PACKAGE_DIR / f"{name}.py" for name in KERNEL_MODULES)


SOURCE_HASH = _source_hash()


def _cache_bases() -> list[Path]:
    if numba.config.CACHE_DIR:
        return [Path(numba.config.CACHE_DIR)]
    bases = []
    try:
        from numba.misc.appdirs import AppDirs

        bases.append(Path(AppDirs(appname="numba", appauthor=False).user_cache_dir))
    except Exception:  # numba moved its helper: skip the user-wide location
        pass
    return bases + [PACKAGE_DIR / "__pycache__"]


def _function_cache_class():
    """numba's per-function cache with a locator keyed by the package's hash."""
    from numba.core.caching import CompileResultCacheImpl, FunctionCache, _CacheLocator

    class PackageLocator(_CacheLocator):
        def __init__(self, py_func, py_file, path: Path):
            self._py_file = py_file  # numba names it in its warnings
            self._lineno = py_func.__code__.co_firstlineno
            self._path = str(path)

        def get_cache_path(self):
            return self._path

        def get_source_stamp(self):
            # a kernel outside KERNEL_MODULES is still checked against its own file
            return SOURCE_HASH, _file_hash([self._py_file])

        def get_disambiguator(self):
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            for base in _cache_bases():
                self = cls(py_func, py_file, base / f"grubler-{SOURCE_HASH}")
                try:
                    self.ensure_cache_path()
                    return self
                except OSError:  # not writable: try the next place
                    continue
            return None

    class PackageCacheImpl(CompileResultCacheImpl):
        _locator_classes = [PackageLocator]

    class PackageFunctionCache(FunctionCache):
        _impl_class = PackageCacheImpl

    return PackageFunctionCache


try:
    _FunctionCache = _function_cache_class()
except ImportError:  # a numba without these internals: its default cache
    _FunctionCache = None


def jit(fn: Callable | None = None, *, inline: bool = False, nrt: bool = False) -> Callable:
    """Compile ``fn`` in nopython mode with a disk cache (see the module notes).

    Division by zero gives inf or nan as in numpy (``error_model='numpy'``): the
    kernels test finiteness where it matters instead of raising mid-step.

    Kernels write into arrays their caller owns and allocate nothing, so by
    default they are compiled without numba's reference counting (``nrt=False``),
    which otherwise costs an atomic increment and decrement per array argument of
    every call between kernels: half the time of a right-hand side.  A kernel that
    allocates says ``@jit(nrt=True)``.

    ``@jit(inline=True)`` marks a small building block whose body is inlined
    (numba IR) into the kernels that call it, instead of linking a separately
    compiled copy: numba re-optimises every linked copy in every caller.
    """
    if fn is None:
        return lambda f: jit(f, inline=inline, nrt=nrt)
    dispatcher = numba.njit(error_model="numpy", inline="always" if inline else "never", _nrt=nrt)(fn)
    try:
        if _FunctionCache is None:
            dispatcher.enable_caching()
        else:
            # what Dispatcher.enable_caching does, with the package's locator
            dispatcher._cache = _FunctionCache(fn)
    except RuntimeError:  # no writable location: compile in every process
        pass
    return dispatcher


def cache_dir(dispatcher) -> str | None:
    """Directory a compiled kernel is cached in (None when it is not cached)."""
    return getattr(dispatcher._cache, "cache_path", None)
