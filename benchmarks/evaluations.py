"""How many evaluations of the equations of motion each integrator family needs
for a given error, next to the thesis method's: the ceiling on "faster than the
thesis method at equal settings".

    python benchmarks/evaluations.py [--out docs/evaluations.md]

The thesis method (penalty closure, RK4 at 1 ms) makes 40 000 evaluations of a
cheap right-hand side over 10 s.  Any method on the exact closure makes fewer but
dearer ones; the wall-time ratio is at most the ratio of evaluation counts times
the ratio of their costs.  This counts evaluations, for the thesis four-bar
swinging freely and driven by 3 N m over 10 s on a 0.1 s grid, against the
independent reference of work_precision.py, for:

- grubler's DOP853 (the default integrator, projection after every step);
- scipy's DOP853, LSODA (Adams up to order 12, switching to BDF if stiff) and
  VODE's variable-order Adams, all on grubler's exact state equation without
  projection: a multistep method spends one or two evaluations per step, the
  usual answer to "fewer evaluations at tight tolerances";

and times one evaluation of each closure's right-hand side inside a compiled
loop, so the cost ratio is measured in the same run.  Counts do not depend on the
machine; the cost ratio is a median of repeats.
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import scipy
import scipy.integrate

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import grubler  # noqa: E402
from grubler.mechanism.dynamics import Inputs  # noqa: E402
from grubler.mechanism.integrators import StateEquation  # noqa: E402
from grubler.mechanism.simulate import DEFAULT_RTOL, Simulator  # noqa: E402
from work_precision import make_problem  # noqa: E402

TOLERANCES = [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]
THESIS_STEP = 1e-3


def counted(ode: StateEquation):
    calls = [0]

    def f(t, y):
        calls[0] += 1
        return ode(t, y)
    return f, calls


def scipy_run(prob, method: str, tol: float, z0, zd0) -> tuple[int, float]:
    ode = StateEquation(prob.scene.mechanism, drive=prob.torque)
    f, calls = counted(ode)
    y0 = np.concatenate([z0, zd0])
    if method == "vode-adams":
        solver = scipy.integrate.ode(f).set_integrator("vode", method="adams", order=12, rtol=tol, atol=tol,
                                                        nsteps=10**6)
        solver.set_initial_value(y0, 0.0)
        theta = [y0[0]] + [solver.integrate(t)[0] for t in prob.tg[1:]]
    else:
        res = scipy.integrate.solve_ivp(f, (0.0, prob.tg[-1]), y0, method=method, rtol=tol, atol=tol,
                                        t_eval=prob.tg)
        theta = res.y[0]
    return calls[0], float(np.max(np.abs(np.asarray(theta) - prob.ref_theta)))


def grubler_run(prob, method: str, integ: str, setting: float, z0, zd0) -> tuple[int, float]:
    kw = dict(step=setting) if integ == "rk4" else dict(rtol=setting, atol=setting)
    sim = Simulator(prob.scene.mechanism, method=method, integrator=integ, z0=z0, zd0=zd0,
                    inputs=Inputs(prob.torque), **kw)
    z, _ = sim.advance_through(prob.tg[1:])
    theta = np.concatenate([[z0[0]], z[:, 0]])
    return sim.stats["rhs_evals"], float(np.max(np.abs(theta - prob.ref_theta)))


def rhs_costs(mechanism, repeat: int = 15) -> dict[str, float]:
    """Seconds per right-hand side of each closure, in the compiled kernel.

    Each evaluation is one ctypes call of ``grb_rhs``; the binding's own cost per
    call is measured on an empty kernel call (``grb_work_size``) in the same
    alternation and taken off, so what remains is the kernel's."""
    from grubler import binding

    lib = binding.library()
    z0, zd0 = grubler.assemble(mechanism, mechanism.z_from_q(mechanism.q_ref), np.ones(mechanism.n_free))
    y = np.concatenate([z0, zd0])
    out, work = np.empty_like(y), binding.work(mechanism.n_links, len(mechanism.closures))
    args = (binding.address(y), 1.0, 0.0, binding.address(work), binding.address(out))
    c, rhs, floor = mechanism.arrays.c, lib.grb_rhs, lib.grb_work_size
    n = 100_000

    def run(code):
        for _ in range(n):
            rhs(c, code, *args)

    def empty(_):
        for _ in range(n):
            floor(3, 1)

    loops = {"exact": (run, 0), "penalty": (run, 1), "call": (empty, 0)}
    times: dict[str, list[float]] = {name: [] for name in loops}
    for _ in range(repeat):
        for name, (fn, code) in loops.items():
            t0 = time.perf_counter()
            fn(code)
            times[name].append((time.perf_counter() - t0) / n)
    call = statistics.median(times["call"])
    return {name: statistics.median(times[name]) - call for name in ("exact", "penalty")}


