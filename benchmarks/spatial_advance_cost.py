"""Cost of the spatial advance (grs_advance) on the presets, this kernel against another build of it, in one
process, runs alternating.

    python benchmarks/spatial_advance_cost.py --before /tmp/old_kernel.so [--repeat 7]

``--before``: the shared object of another build of the kernel (``grubler/_kernel*.so`` copied from a checkout
before a change); its ``grs_*`` functions are declared as this package's binding declares them and the same
mechanisms are run through it.  Each problem is a driven run from its assembled start (10 s of the RSSR under
0.5 N m on the crank; the spherical four-bar, 0.1 N m, and the Bennett linkage, 1 mN m, the mobility-one
presets whose closure conditioning the advance now watches for change points), rtol = atol = 1e-10.  The
machine is shared: the process's CPU seconds (time.process_time: the kernel runs in one thread, and the
other engineers' load moves wall time by +-40 % here), the median of the per-pair ratios and of each build's
times over the repeats, the two builds taking turns.  Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import ctypes
import statistics
import time

import numpy as np

from grubler import binding
from grubler.mechanism import spatial as sp

PROBLEMS = {"rssr": (sp.rssr, 0.5, 10.0), "spherical-fourbar": (sp.spherical_fourbar, 0.1, 10.0),
            "bennett": (sp.bennett, 1e-3, 4.0)}


def other_library(path: str) -> ctypes.CDLL:
    lib = binding.declare(ctypes.CDLL(path))
    for name, (restype, argtypes) in binding._SPATIAL_SIGNATURES.items():
        if not hasattr(lib, name):  # a build from before the function (grs_passages: before the chart)
            setattr(lib, name, lambda *args: 0)
            continue
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    return lib


def run(m, y0, tau, t_end) -> tuple[float, int, np.ndarray]:
    t0 = time.process_time()
    res = m.simulate(y0, t_end=t_end, dt_out=t_end / 100, tau=tau, rtol=1e-10, atol=1e-10)
    return time.process_time() - t0, res.steps, res.y[-1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="another build's kernel shared object")
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    before = other_library(args.before)
    print("| problem | steps before / after | median CPU s before | median CPU s after | after / before (median of "
          "pairs) | end states differ by |")
    print("|---|---|---|---|---|---|")
    for name, (build, torque, t_end) in PROBLEMS.items():
        new, old = build(), build()
        old._lib = before
        y0 = new.assembled_start()
        tau = np.zeros(new.n_coords)
        tau[0] = torque
        times, ratios = {"old": [], "new": []}, []
        for _ in range(args.repeat):
            for key, m in (("old", old), ("new", new)):
                seconds, steps, end = run(m, y0, tau, t_end)
                times[key].append(seconds)
                if key == "old":
                    steps_old, end_old = steps, end
                else:
                    steps_new, end_new = steps, end
            ratios.append(times["new"][-1] / times["old"][-1])
        a, b = statistics.median(times["old"]), statistics.median(times["new"])
        print(f"| {name}, {t_end:g} s | {steps_old} / {steps_new} | {a:.3f} | {b:.3f} | {statistics.median(ratios):.3f} | "
              f"{np.max(np.abs(end_new - end_old)):.2g} |")


if __name__ == "__main__":
    main()
