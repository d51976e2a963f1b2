"""What the app's requests do, in the library's terms: no HTTP here, and no physics.

A scene travels as the parsed TOML the CLI reads (a dict), so every edit goes
through :func:`grubler.scene_from_dict`, the same checks and the same messages
as ``grubler simulate my_scene.toml``; :func:`scene_toml` writes it back in that
format.  Every function returns plain JSON-able data.

Examples
--------
>>> data = preset_data("fourbar-crank-rocker")
>>> out = analyse(data)
>>> out["class"]["grashof"]["kind"], out["class"]["mobility"]
('crank-rocker', 1)
>>> moved = drag(data, "B", 0.6, 0.9)          # the coupler-rocker pin, dragged
>>> moved["mechanism"]["coupler"], moved["mechanism"]["rocker"]
(0.8235, 0.9849)
>>> import tomllib
>>> tomllib.loads(scene_toml(data)) == data
True
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from functools import lru_cache

import numpy as np

from grubler.errors import AssemblyError, Cancelled, GrublerError, InputError, SceneError
from grubler.limits import brief, did_you_mean, parse_toml
from grubler.mechanism.analysis import SIX_BAR_INVERSIONS, classify
from grubler.mechanism.assembly import assemble, branches
from grubler.mechanism.builders import BUILDER_DOCS, HANDLES, MOVES, Drawing, value
from grubler.mechanism.kinematics import link_points
from grubler.mechanism.scene import coordinate_text, preset_names, preset_text, scene_from_dict
from grubler.mechanism.simulate import force_kinds, output_columns, simulate, unit_of
from grubler.quantities import mechanism_output, scene_field
from grubler.views.animation import Sketch, trace_point

SWEEP_STEPS = 180  # positions of the drive over a turn for a coupler curve (2 degrees apart)
LIVE_STEPS = 90  # ... while a pivot is being dragged (4 degrees apart: the curve keeps up with the mouse)
MAX_FRAMES = 400  # frames sent to the page: 40 per second of a 10 s run (the graphs get every output row)
MAX_KEY_PARTS = 4  # names in a scene field's dotted key: a scene's are TABLE.NAME, TABLE[N].NAME or NAME


# -- scenes as data -------------------------------------------------------------------------------
def preset_data(name: str) -> dict:
    """A preset's scene as parsed TOML."""
    if name not in preset_names():
        raise SceneError("preset", f"no such preset: {brief(name)}")
    return tomllib.loads(preset_text(name))


def parse_scene_text(text: str) -> dict:
    """TOML text (a file the user opened, a shared link) as scene data, checked as a scene."""
    if not isinstance(text, str):
        raise SceneError("scene", f"must be TOML text, got {type(text).__name__}")
    data = parse_toml(text, "scene")
    scene_from_dict(data)  # the CLI's checks, now: a bad file is refused where it is opened
    return data


@lru_cache(maxsize=1)
def catalog() -> dict:
    """The presets (name, chain, inversion) and the mechanism types, each with its example preset."""
    presets, types = [], {}
    for name in preset_names():
        data = preset_data(name)
        c = classify(scene_from_dict(data, name).mechanism)
        presets.append({"name": name, "chain": c.chain, "kind": c.name,
                        "description": str(data.get("description", ""))})
        kind = data.get("mechanism", {}).get("type")
        if kind and kind not in types:
            types[kind] = {"type": kind, "example": name, "doc": BUILDER_DOCS.get(kind, "")}
    return {"presets": presets, "types": [types[k] for k in BUILDER_DOCS if k in types]}


def scene_toml(data: dict) -> str:
    """Scene data as TOML text the CLI reads (``tomllib.loads(scene_toml(d)) == d``)."""
    top = [(k, v) for k, v in data.items() if not isinstance(v, dict) and not _is_tables(v)]
    lines = [f"{_key(k)} = {_value(v)}" for k, v in top]
    for k, v in data.items():
        if isinstance(v, dict):
            lines += ["", f"[{_key(k)}]"] + [f"{_key(a)} = {_value(b)}" for a, b in v.items()]
        elif _is_tables(v):
            for table in v:
                lines += ["", f"[[{_key(k)}]]"] + [f"{_key(a)} = {_value(b)}" for a, b in table.items()]
    return "\n".join(lines).lstrip("\n") + "\n"


