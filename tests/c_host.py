"""The tests' C host (tests/fmi_host.c), compiled for FMI 2.0 or 3.0.

One source serves both standards: ``-DHOST_FMI=3`` builds the FMI 3.0 host,
which reads the same script language and prints the same lines as the FMI 2.0
one, so a script runs an FMU's two builds alike.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

SOURCE = Path(__file__).parent / "fmi_host.c"


def compile_host(out: Path, fmi: int = 2, flags=("-std=c99", "-O2"), compiler=("cc",)) -> Path:
    """Build the host into ``out`` against the FMI headers fmpy ships.

    Parameters
    ----------
    out : the executable to write; a name ending in ``.exe`` builds for Windows (no libdl)
    fmi : 2 or 3, the FMI version the host speaks
    flags : the compiler's options (standard, optimisation, sanitizers)
    compiler : the command that compiles, e.g. ``("cc",)``, a MinGW gcc or ``("zig", "cc", "-target", ...)``

    Returns
    -------
    out
    """
    from grubler.fmi.build import fmi_headers_dir

    subprocess.run([*compiler, *flags, f"-DHOST_FMI={fmi}", "-D_POSIX_C_SOURCE=200809L", "-I", str(fmi_headers_dir()),
                    str(SOURCE), "-o", str(out), *([] if out.suffix == ".exe" else ["-ldl", "-pthread"])], check=True)
    return out
