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
from grubler.mechanism.simulate import output_columns, simulate, unit_of
from grubler.quantities import mechanism_output, scene_field
from grubler.views.animation import BARREL_SHARE, Sketch, trace_point

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
            "plates": [[r(p) for p in plate] for plate in geo.plates],
            # a cylinder: its barrel from the first point (as the GIFs draw it), the rod the whole line
            "actuators": [r(a) + r(b) + r(np.asarray(a) + BARREL_SHARE * (np.asarray(b) - a))
                          for a, b in geo.actuators]}


def default_trace(model) -> str:
    """The coupler point a four-bar book would trace: on link 3, half along it and a quarter across."""
    if model.n_links < 2 or not model.closures:
        return "tip"
    a = model.links[1].a or 0.1
    return f"link3:{a / 2:.4g},{a / 4:.4g}"


def analyse(data: dict, trace: str | None = None, live: bool = False, kinematics: bool = False) -> dict:
    """Everything the editor shows: class, mobility, branch, drawing, drag handles and coupler curve.

    A loop that cannot close is no error here: its reason (the words of
    ``grubler info``) comes back as ``problem``, with the unclosed sketch drawn.
    ``live`` (a drag under way) draws the coupler curve from :data:`LIVE_STEPS`
    positions instead of :data:`SWEEP_STEPS`.  ``kinematics`` adds the analysis
    on the drawing (:func:`analysis_view`) of the closed sketch, the drive
    turning steadily at 1 rad/s (1 m/s), as ``analysis``.
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
           "drive": m.drive, "actuators": list(m.actuator_names),
           "trace": trace_spec, "problem": None, "curve": [], "branch": None}
    z0 = m.z_from_q(m.q_ref)
    sketch = Sketch(m, point)
    try:
        z, _ = assemble(m, z0, scene.initial_rates)
        out["closed"] = True
    except AssemblyError as exc:
        z, out["closed"], out["problem"] = z0, False, {"field": exc.field, "reason": exc.reason}
    out["frame"] = _frame(sketch.geometry(sketch.positions(z[None, :])[0]))
    out["handles"] = handles(data, m, z)
    zs = None
    if out["closed"] and m.closures and m.drive:
        zs = drive_sweep(m, z, LIVE_STEPS if live else SWEEP_STEPS)
        out["curve"] = coupler_curve(m, z, point, rows=zs)
        # which branch the sketch closes to, named as `grubler info` lists it: by the other joints' angles
        # the call `grubler info` makes (its 256 random starts too): the page never counts otherwise than the CLI
        found, _ = branches(m, z0)
        q = m.q_from_z(found[0])  # the sketch's branch, listed as info lists it: angles modulo a turn
        angles = [f"{n} {coordinate_text(n, v if n.startswith('B') else v % (2 * math.pi))}"
                  for n, v in ((n, q[m.coordinate_names.index(n)]) for n in m.free_names if n != m.drive)]
        out["branch"] = {"count": len(found), "drive": m.drive, "angles": angles}
    if kinematics and out["closed"]:
        out["analysis"] = analysis_view(m, z, point, zs)
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


def coupler_curve(model, z: np.ndarray, point, steps: int = SWEEP_STEPS, rows: np.ndarray | None = None) -> list:
    """The traced point's path over :func:`drive_sweep` (or over ``rows``, a sweep made already), [[x, y], ...]."""
    zs = drive_sweep(model, z, steps) if rows is None else rows
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

    actuator_handles(data, model, z, add)
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


def _actuator_tables(data: dict) -> list:
    """The scene's ``[[actuator]]`` tables, in the model's order (their keys: ``actuator[j]``)."""
    tables = data.get("actuator")
    return tables if _is_tables(tables) else []


def actuator_handles(data: dict, model, z: np.ndarray, add) -> None:
    """Each actuator's two attachments, dragged to move the point on its link (a ground point: in the world)."""
    for j, act in enumerate(model.actuators[: len(_actuator_tables(data))]):
        for end, k, point in (("from", act.from_link, act.from_point), ("to", act.to_link, act.to_point)):
            key = f"actuator[{j}].{end}_point"
            add(key, Drawing(model, z).at(k - 2, *point), key)


