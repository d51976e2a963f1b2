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

from grubler.errors import SceneError, raise_all
from grubler.limits import brief, did_you_mean, parse_angle_or_number, parse_length

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
        return parse_angle_or_number(self.values[key], f"{self.prefix}.{key}")

    def angle(self, key: str) -> float:
        return self.number(key)

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


@builder("watt-ii", "Watt II (ground ternary): two four-bars in series.  Crank O2A from the origin, coupler AB, "
                    "rocker triangle at pivot O4 [rocker (O4B), rocker_arm (O4C), rocker_web (BC), rocker_side], "
                    "coupler2 CD, output DO6; pivots rocker_pivot O4, output_pivot O6; branches branch1, branch2")
def watt_ii(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"crank": None, "coupler": None, "rocker": None, "rocker_arm": None,
                                 "rocker_web": None, "rocker_side": "left", "coupler2": None, "output": None,
                                 "rocker_pivot": None, "output_pivot": None, "branch1": "open",
                                 "branch2": "open", **_SIX})
    L = {k: p.length(k) for k in ("crank", "coupler", "rocker", "rocker_arm", "rocker_web", "coupler2", "output")}
    th = p.angle("input_angle")
    w = {"O2": (0.0, 0.0), "O4": _point(p, "rocker_pivot"), "O6": _point(p, "output_pivot")}
    w["A"] = (L["crank"] * math.cos(th), L["crank"] * math.sin(th))
    w["B"] = _circles(w["A"], w["O4"], L["coupler"], L["rocker"], _branch(p, "branch1"),
                      "loop 1 (crank, coupler, rocker): triangle A-B-O4", prefix)
    w["C"] = _triangle(w["O4"], w["B"], L["rocker_arm"], L["rocker_web"], _side(p, "rocker_side"),
                       "the rocker's triangle O4-B-C", prefix, "rocker_web")
    w["D"] = _circles(w["C"], w["O6"], L["coupler2"], L["output"], _branch(p, "branch2"),
                      "loop 2 (rocker arm, coupler2, output): triangle C-D-O6", prefix)
    chain = [("O2", "A"), ("A", "B"), ("B", "C", "O4"), ("C", "D"), ("D", "O6")]
    return _six_link_chain(w, chain, [("O4", 4, 1), ("O6", 6, 1)], p.positive("mass_per_length"))


@builder("watt-i", "Watt I (ground binary): a four-bar whose ternary crank and ternary coupler carry a dyad.  "
                   "Crank triangle at the origin O2 [crank (O2A), crank_arm (O2C), crank_web (AC), crank_side], "
                   "coupler triangle [coupler (AB), coupler_arm (AE), coupler_web (BE), coupler_side], rocker BO4 "
                   "at rocker_pivot O4, dyad link5 CD and link6 DE; branches branch1, branch2")
def watt_i(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"crank": None, "crank_arm": None, "crank_web": None, "crank_side": "left",
                                 "coupler": None, "coupler_arm": None, "coupler_web": None, "coupler_side": "left",
                                 "rocker": None, "rocker_pivot": None, "link5": None, "link6": None,
                                 "branch1": "open", "branch2": "open", **_SIX})
    L = {k: p.length(k) for k in ("crank", "crank_arm", "crank_web", "coupler", "coupler_arm", "coupler_web",
                                  "rocker", "link5", "link6")}
    th = p.angle("input_angle")
    w = {"O2": (0.0, 0.0), "O4": _point(p, "rocker_pivot")}
    w["A"] = (L["crank"] * math.cos(th), L["crank"] * math.sin(th))
    w["C"] = _triangle(w["O2"], w["A"], L["crank_arm"], L["crank_web"], _side(p, "crank_side"),
                       "the crank's triangle O2-A-C", prefix, "crank_web")
    w["B"] = _circles(w["A"], w["O4"], L["coupler"], L["rocker"], _branch(p, "branch1"),
                      "loop 1 (crank, coupler, rocker): triangle A-B-O4", prefix)
    w["E"] = _triangle(w["A"], w["B"], L["coupler_arm"], L["coupler_web"], _side(p, "coupler_side"),
                       "the coupler's triangle A-B-E", prefix, "coupler_web")
    w["D"] = _circles(w["C"], w["E"], L["link5"], L["link6"], _branch(p, "branch2"),
                      "loop 2 (crank arm, link5, link6, coupler arm): triangle C-D-E", prefix)
    chain = [("O2", "A", "C"), ("C", "D"), ("D", "E"), ("E", "B", "A"), ("B", "O4")]
    return _six_link_chain(w, chain, [("O4", 6, 1), ("A", 5, 2)], p.positive("mass_per_length"))


