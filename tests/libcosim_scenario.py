"""Run dist/Mechanism.fmu under libcosim (libcosimpy), a second, independent master.

    python3 tests/libcosim_scenario.py FMU_PATH OUT.json

Why a second master: the FMU tests drive the FMU through fmpy only, so an FMU
that merely works with fmpy's calling sequence could pass. libcosim (Open
Simulation Platform, C++) instantiates, initialises and steps FMUs in its own
way (its own setup/initialisation order, integer-nanosecond time, start values
applied during initialisation, an observer that reads outputs after each step),
so agreement with grubler.simulate under libcosim is evidence the FMU is a
conforming FMI 2.0 co-simulation slave rather than an fmpy-shaped one.

The scenario: fixed step 0.01 s, motor_torque = 3.0 given as a real initial
value (libcosim applies it in initialisation mode and no one changes it
afterwards, so it holds for the whole run), 200 steps to t = 2.0 s; after each
step [t, theta2, Fx] is read through a last-value observer, with t the
execution's simulation time after that step. The JSON is written, flushed and
fsynced, then the process leaves with os._exit(0), because a pythonfmu FMU may
crash the interpreter at shutdown (PythonFMU issue 228): the JSON is what counts.
"""

from __future__ import annotations

import json
import os
import sys
from importlib.metadata import version

from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave

NS = 1_000_000_000  # libcosim time is integer nanoseconds
STEP_NS = 10_000_000  # 0.01 s
N_STEPS = 200
TORQUE = 3.0


def write(out: str, result: dict[str, object]) -> None:
    """Write the result as {"done": true, "result": ...}, flushed and fsynced."""
    with open(out, "w") as f:
        json.dump({"done": True, "result": result}, f)
        f.flush()
        os.fsync(f.fileno())


def run(fmu: str, out: str) -> None:
    """Run the scenario and write its result to out while libcosim's objects are still alive."""
    log_output_level(CosimLogLevel.WARNING)  # libcosim logs every FMI call at debug level otherwise
    execution = CosimExecution.from_step_size(step_size=STEP_NS)
    slave = CosimLocalSlave(fmu_path=os.path.abspath(fmu), instance_name="mechanism")
    index: int = execution.add_local_slave(local_slave=slave)
    if index < 0:
        raise RuntimeError(f"libcosim could not add the FMU as a slave: {fmu}")
    vr = {v.name.decode(): v.reference for v in execution.slave_variables(slave_index=index)}
    observer = CosimObserver.create_last_value()
    if not execution.add_observer(observer=observer):
        raise RuntimeError("libcosim could not add the last-value observer")
    if not execution.real_initial_value(slave_index=index, variable_reference=vr["motor_torque"], value=TORQUE):
        raise RuntimeError("libcosim refused the initial value of motor_torque")
    refs = [vr["theta2"], vr["Fx"]]
    rows: list[list[float]] = []
    for _ in range(N_STEPS):
        if not execution.step(step_count=1):
            raise RuntimeError(f"libcosim step failed: {execution.status()}")
        t = execution.status().current_time / NS
        theta2, fx = observer.last_real_values(slave_index=index, variable_references=refs)
        rows.append([t, theta2, fx])
    write(out, {"rows": rows, "libcosimpy_version": version("libcosimpy")})


def main() -> None:
    run(sys.argv[1], sys.argv[2])
    os._exit(0)


if __name__ == "__main__":
    main()
