"""Sweep throughput: points per second on 1 and 2 local processes and a Dask cluster.

    python benchmarks/sweep_throughput.py [--points 24] [--t-end 1.0] [--repeat 3] [--out docs/sweeps.md]

Every variant runs the same sweep (the thesis four-bar over a grid of crank
lengths and drive torques, ``t_end`` simulated seconds a point) through
:func:`grubler.studies.sweep.run_sweep`; the Dask variant starts a
``distributed.LocalCluster`` with two single-threaded worker processes, as a
two-node cluster would run it, and its start-up is timed apart.  Times are
medians over --repeat runs, measured in one process, one variant after another.
"""

from __future__ import annotations

import argparse
import functools
import os
import platform
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from grubler.studies.sweep import evaluate_point, grid, run_sweep, scene_point  # noqa: E402


def points(n: int) -> list[dict]:
    torques = [0.0, 1.0, 3.0]
    lengths = [0.12 + 0.12 * i / max(n // 3 - 1, 1) for i in range(max(n // 3, 1))]
    return grid(**{"link2.a": lengths, "drive.torque": torques})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=24)
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    func = functools.partial(scene_point, "thesis-fourbar", t_end=args.t_end)
    pts = points(args.points)
    # the cost of one point in this process, after a first call that pays imports
    evaluate_point(func, pts[0])
    one = statistics.median(evaluate_point(func, p)["seconds"] for p in pts[:5])
    rows = []
    for label, kw in (("1 process", {"workers": 1}), ("2 processes", {"workers": 2})):
        walls = []
        for _ in range(args.repeat):
            t = run_sweep(func, pts, progress=False, **kw)
            assert not t.failed, t.failed[0]["error"]
            walls.append(t.wall_time)
        rows.append((label, statistics.median(walls), ""))
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        rows.append(("Dask LocalCluster", float("nan"), "dask.distributed not installed"))
    else:
        t0 = time.perf_counter()
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                          silence_logs=40) as cluster, Client(cluster) as client:
            start = time.perf_counter() - t0
            walls = []
            for _ in range(args.repeat):
                t = run_sweep(func, pts, progress=False, scheduler=client)
                assert not t.failed, t.failed[0]["error"]
                walls.append(t.wall_time)
        rows.append(("Dask LocalCluster, 2 workers", statistics.median(walls), f"cluster start-up {start:.1f} s"))
    n = len(pts)
    base = rows[0][1]
    lines = [
        "| where | wall time (median) | points/s | speed-up over 1 process | note |",
        "|---|---|---|---|---|",
    ]
    for label, wall, note in rows:
        lines.append(f"| {label} | {wall:.2f} s | {n / wall:.2f} | {base / wall:.2f}x | {note} |")
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")),
               platform.processor()) if os.path.exists("/proc/cpuinfo") else platform.processor()
    text = "\n".join([
        f"{n} points of {args.t_end:g} s each (thesis four-bar, crank length x drive torque); "
        f"one point costs {one * 1e3:.0f} ms in a warm process (median of 5).",
        "",
        *lines,
        "",
        f"Machine: {os.cpu_count()} cores ({cpu}), Python {platform.python_version()}; "
        f"medians of {args.repeat} runs. Command: `python benchmarks/sweep_throughput.py "
        f"--points {args.points} --t-end {args.t_end:g} --repeat {args.repeat}`.",
    ])
    print(text)
    if args.out:
        args.out.write_text(args.out.read_text().split("<!-- results -->")[0] + "<!-- results -->\n\n" + text + "\n"
                            if args.out.exists() else text + "\n")


if __name__ == "__main__":
    main()