@builder("stephenson-i", "Stephenson I (ground binary between the ternaries): a four-bar whose ternary crank and "
                         "ternary rocker carry a dyad.  Crank triangle at the origin O2 [crank (O2A), crank_arm "
                         "(O2C), crank_web (AC), crank_side], coupler AB, rocker triangle at rocker_pivot O4 [rocker "
                         "(O4B), rocker_arm (O4E), rocker_web (BE), rocker_side], dyad link5 CD and link6 DE")
def stephenson_i(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"crank": None, "crank_arm": None, "crank_web": None, "crank_side": "left",
                                 "coupler": None, "rocker": None, "rocker_arm": None, "rocker_web": None,
                                 "rocker_side": "left", "rocker_pivot": None, "link5": None, "link6": None,
                                 "branch1": "open", "branch2": "open", **_SIX})
    L = {k: p.length(k) for k in ("crank", "crank_arm", "crank_web", "coupler", "rocker", "rocker_arm",
                                  "rocker_web", "link5", "link6")}
    th = p.angle("input_angle")
    w = {"O2": (0.0, 0.0), "O4": _point(p, "rocker_pivot")}
    w["A"] = (L["crank"] * math.cos(th), L["crank"] * math.sin(th))
    w["C"] = _triangle(w["O2"], w["A"], L["crank_arm"], L["crank_web"], _side(p, "crank_side"),
                       "the crank's triangle O2-A-C", prefix, "crank_web")
    w["B"] = _circles(w["A"], w["O4"], L["coupler"], L["rocker"], _branch(p, "branch1"),
                      "loop 1 (crank, coupler, rocker): triangle A-B-O4", prefix)
    w["E"] = _triangle(w["O4"], w["B"], L["rocker_arm"], L["rocker_web"], _side(p, "rocker_side"),
                       "the rocker's triangle O4-B-E", prefix, "rocker_web")
    w["D"] = _circles(w["C"], w["E"], L["link5"], L["link6"], _branch(p, "branch2"),
                      "loop 2 (crank arm, link5, link6, rocker arm): triangle C-D-E", prefix)
    chain = [("O2", "A", "C"), ("C", "D"), ("D", "E"), ("E", "B", "O4"), ("B", "A")]
    return _six_link_chain(w, chain, [("O4", 5, 1), ("A", 6, 2)], p.positive("mass_per_length"))


@builder("stephenson-ii", "Stephenson II (ground binary beside one ternary): crank O2E from the origin drives a "
                          "floating ternary [coupler_p (EP), coupler_q (EQ), coupler_web (PQ), coupler_side] tied "
                          "by link_p (PR) and link_q (QS) to a ternary rocker at rocker_pivot O6 [rocker_r (O6R), "
                          "rocker_s (O6S), rocker_web (RS), rocker_side]; coupler_angle sketches the floating "
                          "ternary's direction E->P, which picks the branch")
