"""Instantaneous analysis of a mechanism at one position: velocities, accelerations, instant centres, forces.

Every body of a planar mechanism (the ground is body 1, moving link k+2 is
body k+2) moves at one instant as a rigid plane: an angular rate ``omega``, an
angular acceleration ``alpha`` and the velocity and acceleration of one of its
points give those of all its points (:class:`Motion`).  They come from one
pass of the kernel (:func:`grubler.mechanism.kinematics.evaluate_into`): each
link's mass centre moves with ``Jc @ zd`` and accelerates with
``Jc @ zdd + bias``, its angle with the constant map ``S``.

From the velocity fields follow

* the **instant centre** of every pair of bodies i, j: the one point whose
  velocity as a point of i equals its velocity as a point of j.  Writing a body's
  field as ``v(P) = u + omega k x P`` (``u`` the velocity of the body's point at
  the world origin), the centre is the homogeneous point
  ``(-du_y, du_x, domega)`` of the differences: a finite point when the two
  turn relative to each other, a direction (a point at infinity) when they only
  translate, as a slider on its guide does (:class:`InstantCentre`).  Any three
  bodies' centres lie on one line (Kennedy's theorem, :func:`kennedy_residual`);
* the **transmission angle** at each pin where a binary link (a two-force
  member: its force acts along its pin-to-pin line) drives the next link away
  from the drive: the acute angle between that line and the line from the pin
  to the driven link's centre with the ground (the line the pin moves across).
  90 degrees transmits best; 0 is a dead centre (:func:`transmission_angles`);
* the **mechanical advantage**: the drive's rate over the output's
  (:func:`mechanical_advantage`), the output torque (or force) per drive torque
  (or force) when no power is lost;
* the **toggle positions** over a turn of the drive: where the output stands
  still and reverses (:func:`turn_analysis`).

When no run gives the state, :func:`kinematic_rates` drives the mechanism at a
constant unit rate (1 rad/s, or 1 m/s for a slide) and finds the other joints'
rates and accelerations from the closures: the textbook's velocity and
acceleration analysis.  :func:`analyse_instant` gathers everything, with the
joints' reactions of the equations of motion (:func:`joint_forces`).

Examples
--------
>>> import grubler
>>> m = grubler.load_scene("thesis-fourbar").mechanism
>>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
>>> zd, zdd = kinematic_rates(m, z)              # the crank at 1 rad/s, steady
>>> mo = motion(m, z, zd, zdd)
>>> ic = instant_centre(mo, 1, 2)                # ground and crank: the crank's pivot
>>> ic.label, (ic.point.round(9) + 0.0).tolist()
('I12', [0.0, 0.0])
>>> ic = instant_centre(mo, 1, 4)                # ground and rocker: the rocker's pivot
>>> (ic.point.round(9) + 0.0).tolist()
[1.0, 0.0]
>>> [round(t.angle_deg, 3) for t in transmission_angles(m, mo)]   # the coupler-rocker pin
[60.0]
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from grubler.mechanism.analysis import link_graph
from grubler.mechanism.dynamics import EXACT, Inputs, forward_dynamics, inverse_dynamics, joint_reactions
from grubler.mechanism.kinematics import (
    K_CBX,
    K_CBY,
    K_CX,
    K_CY,
    K_AX,
    K_AY,
    K_COS,
    K_OX,
    K_OY,
    K_SIN,
    K_TH,
    R_GAMMA,
    evaluate_into,
    tables,
)
from grubler.mechanism.model import Mechanism

GROUND = 1
FAR = 1e6  # a centre beyond this many mechanism sizes is drawn as a direction: the pair only translates
STILL = 1e-12  # relative rates below this (times the size, against the largest) are no motion at all


# -- the velocity and acceleration fields --------------------------------------------------------
@dataclass
class Motion:
    """Each body's velocity and acceleration field at one state (data, world frame).

    Row b - 1 is body b (row 0 the ground, at rest).  A body's point P moves with
    ``v[b-1] + omega[b-1] k x (P - origin[b-1])`` (:meth:`velocity`) and
    accelerates with ``a + alpha k x (P - O) - omega^2 (P - O)``
    (:meth:`acceleration`).

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> mo = motion(m, z, *kinematic_rates(m, z))
    >>> mo.velocity(2, (0.2, 0.0)).round(6).tolist()    # the crank pin, 0.2 m out, at 1 rad/s
    [0.0, 0.2]
    >>> mo.acceleration(2, (0.2, 0.0)).round(6).tolist()   # steady: the centripetal 0.2 m/s^2 inwards
    [-0.2, 0.0]
    """

    origin: np.ndarray  # (B, 2) each body's joint point O (the ground's: the world origin), m
    theta: np.ndarray  # (B,) each body's angle, rad (the ground's: theta1)
    omega: np.ndarray  # (B,) angular rate, rad/s
    alpha: np.ndarray  # (B,) angular acceleration, rad/s^2
    v: np.ndarray  # (B, 2) velocity of O, m/s
    a: np.ndarray  # (B, 2) acceleration of O, m/s^2
    size: float  # the mechanism's size (largest joint distance from the origin), m: the scale of "far"
    axis: np.ndarray | None = None  # (B, 2) each body's slide axis (unit, world), its pair's if that is a slide
    scale: float = 0.0  # the largest speed in the mechanism, m/s: the scale of "still"

    def __post_init__(self):
        self.scale = max(float(np.abs(self.omega).max()) * self.size, float(np.abs(self.v).max()), 1e-300)

    def world(self, body: int, local) -> np.ndarray:
        """The world position of a point given in ``body``'s frame (along, across its link vector)."""
        if body == GROUND:
            return np.asarray(local, dtype=float)
        c, s = math.cos(self.theta[body - 1]), math.sin(self.theta[body - 1])
        return self.origin[body - 1] + np.array([c * local[0] - s * local[1], s * local[0] + c * local[1]])

    def velocity(self, body: int, p) -> np.ndarray:
        """Velocity of the point of ``body`` now at world position ``p``, m/s."""
        r = np.asarray(p, dtype=float) - self.origin[body - 1]
        return self.v[body - 1] + self.omega[body - 1] * np.array([-r[1], r[0]])

    def acceleration(self, body: int, p) -> np.ndarray:
        """Acceleration of the point of ``body`` now at world position ``p``, m/s^2."""
        r = np.asarray(p, dtype=float) - self.origin[body - 1]
        w, al = self.omega[body - 1], self.alpha[body - 1]
        return self.a[body - 1] + al * np.array([-r[1], r[0]]) - w * w * r


