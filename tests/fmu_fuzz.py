"""Property-based fuzz of FMI call sequences on the pythonfmu FMUs, run in a child process.

    python fmu_fuzz.py DIST_FOLDER OUT.json MAX_EXAMPLES [NAME ...]

For every FMU named (default: all of FMUS in DIST_FOLDER), hypothesis generates
call sequences on one instance: setup, enter and exit initialisation in any
order or not at all, steps at the right time or not with any step size (NaN,
negative, 1e300), sets of any variable (unknown value references and wrong
types included) to any value, gets, state get/set with the instance's own
blob, a mutated or truncated one, random bytes or another FMU's, terminate and
reset.  The contract checked at every call:

- the status is OK, Warning, Discard or Error, never Fatal, and the process survives;
- a status other than OK comes with a message the FMU logged during that call;
- no call takes longer than CALL_BOUND seconds.

The child writes the counts and the first violations to OUT.json and leaves with
os._exit (pythonfmu's exit crash, upstream issue 228).  A fixed seed makes a run
repeatable (hypothesis' derandomize); benchmarks/ can run it with more examples.
"""

from __future__ import annotations

import json
import math
import os
import resource
import sys
import time

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

FMUS = ("PID", "CascadeController", "LinearController", "ComputedTorque", "Trajectory", "Encoder", "RateLimiter")
CALL_BOUND = 20.0  # seconds: a noisy 2-core box; a hang is what this catches
STATUS = {0: "ok", 1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}

_LOG: list[tuple[int, str]] = []
_KEEP: list = []  # instances that are not freed (after a failure to instantiate nothing is kept)


def _logger(component, instance_name, level, category, message):
    _LOG.append((level, message.decode(errors="replace")))


def _strings():
    return st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\0"), max_size=40)


def _floats():
    return st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                     st.sampled_from([0.0, -0.0, 1e-3, 1e-2, 0.1, 1.0, 1e300, -1.0]))


def calls():
    """One FMI call, as a tuple the runner interprets."""
    vr = st.one_of(st.integers(0, 40), st.sampled_from([10_000, 2**31 - 1]))
    return st.one_of(
        st.tuples(st.just("setup"), _floats()),
        st.just(("enter",)),
        st.just(("exit",)),
        st.tuples(st.just("step"), st.sampled_from(["now", "now", "now", "other"]), _floats(),
                  st.one_of(st.sampled_from([1e-3, 1e-2, 0.25]), _floats())),
        st.tuples(st.just("setReal"), st.lists(vr, min_size=1, max_size=3), _floats()),
        st.tuples(st.just("setInteger"), st.lists(vr, min_size=1, max_size=2), st.integers(-2**31, 2**31 - 1)),
        st.tuples(st.just("setBoolean"), st.lists(vr, min_size=1, max_size=2), st.booleans()),
        st.tuples(st.just("setString"), st.lists(vr, min_size=1, max_size=2), _strings()),
        st.tuples(st.just("get"), st.sampled_from(["Real", "Integer", "Boolean", "String"]),
                  st.lists(vr, min_size=1, max_size=4)),
        st.just(("getState",)),
        st.tuples(st.just("setState"), st.sampled_from(["own", "mutated", "truncated", "random", "foreign"]),
                  st.integers(0, 10_000), st.binary(max_size=120)),
        st.just(("terminate",)),
        st.just(("reset",)),
    )


