"""Parameter sweeps: one function over many points, on this machine or a Dask cluster.

The same call runs points in local processes (all cores by default) or on a
``dask.distributed`` cluster when given a scheduler address or client.  Every
finished point is appended to a journal beside the output table as it arrives,
so an interrupted sweep resumes where it stopped; a point that raises is a row
with its error, not the end of the sweep.

The function a sweep runs takes a point's values as keywords and returns a dict
of metrics.  It must be importable by the workers (a module-level function), as
with any process pool.

Examples
--------
>>> grid(a=[1, 2], b=[10.0])
[{'a': 1, 'b': 10.0}, {'a': 2, 'b': 10.0}]
>>> table = run_sweep(_square, grid(x=[1.0, 2.0, -1.0]), workers=1, progress=False)
>>> [(r["x"], r.get("y"), r["status"]) for r in table.rows]
[(1.0, 1.0, 'ok'), (2.0, 4.0, 'ok'), (-1.0, None, 'failed')]
>>> table.rows[2]["error"]
'ValueError: x must be >= 0, got -1.0'
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
import re
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

from grubler.errors import GrublerError, InputError
from grubler.limits import MAX_POINTS, MAX_TABLE_BYTES, brief, check_count, clip, decode_text, number, open_output, read_bytes

STATUS_OK = "ok"
STATUS_FAILED = "failed"
META = ("status", "error", "seconds", "key")


def grid(**axes: Iterable) -> list[dict]:
    """Every combination of the axes' values, the first axis varying slowest.

    Examples
    --------
    >>> from grubler.studies.sweep import grid
    >>> grid(a=[1, 2], b=["x", "y"])
    [{'a': 1, 'b': 'x'}, {'a': 1, 'b': 'y'}, {'a': 2, 'b': 'x'}, {'a': 2, 'b': 'y'}]
    """
    names = list(axes)
    values = [list(v) for v in axes.values()]
    check_count(math.prod(len(v) for v in values), MAX_POINTS, "points in the grid", "--set")
    return [dict(zip(names, combo)) for combo in itertools.product(*values)]


def point_key(values: dict) -> str:
    """A stable identity of a point's values (what resuming matches on).

    Examples
    --------
    >>> point_key({"b": 2, "a": 1.0}) == point_key({"a": 1.0, "b": 2})
    True
    """
    text = json.dumps({k: values[k] for k in sorted(values)}, sort_keys=True, default=repr)
    return hashlib.sha1(text.encode()).hexdigest()[:16]


def evaluate_point(func: Callable[..., dict], values: dict) -> dict:
    """Run one point; any exception becomes a failed row with its message.

    Examples
    --------
    >>> from grubler.studies.sweep import evaluate_point, scene_point
    >>> row = evaluate_point(scene_point, {"scene": "thesis-fourbar", "t_end": 0.1, "link2.a": -1.0})
    >>> row["status"], row["error"]                      # a failing point is a row, not an exception
    ('failed', 'SceneError: link2.a: length must be >= 0, got -1.0')
    """
    t0 = time.perf_counter()
    row = dict(values)
    try:
        metrics = func(**values)
        if not isinstance(metrics, dict):
            raise TypeError(f"the sweep function must return a dict of metrics, got {type(metrics).__name__}")
        clash = set(metrics) & (set(values) | set(META))
        if clash:
            raise ValueError(f"metric names clash with inputs or bookkeeping: {', '.join(sorted(clash))}")
        row.update(metrics)
        row["status"], row["error"] = STATUS_OK, ""
    except Exception as exc:  # noqa: BLE001 - a failed point is data, not the end of the sweep
        row["status"] = STATUS_FAILED
        row["error"] = f"{type(exc).__name__}: {exc}" if str(exc) else traceback.format_exc(limit=1).strip()
    row["seconds"] = time.perf_counter() - t0
    row["key"] = point_key(values)
    return row


@dataclass
class SweepTable:
    """The sweep's rows (inputs, metrics, status, error, seconds, key) in point order.

    Examples
    --------
    >>> import functools
    >>> from grubler.studies.sweep import grid, run_sweep, scene_point
    >>> table = run_sweep(functools.partial(scene_point, "thesis-fourbar", t_end=0.1),
    ...                   grid(**{"link2.m": [1.0, 2.0]}), workers=1, progress=False)
    >>> table.metrics[:2], len(table.column("final_drive_angle")), table.failed
    (['final_drive_angle', 'peak_drive_speed'], 2, [])
    """

    rows: list[dict]
    inputs: list[str]
    wall_time: float = 0.0
    resumed: int = 0
    workers: str = ""
    metrics: list[str] = field(default_factory=list)
    units: dict[str, str] = field(default_factory=dict)  # of inputs and metrics, for the CSV's headings

    @property
    def columns(self) -> list[str]:
        return self.inputs + self.metrics + list(META)

    @property
    def failed(self) -> list[dict]:
        return [r for r in self.rows if r["status"] == STATUS_FAILED]

    def column(self, name: str) -> list:
        return [r.get(name) for r in self.rows]

    def write(self, path: str | Path) -> Path:
        """CSV, or Parquet for a ``.parquet`` path (needs pyarrow)."""
        path = Path(path)
        if path.suffix == ".parquet":
            try:
                import pyarrow as pa
                import pyarrow.parquet as pq
            except ImportError:
                raise GrublerError(f"{path}: writing Parquet needs pyarrow (pip install pyarrow), "
                                   "or write a .csv") from None
            pq.write_table(pa.table({c: [r.get(c) for r in self.rows] for c in self.columns}), path)
            return path
        from grubler.records import column_heading

        units = {"seconds": "s", **self.units}
        with open_output(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([column_heading(c, units.get(c, "")) for c in self.columns])
            for r in self.rows:
                w.writerow([_plain(r.get(c)) for c in self.columns])
        return path


def _plain(v):
    return repr(v) if isinstance(v, float) and math.isfinite(v) else v


def _journal(out: Path) -> Path:
    return out.with_name(out.name + ".journal.jsonl")


def signature(func: Callable) -> str:
    """What a journal is of: the function, the constants bound to it, and the content of
    the files those constants name (an edited scene file is another sweep).

    Examples
    --------
    >>> import functools
    >>> signature(functools.partial(scene_point, "thesis-fourbar", t_end=1.0)).split("sweep.")[-1]
    "scene_point('thesis-fourbar',) {'t_end': 1.0}"
    """
    import functools

    args, files = "", []
    while isinstance(func, functools.partial):
        args = f"{func.args!r} {dict(sorted(func.keywords.items()))!r}" + args
        files += [v for v in list(func.args) + list(func.keywords.values()) if isinstance(v, (str, Path))]
        func = func.func
    digests = ""
    for f in files:
        if "\n" not in str(f) and len(str(f)) < 4096 and Path(f).is_file():
            digests += f" {Path(f).name}#sha256:{hashlib.sha256(Path(f).read_bytes()).hexdigest()[:16]}"
    return f"{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', repr(func))}{args}{digests}"


def _read_done(out: Path | None, sig: str, retry_failed: bool) -> dict[str, dict]:
    """Rows finished by an earlier run of the same sweep: its journal."""
    if out is None:
        return {}
    done = {}
    journal = _journal(out)
    if journal.is_file():
        lines = decode_text(read_bytes(journal, "--out", MAX_TABLE_BYTES), "--out", str(journal)).splitlines()
        if not lines:  # killed before its header reached the disk: nothing was finished
            return done
        try:
            head = json.loads(lines[0])
        except json.JSONDecodeError:
            head = None
        if not isinstance(head, dict) or "sweep" not in head:
            raise GrublerError(f"{journal}: not a sweep journal (its first line is no header); "
                               "move it away, or start afresh with --no-resume (which keeps it as a backup)")
        if head.get("sweep") != sig:
            raise GrublerError(f"{out}: its journal is of another sweep ({clip(str(head.get('sweep')), 200)}), "
                               f"not {clip(sig, 200)}; start afresh (resume=False, --no-resume, which keeps the "
                               "old journal as a backup) or write elsewhere")
        for line in lines[1:]:
            try:
                row = json.loads(line)
            except json.JSONDecodeError:  # a line cut by the interruption
                continue
            if not isinstance(row, dict) or not isinstance(row.get("key"), str):
                continue
            if retry_failed and row.get("status") == STATUS_FAILED:
                continue
            done[row["key"]] = row
    return done


def _drop_torn_line(journal: Path) -> None:
    """Cut off a last line the writer did not finish (no newline after it).

    A sweep killed while writing a row leaves it torn; a resumed run appending
    after it would glue its first row onto the fragment, and both points would
    be lost to the journal.  Without the fragment, its point is computed again
    and the next row starts on a line of its own.
    """
    if not journal.is_file():
        return
    with open(journal, "rb+") as fh:
        size = end = fh.seek(0, os.SEEK_END)
        while end > 0:  # back from the end, a block at a time, to the last newline
            start = max(0, end - 65536)
            fh.seek(start)
            cut = fh.read(end - start).rfind(b"\n")
            if cut >= 0:
                end = start + cut + 1
                break
            end = start
        if end < size:
            fh.truncate(end)


def _set_aside(journal: Path) -> Path:
    """Move an old journal to the first free ``.N`` backup name: never delete finished points."""
    k = 1
    while journal.with_name(f"{journal.name}.{k}").exists():
        k += 1
    backup = journal.with_name(f"{journal.name}.{k}")
    journal.rename(backup)
    return backup


class _Progress:
    def __init__(self, total: int, enabled: bool):
        self.total, self.enabled = total, enabled
        self.done = self.failed = 0
        self.t0 = time.perf_counter()
        self.tty = sys.stderr.isatty()
        self.last = -1.0

    def update(self, row: dict) -> None:
        self.done += 1
        self.failed += row["status"] == STATUS_FAILED
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        frac = self.done / max(self.total, 1)
        if not self.tty and frac < 1.0 and frac - self.last < 0.1:
            return
        self.last = frac
        left = el / self.done * (self.total - self.done)
        bar = "#" * int(30 * frac)
        msg = (f"sweep [{bar:<30}] {self.done}/{self.total}"
               f"{f' ({self.failed} failed)' if self.failed else ''} {el:.1f} s, ~{left:.0f} s left")
        print(("\r" if self.tty else "") + msg, end="" if self.tty and frac < 1.0 else "\n",
              file=sys.stderr, flush=True)


def run_sweep(func: Callable[..., dict], points: list[dict], out: str | Path | None = None,
              workers: int | None = None, scheduler=None, resume: bool = True, retry_failed: bool = False,
              progress: bool = True, units: dict[str, str] | None = None) -> SweepTable:
    """Run ``func(**point)`` for every point and gather a table.

    Parameters
    ----------
    func : callable
        Module-level function of the point's values returning a dict of metrics.
    points : list of dict
        The points (see :func:`grid`); every point has the same keys.
    out : path, optional
        Table to write (``.csv`` or ``.parquet``); its journal
        ``OUT.journal.jsonl`` records each finished point as it arrives.
    workers : int, optional
        Local processes (default: every core; 1 runs in this process).
    scheduler : str or distributed.Client, optional
        A Dask scheduler address (``'tcp://host:8786'``) or client: run there.
    resume : bool
        Skip points the journal already holds (finished or failed).
    retry_failed : bool
        When resuming, run the failed points again.
    progress : bool
        A progress bar on stderr.
    units : dict, optional
        The unit of each input and metric, for the table's headings
        (``peak_closure_force [N]``); see :func:`scene_point_units`.

    Returns
    -------
    SweepTable

    Examples
    --------
    >>> import functools
    >>> from grubler.studies.sweep import grid, run_sweep, scene_point
    >>> f = functools.partial(scene_point, "thesis-fourbar", t_end=0.2)   # a module-level function, constants bound
    >>> table = run_sweep(f, grid(**{"drive.torque": [0.0, 3.0]}), workers=1, progress=False)
    >>> table.inputs, [row["status"] for row in table.rows]
    (['drive.torque'], ['ok', 'ok'])
    >>> [round(row["final_drive_angle"], 4) for row in table.rows]
    [-0.4527, -0.2073]
    """
    points = [dict(p) for p in points]
    if not points:
        raise GrublerError("sweep: no points")
    inputs = list(points[0])
    for i, p in enumerate(points):
        if list(p) != inputs:
            raise GrublerError(f"sweep: point {i} has keys {list(p)}, the first has {inputs}")
    out = Path(out) if out is not None else None
    sig = signature(func)
    if out is not None and not resume and _journal(out).exists() and _journal(out).stat().st_size:
        backup = _set_aside(_journal(out))
        if progress:
            print(f"sweep: the earlier journal is kept as {backup}", file=sys.stderr)
    if out is not None and resume:
        _drop_torn_line(_journal(out))
    done = _read_done(out, sig, retry_failed) if resume else {}
    keys = [point_key(p) for p in points]
    todo = [(k, p) for k, p in zip(keys, points) if k not in done]
    resumed = len(points) - len(todo)
    bar = _Progress(len(todo), progress)
    rows: dict[str, dict] = {k: done[k] for k in keys if k in done}
    journal = None
    if out is not None:
        fresh = not _journal(out).exists() or _journal(out).stat().st_size == 0
        journal = open(_journal(out), "w" if fresh else "a")
        if fresh:  # the header reaches the disk before any work: a journal is never headerless
            journal.write(json.dumps({"sweep": sig}) + "\n")
            journal.flush()
            os.fsync(journal.fileno())
    t0 = time.perf_counter()

    def finished(row: dict) -> None:
        rows[row["key"]] = row
        if journal is not None:
            journal.write(json.dumps(row, default=repr) + "\n")
            journal.flush()
        bar.update(row)

    try:
        if scheduler is not None:
            where = _run_dask(func, todo, scheduler, finished)
        elif workers == 1 or len(todo) <= 1:
            for _, p in todo:
                finished(evaluate_point(func, p))
            where = "1 process"
        else:
            n = workers or os.cpu_count() or 1
            if n < 1:
                raise GrublerError(f"sweep: workers must be >= 1, got {n}")
            pool = ProcessPoolExecutor(max_workers=n, initializer=_worker_start, initargs=(os.getpid(),))
            try:
                futures = [pool.submit(evaluate_point, func, p) for _, p in todo]
                for fut in as_completed(futures):
                    finished(fut.result())
            except BaseException:  # Ctrl-C or an error: no worker outlives the sweep
                _stop_workers(pool)
                raise
            pool.shutdown()
            where = f"{n} processes"
    finally:
        if journal is not None:
            journal.close()
    metrics = []
    for k in keys:
        for name in rows[k]:
            if name not in inputs and name not in META and name not in metrics:
                metrics.append(name)
    table = SweepTable([rows[k] for k in keys], inputs, time.perf_counter() - t0, resumed, where, metrics,
                       dict(units or {}))
    if out is not None:
        table.write(out)
    return table


def _worker_start(parent: int) -> None:
    """A local worker ignores Ctrl-C (the main process stops it) and dies with the main process."""
    import signal
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        import ctypes

        try:  # PR_SET_PDEATHSIG: the kernel sends SIGKILL when the parent dies, even mid-computation
            ctypes.CDLL(None, use_errno=True).prctl(1, 9, 0, 0, 0)
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:  # the parent died before the line above took effect
        os._exit(1)

    def watch():  # elsewhere (and as a second guard): poll for the parent
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the workers now, not after their current point."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # the executor has no public handle
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(timeout=1.0)
        if proc.is_alive():
            proc.kill()


def _run_dask(func, todo, scheduler, finished) -> str:
    try:
        from distributed import Client, as_completed as dask_completed
    except ImportError:
        raise GrublerError("sweep: a Dask scheduler needs dask.distributed "
                           "(pip install 'dask[distributed]')") from None
    if isinstance(scheduler, Client):
        client = scheduler
    else:
        address = str(scheduler)
        if not re.fullmatch(r"(tcp|tls|inproc|ucx|ws|wss)://[^\s/:]+:\d{1,5}|(tcp|tls)://\[[0-9a-fA-F:]+\]:\d{1,5}",
                            address):
            raise InputError("--scheduler", f"{brief(address)} is not a scheduler address: write "
                                            "tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786)")
        try:
            client = Client(address, timeout=10)
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError("--scheduler", f"cannot reach {address}: {clip(str(exc), 200)}") from None
    try:
        futures = client.map(evaluate_point, [func] * len(todo), [p for _, p in todo], pure=False)
        for fut in dask_completed(futures):
            finished(fut.result())
        n = len(client.scheduler_info().get("workers", {}))
        return f"Dask cluster at {client.scheduler.address} ({n} workers)"
    finally:
        if client is not scheduler:
            client.close()


def scene_point(scene: str, t_end: float = 2.0, method: str | None = None, rtol: float = 1e-9,
                **params) -> dict:
    """Simulate a scene with dotted parameters overridden; the numbers a sweep compares.

    Parameters
    ----------
    scene : str
        Preset name, TOML file or TOML text.
    t_end : float
        Simulated time, s.
    method : {'exact', 'penalty'}, optional
    rtol : float
    **params
        Dotted parameters (see :func:`grubler.mechanism.scene.parameter_names`).

    Returns
    -------
    dict
        ``final_drive_angle``, ``peak_drive_speed``, ``peak_closure_force`` (N),
        ``max_closure_error``, ``energy_balance`` (J: energy change not
        explained by the drive's work and the dampers; mostly the trapezoid
        rule's error on the work over the output grid),
        ``run_seconds``.

    Examples
    --------
    >>> from grubler.studies.sweep import scene_point
    >>> out = scene_point("thesis-fourbar", t_end=0.1, **{"drive.torque": 3.0})
    >>> round(out["final_drive_angle"], 4), bool(out["max_closure_error"] < 1e-10)
    (-0.0518, True)
    """
    from grubler.views.report import energy_balance
    from grubler.mechanism.scene import load_scene, override
    from grubler.mechanism.simulate import output_columns, simulate

    sc = override(load_scene(scene), params)
    t0 = time.perf_counter()
    res = simulate(sc, t_end=t_end, dt_out=min(0.01, t_end / 10), method=method, rtol=rtol, atol=rtol)
    wall = time.perf_counter() - t0
    m = sc.mechanism
    # the balance's terms: the drive's work, the force elements' work and losses (the joint dampers' come from the rates)
    cols = {c: res[c] for c in ["t", "E", "P_drive"] + [f"{n}_d" for n in m.coordinate_names]
            + output_columns(m, ("forces",))[1:]}
    out = {"final_drive_angle": math.nan, "peak_drive_speed": math.nan}
    if m.drive is not None:
        out["final_drive_angle"] = float(res[m.drive][-1])
        out["peak_drive_speed"] = float(max(abs(res[m.drive + "_d"])))
    out["peak_closure_force"] = float(max(abs(res["Fx"] + 1j * res["Fy"]))) if m.closures else 0.0
    out["max_closure_error"] = float(max(res["closure_error"]))
    out["energy_balance"] = float(max(abs(energy_balance(cols, m))))
    out["run_seconds"] = wall
    return out


def scene_point_units(scene, names=()) -> dict[str, str]:
    """The unit of each of :func:`scene_point`'s metrics for ``scene``, and of the parameters ``names``.

    Examples
    --------
    >>> from grubler.mechanism.scene import load_scene
    >>> u = scene_point_units(load_scene("thesis-fourbar"), ["link2.a", "drive.torque"])
    >>> u["link2.a"], u["drive.torque"], u["peak_drive_speed"], u["peak_closure_force"]
    ('m', 'N m', 'rad/s', 'N')
    """
    from grubler.mechanism.simulate import unit_of
    from grubler.quantities import ANGLE_UNIT, force_field, scene_field

    m = scene.mechanism
    drive = m.drive
    slide = bool(drive and drive.startswith("B"))
    units = {"final_drive_angle": unit_of(drive) if drive else "", "peak_drive_speed": unit_of(f"{drive}_d") if drive
             else "", "peak_closure_force": "N", "max_closure_error": unit_of("closure_error"), "energy_balance": "J",
             "run_seconds": "s"}
    elements = {e.name: e for e in m.forces}
    for name in names:  # scene parameters (grubler.mechanism.scene.parameter_names)
        head, _, last = name.partition(".")
        if head == "initial":
            units[name] = unit_of(last)
            continue
        if head in elements:  # a force element's field, its unit by its kind (and a joint spring's joint)
            e = elements[head]
            q = force_field(e.table, last, on_slide=e.joint.startswith("B") if e.table == "joint_spring" else None)
            units[name] = q.unit
            continue
        # on a slide joint a damping is in N s/m and an effort in N
        link_slide = head.startswith("link") and head[4:].isdigit() and 0 <= int(head[4:]) - 2 < m.n_links \
            and m.links[int(head[4:]) - 2].joint != "R"
        effort_slide = (name in ("drive.torque", "drive.inertia") and slide) or (name == "load.torque" and bool(m.load and
                                                                                          m.load.startswith("B")))
        q = scene_field(name, on_slide=link_slide or effort_slide)
        units[name] = "" if q.unit == ANGLE_UNIT else q.unit
    return units


def parse_axis(text: str) -> tuple[str, list]:
    """``NAME=V1,V2,...`` or ``NAME=START:STOP:N`` (N points, ends included).

    Examples
    --------
    >>> parse_axis("link2.a=0.1:0.3:3")
    ('link2.a', [0.1, 0.2, 0.3])
    >>> parse_axis("drive_joint=theta2,theta3")
    ('drive_joint', ['theta2', 'theta3'])
    """
    name, eq, spec = text.partition("=")
    name = name.strip()
    if not eq or not name or not spec.strip():
        raise InputError("--set", f"{brief(text)}: write NAME=V1,V2,... or NAME=START:STOP:N")
    return name, _values(spec, f"--set {clip(name)}")


def parse_values(spec: str, option: str, unit: str = "", positive: bool = True) -> list[float]:
    """An option's list of numbers, ``V1,V2,...`` or ``START:STOP:N``, each as given in ``unit``.

    The rule of :func:`parse_axis` for an option of its own (``--bores``,
    ``--ratios``): refusals name ``option`` and quote the value as typed with its
    unit; the caller converts once every value is read.

    Examples
    --------
    >>> parse_values("32,40:", "--bores", "mm")
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: --bores: '32,40:' has 1 colon(s): write a range as START:STOP:N (N points, ends included, e.g. 0.1:0.3:5) or list the values as V1,V2,...
    >>> parse_values("30:50:3", "--bores", "mm")
    [30.0, 40.0, 50.0]
    """
    if not isinstance(spec, str) or not spec.strip():
        raise InputError(option, f"needs at least one value{f' ({unit})' if unit else ''}: V1,V2,... or START:STOP:N")
    u = f" {unit}" if unit else ""
    out = []
    for v in _values(spec, option, unit):
        if isinstance(v, str):
            raise InputError(option, f"{brief(v)} is not a number: write V1,V2,... or START:STOP:N"
                                     + (f", in {unit}" if unit else ""))
        v = number(v, option, unit=unit)  # finite, bounded: a refusal quotes it in its unit
        if positive and not v > 0:
            raise InputError(option, f"must be > 0{u}, got {v:g}{u}")
        out.append(v)
    return out


def _values(spec: str, field: str, unit: str = "") -> list:
    """The values of ``V1,V2,...`` (numbers where they read as one, else the text) or ``START:STOP:N``."""
    parts = spec.split(":")
    if len(parts) not in (1, 3):
        # 0.3:0.1, 0.1:0.3:5:2: a range, but not START:STOP:N
        raise InputError(field, f"{brief(spec)} has {len(parts) - 1} colon(s): write a range as "
                                "START:STOP:N (N points, ends included, e.g. 0.1:0.3:5) or list "
                                "the values as V1,V2,...")
    if len(parts) == 3:
        try:
            a, b = number(parts[0], field, unit=unit), number(parts[1], field, unit=unit)
        except InputError as exc:
            raise InputError(exc.field, f"START:STOP:N needs two numbers{f' of {unit}' if unit else ''} and a count "
                                        f"from 1 to {MAX_POINTS:g}: {exc.reason}") from None
        try:
            n = number(parts[2], field, low=1, high=MAX_POINTS, integer=True)
        except InputError:
            raise InputError(field, f"{brief(spec)}: N, the count of points, must be a whole number from 1 to "
                                    f"{MAX_POINTS:g}, got {brief(parts[2].strip())}") from None
        return [a + (b - a) * i / (n - 1) if n > 1 else a for i in range(n)]
    check_count(spec.count(",") + 1, MAX_POINTS, "values", field)
    values = []
    for v in spec.split(","):
        v = v.strip()
        try:
            values.append(float(v))
        except ValueError:
            values.append(v)
    return values


def _square(x: float) -> dict:
    # the doctest's sweep function (module level, so worker processes can import it)
    if x < 0:
        raise ValueError(f"x must be >= 0, got {x}")
    return {"y": x * x}


__all__ = ["grid", "parse_axis", "parse_values", "run_sweep", "evaluate_point", "point_key", "signature", "scene_point", "SweepTable"]