# The mechanism's structure (its joints as a graph, the drive's and the output's links, the pins that transmit)
# is a function of the model alone: found once per model (the model is immutable and hashable) and shared,
# read-only, by every instant and every row of a sweep.
structural = functools.lru_cache(maxsize=32)


@structural
def _joint_index(model: Mechanism) -> int:
    """Index in z of the joint the analysis drives: the scene's drive, or the first link's joint."""
    return model.free_index(model.drive) if model.drive else 0


def _drive_row(model: Mechanism) -> np.ndarray:
    e = np.zeros((1, model.n_links))
    e[0, _joint_index(model)] = 1.0
    return e


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``A x = b``: exactly when A is square and regular (a mobility of one), else least squares, least norm."""
    if A.shape[0] == A.shape[1]:
        try:
            return np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            pass  # a dead centre: the drive alone does not fix the others' rates
    return np.linalg.lstsq(A, b, rcond=None)[0]


def _steady_rates(model: Mechanism, tab, rate: float) -> np.ndarray:
    """Joint rates with the drive at ``rate``, from a workspace filled at the position: ``J zd = 0``."""
    A = np.vstack([tab.J, _drive_row(model)])
    b = np.zeros(A.shape[0])
    b[-1] = rate
    return _solve(A, b)


def kinematic_rates(model: Mechanism, z, rate: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Joint rates and accelerations with the drive turning steadily at ``rate`` (rad/s, or m/s on a slide).

    The closures fix the other joints' rates (``J zd = 0``) and accelerations
    (``J zdd = gamma``); where they leave some free (a mobility above one, an
    open chain), the free ones are the least that satisfy them (least squares,
    least norm): an open chain's other joints stand still.  The drive is the
    scene's drive joint, or the first link's joint when it names none.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-slider-crank").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> zd, zdd = kinematic_rates(m, z, 2.0)
    >>> round(float(zd[0]), 9), round(float(zdd[0]), 9) + 0.0     # the crank at 2 rad/s, steady
    (2.0, 0.0)
    """
    z = np.asarray(z, dtype=float)
    n = model.n_links
    tab = tables(model)
    evaluate_into(model, tab, z, np.zeros(n))
    zd = _steady_rates(model, tab, rate)
    evaluate_into(model, tab, z, zd)  # the right side of the acceleration constraint depends on the rates
    A = np.vstack([tab.J, _drive_row(model)])
    zdd = _solve(A, np.r_[tab.R[:, R_GAMMA], 0.0])
    return zd, zdd


