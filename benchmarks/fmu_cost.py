"""Cost of the mechanism FMU per communication step, next to the library and a
do-nothing FMU (the floor that pythonfmu and fmpy set).

    python benchmarks/fmu_cost.py [--t-end 10] [--repeat 5] [--out docs/fmu-benchmark.md]

Every variant runs the thesis four-bar driven by 3 N m for t_end seconds, sets
the torque input and reads theta2, theta2_d, Fx, Fy at every communication step.
Times are medians over --repeat runs, all measured in this one process.
"""

from __future__ import annotations

import argparse
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
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
from pythonfmu.builder import FmuBuilder  # noqa: E402

import grubler  # noqa: E402
from grubler.simulate import Simulator  # noqa: E402

READ = ["theta2", "theta2_d", "Fx", "Fy"]


def time_fmu(path: Path, t_end: float, h: float, read: list[str]) -> float:
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    d = extract(str(path))
    s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="b")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    refs = [vr[n] for n in read]
    u = [vr["motor_torque"]]
    n = int(round(t_end / h))
    t0 = time.perf_counter()
    for i in range(n):
        s.setReal(u, [3.0])
        s.doStep(i * h, h)
        s.getReal(refs)
    wall = time.perf_counter() - t0
    s.terminate()
    s.freeInstance()
    return wall


def time_library(t_end: float, h: float) -> float:
    sim = Simulator(grubler.load_scene("thesis-fourbar").mechanism)
    n = int(round(t_end / h))
    t0 = time.perf_counter()
    for i in range(n):
        sim.set_inputs(3.0)
        sim.advance_to((i + 1) * h)
        sim.outputs(["state", "dynamics"])
    return time.perf_counter() - t0


def time_slave_bookkeeping(t_end: float, h: float, read: list[str], null: bool = False) -> float:
    """The slave's own Python work per step, with the physics stubbed out.

    The end-to-end difference FMU - library is a small number between two large,
    noisy ones; this isolates what the slave adds around the library calls.  With
    ``null`` it times the do-nothing slave the same way, whose Python calls the
    null FMU's floor already contains.
    """
    sys.path.insert(0, str(HERE.parent / "fmu_src" / "slaves"))
    sys.path.insert(0, str(HERE))
    if null:
        from grubler_null import NullSlave

        slave = NullSlave(instance_name="bookkeeping")
        read = ["theta2"]
    else:
        from grubler_mechanism import Mechanism

        slave = Mechanism(instance_name="bookkeeping")
        slave.exit_initialization_mode()
        sim = slave._sim
        canned = sim.outputs(["state", "dynamics"])
        sim.advance_to = lambda t: setattr(sim._integ, "t", t)
        sim.outputs = lambda groups: canned
    vr = {v.name: v.value_reference for v in slave.vars.values()}
    refs = [vr[name] for name in read]
    n = int(round(t_end / h))
    t0 = time.perf_counter()
    for i in range(n):
        slave.set_real([vr["motor_torque"]], [3.0])
        slave.do_step(i * h, h)
        slave.get_real(refs)
    return time.perf_counter() - t0


def time_simulate_fmu(path: Path, t_end: float, h: float) -> float:
    import numpy as np

    sig = np.array([(0.0, 3.0), (t_end, 3.0)], dtype=[("time", float), ("motor_torque", float)])
    t0 = time.perf_counter()
    fmpy.simulate_fmu(str(path), stop_time=t_end, step_size=h, output_interval=h, input=sig)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-end", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default=str(HERE.parent / "docs" / "fmu-benchmark.md"))
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="fmu_bench_"))
    (mech,) = build_fmu.build(tmp, ["Mechanism"])
    null = Path(FmuBuilder.build_FMU(HERE / "grubler_null.py", dest=tmp / "NullSlave.fmu"))
    rows = []
    for h in (1e-3, 1e-2):
        n = int(round(args.t_end / h))
        variants = (("library", lambda: time_library(args.t_end, h)),
                    ("fmu", lambda: time_fmu(mech, args.t_end, h, READ)),
                    ("null", lambda: time_fmu(null, args.t_end, h, ["theta2"])),
                    ("bookkeeping", lambda: time_slave_bookkeeping(args.t_end, h, READ)),
                    ("null_bookkeeping", lambda: time_slave_bookkeeping(args.t_end, h, READ, null=True)))
        # interleaved, so that a machine that speeds up or slows down during the
        # run moves every variant alike and their differences stay fair
        runs: dict[str, list[float]] = {label: [] for label, _ in variants}
        for _ in range(args.repeat):
            for label, fn in variants:
                runs[label].append(fn())
        med = {label: statistics.median(r) for label, r in runs.items()}
        med["simulate_fmu"] = statistics.median(time_simulate_fmu(mech, args.t_end, h)
                                                for _ in range(max(1, args.repeat // 2)))
        overhead = (med["fmu"] - med["library"]) / n * 1e6
        rows.append((h, n, med, overhead))
        print(h, n, {k: round(v, 4) for k, v in med.items()}, f"overhead {overhead:.1f} us/step", flush=True)
    lines = [
        "# Cost of the mechanism FMU",
        "",
        f"Command: `python benchmarks/fmu_cost.py --t-end {args.t_end:g} --repeat {args.repeat}`",
        f"(machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"fmpy {fmpy.__version__}; medians of {args.repeat} runs in one process).",
        "",
        f"Scene: thesis-fourbar driven by 3 N m for {args.t_end:g} s. `library`: grubler.Simulator stepped to each",
        "communication point, reading state and dynamics outputs. `fmu`: Mechanism.fmu through fmpy's",
        "FMU2Slave, setting motor_torque and reading theta2, theta2_d, Fx, Fy each step. `null`: an FMU whose",
        "doStep does nothing (the pythonfmu + fmpy floor). `simulate_fmu`: fmpy.simulate_fmu recording every",
        "output (all output groups computed each step). `slave` is what the slave's own Python adds per",
        "step over the do-nothing slave (its setReal/doStep/getReal path timed in-process with the library",
        "calls stubbed out, minus the same for the null slave), so the FMU's cost over the library is",
        "null + slave per step. The end-to-end difference FMU - library is shown too, but it is a small",
        "number between two large ones and moves with the machine's noise (several percent).",
        "",
        "| step (s) | steps | library (s) | FMU (s) | simulate_fmu (s) | FMU - library (us/step) "
        "| null FMU (us/step) | slave (us/step) | null + slave (us/step) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for h, n, med, overhead in rows:
        null_us = med["null"] / n * 1e6
        slave_us = (med["bookkeeping"] - med["null_bookkeeping"]) / n * 1e6
        lines.append(f"| {h:g} | {n} | {med['library']:.3f} | {med['fmu']:.3f} | {med['simulate_fmu']:.3f} | "
                     f"{overhead:.1f} | {null_us:.1f} | {slave_us:.1f} | {null_us + slave_us:.1f} |")
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    sys.stdout.flush()
    os._exit(0)


if __name__ == "__main__":
    main()
