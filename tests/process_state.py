"""The process-wide state a test must leave as it found it (conftest.py checks it around every test).

The whole suite runs in one process, so what one test leaves behind is what the
next test starts from: an environment variable a library set (dask's LocalCluster
writes OMP_NUM_THREADS=1 and PYTHONHASHSEED into the parent's os.environ and
never takes them back, so every later child process inherited them), a working
folder changed, a signal handler, a resource limit, numpy's error settings,
fmpy's shared default logger, a thread or a child process still running.  Such
a leak passes here and fails elsewhere, in whichever test happens to come next.

Only what is cheap to read is compared (a few dozen microseconds a test); threads
and child processes are waited for briefly, and only when new ones are there.
"""

from __future__ import annotations

import contextlib
import os
import resource
import signal
import socket
import sys
import tempfile
import threading
import time

# pytest's own, rewritten at every phase of every test
_OWN_VARIABLES = {"PYTEST_CURRENT_TEST"}
_SIGNALS = [getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGPIPE", "SIGALRM", "SIGCHLD", "SIGHUP", "SIGUSR1")
            if hasattr(signal, n)]
_LIMITS = [getattr(resource, n) for n in ("RLIMIT_AS", "RLIMIT_DATA", "RLIMIT_STACK", "RLIMIT_NOFILE", "RLIMIT_CPU",
                                          "RLIMIT_CORE", "RLIMIT_FSIZE", "RLIMIT_NPROC") if hasattr(resource, n)]
# multiprocessing's helper processes, one per process for the rest of its life (started by the first pool or
# semaphore that needs one): a singleton, not a leak
_HELPERS = ("multiprocessing.resource_tracker", "multiprocessing.forkserver")
GRACE = 10.0  # seconds a new thread or child process is given to finish before it counts as left running


# fmpy's logging library keeps ONE process-wide pointer (its static s_logger) to the Python logger that its
# native proxy calls: fmpy.fmi1/fmi2 point it at their default callbacks' logger, which lives as long as the
# process; simulate_fmu(logger=...) and instantiate_fmu(logger=...) point it at the run's own callback, freed after
# the run, and the next FMU that logs through the default callbacks calls freed memory (CI's segmentation fault
# after test_change_points). Every other caller is recorded here, with where it was called from, and refused: its
# callbacks keep their own logger (the proxy only formats the message's variadic arguments).
PROXY_TAKERS: list[str] = []


def watch_fmpy_logging_proxy() -> None:
    """Route fmpy's addLoggerProxy through a check that lets only fmpy's own default callbacks take the proxy."""
    import ctypes
    import traceback

    try:
        import fmpy.logging as fmpy_logging
    except Exception:  # noqa: BLE001 - no fmpy (or no logging library for this platform): nothing to watch
        return
    real = fmpy_logging.addLoggerProxy
    if getattr(real, "watched", False):
        return

    def add_logger_proxy(callbacks):
        # (sys.modules, not an import: fmpy.fmi1 calls this while it is being imported)
        forever = {ctypes.addressof(m.defaultCallbacks) for m in map(sys.modules.get, ("fmpy.fmi1", "fmpy.fmi2"))
                   if m is not None and hasattr(m, "defaultCallbacks")}
        if ctypes.addressof(getattr(callbacks, "_obj", callbacks)) in forever:
            return real(callbacks)
        caller = [f for f in traceback.extract_stack()[:-1] if "/fmpy/" not in f.filename]
        PROXY_TAKERS.append(f"{caller[-1].filename}:{caller[-1].lineno}" if caller else "?")
        return None

    add_logger_proxy.watched = True
    fmpy_logging.addLoggerProxy = add_logger_proxy


def children() -> dict[int, str]:
    """This process's child processes still running (not zombies), with their command lines."""
    pids: set[int] = set()
    for tid in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{tid}/children") as fh:
                pids |= {int(p) for p in fh.read().split()}
        except OSError:  # (a thread that ended meanwhile; a kernel without the children file)
            pass
    out = {}
    for p in pids:
        try:
            with open(f"/proc/{p}/stat") as fh:
                if fh.read().rpartition(")")[2].split()[0] == "Z":
                    continue
            with open(f"/proc/{p}/cmdline", "rb") as fh:
                cmd = fh.read().replace(b"\0", b" ").decode(errors="replace").strip()
            if not any(h in cmd for h in _HELPERS):
                out[p] = cmd[:160]
        except OSError:  # ended meanwhile
            pass
    return out