def _fields(model: Mechanism, tab, zd, zdd) -> Motion:
    """The bodies' fields from a workspace filled at (z, zd): each link's mass centre, its Jacobian and bias.

    A link's joint point O moves as its mass centre C less the turn about it:
    ``v_O = Jc zd - omega k x (C - O)``, ``a_O = Jc zdd + bias - alpha k x (C - O) + omega^2 (C - O)``.
    """
    K = tab.K
    jw = model.S[1::2]  # each link's angle from the joint coordinates, a constant map (a tree's too)
    omega, alpha = jw @ zd, jw @ zdd
    o, c = K[:, K_OX:K_OY + 1], K[:, K_CX:K_CY + 1]
    arm = c - o
    perp = np.column_stack([-arm[:, 1], arm[:, 0]])
    v = tab.Jc @ zd - omega[:, None] * perp
    a = tab.Jc @ zdd + K[:, K_CBX:K_CBY + 1] - alpha[:, None] * perp + (omega * omega)[:, None] * arm
    origin = np.vstack([np.zeros((1, 2)), o])
    size = max(float(np.abs(o).max()), abs(model.a1), max((abs(l.a) for l in model.links), default=0.0), 1e-9)
    return Motion(origin, np.r_[model.theta1, K[:, K_TH]], np.r_[0.0, omega], np.r_[0.0, alpha],
                  np.vstack([np.zeros((1, 2)), v]), np.vstack([np.zeros((1, 2)), a]), size,
                  np.vstack([np.zeros((1, 2)), K[:, K_AX:K_AY + 1]]))


def motion(model: Mechanism, z, zd, zdd=None) -> Motion:
    """Every body's velocity and acceleration field at joint state (z, zd, zdd): one pass of the kernel.

    ``zdd`` None means no joint accelerates (only the convective part remains).

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> mo = motion(m, z, [1.0, 0.0, 0.0])    # the crank turning, the other joints held: one rigid body
    >>> mo.omega.round(6).tolist()
    [0.0, 1.0, 1.0, 1.0]
    """
    n = model.n_links
    z, zd = np.asarray(z, dtype=float), np.asarray(zd, dtype=float)
    zdd = np.zeros(n) if zdd is None else np.asarray(zdd, dtype=float)
    tab = tables(model)
    evaluate_into(model, tab, z, zd)
    return _fields(model, tab, zd, zdd)


# -- instant centres -------------------------------------------------------------------------------
@dataclass(frozen=True)
class InstantCentre:
    """The instant centre of bodies i and j (thesis numbering, 1 the ground).

    ``point`` is where it is (m); a pair that only translates relative to each
    other has its centre at infinity, and ``direction`` (a unit vector, the
    line every point moves across) instead; a pair at rest relative to each
    other has neither.  ``homogeneous`` is (x, y, w), the point (x/w, y/w).

    Examples
    --------
    >>> ic = InstantCentre(1, 3, (2.0, 1.0, 2.0), np.array([1.0, 0.5]), None)
    >>> ic.label, ic.point.tolist()
    ('I13', [1.0, 0.5])
    """

    i: int
    j: int
    homogeneous: tuple[float, float, float]
    point: np.ndarray | None
    direction: np.ndarray | None

    @property
    def label(self) -> str:
        """'I13' (two-digit bodies separated: 'I1,12')."""
        return f"I{self.i}{self.j}" if max(self.i, self.j) < 10 else f"I{self.i},{self.j}"


def _at_origin(mo: Motion, b: int) -> tuple[float, float]:
    """Velocity of body b's point at the world origin: v_O - omega k x O."""
    (vx, vy), (ox, oy), w = mo.v[b - 1], mo.origin[b - 1], mo.omega[b - 1]
    return float(vx + w * oy), float(vy - w * ox)


def instant_centre(mo: Motion, i: int, j: int) -> InstantCentre:
    """The instant centre of bodies ``i`` and ``j`` from their velocity fields.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-slider-crank").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> ic = instant_centre(motion(m, z, *kinematic_rates(m, z)), 1, 4)   # the block on its guide
    >>> ic.point is None, ic.direction.round(6).tolist()                  # at infinity, across the guide
    (True, [0.0, 1.0])
    """
    (uix, uiy), (ujx, ujy) = _at_origin(mo, i), _at_origin(mo, j)
    du = (uix - ujx, uiy - ujy)
    dw = float(mo.omega[i - 1] - mo.omega[j - 1])
    h = (-du[1], du[0], dw)
    speed = math.hypot(*du)
    scale = mo.scale
    if speed <= STILL * scale and abs(dw) * mo.size <= STILL * scale:
        return InstantCentre(i, j, h, None, None)
    if abs(dw) * FAR * mo.size <= speed:
        d = np.array([h[0], h[1]]) / speed
        if d[0] < -1e-12 or (abs(d[0]) <= 1e-12 and d[1] < 0):  # a line's direction: one of its two senses
            d = -d
        return InstantCentre(i, j, h, None, d + 0.0)
    return InstantCentre(i, j, h, np.array([h[0] / dw, h[1] / dw]) + 0.0, None)


