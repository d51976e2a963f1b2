"""The app's HTTP side: a local listener, its safety checks, sessions and cancellable runs.

The standard library's threaded server: each request has its own thread, so a
long simulation does not stop the page from being served, and the cancel
request that stops it gets through.  What a request may do:

- come to the address the app listens on: a ``Host`` that is not
  ``127.0.0.1:PORT`` or ``localhost:PORT`` (DNS rebinding) and an ``Origin``
  that is not the app's own (another site's page posting to it) are refused;
- read and write files only inside the folder the app was started in;
- see only its own browser session's results (a random cookie keys them);
- send at most :data:`MAX_BODY` bytes.

Every refusal is JSON ``{"error": {"field", "reason"}}``: the field the page
shows the one-line reason next to.  The physics is :mod:`grubler.app.actions`'s.
"""

from __future__ import annotations

import http.cookies
import json
import mimetypes
import re
import secrets
import socket
import sys
import threading
import time
import traceback
import webbrowser
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
MAX_SESSIONS = 64  # browser sessions remembered; the oldest is forgotten first
COOKIE = "grubler_session"


@dataclass
class Session:
    """One browser's work: its last run and the flag that cancels the run under way."""

    result: object | None = None
    cancel: threading.Event = field(default_factory=threading.Event)
    lock: threading.Lock = field(default_factory=threading.Lock)


class AppServer(ThreadingHTTPServer):
    """The app's server: where it listens, the folder it may touch, the scene it opens with."""

    daemon_threads = True

    def __init__(self, host: str = "127.0.0.1", port: int = 0, root: str | Path = ".", scene: dict | None = None):
        super().__init__((host, port), Handler)
        self.root = Path(root).resolve()
        self.start_scene = scene
        self.sessions: dict[str, Session] = {}
        self.sessions_lock = threading.Lock()
        port = self.server_address[1]
        self.allowed_hosts = {f"{n}:{port}" for n in host_names(host)}
        self.url = f"http://{'127.0.0.1' if host in ('0.0.0.0', '') else host}:{port}/"
        # the servo's FMUs, unpacked once for every re-run (a gain tuned is a re-run)
        self.unpacked = cosim.UnpackedFMUs()

    def server_close(self) -> None:
        super().server_close()
        self.unpacked.close()

    def session(self, token: str | None) -> tuple[str, Session]:
        """The session a cookie names, or a new one (with its new token)."""
        with self.sessions_lock:
            if token and token in self.sessions:
                return token, self.sessions[token]
            token = secrets.token_urlsafe(24)
            if len(self.sessions) >= MAX_SESSIONS:
                self.sessions.pop(next(iter(self.sessions)))
            self.sessions[token] = Session()
            return token, self.sessions[token]

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
        super().setup()
        # headers and body go out as two writes: without this, Nagle's algorithm holds
        # the body until the browser's delayed ACK, some 40 ms on every answer
        self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def log_message(self, fmt, *args):  # quiet: the terminal shows the URL, not every request
        pass

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

    def _session(self) -> tuple[str, Session, bool]:
        jar = http.cookies.SimpleCookie()
        try:
            jar.load(self.headers.get("Cookie", ""))
        except http.cookies.CookieError:
            pass
        given = jar[COOKIE].value if COOKIE in jar else None
        token, session = self.server.session(given)
        return token, session, token != given

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
        token, session, new = self._session()
        extra = self._cookie(token) if new else {}
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
                return self._send_json(404, {"error": {"field": "csv", "reason": "simulate first"}}, extra)
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
    def do_POST(self):
        if not self._allowed():
            return
        token, session, new = self._session()
        extra = self._cookie(token) if new else {}
        name = urlsplit(self.path).path.removeprefix("/api/")
        try:
            if self.headers.get("Content-Type", "").split(";")[0].strip() != "application/json":
                # a form post from another page cannot set this type without a CORS preflight
                raise InputError("request", "must be JSON (Content-Type: application/json)")
            size = int(self.headers.get("Content-Length") or 0)
            if size > MAX_BODY:
                raise InputError("request", f"{size} bytes is more than the app takes ({MAX_BODY})")
            try:
                body = json.loads(self.rfile.read(size) or b"{}")
            except (ValueError, UnicodeDecodeError):
                raise InputError("request", "not valid JSON") from None
            if not isinstance(body, dict):
                raise InputError("request", "must be a JSON object")
            if name == "export":  # a file, not JSON
                return self._export(session, body, extra)
            action = ACTIONS.get(name)
            if action is None:
                raise InputError("action", f"no such action: {limits.brief(name)}")
            began = time.perf_counter()
            out = action(self.server, session, body)
            text = json.dumps(out, allow_nan=False).encode()
            # the server's share of the answer (the action, and its JSON), for the page's latency figures
            timing = f"action;dur={(time.perf_counter() - began) * 1e3:.2f}"
            self._send(200, text, "application/json", {**extra, "Server-Timing": timing})
        except (GrublerError, OSError, MemoryError, ValueError) as exc:
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


