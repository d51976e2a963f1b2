"""Controller FMU scenarios, run in a child process by test_controllers.py.

    python controller_scenarios.py DIST_FOLDER OUT.json

Every scenario drives FMUs through fmpy with the same loops the tests run on the
Python laws (:class:`grubler.controllers.Sampler`), and writes what it measured
to OUT.json, then leaves with os._exit so that a crash at interpreter shutdown
(pythonfmu and numpy, upstream PythonFMU issue 228) can neither hide nor fake a
result.  It also holds the tiny user-written law the custom-law FMU is built from.
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np

from fmi_child import instance, report, status  # beside this script
from grubler.controllers import Law, Parameter


class RateLimiter(Law):
    """Follows its input at a limited rate (a user-written law for the custom-FMU test)."""

    inputs = {"target": "signal to follow [rad]"}
    outputs = {"y": "rate-limited signal [rad]", "limited": "1 while the rate limit acts [1]"}
    parameters = {"rate": Parameter(2.0, "largest rate of change [rad/s]"),
                  "Ts": Parameter(0.01, "sample time [s]")}

    def __init__(self, rate: float = 2.0, Ts: float = 0.01):
        if not rate > 0:
            from grubler.errors import SceneError
            raise SceneError("rate", f"must be positive, got {rate}")
        self.rate, self.Ts = float(rate), float(Ts)
        self.y = 0.0  # the state a rollback must restore

    def update(self, t, inputs):
        step = self.rate * self.Ts
        d = min(max(inputs["target"] - self.y, -step), step)
        limited = abs(inputs["target"] - self.y) > step
        self.y += d
        return {"y": self.y, "limited": 1.0 if limited else 0.0}


# -- parameters shared by the child and the tests --------------------------------------
PID_PARAMS = {"K": 8.0, "Ti": 0.4, "Td": 0.05, "N": 10.0, "b": 0.7, "c": 0.5, "Ts": 1e-3, "u_min": -6.0,
              "u_max": 6.0, "anti_windup": "back-calculation"}
CASCADE = {"K_position": 10.0, "K_speed": 50.0, "Ti_speed": 0.05, "speed_limit": 4.0, "u_min": -10.0,
           "u_max": 10.0, "Ts": 1e-3}
TRAJ = {"kind": "scurve", "distance": 1.2, "v_max": 3.0, "a_max": 5.0, "j_max": 100.0, "delay": 0.02,
        "dwell": 0.1, "repeat": 2, "reverse": True}
LIN = {"num": "0.5 2 1", "den": "0.02 1 0", "method": "tustin", "Ts": 1e-2}
CT = {"gear_ratio": 10.0, "efficiency": 0.9, "R": 1.2, "k_t": 0.05, "k_e": 0.05,
      "drive_inertia": 0.01}
ENC = {"counts_per_rev": 2000, "noise_std": 2e-3, "seed": 7, "delay": 2, "Ts": 1e-3}


# -- loops shared by the child (FMU blocks) and the tests (Sampler blocks) ---------
def plant_matrices(h: float) -> tuple[np.ndarray, np.ndarray]:
    """ZOH discretisation, at h, of a motor on an inertia: theta'' = u - theta' (states theta, omega)."""
    e = math.exp(-h)
    A = np.array([[1.0, 1.0 - e], [0.0, e]])
    B = np.array([h - (1.0 - e), 1.0 - e])
    return A, B


def pid_loop(block, h: float, n: int) -> list[list[float]]:
    """A PID block on the motor, setpoint step to 1 rad and a feedforward at 0.1 s."""
    A, B = plant_matrices(h)
    x = np.zeros(2)
    rows = []
    for k in range(n):
        t = k * h
        out = block.step(t, h, {"setpoint": 1.0 if t >= 0.01 - 1e-12 else 0.0, "measurement": float(x[0]),
                                "feedforward": 0.5 if t >= 0.1 - 1e-12 else 0.0})
        x = A @ x + B * out["u"]
        rows.append([t + h, out["u"], float(x[0])])
    return rows


