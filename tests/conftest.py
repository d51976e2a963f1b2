import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent
# the independent reference lives beside the tests
sys.path.insert(0, str(HERE))

# the helpers beside the tests (references, scenarios run in child processes, builds.py)
# are no tests: --doctest-modules would import them, and some import the optional test
# dependencies (hypothesis, libcosimpy) at the top
collect_ignore = sorted(p.name for p in HERE.glob("*.py") if not p.name.startswith("test_") and p.name != "conftest.py")


def pytest_configure(config):
    """builds.py keeps its builds in pytest's cache folder (pytest --cache-clear empties it); fmpy's logging proxy is
    watched (tests/process_state.py)."""
    import builds

    if getattr(config, "cache", None) is not None:
        builds.CACHE = config.cache.mkdir("grubler-fmus")
    import process_state

    process_state.watch_fmpy_logging_proxy()


@pytest.fixture
def app(tmp_path):
    """A grubler app served from a fresh folder on a free port of 127.0.0.1, in a thread of this process."""
    import threading

    from grubler.app.server import AppServer

    server = AppServer("127.0.0.1", 0, tmp_path)
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()


@pytest.fixture(autouse=True)
def _leaves_the_process_as_it_found_it():
    """Every test runs in the suite's one process: what it leaves behind (an environment variable, the working
    folder, a signal handler, fmpy's default logger, a thread or child process still running) is what the next
    test starts from, so it fails here, named, instead of there (tests/process_state.py)."""
    import process_state

    before = process_state.snapshot()
    yield
    left = process_state.left_behind(before)
    if left:
        process_state.restore(before)
        pytest.fail("the test left process-wide state behind:\n  " + "\n  ".join(left), pytrace=False)