def _move_actuator(data: dict, out: dict, handle: str, x: float, y: float) -> bool:
    """An actuator's attachment dragged to (x, y): its point in its link's frame (False: not such a handle)."""
    found = re.fullmatch(r"actuator\[(\d+)\]\.(from|to)_point", handle)
    if not found or int(found[1]) >= len(_actuator_tables(out)):
        return False
    model, z = _sketch(data)
    act = model.actuators[int(found[1])]
    k = (act.from_link if found[2] == "from" else act.to_link) - 2
    # the link's origin and unit axes where the sketch closes: the point's (along, across) in that frame
    o, e_u, e_v = link_points(model, z[None, :], [k] * 3, [(0, 0), (1, 0), (0, 1)])[0]
    d = np.array([x, y]) - o
    _actuator_tables(out)[int(found[1])][f"{found[2]}_point"] = [_r(np.dot(d, e_u - o)) + 0.0,
                                                                 _r(np.dot(d, e_v - o)) + 0.0]
    return True


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
    if _move_actuator(data, out, handle, x, y):
        return out
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
                 live: bool = False, kinematics: bool = False, drawn: dict | None = None) -> dict:
    """What the editor shows (:func:`analyse`) of ``moved``, the scene ``data`` with ``handle`` dragged to (x, y).

    Where a builder cannot lay its links through the moved joints (a six-bar's
    pivot beyond its links' reach), its reason is the ``problem``, in the words
    ``grubler info`` prints for that scene, and the sketch drawn is the drag's
    start, open, with the dragged handle at the pointer.  A six-bar's origin O2
    dragged comes with ``shift``, the pointer: the answer is in the moved
    origin's coordinates, which the page draws shifted by it.  A drag that
    starts from a scene its builder cannot lay either (a second drag of a
    six-bar left open) draws ``drawn``, the scene whose sketch the page shows;
    ``sketch_of`` names the scene the answer's sketch is of, when not ``moved``.
    """
    try:
        out = analyse(moved, trace, live, kinematics)
        if handle == "O2":  # drawn where the drag began: the origin under the pointer, the rest where it was
            out["shift"] = [x, y]
        return out
    except AssemblyError:
        raise
    except SceneError as exc:
        problem = error_of(exc)
    sketch_of = data
    try:
        out = analyse(data, trace, live=True)  # the start: the drag began on a drawing, so it was drawn
    except AssemblyError:
        raise
    except SceneError:
        if not isinstance(drawn, dict):
            raise
        sketch_of, out = drawn, analyse(drawn, trace, live=True)
    out.update(closed=False, problem=problem, curve=[], branch=None, sketch_of=echoed(sketch_of))
    for h in out["handles"]:
        if h["id"] == handle:
            h["xy"] = [x, y]
    return out


def _finite(v, field: str) -> float:
    from grubler.limits import number

    return number(v, field)


# -- the analysis on the drawing: velocities, accelerations, instant centres, forces ---------------------------
def _xy(v) -> list:
    return [round(float(v[0]), 9), round(float(v[1]), 9)]


