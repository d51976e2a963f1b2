"""The check that every test leaves the process as it found it (tests/process_state.py, run by conftest.py)."""

import os
import signal
import subprocess
import sys
import threading

import process_state


def test_what_a_test_leaves_behind_is_named_and_put_back(tmp_path, monkeypatch):
    monkeypatch.setattr(process_state, "GRACE", 0.1)
    before = process_state.snapshot()
    os.environ["OMP_NUM_THREADS_LEFT_BY_A_TEST"] = "1"
    os.chdir(tmp_path)
    handler = signal.signal(signal.SIGUSR1, lambda *a: None)
    release = threading.Event()
    thread = threading.Thread(target=release.wait, name="left-running")
    thread.start()
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        left = process_state.left_behind(before)
    finally:
        release.set()
        thread.join()
        child.kill()
        child.wait()
        process_state.restore(before)
    assert "os.environ['OMP_NUM_THREADS_LEFT_BY_A_TEST']: '(unset)' -> '1'" in left
    assert f"working folder: {before['working folder']!r} -> {str(tmp_path)!r}" in left
    assert any(line.startswith("signal handlers['SIGUSR1']") for line in left), left
    assert "thread 'left-running' still running" in left
    assert any(line.startswith(f"child process {child.pid} still running") for line in left), left
    assert len(left) == 5, left
    # put back: the environment, the folder, the handler
    assert "OMP_NUM_THREADS_LEFT_BY_A_TEST" not in os.environ
    assert os.getcwd() == before["working folder"]
    assert signal.getsignal(signal.SIGUSR1) is handler
    assert process_state.left_behind(before) == []


def test_only_fmpys_own_default_callbacks_take_its_logging_proxy():
    # the CI segmentation fault: a run's own callback in fmpy's one process-wide proxy, freed after the run
    import ctypes

    import fmpy.fmi2
    import fmpy.logging

    before = process_state.snapshot()
    fmpy.logging.addLoggerProxy(ctypes.byref(fmpy.fmi2.defaultCallbacks))  # fmpy's own: lives as long as fmpy
    assert process_state.left_behind(before) == []
    run_own = fmpy.fmi2.fmi2CallbackFunctions()
    run_own.logger = fmpy.fmi2.fmi2CallbackLoggerTYPE(lambda *a: None)
    logger = ctypes.cast(run_own.logger, ctypes.c_void_p).value
    fmpy.logging.addLoggerProxy(ctypes.byref(run_own))
    left = process_state.left_behind(before)
    del process_state.PROXY_TAKERS[before["fmpy logging proxy"]:]  # (this test's own, not a leak)
    assert len(left) == 1 and left[0].startswith("fmpy's process-wide logging proxy handed a callback"), left
    assert f"{__file__}:" in left[0]
    # refused: the run keeps its own logger, the proxy still calls fmpy's
    assert ctypes.cast(run_own.logger, ctypes.c_void_p).value == logger
