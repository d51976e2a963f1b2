"""IFToMM benchmark A02, the N-four-bar mechanism, against an exact reference.

    python benchmarks/iftomm/a02.py [--n 1 2 5 10 20 40] [--t-end 20] [--csv FILE] [--repeat 3]

The problem (the A Coruña / IFToMM multibody benchmark library, González et al.):
N four-bar windows in a row made of 2N + 1 links, each 1 m long with 1 kg spread
evenly along it, under gravity (9.81 m/s^2 along -y).  The N + 1 cranks A_i B_i
turn about ground pivots A_i = (i, 0); the N couplers B_{i-1} B_i join their
tips.  At the start every crank is vertical and B0 = (0, 1) moves at 1 m/s
along +x.  The run is 20 s; the library's reference is the time history of the
position and velocity of B0 (x and y) at 400 output steps, with accuracy bands
1e-1 (low) and 1e-3 (high).  At the horizontal position all N loops are
singular at once and the mobility jumps from 1 to N + 1: every closure's
Jacobian loses rank there together.

The scene is a tree: the cranks hang from the ground at slides B = i along x,
coupler i hangs from crank i - 1's tip, and closure i pins coupler i's tip to
crank i's tip.  In exact arithmetic every N moves as one parallelogram (the
couplers translate), so the reference is a 1-DOF ODE in the crank angle phi,
written here from the energy with no code of the library's:

    ((N + 1) / 3 + N) phi'' = -g ((N + 1) / 2 + N) cos(phi),
    phi(0) = pi / 2, phi'(0) = -1 rad/s,

integrated by scipy's DOP853 at rtol = atol = 1e-13.  B0 = (cos phi, sin phi).

The error is the library's: for each of the four signals (x, y, vx, vy of B0),
at each of the 400 output instants, the difference from the reference, relative
to the reference's value where that exceeds the threshold 1e-3 and absolute
below it; the error is the largest over signals and instants.  The script also
prints the largest absolute difference.

--csv FILE writes t, x, y, vx, vy of B0 at the 400 output instants (N = the
last --n).  The CPU time is the simulation's own (process time of
grubler.simulate, scene loading and assembly included), the median of --repeat
runs in one process.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

G = 9.81
OUTPUT_STEPS = 400
THRESHOLD = 1e-3
HIGH_BAND, LOW_BAND = 1e-3, 1e-1
HERE = Path(__file__).resolve().parent
# the library's own submissions we could read (see docs/iftomm.md): OpenSim 3.2,
# N = 2 over 10 s on an Intel Core i5-4570 at 3.2 GHz
PUBLISHED = {(2, 10.0): ("OpenSim 3.2 (i5-4570 3.2 GHz, Windows 8.1)", 0.455)}


def crank_link(i: int) -> int:
    """The scene's link number (2 ..) of crank i (0 .. N): cranks and couplers alternate."""
    return 2 if i == 0 else 2 * i + 1


def coupler_link(i: int) -> int:
    """The link number of coupler i (1 .. N), which hangs from crank i - 1."""
    return 2 * i + 2


def scene_text(n: int, t_end: float = 20.0) -> str:
    """The A02 scene with N windows, as TOML (benchmarks/iftomm/a02_nfourbar.toml is N = 40: --scene)."""
    rows = [f'name = "iftomm-a02-n{n}"',
            f'description = "IFToMM benchmark A02: {n} four-bar windows of 1 m, 1 kg links sharing their cranks"',
            'kind = "N-four-bar (IFToMM A02)"',
            "gravity = 9.81",
            "",
            "[ground]",
            "a1 = 0.0",
            'theta1 = "-pi/2"      # the ground vector points down: its slide B runs along +x',
            ""]
    rod = ["a = 1.0", "m = 1.0", "p = 0.5", "I = 0.08333333333333333   # m l^2 / 12"]
    for i in range(n + 1):
        rows += [f"[link{crank_link(i)}]   # crank {i}, pivot A{i} = ({i}, 0)", 'joint = "R"', *rod,
                 'parent = "ground"', ""]
        if i:
            rows += [f"[link{coupler_link(i)}]   # coupler {i}, from B{i - 1}", 'joint = "R"', *rod,
                     f'parent = "link{crank_link(i - 1)}"', ""]
    for i in range(1, n + 1):
        rows += ["[[closure]]", 'type = "revolute"', f"link = {coupler_link(i)}      # coupler {i}'s tip ...",
                 f"to_link = {crank_link(i)}   # ... on crank {i}'s tip B{i}", "point = [1.0, 0.0]", ""]
    rows += ["[drive]", 'joint = "theta2"      # crank 0: held by assembly; no torque', "torque = 0.0", "",
             "[initial]"]
    for i in range(n + 1):
        k = crank_link(i)
        rows.append(f'theta{k} = "pi/2"')
        if i:
            rows.append(f"B{k - 1} = {float(i)}")  # the crank's pivot, i m along x
    for i in range(1, n + 1):
        rows.append(f"theta{coupler_link(i)} = 0.0")
    rows += ["theta2_d = -1.0      # B0 moves at 1 m/s along +x", "",
             "[simulate]", f"t_end = {t_end:g}", f"dt_out = {t_end / OUTPUT_STEPS:g}", 'method = "exact"', ""]
    return "\n".join(rows)


def reference(n: int, t: np.ndarray) -> np.ndarray:
    """Exact B0 (x, y, vx, vy) at times t: the parallelogram's 1-DOF ODE by scipy at 1e-13."""
    from scipy.integrate import solve_ivp

    inertia = (n + 1) / 3.0 + n          # cranks about their pivots, couplers translating with B
    weight = G * ((n + 1) / 2.0 + n)     # d(potential)/d(sin phi)

    def f(_t, s):
        return [s[1], -weight / inertia * math.cos(s[0])]

    sol = solve_ivp(f, (0.0, float(t[-1])), [math.pi / 2, -1.0], method="DOP853", t_eval=t,
                    rtol=1e-13, atol=1e-13)
    phi, w = sol.y
    return np.column_stack([np.cos(phi), np.sin(phi), -np.sin(phi) * w, np.cos(phi) * w])


