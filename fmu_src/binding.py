"""The one place Python calls the compiled kernel: ctypes declarations of grubler.h.

The kernel (``fmu_src/kernel/*.c``, and the motor model in ``motors/kernel``) is
built into the extension ``grubler._kernel`` by ``pip install -e .``; this module
loads that file with ctypes and declares each function's argument types once.
Arrays cross as pointers to the numpy buffers the caller owns: no copies, no
Python call inside the kernel's loops.
"""

from __future__ import annotations

import ctypes
import functools
import importlib.util


class KernelMissing(ImportError):
    """The compiled kernel is not built (run ``pip install -e .`` with a C compiler)."""


@functools.lru_cache(maxsize=None)
def library() -> ctypes.CDLL:
    """The loaded kernel library (grubler._kernel's shared object)."""
    spec = importlib.util.find_spec("grubler._kernel")
    if spec is None or spec.origin is None:
        raise KernelMissing("grubler's compiled kernel (grubler._kernel) is not built: run `pip install -e .` "
                            "in the project folder on a machine with a C compiler")
    return ctypes.CDLL(spec.origin)
