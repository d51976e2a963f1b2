"""Mechanisms from the engineer's own parameters, as generic chain data.

Each builder turns a few familiar dimensions (a four-bar's ground, crank, coupler
and rocker; a slider-crank's crank, rod and offset; ...) into the generalised
chain of MODEL.md: link tables, closure and a closed initial configuration.  A
scene's ``[mechanism]`` table names a builder with ``type`` and gives its
parameters; the builder's output can still be overridden field by field.

Links are uniform slender bars by default (mass ``mass_per_length`` times length,
centre mid-way, I = m L^2 / 12); blocks (zero length) get ``block_mass``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from grubler.errors import InputError, SceneError, raise_all
from grubler.limits import brief, did_you_mean, parse_angle_or_number, parse_length, parse_number
from grubler.mechanism.kinematics import link_points
from grubler.quantities import scene_field

BUILDERS: dict[str, Callable[[dict, str], dict]] = {}
BUILDER_DOCS: dict[str, str] = {}
# A builder's geometry read backwards, for the editor: where its handles are on
# the drawing (HANDLES) and which of its numbers a handle dragged to a point
# sets (MOVES).  Each is registered beside the builder it undoes.
HANDLES: dict[str, Callable] = {}
MOVES: dict[str, Callable] = {}


def builder(name: str, doc: str):
    def register(fn):
        BUILDERS[name] = fn
        BUILDER_DOCS[name] = doc
        return fn
    return register


def handles_of(*names: str):
    """Register ``fn(mech, drawing) -> [(id, (x, y), sets), ...]``: the points of a
    builder's drawing a designer drags, and the parameters each one sets (in words)."""
    def register(fn):
        HANDLES.update(dict.fromkeys(names, fn))
        return fn
    return register


def moves_of(*names: str):
    """Register ``fn(mech, handle, x, y, drawing) -> bool``: set in ``mech`` (a
    builder's parameters, changed in place) the numbers that put ``handle`` at
    (x, y), m; False for a handle the builder does not have.  ``drawing()`` is
    the scene as the drag started, closed (a :class:`Drawing`)."""
    def register(fn):
        MOVES.update(dict.fromkeys(names, fn))
        return fn
    return register


class Drawing:
    """A built scene where it closes: its mechanism and real joint coordinates z."""

    def __init__(self, model, z):
        self.model, self.z = model, z

    def at(self, k: int, u: float = 0.0, v: float = 0.0) -> np.ndarray:
        """Where the point (u, v) of moving link ``k`` (0-based; -1 the ground) is, m."""
        return link_points(self.model, self.z[None, :], [k], [(u, v)])[0, 0]


def value(v) -> float:
    """A builder's number as a handle reads it (0 where it is not one yet: the drawing shows the rest)."""
    try:
        return parse_angle_or_number(v, "value")
    except InputError:
        return 0.0


def _r(v: float) -> float:
    return round(float(v), 4)  # a tenth of a millimetre: what a drag can mean


def _deg(angle: float) -> str:
    return f"{math.degrees(angle):.4g} deg"


def _left(p, q, x) -> bool:
    """Whether x lies left of the line p -> q (the builders' 'left' and 'open')."""
    return (q[0] - p[0]) * (x[1] - p[1]) - (q[1] - p[1]) * (x[0] - p[0]) >= 0


_SIDE_WORDS = {True: ("left", "open"), False: ("right", "crossed")}


def _crank_pin(mech: dict) -> tuple[float, float]:
    """A builder's crank pin from its crank and crank angle (the crank turns about the origin)."""
    crank, th = value(mech.get("crank")), value(mech.get("crank_angle", 0.0))
    return crank * math.cos(th), crank * math.sin(th)


def _move_crank(mech: dict, x: float, y: float, angle_key: str = "crank_angle") -> None:
    """The crank pin dragged: the crank's length and angle (it turns about the origin)."""
    mech["crank"] = _r(math.hypot(x, y))
    mech[angle_key] = _deg(math.atan2(y, x))


class _Params:
    """Reads a builder's parameters with defaults, naming the field on error."""

    def __init__(self, params: dict, prefix: str, allowed: dict[str, float | str | None]):
        self.prefix = prefix
        unknown = sorted(set(params) - set(allowed) - {"type"})
        self.values = {k: params.get(k, v) for k, v in allowed.items()}
        # every unknown and every missing parameter at once
        raise_all([SceneError(f"{prefix}.{key}", f"unknown parameter{did_you_mean(key, allowed)}; "
                                                 f"this builder takes {', '.join(allowed)}") for key in unknown]
                  + [SceneError(f"{prefix}.{k}", "is required") for k, v in self.values.items() if v is None])

    def length(self, key: str, allow_zero: bool = False) -> float:
        v = self.signed_length(key)
        if v < 0 or (v == 0 and not allow_zero):
            raise SceneError(f"{self.prefix}.{key}", f"length must be {'>= 0' if allow_zero else 'positive'}, got {v}")
        return v

    def positive(self, key: str) -> float:
        v = self.number(key)
        if v <= 0:
            raise SceneError(f"{self.prefix}.{key}", f"must be positive, got {v}")
        return v

    def number(self, key: str) -> float:
        """A plain number (a mass, an inertia) in its SI unit (the one table's: quantities.scene_field)."""
        return parse_number(self.values[key], f"{self.prefix}.{key}", scene_field(key).unit)

    def angle(self, key: str) -> float:
        return parse_angle_or_number(self.values[key], f"{self.prefix}.{key}")

    def signed_length(self, key: str) -> float:
        """A length that may be negative (an offset), m: an angle is refused (parse_length)."""
        return parse_length(self.values[key], f"{self.prefix}.{key}")


def bar(joint: str, length: float, mass_per_length: float, **extra) -> dict:
    """A uniform slender bar along the link vector."""
    m = mass_per_length * length
    d = {"joint": joint, "a": length, "p": length / 2, "q": 0.0, "m": m, "I": m * length**2 / 12}
    d.update(extra)
    return d


def block(joint: str, mass: float, a: float = 0.0) -> dict:
    return {"joint": joint, "a": a, "p": 0.0, "q": 0.0, "m": mass, "I": 0.0}


