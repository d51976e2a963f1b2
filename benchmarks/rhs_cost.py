"""Cost of the simulator's hot path: a right-hand side, a DOP853 step, a 1 ms
co-simulation advance (the thesis four-bar, a six-bar, and the coupling rod, whose
redundant closure passes a change point every 0.4 s), a 10 s run of the thesis
four-bar, and a fresh process's first simulation.

    python benchmarks/rhs_cost.py [--repeat 5] [--cosim-steps 10000] [--parts ...] [--json out.json]

Every number is the median of --repeat runs in this one process (the machine is
shared and noisy: compare ratios measured in the same run).  It uses only the
public API (``forward_dynamics``, ``Simulator``, ``simulate``), so the same script
measures an older checkout of the package (put it first on PYTHONPATH).

Accuracy: the reference is this library at rtol = atol = 1e-13; the error is the
largest crank-angle (theta2) difference over the 10 s at the output grid.  The
sweep runs on the scene's 0.01 s grid and on a 0.1 s grid: DOP853 interpolates the
output times between its steps, so the two should take the same steps (an older
version ended a step at every output time, and the 0.01 s grid set its steps).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import grubler
from grubler.mechanism.assembly import assemble
from grubler.mechanism.dynamics import Inputs, forward_dynamics
from grubler.mechanism.simulate import Simulator

SCENE = "thesis-fourbar"
PARTS = ("first_call", "rhs", "cosim", "outputs", "accuracy")
TARGET_ERROR = 1e-8  # rad, max crank-angle error


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def rhs_call(repeat: int) -> float:
    """One public forward_dynamics call (Python in, dataclasses out), s."""
    m = grubler.load_scene(SCENE).mechanism
    z, zd = assemble(m, m.z_from_q(m.q_ref))
    zd = zd + 0.5
    n = 2000
    forward_dynamics(m, z, zd, Inputs(1.0))
    return median_time(lambda: [forward_dynamics(m, z, zd, Inputs(1.0)) for _ in range(n)], repeat) / n


def free_run(repeat: int) -> dict:
    """10 s in one advance_to: cost per step and per evaluation inside the integrator."""
    m = grubler.load_scene(SCENE).mechanism
    stats = {}

    def run():
        sim = Simulator(m)
        sim.advance_to(10.0)
        stats.update(sim.stats)

    Simulator(m).advance_to(0.01)  # warm
    wall = median_time(run, repeat)
    return {"wall": wall, "per_step": wall / stats["steps"], "per_eval": wall / stats["rhs_evals"], **stats}


def cosim(steps: int, repeat: int) -> dict:
    """advance_to(t + 1 ms) with the drive torque changed before every step."""
    m = grubler.load_scene(SCENE).mechanism
    torque = 3.0 * np.sin(np.arange(steps) * 1e-3 * 5.0)

    def run():
        sim = Simulator(m)
        for i in range(steps):
            sim.set_inputs(drive=float(torque[i]))
            sim.advance_to((i + 1) * 1e-3)

    run_short = Simulator(m)
    run_short.advance_to(1e-3)  # warm
    wall = median_time(run, repeat)
    return {"steps": steps, "wall": wall, "per_step": wall / steps}


CLOSURE_SCENES = ("thesis-fourbar", "stephenson-iii", "coupling-rod")


def cosim_closures(steps: int, repeat: int) -> dict:
    """advance_to(t + 1 ms) over ``steps`` steps of each of CLOSURE_SCENES, on the
    scene's own efforts (the coupling rod crosses its change points on them), s per step."""
    out = {}
    for name in CLOSURE_SCENES:
        m = grubler.load_scene(name).mechanism
        stats = {}

        def run():
            sim = Simulator(m)
            for i in range(steps):
                sim.advance_to((i + 1) * 1e-3)
            stats.update(sim.stats)

        Simulator(m).advance_to(1e-3)  # warm
        wall = median_time(run, repeat)
        out[name] = {"steps": steps, "wall": wall, "per_step": wall / steps,
                     "passages": stats["passage_count"], "charts": stats["charts"]}
    return out


def outputs_cost(repeat: int) -> dict:
    """Simulator.outputs for growing sets of output groups (what an FMU pays per read), s."""
    from grubler.mechanism.simulate import GROUPS

    sim = Simulator(grubler.load_scene(SCENE).mechanism)
    sim.advance_to(0.1)
    n = 2000
    out = {}
    for k in range(1, len(GROUPS) + 1):
        groups = list(GROUPS[:k])
        sim.outputs(groups)
        out["+".join(groups)] = median_time(lambda: [sim.outputs(groups) for _ in range(n)], repeat) / n
    return out


def crank_error(res, ref) -> float:
    return float(np.max(np.abs(res["theta2"] - ref["theta2"])))


