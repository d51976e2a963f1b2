"""A whole system as one FMU: 10 s at 1 ms in the C host, start-up included, native against fmpy's container.

    python benchmarks/system_fmu_cost.py [--ssd examples/servo_fourbar.ssd] [--repeat 7] [--dist dist]

Exports the system twice, as one native FMU (grubler.system.native: its models
and master.c in one binary) and as fmpy's container FMU
(grubler.system.container: the FMUs nested, Jacobi), unpacks each once, and
runs each in the tests' C host (tests/fmi_host.c) under ``env -i``: instantiate,
initialise, 10 000 steps of 1 ms reading the crank angle after each, free.
The figure is the whole process, start-up included (the container's: reading
its configuration, loading its nested binaries), as wall time and as the CPU
time the process used (user + system, from wait4: the machine is shared, so
the wall time carries the other processes' load).  Medians of ``--repeat``
runs, alternating the two.  Prints a Markdown table.

The FMUs of the system must be built (``python build_fmu.py``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

import numpy as np  # noqa: E402
from fmpy import read_model_description  # noqa: E402

from c_host import compile_host  # noqa: E402
from grubler.system.container import export_system  # noqa: E402
from grubler.system.native import export_native_system  # noqa: E402


def timed(cmd: list[str], script: str) -> tuple[float, float]:
    """Wall and CPU seconds of one run of ``cmd`` fed ``script``."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    proc.stdin.write(script.encode())
    proc.stdin.close()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{cmd[1]} failed (exit {proc.returncode})")
    return wall, usage.ru_utime + usage.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ssd", default=str(HERE.parent / "examples" / "servo_fourbar.ssd"))
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--output", default="mechanism.theta2")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="grubler_sysfmu_") as tmp:
        d = Path(tmp)
        host = compile_host(d / "fmi_host")
        runs = {}
        for kind, export in (("native", lambda p: export_native_system(args.ssd, p, "linux64")),
                             ("container", lambda p: export_system(args.ssd, p))):
            fmu = export(d / f"{kind}.fmu")
            zipfile.ZipFile(fmu).extractall(d / kind)
            md = read_model_description(str(fmu))
            vr = next(v.valueReference for v in md.modelVariables if v.name == args.output)
            lib = d / kind / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
            uri = (d / kind / "resources").as_uri()
            runs[kind] = (["env", "-i", str(host), str(lib), md.guid, uri],
                          f"new 0 s\nsetup 0\nenter\nexit\nrun 0 0.001 10000 {vr}\nfree\n", [])
        for _ in range(args.repeat):
            for cmd, script, times in runs.values():
                times.append(timed(cmd, script))
    print(f"{Path(args.ssd).name}: 10 s at 1 ms in the C host under env -i, start-up included "
          f"(median of {args.repeat}; load average {os.getloadavg()[0]:.1f})\n")
    print("| FMU | wall [s] | CPU [s] |")
    print("|---|---|---|")
    for kind, (_, _, times) in runs.items():
        wall, cpu = np.median(np.array(times), axis=0)
        print(f"| {kind} | {wall:.3f} | {cpu:.3f} |")


if __name__ == "__main__":
    main()