_BARS = {"mass_per_length": 1.0, "block_mass": 0.5}


@builder("four-bar", "ground, crank, coupler, rocker (m); crank_angle (rad or 'N deg'); branch 'open'|'crossed'")
def four_bar(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"ground": None, "crank": None, "coupler": None, "rocker": None,
                                 "crank_angle": 0.0, "branch": "open", **_BARS})
    g, r2, r3, r4 = (p.length(k) for k in ("ground", "crank", "coupler", "rocker"))
    th2 = p.angle("crank_angle")
    branch = p.values["branch"]
    if branch not in ("open", "crossed"):
        raise SceneError(f"{prefix}.branch", f"must be 'open' or 'crossed', got {brief(branch)}")
    rho = p.positive("mass_per_length")
    # a guess on the chosen branch; assembly makes it exact (or says why it cannot)
    px, py = r2 * math.cos(th2), r2 * math.sin(th2)
    dx, dy = g - px, -py
    d = math.hypot(dx, dy)
    base = math.atan2(dy, dx)
    cos_b = 0.0 if d == 0 else max(-1.0, min(1.0, (r3 * r3 + d * d - r4 * r4) / (2 * r3 * d)))
    th3 = base + (1 if branch == "open" else -1) * math.acos(cos_b)
    ox, oy = px + r3 * math.cos(th3), py + r3 * math.sin(th3)
    th4 = math.atan2(-oy, g - ox)
    return {
        "links": [bar("R", r2, rho), bar("R", r3, rho), bar("R", r4, rho)],
        "closure": {"type": "revolute", "point": [g, 0.0]},
        "initial": {"theta2": th2, "theta3": th3, "theta4": th4},
        "drive": "theta2",
    }


@handles_of("four-bar")
def _four_bar_handles(mech: dict, d: Drawing) -> list:
    return [("A", d.at(0, d.model.links[0].a), "mechanism.crank, mechanism.crank_angle"),
            ("B", d.at(1, d.model.links[1].a), "mechanism.coupler, mechanism.rocker, mechanism.branch"),
            ("O4", (value(mech.get("ground")), 0.0), "mechanism.ground")]


@moves_of("four-bar")
def _four_bar_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle == "A":
        _move_crank(mech, x, y)
    elif handle == "B":  # the coupler and rocker meet there, on the side of the line A-O4 it lies
        (ax, ay), ground = _crank_pin(mech), value(mech.get("ground"))
        mech["coupler"] = _r(math.hypot(x - ax, y - ay))
        mech["rocker"] = _r(math.hypot(x - ground, y))
        mech["branch"] = _SIDE_WORDS[_left((ax, ay), (ground, 0.0), (x, y))][1]
    elif handle == "O4":
        mech["ground"] = _r(x)  # the pivot's distance, on its axis
    else:
        return False
    return True


@builder("slider-crank", "crank, rod (m), offset of the slide line (m); crank_angle; slider_mass")
def slider_crank(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"crank": None, "rod": None, "offset": 0.0, "crank_angle": 0.0,
                                 "slider_mass": 1.0, **_BARS})
    r2, r3 = p.length("crank"), p.length("rod")
    e = p.signed_length("offset")
    th2 = p.angle("crank_angle")
    rho = p.positive("mass_per_length")
    s = (e - r2 * math.sin(th2)) / r3
    th3 = math.asin(max(-1.0, min(1.0, s)))
    return {
        "links": [bar("R", r2, rho), bar("R", r3, rho), block("R", p.positive("slider_mass"))],
        "closure": {"type": "prismatic", "point": [0.0, e], "angle": 0.0, "psi": 0.0},
        "initial": {"theta2": th2, "theta3": th3, "theta4": 0.0},
        "drive": "theta2",
    }


@handles_of("slider-crank")
def _slider_crank_handles(mech: dict, d: Drawing) -> list:
    return [("A", d.at(0, d.model.links[0].a), "mechanism.crank, mechanism.crank_angle"),
            ("slider", d.at(2), "mechanism.rod, mechanism.offset")]


@moves_of("slider-crank")
def _slider_crank_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle == "A":
        _move_crank(mech, x, y)
    elif handle == "slider":  # the block: the slide line through it, the rod from the crank pin to it
        mech["rod"], mech["offset"] = _r(math.dist(_crank_pin(mech), (x, y))), _r(y)
    else:
        return False
    return True


@builder("quick-return", "crank, ground (pivot distance, lever pivot below the crank's), lever (m); crank_angle")
def quick_return(params: dict, prefix: str) -> dict:
    # Whitworth (ground < crank) or crank-shaper (ground > crank): the crank pin's
    # block slides along a slotted lever pivoted at (0, -ground)
    p = _Params(params, prefix, {"crank": None, "ground": None, "lever": None, "crank_angle": 0.0, **_BARS})
    r2, d, lever = p.length("crank"), p.length("ground"), p.length("lever")
    th2 = p.angle("crank_angle")
    rho = p.positive("mass_per_length")
    pin = (r2 * math.cos(th2), r2 * math.sin(th2))
    to_pivot = (-pin[0], -d - pin[1])
    th4 = math.atan2(to_pivot[1], to_pivot[0])
    return {
        "links": [bar("R", r2, rho), block("R", p.positive("block_mass")), bar("P", lever, rho)],
        "closure": {"type": "revolute", "point": [0.0, -d]},
        "initial": {"theta2": th2, "theta3": th4 - math.pi / 2, "B3": math.hypot(*to_pivot) - lever,
                    "theta4": th4},
        "drive": "theta2",
    }


@handles_of("quick-return")
def _quick_return_handles(mech: dict, d: Drawing) -> list:
    return [("A", d.at(0, d.model.links[0].a), "mechanism.crank, mechanism.crank_angle"),
            ("pivot", (0.0, -value(mech.get("ground"))), "mechanism.ground"),
            ("lever", d.at(2), "mechanism.lever")]


@moves_of("quick-return")
def _quick_return_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle == "A":
        _move_crank(mech, x, y)
    elif handle == "pivot":  # the lever's pivot, below the crank's
        mech["ground"] = _r(-y)
    elif handle == "lever":
        mech["lever"] = _r(math.dist((0.0, -value(mech.get("ground"))), (x, y)))
    else:
        return False
    return True