def analysis_view(model, z, point, zs=None, zd=None, inputs=None, method: str = "exact") -> dict:
    """What the page's analysis layer draws, at position ``z`` (:func:`grubler.mechanism.instant.analyse_instant`).

    ``points``: every joint and the traced point, with velocity ``v`` (m/s) and
    acceleration ``a`` (m/s^2); ``centres``: every pair's instant centre, a
    point ``at`` or a ``direction`` (at infinity); ``transmission``: each pin's
    angle (deg) and, over the sweep ``zs``, its least and where;
    ``toggles``: the traced point where the output stands; ``limits``: where a
    drive that cannot turn fully stops; ``advantage``;
    ``forces``: each joint's force (N) on its link.  With no ``zd`` the drive
    turns steadily at 1 rad/s (1 m/s) and the forces are those that hold it.
    """
    from grubler.mechanism.instant import analyse_instant, joint_points, turn_analysis

    res = analyse_instant(model, z, zd, inputs, method)
    mo = res.motion
    pts = []
    for joint, at in joint_points(model, mo):
        pts.append({"name": f"{joint.a}{joint.b}" if max(joint.a, joint.b) < 10 else f"{joint.a},{joint.b}",
                    "at": _xy(at), "v": _xy(mo.velocity(joint.b, at)), "a": _xy(mo.acceleration(joint.b, at))})
    if point is not None:
        k, local = point
        at = mo.world(k + 2, local)
        pts.append({"name": "trace", "at": _xy(at), "v": _xy(mo.velocity(k + 2, at)),
                    "a": _xy(mo.acceleration(k + 2, at))})
    centres = []
    for ic in res.centres:
        c = {"label": ic.label}
        if ic.point is not None:
            c["at"] = _xy(ic.point)
        elif ic.direction is not None:
            c["direction"] = _xy(ic.direction)
        centres.append(c)
    transmission = [{"label": t.label, "at": _xy(t.at), "deg": round(t.angle_deg, 4)} for t in res.transmission]
    toggles, limits = [], []
    drive_rate = "1 m/s" if model.drive and not model.arrays.revolute[model.free_index(model.drive)] else "1 rad/s"
    if zs is not None and len(zs):
        turn = turn_analysis(model, zs)
        trace = (link_points(model, zs, [point[0]], [point[1]])[:, 0, :] if point is not None else None)
        for t in transmission:
            least = turn.least.get(t["label"])
            if least is not None:
                t["least_deg"] = round(least[0], 4)
                t["least_drive"] = float(turn.drive[least[1]])
                if trace is not None:
                    t["least_at"] = _xy(trace[least[1]])
        for rows, marks in ((turn.toggles, toggles), (turn.limits, limits)):
            for row in rows:
                marks.append({"drive": float(turn.drive[row]), "at": None if trace is None else _xy(trace[row])})
    ma = res.advantage
    return {"state": "run" if zd is not None else f"drive at {drive_rate}, steady",
            "drive": model.drive, "points": pts, "centres": centres, "transmission": transmission,
            "toggles": toggles, "limits": limits,
            "advantage": None if ma is None else {"output": f"link{ma.output}", "value": ma.value, "unit": ma.unit},
            "forces": None if res.forces is None else [
                {"label": f.label, "at": _xy(f.at), "f": _xy(f.force), "moment": round(f.moment, 9)}
                for f in res.forces],
            "forces_reason": res.forces_reason}


def run_instant(data: dict, result, t, trace: str | None = None) -> dict:
    """The analysis (:func:`analysis_view`) at the run's output time nearest ``t``: its state and efforts.

    ``result`` is the session's last run; a run of another scene, or none, is
    refused, so that the arrows never show one scene's motion on another.
    """
    t = _finite(t, "at")
    scene = scene_from_dict(data)
    if result is None or result.model != scene.mechanism:
        raise InputError("at", "no run of this scene to analyse: simulate it first")
    row = int(np.clip(np.searchsorted(result.t, t), 0, len(result.t) - 1))
    if row > 0 and abs(result.t[row - 1] - t) <= abs(result.t[row] - t):
        row -= 1
    ts = float(result.t[row])
    inputs = result.constant_inputs or result.inputs_at(ts)
    point = trace_point(trace or default_trace(scene.mechanism), scene.mechanism)
    out = analysis_view(result.model, result.z[row], point, None, result.zd[row], inputs, result.method)
    out["t"] = ts
    return {"analysis": out}


# -- runs ----------------------------------------------------------------------------------------


# what the page's graphs show of a column in radians: degrees, as the scene's form writes its angles (the
# CSV and the report keep radians, as `grubler simulate --csv` writes them)
DEGREES = {"rad": "deg", "rad/s": "deg/s", "rad/s^2": "deg/s^2"}


