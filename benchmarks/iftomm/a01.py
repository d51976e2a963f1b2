"""IFToMM benchmark A01, the simple pendulum, against the exact pendulum.

The library's statement (mbsbenchmark A01, Gonzalez et al.): a 1 kg point mass on a
massless 1 m link under gravity 9.81 N/kg along -y, released at rest horizontal with
the mass at x = +1 m, simulated for 2000 s; the result is the mass's position (x, y)
at 4000 output steps (every 0.5 s), and the allowed errors are 1e-1 (low precision)
and 1e-3 (high precision).

The reference is the closed form, sharing no code with grubler.  With phi the angle
from the downward vertical (phi0 = pi/2), k = sin(phi0 / 2), m = k^2 and
w = sqrt(g / L), the pendulum released at rest from its amplitude is

    sin(phi / 2) = k sn(K(m) - w t | m),   cos(phi / 2) = dn(K(m) - w t | m),

so x = L sin(phi) = 2 L k sn dn and y = -L cos(phi) = L (2 m sn^2 - 1), and its
period is 4 K(m) / w (scipy.special.ellipj, ellipk).

The error printed is the largest deviation of x and y from the exact ones over the
4001 output instants, in metres (the link is 1 m, so it is also relative); the
library's own formula (its "threshold value of 1.0E-3") was not within reach, so
this is the plain maximum, the strictest reading.  The period is also read off the
run (the mass's upward crossings of x = 0) and compared with 4 K / w.

    python benchmarks/iftomm/a01.py [--rtol 1e-10] [--repeat 7] [--csv FILE]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy.special import ellipj, ellipk

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from timing import machine, median_cpu  # noqa: E402

from grubler.mechanism.scene import load_scene  # noqa: E402
from grubler.mechanism.simulate import simulate  # noqa: E402

SCENE = HERE / "a01_pendulum.toml"
G, L = 9.81, 1.0
PHI0 = math.pi / 2          # released horizontal
T_END, STEPS = 2000.0, 4000
BANDS = {"low": 1e-1, "high": 1e-3}
OPENSIM_10S = 0.637         # s, OpenSim 3.2, A01 for 10 s (Intel i5-4570 @ 3.2 GHz)


def exact(t):
    """The mass's exact (x, y), m, at the times t, s."""
    m = math.sin(PHI0 / 2) ** 2
    K = ellipk(m)
    # reduce the argument to one period first: ellipj of a large argument loses digits
    u = np.mod(K - math.sqrt(G / L) * np.asarray(t, dtype=float), 4 * K)
    sn, _, dn, _ = ellipj(u, m)
    return 2 * L * math.sqrt(m) * sn * dn, L * (2 * m * sn**2 - 1)


def period() -> float:
    return 4 * ellipk(math.sin(PHI0 / 2) ** 2) / math.sqrt(G / L)


def upward_crossings(t, x, xd):
    """Times where x rises through 0, by cubic Hermite interpolation between the samples."""
    out = []
    for i in np.nonzero((x[:-1] < 0) & (x[1:] >= 0))[0]:
        h = t[i + 1] - t[i]
        lo, hi = 0.0, 1.0
        for _ in range(60):  # bisection on the Hermite cubic
            s = (lo + hi) / 2
            h00, h10, h01, h11 = 2*s**3 - 3*s**2 + 1, s**3 - 2*s**2 + s, -2*s**3 + 3*s**2, s**3 - s**2
            v = h00 * x[i] + h10 * h * xd[i] + h01 * x[i + 1] + h11 * h * xd[i + 1]
            lo, hi = (s, hi) if v < 0 else (lo, s)
        out.append(t[i] + h * (lo + hi) / 2)
    return np.array(out)


def run(rtol: float, t_end: float = T_END, dt_out: float = T_END / STEPS):
    return simulate(load_scene(SCENE), t_end=t_end, dt_out=dt_out, rtol=rtol, atol=rtol)


def errors(res) -> dict:
    x, y = exact(res.t)
    ex = float(np.max(np.abs(res["tip_x"] - x)))
    ey = float(np.max(np.abs(res["tip_y"] - y)))
    return {"error_x": ex, "error_y": ey, "error": max(ex, ey)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rtol", type=float, default=1e-10, help="integration tolerance (rtol = atol)")
    ap.add_argument("--repeat", type=int, default=7, help="timed runs; the median is reported")
    ap.add_argument("--csv", help="write t, x, y and the exact x, y at the 4001 output instants")
    args = ap.parse_args(argv)

    cpu, _, res = median_cpu(lambda: run(args.rtol), args.repeat)
    err = errors(res)
    # the period, from a finer record of the same run (the 0.5 s outputs are too sparse for crossings)
    fine = run(args.rtol, t_end=20 * period(), dt_out=0.01)
    xd = -L * np.sin(fine["theta2"]) * fine["theta2_d"]
    crossings = upward_crossings(fine.t, fine["tip_x"], xd)
    measured = float(np.mean(np.diff(crossings)))
    cpu10, _, _ = median_cpu(lambda: run(args.rtol, t_end=10.0, dt_out=10.0 / STEPS), args.repeat)

    band = next((name for name, tol in sorted(BANDS.items(), key=lambda kv: kv[1]) if err["error"] < tol), "none")
    print(f"A01 simple pendulum, 2000 s, {STEPS} output steps, DOP853 rtol = atol = {args.rtol:g}")
    print(f"  error (max |x - x_exact|, |y - y_exact| over the outputs): x {err['error_x']:.2e} m, "
          f"y {err['error_y']:.2e} m -> band: {band}")
    print(f"  period: exact 4K/w = {period():.12f} s, measured over 20 periods {measured:.12f} s "
          f"(difference {measured - period():.1e} s)")
    print(f"  CPU time: {cpu:.4f} s for 2000 s (median of {args.repeat}); {cpu10:.5f} s for 10 s "
          f"(OpenSim 3.2, 10 s: {OPENSIM_10S} s)")
    print(f"  machine: {machine()}")
    if args.csv:
        x, y = exact(res.t)
        np.savetxt(args.csv, np.column_stack([res.t, res["tip_x"], res["tip_y"], x, y]), delimiter=",",
                   header="t,x,y,x_exact,y_exact", comments="", fmt="%.15g")
    return 0


if __name__ == "__main__":
    sys.exit(main())
