"""Cost of the native mechanism FMU per communication step through fmpy, next to
the kernel's own stepping and the library's Python Simulator.

    python benchmarks/fmu_cost.py [--t-end 10] [--repeat 5] [--block 100] [--out docs/fmu-benchmark.md]

(The FMU in a C host, with no Python at all: benchmarks/native_fmu_cost.py.)

Every variant runs the thesis four-bar driven by 3 N m for t_end seconds, sets the
torque input and reads theta2, theta2_d, Fx, Fy at every communication step.

The machine is shared and its speed drifts by tens of percent within a minute, so
the variants run in lockstep: each run of t_end seconds is cut into blocks of
--block communication steps, and every block is timed for each variant in turn
(the order rotating from block to block).  A difference between two variants is
the median over blocks of their paired block times: drift slower than a block
cancels.  --repeat runs of t_end seconds, fresh instances each.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import build_fmu  # noqa: E402
import fmpy  # noqa: E402
import numpy as np  # noqa: E402
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
import grubler  # noqa: E402
from grubler import binding  # noqa: E402
from grubler.mechanism.simulate import Simulator  # noqa: E402

READ = ["theta2", "theta2_d", "Fx", "Fy"]
TORQUE = 3.0


class LibraryRun:
    """The library doing what the FMU does each step: set the torque, advance, read."""

    def __init__(self, h: float):
        self.sim = Simulator(grubler.load_scene("thesis-fourbar").mechanism)
        self.h, self.i = h, 0

    def steps(self, k: int) -> None:
        sim, h, i = self.sim, self.h, self.i
        for j in range(i, i + k):
            sim.set_inputs(TORQUE)
            sim.advance_to((j + 1) * h)
            out = sim.outputs(["state", "dynamics"])
            [out[name] for name in READ]
        self.i = i + k

    def close(self) -> None:
        pass


class FmuRun:
    """An FMU driven through fmpy's FMU2Slave, as a user's own master loop would."""

    def __init__(self, path: Path, unzipped: str, h: float):
        md = read_model_description(str(path))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        self.s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                           instanceName="bench")
        self.s.instantiate()
        self.s.setupExperiment(startTime=0.0)
        self.s.enterInitializationMode()
        self.s.exitInitializationMode()
        self.read = [vr[n] for n in READ]
        self.u = [vr["motor_torque"]]
        self.h, self.i = h, 0

    def steps(self, k: int) -> None:
        s, u, read, h, i = self.s, self.u, self.read, self.h, self.i
        for j in range(i, i + k):
            s.setReal(u, [TORQUE])
            s.doStep(j * h, h)
            s.getReal(read)
        self.i = i + k

    def close(self) -> None:
        self.s.terminate()
        self.s.freeInstance()


class FmuRawRun(FmuRun):
    """The same FMU through the C functions fmpy loaded, with buffers made once and
    the status checked, as grubler's own master (grubler.system.cosim) calls them."""

    def __init__(self, path: Path, unzipped: str, h: float):
        super().__init__(path, unzipped, h)
        f = self.s._functions
        self.c = self.s.component
        self.set_real, self.do_step, self.get_real = f["fmi2SetReal"], f["fmi2DoStep"], f["fmi2GetReal"]
        self.u_vr = (ctypes.c_uint * 1)(*self.u)
        self.u_buf = (ctypes.c_double * 1)(TORQUE)
        self.read_vr = (ctypes.c_uint * len(self.read))(*self.read)
        self.read_buf = (ctypes.c_double * len(self.read))()

    def steps(self, k: int) -> None:
        c, h, i, n = self.c, self.h, self.i, len(self.read)
        set_real, do_step, get_real = self.set_real, self.do_step, self.get_real
        u_vr, u_buf, read_vr, read_buf = self.u_vr, self.u_buf, self.read_vr, self.read_buf
        for j in range(i, i + k):
            u_buf[0] = TORQUE
            if set_real(c, u_vr, 1, u_buf) > 1 or do_step(c, j * h, h, 1) > 1 or get_real(c, read_vr, n, read_buf) > 1:
                raise RuntimeError(f"FMI call failed at step {j}")
            [read_buf[m] for m in range(n)]
        self.i = i + k