@builder("swinging-block", "crank, ground (pivot distance), rod (m); crank_angle")
def swinging_block(params: dict, prefix: str) -> dict:
    # oscillating cylinder: a rod pinned to the crank slides through a block
    # pivoted on the ground at (ground, 0)
    p = _Params(params, prefix, {"crank": None, "ground": None, "rod": None, "crank_angle": 0.0, **_BARS})
    r2, d, rod = p.length("crank"), p.length("ground"), p.length("rod")
    th2 = p.angle("crank_angle")
    rho = p.positive("mass_per_length")
    pin = (r2 * math.cos(th2), r2 * math.sin(th2))
    to_pivot = (d - pin[0], -pin[1])
    th3 = math.atan2(to_pivot[1], to_pivot[0]) - math.pi / 2
    m_rod = rho * rod
    rod_link = {"joint": "R", "a": 0.0, "p": 0.0, "q": rod / 2, "m": m_rod, "I": m_rod * rod**2 / 12}
    return {
        "links": [bar("R", r2, rho), rod_link, block("P", p.positive("block_mass"))],
        "closure": {"type": "revolute", "point": [d, 0.0]},
        "initial": {"theta2": th2, "theta3": th3, "B3": math.hypot(*to_pivot), "theta4": th3 + math.pi / 2},
        "drive": "theta2",
    }


@handles_of("swinging-block")
def _swinging_block_handles(mech: dict, d: Drawing) -> list:
    return [("A", d.at(0, d.model.links[0].a), "mechanism.crank, mechanism.crank_angle"),
            ("pivot", (value(mech.get("ground")), 0.0), "mechanism.ground")]  # the block's ground pivot


@moves_of("swinging-block")
def _swinging_block_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle == "A":
        _move_crank(mech, x, y)
    elif handle == "pivot":
        mech["ground"] = _r(x)
    else:
        return False
    return True


@builder("pendulum-pump", "crank (pivot to pin), link, rod (m), offset (m, slide line from the pivot); crank_angle")
def pendulum_pump(params: dict, prefix: str) -> dict:
    # slider-crank with the slider fixed (second inversion): a vertical rod slides
    # through a block fixed at x = offset; the crank swings about the origin
    p = _Params(params, prefix, {"crank": None, "link": None, "rod": None, "offset": None,
                                 "crank_angle": 0.0, **_BARS})
    r2, r3, rod = p.length("crank"), p.length("link"), p.length("rod")
    e = p.signed_length("offset")
    th2 = p.angle("crank_angle")
    rho = p.positive("mass_per_length")
    px = r2 * math.cos(th2)
    c = max(-1.0, min(1.0, (e - px) / r3))
    th3 = math.acos(c)
    return {
        "links": [bar("R", r2, rho), bar("R", r3, rho), bar("R", rod, rho)],
        "closure": {"type": "prismatic", "link": 4, "at": [0.0, 0.0], "point": [e, 0.0],
                    "angle": math.pi / 2, "psi": math.pi / 2},
        "initial": {"theta2": th2, "theta3": th3, "theta4": math.pi / 2},
        "drive": "theta2",
    }


@handles_of("pendulum-pump")
def _pendulum_pump_handles(mech: dict, d: Drawing) -> list:
    return [("A", d.at(0, d.model.links[0].a), "mechanism.crank, mechanism.crank_angle"),
            ("slide", (value(mech.get("offset")), 0.0), "mechanism.offset"),
            ("C", d.at(2), "mechanism.link, mechanism.offset"),
            ("rod", d.at(2, d.model.links[2].a), "mechanism.rod")]


@moves_of("pendulum-pump")
def _pendulum_pump_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle == "A":
        _move_crank(mech, x, y)
    elif handle == "slide":
        mech["offset"] = _r(x)
    elif handle == "C":  # the pump's link and rod pin: on the slide line, which follows it
        mech["link"], mech["offset"] = _r(math.dist(_crank_pin(mech), (x, y))), _r(x)
    elif handle == "rod":
        mech["rod"] = _r(math.dist(drawing().at(2), (x, y)))
    else:
        return False
    return True


@builder("scotch-yoke", "crank (m); crank_angle; yoke_mass, block_mass")
def scotch_yoke(params: dict, prefix: str) -> dict:
    # yoke slides on x, the block on the yoke along y, the crank turns about the origin
    p = _Params(params, prefix, {"crank": None, "crank_angle": 0.0, "yoke_mass": 1.0, **_BARS})
    r = p.length("crank")
    th = p.angle("crank_angle")
    rho = p.positive("mass_per_length")
    return {
        "ground": {"theta1": math.pi / 2},
        "links": [block("P", p.positive("yoke_mass")), block("P", p.positive("block_mass")), bar("R", r, rho)],
        "closure": {"type": "revolute", "point": [0.0, 0.0]},
        "initial": {"B1": -r * math.cos(th), "theta2": 0.0, "B2": r * math.sin(th), "theta3": 0.0,
                    "theta4": th + math.pi},
        "drive": "theta4",
    }


@handles_of("scotch-yoke")
def _scotch_yoke_handles(mech: dict, d: Drawing) -> list:
    return [("A", d.at(2), "mechanism.crank, mechanism.crank_angle")]


@moves_of("scotch-yoke")
def _scotch_yoke_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle != "A":
        return False
    _move_crank(mech, x, y)
    return True


@builder("oldham", "offset (m, between the shafts); shaft_angle; disc_mass, disc_inertia, shaft_mass, shaft_inertia")
def oldham(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"offset": None, "shaft_angle": 0.0, "disc_mass": 0.5, "disc_inertia": 1e-3,
                                 "shaft_mass": 1.0, "shaft_inertia": 1e-3})
    d = p.length("offset")
    th = p.angle("shaft_angle")
    ms, Is = p.positive("shaft_mass"), p.number("shaft_inertia")
    shaft = {"joint": "R", "a": 0.0, "p": 0.0, "q": 0.0, "m": ms, "I": Is}
    disc = {"joint": "P", "a": 0.0, "p": 0.0, "q": 0.0, "m": p.positive("disc_mass"), "I": p.number("disc_inertia")}
    out_shaft = dict(shaft, joint="P")
    # the disc centre sits where the two perpendicular slots cross (Thales circle)
    return {
        "links": [shaft, disc, out_shaft],
        "closure": {"type": "revolute", "point": [d, 0.0]},
        "initial": {"theta2": th, "B2": -d * math.sin(th), "theta3": th + math.pi / 2,
                    "B3": -d * math.cos(th), "theta4": th + math.pi / 2},
        "drive": "theta2",
    }