def stephenson_ii(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"crank": None, "coupler_p": None, "coupler_q": None, "coupler_web": None,
                                 "coupler_side": "left", "link_p": None, "link_q": None, "rocker_r": None,
                                 "rocker_s": None, "rocker_web": None, "rocker_side": "left", "rocker_pivot": None,
                                 "coupler_angle": 0.0, "branch": "open", **_SIX})
    L = {k: p.length(k) for k in ("crank", "coupler_p", "coupler_q", "coupler_web", "link_p", "link_q",
                                  "rocker_r", "rocker_s", "rocker_web")}
    th, phi = p.angle("input_angle"), p.angle("coupler_angle")
    w = {"O2": (0.0, 0.0), "O6": _point(p, "rocker_pivot")}
    w["E"] = (L["crank"] * math.cos(th), L["crank"] * math.sin(th))
    # a triad, not a dyad: no closed form from the input.  Given the floating
    # ternary's direction phi, P and Q follow, the rocker hangs from P (a dyad
    # P-R-O6) and the miss |SQ| - link_q is a function of phi alone: its roots are
    # the branches.  The sketch is the root nearest coupler_angle.
    side_c, side_r, br = _side(p, "coupler_side"), _side(p, "rocker_side"), _branch(p, "branch")

    def place(angle):
        w["P"] = (w["E"][0] + L["coupler_p"] * math.cos(angle), w["E"][1] + L["coupler_p"] * math.sin(angle))
        w["Q"] = _triangle(w["E"], w["P"], L["coupler_q"], L["coupler_web"], side_c,
                           "the coupler's triangle E-P-Q", prefix, "coupler_web")
        w["R"] = _circles(w["P"], w["O6"], L["link_p"], L["rocker_r"], br,
                          "link_p and the rocker: triangle P-R-O6", prefix)
        w["S"] = _triangle(w["O6"], w["R"], L["rocker_s"], L["rocker_web"], side_r,
                           "the rocker's triangle O6-R-S", prefix, "rocker_web")
        return math.dist(w["S"], w["Q"]) - L["link_q"]

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
        raise SceneError(f"{prefix}.input_angle",
                         "no direction of the floating ternary closes the loop through link_q at this input angle "
                         f"(the rocker hanging on the '{p.values['branch']}' side)")
    place(min(roots, key=lambda a: abs(a - phi)))
    chain = [("O2", "E"), ("E", "P", "Q"), ("P", "R"), ("R", "S", "O6"), ("S", "Q")]
    return _six_link_chain(w, chain, [("O6", 5, 1), ("Q", 6, 3)], p.positive("mass_per_length"))


@builder("stephenson-iii", "Stephenson III (ground ternary): a crank O2A from the origin and a rocker BO4 at "
                           "rocker_pivot O4 carry a floating ternary [coupler (AB), coupler_arm (AC), coupler_web "
                           "(BC), coupler_side]; its third joint C drives the dyad link5 CD, link6 DO6 to "
                           "output_pivot O6 (the ground ternary O2-O4-O6 by its pivots); branches branch1, branch2")
def stephenson_iii(params: dict, prefix: str) -> dict:
    p = _Params(params, prefix, {"crank": None, "coupler": None, "coupler_arm": None, "coupler_web": None,
                                 "coupler_side": "left", "rocker": None, "link5": None, "link6": None,
                                 "rocker_pivot": None, "output_pivot": None, "branch1": "open", "branch2": "open",
                                 **_SIX})
    L = {k: p.length(k) for k in ("crank", "coupler", "coupler_arm", "coupler_web", "rocker", "link5", "link6")}
    th = p.angle("input_angle")
    w = {"O2": (0.0, 0.0), "O4": _point(p, "rocker_pivot"), "O6": _point(p, "output_pivot")}
    w["A"] = (L["crank"] * math.cos(th), L["crank"] * math.sin(th))
    w["B"] = _circles(w["A"], w["O4"], L["coupler"], L["rocker"], _branch(p, "branch1"),
                      "loop 1 (crank, coupler, rocker): triangle A-B-O4", prefix)
    w["C"] = _triangle(w["A"], w["B"], L["coupler_arm"], L["coupler_web"], _side(p, "coupler_side"),
                       "the coupler's triangle A-B-C", prefix, "coupler_web")
    w["D"] = _circles(w["C"], w["O6"], L["link5"], L["link6"], _branch(p, "branch2"),
                      "loop 2 (coupler arm, link5, link6): triangle C-D-O6", prefix)
    # no path from the ground passes through all five links: the chain branches
    # at the floating ternary (link 3), which carries the rocker (link 4) at B and
    # the dyad (links 5, 6) at C; both loops close on the ground pivots
    chain = [("O2", "A"), ("A", "B", "C"), ("B", "O4"), ("C", "D"), ("D", "O6")]
    return _six_link_chain(w, chain, [("O4", 4, 1), ("O6", 6, 1)], p.positive("mass_per_length"),
                           parents=[1, 2, 3, 3, 5])
