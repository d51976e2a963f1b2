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
from typing import Callable

from .errors import SceneError
from .limits import brief

BUILDERS: dict[str, Callable[[dict, str], dict]] = {}
BUILDER_DOCS: dict[str, str] = {}


def builder(name: str, doc: str):
    def register(fn):
        BUILDERS[name] = fn
        BUILDER_DOCS[name] = doc
        return fn
    return register


class _Params:
    """Reads a builder's parameters with defaults, naming the field on error."""

    def __init__(self, params: dict, prefix: str, allowed: dict[str, float | str | None]):
        self.prefix = prefix
        unknown = set(params) - set(allowed) - {"type"}
        if unknown:
            raise SceneError(f"{prefix}.{sorted(unknown)[0]}",
                             f"unknown parameter; this builder takes {', '.join(allowed)}")
        self.values = {k: params.get(k, v) for k, v in allowed.items()}
        for k, v in self.values.items():
            if v is None:
                raise SceneError(f"{prefix}.{k}", "is required")

    def length(self, key: str, allow_zero: bool = False) -> float:
        v = self.number(key)
        if v < 0 or (v == 0 and not allow_zero):
            raise SceneError(f"{self.prefix}.{key}", f"length must be {'>= 0' if allow_zero else 'positive'}, got {v}")
        return v

    def positive(self, key: str) -> float:
        v = self.number(key)
        if v <= 0:
            raise SceneError(f"{self.prefix}.{key}", f"must be positive, got {v}")
        return v

    def number(self, key: str) -> float:
        from .scene import parse_angle_or_number

        return parse_angle_or_number(self.values[key], f"{self.prefix}.{key}")

    def angle(self, key: str) -> float:
        return self.number(key)


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


@builder("slider-crank", "crank, rod (m), offset of the slide line (m); crank_angle; slider_mass")
def slider_crank(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"crank": None, "rod": None, "offset": 0.0, "crank_angle": 0.0,
                                 "slider_mass": 1.0, **_BARS})
    r2, r3 = p.length("crank"), p.length("rod")
    e = p.number("offset")
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


@builder("pendulum-pump", "crank (pivot to pin), link, rod (m), offset (m, slide line from the pivot); crank_angle")
def pendulum_pump(params: dict, prefix: str) -> dict:
    # slider-crank with the slider fixed (second inversion): a vertical rod slides
    # through a block fixed at x = offset; the crank swings about the origin
    p = _Params(params, prefix, {"crank": None, "link": None, "rod": None, "offset": None,
                                 "crank_angle": 0.0, **_BARS})
    r2, r3, rod = p.length("crank"), p.length("link"), p.length("rod")
    e = p.number("offset")
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
