"""The app's HTTP side: a local listener, its safety checks, sessions and cancellable runs.

The standard library's threaded server: each request has its own thread, so a
long simulation does not stop the page from being served, and the cancel
request that stops it gets through.  What a request may do:

- come to the address the app listens on: a ``Host`` that is not
  ``127.0.0.1:PORT`` or ``localhost:PORT`` (DNS rebinding) and an ``Origin``
  that is not the app's own (another site's page posting to it) are refused;
- read and write files only inside the folder the app was started in;
- see only its own browser session's results (a random cookie keys them);
- send at most :data:`MAX_BODY` bytes, with a ``Content-Length`` that says how
  many, within :data:`CLIENT_TIMEOUT` seconds;
- leave at any time: a client that closes its connection before its answer
  (a tab closed during a run, a fetch aborted, a timeout) cancels its run, and
  the server carries on (the app ignores SIGPIPE: a write to a closed socket
  is an error of that request, not the end of the process).

Every refusal is JSON ``{"error": {"field", "reason"}}``: the field the page
shows the one-line reason next to.  The physics is :mod:`grubler.app.actions`'s.
"""

from __future__ import annotations

import http.cookies
import json
import mimetypes
import re
import secrets
import selectors
import signal
import socket
import sys
import threading
import time
import traceback
import webbrowser
from collections import OrderedDict
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from grubler.system import cosim
from grubler import limits
from grubler.app import actions
from grubler.errors import GrublerError, InputError

MAX_BODY = 2 * 1024**2  # a scene is a few kilobytes
MAX_SESSIONS = 64  # browser sessions remembered; the idle one used least recently is forgotten first
CLIENT_TIMEOUT = 30.0  # s a client may take to send a request (or leave a kept-alive connection idle)
MAX_CONNECTIONS = 128  # open at once (a browser opens six); one more is closed at once
COOKIE = "grubler_session"
# a client that left: what writing to it, or reading from it, raises
GONE = (ConnectionError, TimeoutError)
MAX_DEPTH = 32  # JSON nesting a request may have: a scene is some five levels deep
WATCH_POLL = 0.1  # s between looks at a running request's connection


class BadRequest(InputError):
    """A request the page never sends (its framing, its JSON): refused with an HTTP error status."""

    def __init__(self, status: int, field: str, reason: str):
        super().__init__(field, reason)
        self.status = status


class AnyOf:
    """Set once any of its flags is: a run stops for the page's Cancel, a newer run, or its client gone."""

    def __init__(self, *flags):
        self.flags = [f for f in flags if f is not None]

    def is_set(self) -> bool:
        return any(f.is_set() for f in self.flags)


class ClientWatch:
    """Whether the client of a request under way has left: its connection read to its end, or reset.

    While the action runs, nothing reads the request's socket: a thread looks
    at it every :data:`WATCH_POLL` s (a peek, which consumes nothing) and sets
    ``gone`` at its end of file.  An HTTP client does not half-close a
    connection it awaits an answer on; a browser that closes the tab, a fetch
    aborted and ``curl -m`` all close it.
    """

    def __init__(self, sock: socket.socket):
        self.sock = sock
        self.gone = threading.Event()
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="grubler-app-client", daemon=True)

    def __enter__(self) -> "ClientWatch":
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._done.set()
        self._thread.join()

    def _watch(self) -> None:
        with selectors.DefaultSelector() as sel:
            sel.register(self.sock, selectors.EVENT_READ)
            while not self._done.is_set():
                if not sel.select(WATCH_POLL):
                    continue
                try:
                    data = self.sock.recv(1, socket.MSG_PEEK)
                except (BlockingIOError, InterruptedError, TimeoutError):
                    continue
                except OSError:  # reset
                    data = b""
                if not data:
                    self.gone.set()
                    return
                self._done.wait(WATCH_POLL)  # bytes of a next request: the client is there