def describe(column: str, actuators=(), unit: str | None = None) -> str:
    """A run column in words with its unit: 'theta3_d' -> 'angular rate of link 3 (theta3_d), rad/s'."""
    q = mechanism_output(column, actuators)
    words = q.label if q else column
    u = unit_of(column) if unit is None else unit
    return f"{words} ({column})" + (f", {u}" if u else "")


def plotted(column: str, values, actuators=()) -> dict:
    """A column as the graphs get it: an angle (or its rates) in degrees, its label and unit saying so."""
    u, values = unit_of(column), np.asarray(values, dtype=float)
    if u in DEGREES:
        u, values = DEGREES[u], np.degrees(values)
    return {"name": column, "label": describe(column, actuators, u), "unit": u, "f32": _f32(values)}


def run_simulation(data: dict, t_end: float | None, dt_out: float | None, torque: float | None, cancel=None,
                   trace: str | None = None, actuator_force: float | None = None):
    """Simulate the scene (the CLI's ``simulate``) and what the page plays and plots of it.

    Returns
    -------
    result : grubler.Result
        Kept by the session for the CSV export.
    view : dict
        Times, frames (at most :data:`MAX_FRAMES`, evenly spread), the traced
        point's path, every output column with its description, and the
        run's warnings (an actuator given no force holds nothing).
    ``actuator_force`` (N, pushing its points apart) is the scene's first
    actuator's, as ``grubler simulate --actuator-force NAME=N`` gives it.
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
    if actuator_force not in (None, "") and scene.mechanism.actuator_names:
        kw["actuator_forces"] = {scene.mechanism.actuator_names[0]: number(actuator_force, "actuator_force",
                                                                           unit="N")}
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
            "columns": [plotted(c, res[c], scene.mechanism.actuator_names) for c in columns],
            "summary": _summary(scene, res), "warnings": list(res.warnings)}
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
    if scene.mechanism.actuators:  # a DC motor on the crank of a boom its cylinder lifts is not its drive
        m = scene.mechanism
        raise SceneError("servo", f"{m.name or 'the scene'} is driven by its cylinder {m.actuator_names[0]}, not "
                                  f"a motor on {m.drive or 'a joint'}: its servo is the cylinder's")
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


def check_fmu_folder(d, names=("Mechanism", "DCMotor", "PID", "Encoder", "Trajectory")) -> None:
    """The FMUs the servo runs are in ``d`` (the app's ``dist/``, where ``python3 build_fmu.py`` puts them)."""
    from pathlib import Path

    d = Path(d)
    missing = [n for n in names if not (d / f"{n}.fmu").is_file()]
    if missing:
        raise InputError("servo", f"no {', '.join(m + '.fmu' for m in missing)} in {d}: build the FMUs there first "
                                  "(python3 build_fmu.py, in the folder the app was started in)")


def run_servo(data: dict, settings: dict, fmu_dir, cancel=None, unpacked=None, build_dir=None) -> dict:
    """Co-simulate the servo drive of the scene (``grubler cosim`` of :func:`grubler.system.servo.servo_system`).

    Returns the tracking error, the current and the voltages over time (every
    10th step), and the drive's and the motor's limits to hold them against.
    A scene driven by a cylinder gets the cylinder's servo instead
    (:func:`run_cylinder_servo`; its mechanism FMU is built in ``build_dir``).
    """
    from grubler.motors import load_motor
    from grubler.system import cosim
    from grubler.system.servo import servo_system

    if scene_from_dict(data).mechanism.actuators:
        return run_cylinder_servo(data, settings, fmu_dir, build_dir, cancel, unpacked)
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
            # angles in degrees, as the scene's form writes them (the servo form's move is in radians, as
            # the Trajectory FMU takes it)
            "columns": [{"name": "error", "label": "tracking error, setpoint - response (deg)", "unit": "deg",
                         "f32": _f32(np.degrees(error))},
                        {"name": "setpoint", "label": "crank angle, setpoint (deg)", "unit": "deg",
                         "f32": _f32(np.degrees(res["trajectory.position"]))},
                        {"name": "response", "label": "crank angle, response (deg)", "unit": "deg",
                         "f32": _f32(np.degrees(res["mechanism.drive_angle"]))},
                        {"name": "current", "label": "motor current (A)", "unit": "A", "f32": _f32(current)},
                        {"name": "voltage", "label": "motor voltage, applied (V)", "unit": "V", "f32": _f32(volts)},
                        {"name": "command", "label": "motor voltage, commanded (V)", "unit": "V",
                         "f32": _f32(res["motor.voltage"])}],
            "limits": {k: v for k, v in limits.items() if v is not None and math.isfinite(v)},
            "summary": f"{design.t_end:g} s at {design.step:g} s steps in {res.wall_time:.2f} s: tracking error "
                       f"up to {np.degrees(np.max(np.abs(error))):.3g} deg, current up to {np.max(np.abs(current)):.3g} A "
                       f"(limit {design.current_limit:g} A), voltage up to {np.max(np.abs(volts)):.3g} V "
                       f"(supply {design.supply_voltage:g} V)"}