def loglog_at(points: list[tuple[int, float]], target: float) -> float | None:
    """Evaluations needed for ``target`` error, interpolated log-log between runs."""
    pts = sorted((e, n) for n, e in points if e > 0)
    for (e1, n1), (e2, n2) in zip(pts, pts[1:]):
        if e1 <= target <= e2:
            w = (math.log(target) - math.log(e1)) / (math.log(e2) - math.log(e1))
            return math.exp(math.log(n1) + w * (math.log(n2) - math.log(n1)))
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE.parent / "docs" / "evaluations.md"))
    args = ap.parse_args()
    labels = ["four-bar", "four-bar, 3 N m"]
    cost = rhs_costs(grubler.load_scene("thesis-fourbar").mechanism)
    lines = ["# Evaluations of the equations of motion against error", "",
             "Command: `python benchmarks/evaluations.py` "
             f"(Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}).", "",
             "The thesis method (penalty closure, RK4 at 1 ms) makes 40 000 evaluations of a cheap right-hand "
             "side over 10 s. A method on the exact closure makes fewer but dearer ones; counted in evaluations "
             "alone, its speed-up over the thesis method is (thesis evaluations x penalty cost) / (its evaluations "
             "x exact cost). Each integrator's own work per step moves the measured figure from that estimate (the "
             "thesis method's RK4 has 10 000 steps of it): docs/benchmarks.md measures the real ratio. Counted here for the thesis four-bar over 10 s on a 0.1 s grid, errors "
             "against work_precision.py's independent reference: grubler's DOP853 (projected after every step), "
             "and on grubler's exact state equation without projection scipy's DOP853, LSODA (Adams up to order "
             "12) and VODE's variable-order Adams: multistep methods spend one or two evaluations per step, the "
             "usual way to fewer evaluations at tight tolerances.", "",
             f"One right-hand side in a compiled loop: exact closure {cost['exact'] * 1e9:.0f} ns, penalty closure "
             f"{cost['penalty'] * 1e9:.0f} ns (ratio {cost['exact'] / cost['penalty']:.2f}, medians of 15, alternating).", ""]
    for label in labels:
        prob = make_problem(label, quick=False)
        m = prob.scene.mechanism
        z0, zd0 = grubler.assemble(m, m.z_from_q(m.q_ref), np.zeros(m.n_free))
        thesis_n, thesis_err = grubler_run(prob, "penalty", "rk4", THESIS_STEP, z0, zd0)
        curves = {"grubler DOP853 (projected)": [grubler_run(prob, "exact", "dop853", t, z0, zd0)
                                                 for t in TOLERANCES]}
        for name, method in (("scipy DOP853", "DOP853"), ("scipy LSODA", "LSODA"), ("VODE Adams", "vode-adams")):
            curves[name] = [scipy_run(prob, method, t, z0, zd0) for t in TOLERANCES]
        default_n, default_err = curves["grubler DOP853 (projected)"][TOLERANCES.index(DEFAULT_RTOL)]
        lines += [f"## {label}, 10 s", "",
                  f"Thesis method: {thesis_n} evaluations, crank-angle error {thesis_err:.2e} rad. "
                  f"grubler's default (DOP853, rtol = {DEFAULT_RTOL:g}): {default_n} evaluations, "
                  f"{default_err:.1e} rad: counted in evaluations, "
                  f"{thesis_n * cost['penalty'] / (default_n * cost['exact']):.1f}x faster than the thesis method.", "",
                  "| integrator | " + " | ".join(f"tol {t:g}" for t in TOLERANCES) + " |",
                  "|---|" + "---|" * len(TOLERANCES)]
        for name, pts in curves.items():
            lines.append(f"| {name} | " + " | ".join(f"{n} / {e:.1e}" for n, e in pts) + " |")
        lines += ["", "(evaluations / max crank-angle error in rad)", "",
                  "Evaluations needed for a given error (log-log interpolation), and the speed-up over the thesis "
                  "method that count gives at the measured cost per evaluation "
                  "(thesis evaluations x penalty cost / (evaluations x exact cost)):", "",
                  "| error (rad) | " + " | ".join(curves) + " |", "|---|" + "---|" * len(curves)]
        for target in (1e-6, 1e-7, 1e-8, 1e-9):
            cells = []
            for pts in curves.values():
                n = loglog_at(pts, target)
                cells.append("—" if n is None else
                             f"{n:.0f} ({thesis_n * cost['penalty'] / (n * cost['exact']):.1f}x)")
            lines.append(f"| {target:g} | " + " | ".join(cells) + " |")
        lines.append("")
        print("\n".join(lines[-12:]), flush=True)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