@handles_of("oldham")
def _oldham_handles(mech: dict, d: Drawing) -> list:
    # the output shaft's pivot; a point on the input shaft's slot, offset from its pivot
    th, off = value(mech.get("shaft_angle", 0.0)) + math.pi / 2, value(mech.get("offset"))
    return [("shaft2", d.at(-1, *d.model.closures[0].to_point), "mechanism.offset"),
            ("slot", (off * math.cos(th), off * math.sin(th)), "mechanism.shaft_angle")]


@moves_of("oldham")
def _oldham_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle == "shaft2":
        mech["offset"] = _r(x)
    elif handle == "slot":
        mech["shaft_angle"] = _deg(math.atan2(y, x) - math.pi / 2)
    else:
        return False
    return True


@builder("double-slider", "coupler (m); axes_angle (between the slides, default 90 deg: elliptic trammel); "
                          "coupler_angle")
def double_slider(params: dict, prefix: str) -> dict:
    # first slide along x through the origin, second along a line through the
    # origin at axes_angle; the coupler joins the two blocks
    p = _Params(params, prefix, {"coupler": None, "axes_angle": math.pi / 2, "coupler_angle": "45 deg", **_BARS})
    L = p.length("coupler")
    alpha = p.angle("axes_angle")
    if abs(math.sin(alpha)) < 1e-9:
        raise SceneError(f"{prefix}.axes_angle", "the two slides must not be parallel")
    th3 = p.angle("coupler_angle")
    rho = p.positive("mass_per_length")
    # x1 + L e(th3) = s e(alpha): solve for the first block's x
    s = L * math.sin(th3) / math.sin(alpha)
    x1 = s * math.cos(alpha) - L * math.cos(th3)
    mb = p.positive("block_mass")
    return {
        "ground": {"theta1": math.pi / 2},
        "links": [block("P", mb), bar("R", L, rho), block("R", mb)],
        "closure": {"type": "prismatic", "point": [0.0, 0.0], "angle": alpha, "psi": 0.0},
        "initial": {"B1": -x1, "theta2": 0.0, "theta3": th3, "theta4": 0.0},
        "drive": "theta3",
    }


@handles_of("double-slider")
def _double_slider_handles(mech: dict, d: Drawing) -> list:
    return [("block1", d.at(0), "mechanism.coupler, mechanism.coupler_angle"),
            ("block2", d.at(2), "mechanism.coupler, mechanism.coupler_angle, mechanism.axes_angle")]


@moves_of("double-slider")
def _double_slider_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle not in ("block1", "block2"):
        return False
    # one block moved, the other kept: the coupler between them
    d = drawing()
    one, two = d.at(0), d.at(2)
    if handle == "block1":
        one = np.array([x, 0.0])  # the first slide: the x axis
    else:
        two = np.array([x, y])
        mech["axes_angle"] = _deg(math.atan2(y, x))
    mech["coupler"] = _r(math.dist(one, two))
    mech["coupler_angle"] = _deg(math.atan2(two[1] - one[1], two[0] - one[0]))
    return True


@builder("conchoidal", "height (m, pivot to the guide line), arm (m, offset of the rod from the pivot), "
                       "rod (m), rod_angle (direction of the rod)")
def conchoidal(params: dict, prefix: str) -> dict:
    # a rod turns about the origin; a block slides on it and is pinned to a
    # second block that runs along the line y = height.  The rod is the slide
    # axis of link 2, e_perp(theta2), so theta2 = rod_angle - 90 deg.
    p = _Params(params, prefix, {"height": None, "arm": 0.0, "rod_angle": "60 deg", "rod": 2.0, **_BARS})
    h = p.length("height")
    arm = p.length("arm", allow_zero=True)
    rod = p.length("rod")
    along = p.angle("rod_angle")
    if abs(math.sin(along)) < 1e-9:
        raise SceneError(f"{prefix}.rod_angle", "a rod parallel to the guide line never meets it")
    th2 = along - math.pi / 2
    b2 = (h - arm * math.sin(th2)) / math.sin(along)
    rho = p.positive("mass_per_length")
    mb = p.positive("block_mass")
    m_rod = rho * rod
    rod_link = {"joint": "R", "a": arm, "p": 0.0, "q": rod / 2, "m": m_rod, "I": m_rod * rod**2 / 12}
    return {
        "ground": {"theta1": math.pi / 2},
        "links": [rod_link, block("P", mb), block("R", mb)],
        "closure": {"type": "prismatic", "point": [0.0, h], "angle": 0.0, "psi": 0.0},
        "initial": {"theta2": th2, "B2": b2, "theta3": th2, "theta4": 0.0},
        "drive": "theta2",
    }


def _rod_angle(pin, arm: float) -> float:
    """The conchoidal's rod direction through ``pin`` that passes the pivot at ``arm`` (its foot's side)."""
    d = max(math.hypot(*pin), arm)  # a pin nearer than the arm: the rod as near as it can pass
    return math.atan2(pin[1], pin[0]) - math.acos(arm / d) + math.pi / 2


@handles_of("conchoidal")
def _conchoidal_handles(mech: dict, d: Drawing) -> list:
    return [("block", d.at(2), "mechanism.height, mechanism.rod_angle"),
            ("arm", d.at(0, d.model.links[0].a), "mechanism.arm, mechanism.rod_angle")]


@moves_of("conchoidal")
def _conchoidal_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    if handle not in ("block", "arm"):
        return False
    # the rod passes the pivot at `arm` and through the blocks' pin
    pin = drawing().at(2)
    if handle == "block":
        pin = np.array([x, y])
        mech["height"] = _r(y)
    else:
        mech["arm"] = _r(math.hypot(x, y))
    mech["rod_angle"] = _deg(_rod_angle(pin, value(mech.get("arm", 0.0))))
    return True