def instant_centres(mo: Motion) -> list[InstantCentre]:
    """The centres of every pair of bodies, I12, I13, ..., in that order: B (B - 1) / 2 of them.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("watt-ii").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> centres = instant_centres(motion(m, z, *kinematic_rates(m, z)))
    >>> len(centres), centres[0].label, centres[-1].label      # six bodies: fifteen pairs
    (15, 'I12', 'I56')
    """
    bodies = range(1, mo.origin.shape[0] + 1)
    return [instant_centre(mo, i, j) for i, j in itertools.combinations(bodies, 2)]


def kennedy_residual(a: InstantCentre, b: InstantCentre, c: InstantCentre) -> float:
    """How far three centres are from one line: the sine of the angle at the middle one (0 on a line).

    Computed from the centres as drawn (points and directions), not from the
    fields they came from: the determinant of their unit homogeneous vectors.
    None of the three may be undefined.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> mo = motion(m, z, *kinematic_rates(m, z))
    >>> kennedy_residual(*(instant_centre(mo, i, j) for i, j in ((1, 2), (2, 3), (1, 3)))) < 1e-12
    True
    """
    rows = []
    for ic in (a, b, c):
        if ic.point is not None:
            h = np.array([ic.point[0], ic.point[1], 1.0])
        elif ic.direction is not None:
            h = np.array([ic.direction[0], ic.direction[1], 0.0])
        else:
            raise ValueError(f"{ic.label}: the two bodies do not move relative to each other; no centre")
        rows.append(h / np.linalg.norm(h))
    return abs(float(np.linalg.det(np.array(rows))))


# -- the joints as drawn: which bodies they join and where -----------------------------------------
@structural
def _graph(model: Mechanism):
    joints = link_graph(model)
    near: dict[int, set] = {b: set() for b in range(1, model.n_links + 2)}
    for j in joints:
        near[j.a].add(j.b)
        near[j.b].add(j.a)
    return joints, near


def _drive_body(model: Mechanism) -> int:
    return _joint_index(model) + 2


@structural
def _distances(model: Mechanism) -> dict[int, int]:
    """Joints from the drive's link to each moving link, through moving links: the way power flows."""
    start, near = _drive_body(model), _graph(model)[1]
    dist, todo = {start: 0}, [start]
    while todo:
        b = todo.pop(0)
        for c in sorted(near[b]):
            if c != GROUND and c not in dist:
                dist[c] = dist[b] + 1
                todo.append(c)
    return dist


def joint_points(model: Mechanism, mo: Motion) -> list[tuple[object, np.ndarray]]:
    """Every joint of :func:`grubler.mechanism.analysis.link_graph` with where it is now (world, m).

    A chain joint sits at its link's origin; a closure at its closing point.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> [(j.label, at.round(6).tolist()) for j, at in joint_points(m, motion(m, z, np.zeros(3)))][::3]
    [('link1-link2 (chain)', [0.0, 0.0]), ('closure: link4-link1', [1.0, 0.0])]
    """
    out = []
    for j in _graph(model)[0]:
        out.append((j, mo.world(j.b, j.at_b) if j.b != GROUND else mo.world(j.a, j.at_a)))
    return out


# -- transmission angle and mechanical advantage ----------------------------------------------------
@dataclass(frozen=True)
class TransmissionAngle:
    """The transmission angle at the pin where binary link ``coupler`` drives link ``output``.

    ``angle_deg`` is the acute angle between the coupler's pin-to-pin line and
    the line from the pin to the output's instant centre with the ground, deg
    (90 best, 0 a dead centre); ``at`` is the pin (world, m).

    Examples
    --------
    >>> TransmissionAngle(3, 4, np.array([0.6, 0.7]), 60.0).label
    'mu34'
    """

    coupler: int
    output: int
    at: np.ndarray
    angle_deg: float

    @property
    def label(self) -> str:
        return f"mu{self.coupler}{self.output}"


@structural
def _transmission_pins(model: Mechanism):
    """(coupler, output, pin joint, coupler's other joint) of every pin where a binary link drives the next."""
    joints = _graph(model)[0]
    dist = _distances(model)
    out = []
    for pin in joints:
        if pin.kind != "R" or GROUND in (pin.a, pin.b):
            continue
        for c, o in ((pin.a, pin.b), (pin.b, pin.a)):
            mine = [j for j in joints if c in (j.a, j.b)]
            if (c == _drive_body(model) or len(mine) != 2 or any(j.kind != "R" for j in mine)
                    or dist.get(c, -1) < 0 or dist.get(o, -1) <= dist[c] or not _in_loop(joints, pin)):
                continue
            other = next(j for j in mine if j is not pin)
            out.append((c, o, pin, other))
    return out