def cascade_loop(block, traj, h: float, n: int) -> list[list[float]]:
    """Trajectory -> cascade controller -> motor, position and speed fed back (no current loop)."""
    A, B = plant_matrices(h)
    x = np.zeros(2)
    rows = []
    p = dict(traj.outputs)  # the setpoint at t = 0
    for k in range(n):
        t = k * h
        out = block.step(t, h, {"position_setpoint": p["position"], "velocity_setpoint": p["velocity"],
                                "position": float(x[0]), "speed": float(x[1]), "current": 0.0})
        x = A @ x + B * out["u"]
        p = traj.step(t, h, {})
        rows.append([t + h, out["u"], float(x[0]), p["position"]])
    return rows


def open_loop(block, h: float, inputs: list[dict]) -> list[list[float]]:
    """A block fed a given input sequence, one communication step each; rows of its outputs."""
    rows = []
    for k, u in enumerate(inputs):
        out = block.step(k * h, h, u)
        rows.append([(k + 1) * h] + [out[name] for name in sorted(out)])
    return rows


def encoder_inputs(n: int) -> list[dict]:
    return [{"position": 0.3 * math.sin(3.0 * k * 1e-3) + 0.01 * k * 1e-3} for k in range(n)]


def computed_torque_inputs(h: float, n: int) -> list[dict]:
    from grubler.controllers import Trajectory

    tr = Trajectory("sine", amplitude=0.8, frequency=1.5)
    return [dict(zip(("position", "velocity", "acceleration"), tr.evaluate(k * h))) for k in range(n)]


def linear_inputs(n: int) -> list[dict]:
    return [{"setpoint": math.sin(0.05 * k), "measurement": 0.2 * math.cos(0.11 * k), "feedforward": 0.0}
            for k in range(n)]


# -- the child: the same loops over FMU instances ------------------------------------
_EXTRACTED: dict = {}
_ALIVE: list = []


class FmuBlock:
    """An FMU instance with the Sampler's step(t, h, inputs) -> outputs interface."""

    def __init__(self, fmu: str, params: dict | None = None, name: str = "x", messages: list | None = None):
        from fmpy import extract, read_model_description

        if fmu not in _EXTRACTED:  # one extraction per FMU: one copy of its binary in the process
            _EXTRACTED[fmu] = (read_model_description(fmu), extract(fmu))
        md, unzipped = _EXTRACTED[fmu]
        _ALIVE.append(self)  # an instance dropped without freeInstance takes the process down later
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.names = sorted(v.name for v in md.modelVariables if v.causality == "output")
        self.messages = messages if messages is not None else []
        s = instance(md, unzipped, name, self.messages, params)
        self.s = s
        # held outputs, as Sampler.outputs (none after a failed initialisation: reading them is an error)
        self.outputs = self.read() if s.init_status == "ok" else {}

    def read(self) -> dict:
        return dict(zip(self.names, self.s.getReal([self.vr[n] for n in self.names])))

    def step(self, t: float, h: float, inputs: dict) -> dict:
        if inputs:
            self.s.setReal([self.vr[n] for n in inputs], list(inputs.values()))
        self.s.doStep(t, h)
        self.outputs = self.read()
        return self.outputs


