"""Where the servo co-simulation's time goes: per component and per FMI call.

    python benchmarks/cosim_profile.py [--t-end 10] [--step 1e-3] [--repeat 5]

Runs examples/servo_fourbar.ssd (the README's main job) with grubler's master,
first plainly (the wall time a user sees, median of --repeat runs), then once
with every component's setReal, doStep and getReal timed by the master's C
loop (``cosim.run(..., profile=True)``: two clock readings per call).  What
is left of the wall time is the master itself: reading the system,
instantiating, initialising, its stepping loop.  Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import build_fmu  # noqa: E402
from grubler import cosim  # noqa: E402

SSD = HERE.parent / "examples" / "servo_fourbar.ssd"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=10.0)
    ap.add_argument("--step", type=float, default=1e-3)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--system", type=Path, default=SSD, help="the .ssd to run (default: the README's servo four-bar)")
    ap.add_argument("--master", choices=cosim.MASTERS, help="the master (default: cosim.run's)")
    ap.add_argument("--tol", type=float, help="the extrapolating master's tolerance (default: none, a fixed step)")
    args = ap.parse_args()
    how = {"master": args.master, "tol": args.tol}
    if args.system == SSD and not all((HERE.parent / "dist" / f"{n}.fmu").exists() for n in build_fmu.FMUS):
        build_fmu.build()
    system = args.system
    cosim.run(system, t_end=0.1, step=args.step, **how)  # warm: extraction, first loads
    walls = []
    for _ in range(args.repeat):
        res = cosim.run(system, t_end=args.t_end, step=args.step, **how)
        walls.append(res.wall_time)
    res = cosim.run(system, t_end=args.t_end, step=args.step, profile=True, **how)
    steps = round(args.t_end / args.step)
    where = "" if system == SSD else f" --system {system}"
    where += "".join(f" --{k} {v}" for k, v in how.items() if v is not None)
    print(f"Command: `python benchmarks/cosim_profile.py --t-end {args.t_end:g} --step {args.step:g} "
          f"--repeat {args.repeat}{where}`\n")
    print(f"Wall time of {args.t_end:g} s at {args.step:g} s ({steps} steps), grubler's master ({res.master}): median "
          f"{statistics.median(walls):.3f} s (runs: {', '.join(f'{w:.3f}' for w in walls)}), "
          f"{args.t_end / statistics.median(walls):.0f}x real time.\n")
    print("| component | setReal (us/step) | doStep (us/step) | getReal (us/step) | total (s) | share |")
    print("|---|---|---|---|---|---|")
    grand = sum(sum(v) for v in res.profile.values())
    for comp in res.order:
        calls = res.profile[comp]
        row = " | ".join(f"{x / steps * 1e6:.1f}" for x in calls)
        print(f"| {comp} | {row} | {sum(calls):.3f} | {100 * sum(calls) / grand:.0f} % |")
    print(f"| the master itself | | | | {res.wall_time - grand:.3f} | |")
    print(f"\nProfiled run: {res.wall_time:.3f} s wall (set-up, initialisation and the first row included), "
          f"{grand:.3f} s inside the FMUs' calls.")


if __name__ == "__main__":
    main()