class Runner:
    """Plays call sequences on instances of one FMU and records contract violations."""

    def __init__(self, fmu: str, foreign_blob: bytes):
        from fmpy import extract, read_model_description

        self.md = read_model_description(fmu)
        self.unzipped = extract(fmu)
        self.name = self.md.coSimulation.modelIdentifier
        self.foreign = foreign_blob
        self.types = {v.valueReference: v.type for v in self.md.modelVariables}
        self.calls = 0
        self.statuses: dict[str, int] = {}
        self.violations: list[dict] = []
        self.slowest = 0.0

    def new(self):
        from fmpy.fmi2 import FMU2Slave

        s = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzipped, modelIdentifier=self.name,
                      instanceName=f"{self.name}{self.calls}")
        s.instantiate(loggingOn=True)
        return s

    def play(self, initialised: bool, sequence) -> None:
        s = self.new()
        if initialised:  # half the sequences start from a running instance, to reach its deeper states
            sequence = [("setup", 0.0), ("enter",), ("exit",), *sequence]
        ctx = {"t": 0.0, "blob": None}
        trail = []
        for call in sequence:
            trail.append(repr(call)[:200])
            del _LOG[:]
            t0 = time.perf_counter()
            code = self._call(s, call, ctx)
            took = time.perf_counter() - t0
            self.calls += 1
            self.slowest = max(self.slowest, took)
            self.statuses[STATUS.get(code, str(code))] = self.statuses.get(STATUS.get(code, str(code)), 0) + 1
            problem = None
            if code not in (0, 1, 2, 3):
                problem = f"status {STATUS.get(code, code)}"
            elif code != 0 and not _LOG:
                problem = f"status {STATUS[code]} without a logged message"
            elif took > CALL_BOUND:
                problem = f"took {took:.1f} s"
            if problem and len(self.violations) < 20:
                self.violations.append({"fmu": self.name, "problem": problem, "calls": trail[-8:],
                                        "log": [m for _, m in _LOG][-3:]})
            if code == 4:  # the instance is gone: nothing more to ask it
                _KEEP.append(s)
                return
        s.freeInstance()

    def _call(self, s, call, ctx) -> int:
        from fmpy.fmi1 import FMICallException

        kind = call[0]
        try:
            if kind == "setup":
                s.setupExperiment(startTime=call[1])
                ctx["t"] = call[1]
            elif kind == "enter":
                s.enterInitializationMode()
            elif kind == "exit":
                s.exitInitializationMode()
            elif kind == "step":
                t = ctx["t"] if call[1] == "now" else call[2]
                s.doStep(t, call[3])
                ctx["t"] = t + call[3]
            elif kind.startswith("set") and kind != "setState":
                vrs, value = call[1], call[2]
                getattr(s, kind)(vrs, [value] * len(vrs))
            elif kind == "get":
                getattr(s, f"get{call[1]}")(call[2])
            elif kind == "getState":
                state = s.getFMUState()
                ctx["blob"] = bytes(s.serializeFMUState(state))
                s.freeFMUState(state)
            elif kind == "setState":
                blob = self._blob(call, ctx)
                state = s.deserializeFMUState(blob)
                try:
                    s.setFMUState(state)
                finally:
                    s.freeFMUState(state)
            elif kind == "terminate":
                s.terminate()
            elif kind == "reset":
                s.reset()
                ctx["t"] = 0.0
            return 0
        except FMICallException as exc:
            return int(exc.status)

    def _blob(self, call, ctx) -> bytes:
        how, at, noise = call[1], call[2], call[3]
        own = ctx["blob"] or self.foreign
        if how == "own":
            return own
        if how == "mutated":
            b = bytearray(own)
            b[at % len(b)] ^= 1 + at % 255
            return bytes(b)
        if how == "truncated":
            return own[: at % len(own)]
        if how == "random":
            return noise
        return self.foreign


def _foreign_blob(fmu: str) -> bytes:
    """A valid state blob of another FMU."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(fmu)
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="foreign")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    state = s.getFMUState()
    blob = bytes(s.serializeFMUState(state))
    s.freeFMUState(state)
    _KEEP.append(s)
    return blob


def main() -> None:
    from fmpy.fmi2 import defaultCallbacks, fmi2CallbackLoggerTYPE

    dist, out_path, examples = sys.argv[1], sys.argv[2], int(sys.argv[3])
    names = sys.argv[4:] or [n for n in FMUS if os.path.exists(os.path.join(dist, f"{n}.fmu"))]
    resource.setrlimit(resource.RLIMIT_AS, (16 << 30, 16 << 30))  # a runaway allocation fails here
    keep = fmi2CallbackLoggerTYPE(_logger)
    defaultCallbacks.logger = keep
    result = {"fmus": {}, "violations": []}
    for name in names:
        other = "Encoder" if name != "Encoder" else "PID"
        runner = Runner(os.path.join(dist, f"{name}.fmu"), _foreign_blob(os.path.join(dist, f"{other}.fmu")))

        @settings(max_examples=examples, derandomize=True, deadline=None, database=None,
                  suppress_health_check=list(HealthCheck))
        @given(st.booleans(), st.lists(calls(), min_size=1, max_size=25))
        def sequences(initialised, seq):
            runner.play(initialised, seq)

        t0 = time.perf_counter()
        sequences()
        result["fmus"][name] = {"sequences": examples, "calls": runner.calls, "statuses": runner.statuses,
                                "slowest_call_s": runner.slowest, "seconds": time.perf_counter() - t0}
        result["violations"] += runner.violations
    with open(out_path, "w") as fh:
        json.dump({"done": True, "result": result}, fh, default=lambda o: repr(o) if not math.isfinite(o) else o)
        fh.flush()
        os.fsync(fh.fileno())
    os._exit(0)


if __name__ == "__main__":
    main()