def _is_tables(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(t, dict) for t in v)


def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if v != v else ("inf" if v > 0 else "-inf"))
    if isinstance(v, str):
        return json.dumps(v)  # a JSON string is a TOML basic string (its escapes are TOML's)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(a)} = {_value(b)}" for a, b in v.items()) + "}"
    raise SceneError("scene", f"cannot write {type(v).__name__} values to TOML")


def echoed(data):
    """Scene data as the page is sent it back: a number that is not finite as TOML's word for it.

    A refused NaN (``gravity = nan``) is shown in its field with the reason
    next to it; JSON has no NaN, and the word, sent back, is refused the same way.
    """
    if isinstance(data, float) and not math.isfinite(data):
        return _value(data)
    if isinstance(data, dict):
        return {k: echoed(v) for k, v in data.items()}
    if isinstance(data, list):
        return [echoed(v) for v in data]
    return data


# -- the form: every number of the scene, named as the TOML names it, with its unit ------------------
_TEXT = {"name", "description", "kind", "type", "joint", "existence", "parent", "link", "to_link", "method"}


def choices(key: str) -> list[str] | None:
    """The words the scene reader takes for a field, when they are a short list (the form offers a menu)."""
    head, leaf = key.split(".")[0], key.rsplit(".", 1)[-1]
    if key == "mechanism.type":
        return list(BUILDER_DOCS)
    if head.startswith("closure") and leaf == "type":
        return ["revolute", "prismatic", "none"]
    if leaf == "method":
        return ["exact", "penalty"]
    if head.startswith("link") and leaf == "joint":
        return ["R", "P"]
    if leaf.endswith("_side"):
        return ["left", "right"]
    if leaf.startswith("branch"):
        return ["open", "crossed"]
    return None


def unit(key: str) -> str:
    """The unit a scene field is written in, for the form's label ('' for words and counts)."""
    return scene_field(key).unit


def fields(data: dict) -> list[dict]:
    """The form: one entry per editable value, its dotted key (the name errors use), value and unit."""
    out = []

    def add(prefix, table):
        for k, v in table.items():
            key = f"{prefix}{k}"
            if k in ("name", "description", "kind") and not prefix:
                continue
            if isinstance(v, dict):
                add(key + ".", v)
            elif _is_tables(v):
                for j, t in enumerate(v):
                    add(f"{key}[{j}].", t)
            else:
                entry = {"key": key, "value": v, "unit": unit(key), "text": k in _TEXT or isinstance(v, bool)}
                if choices(key):
                    entry["choices"] = choices(key)
                out.append(entry)
    add("", data)
    return out


def edit(data: dict, key: str, text) -> dict:
    """Scene data with the value at dotted ``key`` set from the form's ``text`` (a number, a list or words)."""
    if not isinstance(key, str) or not re.fullmatch(r"[A-Za-z0-9_]+(\[\d+\])?(\.[A-Za-z0-9_]+(\[\d+\])?)*", key):
        raise InputError("field", f"not a scene field: {brief(key)}")
    if key.count(".") >= MAX_KEY_PARTS:
        raise InputError("field", f"not a scene field: {brief(key)} has {key.count('.') + 1} parts; a scene's "
                                  f"field has at most {MAX_KEY_PARTS} (TABLE.NAME, TABLE[N].NAME)")
    out = json.loads(json.dumps(data))
    *path, leaf = re.findall(r"([A-Za-z0-9_]+)(?:\[(\d+)\])?", key)
    table = out
    for name, index in path:
        table = table.setdefault(name, {})
        if index:
            if not (isinstance(table, list) and int(index) < len(table)):
                raise InputError(key, "no such table in this scene")
            table = table[int(index)]
        if not isinstance(table, dict):
            raise InputError(key, "no such table in this scene")
    table[leaf[0]] = _typed(text)
    return out


def _typed(text):
    """A form value as TOML would hold it: numbers as numbers, '[x, y]' as a list, else the text."""
    if not isinstance(text, str):
        return text
    s = text.strip()
    if s.startswith("[") and s.endswith("]"):
        return [_typed(p) for p in s[1:-1].split(",") if p.strip()]
    try:
        return int(s) if re.fullmatch(r"[+-]?\d+", s) else float(s)
    except ValueError:
        return s


