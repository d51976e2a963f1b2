"""IFToMM benchmark A03, Andrews' squeezing mechanism, against the published reference.

The mechanism (seven bodies, one degree of freedom, a spring c0 = 4530 N/m,
l0 = 0.07785 m, a drive torque of 0.033 N m, no gravity) is Hairer & Wanner's
(Solving ODEs II, VII.7) and the Bari "Test Set for IVP Solvers" (Mazzia et al.,
problem "andrews"), whose reference solution at t = 0.03 s gives the seven angles
(beta, Theta, gamma, Phi, delta, Omega, epsilon) to 16 digits (computed by PSIDE at
rtol = atol = 1e-14).  The IFToMM library (A03) takes the same problem; its own
statement and reference history were not within reach of this study (OpenSim 3.2's
submission runs it for 0.05 s: 0.384 s of CPU).

This script runs the scene a03_andrews.toml, maps our absolute link angles to the
test set's seven, and compares them at t = 0.03 s with

- the published values (digits matched: -log10 |ours - published| / |published|);
- an independent reference (andrews_reference.py: the test set's own formulation,
  Lagrange's equations with the six closures at the acceleration level, scipy's
  DOP853 at 1e-13; it shares no code with grubler).

Ours and the independent reference agree to about 1e-11 rad, and both differ from
the published values by the published rates times one and the same 1.0e-12 s: the
published digits are, to about 4e-12 rad, the solution at t = 0.03 + 1.0e-12 s.  The
script prints that implied time offset for every angle.

    python benchmarks/iftomm/a03.py [--rtol 1e-12] [--repeat 7] [--json FILE] [--sweep]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import andrews_reference  # noqa: E402
from timing import machine, median_cpu  # noqa: E402

from grubler.mechanism.scene import load_scene  # noqa: E402
from grubler.mechanism.simulate import simulate  # noqa: E402

SCENE = HERE / "a03_andrews.toml"
NAMES = andrews_reference.NAMES
T_REF = 0.03
# the test set's reference solution at t = 0.03 s (SOLN of andrews.f, PSIDE at 1e-14): the angles and their rates
PUBLISHED = np.array([0.1581077119629904e+2, -0.1575637105984298e+2, 0.4082224013073101e-1,
                      -0.5347301163226948e+0, 0.5244099658805304e+0, 0.5347301163226948e+0,
                      0.1048080741042263e+1])
PUBLISHED_RATES = np.array([0.1139920302151208e+4, -0.1424379294994111e+4, 0.1103291221937134e+2,
                            0.1929337464421385e+2, 0.5735699284790808e+0, -0.1929337464421385e+2,
                            0.3231791658026955e+0])
MOM = 0.033  # N m, the drive torque
OPENSIM_005 = 0.384  # s, OpenSim 3.2, A03 for 0.05 s (Intel i5-4570 @ 3.2 GHz)


def test_set_angles(theta: dict) -> np.ndarray:
    """The test set's (beta, Theta, gamma, Phi, delta, Omega, epsilon) from our absolute angles theta2..theta8.

    The scene's comments give the geometry: link3 runs F -> E (the test set's body 2
    points E -> F), link4 E -> B, link5 E -> G, link6 G -> A, link7 E -> H, link8 H -> A.
    """
    pi = math.pi
    beta = theta[2]
    delta = theta[6] - pi
    epsilon = theta[8] - pi / 2
    return np.array([beta, theta[3] - beta - pi, theta[4] - pi / 2, theta[5] - delta - pi / 2, delta,
                     theta[7] - epsilon - pi, epsilon])


def run(rtol: float, t_end: float = T_REF):
    return simulate(load_scene(SCENE), t_end=t_end, dt_out=t_end, rtol=rtol, atol=rtol)


def final_angles(res) -> np.ndarray:
    return test_set_angles({k: float(res[f"theta{k}"][-1]) for k in range(2, 9)})


def digits(ours: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Significant digits matched, -log10 of the relative error (17 where they are equal)."""
    rel = np.abs(ours - ref) / np.abs(ref)
    return np.where(rel > 0, -np.log10(np.maximum(rel, 1e-17)), 17.0)


def compare(angles: np.ndarray, independent: np.ndarray | None) -> dict:
    out = {"t": T_REF,
           "angles": dict(zip(NAMES, map(float, angles))),
           "published": dict(zip(NAMES, map(float, PUBLISHED))),
           "error_published": dict(zip(NAMES, map(float, angles - PUBLISHED))),
           "digits_published": dict(zip(NAMES, map(float, digits(angles, PUBLISHED)))),
           # the time offset that would explain each difference: (ours - published) / published rate
           "implied_offset_s": dict(zip(NAMES, map(float, (PUBLISHED - angles) / PUBLISHED_RATES)))}
    if independent is not None:
        out["independent"] = dict(zip(NAMES, map(float, independent)))
        out["error_independent"] = dict(zip(NAMES, map(float, angles - independent)))
        out["digits_independent"] = dict(zip(NAMES, map(float, digits(angles, independent))))
    return out


