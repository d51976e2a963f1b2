import sys
from pathlib import Path

import pytest

# the independent reference lives beside the tests
sys.path.insert(0, str(Path(__file__).parent))


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