# -- what the page shows of a scene -----------------------------------------------------------------
def _frame(geo) -> dict:
    r = lambda p: [round(float(p[0]), 6), round(float(p[1]), 6)]  # noqa: E731 (a micrometre is plenty)
    return {"bars": [r(a) + r(b) for a, b in geo.bars], "joints": [r(p) for p in geo.joints],
            "fixed": [r(p) for p in geo.fixed], "blocks": [r(c) + [round(a, 6)] for c, a in geo.blocks],
            "guides": [r(p) + [round(a, 6), bool(f)] for p, a, f in geo.guides],
            "plates": [[r(p) for p in plate] for plate in geo.plates]}


def default_trace(model) -> str:
    """The coupler point a four-bar book would trace: on link 3, half along it and a quarter across."""
    if model.n_links < 2 or not model.closures:
        return "tip"
    a = model.links[1].a or 0.1
    return f"link3:{a / 2:.4g},{a / 4:.4g}"


def analyse(data: dict, trace: str | None = None, live: bool = False) -> dict:
    """Everything the editor shows: class, mobility, branch, drawing, drag handles and coupler curve.

    A loop that cannot close is no error here: its reason (the words of
    ``grubler info``) comes back as ``problem``, with the unclosed sketch drawn.
    ``live`` (a drag under way) draws the coupler curve from :data:`LIVE_STEPS`
    positions instead of :data:`SWEEP_STEPS`.
    """
    scene = scene_from_dict(data)
    m = scene.mechanism
    c = classify(m)
    trace_spec = trace or default_trace(m)
    point = trace_point(trace_spec, m)
    out = {"class": {"chain": c.chain, "name": c.name, "mobility": c.mobility,
                     "inversion": SIX_BAR_INVERSIONS.get(c.name.removesuffix(" six-bar"), ""),
                     "grashof": None if c.grashof is None else
                     {"kind": c.grashof.kind, "detail": c.grashof.detail, "s_plus_l": c.grashof.s_plus_l,
                      "p_plus_q": c.grashof.p_plus_q}},
           "drive": m.drive, "trace": trace_spec, "problem": None, "curve": [], "branch": None}
    z0 = m.z_from_q(m.q_ref)
    sketch = Sketch(m, point)
    try:
        z, _ = assemble(m, z0, scene.initial_rates)
        out["closed"] = True
    except AssemblyError as exc:
        z, out["closed"], out["problem"] = z0, False, {"field": exc.field, "reason": exc.reason}
    out["frame"] = _frame(sketch.geometry(sketch.positions(z[None, :])[0]))
    out["handles"] = handles(data, m, z)
    if out["closed"] and m.closures and m.drive:
        out["curve"] = coupler_curve(m, z, point, LIVE_STEPS if live else SWEEP_STEPS)
        # which branch the sketch closes to, named as `grubler info` lists it: by the other joints' angles
        # the call `grubler info` makes (its 256 random starts too): the page never counts otherwise than the CLI
        found, _ = branches(m, z0)
        q = m.q_from_z(found[0])  # the sketch's branch, listed as info lists it: angles modulo a turn
        angles = [f"{n} {coordinate_text(n, v if n.startswith('B') else v % (2 * math.pi))}"
                  for n, v in ((n, q[m.coordinate_names.index(n)]) for n in m.free_names if n != m.drive)]
        out["branch"] = {"count": len(found), "drive": m.drive, "angles": angles}
    return out


def pick_trace(data: dict, x: float, y: float) -> str:
    """The trace spec ('linkK:u,v') of the point (x, y), m, on the moving link whose bar passes nearest it."""
    x, y = _finite(x, "trace"), _finite(y, "trace")
    scene = scene_from_dict(data)
    m = scene.mechanism
    z, _ = assemble(m, m.z_from_q(m.q_ref), scene.initial_rates)
    n = m.n_links
    # each link's joint and unit axes, placed by the kernel: the point's (u, v) in that frame
    frames = link_points(m, z[None, :], [k for k in range(n) for _ in range(3)], [(0, 0), (1, 0), (0, 1)] * n)
    frames = frames[0].reshape(n, 3, 2)
    best = None
    for k in range(n):
        o = frames[k, 0]
        u, v = float(np.dot((x, y) - o, frames[k, 1] - o)), float(np.dot((x, y) - o, frames[k, 2] - o))
        a = m.links[k].a
        along = min(max(u, min(0.0, a)), max(0.0, a))
        gap = math.hypot(u - along, v)
        if best is None or gap < best[0]:
            best = (gap, k, u, v)
    _, k, u, v = best
    return f"link{k + 2}:{u:.4g},{v:.4g}"


