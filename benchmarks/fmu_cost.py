"""Cost of the mechanism FMU per communication step, next to the library and a
do-nothing FMU (the floor that pythonfmu and fmpy set).

    python benchmarks/fmu_cost.py [--t-end 10] [--repeat 5] [--block 100] [--out docs/fmu-benchmark.md]

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
from pythonfmu.builder import FmuBuilder  # noqa: E402

import grubler  # noqa: E402
from grubler.simulate import Simulator  # noqa: E402

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
    the status checked, as grubler's own master (grubler.cosim) calls them."""

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
    null = Path(FmuBuilder.build_FMU(HERE / "grubler_null.py", dest=tmp / "NullSlave.fmu"))
    wrapper = Path(FmuBuilder.build_FMU(HERE / "grubler_wrapper.py", dest=tmp / "WrapperSlave.fmu",
                                        project_files=[HERE / "grubler_null.py"]))
    unzipped = {p: extract(str(p)) for p in (mech, null, wrapper)}
    rows = []
    for h in (1e-3, 1e-2):
        n = int(round(args.t_end / h))
        block = min(args.block, n // 10)
        makers = {"library": lambda: LibraryRun(h),
                  "fmu": lambda: FmuRun(mech, unzipped[mech], h),
                  "fmu_raw": lambda: FmuRawRun(mech, unzipped[mech], h),
                  "null": lambda: FmuRun(null, unzipped[null], h),
                  "wrapper": lambda: FmuRun(wrapper, unzipped[wrapper], h)}
        lockstep(makers, 10 * block, block)  # warm: caches, first compiled calls
        blocks = {label: [] for label in makers}
        totals = {label: [] for label in makers}
        for _ in range(args.repeat):
            run = lockstep(makers, n, block)
            for label, v in run.items():
                blocks[label].append(v)
                totals[label].append(v.sum())
        b = {label: np.concatenate(v) for label, v in blocks.items()}
        per_step = {label: float(np.median(v)) / block * 1e6 for label, v in b.items()}
        over = float(np.median(b["fmu"] - b["library"])) / block * 1e6
        over_raw = float(np.median(b["fmu_raw"] - b["library"])) / block * 1e6
        floor = float(np.median(b["wrapper"] - b["library"])) / block * 1e6
        slave = float(np.median(b["fmu"] - b["wrapper"])) / block * 1e6
        sim_fmu = statistics.median(time_simulate_fmu(mech, args.t_end, h) for _ in range(max(1, args.repeat // 2)))
        rows.append(dict(h=h, n=n, block=block, blocks=len(b["fmu"]), per_step=per_step, over=over, over_raw=over_raw, floor=floor, slave=slave,
                         total={k: statistics.median(v) for k, v in totals.items()}, simulate_fmu=sim_fmu))
        print(rows[-1], flush=True)
    lines = [
        "# Cost of the mechanism FMU",
        "",
        f"Command: `python benchmarks/fmu_cost.py --t-end {args.t_end:g} --repeat {args.repeat} --block {args.block}`",
        f"(machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"fmpy {fmpy.__version__}, pythonfmu {_version('pythonfmu')}).",
        "",
        f"Scene: thesis-fourbar driven by {TORQUE:g} N m for {args.t_end:g} s. Every variant sets the torque and",
        "reads theta2, theta2_d, Fx, Fy at each communication step:",
        "",
        "- `library`: grubler.Simulator: set_inputs, advance_to, outputs(state, dynamics);",
        "- `FMU`: Mechanism.fmu through fmpy's FMU2Slave: setReal, doStep, getReal;",
        "- `FMU, raw`: the same FMU through the C functions fmpy loaded (`FMU2Slave._functions`), with",
        "  buffers made once and every status checked, as grubler's own master calls them: FMU2Slave's",
        "  methods build ctypes arrays and lists at every call;",
        "- `null`: an FMU with the same variables whose doStep does nothing and whose setReal/getReal",
        "  are the leanest a pythonfmu slave can have (benchmarks/grubler_null.py): what pythonfmu's",
        "  C++ layer and fmpy cost for these three calls when nothing else runs;",
        "- `wrapper`: the leanest FMU around the library (benchmarks/grubler_wrapper.py): each step",
        "  exactly the library run's calls, with no checks and no lazy outputs. `wrapper - library`",
        "  is the floor for an FMU that does this work. The same C++ layer and fmpy calls cost more",
        "  here than around the do-nothing slave, most likely because the library's work between",
        "  them pushes their code and data out of the processor's caches.",
        "",
        "The five run in lockstep, in blocks of communication steps timed in turn, and",
        "differences are medians of paired blocks (see the script), so the machine's drift",
        "cancels. `FMU - library` is what a user pays for the FMU; `FMU - wrapper` is the part",
        "of it the slave's own Python adds (input checks, lazy output groups, rollback records).",
        "",
        "| step (s) | steps | blocks | library (us/step) | FMU (us/step) | null (us/step) "
        "| FMU - library (us/step) | FMU, raw - library (us/step) | wrapper - library: floor (us/step) "
        "| FMU - wrapper (us/step) | library, 10 s (s) | FMU, 10 s (s) | fmpy.simulate_fmu, 10 s (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        p, t = r["per_step"], r["total"]
        lines.append(f"| {r['h']:g} | {r['n']} | {r['blocks']} x {r['block']} | {p['library']:.1f} | {p['fmu']:.1f} | "
                     f"{p['null']:.1f} | {r['over']:.1f} | {r['over_raw']:.1f} | {r['floor']:.1f} | {r['slave']:.1f} | "
                     f"{t['library']:.3f} | {t['fmu']:.3f} | "
                     f"{r['simulate_fmu']:.3f} |")
    first = rows[0]
    lines += ["", f"Target: at a {first['h']:g} s step the FMU costs at most the library's run plus 10 us per step.",
              f"Through FMU2Slave's methods: {first['over']:.1f} us/step, "
              + ("met" if first["over"] <= 10 else "not met") + f"; through fmpy's C functions as grubler's "
              f"master calls them: {first['over_raw']:.1f} us/step, " + ("met." if first["over_raw"] <= 10 else
                                                                         "not met.")
              + f" The leanest FMU around the library already costs {first['floor']:.1f} us/step through "
              f"FMU2Slave; the slave's own checks and lazy outputs add {first['slave']:.1f}.",
              "", "`fmpy.simulate_fmu` records every output (so every output group is computed each step) and",
              "interpolates the input signal: it is the convenient path, not the fast one."]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    sys.stdout.flush()
    os._exit(0)  # pythonfmu's exit-time heap corruption (upstream issue 228) must not mask the output


def _version(dist: str) -> str:
    from importlib.metadata import version

    return version(dist)


if __name__ == "__main__":
    main()
