"""The pythonfmu FMUs the project builds (controllers, encoder, trajectory, a user's
own law) meet the FMU contract: states serialised as a checked plain byte layout
(never pickle), a state set before initialisation honoured, the FMI call sequence
enforced with fmi2Error and a logged message (never fmi2Fatal), buffer-sizing
parameters bounded, a second instantiation after the first extraction folder is
gone, and two builds of the package never silently sharing code.

The FMUs run in child processes (contract_scenarios.py): pythonfmu can crash at
interpreter exit (upstream issue 228).
"""

from __future__ import annotations

import collections
import json
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from grubler.errors import SceneError
from grubler.system.fmu_state import MAGIC, SlaveState, StateError, from_bytes, to_bytes

HERE = Path(__file__).parent
ERROR = "status 3 (error)"


# -- the byte layout, in this process -------------------------------------------------
IDENT = {"model": "M", "build": "b", "parameters": "p"}


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


def test_state_round_trips_bit_exactly():
    g = np.random.Generator(np.random.PCG64(3))
    g.standard_normal(5)
    mt = np.random.Generator(np.random.MT19937(4))
    payload = {"x": np.array([[1.5, -0.0], [np.nan, np.inf]]), "i": np.arange(4, dtype=np.int16),
               "g": g, "mt": mt, "d": collections.deque([0.1, 0.2], maxlen=3), "t": (1, 2.0, None),
               "s": "text", "big": 2**100, "f": np.float32(0.1), (1, "k"): [True, False]}
    back = from_bytes(to_bytes(SlaveState(IDENT, payload))).payload
    assert back["x"].tobytes() == payload["x"].tobytes() and back["x"].dtype == payload["x"].dtype
    assert back["i"].dtype == np.int16 and back["i"].tolist() == [0, 1, 2, 3]
    assert back["g"].standard_normal(4).tobytes() == g.standard_normal(4).tobytes()
    assert back["mt"].random(3).tobytes() == mt.random(3).tobytes()
    assert back["d"] == payload["d"] and back["d"].maxlen == 3
    assert back["t"] == (1, 2.0, None) and back["s"] == "text" and back["big"] == 2**100
    assert back["f"].dtype == np.float32 and back["f"] == payload["f"] and back[(1, "k")] == [True, False]


def test_state_layout_is_versioned_and_checked():
    blob = to_bytes(SlaveState(IDENT, {"x": 1.0}))
    assert blob.startswith(MAGIC) and int.from_bytes(blob[8:12], "little") == 1
    flipped = bytearray(blob)
    flipped[-40] ^= 0x20
    cases = {"corrupted": bytes(flipped), "truncated": blob[:-5], "not a grubler": b"x" * 100,
             "format version 7": blob[:8] + (7).to_bytes(4, "little") + blob[12:]}
    for why, bad in cases.items():
        with pytest.raises(StateError, match=why):
            from_bytes(bad)
    with pytest.raises(StateError, match="not a grubler"):
        from_bytes(pickle.dumps({"x": "y" * 100}))
    with pytest.raises(StateError, match="other parameter values"):
        from_bytes(blob).check({**IDENT, "parameters": "q"})
    with pytest.raises(StateError, match="another FMU"):
        from_bytes(blob).check({**IDENT, "model": "N"})


def test_a_state_that_is_not_plain_data_is_refused_by_name():
    with pytest.raises(StateError, match=r"\['law'\]: a object cannot be serialised"):
        to_bytes(SlaveState(IDENT, {"law": object()}))
    with pytest.raises(StateError, match="dtype object"):
        to_bytes(SlaveState(IDENT, {"a": np.array([None])}))


def test_buffer_sizing_parameters_are_bounded_by_name():
    from grubler.controllers import Encoder, LinearController

    with pytest.raises(SceneError, match=r"delay: must be at most 1000000, got 2000000000"):
        Encoder(delay=2_000_000_000)
    with pytest.raises(SceneError, match=r"num: 5001 coefficients: a controller has order at most 64"):
        LinearController.from_parameters(num="1 " * 5001, den="1 " * 5002)