def _in_loop(joints, pin) -> bool:
    """Whether ``pin`` closes a loop (its two bodies stay joined without it): an open chain's joints carry
    moments, and no link of it is a two-force member."""
    reached, todo = {pin.a}, [pin.a]
    while todo:
        b = todo.pop()
        for j in joints:
            if j is not pin and b in (j.a, j.b):
                c = j.b if j.a == b else j.a
                if c not in reached:
                    reached.add(c)
                    todo.append(c)
    return pin.b in reached


def _where(mo: Motion, joint, body: int) -> np.ndarray:
    return mo.world(body, joint.at_a if joint.a == body else joint.at_b)


def transmission_angles(model: Mechanism, mo: Motion, pins=None) -> list[TransmissionAngle]:
    """The transmission angle at every pin where a binary link drives a link farther from the drive.

    A four-bar has one (coupler on rocker), a slider-crank one (rod on block:
    the angle between the rod and the normal to the guide), a Watt II six-bar
    two; a pin whose output is at rest relative to the ground, or whose coupler
    has zero length, gives none.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("watt-ii").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> [(t.label, round(t.angle_deg, 2)) for t in transmission_angles(m, motion(m, z, *kinematic_rates(m, z)))]
    [('mu34', 38.5), ('mu56', 79.96)]
    """
    out = []
    for c, o, pin, other in pins if pins is not None else _transmission_pins(model):
        b, a = _where(mo, pin, c), _where(mo, other, c)
        ic = instant_centre(mo, GROUND, o)
        if ic.point is not None:
            across = b - ic.point
        elif ic.direction is not None:
            across = ic.direction
        else:
            continue
        force = b - a
        nf, na = math.hypot(*force), math.hypot(*across)
        if nf <= 1e-12 * mo.size or na <= 1e-12 * mo.size:
            continue
        cos = abs(float(force @ across)) / (nf * na)
        out.append(TransmissionAngle(c, o, b, math.degrees(math.acos(min(cos, 1.0)))))
    return out


@structural
def output_body(model: Mechanism) -> int | None:
    """The link whose motion the mechanism delivers: the load's, else the ground's neighbour farthest from the drive.

    None for an open chain (no other link is jointed to the ground).  A load on
    the drive's own joint (a toggle clamp's reaction) names no output: the
    farthest link is taken then.

    Examples
    --------
    >>> import grubler
    >>> [output_body(grubler.load_scene(n).mechanism) for n in ("watt-ii", "slider-crank", "triple-pendulum")]
    [6, 4, None]
    """
    drive = _drive_body(model)
    if model.load and model.free_index(model.load, "load") + 2 != drive:
        return model.free_index(model.load, "load") + 2
    near, dist = _graph(model)[1], _distances(model)
    grounded = [b for b in near[GROUND] if b != drive and b in dist]
    return max(grounded, key=lambda b: (dist[b], b)) if grounded else None


@dataclass(frozen=True)
class Advantage:
    """Mechanical advantage: output effort per drive effort, the drive's rate over the output's.

    ``value`` is None at a toggle (the output stands: infinite advantage).
    ``unit`` is '' (torque per torque, or force per force), '1/m' (force per
    torque) or 'm' (torque per force).

    Examples
    --------
    >>> Advantage(4, 2.5, "")          # link 4 turns at 0.4 times the drive's rate: 2.5 times its torque
    Advantage(output=4, value=2.5, unit='')
    """

    output: int
    value: float | None
    unit: str


@structural
def _guide(model: Mechanism, body: int) -> tuple | None:
    """How ``body`` slides on the ground: None when it turns (a revolute to it, or no joint), ('chain', row)
    when its own pair is the slide (its axis in the link table's row), ('fixed', (x, y)) a ground closure's line."""
    for j in _graph(model)[0]:
        if {j.a, j.b} == {GROUND, body} and j.kind == "P":
            if j.b == body and model.parents[body - 2] == GROUND and model.links[body - 2].joint == "P":
                return ("chain", body - 2)
            cl = next(c for c in model.closures if {c.link, c.to_link} == {GROUND, body})
            return ("fixed", (math.cos(cl.angle), math.sin(cl.angle)))
    return None


def _output_rate(model: Mechanism, mo: Motion, body: int) -> tuple[float, bool]:
    """The output's rate (rad/s, or m/s along its guide) and whether it turns."""
    guide = _guide(model, body)
    if guide is None:
        return float(mo.omega[body - 1]), True
    axis = mo.axis[guide[1] + 1] if guide[0] == "chain" else np.array(guide[1])
    return float(mo.v[body - 1] @ axis), False