def drive_sweep(model, z: np.ndarray, steps: int = SWEEP_STEPS) -> np.ndarray:
    """Closed positions as the drive turns a full turn (a slide: its length either way) from ``z``.

    Each position is assembled from the one before, so the sweep stays on the
    branch it started on; where the loop stops closing (a rocker's limit), the
    sweep goes back and runs the other way.  Rows in drive order.
    """
    i = model.free_index(model.drive)
    revolute = bool(model.arrays.revolute[i])
    span = 2 * math.pi if revolute else 2 * max(abs(l.a) for l in model.links)
    step = span / steps
    ahead, behind = [z], []
    for sign, rows in ((1, ahead), (-1, behind)):
        zc = z
        for k in range(1, steps if sign > 0 else steps - len(ahead) + 1):
            guess = zc.copy()
            guess[i] = z[i] + sign * k * step
            try:
                zc, _ = assemble(model, guess)
            except AssemblyError:
                break
            rows.append(zc)
        if sign > 0 and len(ahead) == steps:
            ahead.append(ahead[0])  # a full turn: the curve closes
            break
    return np.array(behind[::-1] + ahead)


def coupler_curve(model, z: np.ndarray, point, steps: int = SWEEP_STEPS) -> list:
    """The traced point's path over :func:`drive_sweep`, [[x, y], ...]."""
    zs = drive_sweep(model, z, steps)
    k, local = point
    xy = link_points(model, zs, [k], [local])[:, 0, :]
    return np.round(xy, 6).tolist()


def handles(data: dict, model, z: np.ndarray) -> list[dict]:
    """The points a user can drag, where they are now, and what each changes (in words).

    A builder's scene gets the handles its builder registers beside its build
    (:data:`grubler.mechanism.builders.HANDLES`: a crank pin, the ground pivots,
    the blocks, every six-bar joint); a link table its ground closures and the
    ends of its crank (of every link, in an open chain).
    """
    out = []

    def add(hid, xy, sets):
        out.append({"id": hid, "xy": [round(float(v), 6) for v in xy], "sets": sets})

    mech = data.get("mechanism")
    if isinstance(mech, dict):
        where = HANDLES.get(mech.get("type"))
        for hid, xy, sets in where(mech, Drawing(model, z)) if where else ():
            add(hid, xy, sets)
        return out
    closures = data.get("closure")
    tables = [closures] if isinstance(closures, dict) else closures if _is_tables(closures) else []
    for j, cl in enumerate(tables):
        if cl.get("to_link", 1) == 1 and isinstance(cl.get("point"), list):
            key = "closure" if isinstance(closures, dict) else f"closure[{j}]"
            add(f"{key}.point", [value(v) for v in cl["point"]], f"{key}.point")
    # a pinned link's far end: its length and its start angle (the ground's closures win a shared spot); in
    # a closed chain only the first link's, whose angle is held: the others' are the assembly's to find
    for k, link in enumerate(model.links):
        name = f"link{k + 2}"
        if link.joint == "R" and link.a and isinstance(data.get(name), dict) and (k == 0 or not model.closures):
            xy = Drawing(model, z).at(k, link.a)
            if all(math.dist(xy, h["xy"]) > 1e-9 for h in out):
                add(f"{name}.end", xy, f"{name}.a, initial.theta{k + 2}")
    return out


def _r(v: float) -> float:
    return round(float(v), 4)  # a tenth of a millimetre: what a drag can mean


def _deg(angle: float) -> str:
    return f"{math.degrees(angle):.4g} deg"


def _sketch(data: dict):
    """The scene's mechanism and where its sketch closes (or the sketch itself, where it does not)."""
    return _sketch_of(json.dumps(data, sort_keys=True))


@lru_cache(maxsize=8)
def _sketch_of(text: str):
    # every move of a drag starts from the same scene: built and closed once (Stephenson II's builder
    # alone takes some 3 ms), the mechanism immutable and its coordinates read-only
    scene = scene_from_dict(json.loads(text))
    m = scene.mechanism
    z = m.z_from_q(m.q_ref)
    try:
        z = assemble(m, z, scene.initial_rates)[0]
    except AssemblyError:
        pass
    z.flags.writeable = False
    return m, z