def test_default_law_state_holds_inner_laws_as_plain_data():
    from grubler.controllers import CascadeController

    c = CascadeController(K_position=10.0, K_speed=50.0, Ti_speed=0.05, Ts=1e-3)
    for k in range(5):
        c.update(k * 1e-3, {"position_setpoint": 1.0, "velocity_setpoint": 0.0, "position": 0.0, "speed": 0.0})
    blob = to_bytes(SlaveState(IDENT, c.get_state()))
    after = [c.update(5e-3 + k * 1e-3, {"position_setpoint": 1.0, "velocity_setpoint": 0.0, "position": 0.1,
                                        "speed": 0.2}) for k in range(5)]
    c.set_state(from_bytes(blob).payload)
    again = [c.update(5e-3 + k * 1e-3, {"position_setpoint": 1.0, "velocity_setpoint": 0.0, "position": 0.1,
                                        "speed": 0.2}) for k in range(5)]
    assert after == again


# -- the FMUs, in child processes ----------------------------------------------------
@pytest.fixture(scope="module")
def dist(tmp_path_factory):
    sys.path.insert(0, str(HERE.parent))
    import builds

    from controller_scenarios import RateLimiter  # a user's own law

    from grubler.controllers import PID, CascadeController, ComputedTorque, Encoder, LinearController, Trajectory

    folder = tmp_path_factory.mktemp("contract_dist")
    # the shipped laws are native FMUs (test_native_laws.py); the pythonfmu route, which users'
    # own laws take, is held to its contract on them too
    for law in (PID, CascadeController, LinearController, Encoder, Trajectory, ComputedTorque, RateLimiter):
        builds.controller_fmu(law, folder)
    return folder


def run_child(mode: str, dist: Path, out: Path, extra: str = "") -> dict:
    proc = subprocess.run([sys.executable, str(HERE / "contract_scenarios.py"), mode, str(dist), str(out), extra],
                          capture_output=True, text=True, timeout=600, cwd=str(HERE))
    assert out.exists(), f"contract scenario {mode} wrote nothing (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    return json.loads(out.read_text())["result"]


def _said(messages: list[str], text: str) -> bool:
    return any(text in m for m in messages)


def test_serialised_states_replay_and_bad_blobs_are_refused(dist, tmp_path):
    r = run_child("states", dist, tmp_path / "out.json", str(tmp_path))
    assert r["blob_head"] == "GRBSTATE"
    assert r["replay_status"] == "ok" and r["replay_equal"]
    for name, why in (("corrupted", "corrupted"), ("truncated", "truncated"), ("empty", "truncated"),
                      ("pickle", "not a grubler FMU state"), ("framed_pickle", "unknown value tag 'pickle'"),
                      ("other_parameters", "other parameter values"), ("other_fmu", "another FMU")):
        # refused on the way in: by fmi2DeSerializeFMUstate, with the instance it is meant for
        assert r[f"{name}_status"] == f"fmi2DeSerializeFMUstate failed with {ERROR}.", (name, r[f"{name}_status"])
        assert _said(r[f"{name}_messages"], why), (name, r[f"{name}_messages"])
    assert not r["pickle_ran"]
    assert r["misfit_status"] == f"fmi2SetFMUstate failed with {ERROR}.", r["misfit_status"]
    assert _said(r["misfit_messages"], "does not fit this FMU"), r["misfit_messages"]
    assert r["misfit_left_unchanged"]
    # a state set between instantiate and initialisation is applied when initialisation ends
    assert r["preinit_set_status"] == "ok" and r["preinit_exit_status"] == "ok"
    assert r["preinit_equal"]
    assert ERROR in r["preinit_foreign_exit_status"]
    assert _said(r["preinit_foreign_messages"], "other parameter values")


def test_call_sequence_and_statuses(dist, tmp_path):
    r = run_child("sequence", dist, tmp_path / "out.json")
    for key, why in (("step_before_init", "before initialisation"), ("step_in_init_mode", "in initialisation mode"),
                     ("set_output", "measured_position is an output variable"),
                     ("set_parameter_after_init", "delay is a fixed parameter"),
                     ("unknown_reference", "value reference 10000"), ("wrong_type", "not a Real"),
                     ("step_after_terminate", "after terminate"),
                     ("huge_delay_exit", "delay: must be at most 1000000, got 2000000000"),
                     ("huge_delay_output", "initialisation failed"), ("huge_delay_step", "failed initialisation"),
                     ("huge_order_exit", "order at most 64")):
        assert ERROR in r[key], (key, r[key])
        assert _said(r[key + "_messages"], why), (key, r[key + "_messages"])
    assert r["exit"] == "ok" and r["step"] == "ok"
    assert r["delay_after_refusal"] == 0  # the refused value was not taken
    # a step that would run for ever is refused as fmi2Discard, and the instance goes on
    assert "status 2 (discard)" in r["endless_step"] and _said(r["endless_step_messages"], "at most 100000")
    assert r["after_endless_step"] == "ok"
    # scene text that once took the importer down with fmi2Fatal
    for key in ("deep_toml", "huge_integer", "binary"):
        assert ERROR in r[key + "_exit"], key
        assert _said(r[key + "_exit_messages"], "initialisation failed"), r[key + "_exit_messages"]


