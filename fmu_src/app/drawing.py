"""The drawing: a scene's sketch where it closes, its coupler curve, its handles and drags, and the analysis on it.

Examples
--------
>>> from grubler.app.scene_form import preset_data
>>> data = preset_data("fourbar-crank-rocker")
>>> out = analyse(data)
>>> out["class"]["grashof"]["kind"], out["class"]["mobility"]
('crank-rocker', 1)
>>> moved = drag(data, "B", 0.6, 0.9)          # the coupler-rocker pin, dragged
>>> moved["mechanism"]["coupler"], moved["mechanism"]["rocker"]
(0.8235, 0.9849)
"""

from __future__ import annotations

import json
import math
import re
from functools import lru_cache

import numpy as np

from grubler.errors import AssemblyError, InputError, SceneError
from grubler.limits import brief
from grubler.mechanism.analysis import SIX_BAR_INVERSIONS, classify
from grubler.mechanism.assembly import assemble, branches
from grubler.mechanism.builders import HANDLES, MOVES, Drawing, value
from grubler.mechanism.kinematics import link_points
from grubler.mechanism.scene import coordinate_text, scene_from_dict
from grubler.views.animation import BARREL_SHARE, Sketch, coil, trace_point, zigzag
from grubler.app.scene_form import _is_tables, echoed, edit, error_of

SWEEP_STEPS = 180  # positions of the drive over a turn for a coupler curve (2 degrees apart)
LIVE_STEPS = 90  # ... while a pivot is being dragged (4 degrees apart: the curve keeps up with the mouse)


def _frame(geo, sketch=None) -> dict:
    """A sketch's geometry as the page draws it; with its ``sketch``, each load's row carries its magnitude (N),
    which the page writes on its arrow (the geometry has the direction only)."""
    r = lambda p: [round(float(p[0]), 6), round(float(p[1]), 6)]  # noqa: E731 (a micrometre is plenty)
    return {"bars": [r(a) + r(b) for a, b in geo.bars], "joints": [r(p) for p in geo.joints],
            "fixed": [r(p) for p in geo.fixed], "blocks": [r(c) + [round(a, 6)] for c, a in geo.blocks],
            "guides": [r(p) + [round(a, 6), bool(f)] for p, a, f in geo.guides],
            "plates": [[r(p) for p in plate] for plate in geo.plates],
            # a cylinder: its barrel from the first point (as the GIFs draw it), the rod the whole line
            "actuators": [r(a) + r(b) + r(np.asarray(a) + BARREL_SHARE * (np.asarray(b) - a))
                          for a, b in geo.actuators],
            # the force elements as the GIFs draw them: a spring's zigzag (its points), a torsion spring's coil at
            # its joint (centre and its link's angle: the page draws the catalog's coil there), a load's direction
            "springs": [[r(p) for p in zigzag(a, b)] for a, b in geo.springs],
            "coils": [r(c) + [round(float(a), 6)] for c, a in geo.coils],
            "loads": [r(p) + [round(float(u[0]), 6), round(float(u[1]), 6)] + magnitude
                      for (p, u), magnitude in zip(geo.loads, _load_magnitudes(sketch, len(geo.loads)))]}


def _load_magnitudes(sketch, count: int) -> list:
    """Each drawn load's force magnitude (N) as a one-item list to append to its row (none without the sketch):
    the sketch draws the loads of nonzero force, in the scene's order."""
    if sketch is None:
        return [[] for _ in range(count)]
    return [[round(float(np.hypot(*e.force)), 9)] for e in sketch.loads]


def coil_shape() -> list:
    """A torsion spring's coil as the GIFs draw it, of radius 1 about (0, 0) with its outer end along +x: the page
    draws it at each of a frame's ``coils``, turned by its angle and scaled to the view."""
    return np.round(coil((0.0, 0.0), 1.0, 0.0), 4).tolist()


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
    pos = sketch.positions(z[None, :])[0]
    geo = sketch.geometry(pos)
    out["frame"] = _frame(geo, sketch)
    out["dims"] = dimensions(m, sketch, pos, geo.fixed)
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