def drag(data: dict, handle: str, x: float, y: float) -> dict:
    """Scene data with the numbers behind ``handle`` set so that it sits at (x, y), m.

    ``data`` is the scene as the drag started: the numbers a handle does not
    set stay as they were then.  A builder's scene is moved by its builder
    (:data:`grubler.mechanism.builders.MOVES`); a link table by its ground
    closures' points and its links' ends.
    """
    x, y = (_finite(v, "drag") for v in (x, y))
    if not isinstance(handle, str):
        raise InputError("drag", f"a handle is named by its id, got {brief(handle)}")
    out = json.loads(json.dumps(data))
    mech = out.get("mechanism")
    kind = mech.get("type") if isinstance(mech, dict) else None
    move = MOVES.get(kind) if isinstance(kind, str) else None
    if move and move(mech, handle, x, y, lambda: Drawing(*_sketch(data))):
        return out
    if re.fullmatch(r"closure(\[\d+\])?\.point", handle) and not kind:
        return edit(out, handle, [_r(x), _r(y)])
    if re.fullmatch(r"link\d+\.end", handle) and not kind and isinstance(out.get(handle.removesuffix(".end")), dict):
        name = handle.removesuffix(".end")
        model, z = _sketch(data)
        o = Drawing(model, z).at(int(name[4:]) - 2)
        out[name]["a"] = _r(math.hypot(x - o[0], y - o[1]))
        out.setdefault("initial", {})[f"theta{name[4:]}"] = _deg(math.atan2(y - o[1], x - o[0]))
        return out
    raise InputError("drag", f"this scene has no point {brief(handle)} to drag")


def analyse_drag(data: dict, moved: dict, handle: str, x: float, y: float, trace: str | None = None,
                 live: bool = False) -> dict:
    """What the editor shows (:func:`analyse`) of ``moved``, the scene ``data`` with ``handle`` dragged to (x, y).

    Where a builder cannot lay its links through the moved joints (a six-bar's
    pivot beyond its links' reach), its reason is the ``problem``, in the words
    ``grubler info`` prints for that scene, and the sketch drawn is the drag's
    start, open, with the dragged handle at the pointer.  A six-bar's origin O2
    dragged comes with ``shift``, the pointer: the answer is in the moved
    origin's coordinates, which the page draws shifted by it.
    """
    try:
        out = analyse(moved, trace, live)
        if handle == "O2":  # drawn where the drag began: the origin under the pointer, the rest where it was
            out["shift"] = [x, y]
        return out
    except AssemblyError:
        raise
    except SceneError as exc:
        problem = error_of(exc)
    out = analyse(data, trace, live=True)  # the start: the drag began on a drawing, so it was drawn
    out.update(closed=False, problem=problem, curve=[], branch=None)
    for h in out["handles"]:
        if h["id"] == handle:
            h["xy"] = [x, y]
    return out


def _finite(v, field: str) -> float:
    from grubler.limits import number

    return number(v, field)


# -- runs ----------------------------------------------------------------------------------------


def describe(column: str, actuators=(), forces=()) -> str:
    """A run column in words with its unit: 'theta3_d' -> 'angular rate of link 3 (theta3_d), rad/s'.

    ``forces``: the force elements as (name, kind) pairs (grubler.mechanism.simulate.force_kinds)."""
    q = mechanism_output(column, actuators, forces)
    words = q.label if q else column
    u = unit_of(column)
    return f"{words} ({column})" + (f", {u}" if u else "")