def test_every_fmu_replays_a_serialised_state_also_set_before_initialisation(dist, tmp_path):
    r = run_child("every", dist, tmp_path / "out.json")
    assert set(r) == {"PID", "CascadeController", "LinearController", "ComputedTorque", "Trajectory", "Encoder",
                      "RateLimiter"}
    for name, got in r.items():
        assert got["moved"], name  # the replayed stretch is not a constant
        assert got["replay_status"] == "ok" and got["replay_equal"], (name, got)
        assert got["preinit_status"] == "ok" and got["exit_status"] == "ok" and got["preinit_equal"], (name, got)


def test_fuzzed_call_sequences_never_crash_hang_or_answer_fatal(dist, tmp_path):
    """hypothesis-generated FMI call sequences on every FMU (fmu_fuzz.py), fixed seed.

    benchmarks/fmu_fuzz.py runs the long profile.
    """
    pytest.importorskip("hypothesis")
    out = tmp_path / "out.json"
    proc = subprocess.run([sys.executable, str(HERE / "fmu_fuzz.py"), str(dist), str(out), "60"],
                          capture_output=True, text=True, timeout=900, cwd=str(HERE))
    assert out.exists(), f"the fuzz child died (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    r = json.loads(out.read_text())["result"]
    assert len(r["fmus"]) == 7
    for name, got in r["fmus"].items():
        assert got["statuses"].get("ok", 0) > 0 and got["statuses"].get("error", 0) > 0, (name, got)
        assert "fatal" not in got["statuses"], (name, got)
    assert r["violations"] == []


def test_second_instantiation_after_the_extraction_folder_is_gone(dist, tmp_path):
    r = run_child("reload", dist, tmp_path / "out.json", str(tmp_path))
    assert r["init_0"] == "ok" and r["init_1"] == "ok", (r["messages_0"], r["messages_1"])
    assert r["step_0"] == "ok" and r["step_1"] == "ok"
    assert r["grubler_from_0"] and r["grubler_from_1"]  # each ran the copy of its own extraction
    assert r["same_outputs"]


def test_two_builds_of_the_package_never_share_a_process(dist, tmp_path):
    # another build: the same package with one file changed, staged and built in a process that imports it
    other = tmp_path / "other"
    script = f"""
import sys
sys.path.insert(0, {str(other / 'src')!r})
from grubler.controllers.fmu import stage_package
"""
    subprocess.run([sys.executable, "-c", f"""
import sys
from pathlib import Path
from grubler.controllers.fmu import stage_package
pkg = stage_package(Path({str(other / 'src')!r}))
(pkg / 'errors.py').write_text((pkg / 'errors.py').read_text() + '\\n# another version\\n')
"""], check=True, timeout=120)
    subprocess.run([sys.executable, "-c", script + f"""
import grubler
assert grubler.__file__.startswith({str(other)!r}), grubler.__file__
from grubler.controllers import PID
from grubler.controllers.fmu import build_controller_fmu
build_controller_fmu(PID, {str(other / 'PID.fmu')!r})
"""], check=True, timeout=300, cwd=str(tmp_path))
    r = run_child("versions", dist, tmp_path / "out.json", str(other / "PID.fmu"))
    assert r["first"] == "ok"
    assert "Failed to instantiate" in r["second"], r["second"]
    assert _said(r["second_messages"], "is already loaded in this process"), r["second_messages"]
    assert r["first_still_steps"] == "ok"
    # grubler's co-simulation runner, which imports grubler itself, says why
    r = run_child("cosim", dist, tmp_path / "cosim.json", str(other / "PID.fmu"))
    assert r["error"].startswith("pid: PID.fmu could not be instantiated: pid: "), r["error"]
    assert "is already loaded in this process" in r["error"]
