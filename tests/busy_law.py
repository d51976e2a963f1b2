"""A law that spends its sample in Python (for the Ctrl-C test: a signal then lands inside its do_step)."""

import time
from pathlib import Path

from grubler.controllers.law import Law, Parameter


class Busy(Law):
    """Holds its output at the time of its last sample, after spinning for ``spin`` seconds."""

    inputs = {}
    outputs = {"y": "time of the last sample [s]"}
    parameters = {"spin": Parameter(0.002, "Python time spent per sample [s]"),
                  "Ts": Parameter(0.0, "sample time [s]"),
                  "started": Parameter("", "a file made at the first sample, once it steps [-]")}

    def __init__(self, spin: float = 0.002, Ts: float = 0.0, started: str = ""):
        self.spin, self.Ts, self.started = float(spin), float(Ts), str(started)

    def update(self, t, inputs):
        if self.started:
            Path(self.started).touch()
            self.started = ""
        end = time.perf_counter() + self.spin
        while time.perf_counter() < end:  # pure Python: where a SIGINT raises KeyboardInterrupt
            pass
        return {"y": t}