def mechanical_advantage(model: Mechanism, mo: Motion, zd) -> Advantage | None:
    """The drive's rate over the output's (:func:`output_body`); None without an output.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("fourbar-parallelogram").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> zd, zdd = kinematic_rates(m, z)
    >>> ma = mechanical_advantage(m, motion(m, z, zd, zdd), zd)
    >>> ma.output, round(ma.value, 9), ma.unit        # a parallelogram turns its output as its crank
    (4, 1.0, '')
    """
    body = output_body(model)
    if body is None:
        return None
    i = _joint_index(model)
    rate_in, turns_in = float(np.asarray(zd)[i]), bool(model.arrays.revolute[i])
    rate_out, turns_out = _output_rate(model, mo, body)
    unit = "" if turns_in == turns_out else ("1/m" if turns_in else "m")
    if abs(rate_out) <= 1e-9 * abs(rate_in) * (1.0 if turns_in == turns_out else mo.size):
        return Advantage(body, None, unit)
    return Advantage(body, rate_in / rate_out, unit)


# -- the joints' forces ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class JointForce:
    """The force (N, world frame) one body exerts on another at a joint, and the joint's moment (N m).

    Examples
    --------
    >>> f = JointForce("link1-link2", 2, 1, np.zeros(2), np.array([4.2, 24.6]), 2.7)   # as joint_forces makes it
    >>> f.on, f.by, f.force.tolist()
    (2, 1, [4.2, 24.6])
    """

    label: str
    on: int  # the body it acts on
    by: int  # the body that exerts it
    at: np.ndarray
    force: np.ndarray
    moment: float


def joint_forces(model: Mechanism, z, zd, inputs: Inputs, method: str = EXACT) -> list[JointForce]:
    """Every joint's reaction at one state: the chain's joints, then the closures.

    A chain joint's is what its predecessor exerts on its link
    (:func:`grubler.mechanism.dynamics.joint_reactions`, the ``R<k>_*`` columns
    of ``grubler simulate --reactions``); a closure's what the closure exerts on
    its closing link (the ``Fx``, ``Fy``, ``Mz`` and ``closure<j>_*`` columns).

    Raises
    ------
    numpy.linalg.LinAlgError
        When the equations of motion are singular there.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z = m.z_from_q(m.q_ref)
    >>> f = joint_forces(m, z, np.zeros(3), Inputs(drive=3.0))      # at rest, 3 N m on the crank
    >>> f[0].label, f[0].force.round(3).tolist()                    # the ground on the crank: R1 of --reactions
    ('link1-link2', [4.202, 24.567])
    """
    dyn = forward_dynamics(model, np.asarray(z, float), np.asarray(zd, float), inputs, method)
    reactions = joint_reactions(model, dyn, inputs)
    mo = motion(model, z, zd, dyn.zdd)
    out = []
    for k, pred in enumerate(model.parents):
        out.append(JointForce(f"link{pred}-link{k + 2}", k + 2, pred, mo.origin[k + 1].copy(),
                              reactions[k, :2].copy(), float(reactions[k, 2])))
    for j, cl in enumerate(model.closures):
        lam = dyn.lam[2 * j:2 * j + 2]
        f = dyn.ck.force_dir[j] @ lam
        out.append(JointForce(f"link{cl.to_link}-link{cl.link}", cl.link, cl.to_link, mo.world(cl.link, cl.point),
                              f, float(dyn.ck.moment_row[j] @ lam)))
    return out


# -- over a turn: the least transmission angle and the toggle positions ---------------------------------
@dataclass
class Turn:
    """What a sweep of the drive over its range shows.

    ``drive`` holds the drive's coordinate at each row; ``angles`` each pin's
    transmission angle per row (deg, NaN where undefined); ``least`` per pin
    (label) its minimum and the row of it; ``toggles`` the rows where the
    output's rate changes sign (it stands still and reverses); ``limits`` the
    two ends of a revolute drive's sweep that is no full turn: where the drive
    itself stops (a rocker's dead centres, a non-Grashof chain's limits).

    Examples
    --------
    >>> turn = Turn(np.array([0.0, 0.1]))      # as turn_analysis begins it
    >>> turn.least, turn.toggles
    ({}, [])
    """

    drive: np.ndarray
    angles: dict = field(default_factory=dict)
    least: dict = field(default_factory=dict)
    toggles: list = field(default_factory=list)
    limits: list = field(default_factory=list)