def run_all(dist: str) -> dict:
    f = lambda name: os.path.join(dist, f"{name}.fmu")  # noqa: E731
    res = {}
    res["pid_2_samples_per_step"] = pid_loop(FmuBlock(f("PID"), PID_PARAMS, "p1"), 2e-3, 150)
    res["pid_hold"] = pid_loop(FmuBlock(f("PID"), PID_PARAMS, "p2"), 0.25e-3, 1200)
    traj = FmuBlock(f("Trajectory"), TRAJ, "tr")
    res["cascade"] = cascade_loop(FmuBlock(f("CascadeController"), CASCADE, "c"), traj, 1e-3, 600)
    res["linear"] = open_loop(FmuBlock(f("LinearController"), LIN, "lin"), 1e-2, linear_inputs(200))
    res["computed_torque"] = open_loop(FmuBlock(f("ComputedTorque"), CT, "ct"), 1e-2, computed_torque_inputs(1e-2, 70))
    # encoder: a run, then a rollback (in memory and serialised) must replay the same noise
    enc = FmuBlock(f("Encoder"), ENC, "enc")
    inputs = encoder_inputs(400)
    first = open_loop(enc, 1e-3, inputs[:200])
    state = enc.s.getFMUState()
    blob = enc.s.serializeFMUState(state)
    rest = [[r[0] + 0.2] + r[1:] for r in open_loop(_Shift(enc, 0.2), 1e-3, inputs[200:])]
    enc.s.setFMUState(state)
    replay = [[r[0] + 0.2] + r[1:] for r in open_loop(_Shift(enc, 0.2), 1e-3, inputs[200:])]
    enc.s.setFMUState(enc.s.deserializeFMUState(blob))
    replay2 = [[r[0] + 0.2] + r[1:] for r in open_loop(_Shift(enc, 0.2), 1e-3, inputs[200:])]
    res["encoder"] = {"run": first + rest, "replay": replay, "replay_serialized": replay2}
    # the user's law, built by build_controller_fmu
    law = FmuBlock(f("RateLimiter"), {"rate": 3.0}, "law")
    initial = dict(law.outputs)
    targets = [{"target": 1.0 if k < 60 else -0.5} for k in range(120)]
    a = open_loop(law, 0.01, targets[:50])
    st = law.s.getFMUState()
    b = [[r[0] + 0.5] + r[1:] for r in open_loop(_Shift(law, 0.5), 0.01, targets[50:])]
    law.s.setFMUState(st)
    c = [[r[0] + 0.5] + r[1:] for r in open_loop(_Shift(law, 0.5), 0.01, targets[50:])]
    res["custom"] = {"run": a + b, "replay": c, "initial": initial}
    # errors: logged, reported as a failed step, the instance survives
    msgs: list[str] = []
    pid = FmuBlock(f("PID"), PID_PARAMS, "nan", msgs)
    pid.step(0.0, 1e-3, {"setpoint": 1.0, "measurement": 0.0, "feedforward": 0.0})
    pid.s.setReal([pid.vr["measurement"]], [math.nan])
    res["nan_step"] = status(lambda: pid.s.doStep(1e-3, 1e-3))
    pid.s.setReal([pid.vr["measurement"]], [0.0])
    res["after_nan"] = status(lambda: pid.s.doStep(1e-3, 1e-3))
    res["messages_nan"] = list(msgs)
    msgs.clear()
    bad = FmuBlock(f("PID"), {"u_min": 1.0, "u_max": -1.0}, "bad", msgs)
    res["bad_param_init"] = bad.s.init_status
    res["bad_param"] = status(lambda: bad.s.doStep(0.0, 1e-3))
    res["messages_param"] = list(msgs)
    msgs.clear()
    # a crank longer than coupler and rocker can reach from its sketch: the loop does not close there
    badct = FmuBlock(f("ComputedTorque"), {"link2.a": 9.0}, "badct", msgs)
    res["bad_mechanism_init"] = badct.s.init_status
    res["bad_mechanism"] = status(lambda: badct.s.doStep(0.0, 1e-3))
    res["messages_mechanism"] = list(msgs)
    # Trajectory through fmpy's own simulate_fmu
    import fmpy

    sim = fmpy.simulate_fmu(f("Trajectory"), stop_time=2.5, step_size=1e-2, output_interval=1e-2,
                            start_values=TRAJ, output=["position", "velocity", "acceleration"])
    res["trajectory"] = {name: sim[name].tolist() for name in sim.dtype.names}
    return res


class _Shift:
    """A block whose clock starts at an offset (the second half of a run)."""

    def __init__(self, block, offset: float):
        self.block, self.offset = block, offset

    def step(self, t, h, inputs):
        return self.block.step(t + self.offset, h, inputs)


def main() -> None:
    dist, out_path = sys.argv[1:3]
    result = run_all(dist)
    report(out_path, result)


if __name__ == "__main__":
    main()