def _move_cycle(model, settings: dict):
    """The servo form's move of the drive joint, there and back, as the sizing studies' duty cycle."""
    from grubler.controllers.trajectory import Trajectory
    from grubler.limits import number
    from grubler.studies.sizing import DutyCycle

    if not isinstance(settings, dict):
        raise InputError("servo", "missing: the page sends the servo settings as a JSON object")
    if model.drive is None:
        raise SceneError("drive.joint", "the move is of the scene's drive joint: name one ([drive] joint)")
    base, pos = servo_defaults(), {"low": 0.0, "low_open": True}

    def get(key, **bounds):
        v = settings.get(key)
        return number(base[key] if v in (None, "") else v, f"servo.{key}", **bounds)

    kind = settings.get("kind") or "trapezoid"
    if kind not in ("trapezoid", "scurve"):
        raise InputError("servo.kind", f"must be 'trapezoid' or 'scurve', got {brief(kind)}")
    distance, dwell = get("distance"), get("dwell", low=0.0)
    traj = Trajectory(kind, distance=distance, v_max=get("v_max", **pos), a_max=get("a_max", **pos),
                      dwell=dwell, repeat=2, reverse=True)
    start = float(model.z_from_q(model.q_ref)[model.free_index(model.drive)])
    return DutyCycle.from_trajectory(traj, (traj.move_time + dwell) * 2, start=start,
                                     name=f"{kind} move of {distance:g} rad and back")


# -- a cylinder's servo: the valve commanded by a PID on the actuator's length, as examples/cylinder_systems.py
def cylinder_servo_defaults(data: dict) -> dict | None:
    """What the cylinder servo's form starts from: the preset's design (``PRESET_DESIGNS``), or the defaults.

    None for a scene without an actuator.  Lengths in m, the move's limits in
    m/s and m/s2, the gain in valve opening per metre of error.
    """
    from grubler.motors.hydraulic import DEFAULT as HYDRAULIC
    from grubler.motors.pneumatic import DEFAULT as PNEUMATIC
    from grubler.system.cylinder_servo import PRESET_DESIGNS, CylinderServoDesign

    scene = scene_from_dict(data)
    if not scene.mechanism.actuators:
        return None
    d = PRESET_DESIGNS.get(scene.name) or CylinderServoDesign(scene.name or "scene")
    cyl = {"hydraulic": HYDRAULIC, "pneumatic": PNEUMATIC}[d.cylinder]
    return {**_sizing_move(scene.mechanism, d), "actuator": scene.mechanism.actuator_names[0], "cylinder": d.cylinder,
            "bore": d.constants.get("bore", cyl.bore), "rod": d.constants.get("rod", cyl.rod),
            "stroke": d.constants.get("stroke", cyl.stroke), "start_position": d.start_position, "move": d.move,
            "speed": d.speed, "acceleration": d.acceleration, "delay": d.delay, "K": d.pid.get("K", 0.0),
            "Ti": d.pid.get("Ti", 0.0), "Td": d.pid.get("Td", 0.0), "t_end": d.t_end, "step": d.step}


