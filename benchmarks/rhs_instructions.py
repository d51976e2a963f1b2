"""Instructions per evaluation of the state equation, this checkout's kernel against an older commit's.

    python benchmarks/rhs_instructions.py OLD_COMMIT [--calls 10000] [--scenes thesis-fourbar stephenson-iii ...]

On a shared machine a wall-clock ratio of two kernels moves by tens of percent
from one minute to the next; the count of instructions an evaluation executes
does not.  This builds both kernels (``cc -O2 -std=c99``, as setup.py does) into
one small C driver each, which reads a preset's model tables and a state written
here, and calls ``grb_rhs`` CALLS times under valgrind's callgrind; the count per
call is the run's total over CALLS (the driver's own start is a few thousand
instructions, under 0.1 % here).  It checks that both kernels return the same
accelerations, bit for bit.  Needs valgrind.
"""

from __future__ import annotations

import argparse
import ctypes
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "grubler.h"
int main(int argc, char **argv) {
    FILE *f = fopen(argv[1], "rb");
    long calls = atol(argv[2]);
    int method = atoi(argv[3]);
    static double buf[1 << 16];
    size_t got = fread(buf, sizeof(double), 1 << 16, f);
    fclose(f);
    if (got < 9) return 2;
    int n = (int)buf[0], c = (int)buf[1];
    grb_model m = {0};
    m.n_links = n;
    m.n_closures = c;
    m.links = buf + 9;
    m.closures = buf + 9 + GRB_L_COLUMNS * n;
    m.theta1 = buf[2];
    m.gravity = buf[3];
    m.drive = (int)buf[4];
    m.load = (int)buf[5];
    m.drive_inertia = buf[6];
    const double *y = buf + 9 + GRB_L_COLUMNS * n + GRB_CL_COLUMNS * c;
    size_t ws = grb_work_size(n, c);
    double *work = calloc(ws, sizeof(double)), *out = calloc(2 * (size_t)n, sizeof(double));
    if (grb_work_init(n, c, work, ws) != GRB_OK) return 3;
    for (long k = 0; k < calls; k++) grb_rhs(&m, method, y, 0.5, 0.0, work, out);
    for (int i = 0; i < 2 * n; i++) printf("%a\n", out[i]);
    return 0;
}
"""


def model_file(name: str, path: Path) -> None:
    """The preset's kernel tables and a state (assembled start, rates + 0.3) as the driver reads them."""
    import grubler
    from grubler import binding

    scene = grubler.load_scene(name)
    m = scene.mechanism
    if m.actuators or m.forces:
        raise SystemExit(f"{name}: the driver carries no actuators or force elements")
    cls = next(v for v in vars(binding).values()
               if isinstance(v, type) and issubclass(v, ctypes.Structure) and any(f[0] == "n_links" for f in v._fields_))
    s = cls.from_address(m.arrays.c)
    n, c = s.n_links, s.n_closures
    links = np.ctypeslib.as_array((ctypes.c_double * (n * 11)).from_address(s.links))
    closures = np.ctypeslib.as_array((ctypes.c_double * (c * 11)).from_address(s.closures)) if c else np.zeros(0)
    run = grubler.simulate(scene, t_end=0.01, dt_out=0.01)
    y = np.concatenate([run.z[0], run.zd[0] + 0.3])
    head = [n, c, s.theta1, s.gravity, s.drive, s.load, s.drive_inertia, 0, 0]
    np.concatenate([np.array(head, float), links, closures, y]).tofile(path)


def build(kernel: Path, motors: Path, exe: Path, driver: Path) -> None:
    sources = [str(p) for p in sorted(kernel.glob("*.c")) + sorted(motors.glob("*.c")) if p.name != "_module.c"]
    subprocess.run(["cc", "-O2", "-std=c99", "-I", str(kernel), "-I", str(motors), str(driver), *sources,
                    "-o", str(exe), "-lm"], check=True)


def count(exe: Path, model: Path, calls: int, method: int) -> tuple[int, str]:
    out = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", str(exe), str(model),
                          str(calls), str(method)], capture_output=True, text=True, check=True)
    total = int(re.search(r"Collected : (\d+)", out.stderr).group(1))
    return total, out.stdout


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", help="commit to compare against")
    ap.add_argument("--calls", type=int, default=10000)
    ap.add_argument("--scenes", nargs="+", default=["thesis-fourbar", "slider-crank", "stephenson-iii",
                                                    "coupling-rod"])
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="rhs_instructions_"))
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.old, "fmu_src/kernel", "motors/kernel"],
                             check=True, capture_output=True).stdout
    (tmp / "old").mkdir()
    subprocess.run(["tar", "-x", "-C", str(tmp / "old")], input=archive, check=True)
    driver = tmp / "driver.c"
    driver.write_text(DRIVER)
    exes = {"old": tmp / "old.exe", "new": tmp / "new.exe"}
    build(tmp / "old" / "fmu_src" / "kernel", tmp / "old" / "motors" / "kernel", exes["old"], driver)
    build(ROOT / "fmu_src" / "kernel", ROOT / "motors" / "kernel", exes["new"], driver)
    print(f"Instructions per grb_rhs (callgrind, {args.calls} calls), {args.old} -> this checkout\n")
    print("| scene | method | old | new | new / old |")
    print("|---|---|---|---|---|")
    for name in args.scenes:
        model = tmp / f"{name}.bin"
        model_file(name, model)
        for method, label in ((0, "exact"), (1, "penalty")):
            (old, old_out), (new, new_out) = (count(exes[k], model, args.calls, method) for k in ("old", "new"))
            same = "" if old_out == new_out else " (results differ!)"
            print(f"| {name} | {label} | {old / args.calls:.0f} | {new / args.calls:.0f} | {new / old:.3f}{same} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