def turn_analysis(model: Mechanism, zs) -> Turn:
    """Transmission angles and toggle positions over closed positions ``zs`` (rows in drive order).

    The rows are taken together: one kernel pass each for the positions and
    Jacobians, then every row's rates (the drive at 1 rad/s or 1 m/s), the
    output's centre with the ground and the angles at once, as
    :func:`transmission_angles` and :func:`mechanical_advantage` find them at
    one instant.

    Examples
    --------
    >>> import grubler, numpy as np
    >>> m = grubler.load_scene("fourbar-crank-rocker").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> from grubler.mechanism.assembly import assemble
    >>> zs = [z]
    >>> for step in range(1, 180):
    ...     guess = zs[-1].copy(); guess[0] = z[0] + step * np.pi / 90
    ...     zs.append(assemble(m, guess)[0])
    >>> turn = turn_analysis(m, np.array(zs))
    >>> len(turn.toggles), turn.limits       # a crank-rocker's rocker stops twice a turn; its crank never
    (2, [])
    """
    zs = np.asarray(zs, dtype=float)
    rows, n = zs.shape[0], model.n_links
    turn = Turn(zs[:, _joint_index(model)].copy())
    if rows == 0:
        return turn
    tab = tables(model)
    K, Jc = np.empty((rows,) + tab.K.shape), np.empty((rows,) + tab.Jc.shape)
    A = np.empty((rows, tab.J.shape[0] + 1, n))
    for r, z in enumerate(zs):
        evaluate_into(model, tab, z, np.zeros(n))  # positions and Jacobians: the rates are linear in the drive's
        K[r], Jc[r], A[r, :-1] = tab.K, tab.Jc, tab.J
    A[:, -1] = _drive_row(model)
    b = np.zeros(A.shape[1])
    b[-1] = 1.0
    try:
        zd = np.linalg.solve(A, np.broadcast_to(b, (rows, b.size))[..., None])[..., 0]
    except np.linalg.LinAlgError:  # not square, or a dead centre among the rows: row by row
        zd = np.array([_solve(a, b) for a in A])
    omega = zd @ model.S[1::2].T  # (rows, N)
    o, c = K[:, :, K_OX:K_OY + 1], K[:, :, K_CX:K_CY + 1]
    arm = c - o
    v = np.einsum("rkin,rn->rki", Jc, zd) - omega[..., None] * np.stack([-arm[..., 1], arm[..., 0]], -1)

    def world(body, local):  # (rows, 2)
        if body == GROUND:
            return np.broadcast_to(np.asarray(local, float), (rows, 2))
        k = body - 2
        cs, sn = K[:, k, K_COS], K[:, k, K_SIN]
        return o[:, k] + np.stack([cs * local[0] - sn * local[1], sn * local[0] + cs * local[1]], -1)

    def centre_with_ground(body):  # homogeneous (rows, 3), as instant_centre(mo, GROUND, body)
        k = body - 2
        ux, uy = v[:, k, 0] + omega[:, k] * o[:, k, 1], v[:, k, 1] - omega[:, k] * o[:, k, 0]
        return np.stack([uy, -ux, -omega[:, k]], -1)

    for cpl, out, pin, other in _transmission_pins(model):
        at = lambda joint: world(cpl, joint.at_a if joint.a == cpl else joint.at_b)  # noqa: E731
        pb, pa = at(pin), at(other)
        h = centre_with_ground(out)
        across = pb * h[:, 2:3] - h[:, :2]  # pin minus centre, times w: a direction where the centre is far
        force = pb - pa
        norms = np.linalg.norm(force, axis=1) * np.linalg.norm(across, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.abs(np.einsum("ri,ri->r", force, across)) / norms
        angle = np.degrees(np.arccos(np.minimum(cos, 1.0)))
        angle[~(norms > 1e-24 * max(float(np.abs(zs).max()), 1.0))] = np.nan
        turn.angles[f"mu{cpl}{out}"] = angle
        if np.isfinite(angle).any():
            r = int(np.nanargmin(angle))
            turn.least[f"mu{cpl}{out}"] = (float(angle[r]), r)
    body = output_body(model)
    if body is not None:
        guide = _guide(model, body)
        if guide is None:
            rate = omega[:, body - 2]
        else:
            axis = K[:, guide[1], K_AX:K_AY + 1] if guide[0] == "chain" else np.asarray(guide[1])
            rate = np.einsum("ri,ri->r", v[:, body - 2], np.broadcast_to(axis, (rows, 2)))
        turn.toggles = _reversals(rate, 1e-9 * (1.0 if guide is None else float(np.abs(zs).max()) or 1.0))
    # a revolute drive's sweep that spans less than a turn (less one of its steps) stopped at both ends where
    # the loop would no longer close
    if model.arrays.revolute[_joint_index(model)] and rows > 2:
        step = float(np.median(np.abs(np.diff(turn.drive))))
        if np.ptp(turn.drive) + 1.5 * step < 2 * math.pi:
            turn.limits = [0, rows - 1]
    return turn


def _reversals(rate: np.ndarray, still: float) -> list[int]:
    """The rows where ``rate`` changes sign, each the row of least speed between the two signs.

    A rate within ``still`` of zero has no sign: rounding in a folded position
    (a parallelogram's links lying on one another) flips it, and no reversal is
    counted there, only where the output moves one way before and the other after.
    """
    out, last = [], None  # (row, sign) of the last moving row
    for r, value in enumerate(rate):
        if abs(value) <= still:
            continue
        sign = value > 0
        if last is not None and sign != last[1]:
            out.append(last[0] + int(np.argmin(np.abs(rate[last[0]:r + 1]))))
        last = (r, sign)
    return out


# -- everything at one instant --------------------------------------------------------------------------
@dataclass
class InstantAnalysis:
    """The whole analysis at one state (:func:`analyse_instant`).

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("slider-crank").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> out = analyse_instant(m, z)
    >>> out.advantage.unit, out.forces_reason               # newtons on the block per newton metre on the crank
    ('1/m', '')
    """

    z: np.ndarray
    zd: np.ndarray
    zdd: np.ndarray
    motion: Motion
    centres: list
    transmission: list
    advantage: Advantage | None
    forces: list | None  # None when the equations of motion are singular there
    forces_reason: str = ""


def analyse_instant(model: Mechanism, z, zd=None, inputs: Inputs | None = None, method: str = EXACT,
                    zdd=None) -> InstantAnalysis:
    """Velocities, accelerations, instant centres, transmission angles, advantage and joint forces at one state.

    Parameters
    ----------
    model : Mechanism
    z : array
        A closed position.
    zd : array, optional
        The joint rates (a run's); None drives the mechanism steadily at a unit
        rate (:func:`kinematic_rates`), and its forces are then the kinetostatic
        ones: the drive effort that holds that motion, found by inverse dynamics.
    inputs : Inputs, optional
        The efforts acting (a run's); their accelerations follow from the
        equations of motion unless ``zdd`` is given.

    The transmission angles and the mechanical advantage belong to the
    position (the drive moving it steadily), not to the run's rates: a run at
    rest has them too; so do the instant centres of a run at rest.

    Examples
    --------
    >>> import grubler
    >>> m = grubler.load_scene("thesis-fourbar").mechanism
    >>> z, _ = grubler.assemble(m, m.z_from_q(m.q_ref))
    >>> out = analyse_instant(m, z)
    >>> len(out.centres), [f.label for f in out.forces]
    (6, ['link1-link2', 'link2-link3', 'link3-link4', 'link1-link4'])
    """
    z = np.asarray(z, dtype=float)
    steady = kinematic_rates(model, z)
    if zd is None:
        zd, zdd = steady
        inputs = inputs or Inputs()
        if model.drive:
            try:
                inputs = Inputs(inverse_dynamics(model, z, zd, zdd, inputs)[0] + inputs.drive, inputs.load,
                                inputs.actuators)
            except np.linalg.LinAlgError:
                pass
    inputs = inputs or Inputs()
    zd = np.asarray(zd, dtype=float)
    forces, reason = None, ""
    try:
        forces = joint_forces(model, z, zd, inputs, method)
        if zdd is None:
            zdd = forward_dynamics(model, z, zd, inputs, method).zdd
    except np.linalg.LinAlgError:
        reason = "the equations of motion are singular here (a link without inertia that no closure carries)"
    zdd = np.zeros(model.n_links) if zdd is None else np.asarray(zdd, dtype=float)
    mo = motion(model, z, zd, zdd)
    geometric = mo if zd is steady[0] else motion(model, z, *steady)
    moving = float(np.abs(zd).max()) > 0.0
    return InstantAnalysis(z, zd, zdd, mo, instant_centres(mo if moving else geometric),
                           transmission_angles(model, geometric), mechanical_advantage(model, geometric, steady[0]),
                           forces, reason)


__all__ = [
    "Advantage",
    "InstantAnalysis",
    "InstantCentre",
    "JointForce",
    "Motion",
    "TransmissionAngle",
    "Turn",
    "analyse_instant",
    "instant_centre",
    "instant_centres",
    "joint_forces",
    "joint_points",
    "kennedy_residual",
    "kinematic_rates",
    "mechanical_advantage",
    "motion",
    "output_body",
    "transmission_angles",
    "turn_analysis",
]
