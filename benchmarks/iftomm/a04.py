"""IFToMM multibody benchmark A04, the Bricard mechanism, on the spatial kernel: error and CPU time.

The problem (González, Dopico, Lugrís, Cuadrado 2006; the IFToMM library's A04):
five rods of 1 m and 1 kg (square section 0.1 m) and six revolute joints in a loop,
overconstrained (Grübler's count gives no mobility, the axes' layout one), gravity
9.81 along -y, from rest at the pose the library draws, 10 s.  The reference
solution is the time history of point P3 (joint 3: rod 2's far end).  Built by
``grubler.mechanism.spatial.bricard()``.

Error, as the library states it for its A problems (its A02 page: the largest
deviation of the reference point's coordinates from the reference solution over
the output steps; 1e-1 is "low", 1e-3 "high precision"): here the largest
|P3 - P3_ref| over 400 outputs of 0.025 s, any coordinate (each output
ends a step of the spatial advance, so the grid bounds the step).  The library's data
file (A04_solution_data.txt) is not in the stored references, so P3_ref is

- with ``--bodies``: the body-coordinate Newton-Euler model of the tests
  (tests/spatial_bodies.py: quaternions, the six revolutes as constraint rows,
  scipy's DOP853 at 1e-12; it shares no code with the kernel), and
- always: the kernel itself at rtol = atol = 1e-13 (self-convergence);

the library's plotted reference is checked at its turning points (P3 at
(-1, -1, 0) at 2.5 s and 7.5 s, back at (1, -1, 0) at 5 s and 10 s).  The run's
energy drift (the measure OpenSim's A04 page uses) is reported too.

CPU time: ``time.process_time`` of the simulate call alone (model built, start
assembled, outputs post-processed outside it), the best of ``--rounds``.

    python benchmarks/iftomm/a04.py [--rounds 5] [--dt 0.025] [--bodies]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time

import numpy as np

from grubler.mechanism import spatial as sp

T_END, DT = 10.0, 0.025  # 400 output steps, as the library's A02 statement measures
TURNING = {2.5: (-1.0, -1.0, 0.0), 5.0: (1.0, -1.0, 0.0), 7.5: (-1.0, -1.0, 0.0), 10.0: (1.0, -1.0, 0.0)}


def run(m, y0, tol: float, dt: float = DT):
    return m.simulate(y0, t_end=T_END, dt_out=dt, rtol=tol, atol=tol)


def cpu_time(m, y0, tol: float, rounds: int, dt: float) -> float:
    best = math.inf
    for _ in range(rounds):
        t0 = time.process_time()
        run(m, y0, tol, dt)
        best = min(best, time.process_time() - t0)
    return best


def body_reference(m, y0) -> np.ndarray:
    """P3 over the output grid from the tests' body-coordinate model (not timed)."""
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tests"))
    from spatial_bodies import Body, BodySystem, Revolute, rotation  # noqa: E402  (a test helper, not grubler)

    z0 = y0[:m.n_coords]
    origins, frames = m.frames(z0)
    centres = [origins[k] + frames[k] @ np.array(l.com) for k, l in enumerate(m.links)]
    bodies = [Body(l.mass, np.array(l.inertia), centres[k], frames[k]) for k, l in enumerate(m.links)]
    # A04's six joints at the start: rod k between joints k and k + 1, the ground from joint 6 to joint 1
    joints = [(0, -1), (1, 0), (2, 1), (3, 2), (4, 3), (4, -1)]
    revolutes = []
    for (i, j), (point, axis) in zip(joints, sp.BRICARD_JOINTS):
        point, axis = np.array(point, float), np.array(axis, float)

        def local(k):
            return (point, axis) if k < 0 else (frames[k].T @ (point - centres[k]), frames[k].T @ axis)
        (a, u), (b, v) = local(i), local(j)
        revolutes.append(Revolute(i, a, j, b, u, v))
    system = BodySystem(bodies, revolutes, np.array(m.gravity))
    t = np.linspace(0.0, T_END, int(round(T_END / DT)) + 1)
    ys = system.run(t, rtol=1e-12, atol=1e-12)
    tip = frames[1].T @ (np.array(sp.BRICARD_JOINTS[2][0], float) - centres[1])  # P3 on rod 2
    return np.array([system.unpack(y)[1][0] + rotation(system.unpack(y)[1][1]) @ tip for y in ys])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5, help="timed repetitions per tolerance (best counts)")
    ap.add_argument("--dt", type=float, default=DT, help="output interval, s (P3's grid; a multiple of 0.025)")
    ap.add_argument("--bodies", action="store_true", help="also run the body-coordinate reference (about a minute)")
    args = ap.parse_args(argv)
    m = sp.bricard()
    y0 = m.assembled_start()
    tight = run(m, y0, 1e-13)
    p_ref = sp.bricard_p3(m, tight.y)
    print(f"A04 Bricard, {T_END:g} s from rest, P3 every {args.dt:g} s; {platform.processor() or platform.machine()}, "
          f"load {os.getloadavg()[0]:.1f}")
    if args.bodies:
        t0 = time.perf_counter()
        p_body = body_reference(m, y0)
        print(f"kernel at 1e-13 vs the body-coordinate model: P3 max |error| "
              f"{np.abs(p_ref - p_body).max():.2e} m ({time.perf_counter() - t0:.0f} s for the body model)")
    worst_turn = max(np.abs(p_ref[int(round(t / DT))] - np.array(p)).max() for t, p in TURNING.items())
    print(f"the library's plotted turning points: P3 within {worst_turn:.1e} m")
    print()
    print("| rtol = atol | P3 error (m) | energy drift (J) | closure (m) | steps | CPU time (s) |")
    print("|---|---|---|---|---|---|")
    for tol in (1e-6, 1e-8, 1e-10, 1e-12):
        res = run(m, y0, tol, args.dt)
        every = int(round(args.dt / DT))
        error = np.abs(sp.bricard_p3(m, res.y) - p_ref[::every]).max()
        ke, pe = res.energy().T
        drift = np.abs(ke + pe - ke[0] - pe[0]).max()
        print(f"| {tol:.0e} | {error:.1e} | {drift:.1e} | {res.closure_error().max():.1e} | {res.steps} | "
              f"{cpu_time(m, y0, tol, args.rounds, args.dt):.4f} |")


if __name__ == "__main__":
    main()