@dataclass
class Session:
    """One browser's work: its last run and the flag that cancels the run under way (held by its lock)."""

    result: object | None = None
    cancel: threading.Event = field(default_factory=threading.Event)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def idle(self) -> bool:
        return not self.lock.locked()


class AppServer(ThreadingHTTPServer):
    """The app's server: where it listens, the folder it may touch, the scene it opens with."""

    daemon_threads = True

    def __init__(self, host: str = "127.0.0.1", port: int = 0, root: str | Path = ".", scene: dict | None = None):
        super().__init__((host, port), Handler)
        self.root = Path(root).resolve()
        self.start_scene = scene
        self.start_spatial = None  # a spatial scene's TOML the app was started with: the 3D view opens it
        self.sessions: OrderedDict[str, Session] = OrderedDict()  # least recently used first
        self.max_sessions = MAX_SESSIONS
        self.evicted: OrderedDict[str, None] = OrderedDict()  # tokens forgotten for room, to tell their page
        self.sessions_lock = threading.Lock()
        port = self.server_address[1]
        self.allowed_hosts = {f"{n}:{port}" for n in host_names(host)}
        self.url = f"http://{'127.0.0.1' if host in ('0.0.0.0', '') else host}:{port}/"
        # the servo's FMUs, unpacked once for every re-run (a gain tuned is a re-run)
        self.unpacked = cosim.UnpackedFMUs()
        # a cylinder's scene runs a mechanism FMU of its own: compiled once per scene, kept until the app stops
        self.builds = limits.temp_dir("grubler-app-builds-")

        self.client_timeout = CLIENT_TIMEOUT
        self.connections = threading.BoundedSemaphore(MAX_CONNECTIONS)

    def server_close(self) -> None:
        super().server_close()
        self.unpacked.close()
        limits.remove_temp_dir(self.builds)

    def process_request(self, request, client_address):
        # a thread per connection, up to MAX_CONNECTIONS: a client that opens thousands is not given thousands
        if not self.connections.acquire(blocking=False):
            self.shutdown_request(request)
            return
        try:
            super().process_request(request, client_address)
        except BaseException:
            self.connections.release()
            raise

    def process_request_thread(self, request, client_address):
        try:
            super().process_request_thread(request, client_address)
        finally:
            self.connections.release()

    def handle_error(self, request, client_address):
        # a client that left is its own business; anything else is a bug, with its traceback
        if not isinstance(sys.exc_info()[1], GONE):
            super().handle_error(request, client_address)

    def session(self, token: str | None) -> tuple[str, Session, str | None]:
        """The session a cookie names, or a new one with its new token.

        The third item says why a cookie given named no session: ``'evicted'``
        (forgotten for room) or ``'unknown'`` (the app restarted, or a made-up
        token); None when none was given or it was found.
        """
        with self.sessions_lock:
            if token and token in self.sessions:
                self.sessions.move_to_end(token)
                return token, self.sessions[token], None
            lost = None if not token else ("evicted" if token in self.evicted else "unknown")
            while len(self.sessions) >= self.max_sessions:
                self._evict()
            token = secrets.token_urlsafe(24)
            self.sessions[token] = Session()
            return token, self.sessions[token], lost

    def _evict(self) -> None:
        # the one used least recently among those with nothing to lose (no run kept, none under way),
        # else among the idle ones, else the least recently used: a burst of new sessions pushes out
        # sessions like its own before a page's results
        order = list(self.sessions.items())
        victim = next((t for t, s in order if s.result is None and s.idle()), None) or \
            next((t for t, s in order if s.idle()), None) or order[0][0]
        self.sessions.pop(victim)
        self.evicted[victim] = None
        while len(self.evicted) > 16 * self.max_sessions:
            self.evicted.popitem(last=False)

    def inside(self, name, field: str = "file") -> Path:
        """A file name from the page as a path inside the app's folder, or an InputError."""
        if not isinstance(name, str) or not name.strip() or "\x00" in name:
            raise InputError(field, "give a file name")
        path = (self.root / name).resolve()
        if path != self.root and self.root not in path.parents:
            raise InputError(field, f"{limits.brief(name)} is outside the folder the app was started in "
                                    f"({self.root})")
        return path


