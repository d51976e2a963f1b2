"""Type synthesis facts a user can ask for: mobility, Grashof class, chain type.

Examples
--------
>>> kutzbach_mobility(n_bodies=4, n_lower_pairs=4)
1
>>> grashof(ground=1.0, crank=0.3, coupler=0.8, rocker=0.6).kind
'crank-rocker'
>>> grashof(ground=0.3, crank=1.0, coupler=0.8, rocker=0.6).kind
'double-crank'
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from grubler.mechanism.model import kutzbach_mobility  # the count lives with the model it counts

if TYPE_CHECKING:  # pragma: no cover
    from grubler.mechanism.model import Mechanism


@dataclass(frozen=True)
class Grashof:
    """Grashof classification of a four-bar linkage.

    Attributes
    ----------
    kind : str
        'crank-rocker', 'double-crank', 'double-rocker', 'change-point',
        'parallelogram', 'deltoid' or 'triple-rocker' (non-Grashof).
    grashof : bool
        Whether s + l <= p + q (some link turns fully).
    s_plus_l, p_plus_q : float
        The two sides of the condition, m.
    detail : str
        One line for people.

    Examples
    --------
    >>> from grubler import grashof
    >>> g = grashof(ground=1.0, crank=0.2, coupler=0.8, rocker=0.8)
    >>> g.kind, g.grashof, round(g.s_plus_l, 3), round(g.p_plus_q, 3)
    ('crank-rocker', True, 1.2, 1.6)
    """

    kind: str
    grashof: bool
    s_plus_l: float
    p_plus_q: float
    detail: str


def grashof(ground: float, crank: float, coupler: float, rocker: float, rtol: float = 1e-9) -> Grashof:
    """Grashof class of a four-bar from its pin-to-pin lengths.

    Parameters
    ----------
    ground, crank, coupler, rocker : float
        Ground (pivot to pivot), input link at the first pivot, coupler, output link.

    Returns
    -------
    Grashof

    Examples
    --------
    >>> grashof(1.0, 1.0, 1.0, 1.0).kind
    'parallelogram'
    >>> grashof(1.0, 0.9, 0.9, 0.9).grashof
    False
    """
    lengths = {"ground": ground, "crank": crank, "coupler": coupler, "rocker": rocker}
    for name, v in lengths.items():
        if not (v > 0 and math.isfinite(v)):
            raise ValueError(f"{name}: length must be positive and finite, got {v}")
    ordered = sorted(lengths.values())
    s, l = ordered[0], ordered[-1]
    pq = ordered[1] + ordered[2]
    sl = s + l
    tol = rtol * (sl + pq)
    shortest = min(lengths, key=lambda k: lengths[k])
    if abs(sl - pq) <= tol:
        close = lambda x, y: abs(x - y) <= tol  # noqa: E731
        if close(ground, coupler) and close(crank, rocker):
            kind, detail = "parallelogram", "change-point with opposite links equal: parallelogram or antiparallelogram"
        elif (close(ground, crank) and close(coupler, rocker)) or (close(ground, rocker) and close(crank, coupler)):
            kind, detail = "deltoid", "change-point with adjacent links equal (kite)"
        else:
            kind, detail = "change-point", "s + l = p + q: all links can align; it may flip branch there"
        return Grashof(kind, True, sl, pq, detail)
    if sl > pq:
        return Grashof("triple-rocker", False, sl, pq,
                       "s + l > p + q (non-Grashof): no link turns fully, every moving link rocks")
    if shortest == "ground":
        kind, detail = "double-crank", "shortest link is the ground: both crank and rocker turn fully (drag link)"
    elif shortest == "coupler":
        kind, detail = "double-rocker", "shortest link is the coupler: it turns fully, crank and rocker rock"
    elif shortest == "crank":
        kind, detail = "crank-rocker", "shortest link is the crank: it turns fully, the rocker rocks"
    else:
        kind, detail = "crank-rocker", "shortest link is the output: it turns fully, the input rocks (rocker-crank)"
    return Grashof(kind, True, sl, pq, detail)


@dataclass(frozen=True)
class SliderCrankClass:
    """Whether a slider-crank's crank turns fully: Grashof's criterion for the slider-crank.

    The coupler reaches the slide line from every crank angle iff the crank pin's
    farthest distance from the line, crank + |offset|, is at most the coupler.

    Attributes
    ----------
    kind : str
        'crank' (the crank turns fully), 'change-point' (crank + |offset| = coupler: the
        coupler stands square to the line once a turn), 'rocker' (the crank rocks between
        two limits) or 'unassemblable' (|offset| - crank > coupler: the coupler never reaches
        the line).
    crank, coupler, offset : float
        Pin-to-pin lengths and the crank pivot's distance from the slide line, m.
    ratio : float
        Coupler over crank (the rod ratio).
    detail : str
        One line for people.
    """

    kind: str
    crank: float
    coupler: float
    offset: float
    ratio: float
    detail: str


def slider_crank_class(crank: float, coupler: float, offset: float = 0.0, rtol: float = 1e-9) -> SliderCrankClass:
    """The class of an in-line (``offset`` 0) or offset slider-crank from its lengths, m.

    Examples
    --------
    >>> slider_crank_class(0.25, 1.0, 0.2).kind
    'crank'
    >>> slider_crank_class(0.5, 0.6, 0.3).kind     # 0.5 + 0.3 > 0.6: the crank rocks
    'rocker'
    """
    for name, v in (("crank", crank), ("coupler", coupler)):
        if not (v > 0 and math.isfinite(v)):
            raise ValueError(f"{name}: length must be positive and finite, got {v}")
    e = abs(offset)
    reach, tol = crank + e, rtol * (crank + e + coupler)
    if abs(reach - coupler) <= tol:
        kind, detail = "change-point", "crank + |offset| = coupler: the coupler stands square to the slide once a turn"
    elif reach < coupler:
        kind, detail = "crank", "crank + |offset| < coupler: the crank turns fully"
    elif e - crank <= coupler:
        kind, detail = "rocker", "crank + |offset| > coupler: the crank rocks between two limits"
    else:
        kind, detail = "unassemblable", "|offset| - crank > coupler: the coupler never reaches the slide"
    return SliderCrankClass(kind, crank, coupler, e, coupler / crank, detail)


@dataclass(frozen=True)
class Classification:
    """What a mechanism is, read off its topology and dimensions."""

    chain: str  # 'RRRR', 'RRRP', 'RRPP', 'RPRP', 'Watt', 'Stephenson', or 'open' / 'N-link'
    name: str  # inversion, e.g. 'slider-crank', or the declared kind
    mobility: int
    grashof: Grashof | None
    fourbar_lengths: tuple[float, float, float, float] | None
    slider_crank: SliderCrankClass | None = None  # a slider-crank's own class (crank, rocker), its offset, ratio


def _pin_lengths(model: "Mechanism") -> tuple[float, float, float, float]:
    """Ground, crank, coupler, rocker pin-to-pin lengths of an RRRR chain."""
    q = model.q_ref
    th1 = model.theta1
    o2 = np.array([model.a1 * math.cos(th1) - q[0] * math.sin(th1), model.a1 * math.sin(th1) + q[0] * math.cos(th1)])
    cl = model.closures[0]
    ground = float(np.linalg.norm(np.asarray(cl.to_point) - o2))
    crank = math.hypot(model.links[0].a, q[2])
    coupler = math.hypot(model.links[1].a, q[4])
    rocker = math.hypot(*cl.point)
    return ground, crank, coupler, rocker


def _slider_crank_lengths(model: "Mechanism") -> tuple[float, float, float]:
    """Crank, coupler (pin to pin, as :func:`_pin_lengths` reads them) and offset of an R-R-R chain whose
    last link slides on a ground line: the distance from the crank's pivot to the line the coupler-slider
    pin runs on (the closing point's line, moved by that point's place on the slider, whose orientation is
    held)."""
    q = model.q_ref
    th1 = model.theta1
    o2 = np.array([model.a1 * math.cos(th1) - q[0] * math.sin(th1), model.a1 * math.sin(th1) + q[0] * math.cos(th1)])
    cl = model.closures[0]
    c, s_ = math.cos(cl.psi), math.sin(cl.psi)
    pin_line = np.asarray(cl.to_point) - np.array([c * cl.point[0] - s_ * cl.point[1],
                                                   s_ * cl.point[0] + c * cl.point[1]])
    direction = np.array([math.cos(cl.angle), math.sin(cl.angle)])
    rel = o2 - pin_line
    offset = abs(float(direction[0] * rel[1] - direction[1] * rel[0]))
    return math.hypot(model.links[0].a, q[2]), math.hypot(model.links[1].a, q[4]), offset


def classify(model: "Mechanism") -> Classification:
    """Chain type and inversion of a mechanism (MODEL.md section 1).

    Examples
    --------
    >>> import grubler
    >>> c = grubler.classify(grubler.load_scene("thesis-fourbar").mechanism)
    >>> c.name, c.mobility, c.grashof.kind
    ('four-bar (crank-rocker)', 1, 'crank-rocker')
    """
    mob = model.mobility
    if not model.closures:
        return Classification("open", model.kind or f"open chain of {model.n_links} links", mob, None, None)
    six = six_bar_inversion(model)
    if six:
        return Classification(six.split()[0], f"{six} six-bar", mob, None, None)
    cl = model.closures[0]
    if model.n_links != 3 or len(model.closures) != 1 or cl.to_link != 1 or cl.link != 4:
        return Classification(f"{model.n_links + 1}-link", model.kind or "closed chain", mob, None, None)
    loop = [l.joint for l in model.links] + ["R" if cl.kind == "revolute" else "P"]
    n_p = loop.count("P")
    ground_joints = {loop[0], loop[3]}
    g = lengths = None
    if n_p == 0:
        chain = "RRRR"
        lengths = _pin_lengths(model)
        g = grashof(*lengths) if all(v > 0 for v in lengths) else None
        name = f"four-bar ({g.kind})" if g else "four-bar"
    elif n_p == 1:
        chain = "RRRP"
        name = ("slider-crank" if "P" in ground_joints
                else "quick-return or swinging block (slider-crank chain, a two-revolute link fixed)")
        if loop == ["R", "R", "R", "P"]:  # crank, coupler, slider on a ground line
            crank, coupler, offset = _slider_crank_lengths(model)
            if crank > 0 and coupler > 0:
                sc = slider_crank_class(crank, coupler, offset)
                return Classification(chain, model.kind or f"slider-crank ({sc.kind})", mob, None, None, sc)
    elif any(loop[i] == loop[(i + 1) % 4] == "P" for i in range(4)):
        chain = "RRPP"
        if ground_joints == {"P"}:
            axis1 = model.theta1 + math.pi / 2
            perpendicular = abs(math.cos(axis1 - cl.angle)) < 1e-9
            name = "double slider (elliptic trammel)" if perpendicular else "double slider"
        elif ground_joints == {"R"}:
            name = "Oldham coupling"
        else:
            name = "Scotch yoke"
    else:
        chain = "RPRP"
        name = "conchoidal-motion mechanism"
    return Classification(chain, model.kind or name, mob, g, lengths)


def explain_unclosable(model: "Mechanism", z0, held: list[int]) -> str:
    """Why a chain cannot close: a four-bar in Grashof / triangle terms, a chain of dyads by
    the loop and the triangle that fail ('' when neither applies)."""
    c = classify(model)
    if c.chain != "RRRR" or c.fourbar_lengths is None:
        return dyad_reason(model, z0, held)
    ground, crank, coupler, rocker = c.fourbar_lengths
    ordered = sorted(c.fourbar_lengths)
    if ordered[-1] >= sum(ordered[:-1]):
        return (f"the longest link ({ordered[-1]:.6g} m) is not shorter than the other three together "
                f"({sum(ordered[:-1]):.6g} m), so no position closes")
    if model.free_names and held and model.free_names[held[0]] == "theta2" and model.links[0].joint == "R":
        from grubler.mechanism.kinematics import chain_kinematics

        pin = chain_kinematics(model, np.asarray(z0, float), np.zeros(model.n_links)).origin[1]
        diag = float(np.linalg.norm(np.asarray(model.closures[0].to_point) - pin))
        lo, hi = abs(coupler - rocker), coupler + rocker
        if not lo <= diag <= hi:
            return (f"at this crank angle the crank pin is {diag:.6g} m from the rocker pivot, but coupler and "
                    f"rocker ({coupler:.6g} m, {rocker:.6g} m) only span {lo:.6g} to {hi:.6g} m (triangle "
                    "inequality)")
        # the triangle closes: blaming it would contradict the numbers; at its edge the two
        # solutions meet, where the solver's Jacobian is singular
        if min(diag - lo, hi - diag) <= 1e-3 * hi:
            return (f"at this crank angle coupler and rocker must lie nearly in line (the crank pin is {diag:.6g} m "
                    f"from the rocker pivot, their span {lo:.6g} to {hi:.6g} m): two assembly branches meet "
                    "there (a change point or dead centre), and the closure cannot be solved from this guess")
    return ""


def explain_singular_start(model: "Mechanism", z, zd, method: str) -> str:
    """Which link's missing inertia makes the equations of motion unsolvable at a state ('' if none).

    A revolute link with ``I = 0`` and its mass centre on its joint gives its
    coordinate no inertia; unless a closure carries it, the equations of motion
    are singular.  Each link in turn is given a small moment of inertia: the one
    that makes the state solvable is named.  (The equations themselves are the
    kernel's; this only calls them.)
    """
    from dataclasses import replace

    from grubler.mechanism.dynamics import Inputs, forward_dynamics

    z, zd = np.asarray(z, float), np.asarray(zd, float)
    try:  # the premise: the equations of motion are singular at this state
        forward_dynamics(model, z, zd, Inputs(), method)
        return ""
    except (np.linalg.LinAlgError, ValueError, ArithmeticError):
        pass
    scale = max([1.0] + [link.m * link.a**2 for link in model.links])
    for k, link in enumerate(model.links):
        if link.joint != "R" or link.I > 0 or (link.m > 0 and (link.p, link.q) != (0.0, 0.0)):
            continue  # its rotation carries inertia: I, or its mass off the joint (m (p^2 + q^2))
        links = list(model.links)
        links[k] = replace(link, I=1e-6 * scale)
        try:
            forward_dynamics(model.replace(links=tuple(links)), z, zd, Inputs(), method)
        except (np.linalg.LinAlgError, ValueError, ArithmeticError):
            continue
        return (f"link{k + 2}.I: the link's rotation carries no inertia (I = 0 and its mass centre on its "
                "joint) and no closure carries it, so the equations of motion are singular; give it a "
                "moment of inertia I > 0 or move its mass centre (p, q) off the joint")


# -- topology: the links as bodies, the chain's joints and the closures as edges ----------
@dataclass(frozen=True)
class Joint:
    """One joint of the link graph: bodies (1 = ground), kind 'R'/'P', and where it sits on each.

    ``at_a`` and ``at_b`` are the joint's point in body a's and body b's frame
    (the ground's frame is the world frame); ``label`` names it for people.
    """

    a: int
    b: int
    kind: str
    at_a: tuple[float, float]
    at_b: tuple[float, float]
    label: str


def link_graph(model: "Mechanism") -> list[Joint]:
    """Every joint of the mechanism as an edge between two bodies.

    The chain's pairs join link k to its predecessor (link k-1 in a serial
    chain, any earlier link or the ground in a tree) at link k's origin, the
    predecessor's point (a, B); each closure joins its two links at its points.
    """
    q = model.q_ref
    out = []
    for k, (link, pred) in enumerate(zip(model.links, model.parents)):
        body = k + 2
        if pred == 1:
            c, s = math.cos(model.theta1), math.sin(model.theta1)
            at_pred = (model.a1 * c - q[2 * k] * s, model.a1 * s + q[2 * k] * c)
        else:
            at_pred = (model.links[pred - 2].a, q[2 * k])
        out.append(Joint(pred, body, link.joint, at_pred, (0.0, 0.0), f"link{pred}-link{body} (chain)"))
    for j, cl in enumerate(model.closures):
        name = "closure" if len(model.closures) == 1 else f"closure[{j}]"
        out.append(Joint(cl.link, cl.to_link, "R" if cl.kind == "revolute" else "P", tuple(cl.point),
                         tuple(cl.to_point), f"{name}: link{cl.link}-link{cl.to_link}"))
    return out


def joint_counts(model: "Mechanism") -> dict[int, int]:
    """How many joints each link carries (1 the ground): 2 binary, 3 ternary, ..."""
    count = {b: 0 for b in range(1, model.n_links + 2)}
    for j in link_graph(model):
        count[j.a] += 1
        count[j.b] += 1
    return count


SIX_BAR_INVERSIONS = {  # what each name means: which link of which chain is the ground
    "Watt I": "Watt chain (the two ternary links share a joint), a binary link fixed",
    "Watt II": "Watt chain (the two ternary links share a joint), a ternary link fixed: two four-bars in series",
    "Stephenson I": "Stephenson chain (binary links between the ternaries), the binary joining both ternaries fixed",
    "Stephenson II": "Stephenson chain (binary links between the ternaries), a binary of the two-link path fixed",
    "Stephenson III": "Stephenson chain (binary links between the ternaries), a ternary link fixed",
}


def six_bar_inversion(model: "Mechanism") -> str | None:
    """'Watt I' ... 'Stephenson III' for a six-link chain of seven revolutes, else None.

    Read off the link graph: the two ternary links (three joints each) are
    adjacent in a Watt chain, not in a Stephenson chain; which link is the ground
    (link 1) picks the inversion.
    """
    joints = link_graph(model)
    if model.n_links != 5 or len(joints) != 7 or any(j.kind != "R" for j in joints):
        return None
    degree = joint_counts(model)
    nbrs: dict[int, set] = {b: set() for b in range(1, 7)}
    for j in joints:
        nbrs[j.a].add(j.b)
        nbrs[j.b].add(j.a)
    ternary = [b for b, d in degree.items() if d == 3]
    if len(ternary) != 2 or sorted(degree.values()) != [2, 2, 2, 2, 3, 3]:
        return None
    t1, t2 = ternary
    if t2 in nbrs[t1]:
        return "Watt II" if 1 in ternary else "Watt I"
    if 1 in ternary:
        return "Stephenson III"
    return "Stephenson I" if {t1, t2} <= nbrs[1] else "Stephenson II"


def _pose_point(pose, local):
    (ox, oy, th) = pose
    c, s = math.cos(th), math.sin(th)
    return (ox + c * local[0] - s * local[1], oy + s * local[0] + c * local[1])


def dyad_reason(model: "Mechanism", z0, held: list[int]) -> str:
    """Which loop and which triangle keep a revolute chain from closing ('' when none is found).

    With the held coordinate's link placed, take in turn every dyad (two unplaced
    links pinned together, each pinned to a placed link): its two outer pins are
    fixed, and the triangle they make with the two links' pin-to-pin lengths must
    exist.  The branch of each dyad that closes is the one nearest the sketch.
    """
    from grubler.mechanism.kinematics import chain_kinematics

    if not held or any(l.joint != "R" for l in model.links) or any(c.kind != "revolute" for c in model.closures):
        return ""
    joints = link_graph(model)
    kin = chain_kinematics(model, np.asarray(z0, float), np.zeros(model.n_links))
    sketch = {k + 2: (kin.origin[k][0], kin.origin[k][1], kin.theta[k]) for k in range(model.n_links)}
    placed = {1: (0.0, 0.0, 0.0)}
    # the held link hangs from the ground at its sketch pose; links before it are not held
    h = held[0] + 2
    if h != 2:
        return ""
    placed[2] = sketch[2]
    while len(placed) < model.n_links + 1:
        found = False
        for pin in joints:
            u1, u2 = pin.a, pin.b
            if u1 in placed or u2 in placed:
                continue
            outer = []
            for u, at_mid in ((u1, pin.at_a), (u2, pin.at_b)):
                ties = [(j, j.b if j.a == u else j.a) for j in joints if j is not pin and u in (j.a, j.b)
                        and (j.b if j.a == u else j.a) in placed]
                if len(ties) != 1:
                    break
                j, other = ties[0]
                at_u, at_other = (j.at_a, j.at_b) if j.a == u else (j.at_b, j.at_a)
                outer.append((u, at_mid, at_u, _pose_point(placed[other], at_other), j.label))
            if len(outer) != 2:
                continue
            (ua, ma, oa, pa, la), (ub, mb, ob, pb, lb) = outer
            ra, rb = math.dist(ma, oa), math.dist(mb, ob)
            d = math.dist(pa, pb)
            if d > ra + rb or d < abs(ra - rb) or d == 0:
                return (f"the loop through {la} and {lb} cannot close: its dyad link{ua}-link{ub} "
                        f"({ra:.6g} m and {rb:.6g} m pin to pin) must span the {d:.6g} m between those two pins, "
                        f"but reaches only {abs(ra - rb):.6g} to {ra + rb:.6g} m (no triangle)")
            # place both on the sketch's side: the middle pin nearest its sketch position
            along = (ra * ra - rb * rb + d * d) / (2 * d)
            hgt = math.sqrt(max(ra * ra - along * along, 0.0))
            ux, uy = (pb[0] - pa[0]) / d, (pb[1] - pa[1]) / d
            target = _pose_point(sketch[ua], ma)
            mids = [(pa[0] + along * ux - s * hgt * uy, pa[1] + along * uy + s * hgt * ux) for s in (1, -1)]
            mid = min(mids, key=lambda m: math.dist(m, target))
            for u, at_mid, at_out, p_out in ((ua, ma, oa, pa), (ub, mb, ob, pb)):
                th = (math.atan2(mid[1] - p_out[1], mid[0] - p_out[0])
                      - math.atan2(at_mid[1] - at_out[1], at_mid[0] - at_out[0]))
                c, s = math.cos(th), math.sin(th)
                placed[u] = (p_out[0] - c * at_out[0] + s * at_out[1], p_out[1] - s * at_out[0] - c * at_out[1], th)
            found = True
            break
        if not found:
            return ""  # not a chain of dyads (a triad): the assembly's closest approach is all there is
    return ""