def run_simulation(data: dict, t_end: float | None, dt_out: float | None, torque: float | None, cancel=None,
                   trace: str | None = None):
    """Simulate the scene (the CLI's ``simulate``) and what the page plays and plots of it.

    Returns
    -------
    result : grubler.Result
        Kept by the session for the CSV export.
    view : dict
        Times, frames (at most :data:`MAX_FRAMES`, evenly spread), the traced
        point's path and every output column with its description.
    """
    from grubler.limits import number

    scene = scene_from_dict(data)
    kw = {}
    if t_end not in (None, ""):
        kw["t_end"] = number(t_end, "t_end", low=0.0, low_open=True, unit="s")
    if dt_out not in (None, ""):
        kw["dt_out"] = number(dt_out, "dt_out", low=0.0, low_open=True, unit="s")
    if torque not in (None, ""):
        kw["torque"] = number(torque, "torque")
    point = trace_point(trace or default_trace(scene.mechanism), scene.mechanism)
    res = simulate(scene, cancel=cancel, **kw)
    _check_cancel(cancel, res.t[-1])
    rows = np.unique(np.linspace(0, len(res.t) - 1, min(len(res.t), MAX_FRAMES)).round().astype(int))
    sketch = Sketch(scene.mechanism, point)
    pos = sketch.positions(res.z[rows])
    frames = [_frame(sketch.geometry(p)) for p in pos]
    k, local = point
    path = link_points(scene.mechanism, res.z, [k], [local])[:, 0, :]
    columns = res.columns
    res.compute(["state", "dynamics", "energy"])  # every column in one kernel pass, then one more look at the flag
    _check_cancel(cancel, res.t[-1])
    view = {"t": res.t.tolist(), "frame_t": res.t[rows].tolist(), "frames": frames,
            "path": np.round(path, 6).tolist(),
            "columns": [{"name": c, "label": describe(c, scene.mechanism.actuator_names, force_kinds(scene.mechanism)),
                         "f32": _f32(res[c])}
                        for c in columns],
            "summary": _summary(scene, res)}
    return res, view


def _check_cancel(cancel, t: float) -> None:
    """The run's outputs take a while too (a kernel pass over every row): a cancel then is honoured as well."""
    if cancel is not None and cancel.is_set():
        raise Cancelled("run", f"cancelled at t = {t:.6g} s (the end: its outputs were being computed)")


def _f32(values) -> str:
    """A column for the graphs: little-endian float32, base64 (a fifth of its JSON; the CSV keeps every digit)."""
    import base64

    return base64.b64encode(np.asarray(values, dtype="<f4").tobytes()).decode()


def _summary(scene, res) -> str:
    e = res["E"]
    text = (f"{scene.name or 'scene'}: {len(res.t)} points to t = {res.t[-1]:g} s, method {res.method}, "
            f"{res.stats['steps']} steps; max closure error {np.max(res['closure_error']):.3g}; "
            f"energy {e[0]:.6g} J -> {e[-1]:.6g} J")
    count = res.stats.get("passage_count", 0)
    if count:
        text += f"; passed {count} change point{'s' if count > 1 else ''}"
    return text


def result_csv(res, path) -> None:
    """The run as ``grubler simulate --csv`` writes it."""
    res.to_csv(path, ["state", "dynamics", "energy"])


# -- the servo drive: a co-simulation of FMUs, and a sizing study ---------------------------------------
SERVO_SIGNALS = ["trajectory.position", "mechanism.drive_angle", "motor.current", "motor.voltage",
                 "motor.terminal_voltage"]


def servo_defaults() -> dict:
    """What the servo form starts from: the data sets, and the servo four-bar's design (``ServoDesign()``)."""
    from grubler.motors import list_motors
    from grubler.system.servo import ServoDesign

    d = ServoDesign()
    return {"motors": list_motors(), "motor": d.motor, "gear_ratio": d.gear_ratio, "supply_voltage": d.supply_voltage,
            "current_limit": d.current_limit, "K": d.pid["K"], "Ti": d.pid["Ti"], "Td": d.pid["Td"],
            "kind": d.trajectory["kind"], "distance": d.trajectory["distance"], "v_max": d.trajectory["v_max"],
            "a_max": d.trajectory["a_max"], "dwell": d.trajectory["dwell"], "t_end": d.t_end, "step": d.step}