def dimensions(model, sketch, pos, fixed=()) -> list[dict]:
    """Each link's name and length (its link vector's, m) with its ends where the sketch draws them, the ground's
    first: what the page writes along the links.  The ground is link 1's vector where it has one, else the
    line from each ground pivot to the next (``fixed``, the sketch's pivots: a four-bar's O2 to O4)."""
    r = lambda p: [round(float(p[0]), 6), round(float(p[1]), 6)]  # noqa: E731
    out = []
    if model.a1 > 0:
        out.append({"name": "ground", "length": model.a1, "from": [0.0, 0.0], "to": r(pos[sketch.ground_end])})
    else:
        for a, b in zip(fixed, fixed[1:]):
            if math.dist(a, b) > 1e-9:
                out.append({"name": "ground", "length": round(math.dist(a, b), 9), "from": r(a), "to": r(b)})
    for k, link in enumerate(model.links):
        if link.a > 0:
            out.append({"name": f"link{k + 2}", "length": link.a, "from": r(pos[sketch.origin[k]]),
                        "to": r(pos[sketch.end[k]])})
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
    return _tables(data, "actuator")


def _tables(data: dict, table: str) -> list:
    """The scene's ``[[table]]`` tables, in the model's order (their keys: ``table[j]``)."""
    tables = data.get(table)
    return tables if _is_tables(tables) else []


def _attachments(data: dict, model) -> list:
    """Every point a cylinder, a spring or a load is pinned at: (its key, its link 0-based (-1 the ground), point).

    The keys name the scene's fields (``actuator[0].from_point``, ``spring[1].to_point``, ``point_load[0].point``):
    the handle's id, and what dragging it sets."""
    out = []
    ends = [("actuator", list(model.actuators))] + [
        ("spring", [e for e in model.forces if e.table == "spring"])]
    for table, items in ends:
        for j, item in enumerate(items[: len(_tables(data, table))]):
            for end, k, point in (("from", item.from_link, item.from_point), ("to", item.to_link, item.to_point)):
                out.append((f"{table}[{j}].{end}_point", k - 2, point))
    loads = [e for e in model.forces if e.table == "point_load"]
    for j, load in enumerate(loads[: len(_tables(data, "point_load"))]):
        out.append((f"point_load[{j}].point", load.link - 2, load.point))
    return out


def actuator_handles(data: dict, model, z: np.ndarray, add) -> None:
    """Each actuator's and spring's two attachments and each load's point, dragged to move the point on its
    link (a ground point: in the world)."""
    for key, k, point in _attachments(data, model):
        add(key, Drawing(model, z).at(k, *point), key)


def _move_actuator(data: dict, out: dict, handle: str, x: float, y: float) -> bool:
    """An actuator's or a spring's attachment, or a load's point, dragged to (x, y): its point in its link's
    frame (False: not such a handle)."""
    found = re.fullmatch(r"(actuator|spring|point_load)\[(\d+)\]\.(from_point|to_point|point)", handle)
    if not found or int(found[2]) >= len(_tables(out, found[1])):
        return False
    model, z = _sketch(data)
    k = next((k for key, k, _ in _attachments(data, model) if key == handle), None)
    if k is None:
        return False
    # the link's origin and unit axes where the sketch closes: the point's (along, across) in that frame
    o, e_u, e_v = link_points(model, z[None, :], [k] * 3, [(0, 0), (1, 0), (0, 1)])[0]
    d = np.array([x, y]) - o
    _tables(out, found[1])[int(found[2])][found[3]] = [_r(np.dot(d, e_u - o)) + 0.0, _r(np.dot(d, e_v - o)) + 0.0]
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
            "forces_reason": res.forces_reason,
            "element_forces": element_forces(model, mo, res.z, res.zd) if res.forces is not None else []}


def element_forces(model, mo, z, zd) -> list:
    """The force elements' forces as the analysis layer draws them beside the joints': a spring's (spring,
    damper and gas, the kernel's ``<name>_force``, positive pushing its points apart) at both its ends along its
    line, a load's at its point.  A joint spring's effort is a moment at its joint: not an arrow (its graph has it).
    """
    from grubler.mechanism.simulate import force_outputs

    if not model.forces:
        return []
    along = force_outputs(model, np.concatenate([z, zd])[None, :])
    out = []
    for e in model.forces:
        if e.table == "spring":
            a, b = mo.world(e.from_link, e.from_point), mo.world(e.to_link, e.to_point)
            d = float(np.hypot(*(b - a)))
            if d > 0:
                f = float(along[f"{e.name}_force"][0]) * (b - a) / d
                out += [{"label": e.name, "at": _xy(b), "f": _xy(f)}, {"label": e.name, "at": _xy(a), "f": _xy(-f)}]
        elif e.table == "point_load" and np.hypot(*e.force) > 0:
            out.append({"label": e.name, "at": _xy(mo.world(e.link, e.point)), "f": _xy(e.force)})
    return out


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


__all__ = ["analyse", "pick_trace", "drive_sweep", "coupler_curve", "handles", "drag", "analyse_drag", "analysis_view",
           "run_instant", "default_trace", "element_forces"]