def accuracy(repeat: int, dt_out: float) -> dict:
    scene = grubler.load_scene(SCENE)
    ref = grubler.simulate(scene, t_end=10.0, dt_out=dt_out, rtol=1e-13, atol=1e-13)
    out = {"dt_out": dt_out, "default": {}, "sweep": []}
    res = grubler.simulate(scene, t_end=10.0, dt_out=dt_out)
    out["default"] = {"wall": median_time(lambda: grubler.simulate(scene, t_end=10.0, dt_out=dt_out), repeat),
                      "error": crank_error(res, ref), **res.stats}
    for tol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        res = grubler.simulate(scene, t_end=10.0, dt_out=dt_out, rtol=tol, atol=tol)
        wall = median_time(lambda: grubler.simulate(scene, t_end=10.0, dt_out=dt_out, rtol=tol, atol=tol), repeat)
        out["sweep"].append({"tol": tol, "error": crank_error(res, ref), "wall": wall, **res.stats})
    ok = [r for r in out["sweep"] if r["error"] <= TARGET_ERROR]
    out["loosest_within_target"] = max(ok, key=lambda r: r["tol"]) if ok else None
    return out


FIRST_CALL = """
import time
t0 = time.perf_counter()
import grubler
t1 = time.perf_counter()
grubler.simulate("thesis-fourbar", t_end=0.01)
t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def first_call(repeat: int) -> dict:
    """A fresh interpreter: import, then a first (tiny) simulation; warm and cold disk cache."""
    def once(env):
        out = subprocess.run([sys.executable, "-c", FIRST_CALL], env=env, capture_output=True, text=True,
                             check=True).stdout.split()
        return float(out[0]), float(out[1])

    env = dict(os.environ)
    warm = [once(env) for _ in range(repeat)]
    result = {"warm_import": statistics.median(w[0] for w in warm),
              "warm_first": statistics.median(w[1] for w in warm)}
    import importlib.util

    if importlib.util.find_spec("grubler.jit") is None:  # the C kernel is compiled at install: no cache to miss
        return result
    with tempfile.TemporaryDirectory() as cache:
        cold = once({**env, "NUMBA_CACHE_DIR": cache})
    result["cold_import"], result["cold_first"] = cold
    return result


def machine() -> dict:
    info = {"python": platform.python_version(), "numpy": np.__version__, "cpus": os.cpu_count(),
            "processor": platform.processor() or platform.machine(), "load": os.getloadavg()[0]}
    try:
        import numba

        info["numba"] = numba.__version__
    except ImportError:
        pass
    return info


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cosim-steps", type=int, default=10000)
    ap.add_argument("--parts", nargs="+", default=list(PARTS), choices=PARTS)
    ap.add_argument("--json", default=None, help="also write the numbers here")
    args = ap.parse_args()
    r = {"package": grubler.__file__, "machine": machine()}
    parts = set(args.parts)
    us = 1e6
    print(f"package {r['package']}; {r['machine']}")
    if "first_call" in parts:
        r["first_call"] = fc = first_call(3)
        print(f"fresh process, warm cache: import {fc['warm_import']:.2f} s, first simulate {fc['warm_first']:.2f} s")
        if "cold_first" in fc:
            print(f"fresh process, cold cache: import {fc['cold_import']:.2f} s, "
                  f"first simulate {fc['cold_first']:.2f} s")
    if "rhs" in parts:
        r["rhs_call"] = rhs_call(args.repeat)
        r["free_run"] = fr = free_run(args.repeat)
        print(f"forward_dynamics call        {r['rhs_call'] * us:9.2f} us")
        print(f"RHS eval inside integrator   {fr['per_eval'] * us:9.2f} us  ({fr['rhs_evals']} evals, "
              "10 s in one advance)")
        print(f"DOP853 step                  {fr['per_step'] * us:9.2f} us  ({fr['steps']} steps, "
              f"{fr['rejected']} rejected)")
    if "cosim" in parts:
        r["cosim"] = cs = cosim(args.cosim_steps, args.repeat)
        print(f"advance_to(t + 1 ms)         {cs['per_step'] * us:9.2f} us  ({cs['steps']} steps: {cs['wall']:.3f} s)")
        r["cosim_closures"] = cc = cosim_closures(args.cosim_steps, args.repeat)
        for name, c in cc.items():
            print(f"  {name:26s} {c['per_step'] * us:9.2f} us per 1 ms step on its own efforts "
                  f"({c['wall']:.3f} s for {c['steps']} steps; {c['passages']} change points, {c['charts']} charts)")
    if "outputs" in parts:
        r["outputs"] = oc = outputs_cost(args.repeat)
        for groups, t in oc.items():
            print(f"outputs({groups}) {t * us:9.2f} us")
    if "accuracy" in parts:
        r["accuracy"] = acc = [accuracy(args.repeat, dt) for dt in (0.01, 0.1)]
        for a in acc:
            d = a["default"]
            print(f"simulate 10 s, dt_out {a['dt_out']:g} s, default tol: {d['wall']:.4f} s "
                  f"(max crank error {d['error']:.2e} rad, {d['steps']} steps)")
            for s in a["sweep"]:
                print(f"  rtol=atol={s['tol']:.0e}: error {s['error']:.2e} rad, {s['wall']:.4f} s, "
                      f"{s['steps']} steps")
            best = a["loosest_within_target"]
            if best:
                print(f"  loosest tolerance with error <= {TARGET_ERROR:g}: {best['tol']:.0e} "
                      f"({best['wall']:.4f} s)")
    r["machine"]["load_after"] = os.getloadavg()[0]
    print(f"load average before / after: {r['machine']['load']:.1f} / {r['machine']['load_after']:.1f}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(r, fh, indent=1)


if __name__ == "__main__":
    main()