def host_names(host: str) -> set[str]:
    """The names a browser may call this server by (a DNS name rebound to it is none of them)."""
    loopback = {"127.0.0.1", "localhost"}
    if host in loopback:
        return loopback
    if host in ("0.0.0.0", ""):  # every interface: this machine's own names and addresses
        names = loopback | {socket.gethostname(), socket.getfqdn()}
        try:
            names |= set(socket.gethostbyname_ex(socket.gethostname())[2])
        except OSError:
            pass
        return names
    return {host}


def _static(name: str) -> bytes | None:
    folder = resources.files("grubler.app") / "static"
    if not re.fullmatch(r"[a-z0-9_-]+\.(html|js|css|png|svg)", name):
        return None
    f = folder / name
    return f.read_bytes() if f.is_file() else None


class Handler(BaseHTTPRequestHandler):
    server: AppServer
    server_version = "grubler-app"
    protocol_version = "HTTP/1.1"

    def setup(self):
        # every read and write of this connection gives up after this long: a client that sends a
        # request slowly (or leaves it half sent) holds its thread no longer
        self.timeout = self.server.client_timeout
        super().setup()
        # headers and body go out as two writes: without this, Nagle's algorithm holds
        # the body until the browser's delayed ACK, some 40 ms on every answer
        self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def log_message(self, fmt, *args):  # quiet: the terminal shows the URL, not every request
        pass

    def handle(self):
        try:
            super().handle()
        except GONE:  # the client left, or was too slow: its connection ends here, the server carries on
            self.close_connection = True

    # -- the checks every request passes ---------------------------------------------------
    def _allowed(self) -> bool:
        host = self.headers.get("Host", "")
        if host not in self.server.allowed_hosts:
            self._send_json(403, {"error": {"field": "Host", "reason": f"{limits.brief(host)} is not this app's "
                                                                      "address (DNS rebinding?)"}})
            return False
        origin = self.headers.get("Origin")
        if origin is not None and origin not in {f"http://{h}" for h in self.server.allowed_hosts}:
            self._send_json(403, {"error": {"field": "Origin", "reason": f"requests from {limits.brief(origin)} "
                                                                        "are refused: only the app's own page "
                                                                        "may call it"}})
            return False
        return True

    def _session(self) -> tuple[Session, dict, str | None]:
        """This browser's session, the headers that go with the answer, and why its cookie named none (if so).

        A page whose session was forgotten is told so on its next answer
        (``X-Grubler-Session: evicted`` or ``unknown``): the page says its
        last run is gone from the server, rather than an export failing later.
        """
        jar = http.cookies.SimpleCookie()
        try:
            jar.load(self.headers.get("Cookie", ""))
        except http.cookies.CookieError:
            pass
        given = jar[COOKIE].value if COOKIE in jar else None
        token, session, lost = self.server.session(given)
        extra = self._cookie(token) if token != given else {}
        if lost:
            extra["X-Grubler-Session"] = lost
        return session, extra, lost

    # -- replies ------------------------------------------------------------------------------
    def _send(self, code: int, body: bytes, ctype: str, extra: dict | None = None):
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("X-Frame-Options", "DENY")
        self.send_header("Content-Security-Policy",
                         "default-src 'self'; img-src 'self' data: blob:; style-src 'self'; frame-ancestors 'none'")
        for k, v in (extra or {}).items():
            self.send_header(k, v)
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _send_json(self, code: int, obj, extra: dict | None = None):
        self._send(code, json.dumps(obj, allow_nan=False).encode(), "application/json", extra)

    def _cookie(self, token: str) -> dict:
        return {"Set-Cookie": f"{COOKIE}={token}; HttpOnly; SameSite=Strict; Path=/"}

    # -- GET: the page, its files, downloads ----------------------------------------------------------
    def do_GET(self):
        if not self._allowed():
            return
        session, extra, lost = self._session()
        url = urlsplit(self.path)
        if url.path == "/":
            return self._send(200, _static("index.html"), "text/html; charset=utf-8", extra)
        if url.path.startswith("/static/"):
            body = _static(url.path[len("/static/"):])
            if body is None:
                return self._send_json(404, {"error": {"field": "path", "reason": "no such file"}})
            ctype = mimetypes.guess_type(url.path)[0] or "application/octet-stream"
            return self._send(200, body, ctype + ("; charset=utf-8" if ctype.startswith("text/") or
                                                  ctype.endswith("javascript") else ""), extra)
        if url.path == "/api/result.csv":
            if session.result is None:
                return self._send_json(404, {"error": {"field": "csv", "reason": forgotten(lost) or "simulate first"}},
                                       extra)
            folder = limits.temp_dir("grubler-app-")
            try:
                path = folder / "run.csv"
                actions.result_csv(session.result, path)
                body = path.read_bytes()
            finally:
                limits.remove_temp_dir(folder)
            name = re.sub(r"[^A-Za-z0-9_.-]", "_", parse_qs(url.query).get("name", ["run"])[0])[:80] or "run"
            return self._send(200, body, "text/csv",
                              {**extra, "Content-Disposition": f'attachment; filename="{name}.csv"'})
        self._send_json(404, {"error": {"field": "path", "reason": "no such page"}}, extra)

    do_HEAD = do_GET

    # -- POST: one JSON action each ---------------------------------------------------------------------
    def _body(self) -> dict:
        """The request's JSON object, or a :class:`BadRequest` (its connection is then closed)."""
        if self.headers.get("Content-Type", "").split(";")[0].strip() != "application/json":
            # a form post from another page cannot set this type without a CORS preflight
            raise BadRequest(400, "request", "must be JSON (Content-Type: application/json)")
        if self.headers.get("Transfer-Encoding"):
            raise BadRequest(411, "Content-Length", "give the body's length in bytes (a chunked body is not taken)")
        given = self.headers.get_all("Content-Length") or ["0"]
        if len(given) > 1 or not re.fullmatch(r"\d{1,15}", given[0].strip()):
            raise BadRequest(400, "Content-Length", f"must be one count of bytes, got {limits.brief(', '.join(given))}")
        size = int(given[0])
        if size > MAX_BODY:
            raise BadRequest(413, "Content-Length", f"{size} bytes is more than the app takes ({MAX_BODY})")
        try:
            raw = self.rfile.read(size)
        except TimeoutError:
            raise BadRequest(408, "request", f"the body did not arrive within {self.server.client_timeout:g} s "
                                             f"({size} bytes were announced)") from None
        if len(raw) < size:  # the connection ended before the body did: nobody waits for an answer
            raise ConnectionAbortedError(f"{len(raw)} of {size} bytes")
        try:
            body = json.loads(raw or b"{}")
        except RecursionError:
            raise BadRequest(400, "request", f"nested too deep to read: the app takes at most {MAX_DEPTH} "
                                             "levels") from None
        except (ValueError, UnicodeDecodeError):
            raise BadRequest(400, "request", "not valid JSON") from None
        if not isinstance(body, dict):
            raise BadRequest(400, "request", "must be a JSON object")
        for key, value in body.items():
            if _depth(value) > MAX_DEPTH:
                raise BadRequest(400, key, f"nested more than {MAX_DEPTH} levels deep: no scene or setting is")
        return body

    def do_POST(self):
        if not self._allowed():
            return
        session, extra, _ = self._session()
        name = urlsplit(self.path).path.removeprefix("/api/")
        watch = None
        try:
            body = self._body()
            if name == "export":  # a file, not JSON
                return self._export(session, body, extra)
            action = ACTIONS.get(name)
            if action is None:
                raise InputError("action", f"no such action: {limits.brief(name)}")
            began = time.perf_counter()
            if action in RUNS:  # a run as long as it takes: cancelled if its client leaves meanwhile
                with ClientWatch(self.connection) as watch:
                    out = action(self.server, session, body, watch.gone)
            else:
                out = action(self.server, session, body)
            text = json.dumps(out, allow_nan=False).encode()
            # the server's share of the answer (the action, and its JSON), for the page's latency figures
            timing = f"action;dur={(time.perf_counter() - began) * 1e3:.2f}"
            self._send(200, text, "application/json", {**extra, "Server-Timing": timing})
        except GONE:
            raise
        except BadRequest as exc:
            self.close_connection = True  # what follows on this connection cannot be trusted to be a request
            self._send_json(exc.status, {"error": actions.error_of(exc)}, extra)
        except (GrublerError, OSError, MemoryError, ValueError) as exc:
            if watch is not None and watch.gone.is_set():  # nobody to answer: say in the terminal what was stopped
                print(f"grubler app: the page of a {name} run left before its answer; "
                      f"{getattr(exc, 'reason', exc)}", file=sys.stderr, flush=True)
                self.close_connection = True
                return
            if isinstance(exc, MemoryError):
                exc = GrublerError("out of memory: make the run smaller")
            elif not isinstance(exc, GrublerError):
                exc = InputError("request", str(exc))
            # a refusal is the app's answer, not a failed request: 200, so that the
            # browser logs no error for what the page shows next to its field
            self._send_json(200, {"error": actions.error_of(exc)}, extra)
        except Exception as exc:  # a bug: the page gets one line, the terminal the traceback
            traceback.print_exc(file=sys.stderr)
            self._send_json(500, {"error": actions.error_of(exc)}, extra)

    def _export(self, session: Session, body: dict, extra: dict):
        folder = limits.temp_dir("grubler-app-")
        try:
            kind = body.get("kind")
            fmu_dir = self.server.inside("dist", "servo") if kind == "ssp" else None
            path = actions.export_file(kind, _data(body), folder, session.result, body.get("servo"), fmu_dir)
            data = path.read_bytes()
        finally:
            limits.remove_temp_dir(folder)
        ctype = {".pdf": "application/pdf"}.get(path.suffix, "application/octet-stream")
        self._send(200, data, ctype, {**extra, "Content-Disposition": f'attachment; filename="{path.name}"'})


