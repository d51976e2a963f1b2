"""CPU time as the IFToMM library asks for it, measured the same way for every problem here.

The library's submissions give the CPU time of one run.  On a shared machine one
run is noise, so a problem is run ``repeat`` times in one process after a warm-up
run (imports, the kernel's first call) and the median of the process's CPU time
(``time.process_time``: this process's user + system time, not the wall clock
other jobs stretch) is what is reported, with the machine and its load average.
"""

from __future__ import annotations

import os
import platform
import statistics
import time


def median_cpu(run, repeat: int = 7):
    """(median CPU seconds, every run's seconds, the last run's result) of ``repeat`` calls of ``run()``."""
    result = run()  # warm-up: not timed
    times = []
    for _ in range(max(1, repeat)):
        t0 = time.process_time()
        result = run()
        times.append(time.process_time() - t0)
    return statistics.median(times), times, result


def machine() -> str:
    """This machine and its load, in one line for a table's caption."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), cpu)
    except OSError:
        pass
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{cpu}, {os.cpu_count()} cores, load average {load}, Python {platform.python_version()}"
