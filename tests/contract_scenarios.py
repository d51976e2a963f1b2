"""FMU contract scenarios for the pythonfmu FMUs, run in a child process by test_fmu_contract.py.

    python contract_scenarios.py MODE DIST_FOLDER OUT.json [EXTRA]

MODE is one of ``states``, ``every`` (state round trips of every FMU), ``sequence``, ``reload`` (a second instantiation
after the first extraction folder is deleted), ``versions`` (two builds of
the package in one process; EXTRA is the other build's FMU) and ``cosim`` (grubler's
runner given the other build).  The child writes
what it measured to OUT.json and leaves with os._exit (pythonfmu's exit crash,
upstream issue 228).  Before its FMUs are loaded it never imports grubler (but in
``cosim``): they load their own copies, as in an importer that is not grubler.
"""

from __future__ import annotations

import math
import os
import pickle
import resource
import shutil
import sys

from fmi_child import instance, recording_callbacks, report, status  # beside this script

ENC = {"counts_per_rev": 2000, "noise_std": 2e-3, "seed": 7, "delay": 2, "Ts": 1e-3}


def _open(fmu: str, folder: str | None = None):
    from fmpy import extract, read_model_description

    md = read_model_description(fmu)
    return md, extract(fmu, unzipdir=folder)


def _refs(md) -> dict:
    return {v.name: v.valueReference for v in md.modelVariables}


def _outputs(md) -> list:
    return [v.valueReference for v in md.modelVariables if v.causality == "output"]


def _steps(s, md, t0: float, n: int, h: float = 1e-3) -> list:
    """n steps of an encoder from t0 on a known input; the outputs after each."""
    vr, out = _refs(md), _outputs(md)
    rows = []
    for k in range(n):
        t = t0 + k * h
        s.setReal([vr["position"]], [0.3 * math.sin(3.0 * t)])
        s.doStep(t, h)
        rows.append(list(s.getReal(out)))
    return rows


def _set_blob(s, blob: bytes) -> str:
    return status(lambda: s.setFMUState(s.deserializeFMUState(blob)))