class KernelRun:
    """The kernel stepping itself, called straight through ctypes with everything
    prepared once: per step, the torque set (the held derivative dropped, as a
    changed input makes the FMU do), one grb_advance to the next communication
    point and one grb_observe for the outputs.  Two foreign calls a step: the
    reference the FMU's three (setReal, doStep, getReal) are measured against."""

    def __init__(self, h: float):
        sim = Simulator(grubler.load_scene("thesis-fourbar").mechanism)
        integ = sim._integ
        self.keep = (sim, integ)
        self.st, self.clock = integ._settings, integ._clock
        self.clock.t, self.clock.h, self.clock.have_f = 0.0, 0.0, 0
        self.st.max_steps = 10_000_000
        n = integ.y.size
        self.y, self.f = integ.y.copy(), np.zeros(n)
        self.t1, self.out1, self.obs = np.zeros(1), np.zeros((1, n)), np.zeros(9 * (n // 2) + 11)
        lib = binding.library()
        self.advance, self.observe = lib.grb_advance, lib.grb_observe
        self.model = sim.model.arrays.c
        self.args = tuple(binding.address(a) for a in (self.y, self.f, self.t1, self.out1, integ.ode.work,
                                                       integ._stepper, self.obs))
        self.why = binding.Failure()
        self.h, self.i = h, 0

    def steps(self, k: int) -> None:
        st, clock, h, i, t1, obs = self.st, self.clock, self.h, self.i, self.t1, self.obs
        a_y, a_f, a_t1, a_out1, a_work, a_stepper, a_obs = self.args
        advance, observe, model, why = self.advance, self.observe, self.model, self.why
        for j in range(i, i + k):
            st.tau_drive = TORQUE
            clock.have_f = 0
            t1[0] = (j + 1) * h
            if advance(model, st, clock, a_y, a_f, a_t1, 1, a_out1, a_work, a_stepper, why) != 0 or \
                    observe(model, 0, a_y, TORQUE, 0.0, 0, a_work, a_obs) != 0:
                raise RuntimeError(f"kernel failed at step {j}")
            [obs[m] for m in (1, 7, 21, 22)]  # theta2, theta2_d, Fx, Fy of three links
        self.i = i + k

    def close(self) -> None:
        pass


def lockstep(makers: dict, n_steps: int, block: int) -> dict[str, np.ndarray]:
    """Per-block wall times of each variant over one run of ``n_steps`` steps."""
    runs = {label: make() for label, make in makers.items()}
    labels = list(runs)
    times = {label: [] for label in labels}
    for b in range(n_steps // block):
        order = labels[b % len(labels):] + labels[:b % len(labels)]
        for label in order:
            t0 = time.perf_counter()
            runs[label].steps(block)
            times[label].append(time.perf_counter() - t0)
    for r in runs.values():
        r.close()
    return {label: np.array(v) for label, v in times.items()}


def time_simulate_fmu(path: Path, t_end: float, h: float) -> float:
    sig = np.array([(0.0, TORQUE), (t_end, TORQUE)], dtype=[("time", float), ("motor_torque", float)])
    t0 = time.perf_counter()
    fmpy.simulate_fmu(str(path), stop_time=t_end, step_size=h, output_interval=h, input=sig)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-end", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--block", type=int, default=100, help="communication steps per timed block")
    ap.add_argument("--out", default=str(HERE.parent / "docs" / "fmu-benchmark.md"))
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="fmu_bench_"))
    (mech,) = build_fmu.build(tmp, ["Mechanism"])
    unzipped = extract(str(mech))
    rows = []
    for h in (1e-3, 1e-2):
        n = int(round(args.t_end / h))
        block = min(args.block, n // 10)
        makers = {"kernel": lambda: KernelRun(h),
                  "fmu_raw": lambda: FmuRawRun(mech, unzipped, h),
                  "fmu": lambda: FmuRun(mech, unzipped, h),
                  "library": lambda: LibraryRun(h)}
        lockstep(makers, 10 * block, block)  # warm: caches, first calls
        blocks = {label: [] for label in makers}
        totals = {label: [] for label in makers}
        for _ in range(args.repeat):
            run = lockstep(makers, n, block)
            for label, v in run.items():
                blocks[label].append(v)
                totals[label].append(v.sum())
        b = {label: np.concatenate(v) for label, v in blocks.items()}
        per_step = {label: float(np.median(v)) / block * 1e6 for label, v in b.items()}

        def over(a, ref):
            return float(np.median(b[a] - b[ref])) / block * 1e6

        sim_fmu = statistics.median(time_simulate_fmu(mech, args.t_end, h) for _ in range(max(1, args.repeat // 2)))
        rows.append(dict(h=h, n=n, block=block, blocks=len(b["fmu"]), per_step=per_step,
                         raw_over_kernel=over("fmu_raw", "kernel"), fmu_over_kernel=over("fmu", "kernel"),
                         library_over_kernel=over("library", "kernel"),
                         total={k: statistics.median(v) for k, v in totals.items()}, simulate_fmu=sim_fmu))
        print(rows[-1], flush=True)
    lines = [
        "# Cost of the mechanism FMU",
        "",
        f"Command: `python benchmarks/fmu_cost.py --t-end {args.t_end:g} --repeat {args.repeat} --block {args.block}`",
        f"(machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"fmpy {fmpy.__version__}).",
        "",
        "Mechanism.fmu is native (the C kernel behind a C FMI wrapper). In a C host, with no",
        "Python in the process, it costs what the kernel's own stepping costs to within a",
        "fraction of a microsecond: `python benchmarks/native_fmu_cost.py` (table below).",
        "This page is the same FMU driven from Python, as grubler's co-simulation master drives it.",
        "",
        f"Scene: thesis-fourbar driven by {TORQUE:g} N m for {args.t_end:g} s. Every variant sets the torque and",
        "reads theta2, theta2_d, Fx, Fy at each communication step:",
        "",
        "- `kernel`: the kernel's own stepping through ctypes (grb_advance + grb_observe, everything",
        "  prepared once): two foreign calls a step, the reference;",
        "- `FMU, raw`: Mechanism.fmu through the C functions fmpy loaded (`FMU2Slave._functions`), buffers",
        "  made once and every status checked, as grubler's master (`grubler.system.cosim`) calls them: three",
        "  foreign calls a step (setReal, doStep, getReal);",
        "- `FMU`: the same FMU through fmpy's FMU2Slave methods, which build ctypes arrays at every call;",
        "- `library`: grubler.Simulator in Python: set_inputs, advance_to, outputs(state, dynamics).",
        "",
        "The four run in lockstep, in blocks of communication steps timed in turn, and",
        "differences are medians of paired blocks (see the script), so the machine's drift cancels.",
        "",
        "| step (s) | steps | blocks | kernel (us/step) | FMU, raw (us/step) | FMU (us/step) | library (us/step) "
        "| FMU, raw - kernel (us/step) | FMU - kernel (us/step) | library - kernel (us/step) "
        "| FMU, raw, 10 s (s) | fmpy.simulate_fmu, 10 s (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        p, t = r["per_step"], r["total"]
        lines.append(f"| {r['h']:g} | {r['n']} | {r['blocks']} x {r['block']} | {p['kernel']:.1f} | "
                     f"{p['fmu_raw']:.1f} | {p['fmu']:.1f} | {p['library']:.1f} | {r['raw_over_kernel']:.1f} | "
                     f"{r['fmu_over_kernel']:.1f} | {r['library_over_kernel']:.1f} | {t['fmu_raw']:.3f} | "
                     f"{r['simulate_fmu']:.3f} |")
    first = rows[0]
    lines += ["", f"Target: through grubler's fmpy-based master at most 3 us per {first['h']:g} s step over the "
              f"kernel's own stepping: {first['raw_over_kernel']:.1f} us, "
              + ("met" if first["raw_over_kernel"] <= 3 else "not met")
              + " (one foreign call more than the reference, and the wrapper's checks).",
              "", "`fmpy.simulate_fmu` records every output (so every output group is computed each step) and",
              "interpolates the input signal: it is the convenient path, not the fast one."]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    sys.stdout.flush()


def _version(dist: str) -> str:
    from importlib.metadata import version

    return version(dist)


if __name__ == "__main__":
    main()