def _sizing_move(model, design) -> dict:
    """The design's move of the actuator's length as the drive joint's (what sizing takes), so that Size sizes
    the cylinder for the move Run servo makes: the drive angle at which the length has moved that far (secant
    steps from the lever dL/dx at the start), the limits over that lever.  Where the drive joint cannot go
    that far (a toggle or a dead point on the way), the largest half, quarter or eighth of the lever's
    estimate that it can ({} where not even that)."""
    from grubler.mechanism.simulate import actuator_lines

    if model.drive is None:
        return {}
    i, a = model.free_index(model.drive), model.actuator_names.index(design.actuator or model.actuator_names[0])
    z0 = assemble(model, model.z_from_q(model.q_ref))[0]

    def length(dx: float) -> float:  # the actuator's length with the drive joint moved dx from the start
        z = z0.copy()
        z[i] += dx
        z = assemble(model, z)[0]
        return float(actuator_lines(model, np.hstack([z, np.zeros_like(z)])[None, :])[0, a, 0])

    def reachable(dx: float) -> bool:  # the loop closes all the way there
        try:
            return all(math.isfinite(length(dx * k / 20)) for k in range(1, 21))
        except (GrublerError, ValueError):
            return False

    try:
        l0, h = length(0.0), 1e-6
        lever = (length(h) - l0) / h
    except (GrublerError, ValueError):
        return {}
    if not (math.isfinite(lever) and abs(lever) > 1e-9):
        return {}
    x0, f0, x1 = 0.0, -design.move, design.move / lever
    try:
        for _ in range(12):
            f1 = length(x1) - l0 - design.move
            if abs(f1) < 1e-9 or f1 == f0:
                break
            x0, f0, x1 = x1, f1, x1 - f1 * (x1 - x0) / (f1 - f0)
        found = abs(length(x1) - l0 - design.move) < 1e-6
    except (GrublerError, ValueError, ZeroDivisionError):
        found = False
    guess = design.move / lever
    distance = next((d for d in ([x1] if found else []) + [guess * f for f in (0.5, 0.25, 0.125)]
                     if math.isfinite(d) and reachable(d)), None)
    if distance is None:
        return {}
    g = lambda v: float(f"{v:.4g}")  # noqa: E731 (as a person would type it)
    return {"distance": g(distance), "v_max": g(design.speed / abs(lever)),
            "a_max": g(design.acceleration / abs(lever)), "dwell": g(design.delay), "kind": "trapezoid"}


def _cylinder_design(data: dict, settings: dict):
    """A :class:`grubler.system.cylinder_servo.CylinderServoDesign` of the scene from the form, each number checked."""
    from grubler.limits import number
    from grubler.system.cylinder_servo import CYLINDERS, PRESET_DESIGNS, CylinderServoDesign

    if not isinstance(settings, dict):
        raise InputError("servo", "missing: the page sends the servo settings as a JSON object")
    base = cylinder_servo_defaults(data)
    pos = {"low": 0.0, "low_open": True}

    def get(key, **bounds):
        v = settings.get(key)
        return number(base[key] if v in (None, "") else v, f"servo.{key}", **bounds)

    kind = settings.get("cylinder") or base["cylinder"]
    if kind not in CYLINDERS:
        raise InputError("servo.cylinder", f"must be one of {', '.join(CYLINDERS)}, got {brief(kind)}")
    preset = PRESET_DESIGNS.get(data.get("name"))
    # the preset's other constants (its seals' smoothing) where its cylinder is the one asked for
    constants = dict(preset.constants) if preset and preset.cylinder == kind else {}
    constants.update(bore=get("bore", **pos), rod=get("rod", **pos), stroke=get("stroke", **pos))
    pid = {**(preset.pid if preset else CylinderServoDesign("").pid), "K": get("K", low=0.0), "Ti": get("Ti", low=0.0),
           "Td": get("Td", low=0.0)}
    return CylinderServoDesign(scene_toml(data), actuator=base["actuator"], cylinder=kind, constants=constants,
                               start_position=get("start_position", low=0.0), move=get("move"),
                               speed=get("speed", **pos), acceleration=get("acceleration", **pos),
                               delay=get("delay", low=0.0), pid=pid, t_end=get("t_end", **pos), step=get("step", **pos))