class _Command:
    """What a crafted pickle would run: it creates a file."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def states(dist: str, scratch: str) -> dict:
    md, d = _open(os.path.join(dist, "Encoder.fmu"))
    res: dict = {}
    msgs: list[str] = []
    a = instance(md, d, "a", msgs, ENC)
    first = _steps(a, md, 0.0, 100)
    blob = bytes(a.serializeFMUState(a.getFMUState()))
    res["blob_head"] = blob[:8].decode("latin-1")
    rest = _steps(a, md, 0.1, 100)
    # a serialised state replays the run bit for bit (the noise generator included)
    res["replay_status"] = _set_blob(a, blob)
    res["replay_equal"] = _steps(a, md, 0.1, 100) == rest
    # bad blobs: refused, logged, the instance unchanged (it goes on as from its current state)
    bad = bytearray(blob)
    bad[40] ^= 0x01
    marker = os.path.join(scratch, "pickle_ran")
    crafted = pickle.dumps(_Command(marker))
    framed = _reframe(blob, b'{"identity":{"model":"Encoder"},"state":{"pickle":"' + crafted.hex().encode() + b'"}}')
    for name, b in (("corrupted", bytes(bad)), ("truncated", blob[: len(blob) // 2]), ("empty", b""),
                    ("pickle", crafted), ("framed_pickle", framed)):
        msgs.clear()
        res[f"{name}_status"] = _set_blob(a, b)
        res[f"{name}_messages"] = list(msgs)
    res["pickle_ran"] = os.path.exists(marker)
    # a crafted blob with this instance's identity (copied from a real one) whose payload does not
    # fit: refused by setFMUstate, and the instance is left as it was
    from grubler.system.fmu_state import SlaveState, from_bytes, to_bytes  # the FMUs' own copy, loaded by now

    real = from_bytes(blob)
    payload = real.payload
    payload["sampler"]["law"] = {"update": "shadows the law's method"}
    misfit = to_bytes(SlaveState(real.identity, payload))
    now = bytes(a.serializeFMUState(a.getFMUState()))
    t_now = 0.2
    expected = _steps(a, md, t_now, 10)
    _set_blob(a, now)
    msgs.clear()
    res["misfit_status"] = _set_blob(a, misfit)
    res["misfit_messages"] = list(msgs)
    res["misfit_left_unchanged"] = _steps(a, md, t_now, 10) == expected
    # a state from an instance with other parameters, and from another FMU
    b_inst = instance(md, d, "b", msgs, {**ENC, "seed": 8})
    _steps(b_inst, md, 0.0, 10)
    other_params = bytes(b_inst.serializeFMUState(b_inst.getFMUState()))
    md2, d2 = _open(os.path.join(dist, "PID.fmu"))
    pid = instance(md2, d2, "pid", msgs, {})
    other_fmu = bytes(pid.serializeFMUState(pid.getFMUState()))
    for name, b in (("other_parameters", other_params), ("other_fmu", other_fmu)):
        msgs.clear()
        res[f"{name}_status"] = _set_blob(a, b)
        res[f"{name}_messages"] = list(msgs)
    # a state set before initialisation (as fmusim's --initial-fmu-state-file does) is honoured
    from fmpy.fmi2 import FMU2Slave

    c = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="c")
    c.instantiate(loggingOn=True)
    vr = _refs(md)
    for k, v in ENC.items():
        (c.setReal if k in ("noise_std", "Ts") else c.setInteger)([vr[k]], [v])
    res["preinit_set_status"] = _set_blob(c, blob)
    c.setupExperiment(startTime=0.0)
    c.enterInitializationMode()
    res["preinit_exit_status"] = status(c.exitInitializationMode)
    res["preinit_equal"] = _steps(c, md, 0.1, 100) == rest
    # ... and refused at the end of initialisation if it is another instance's
    msgs.clear()
    e = instance(md, d, "e", msgs, {**ENC, "seed": 9})  # parameters set, then the state, then exit
    e.reset()
    e.setupExperiment(startTime=0.0)
    for k, v in {**ENC, "seed": 9}.items():
        (e.setReal if k in ("noise_std", "Ts") else e.setInteger)([vr[k]], [v])
    _set_blob(e, blob)
    e.enterInitializationMode()
    res["preinit_foreign_exit_status"] = status(e.exitInitializationMode)
    res["preinit_foreign_messages"] = list(msgs)
    res["first"] = first
    return res


# every pythonfmu FMU the project builds, with parameters and an input sequence that move its state
EVERY = {
    "PID": ({"K": 8.0, "Ti": 0.4, "Td": 0.05, "Ts": 1e-3}, lambda t: {"setpoint": 1.0, "measurement": math.sin(t)}),
    "CascadeController": ({"K_position": 10.0, "K_speed": 50.0, "Ti_speed": 0.05, "Ts": 1e-3},
                          lambda t: {"position_setpoint": 1.0, "position": math.sin(t), "speed": math.cos(t)}),
    "LinearController": ({"num": "0.5 2 1", "den": "0.02 1 0", "Ts": 1e-3},
                         lambda t: {"setpoint": 1.0, "measurement": 0.2 * math.cos(7 * t)}),
    "ComputedTorque": ({"mechanism": "thesis-fourbar", "gear_ratio": 10.0},
                       lambda t: {"position": 0.2 + t, "velocity": 3.0, "acceleration": 5.0 * math.cos(t)}),
    "Trajectory": ({"kind": "trapezoid", "distance": 1.0, "v_max": 2.0, "a_max": 8.0}, lambda t: {}),
    "Encoder": (ENC, lambda t: {"position": 0.3 * math.sin(3.0 * t)}),
    "RateLimiter": ({"rate": 3.0}, lambda t: {"target": 1.0 if t < 0.03 else -0.5}),
}


def _run(s, md, inputs, t0: float, n: int, h: float = 1e-3) -> list:
    vr, out = _refs(md), _outputs(md)
    rows = []
    for k in range(n):
        t = t0 + k * h
        u = inputs(t)
        if u:
            s.setReal([vr[name] for name in u], list(u.values()))
        s.doStep(t, h)
        rows.append(list(s.getReal(out)))
    return rows


def every(dist: str) -> dict:
    """For each FMU: a serialised state replays bit for bit, also when set before initialisation."""
    from fmpy.fmi2 import FMU2Slave

    res = {}
    for name, (params, inputs) in EVERY.items():
        md, d = _open(os.path.join(dist, f"{name}.fmu"))
        msgs: list[str] = []
        a = instance(md, d, f"{name}_a", msgs, params)
        _run(a, md, inputs, 0.0, 40)
        blob = bytes(a.serializeFMUState(a.getFMUState()))
        rest = _run(a, md, inputs, 0.04, 40)
        replay_status = _set_blob(a, blob)
        replay = _run(a, md, inputs, 0.04, 40)
        # a fresh instance, its parameters set, the state set before initialisation
        b = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=f"{name}_b")
        b.instantiate(loggingOn=True)
        _set_params(b, md, params)
        preinit_status = _set_blob(b, blob)
        b.setupExperiment(startTime=0.0)
        b.enterInitializationMode()
        exit_status = status(b.exitInitializationMode)
        preinit = _run(b, md, inputs, 0.04, 40)
        res[name] = {"replay_status": replay_status, "replay_equal": replay == rest, "preinit_status": preinit_status,
                     "exit_status": exit_status, "preinit_equal": preinit == rest,
                     "moved": rest[0] != rest[-1], "messages": msgs}
    return res


def _set_params(s, md, params: dict) -> None:
    vr = _refs(md)
    kinds = {v.name: v.type for v in md.modelVariables}
    for k, v in params.items():
        setter = {"Real": s.setReal, "Integer": s.setInteger, "Boolean": s.setBoolean, "String": s.setString}[kinds[k]]
        setter([vr[k]], [v])


def _reframe(blob: bytes, body: bytes) -> bytes:
    """A blob with a valid header and digest around ``body`` (what a crafted state would look like)."""
    import hashlib
    import struct

    head = blob[:8] + struct.pack("<IQ", struct.unpack_from("<I", blob, 8)[0], len(body)) + body
    return head + hashlib.sha256(head).digest()


def sequence(dist: str) -> dict:
    from fmpy.fmi2 import FMU2Slave

    md, d = _open(os.path.join(dist, "Encoder.fmu"))
    vr, out = _refs(md), _outputs(md)
    res: dict = {}
    msgs: list[str] = []

    def fresh(name):
        s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=name)
        s.instantiate(loggingOn=True, callbacks=recording_callbacks(
            lambda comp, inst, level, cat, message: msgs.append(f"{level}:{message.decode()}")))
        return s

    def record(key, call):
        msgs.clear()
        res[key] = status(call)
        res[key + "_messages"] = list(msgs)

    s = fresh("early")
    record("step_before_init", lambda: s.doStep(0.0, 1e-3))
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    record("step_in_init_mode", lambda: s.doStep(0.0, 1e-3))
    record("exit", s.exitInitializationMode)
    record("set_output", lambda: s.setReal([out[0]], [1.0]))
    record("set_parameter_after_init", lambda: s.setInteger([vr["delay"]], [5]))
    res["delay_after_refusal"] = s.getInteger([vr["delay"]])[0]
    record("unknown_reference", lambda: s.getReal([10_000]))
    record("wrong_type", lambda: s.setReal([vr["delay"]], [1.0]))
    record("step", lambda: s.doStep(0.0, 1e-3))
    s.terminate()
    record("step_after_terminate", lambda: s.doStep(1e-3, 1e-3))
    # a parameter that sizes a buffer: refused at initialisation, by name and limit
    big = fresh("big")
    big.setupExperiment(startTime=0.0)
    big.enterInitializationMode()
    big.setInteger([vr["delay"]], [2_000_000_000])
    record("huge_delay_exit", big.exitInitializationMode)
    record("huge_delay_output", lambda: big.getReal(out))
    record("huge_delay_step", lambda: big.doStep(0.0, 1e-3))
    # the same through the linear controller's order
    md_l, d_l = _open(os.path.join(dist, "LinearController.fmu"))
    msgs.clear()
    lin = instance(md_l, d_l, "lin", msgs, {"num": "1 " * 5000, "den": "1 " * 5001})
    res["huge_order_exit"] = lin.init_status
    res["huge_order_exit_messages"] = list(msgs)
    # a step that would run for ever: refused (fmi2Discard), the instance goes on
    msgs.clear()
    long = instance(md, d, "long", msgs, ENC)
    record("endless_step", lambda: long.doStep(0.0, 1e300))
    record("after_endless_step", lambda: long.doStep(0.0, 1e-3))
    # scene text an importer may pass as the computed-torque mechanism (issue 13): Error, never Fatal
    md_c, d_c = _open(os.path.join(dist, "ComputedTorque.fmu"))
    for key, text in (("deep_toml", "a = " + "[" * 3000 + "]" * 3000), ("huge_integer", "gravity = " + "9" * 400),
                      ("binary", "\x01\x02 = ]]")):
        msgs.clear()
        ct = instance(md_c, d_c, key, msgs, {"mechanism": text})
        res[key + "_exit"] = ct.init_status
        res[key + "_exit_messages"] = list(msgs)
    return res


def reload(dist: str, scratch: str) -> dict:
    """Instantiate, delete the extraction folder, extract again elsewhere, instantiate again."""
    res: dict = {}
    params = {"mechanism": "thesis-fourbar", "gear_ratio": 10.0}  # reads a preset file at initialisation
    rows = []
    for k in range(2):
        folder = os.path.join(scratch, f"extract{k}")
        md, d = _open(os.path.join(dist, "ComputedTorque.fmu"), folder)
        msgs: list[str] = []
        s = instance(md, d, f"ct{k}", msgs, params)
        res[f"init_{k}"] = s.init_status
        res[f"messages_{k}"] = list(msgs)
        vr = _refs(md)
        s.setReal([vr["position"], vr["velocity"], vr["acceleration"]], [0.2, 3.0, 5.0])
        res[f"step_{k}"] = status(lambda: s.doStep(0.0, 1e-2))
        rows.append(list(s.getReal(_outputs(md))))
        s.terminate()
        s.freeInstance()
        shutil.rmtree(folder)
        res[f"grubler_from_{k}"] = os.path.dirname(sys.modules["grubler"].__file__).startswith(folder)
    res["same_outputs"] = rows[0] == rows[1]
    res["rows"] = rows
    return res


def versions(dist: str, other: str) -> dict:
    """The FMU of this build, then one of another build of the package, in one process."""
    res: dict = {}
    md, d = _open(os.path.join(dist, "PID.fmu"))
    msgs: list[str] = []
    a = instance(md, d, "a", msgs, {})
    res["first"] = status(lambda: a.doStep(0.0, 1e-3))
    md_b, d_b = _open(other)
    msgs_b: list[str] = []  # what it logs while it is instantiated too: instance() gives its logger then

    def second():
        instance(md_b, d_b, "b", msgs_b, {})

    res["second"] = status(second)
    res["second_messages"] = list(msgs_b)
    res["first_still_steps"] = status(lambda: a.doStep(1e-3, 1e-3))
    return res


def cosim_other_build(other: str) -> dict:
    """grubler's own co-simulation runner given an FMU built from other package sources."""
    from grubler import cosim, ssp  # this process runs the grubler under test

    system = ssp.System("other")
    system.add("pid", other)
    try:
        cosim.run(system, t_end=0.01, step=1e-3)
        return {"error": None}
    except cosim.CosimError as exc:
        return {"error": str(exc)}


def main() -> None:
    mode, dist, out_path = sys.argv[1:4]
    extra = sys.argv[4] if len(sys.argv) > 4 else ""
    # a runaway allocation ends in MemoryError here, not in the machine's OOM killer
    resource.setrlimit(resource.RLIMIT_AS, (16 << 30, 16 << 30))
    result = {"states": lambda: states(dist, extra), "sequence": lambda: sequence(dist), "every": lambda: every(dist),
              "reload": lambda: reload(dist, extra), "versions": lambda: versions(dist, extra),
              "cosim": lambda: cosim_other_build(extra)}[mode]()
    report(out_path, result)


if __name__ == "__main__":
    main()
