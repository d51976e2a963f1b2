"""Speed of this checkout against an older commit, measured alternately in one process.

    python benchmarks/compare_versions.py OLD_COMMIT [--repeat 21]

The machine's speed drifts by tens of percent within a minute, so two versions
timed one after the other can differ by more than any change between them.  This
exports the old commit's package (``git archive``) as ``grubler_old`` beside the
current ``grubler``, and times each workload with the two versions alternating,
reporting medians and their ratio.  Both versions use only the public API.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def load_old(commit: str):
    tmp = Path(tempfile.mkdtemp(prefix="grubler_old_"))
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "fmu_src", "motors"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
    kernel = tmp / "fmu_src" / "kernel"
    if kernel.is_dir():
        # a C-kernel commit: its kernel built as setup.py builds it, and its binding
        # pointed at that library instead of the installed grubler._kernel
        sources = [str(c) for c in sorted(kernel.glob("*.c")) + sorted((tmp / "motors" / "kernel").glob("*.c"))
                   if c.name != "_module.c"]
        lib = tmp / "old_kernel.so"
        subprocess.run(["cc", "-O2", "-std=c99", "-shared", "-fPIC", "-DGRB_SHARED=1", "-I", str(kernel),
                        "-I", str(tmp / "motors" / "kernel"), *sources, "-o", str(lib), "-lm"], check=True)
        binding = (tmp / "fmu_src" / "binding.py").read_text()
        binding = binding.replace('spec = importlib.util.find_spec("grubler._kernel")',
                                  f'spec = importlib.util.spec_from_file_location("old_kernel", {str(lib)!r})')
        (tmp / "fmu_src" / "binding.py").write_text(binding)
    (tmp / "fmu_src").rename(tmp / "grubler_old")
    sys.path.insert(0, str(tmp))
    import grubler_old

    return grubler_old


def workloads(pkg) -> dict:
    """name -> a function running it once with package ``pkg``; returns its step count."""
    m = pkg.load_scene("thesis-fourbar").mechanism
    grid01 = np.arange(1, 101) * 0.1
    torque = 3.0 * np.sin(np.arange(1000) * 1e-3 * 5.0)

    def simulate_default():
        return pkg.simulate("thesis-fourbar", t_end=10.0).stats["steps"]

    def grid(method, integrator, **kw):
        def run():
            sim = pkg.Simulator(m, method=method, integrator=integrator, **kw)
            sim.advance_through(grid01)
            return sim.stats["steps"]
        return run

    def simulate_and_read(column):
        def run():
            res = pkg.simulate("thesis-fourbar", t_end=10.0)
            res[column]
            return res.stats["steps"]
        return run

    def cosim():
        sim = pkg.Simulator(m)
        for i in range(1000):
            sim.set_inputs(drive=float(torque[i]))
            sim.advance_to((i + 1) * 1e-3)
        return sim.stats["steps"]

    def cosim_scene(name, steps):
        scene_m = pkg.load_scene(name).mechanism

        def run():
            sim = pkg.Simulator(scene_m)
            for i in range(steps):
                sim.advance_to((i + 1) * 1e-3)
            return sim.stats["steps"]
        return run

    return {
        "simulate('thesis-fourbar', t_end=10), defaults (0.01 s grid)": simulate_default,
        "10 s, exact DOP853 rtol 1e-9, 0.1 s grid (advance_through)": grid("exact", "dop853"),
        "10 s, thesis method: penalty RK4 at 1 ms, 0.1 s grid": grid("penalty", "rk4", step=1e-3),
        "10 s, penalty closure's default (Radau, rtol 1e-6), 0.1 s grid": grid("penalty", "radau", rtol=1e-6,
                                                                                 atol=1e-6),
        "the same simulate, then read theta2 (a state column)": simulate_and_read("theta2"),
        "the same simulate, then read Fx (a derived column, 1001 rows)": simulate_and_read("Fx"),
        "1 000 co-simulation steps: set_inputs + advance_to(t + 1 ms)": cosim,
        "a six-bar (stephenson-iii), 1 000 co-simulation steps of 1 ms": cosim_scene("stephenson-iii", 1000),
        "the coupling rod, 1 000 co-simulation steps of 1 ms (two change points)": cosim_scene("coupling-rod", 1000),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", help="commit to compare against")
    ap.add_argument("--repeat", type=int, default=21)
    args = ap.parse_args()
    old = load_old(args.old)
    import grubler

    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    runs = {"old": workloads(old), "new": workloads(grubler)}
    steps = {v: {name: fn() for name, fn in w.items()} for v, w in runs.items()}  # warm (and compile)
    times = {v: {name: [] for name in w} for v, w in runs.items()}
    for _ in range(args.repeat):
        for name in runs["new"]:
            for v in ("old", "new"):
                t0 = time.perf_counter()
                runs[v][name]()
                times[v][name].append(time.perf_counter() - t0)
    print(f"Command: `python benchmarks/compare_versions.py {args.old} --repeat {args.repeat}` "
          f"(old {args.old}, new {head}; medians of {args.repeat}, the versions alternating)\n")
    print("| workload | old (ms) | new (ms) | new / old | steps old -> new |")
    print("|---|---|---|---|---|")
    for name in runs["new"]:
        a, b = (statistics.median(times[v][name]) * 1e3 for v in ("old", "new"))
        print(f"| {name} | {a:.2f} | {b:.2f} | {b / a:.2f} | {steps['old'][name]} -> {steps['new'][name]} |")


if __name__ == "__main__":
    main()
