"""Run an SSP system from its file under libcosim (libcosimpy), telling it nothing else.

    python3 tests/libcosim_ssp_scenario.py SYSTEM.ssd T_END OUT.json ELEMENT.VARIABLE...

libcosim takes the communication step, the parameter values (String ones too)
and the connections from the file alone; the step comes from the file's
``osp:FixedStepAlgorithm baseStepSize`` annotation.  Run in a child process:
libcosim's loader crashes its host on a file it cannot run.  Writes
{"done": true, "result": {"step": s, "rows": [[t, v1, v2, ...], ...]}} after each
step's values are read.
"""

import json
import os
import sys

from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver

NS = 1_000_000_000  # libcosim time is integer nanoseconds


def run(ssd: str, t_end: float, out: str, signals: list[str]) -> None:
    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_ssp_file(ssp_path=os.path.abspath(ssd))  # no step_size: the file's
    observer = CosimObserver.create_last_value()
    if not execution.add_observer(observer=observer):
        raise RuntimeError("libcosim could not add the last-value observer")
    index = {s.name.decode(): s.index for s in execution.slave_infos()}
    refs = []
    for sig in signals:
        element, name = sig.split(".", 1)
        vr = {v.name.decode(): v.reference for v in execution.slave_variables(slave_index=index[element])}
        refs.append((index[element], vr[name]))
    rows = []
    while True:
        if not execution.step(step_count=1):
            raise RuntimeError(f"libcosim step failed: {execution.status()}")
        t = execution.status().current_time / NS
        rows.append([t] + [observer.last_real_values(slave_index=i, variable_references=[r])[0] for i, r in refs])
        if t >= t_end - 1e-9:
            break
    step = rows[1][0] - rows[0][0] if len(rows) > 1 else rows[0][0]
    with open(out, "w") as f:
        json.dump({"done": True, "result": {"step": step, "rows": rows}}, f)
        f.flush()
        os.fsync(f.fileno())


if __name__ == "__main__":
    run(sys.argv[1], float(sys.argv[2]), sys.argv[3], sys.argv[4:])
    os._exit(0)  # libcosim's teardown is no part of the answer