def run_cylinder_servo(data: dict, settings: dict, fmu_dir, build_dir, cancel=None, unpacked=None) -> dict:
    """Co-simulate the scene's cylinder under position control (``grubler cosim`` of
    :func:`grubler.system.cylinder_servo.cylinder_servo_system`): the actuator's length against its setpoint,
    the chambers' pressures against the supply, the force.

    The mechanism FMU of an actuator's scene is compiled (5 to 8 s) into
    ``build_dir``/<the scene's hash>: a re-run of the same scene (a gain tuned) takes it from there.
    """
    import hashlib
    from pathlib import Path

    from grubler.system import cosim
    from grubler.system.cylinder_servo import FMU_OF, cylinder_servo_system

    design = _cylinder_design(data, settings)
    check_fmu_folder(fmu_dir, ("PID", "Trajectory", FMU_OF[design.cylinder].removesuffix(".fmu")))
    if build_dir is None:
        raise InputError("servo", "the cylinder's servo builds its mechanism FMU: give it a folder (build_dir)")
    folder = Path(build_dir) / hashlib.sha256(design.scene.encode()).hexdigest()[:16]
    folder.mkdir(parents=True, exist_ok=True)
    system = cylinder_servo_system(design, fmu_dir, name="app_cylinder_servo", build_dir=folder, reuse=True)
    act = design.actuator
    hydraulic = design.cylinder == "hydraulic"
    signals = ["trajectory.position", f"mechanism.{act}_length", "controller.u", "cylinder.pressure_a",
               "cylinder.pressure_b", "cylinder.force"]
    every = max(1, round(design.t_end / design.step / 2000))  # some 2000 rows: a graph's worth
    res = cosim.run(system, t_end=design.t_end, step=design.step, record=signals, record_every=every,
                    cancel=cancel, unpacked=unpacked)
    setpoint, length = res["trajectory.position"], res[f"mechanism.{act}_length"]
    error = setpoint - length
    pa, pb, force = res["cylinder.pressure_a"], res["cylinder.pressure_b"], res["cylinder.force"]
    # the pressure the circuit is rated for: a hydraulic supply's relief valve, a pneumatic one's supply
    supply = float(system.components["cylinder"].parameters.get("relief_pressure" if hydraulic else "supply_pressure",
                                                                math.nan))
    mm, bar = 1e3, 1e-5
    return {"t": res.t.tolist(), "wall_time": res.wall_time, "kind": "cylinder",
            "columns": [{"name": "error", "label": "tracking error, setpoint - response (mm)", "unit": "mm",
                         "f32": _f32(error * mm)},
                        {"name": "setpoint", "label": f"{act} length, setpoint (mm)", "unit": "mm",
                         "f32": _f32(setpoint * mm)},
                        {"name": "response", "label": f"{act} length, response (mm)", "unit": "mm",
                         "f32": _f32(length * mm)},
                        {"name": "pressure_a", "label": "cap side A pressure (bar)", "unit": "bar", "f32": _f32(pa * bar)},
                        {"name": "pressure_b", "label": "rod side B pressure (bar)", "unit": "bar", "f32": _f32(pb * bar)},
                        {"name": "force", "label": "cylinder force, pushing apart (kN)", "unit": "kN",
                         "f32": _f32(force * 1e-3)},
                        {"name": "command", "label": "valve command (1)", "unit": "1", "f32": _f32(res["controller.u"])}],
            "limits": {"supply_pressure": supply * bar} if math.isfinite(supply) else {},
            "summary": f"{design.t_end:g} s at {design.step:g} s steps in {res.wall_time:.2f} s: a "
                       f"{design.constants['bore'] * mm:g}/{design.constants['rod'] * mm:g} mm {design.cylinder} "
                       f"cylinder moves {act} {design.move * mm:g} mm; tracking error up to "
                       f"{np.max(np.abs(error)) * mm:.3g} mm ({abs(error[-1]) * mm:.3g} mm at the end), pressure up "
                       f"to {max(np.max(pa), np.max(pb)) * bar:.4g} bar"
                       + (f" (supply {supply * bar:.4g} bar)" if math.isfinite(supply) else "")
                       + f", force {np.min(force) * 1e-3:.4g} to {np.max(force) * 1e-3:.4g} kN"}


