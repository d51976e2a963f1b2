"""How the cost grows with links and closures: IFToMM A02 for N = 1, 2, 5, 10, 20, 40.

    python benchmarks/iftomm/a02_scaling.py [--n 1 2 5 10 20 40] [--repeat 3] [--t-end 20]

For each N (2N + 1 links, N closures, 2N closure rows) in this one process:
  - one evaluation of the state equation (the kernel's grb_rhs, exact method, at
    the assembled start: far from the singular position), median over a batch;
  - the whole 20 s run (grubler.simulate, the library's 400 outputs), its CPU
    time (median of --repeat), steps, evaluations and change-point passages;
    the cost per step is the run's time over its accepted steps, passages and
    their charts included, and the run's error against the exact reference
    (benchmarks/iftomm/a02.py's definitions).
Process (CPU) time throughout; the machine is shared, so compare rows measured in
one run.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import a02  # noqa: E402


def rhs_cost(n: int, batch: int, repeat: int) -> float:
    """CPU seconds of one grb_rhs at the assembled start of A02 with N windows."""
    import grubler
    from grubler import binding

    scene = grubler.load_scene(a02.scene_text(n))
    res = grubler.simulate(scene, t_end=0.01, dt_out=0.01)
    y = np.concatenate([res.z[0], res.zd[0]])
    m = scene.mechanism
    lib = binding.library()
    work = binding.work(m.n_links, len(m.closures))
    out = np.zeros_like(y)
    c = m.arrays.c
    ya, wa, oa = binding.address(y), binding.address(work), binding.address(out)
    lib.grb_rhs(c, 0, ya, 0.0, 0.0, wa, oa)
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        for _ in range(batch):
            lib.grb_rhs(c, 0, ya, 0.0, 0.0, wa, oa)
        times.append((time.process_time() - t0) / batch)
    return statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1, 2, 5, 10, 20, 40])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=20.0)
    args = ap.parse_args(argv)
    print(f"| N | links | closures (rows) | one rhs, µs | 20 s run, CPU s | steps | rhs evals | passages | "
          f"per step, ms | error (library) | max abs diff |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.n:
        batch = max(20, int(2000 / n ** 2))
        rhs = rhs_cost(n, batch, args.repeat)
        cpu, result = [], None
        for _ in range(args.repeat):
            result, t = a02.run(n, args.t_end)
            cpu.append(t)
        ours = a02.b0_of(result)
        ref = a02.reference(n, result.t)
        st = result.stats
        total = statistics.median(cpu)
        print(f"| {n} | {2 * n + 1} | {n} ({2 * n}) | {rhs * 1e6:.1f} | {total:.3f} | {st['steps']} | "
              f"{st['rhs_evals']} | {st['passage_count']} | {1e3 * total / st['steps']:.2f} | "
              f"{a02.library_error(ours, ref):.1e} | {np.max(np.abs(ours - ref)):.1e} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