# -- six-link chains ----------------------------------------------------------------
# A six-bar is five moving links from the ground and two closures: in series, or
# branching where no path from the ground passes through every link (Stephenson
# III).  The builders below take what a designer dimensions (pivot positions,
# pin-to-pin lengths, each ternary link's triangle by its three sides) and lay the
# chain through the links; a ternary link is a link of the chain whose third joint
# is a point in its frame that a closure attaches to, or that a second child
# hangs from.

def _circles(p, q, r_p: float, r_q: float, sign: int, what: str, prefix: str):
    """Where a link of length r_p from p meets one of length r_q from q (sign: left/right of p -> q)."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    d = math.hypot(dx, dy)
    if d == 0 or d > r_p + r_q or d < abs(r_p - r_q):
        raise SceneError(f"{prefix}.input_angle",
                         f"{what}: its ends are {d:.6g} m apart but the links ({r_p:.6g} m, {r_q:.6g} m) only "
                         f"span {abs(r_p - r_q):.6g} to {r_p + r_q:.6g} m (triangle inequality)")
    along = (r_p * r_p - r_q * r_q + d * d) / (2 * d)
    h = math.sqrt(max(r_p * r_p - along * along, 0.0))
    ux, uy = dx / d, dy / d
    return (p[0] + along * ux - sign * h * uy, p[1] + along * uy + sign * h * ux)


def _triangle(p, q, r_p: float, r_q: float, side: int, what: str, prefix: str, keys: str):
    """Third vertex of a rigid triangle on the edge p -> q (side +1: left)."""
    d = math.hypot(q[0] - p[0], q[1] - p[1])
    if d > r_p + r_q or d < abs(r_p - r_q):
        raise SceneError(f"{prefix}.{keys}", f"{what}: sides {d:.6g}, {r_p:.6g}, {r_q:.6g} m make no triangle")
    return _circles(p, q, r_p, r_q, side, what, prefix)


def _plate(points, rho: float) -> dict:
    """Mass, centre and inertia of a link drawn as bars between its joints (a ternary: three bars)."""
    bars = [(points[i], points[j]) for i in range(len(points)) for j in range(i + 1, len(points))]
    m = sum(rho * math.dist(a, b) for a, b in bars)
    cx = sum(rho * math.dist(a, b) * (a[0] + b[0]) / 2 for a, b in bars) / m
    cy = sum(rho * math.dist(a, b) * (a[1] + b[1]) / 2 for a, b in bars) / m
    inertia = sum(rho * math.dist(a, b) * (math.dist(a, b) ** 2 / 12
                                           + ((a[0] + b[0]) / 2 - cx) ** 2 + ((a[1] + b[1]) / 2 - cy) ** 2)
                  for a, b in bars)
    return {"m": m, "p": cx, "q": cy, "I": inertia}


def _six_link_chain(world: dict, chain: list, closures: list, rho: float, parents: list | None = None) -> dict:
    """Links, closures and the initial angles of a chain laid through joint positions.

    ``world``: joint name -> position at the sketch; ``chain``: per moving link
    (in chain order from the ground) its joint, the joint its vector points at,
    and its other joints; ``closures``: (joint, link carrying it, link it is
    pinned to; 1 is the ground); ``parents``: each link's predecessor (thesis
    numbering, 1 the ground), None for the serial chain.  A child's joint is the
    first joint of its entry: when that is not where the vector points (a
    ternary crank whose angle is the designer's input angle), it sits at (a, B)
    in this link's frame, a the distance along the vector and B the locked slide
    across it; should it lie behind the joint (a < 0), the vector points at it
    instead.  A link with two children carries both on the line across its
    vector's end: the vector points at the foot of the perpendicular from the
    link's joint to the line through the children's joints.
    """
    n = len(chain)
    parents = list(parents) if parents else [k + 1 for k in range(n)]
    links, frames, initial = [], [], {}
    for k, (origin, to, *extra) in enumerate(chain):
        kids = [c for c in range(n) if parents[c] == k + 2]
        if len(kids) > 2:
            raise ValueError(f"link{k + 2}: at most two links hang from one link")  # builders' own data
        nxt = chain[kids[0]][0] if kids else to
        names = (origin, to, *extra)
        o = world[origin]

        def frame(th):
            c, s = math.cos(th), math.sin(th)
            return th, {n: ((world[n][0] - o[0]) * c + (world[n][1] - o[1]) * s,
                            -(world[n][0] - o[0]) * s + (world[n][1] - o[1]) * c) for n in names}

        def toward(name):
            return math.atan2(world[name][1] - o[1], world[name][0] - o[0])

        if len(kids) == 2:
            p1, p2 = world[chain[kids[0]][0]], world[chain[kids[1]][0]]
            ux, uy = p2[0] - p1[0], p2[1] - p1[1]
            t = ((o[0] - p1[0]) * ux + (o[1] - p1[1]) * uy) / (ux * ux + uy * uy)
            fx, fy = p1[0] + t * ux - o[0], p1[1] + t * uy - o[1]  # the foot, from the joint
            on_line = math.hypot(fx, fy) <= 1e-12 * math.hypot(ux, uy)
            th, local = frame(math.atan2(uy, ux) - math.pi / 2 if on_line else math.atan2(fy, fx))
        else:
            th, local = frame(toward(to))
            if local[nxt][0] < 0:
                th, local = frame(toward(nxt))
        frames.append(local)
        links.append({"joint": "R", "a": local[nxt][0], **_plate([local[x] for x in names], rho)})
        if parents[k] != k + 1:
            links[-1]["parent"] = parents[k]
        initial[f"theta{k + 2}"] = th
        for c in kids:
            at = local[chain[c][0]]
            if abs(at[1]) > 1e-12 * max(1.0, abs(at[0])):
                initial[f"B{c + 1}"] = at[1]
    out = []
    for joint, link, to_link in closures:
        d = {"type": "revolute", "link": link, "at": list(frames[link - 2][joint]), "to_link": to_link}
        d["point"] = list(world[joint]) if to_link == 1 else list(frames[to_link - 2][joint])
        out.append(d)
    return {"links": links, "closure": out, "initial": initial, "drive": "theta2"}


def _branch(p: _Params, key: str) -> int:
    v = p.values[key]
    if v not in ("open", "crossed"):
        raise SceneError(f"{p.prefix}.{key}", f"must be 'open' or 'crossed', got {v!r}")
    return 1 if v == "open" else -1


def _side(p: _Params, key: str) -> int:
    v = p.values[key]
    if v not in ("left", "right"):
        raise SceneError(f"{p.prefix}.{key}", f"must be 'left' or 'right', got {v!r}")
    return 1 if v == "left" else -1


def _point(p: _Params, key: str) -> tuple[float, float]:
    v = p.values[key]
    if not (isinstance(v, (list, tuple)) and len(v) == 2):
        raise SceneError(f"{p.prefix}.{key}", f"must be [x, y], got {v!r}")
    return (parse_length(v[0], f"{p.prefix}.{key}"), parse_length(v[1], f"{p.prefix}.{key}"))


_SIX = {"input_angle": 0.0, "mass_per_length": 1.0}


@dataclass(frozen=True)
class Place:
    """One joint of a six-bar laid from two joints already placed: ``joint`` at
    length ``to_p`` from ``p`` and ``to_q`` from ``q``, on the side ``side``
    picks (a builder's 'left'/'right' or 'open'/'crossed': left of p -> q).
    ``dyad``: two links meeting at the joint (a loop, refused at the input
    angle); otherwise the third vertex of a ternary link's triangle (refused at
    its third side, ``to_q``)."""
    joint: str
    p: str
    q: str
    to_p: str
    to_q: str
    side: str
    what: str
    dyad: bool


@dataclass(frozen=True)
class SixBar:
    """A six-link chain as data: what a designer dimensions and how the joints follow from it.

    ``params`` are the builder's parameters with their defaults (None: required).
    The crank ``pin`` turns about the origin O2 at the input angle; ``pivots``
    are the other ground joints (joint -> parameter); ``places`` lay the other
    joints in turn.  A Stephenson II is a triad, not two dyads: ``triad`` =
    (angle parameter, joint, length parameter) lays that joint at the length
    from the crank pin in the direction the angle sketches, and ``closes`` =
    (joint, joint, length parameter) is the length the places leave open: the
    directions at which it closes are the branches, the nearest the sketch's
    taken.  ``chain``, ``closures`` and ``parents`` are :func:`_six_link_chain`'s.
    """
    doc: str
    params: dict
    pin: str
    pivots: dict
    places: tuple
    chain: tuple
    closures: tuple
    parents: tuple | None = None
    triad: tuple | None = None
    closes: tuple | None = None
    lengths: tuple = field(init=False)
    sides: dict = field(init=False)
    ends: dict = field(init=False)

    def __post_init__(self):
        # the lengths: the parameters a designer must give, but for the pivots' positions
        object.__setattr__(self, "lengths", tuple(k for k, v in self.params.items()
                                                  if v is None and k not in self.pivots.values()))
        # each length parameter's two joints, each side parameter's three (p, q and the joint it places)
        ends = {pl.to_p: (pl.p, pl.joint) for pl in self.places} | {pl.to_q: (pl.q, pl.joint) for pl in self.places}
        if self.triad:
            ends[self.triad[2]] = (self.pin, self.triad[1])
        if self.closes:
            ends[self.closes[2]] = self.closes[:2]
        object.__setattr__(self, "ends", {k: ends[k] for k in self.lengths if k in ends})
        object.__setattr__(self, "sides", {pl.side: (pl.p, pl.q, pl.joint) for pl in self.places})

    @property
    def joints(self) -> tuple:
        """The seven joints: the links' origins in chain order, then the closures' joints."""
        return (*(c[0] for c in self.chain), *(c[0] for c in self.closures))

    @property
    def moving(self) -> set:
        """The joints that are neither on the ground nor the crank pin."""
        return set(self.joints[1:]) - set(self.pivots) - {self.pin}


def _place(pl: Place, w: dict, L: dict, signs: dict, prefix: str) -> None:
    lay = _circles if pl.dyad else _triangle
    extra = () if pl.dyad else (pl.to_q,)
    w[pl.joint] = lay(w[pl.p], w[pl.q], L[pl.to_p], L[pl.to_q], signs[pl.side], pl.what, prefix, *extra)


def _six_bar(sb: SixBar, params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, sb.params)
    L = {k: p.length(k) for k in sb.lengths}
    th = p.angle("input_angle")
    w = {"O2": (0.0, 0.0), **{joint: _point(p, key) for joint, key in sb.pivots.items()}}
    w[sb.pin] = (L["crank"] * math.cos(th), L["crank"] * math.sin(th))
    signs = {pl.side: (_branch if pl.side.startswith("branch") else _side)(p, pl.side) for pl in sb.places}
    if sb.triad:
        _lay_triad(sb, p, w, L, signs, prefix)
    else:
        for pl in sb.places:
            _place(pl, w, L, signs, prefix)
    return _six_link_chain(w, list(sb.chain), list(sb.closures), p.positive("mass_per_length"),
                           parents=list(sb.parents) if sb.parents else None)


def _lay_triad(sb: SixBar, p: _Params, w: dict, L: dict, signs: dict, prefix: str) -> None:
    # a triad, not a dyad: no closed form from the input.  Given the floating
    # ternary's direction phi, the places follow and the miss of the closing
    # length is a function of phi alone: its roots are the branches.  The
    # sketch is the root nearest the angle given.
    key, joint, length = sb.triad
    end1, end2, closing = sb.closes
    phi = p.angle(key)
    pin = w[sb.pin]

    def place(angle):
        w[joint] = (pin[0] + L[length] * math.cos(angle), pin[1] + L[length] * math.sin(angle))
        for pl in sb.places:
            _place(pl, w, L, signs, prefix)
        return math.dist(w[end1], w[end2]) - L[closing]

    def miss(angle):
        try:
            return place(angle)
        except SceneError:
            return math.nan

    grid = [phi + 2 * math.pi * i / 720 for i in range(-360, 361)]  # outward from the sketch
    grid.sort(key=lambda a: abs(a - phi))
    values = {a: miss(a) for a in grid}
    roots = []
    ordered = sorted(grid)
    for a, b in zip(ordered, ordered[1:]):
        fa, fb = values[a], values[b]
        if fa == fa and fb == fb and fa * fb <= 0:
            for _ in range(60):  # bisection: exact to rounding, no derivative needed
                mid = 0.5 * (a + b)
                fm = miss(mid)
                if not fm == fm:
                    break
                a, b, fa = (a, mid, fa) if fa * fm <= 0 else (mid, b, fm)
            roots.append(0.5 * (a + b))
    if not roots:
        branch = next(pl.side for pl in sb.places if pl.side.startswith("branch"))
        raise SceneError(f"{prefix}.input_angle",
                         f"no direction of the floating ternary closes the loop through {closing} at this input "
                         f"angle (the rocker hanging on the '{p.values[branch]}' side)")
    place(min(roots, key=lambda a: abs(a - phi)))


SIX_BARS = {
    "watt-ii": SixBar(
        "Watt II (ground ternary): two four-bars in series.  Crank O2A from the origin, coupler AB, rocker triangle "
        "at pivot O4 [rocker (O4B), rocker_arm (O4C), rocker_web (BC), rocker_side], coupler2 CD, output DO6; "
        "pivots rocker_pivot O4, output_pivot O6; branches branch1, branch2",
        {"crank": None, "coupler": None, "rocker": None, "rocker_arm": None, "rocker_web": None,
         "rocker_side": "left", "coupler2": None, "output": None, "rocker_pivot": None, "output_pivot": None,
         "branch1": "open", "branch2": "open", **_SIX},
        "A", {"O4": "rocker_pivot", "O6": "output_pivot"},
        (Place("B", "A", "O4", "coupler", "rocker", "branch1", "loop 1 (crank, coupler, rocker): triangle A-B-O4",
               True),
         Place("C", "O4", "B", "rocker_arm", "rocker_web", "rocker_side", "the rocker's triangle O4-B-C", False),
         Place("D", "C", "O6", "coupler2", "output", "branch2",
               "loop 2 (rocker arm, coupler2, output): triangle C-D-O6", True)),
        (("O2", "A"), ("A", "B"), ("B", "C", "O4"), ("C", "D"), ("D", "O6")), (("O4", 4, 1), ("O6", 6, 1))),
    "watt-i": SixBar(
        "Watt I (ground binary): a four-bar whose ternary crank and ternary coupler carry a dyad.  Crank triangle "
        "at the origin O2 [crank (O2A), crank_arm (O2C), crank_web (AC), crank_side], coupler triangle [coupler "
        "(AB), coupler_arm (AE), coupler_web (BE), coupler_side], rocker BO4 at rocker_pivot O4, dyad link5 CD and "
        "link6 DE; branches branch1, branch2",
        {"crank": None, "crank_arm": None, "crank_web": None, "crank_side": "left", "coupler": None,
         "coupler_arm": None, "coupler_web": None, "coupler_side": "left", "rocker": None, "rocker_pivot": None,
         "link5": None, "link6": None, "branch1": "open", "branch2": "open", **_SIX},
        "A", {"O4": "rocker_pivot"},
        (Place("C", "O2", "A", "crank_arm", "crank_web", "crank_side", "the crank's triangle O2-A-C", False),
         Place("B", "A", "O4", "coupler", "rocker", "branch1", "loop 1 (crank, coupler, rocker): triangle A-B-O4",
               True),
         Place("E", "A", "B", "coupler_arm", "coupler_web", "coupler_side", "the coupler's triangle A-B-E", False),
         Place("D", "C", "E", "link5", "link6", "branch2",
               "loop 2 (crank arm, link5, link6, coupler arm): triangle C-D-E", True)),
        (("O2", "A", "C"), ("C", "D"), ("D", "E"), ("E", "B", "A"), ("B", "O4")), (("O4", 6, 1), ("A", 5, 2))),
    "stephenson-i": SixBar(
        "Stephenson I (ground binary between the ternaries): a four-bar whose ternary crank and ternary rocker "
        "carry a dyad.  Crank triangle at the origin O2 [crank (O2A), crank_arm (O2C), crank_web (AC), "
        "crank_side], coupler AB, rocker triangle at rocker_pivot O4 [rocker (O4B), rocker_arm (O4E), rocker_web "
        "(BE), rocker_side], dyad link5 CD and link6 DE",
        {"crank": None, "crank_arm": None, "crank_web": None, "crank_side": "left", "coupler": None,
         "rocker": None, "rocker_arm": None, "rocker_web": None, "rocker_side": "left", "rocker_pivot": None,
         "link5": None, "link6": None, "branch1": "open", "branch2": "open", **_SIX},
        "A", {"O4": "rocker_pivot"},
        (Place("C", "O2", "A", "crank_arm", "crank_web", "crank_side", "the crank's triangle O2-A-C", False),
         Place("B", "A", "O4", "coupler", "rocker", "branch1", "loop 1 (crank, coupler, rocker): triangle A-B-O4",
               True),
         Place("E", "O4", "B", "rocker_arm", "rocker_web", "rocker_side", "the rocker's triangle O4-B-E", False),
         Place("D", "C", "E", "link5", "link6", "branch2",
               "loop 2 (crank arm, link5, link6, rocker arm): triangle C-D-E", True)),
        (("O2", "A", "C"), ("C", "D"), ("D", "E"), ("E", "B", "O4"), ("B", "A")), (("O4", 5, 1), ("A", 6, 2))),
    "stephenson-ii": SixBar(
        "Stephenson II (ground binary beside one ternary): crank O2E from the origin drives a floating ternary "
        "[coupler_p (EP), coupler_q (EQ), coupler_web (PQ), coupler_side] tied by link_p (PR) and link_q (QS) to a "
        "ternary rocker at rocker_pivot O6 [rocker_r (O6R), rocker_s (O6S), rocker_web (RS), rocker_side]; "
        "coupler_angle sketches the floating ternary's direction E->P, which picks the branch",
        {"crank": None, "coupler_p": None, "coupler_q": None, "coupler_web": None, "coupler_side": "left",
         "link_p": None, "link_q": None, "rocker_r": None, "rocker_s": None, "rocker_web": None,
         "rocker_side": "left", "rocker_pivot": None, "coupler_angle": 0.0, "branch": "open", **_SIX},
        "E", {"O6": "rocker_pivot"},
        (Place("Q", "E", "P", "coupler_q", "coupler_web", "coupler_side", "the coupler's triangle E-P-Q", False),
         Place("R", "P", "O6", "link_p", "rocker_r", "branch", "link_p and the rocker: triangle P-R-O6", True),
         Place("S", "O6", "R", "rocker_s", "rocker_web", "rocker_side", "the rocker's triangle O6-R-S", False)),
        (("O2", "E"), ("E", "P", "Q"), ("P", "R"), ("R", "S", "O6"), ("S", "Q")), (("O6", 5, 1), ("Q", 6, 3)),
        triad=("coupler_angle", "P", "coupler_p"), closes=("S", "Q", "link_q")),
    "stephenson-iii": SixBar(
        "Stephenson III (ground ternary): a crank O2A from the origin and a rocker BO4 at rocker_pivot O4 carry a "
        "floating ternary [coupler (AB), coupler_arm (AC), coupler_web (BC), coupler_side]; its third joint C "
        "drives the dyad link5 CD, link6 DO6 to output_pivot O6 (the ground ternary O2-O4-O6 by its pivots); "
        "branches branch1, branch2",
        {"crank": None, "coupler": None, "coupler_arm": None, "coupler_web": None, "coupler_side": "left",
         "rocker": None, "link5": None, "link6": None, "rocker_pivot": None, "output_pivot": None,
         "branch1": "open", "branch2": "open", **_SIX},
        "A", {"O4": "rocker_pivot", "O6": "output_pivot"},
        (Place("B", "A", "O4", "coupler", "rocker", "branch1", "loop 1 (crank, coupler, rocker): triangle A-B-O4",
               True),
         Place("C", "A", "B", "coupler_arm", "coupler_web", "coupler_side", "the coupler's triangle A-B-C", False),
         Place("D", "C", "O6", "link5", "link6", "branch2", "loop 2 (coupler arm, link5, link6): triangle C-D-O6",
               True)),
        # no path from the ground passes through all five links: the chain branches
        # at the floating ternary (link 3), which carries the rocker (link 4) at B and
        # the dyad (links 5, 6) at C; both loops close on the ground pivots
        (("O2", "A"), ("A", "B", "C"), ("B", "O4"), ("C", "D"), ("D", "O6")), (("O4", 4, 1), ("O6", 6, 1)),
        parents=(1, 2, 3, 3, 5)),
}
for _name, _sb in SIX_BARS.items():
    builder(_name, _sb.doc)(lambda params, prefix, sb=_sb: _six_bar(sb, params, prefix))
del _name, _sb


def six_bar_joints(sb: SixBar, d: Drawing) -> dict[str, np.ndarray]:
    """A six-bar's seven joints by name, where they are on the drawing: the links' origins and the closures' joints."""
    out = {c[0]: d.at(k) for k, c in enumerate(sb.chain)}
    for (name, *_), cl in zip(sb.closures, d.model.closures):
        out[name] = d.at(cl.to_link - 2, *cl.to_point)
    return out


def _decided_by(sb: SixBar, joint: str) -> list[str]:
    """The parameters a joint stands for: the lengths it ends and the sides it decides."""
    keys = [k for k, ends in {**sb.ends, **sb.sides}.items() if joint in ends]
    return keys + [sb.triad[0]] if sb.triad and joint != "O2" else keys


@handles_of(*SIX_BARS)
def _six_bar_handles(mech: dict, d: Drawing) -> list:
    # every joint a handle.  The origin: the others are measured from it, so each
    # ground pivot and the crank pin move by what it does
    sb = SIX_BARS[mech["type"]]
    at = six_bar_joints(sb, d)
    out = [("A", at[sb.pin], "mechanism.crank, mechanism.input_angle"),
           ("O2", at["O2"], ", ".join(f"mechanism.{k}" for k in ["crank", "input_angle", *_decided_by(sb, "O2"),
                                                                 *sb.pivots.values()]))]
    for name, xy in at.items():
        if name in sb.pivots:
            out.append((sb.pivots[name], xy, f"mechanism.{sb.pivots[name]}"))
        elif name in sb.moving:
            out.append((name, xy, ", ".join(f"mechanism.{k}" for k in _decided_by(sb, name))))
    return out


@moves_of(*SIX_BARS)
def _six_bar_moves(mech: dict, handle: str, x: float, y: float, drawing) -> bool:
    # a moving joint (and the origin O2) dragged keeps every other joint where it
    # is: the lengths it ends, and the sides and branches it decides, follow it
    # (the sketch always closes).  The crank pin and the other ground pivots keep
    # the lengths instead, as the four-bar's do, so a pivot dragged too far shows
    # where the loop stops closing.
    sb = SIX_BARS[mech["type"]]
    if handle == "A":
        _move_crank(mech, x, y, "input_angle")
        return True
    if handle in sb.pivots.values():
        mech[handle] = [_r(x), _r(y)]
        return True
    if handle not in sb.moving | {"O2"}:
        return False
    at = six_bar_joints(sb, drawing())
    at[handle] = np.array([x, y])
    if handle == "O2":  # the scene measured from the moved origin: the others move back by as much
        at = {name: xy - at["O2"] for name, xy in at.items()}
        pin = at[sb.pin]
        mech["crank"], mech["input_angle"] = _r(math.hypot(*pin)), _deg(math.atan2(pin[1], pin[0]))
        for name, key in sb.pivots.items():
            mech[key] = [_r(v) for v in at[name]]
    for key, (p, q) in sb.ends.items():
        if handle in (p, q):
            mech[key] = _r(math.dist(at[p], at[q]))
    for key, (p, q, s) in sb.sides.items():
        if handle in (p, q, s):
            mech[key] = _SIDE_WORDS[_left(at[p], at[q], at[s])][key.startswith("branch")]
    if sb.triad:  # the root the builder picks is the one nearest this direction
        key, joint, _ = sb.triad
        mech[key] = _deg(math.atan2(*(at[joint] - at[sb.pin])[::-1]))
    return True