def forgotten(lost: str | None) -> str | None:
    """Why a page's session is gone, in its words (None when it is not)."""
    if lost == "evicted":
        return (f"the app forgot this page's session to make room (it keeps the {MAX_SESSIONS} used most "
                "recently), and its last run with it: simulate again")
    if lost == "unknown":
        return "the app does not know this page's session (was it restarted?): simulate again"
    return None


def _depth(value) -> int:
    """How deep a parsed JSON value nests (a number: 0), counted without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, (dict, list)):
            deepest = max(deepest, d)
            if d > MAX_DEPTH:
                break
            stack.extend((x, d + 1) for x in (v.values() if isinstance(v, dict) else v))
    return deepest


# -- the actions -----------------------------------------------------------------------------------------
def _data(body: dict) -> dict:
    data = body.get("scene")
    if not isinstance(data, dict):
        raise InputError("scene", "missing: the page sends the scene as a JSON object")
    return data


def a_catalog(server, session, body):
    return {**actions.catalog(), "start": server.start_scene, "coil": actions.coil_shape()}


def _form(data: dict) -> dict:
    """A scene as the page shows it: its data, and the form of its fields."""
    data = actions.echoed(data)
    return {"scene": data, "fields": actions.fields(data)}


def a_preset(server, session, body):
    return _form(actions.preset_data(body.get("name")))


def a_analyse(server, session, body):
    data = _data(body)
    out = _form(data)
    try:
        out.update(actions.analyse(data, body.get("trace"), live=body.get("live") is True,
                                   kinematics=body.get("kinematics") is True))
    except GrublerError as exc:
        out["error"] = actions.error_of(exc)
    return out


def a_edit(server, session, body):
    return a_analyse(server, session, {**body, "scene": actions.edit(_data(body), body.get("key"), body.get("value"))})


def a_add_element(server, session, body):
    return a_analyse(server, session, {**body, "scene": actions.add_element(_data(body), body.get("kind"))})


def a_remove_element(server, session, body):
    return a_analyse(server, session, {**body, "scene": actions.remove_element(_data(body), body.get("element"))})


def a_drag(server, session, body):
    data, handle, x, y = _data(body), body.get("handle"), body.get("x"), body.get("y")
    moved = actions.drag(data, handle, x, y)
    out = _form(moved)
    try:
        out.update(actions.analyse_drag(data, moved, handle, x, y, body.get("trace"), live=body.get("live") is True,
                                        kinematics=body.get("kinematics") is True, drawn=body.get("drawn")))
    except GrublerError as exc:
        out["error"] = actions.error_of(exc)
    return out


def a_instant(server, session, body):
    # the analysis at a run's instant: the session's run, read under its lock (a new run may be replacing it)
    with session.lock:
        return actions.run_instant(_data(body), session.result, body.get("at"), body.get("trace"))


def a_pick(server, session, body):
    return {"trace": actions.pick_trace(_data(body), body.get("x"), body.get("y"))}


def a_toml(server, session, body):
    return {"toml": actions.scene_toml(_data(body))}


def _opened(text: str, name: str = "") -> dict:
    """A file's TOML opened on the planar page: a planar scene's form, or a spatial scene (``dimension = 3``),
    checked as the CLI reads it, to open in the 3D view."""
    from grubler.app.spatial_view import spatial_text
    from grubler.mechanism.spatial_scene import is_spatial

    if isinstance(text, str) and is_spatial(text if "\n" in text else text + "\n"):
        scene, text = spatial_text(text)
        return {"spatial": {"toml": text, "name": scene.name or name}}
    return _form(actions.parse_scene_text(text))


def a_parse(server, session, body):
    return _opened(body.get("toml"))


def a_files(server, session, body):
    return {"folder": str(server.root), "files": sorted(p.name for p in server.root.glob("*.toml") if p.is_file())}


def a_open(server, session, body):
    path = server.inside(body.get("file"), "file")
    text = limits.read_text(path, "file")
    return _opened(text, path.stem)


def a_save(server, session, body):
    name = body.get("file")
    path = server.inside(name, "file")
    if path.suffix != ".toml":
        raise InputError("file", "a scene is saved as NAME.toml")
    text = actions.scene_toml(_data(body))
    actions.parse_scene_text(text)  # what is written reads back as this scene, or nothing is written
    path.write_text(text)
    return {"saved": path.name}


def a_simulate(server, session, body, gone=None):
    session.cancel.set()  # a new run replaces this browser's run under way
    with session.lock:
        session.cancel = threading.Event()
        res, view = actions.run_simulation(_data(body), body.get("t_end"), body.get("dt_out"), body.get("torque"),
                                           cancel=AnyOf(session.cancel, gone), trace=body.get("trace"),
                                           actuator_force=body.get("actuator_force"))
        session.result = res
    return view


def a_cancel(server, session, body):
    session.cancel.set()
    return {"cancelled": True}


def a_servo_defaults(server, session, body):
    """The motor servo's defaults; with a scene, its cylinder servo's too (None: it has no actuator)."""
    out = actions.servo_defaults()
    if "scene" in body:
        out["cylinder"] = actions.cylinder_servo_defaults(_data(body))
    return out


def a_servo(server, session, body, gone=None):
    # a new run replaces this browser's run under way, and the cancel action stops it
    session.cancel.set()
    with session.lock:
        session.cancel = threading.Event()
        return actions.run_servo(_data(body), body.get("servo"), server.inside("dist", "servo"),
                                 cancel=AnyOf(session.cancel, gone), unpacked=server.unpacked,
                                 build_dir=server.builds, trace=body.get("trace"))


def a_sizing(server, session, body):
    return actions.run_sizing(_data(body), body.get("servo"))


ACTIONS = {"catalog": a_catalog, "preset": a_preset, "analyse": a_analyse, "edit": a_edit, "drag": a_drag,
           "toml": a_toml, "parse": a_parse, "files": a_files, "open": a_open, "save": a_save,
           "simulate": a_simulate, "cancel": a_cancel, "servo_defaults": a_servo_defaults, "pick": a_pick, "servo": a_servo,
           "sizing": a_sizing, "instant": a_instant, "add_element": a_add_element,
           "remove_element": a_remove_element}
RUNS = {a_simulate, a_servo}  # the actions whose run stops when their client leaves (they take its flag)


def a_spatial_catalog(server, session, body):
    from grubler.app.spatial_view import spatial_catalog

    return {**spatial_catalog(), "start": server.start_spatial}


def a_spatial(server, session, body):
    from grubler.app.spatial_view import spatial_view

    return spatial_view(body)


# the 3D view of the spatial presets (static/view3d.html, view3d.js)
ACTIONS.update({"spatial_catalog": a_spatial_catalog, "spatial": a_spatial})


def serve(scene: str | None = None, host: str = "127.0.0.1", port: int = 0, open_browser: bool = True,
          root: str | Path = ".", ready=None) -> None:
    """Run the app until interrupted: print its URL, open the browser unless told not to.

    Parameters
    ----------
    scene : str, optional
        Preset name or TOML file to open with (checked before the server starts); a spatial one (a spatial
        preset, or a file that says ``dimension = 3``) opens in the 3D view, whose URL is printed.
    host, port : str, int
        Where to listen: 127.0.0.1 unless told otherwise; port 0 picks a free one.
    ready : callable, optional
        Called with the server once it listens (tests use it).
    """
    from grubler.app.spatial_view import spatial_text
    from grubler.mechanism.spatial_scene import is_spatial, load_spatial_scene

    start, spatial = None, None
    if scene:
        if scene in actions.preset_names():
            start = actions.preset_data(scene)
        elif is_spatial(scene):  # a spatial preset or a file that says dimension = 3: the 3D view opens it
            text = limits.read_text(Path(scene), "scene") if Path(scene).is_file() else None
            loaded = spatial_text(text)[0] if text is not None else load_spatial_scene(scene)
            spatial = {"toml": text, "name": loaded.name or Path(scene).stem} if text else {"name": scene}
        else:
            path = Path(scene)
            start = actions.parse_scene_text(limits.read_text(path, "scene"))
    server = AppServer(host, port, root, start)
    server.start_spatial = spatial
    url = server.url + "static/view3d.html" if spatial else server.url
    # the CLI lets SIGPIPE end `grubler ... | head` quietly; here it would end the app when a client
    # leaves before its answer: ignored, such a write raises BrokenPipeError in that request's thread
    piped = hasattr(signal, "SIGPIPE") and threading.current_thread() is threading.main_thread()
    before = signal.signal(signal.SIGPIPE, signal.SIG_IGN) if piped else None
    try:
        print(f"grubler app: {url}  (Ctrl-C stops it)", flush=True)
        if ready:
            ready(server)
        if open_browser:
            threading.Thread(target=webbrowser.open, args=(url,), daemon=True).start()
        server.serve_forever(poll_interval=0.2)
    finally:
        server.server_close()
        if piped:
            signal.signal(signal.SIGPIPE, before)