def run_sizing(data: dict, settings: dict) -> dict:
    """Which motor and gear ratio fit the servo's move (``grubler size --move``), ranked: the study's table.

    A scene driven by a cylinder gets the cylinder's study instead, bore x supply
    pressure over the CLI's candidates (``grubler size --cylinder ACTUATOR``).
    """
    from grubler.motors import list_motors, load_motor
    from grubler.studies.sizing import Control, size

    model = scene_from_dict(data).mechanism
    if model.actuators:
        return _cylinder_sizing(model, _move_cycle(model, settings))
    design = _servo_design(data, settings)
    cycle = _move_cycle(model, settings)
    study = size(model, cycle, [load_motor(n) for n in list_motors()], [5, 10, 20, 35, 50, 75, 100, 150],
                 supply_voltage=design.supply_voltage, current_limit=design.current_limit, control=Control.servo())
    rows = []
    for a in study.ranked + study.rejected:
        r = a.summary()
        rows.append({"motor": a.candidate.motor.name, "ratio": a.candidate.ratio, "fits": bool(a.feasible),
                     "margin": round(float(a.min_margin), 3), "binding": a.binding,
                     "peak_current": round(r["peak_current"], 3), "peak_voltage": round(r["peak_voltage"], 2),
                     "rpm": round(r["peak_motor_speed"]), "why_not": r["why_not"]})  # the summary's rpm already
    return {"cycle": cycle.name, "kind": "motor", "rows": rows}


def _cylinder_sizing(model, cycle) -> dict:
    """``grubler size --cylinder`` of the scene's first actuator, with the CLI's candidates and constants."""
    from grubler.studies.cylinder_sizing import CANDIDATE_DEFAULTS as CYLINDER_OPTIONS, size_cylinder
    from grubler.studies.sweep import parse_values

    bores = parse_values(CYLINDER_OPTIONS["bores"], "--bores", "mm")
    pressures = parse_values(CYLINDER_OPTIONS["pressures"], "--pressures", "bar")
    name = model.actuator_names[0]
    study = size_cylinder(model, name, cycle, [b * 1e-3 for b in bores], [p * 1e5 for p in pressures],
                          rod_ratio=CYLINDER_OPTIONS["rod_ratio"], constants={"stroke": CYLINDER_OPTIONS["stroke"]})
    rows = []
    for a in study.ranked + study.rejected:
        r = a.summary()
        rows.append({"cylinder": a.candidate.label, "bore": round(r["bore"], 1), "rod": round(r["rod"], 1),
                     "pressure": round(r["supply_pressure"], 1), "fits": bool(a.feasible),
                     "margin": round(float(a.min_margin), 3), "binding": a.binding,
                     "power": round(r["installed_power"], 3), "why_not": r["why_not"]})
    d = study.demand
    return {"cycle": f"{cycle.name}, by actuator {name}: force {d.force.min() / 1e3:.4g} to "
                     f"{d.force.max() / 1e3:.4g} kN, speed up to {abs(d.rate).max():.4g} m/s",
            "kind": "cylinder", "rows": rows}


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
        # named after the scene that was run, which the page may have left since (a preset picked after it)
        stem = identifier_for(Path((result.model.name or "mechanism").replace("-", "_")))
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


__all__ = ["analyse", "analysis_view", "run_instant", "catalog", "drag", "edit", "fields", "parse_scene_text",
           "preset_data", "run_simulation",
           "scene_toml", "describe", "output_columns"]