def _servo_design(data: dict, settings: dict):
    """A :class:`grubler.system.servo.ServoDesign` of the scene from the form's settings, each number checked."""
    from grubler.limits import number
    from grubler.motors import list_motors
    from grubler.system.servo import ServoDesign

    if not isinstance(settings, dict):
        raise InputError("servo", "missing: the page sends the servo settings as a JSON object")
    scene = scene_from_dict(data)
    if scene.mechanism.drive is None:
        raise SceneError("drive.joint", "the servo drives the scene's drive joint: name one ([drive] joint)")
    base = ServoDesign()
    pos = {"low": 0.0, "low_open": True}

    def get(key, **bounds):
        v = settings.get(key)
        return number(base_values[key] if v in (None, "") else v, f"servo.{key}", **bounds)

    base_values = servo_defaults()
    motor = settings.get("motor") or base.motor
    if motor not in list_motors():
        raise InputError("servo.motor", f"no such data set: {brief(motor)}{did_you_mean(motor, list_motors())}")
    kind = settings.get("kind") or "trapezoid"
    if kind not in ("trapezoid", "scurve"):
        raise InputError("servo.kind", f"must be 'trapezoid' or 'scurve', got {brief(kind)}")
    trajectory = {**base.trajectory, "kind": kind, "distance": get("distance"), "v_max": get("v_max", **pos),
                  "a_max": get("a_max", **pos), "dwell": get("dwell", low=0.0)}
    pid = {**base.pid, "K": get("K", low=0.0), "Ti": get("Ti", **pos), "Td": get("Td", low=0.0)}
    supply = get("supply_voltage", **pos)
    pid["u_min"], pid["u_max"] = -supply, supply
    return ServoDesign(scene=scene_toml(data), motor=motor, gear_ratio=get("gear_ratio", **pos),
                       supply_voltage=supply, current_limit=get("current_limit", **pos),
                       trajectory=trajectory, pid=pid, t_end=get("t_end", **pos), step=get("step", **pos))


def check_fmu_folder(d) -> None:
    """The FMUs the servo runs are in ``d`` (the app's ``dist/``, where ``python3 build_fmu.py`` puts them)."""
    from pathlib import Path

    d = Path(d)
    missing = [n for n in ("Mechanism", "DCMotor", "PID", "Encoder", "Trajectory") if not (d / f"{n}.fmu").is_file()]
    if missing:
        raise InputError("servo", f"no {', '.join(m + '.fmu' for m in missing)} in {d}: build the FMUs there first "
                                  "(python3 build_fmu.py, in the folder the app was started in)")


def run_servo(data: dict, settings: dict, fmu_dir, cancel=None, unpacked=None) -> dict:
    """Co-simulate the servo drive of the scene (``grubler cosim`` of :func:`grubler.system.servo.servo_system`).

    Returns the tracking error, the current and the voltages over time (every
    10th step), and the drive's and the motor's limits to hold them against.
    """
    from grubler.motors import load_motor
    from grubler.system import cosim
    from grubler.system.servo import servo_system

    design = _servo_design(data, settings)
    check_fmu_folder(fmu_dir)
    system = servo_system(design, fmu_dir, name="app-servo")
    every = max(1, round(design.t_end / design.step / 2000))  # some 2000 rows: a graph's worth
    res = cosim.run(system, t_end=design.t_end, step=design.step, record=SERVO_SIGNALS, record_every=every,
                    cancel=cancel, unpacked=unpacked)
    error = res["trajectory.position"] - res["mechanism.drive_angle"]
    motor = load_motor(design.motor)
    current, volts = res["motor.current"], res["motor.terminal_voltage"]
    limits = {"current_limit": design.current_limit, "supply_voltage": design.supply_voltage,
              "nominal_current": getattr(motor, "nominal_current", None)}
    return {"t": res.t.tolist(), "wall_time": res.wall_time,
            "columns": [{"name": "error", "label": "tracking error, setpoint - response (rad)", "f32": _f32(error)},
                        {"name": "setpoint", "label": "crank angle, setpoint (rad)",
                         "f32": _f32(res["trajectory.position"])},
                        {"name": "response", "label": "crank angle, response (rad)",
                         "f32": _f32(res["mechanism.drive_angle"])},
                        {"name": "current", "label": "motor current (A)", "f32": _f32(current)},
                        {"name": "voltage", "label": "motor voltage, applied (V)", "f32": _f32(volts)},
                        {"name": "command", "label": "motor voltage, commanded (V)",
                         "f32": _f32(res["motor.voltage"])}],
            "limits": {k: v for k, v in limits.items() if v is not None and math.isfinite(v)},
            "summary": f"{design.t_end:g} s at {design.step:g} s steps in {res.wall_time:.2f} s: tracking error "
                       f"up to {np.max(np.abs(error)):.3g} rad, current up to {np.max(np.abs(current)):.3g} A "
                       f"(limit {design.current_limit:g} A), voltage up to {np.max(np.abs(volts)):.3g} V "
                       f"(supply {design.supply_voltage:g} V)"}


