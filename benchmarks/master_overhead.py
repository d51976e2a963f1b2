"""Master overhead per FMU per step: grubler's master beside fmpy's loops, fmpy's container FMU and libcosim.

    python benchmarks/master_overhead.py [--fmus 4] [--rounds 7] [--steps 4000]

The system is a chain of native DC-motor FMUs (each motor's terminal voltage
drives the next one's voltage input), chosen because one motor step costs a
fraction of a microsecond in C: what a master adds shows.  Each master runs
it with a 1 ms step; its cost per step is the difference of a long and a short
run over the difference of their steps (set-up, extraction and
instantiation cancel).  The floor is what the FMUs' own calls cost with no
master at all: the C host (tests/fmi_host.c) calling setReal, doStep and
getReal on one motor in a loop.  Overhead per FMU per step is then
``(cost per step - FMUs x floor) / FMUs``.

The machine is shared and noisy, so the masters run one after another in
rounds (each round in a rotated order), and each master's cost per FMU and
step is divided by that of grubler's Gauss-Seidel master of the same round:
the table gives medians.

Masters:

- grubler, Gauss-Seidel and Jacobi (``grubler.cosim.run``, recording each motor's current);
- ``fmpy.simulate_fmu`` on one motor alone (it runs one FMU; it records its current);
- ``fmpy.ssp.simulate_ssp`` on the .ssp archive (recording every connector);
- fmpy's container FMU (``grubler export``): through ``fmpy.simulate_fmu``
  (recording each current), and in the C host (``bench``: set one input, step,
  read each current, no Python in the process);
- libcosim (``libcosimpy``, from the .ssd alone, no observer: nothing recorded), when installed.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE), str(HERE.parent / "tests")]

import build_fmu  # noqa: E402

from grubler import cosim, ssp  # noqa: E402
from c_host import compile_host  # noqa: E402
from grubler.system.container import export_system  # noqa: E402

STEP = 1e-3


def chain(motor: Path, n: int, folder: Path) -> ssp.System:
    s = ssp.System("motor_chain", stop_time=1.0, step=STEP)
    for k in range(n):
        s.add(f"m{k}", motor, gear_ratio=50.0, **({"voltage": 12.0} if k == 0 else {}))
        if k:
            s.connect(f"m{k - 1}.terminal_voltage", f"m{k}.voltage")
    s.write(folder / "motor_chain.ssd")
    return s


def bench(host: Path, fmu: Path, folder: Path, start: list[str], vr_in: int, vr_out: list[int], steps: int,
          resources: bool = False) -> float:
    """Seconds per step of the C host's loop (setReal, doStep, getReal) on one FMU binary."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    zipfile.ZipFile(fmu).extractall(folder)
    lib = folder / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    cmd = [str(host), str(lib), md.guid] + ([(folder / "resources").as_uri()] if resources else [])
    script = ["new 0 b", "setup 0.0", "enter", *start, "exit",
              f"bench {steps} 0.0 {STEP!r} {vr_in} " + " ".join(map(str, vr_out))]
    out = subprocess.run(cmd, input="\n".join(script) + "\n", capture_output=True, text=True, env={}, check=True)
    return float(out.stdout.split()[-1]) * 1e-9


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmus", type=int, default=4)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--steps", type=int, default=40000, help="steps of the long run (the short one: a tenth)")
    args = ap.parse_args()
    n_long, n_short = args.steps, args.steps // 10
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (motor,) = build_fmu.build(tmp / "dist", ["DCMotor"])
        system = chain(motor, args.fmus, tmp)
        archive = system.write(tmp / "motor_chain.ssp")
        container = export_system(system, tmp / "MotorChain.fmu")
        record = [f"m{k}.current" for k in range(args.fmus)]
        host = compile_host(tmp / "fmi_host")
        from fmpy import read_model_description, simulate_fmu
        from fmpy.ssp.simulation import simulate_ssp
        from fmpy.ssp.ssd import Parameter, ParameterSet

        mvr = {v.name: v.valueReference for v in read_model_description(str(motor)).modelVariables}
        cvr = {v.name: v.valueReference for v in read_model_description(str(container)).modelVariables}
        pset = ParameterSet()
        pset.parameters = [Parameter(name=f"{c.name}.{p}", type="Real", value=v)
                           for c in system.components.values() for p, v in c.parameters.items()]
        unpacked = cosim.UnpackedFMUs()

        def ours(master):
            return lambda n: cosim.run(system, t_end=n * STEP, step=STEP, master=master, record=record,
                                       unpacked=unpacked).wall_time

        def timed(fn):
            def run(n):
                t0 = time.perf_counter()
                fn(n)
                return time.perf_counter() - t0
            return run

        masters = {  # name -> (FMUs it steps, seconds for n steps incl. set-up)
            "grubler, Gauss-Seidel": (args.fmus, ours(cosim.GAUSS_SEIDEL)),
            "grubler, Jacobi": (args.fmus, ours(cosim.JACOBI)),
            "fmpy.simulate_fmu (one motor)": (1, timed(lambda n: simulate_fmu(
                str(motor), stop_time=n * STEP, step_size=STEP, output_interval=STEP, output=["current"],
                start_values={"voltage": 12.0, "gear_ratio": 50.0}))),
            "fmpy.ssp.simulate_ssp": (args.fmus, timed(lambda n: simulate_ssp(
                str(archive), stop_time=n * STEP, step_size=STEP, parameter_set=pset))),
            "container FMU in fmpy.simulate_fmu": (args.fmus, timed(lambda n: simulate_fmu(
                str(container), stop_time=n * STEP, step_size=STEP, output_interval=STEP, output=record))),
        }
        try:
            from libcosimpy.CosimExecution import CosimExecution
            from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

            log_output_level(CosimLogLevel.ERROR)

            def libcosim(n):
                ex = CosimExecution.from_ssp_file(ssp_path=str(tmp / "motor_chain.ssd"))
                ex.step(step_count=1)  # initialisation happens on the first step
                t0 = time.perf_counter()
                ex.step(step_count=n)
                return time.perf_counter() - t0
            masters["libcosim (libcosimpy)"] = (args.fmus, libcosim)
        except ImportError:
            print("libcosimpy is not installed: no libcosim row", file=sys.stderr)
        floor_dir, cont_dir = tmp / "floor", tmp / "container"
        per_step = {name: [] for name in [*masters, "container FMU in the C host"]}
        floors = []
        for r in range(args.rounds):
            names = list(masters)
            names = names[r % len(names):] + names[:r % len(names)]
            for name in names:
                _, run = masters[name]
                per_step[name].append((run(n_long) - run(n_short)) / (n_long - n_short))
            floors.append(bench(host, motor, floor_dir, [f"setr {mvr['voltage']} 12.0", f"setr {mvr['gear_ratio']} 50.0"],
                                mvr["shaft_speed"], [mvr["current"], mvr["terminal_voltage"]], 100 * n_long))
            per_step["container FMU in the C host"].append(bench(
                host, container, cont_dir, [], cvr["m0.shaft_speed"], [cvr[r] for r in record], n_long,
                resources=True))
            print(f"round {r + 1}: " + ", ".join(f"{k}: {v[-1] * 1e6:.2f} us" for k, v in per_step.items())
                  + f", floor {floors[-1] * 1e6:.3f} us", flush=True)
        unpacked.close()
    fmus = {**{k: v[0] for k, v in masters.items()}, "container FMU in the C host": args.fmus}
    overhead = {k: [(s - fmus[k] * f) / fmus[k] for s, f in zip(v, floors)] for k, v in per_step.items()}
    ref = "grubler, Gauss-Seidel"
    lines = ["| master | FMUs | cost per step (us) | overhead per FMU per step (us) | cost per FMU, to grubler's |",
             "|---|---|---|---|---|"]
    for k in per_step:
        ratio = statistics.median(c / fmus[k] / (g / fmus[ref]) for c, g in zip(per_step[k], per_step[ref]))
        lines.append(f"| {k} | {fmus[k]} | {statistics.median(per_step[k]) * 1e6:.2f} | "
                     f"{statistics.median(overhead[k]) * 1e6:.2f} | {ratio:.2f} |")
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")), "?")
    print(f"\nA chain of {args.fmus} DC-motor FMUs at 1 ms; medians of {args.rounds} rounds; floor (the C host's "
          f"setReal + doStep + getReal on one motor): {statistics.median(floors) * 1e6:.3f} us.\n")
    print("\n".join(lines))
    print(f"\nMachine: {os.cpu_count()} cores ({cpu}), load average {os.getloadavg()[0]:.1f}, Python "
          f"{platform.python_version()}. Command: `python benchmarks/master_overhead.py --fmus {args.fmus} "
          f"--rounds {args.rounds} --steps {args.steps}`.")
    sys.stdout.flush()
    os._exit(0)  # libcosim's threads: skip the teardown


if __name__ == "__main__":
    main()
