"""FMU scenarios run in a child process by test_fmu.py.

    python fmu_scenarios.py SCENARIO FMU OUT.json

Each scenario drives the FMU through fmpy and writes what it measured to OUT.json,
then leaves with os._exit so that a crash in the interpreter's shutdown cannot
turn a good result into a failure or hide a bad one: the test judges the JSON,
not the exit code.
"""

from __future__ import annotations

import math
import sys

import numpy as np
from fmpy import extract, read_model_description

from fmi_child import instance, report, status  # beside this script


class Runner:
    def __init__(self, fmu: str):
        self.md = read_model_description(fmu)
        self.dir = extract(fmu)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.messages: list[str] = []

    def instance(self, name: str = "m", params: dict | None = None, start: float = 0.0):
        return instance(self.md, self.dir, name, self.messages, params, start)

    def get(self, s, names):
        return s.getReal([self.vr[n] for n in names])

    def run(self, s, t0, t1, h, torque=0.0, names=("theta2",), every=None):
        out = []
        n = int(round((t1 - t0) / h))
        every = every or 1
        for i in range(n):
            s.setReal([self.vr["motor_torque"]], [torque])
            s.doStep(currentCommunicationPoint=t0 + i * h, communicationStepSize=h)
            if (i + 1) % every == 0:
                out.append([t0 + (i + 1) * h] + self.get(s, names))
        return out


def scenario_steps(r: Runner) -> dict:
    # one trajectory at three communication steps, sampled every 10 ms
    res = {}
    for h in (1e-4, 1e-3, 1e-2):
        s = r.instance(f"h{h}")
        res[str(h)] = r.run(s, 0.0, 1.0, h, torque=3.0, names=("theta2", "theta3", "Fx", "Fy"),
                            every=int(round(1e-2 / h)))
        s.terminate()
        s.freeInstance()
    return res


def scenario_two_instances(r: Runner) -> dict:
    a = r.instance("a")
    b = r.instance("b", {"link2.m": 2.5})
    out = {"a": [], "b": []}
    for i in range(100):
        for s, key in ((a, "a"), (b, "b")):
            s.setReal([r.vr["motor_torque"]], [3.0])
            s.doStep(i * 0.01, 0.01)
            out[key].append([(i + 1) * 0.01] + r.get(s, ("theta2", "Fx")))
    return out


def scenario_rollback(r: Runner) -> dict:
    s = r.instance("s")
    r.run(s, 0.0, 1.0, 1e-2, torque=3.0)
    state = s.getFMUState()
    blob = s.serializeFMUState(state)
    first = r.run(s, 1.0, 2.0, 1e-2, torque=3.0, names=("theta2", "Fx", "KE"))
    s.setFMUState(state)
    replay = r.run(s, 1.0, 2.0, 1e-2, torque=3.0, names=("theta2", "Fx", "KE"))
    s.setFMUState(s.deserializeFMUState(blob))
    replay2 = r.run(s, 1.0, 2.0, 1e-2, torque=3.0, names=("theta2", "Fx", "KE"))
    # reset and run again from the start
    s.reset()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    again = r.run(s, 0.0, 2.0, 1e-2, torque=3.0, names=("theta2", "Fx", "KE"))[100:]
    return {"first": first, "replay": replay, "replay_serialized": replay2, "after_reset": again}


def scenario_bad_inputs(r: Runner) -> dict:
    out = {}
    s = r.instance("nan")
    r.run(s, 0.0, 0.1, 1e-2, torque=1.0)
    s.setReal([r.vr["motor_torque"]], [math.nan])
    out["nan_step"] = status(lambda: s.doStep(0.1, 0.01))
    # the instance survives: a finite input steps again from where it was
    s.setReal([r.vr["motor_torque"]], [1.0])
    out["after_nan"] = status(lambda: s.doStep(0.1, 0.01))
    out["messages_nan"] = list(r.messages)
    r.messages.clear()
    out["zero_step"] = status(lambda: s.doStep(0.11, 0.0))
    out["messages_zero_step"] = list(r.messages)
    for key, params in (("param", {"link2.m": -1.0}), ("scene", {"method": "lagrange"})):
        r.messages.clear()
        out[f"bad_{key}"] = status(lambda: r.instance(f"bad{key}", params).doStep(0.0, 0.01))
        out[f"messages_{key}"] = list(r.messages)
    return out


def scenario_start_time(r: Runner) -> dict:
    # a master that starts the clock at 5 s: the FMU's time follows it
    s = r.instance("late", {"max_step": 1e-3}, start=5.0)
    rows = r.run(s, 5.0, 6.0, 1e-2, torque=3.0, names=("theta2",))
    return {"rows": rows}


def scenario_feedthrough(r: Runner) -> dict:
    """Outputs read, an effort changed at the same instant, outputs read again."""
    s = r.instance()
    r.run(s, 0.0, 0.5, 1e-2, torque=3.0)
    first = r.get(s, ["theta2", "drive_angle", "drive_speed", "Fx", "theta2_dd"])
    s.setReal([r.vr["motor_torque"]], [5.0])
    second = r.get(s, ["Fx", "theta2_dd", "drive_angle"])
    alone = r.get(s, ["drive_speed"])
    s.doStep(currentCommunicationPoint=0.5, communicationStepSize=1e-2)
    after_step = r.get(s, ["drive_speed", "Fx"])
    return {"first": first, "second": second, "alone": alone, "after_step": after_step}


def scenario_simulate(r: Runner, fmu: str) -> dict:
    import fmpy

    sig = np.array([(0.0, 3.0, 0.0), (10.0, 3.0, 0.0)],
                   dtype=[("time", float), ("motor_torque", float), ("load_torque", float)])
    res = fmpy.simulate_fmu(fmu, stop_time=2.0, output_interval=1e-2, step_size=1e-2, input=sig,
                            output=["theta2", "theta4", "Fx", "Fy", "drive_angle", "drive_speed", "KE"])
    return {name: res[name].tolist() for name in res.dtype.names}


def main() -> None:
    scenario, fmu, out_path = sys.argv[1:4]
    r = Runner(fmu)
    fn = globals()[f"scenario_{scenario}"]
    result = fn(r, fmu) if scenario == "simulate" else fn(r)
    report(out_path, result)


if __name__ == "__main__":
    main()