def run_sizing(data: dict, settings: dict) -> dict:
    """Which motor and gear ratio fit the servo's move (``grubler size --move``), ranked: the study's table."""
    from grubler.controllers.trajectory import Trajectory
    from grubler.motors import list_motors, load_motor
    from grubler.studies.sizing import Control, DutyCycle, size

    design = _servo_design(data, settings)
    model = scene_from_dict(data).mechanism
    tr = design.trajectory
    traj = Trajectory(tr["kind"], distance=tr["distance"], v_max=tr["v_max"], a_max=tr["a_max"],
                      dwell=tr["dwell"], repeat=2, reverse=True)
    start = float(model.z_from_q(model.q_ref)[model.free_index(model.drive)])
    cycle = DutyCycle.from_trajectory(traj, (traj.move_time + tr["dwell"]) * 2, start=start,
                                      name=f"{tr['kind']} move of {tr['distance']:g} rad and back")
    study = size(model, cycle, [load_motor(n) for n in list_motors()], [5, 10, 20, 35, 50, 75, 100, 150],
                 supply_voltage=design.supply_voltage, current_limit=design.current_limit, control=Control.servo())
    rows = []
    for a in study.ranked + study.rejected:
        r = a.summary()
        rows.append({"motor": a.candidate.motor.name, "ratio": a.candidate.ratio, "fits": bool(a.feasible),
                     "margin": round(float(a.min_margin), 3), "binding": a.binding,
                     "peak_current": round(r["peak_current"], 3), "peak_voltage": round(r["peak_voltage"], 2),
                     "rpm": round(r["peak_motor_speed"] * 30 / math.pi), "why_not": r["why_not"]})
    return {"cycle": cycle.name, "rows": rows}


# -- exports: what the CLI would write, into a folder the server sends from and removes -----------------------
EXPORTS = {"fmu": "the mechanism FMU (grubler export)", "ssp": "the servo system as an SSP archive",
           "pdf": "the one-page run report (grubler report)"}


def export_file(kind: str, data: dict, folder, result=None, settings: dict | None = None, fmu_dir=None):
    """Write one export into ``folder`` and return its path.

    Parameters
    ----------
    kind : {'fmu', 'ssp', 'pdf'}
        See :data:`EXPORTS`; 'pdf' needs the session's last run (``result``),
        'ssp' the servo settings and the FMUs the servo runs (``fmu_dir``).
    """
    from pathlib import Path

    from grubler.fmi.build import export, identifier_for

    folder = Path(folder)
    scene = scene_from_dict(data)
    stem = identifier_for(Path((scene.name or "mechanism").replace("-", "_")))
    if kind == "fmu":
        return export(scene, folder / f"{stem}.fmu")
    if kind == "ssp":
        from grubler.system.servo import servo_system

        check_fmu_folder(fmu_dir)
        return servo_system(_servo_design(data, settings), fmu_dir, name=f"{stem}_servo").write(
            folder / f"{stem}_servo.ssp")
    if kind == "pdf":
        from grubler.views.report import write_report
        from grubler.views.runs import read_run

        if result is None:
            raise InputError("report", "simulate first: the report is of the last run")
        csv_path = folder / f"{stem}.csv"
        result_csv(result, csv_path)
        _, columns = read_run(str(csv_path), result.model)
        write_report(columns, [folder / f"{stem}-report.pdf"], result.model, source=csv_path.name)
        return folder / f"{stem}-report.pdf"
    raise InputError("export", f"must be one of {', '.join(EXPORTS)}, got {brief(kind)}")


def error_of(exc: BaseException) -> dict:
    """A refusal as the page shows it: the field it belongs next to, and one line."""
    if isinstance(exc, GrublerError):
        field = getattr(exc, "field", "") or ""
        reason = getattr(exc, "reason", None) or str(exc)
        return {"field": field, "reason": " ".join(str(reason).split())[:1000]}
    return {"field": "", "reason": f"internal error ({type(exc).__name__}); the server's log has the details"}


__all__ = ["analyse", "catalog", "drag", "edit", "fields", "parse_scene_text", "preset_data", "run_simulation",
           "scene_toml", "describe", "output_columns"]