def snapshot() -> dict:
    """The process-wide settings a test may change only if it puts them back."""
    state = {
        "working folder": os.getcwd(),
        "os.environ": {k: v for k, v in os.environ.items() if k not in _OWN_VARIABLES},
        "signal handlers": {signal.Signals(s).name: signal.getsignal(s) for s in _SIGNALS},
        "resource limits": {str(k): resource.getrlimit(k) for k in _LIMITS},
        "tempfile.tempdir": tempfile.tempdir,
        "recursion limit": sys.getrecursionlimit(),
        "socket default timeout": socket.getdefaulttimeout(),
    }
    umask = os.umask(0o022)
    os.umask(umask)
    state["umask"] = umask
    if "numpy" in sys.modules:
        state["numpy error settings"] = sys.modules["numpy"].geterr()
    if "fmpy.fmi2" in sys.modules:
        # fmpy's default callbacks serve every FMU instantiated without callbacks of its own: a logger put there
        # must live as long as the process (see tests/test_architecture's rule on fmpy's logging proxy)
        import ctypes

        state["fmpy default logger"] = ctypes.cast(sys.modules["fmpy.fmi2"].defaultCallbacks.logger,
                                                   ctypes.c_void_p).value
    state["fmpy logging proxy"] = len(PROXY_TAKERS)
    state["threads"] = {t.ident for t in threading.enumerate()}
    state["children"] = set(children())
    return state


def left_behind(before: dict) -> list[str]:
    """What differs from ``before`` now: one line per setting, thread or child process; [] if nothing."""
    after = snapshot()
    found = []
    for key, was in before.items():
        now = after[key]
        if key == "fmpy logging proxy":
            found += [f"fmpy's process-wide logging proxy handed a callback that dies with its run, at {w} "
                      "(simulate_fmu/instantiate_fmu(logger=...)): give the logger in callbacks of the "
                      "instance's own (tests/fmi_child.recording_callbacks)" for w in PROXY_TAKERS[was:]]
        elif key == "threads":
            # (asyncio's default executor's workers belong to an event loop, Playwright's in the browser tests'
            # module fixtures, and end when it closes)
            new = [t for t in threading.enumerate() if t.ident not in was and not t.daemon
                   and not t.name.startswith("asyncio_")]
            for t in new:
                t.join(GRACE)
            found += [f"thread {t.name!r} still running" for t in new if t.is_alive()]
        elif key == "children":
            if set(children()) - was:
                time.sleep(GRACE)
            found += [f"child process {p} still running: {cmd}" for p, cmd in children().items() if p not in was]
        elif isinstance(was, dict) and isinstance(now, dict):
            found += [f"{key}[{k!r}]: {was.get(k, '(unset)')!r} -> {now.get(k, '(unset)')!r}"
                      for k in sorted(set(was) | set(now)) if was.get(k, "(unset)") != now.get(k, "(unset)")]
        elif was != now:
            found.append(f"{key}: {was!r} -> {now!r}")
    return found


@contextlib.contextmanager
def environ_kept():
    """os.environ as it was on entry, put back on the way out, for a library that writes into it and leaves it so
    (dask's LocalCluster: its nanny's settings for the workers it spawns)."""
    env = dict(os.environ)
    try:
        yield
    finally:
        put_back_environ(env)


def put_back_environ(env: dict) -> None:
    """os.environ made ``env`` again (pytest's own variables left as pytest has them)."""
    for k in [k for k in os.environ if k not in env and k not in _OWN_VARIABLES]:
        del os.environ[k]
    os.environ.update(env)


def restore(before: dict) -> None:
    """Put back what can be put back, so that the next test starts clean (the leak is still reported)."""
    put_back_environ(before["os.environ"])
    os.chdir(before["working folder"])
    for s in _SIGNALS:
        handler = before["signal handlers"][signal.Signals(s).name]
        if handler is not None and signal.getsignal(s) is not handler:  # (None: not set from Python)
            signal.signal(s, handler)
    if "numpy error settings" in before:
        sys.modules["numpy"].seterr(**before["numpy error settings"])
    tempfile.tempdir = before["tempfile.tempdir"]