def library_error(ours: np.ndarray, ref: np.ndarray) -> float:
    """Largest difference over signals and instants, relative where |reference| > the threshold."""
    diff = np.abs(ours - ref)
    scale = np.where(np.abs(ref) > THRESHOLD, np.abs(ref), 1.0)
    return float(np.max(diff / scale))


def b0_of(result) -> np.ndarray:
    """B0 (x, y, vx, vy): the tip of crank 0 (link 2, pivot at the origin) from its angle and rate."""
    cols, table = result.table(("state",))
    theta, omega = table[:, cols.index("theta2")], table[:, cols.index("theta2_d")]
    return np.column_stack([np.cos(theta), np.sin(theta), -np.sin(theta) * omega, np.cos(theta) * omega])


def run(n: int, t_end: float, rtol: float = 1e-10, atol: float = 1e-10):
    """One timed run: (result, process seconds)."""
    import grubler

    text = scene_text(n, t_end)
    start = time.process_time()
    result = grubler.simulate(grubler.load_scene(text), t_end=t_end, dt_out=t_end / OUTPUT_STEPS, rtol=rtol,
                              atol=atol)
    return result, time.process_time() - start


def plot(n: int, t: np.ndarray, ours: np.ndarray, ref: np.ndarray, path: Path) -> None:
    """B0's x, y and vx against the reference (top) and |difference| of all four (bottom), log scale."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for k, name in enumerate(("x", "y", "vx")):
        top.plot(t, ref[:, k], color="0.6", lw=3, label=f"{name} reference" if k == 0 else None)
        top.plot(t, ours[:, k], lw=1, label=f"B0 {name}")
    top.set_ylabel("m, m/s")
    top.legend(loc="upper right", fontsize=8, ncol=4)
    top.set_title(f"IFToMM A02, N = {n} ({2 * n + 1} links, {n} loops): point B0, grubler against the exact "
                  "1-DOF reference", fontsize=9)
    for k, name in enumerate(("x", "y", "vx", "vy")):
        bottom.semilogy(t, np.maximum(np.abs(ours[:, k] - ref[:, k]), 1e-16), lw=1, label=name)
    horizontal = t[np.r_[False, np.diff(np.sign(ref[:, 0] * 0 + ref[:, 1])) != 0]]
    for th in horizontal:
        bottom.axvline(th, color="0.85", lw=0.8)
    bottom.axhline(HIGH_BAND, color="red", lw=0.8, ls="--", label="high band 1e-3")
    bottom.set_ylabel("|grubler - reference|")
    bottom.set_xlabel("t, s (grey: the horizontal, every loop singular)")
    bottom.legend(loc="lower right", fontsize=8, ncol=5)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1, 2, 5, 10, 20, 40], help="windows N (default the table's)")
    ap.add_argument("--t-end", type=float, default=20.0, help="s (the library's: 20)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per N; the CPU time is their median")
    ap.add_argument("--rtol", type=float, default=1e-10, help="the integrator's (default 1e-10)")
    ap.add_argument("--atol", type=float, default=1e-10)
    ap.add_argument("--csv", type=Path, help="write t, x, y, vx, vy of B0 (the last N) here")
    ap.add_argument("--scene", type=Path, help="write the scene of the last N here and stop")
    ap.add_argument("--png", type=Path, help="plot B0 against the reference and the difference (the last N) here")
    args = ap.parse_args(argv)
    if min(args.n) < 1 or max(args.n) > 511:
        ap.error(f"--n: N four-bar windows, 1 to 511 (2N + 1 links, at most the kernel's 1024), got {args.n}")
    if not args.t_end > 0:
        ap.error(f"--t-end: must be > 0 s, got {args.t_end}")
    if args.scene:
        args.scene.write_text(scene_text(args.n[-1], args.t_end))
        return 0
    print(f"{'N':>3} {'links':>5} {'loops':>5} {'error':>9} {'max |diff|':>10} {'band':>5} {'steps':>6} "
          f"{'passages':>8} {'CPU s':>7}")
    worst = 0.0
    for n in args.n:
        times, result = [], None
        for _ in range(max(1, args.repeat)):
            result, cpu = run(n, args.t_end, args.rtol, args.atol)
            times.append(cpu)
        ours = b0_of(result)
        ref = reference(n, result.t)
        err = library_error(ours, ref)
        worst = max(worst, err)
        band = "high" if err <= HIGH_BAND else ("low" if err <= LOW_BAND else "none")
        stats = result.stats
        print(f"{n:>3} {2 * n + 1:>5} {n:>5} {err:>9.2e} {np.max(np.abs(ours - ref)):>10.2e} {band:>5} "
              f"{stats.get('steps', 0):>6} {stats.get('passage_count', 0):>8} {float(np.median(times)):>7.3f}")
        published = PUBLISHED.get((n, args.t_end))
        if published:
            print(f"    published: {published[0]}: {published[1]} s")
        if args.png and n == args.n[-1]:
            plot(n, result.t, ours, ref, args.png)
        if args.csv and n == args.n[-1]:
            with open(args.csv, "w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(["t", "x", "y", "vx", "vy"])
                for t, row in zip(result.t, ours):
                    w.writerow([f"{t:.6g}", *(f"{v:.12g}" for v in row)])
    return 0 if worst <= HIGH_BAND else 1


if __name__ == "__main__":
    sys.exit(main())