def energy_drift(rtol: float, t_end: float = 0.05) -> float:
    """The largest |E(t) - E(0) - mom (beta(t) - beta(0))| over a run, J: the energy balance (no damping here).

    E = KE + PE holds the spring's energy; the drive's work is its constant torque
    times the crank's turn.
    """
    res = simulate(load_scene(SCENE), t_end=t_end, dt_out=t_end / 100, rtol=rtol, atol=rtol)
    work = MOM * (res["theta2"] - res["theta2"][0])
    return float(np.max(np.abs(res["E"] - res["E"][0] - work)))


def sweep(independent: np.ndarray, repeat: int) -> list[dict]:
    rows = []
    for rtol in (1e-6, 1e-8, 1e-10, 1e-12, 1e-13):
        cpu, _, res = median_cpu(lambda: run(rtol), repeat)
        a = final_angles(res)
        rows.append({"rtol": rtol, "cpu_s": cpu, "steps": res.stats["steps"],
                     "error_published": float(np.max(np.abs(a - PUBLISHED))),
                     "error_independent": float(np.max(np.abs(a - independent)))})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rtol", type=float, default=1e-12, help="integration tolerance (rtol = atol)")
    ap.add_argument("--repeat", type=int, default=7, help="timed runs; the median is reported")
    ap.add_argument("--json", help="write the seven angles at t = 0.03 s and their comparisons as JSON")
    ap.add_argument("--no-independent", action="store_true", help="skip the independent reference (about 1 s)")
    ap.add_argument("--sweep", action="store_true", help="also the CPU time and error over tolerances 1e-6..1e-13")
    args = ap.parse_args(argv)

    cpu, _, res = median_cpu(lambda: run(args.rtol), args.repeat)
    cpu05, _, _ = median_cpu(lambda: run(args.rtol, t_end=0.05), args.repeat)
    angles = final_angles(res)
    independent = None if args.no_independent else andrews_reference.solve(T_REF)[0]
    out = compare(angles, independent)
    drift = energy_drift(args.rtol)
    out.update(energy_drift_0_05=drift, rtol=args.rtol, steps=res.stats["steps"], cpu_s=cpu, cpu_s_0_05=cpu05, repeat=args.repeat,
               machine=machine())

    print(f"A03 Andrews' squeezing mechanism at t = {T_REF} s, DOP853 rtol = atol = {args.rtol:g} "
          f"({res.stats['steps']} steps)")
    head = f"  {'angle':8s} {'ours':>23s} {'published':>23s} {'digits':>6s} {'offset (s)':>10s}"
    print(head + (f" {'independent':>23s} {'digits':>6s}" if independent is not None else ""))
    for i, name in enumerate(NAMES):
        line = (f"  {name:8s} {angles[i]:+23.16e} {PUBLISHED[i]:+23.16e} {out['digits_published'][name]:6.1f} "
                f"{out['implied_offset_s'][name]:10.3e}")
        if independent is not None:
            line += f" {independent[i]:+23.16e} {out['digits_independent'][name]:6.1f}"
        print(line)
    print(f"  digits matched (the fewest): published {min(out['digits_published'].values()):.1f}"
          + (f", independent {min(out['digits_independent'].values()):.1f}" if independent is not None else ""))
    print(f"  energy balance over 0.05 s: max |E - E0 - drive work| = {drift:.1e} J "
          f"(the drive puts in {MOM * (final_angles(run(args.rtol, 0.05))[0] - andrews_reference.Q0[0]):.4f} J)")
    print(f"  CPU time: {cpu:.4f} s to 0.03 s, {cpu05:.4f} s to 0.05 s (median of {args.repeat}; "
          f"OpenSim 3.2, 0.05 s: {OPENSIM_005} s)")
    print(f"  machine: {out['machine']}")
    if args.sweep and independent is not None:
        out["sweep"] = sweep(independent, args.repeat)
        print(f"  {'rtol':>6s} {'CPU (s)':>8s} {'steps':>6s} {'vs published':>12s} {'vs independent':>14s}")
        for row in out["sweep"]:
            print(f"  {row['rtol']:6.0e} {row['cpu_s']:8.4f} {row['steps']:6d} {row['error_published']:12.2e} "
                  f"{row['error_independent']:14.2e}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