# -- the actions -----------------------------------------------------------------------------------------
def _data(body: dict) -> dict:
    data = body.get("scene")
    if not isinstance(data, dict):
        raise InputError("scene", "missing: the page sends the scene as a JSON object")
    return data


def a_catalog(server, session, body):
    return {**actions.catalog(), "start": server.start_scene}


def a_preset(server, session, body):
    data = actions.preset_data(body.get("name"))
    return {"scene": data, "fields": actions.fields(data)}


def a_analyse(server, session, body):
    data = _data(body)
    out = {"scene": data, "fields": actions.fields(data)}
    try:
        out.update(actions.analyse(data, body.get("trace"), live=body.get("live") is True))
    except GrublerError as exc:
        out["error"] = actions.error_of(exc)
    return out


def a_edit(server, session, body):
    return a_analyse(server, session, {**body, "scene": actions.edit(_data(body), body.get("key"), body.get("value"))})


def a_drag(server, session, body):
    data, handle, x, y = _data(body), body.get("handle"), body.get("x"), body.get("y")
    moved = actions.drag(data, handle, x, y)
    out = {"scene": moved, "fields": actions.fields(moved)}
    try:
        out.update(actions.analyse_drag(data, moved, handle, x, y, body.get("trace"), live=body.get("live") is True))
    except GrublerError as exc:
        out["error"] = actions.error_of(exc)
    return out


def a_pick(server, session, body):
    return {"trace": actions.pick_trace(_data(body), body.get("x"), body.get("y"))}


def a_toml(server, session, body):
    return {"toml": actions.scene_toml(_data(body))}


def a_parse(server, session, body):
    data = actions.parse_scene_text(body.get("toml"))
    return {"scene": data, "fields": actions.fields(data)}


def a_files(server, session, body):
    return {"folder": str(server.root), "files": sorted(p.name for p in server.root.glob("*.toml") if p.is_file())}


def a_open(server, session, body):
    path = server.inside(body.get("file"), "file")
    text = limits.read_text(path, "file")
    data = actions.parse_scene_text(text)
    return {"scene": data, "fields": actions.fields(data)}


def a_save(server, session, body):
    name = body.get("file")
    path = server.inside(name, "file")
    if path.suffix != ".toml":
        raise InputError("file", "a scene is saved as NAME.toml")
    text = actions.scene_toml(_data(body))
    actions.parse_scene_text(text)  # what is written reads back as this scene, or nothing is written
    path.write_text(text)
    return {"saved": path.name}


def a_simulate(server, session, body):
    session.cancel.set()  # a new run replaces this browser's run under way
    with session.lock:
        session.cancel = threading.Event()
        res, view = actions.run_simulation(_data(body), body.get("t_end"), body.get("dt_out"), body.get("torque"),
                                           cancel=session.cancel, trace=body.get("trace"))
        session.result = res
    return view


def a_cancel(server, session, body):
    session.cancel.set()
    return {"cancelled": True}


def a_servo_defaults(server, session, body):
    return actions.servo_defaults()


def a_servo(server, session, body):
    # a new run replaces this browser's run under way, and the cancel action stops it
    session.cancel.set()
    with session.lock:
        session.cancel = threading.Event()
        return actions.run_servo(_data(body), body.get("servo"), server.inside("dist", "servo"), cancel=session.cancel,
                                 unpacked=server.unpacked)


def a_sizing(server, session, body):
    return actions.run_sizing(_data(body), body.get("servo"))


ACTIONS = {"catalog": a_catalog, "preset": a_preset, "analyse": a_analyse, "edit": a_edit, "drag": a_drag,
           "toml": a_toml, "parse": a_parse, "files": a_files, "open": a_open, "save": a_save,
           "simulate": a_simulate, "cancel": a_cancel, "servo_defaults": a_servo_defaults, "pick": a_pick, "servo": a_servo,
           "sizing": a_sizing}


def serve(scene: str | None = None, host: str = "127.0.0.1", port: int = 0, open_browser: bool = True,
          root: str | Path = ".", ready=None) -> None:
    """Run the app until interrupted: print its URL, open the browser unless told not to.

    Parameters
    ----------
    scene : str, optional
        Preset name or TOML file to open with (checked before the server starts).
    host, port : str, int
        Where to listen: 127.0.0.1 unless told otherwise; port 0 picks a free one.
    ready : callable, optional
        Called with the server once it listens (tests use it).
    """
    start = None
    if scene:
        if scene in actions.preset_names():
            start = actions.preset_data(scene)
        else:
            path = Path(scene)
            start = actions.parse_scene_text(limits.read_text(path, "scene"))
    server = AppServer(host, port, root, start)
    print(f"grubler app: {server.url}  (Ctrl-C stops it)", flush=True)
    if ready:
        ready(server)
    if open_browser:
        threading.Thread(target=webbrowser.open, args=(server.url,), daemon=True).start()
    try:
        server.serve_forever(poll_interval=0.2)
    finally:
        server.server_close()
