"""Where the servo co-simulation's time goes: per component and per FMI call.

    python benchmarks/cosim_profile.py [--t-end 10] [--step 1e-3] [--repeat 5]

Runs examples/servo_fourbar.ssd (the README's main job) with grubler's master,
first plainly (the wall time a user sees, median of --repeat runs), then once
with every component's setReal, doStep and getReal timed (the timers add their
own small cost, so the shares are what to read, not the sum).  Prints a
Markdown table.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections import defaultdict
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import build_fmu  # noqa: E402
from grubler import cosim  # noqa: E402

SSD = HERE.parent / "examples" / "servo_fourbar.ssd"


def timed(totals, counts):
    """Wrap the master's per-instance calls with timers keyed by (component, call)."""
    originals = {name: getattr(cosim._Instance, name) for name in ("push", "do_step", "publish")}

    def wrap(name, fn):
        def call(self, *args, **kw):
            t0 = time.perf_counter()
            try:
                return fn(self, *args, **kw)
            finally:
                totals[(self.name, name)] += time.perf_counter() - t0
                counts[(self.name, name)] += 1
        return call

    for name, fn in originals.items():
        setattr(cosim._Instance, name, wrap(name, fn))
    return originals


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=10.0)
    ap.add_argument("--step", type=float, default=1e-3)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    if not all((HERE.parent / "dist" / f"{n}.fmu").exists() for n in build_fmu.FMUS):
        build_fmu.build()
    cosim.run(SSD, t_end=0.1, step=args.step)  # warm: extraction, first loads
    walls = []
    for _ in range(args.repeat):
        res = cosim.run(SSD, t_end=args.t_end, step=args.step)
        walls.append(res.wall_time)
    totals, counts = defaultdict(float), defaultdict(int)
    originals = timed(totals, counts)
    try:
        res = cosim.run(SSD, t_end=args.t_end, step=args.step)
    finally:
        for name, fn in originals.items():
            setattr(cosim._Instance, name, fn)
    steps = round(args.t_end / args.step)
    print(f"Command: `python benchmarks/cosim_profile.py --t-end {args.t_end:g} --step {args.step:g} "
          f"--repeat {args.repeat}`\n")
    print(f"Wall time of {args.t_end:g} s at {args.step:g} s ({steps} steps), grubler's master: median "
          f"{statistics.median(walls):.3f} s (runs: {', '.join(f'{w:.3f}' for w in walls)}).\n")
    print("| component | setReal (us/call) | doStep (us/call) | getReal (us/call) | total (s) | share |")
    print("|---|---|---|---|---|---|")
    grand = sum(totals.values())
    for comp in res.order:
        row = [totals[(comp, c)] / max(counts[(comp, c)], 1) * 1e6 for c in ("push", "do_step", "publish")]
        total = sum(totals[(comp, c)] for c in ("push", "do_step", "publish"))
        print(f"| {comp} | {row[0]:.1f} | {row[1]:.1f} | {row[2]:.1f} | {total:.3f} | {100 * total / grand:.0f} % |")
    print(f"\nInstrumented run: {res.wall_time:.3f} s wall, {grand:.3f} s inside the timed calls.")


if __name__ == "__main__":
    main()
