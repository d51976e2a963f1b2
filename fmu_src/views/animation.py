"""Drawing a mechanism to scale, and animating a trajectory.

The geometry of a frame comes from the same kinematics the simulator integrates:
the points a drawing needs are fixed to links (:class:`Sketch`), and one kernel
call (:func:`grubler.mechanism.kinematics.link_points`) places them at every instant.  This
module only decides how each part looks: links as bars, a link with three or
more joints (or a traced point off its line) as a filled plate, revolute joints
as circles, prismatic joints as a block on its guide with the guide's axis drawn,
fixed pivots hatched.  The view is fitted once to every point of the whole
motion, so nothing is clipped and nothing jumps.

A film's still parts (axes, grid, ground, the signals' curves) are drawn once by
matplotlib; each frame is that picture, in a fixed 256-colour palette, with the
moving parts drawn over it by Pillow, which writes the GIF with no per-frame
colour quantisation.
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Polygon  # noqa: E402

from grubler.errors import InputError, SceneError  # noqa: E402
from grubler.limits import brief, check_size, number  # noqa: E402
from grubler.mechanism.kinematics import link_points  # noqa: E402
from grubler.mechanism.model import PRISMATIC, Mechanism  # noqa: E402

LINK_COLOUR = "#1f4e79"
JOINT_COLOUR = "#d62728"  # used for revolute joints only: tests find them by it
BLOCK_COLOUR = "#2ca02c"
GUIDE_COLOUR = "#7f7f7f"
TRACE_COLOUR = "#ff7f0e"
CYLINDER_COLOUR = "#17becf"  # an actuator's barrel
SPRING_COLOUR = "#8c564b"  # a spring's zigzag
SPRING_TURNS = 7  # the zigzag's points either side of its line
COIL_TURNS = 2  # a torsion spring's spiral at its joint
LOAD_COLOUR = "#9467bd"  # a point load's arrow
LOAD_ARROW_PX = 45  # an arrow's length on the GIF (its direction is the force's; its size says nothing)
BARREL_SHARE = 0.55  # of an actuator's length, the barrel drawn from its first point (the rod runs the whole line)

# the public names (the API reference's): the rest is the package's inside
__all__ = ["animate", "check_frames", "trace_point", "trace_path", "frame_geometry", "FrameGeometry"]


@dataclass
class FrameGeometry:
    """What one frame shows, in world coordinates (m).

    Examples
    --------
    >>> import grubler
    >>> res = grubler.simulate("thesis-fourbar", t_end=0.5)
    >>> g = frame_geometry(res.model, res.z[0])       # a FrameGeometry: what the first frame draws
    >>> len(g.bars), len(g.fixed)                     # the three moving links; two ground pivots
    (3, 2)
    >>> g.points().shape                              # every drawn point, for fitting a view
    (12, 2)
    """

    bars: list = field(default_factory=list)  # [(p0, p1), ...]
    joints: list = field(default_factory=list)  # revolute centres
    fixed: list = field(default_factory=list)  # ground pivots (hatched)
    blocks: list = field(default_factory=list)  # (centre, axis angle)
    guides: list = field(default_factory=list)  # (point, axis angle, fixed?)
    plates: list = field(default_factory=list)  # links with three or more corners: their corners, in order
    trace: np.ndarray | None = None  # the traced point, if any
    actuators: list = field(default_factory=list)  # [(first point, second point), ...]: a barrel and its rod
    springs: list = field(default_factory=list)  # [(first point, second point), ...]: a zigzag between them
    loads: list = field(default_factory=list)  # [(point, unit direction), ...]: a point load's arrow, ending there
    coils: list = field(default_factory=list)  # [(joint centre, link angle), ...]: a torsion spring at a revolute

    def points(self) -> np.ndarray:
        pts = [p for bar in self.bars for p in bar] + self.joints + self.fixed + [b[0] for b in self.blocks]
        pts += [p for line in self.actuators + self.springs for p in line]
        return np.array(pts, dtype=float).reshape(-1, 2)


class Sketch:
    """Which points of which links a drawing of ``model`` needs, and how they make a frame.

    The points (joint centres, link ends, closure points, a traced point, and
    two unit directions per link for the slide axes) are fixed to their links,
    so one kernel call (:func:`grubler.mechanism.kinematics.link_points`) places them at
    every instant of a trajectory; :meth:`geometry` turns one instant's
    positions into the drawing primitives.
    """

    def __init__(self, model: Mechanism, trace=None):
        self.model, self.link, self.local = model, [], []
        n = model.n_links
        self.origin = [self._add(k, 0.0, 0.0) for k in range(n)]
        self.end = [self._add(k, lk.a, 0.0) for k, lk in enumerate(model.links)]
        self.ground_end = self._add(-1, model.a1 * math.cos(model.theta1), model.a1 * math.sin(model.theta1))
        self.closure_a = [self._add(cl.link - 2, *cl.point) for cl in model.closures]
        self.closure_b = [self._add(cl.to_link - 2 if cl.to_link > 1 else -1, *cl.to_point) for cl in model.closures]
        self.trace_link = trace[0] if trace else None
        self.trace = self._add(trace[0], *trace[1]) if trace else None
        self.actuator_ends = [(self._add(a.from_link - 2, *a.from_point), self._add(a.to_link - 2, *a.to_point))
                              for a in model.actuators]
        self.springs = [e for e in model.forces if e.table == "spring"]
        self.spring_ends = [(self._add(e.from_link - 2, *e.from_point), self._add(e.to_link - 2, *e.to_point))
                            for e in self.springs]
        self.loads = [e for e in model.forces if e.table == "point_load" and np.hypot(*e.force) > 0]
        self.load_points = [self._add(e.link - 2, *e.point) for e in self.loads]
        # a joint spring acts at its link's real joint: coordinate pairs (B, theta) per link, the slide first
        self.joint_springs = [divmod(model.coordinate_names.index(e.joint), 2) for e in model.forces
                              if e.table == "joint_spring"]
        self.n_drawn = len(self.link)  # the points so far are drawn (and fit the view); the directions are not
        self.across = [self._add(k, 0.0, 1.0) for k in range(n)]  # e_perp(theta_k): its children's slide axis
        self.along = [self._add(k, 1.0, 0.0) for k in range(n)]  # e(theta_k): a prismatic closure's base angle

    def _add(self, k: int, u: float, v: float) -> int:
        self.link.append(int(k))
        self.local.append((float(u), float(v)))
        return len(self.link) - 1

    def positions(self, zs: np.ndarray) -> np.ndarray:
        """Every point at every row of ``zs``: (rows, points, 2)."""
        return link_points(self.model, zs, self.link, self.local)

    def drawn_points(self, pos: np.ndarray) -> np.ndarray:
        """The points a frame draws (not the helper directions), (..., k, 2)."""
        return pos[..., : self.n_drawn, :]

    def _angle(self, pos, frm: int, to: int) -> float:
        d = pos[to] - pos[frm]
        return math.atan2(d[1], d[0])

    def geometry(self, pos: np.ndarray) -> FrameGeometry:
        """The drawing primitives at one instant, from that row of :meth:`positions`."""
        m, n = self.model, self.model.n_links
        parent = [pk - 2 for pk in m.parents]  # each link's predecessor (the chain may branch), -1 the ground
        geo = FrameGeometry()
        O, E = [pos[i] for i in self.origin], [pos[i] for i in self.end]
        for k in range(n):
            geo.bars.append((O[k], E[k]))
            for c in range(k + 1, n):  # its children hang off its end, moved along their slides
                if parent[c] == k and np.linalg.norm(E[k] - O[c]) > 1e-9:
                    geo.bars.append((E[k], O[c]))
        for k, link in enumerate(m.links):
            p = parent[k]
            if link.joint == PRISMATIC:  # the slide's axis is e_perp of its predecessor
                axis = m.theta1 + math.pi / 2 if p < 0 else self._angle(pos, self.origin[p], self.across[p])
                geo.guides.append((pos[self.ground_end] if p < 0 else E[p], axis, p < 0))
                geo.blocks.append((O[k], axis))
            else:
                geo.joints.append(O[k])
                if p < 0:
                    geo.fixed.append(O[k])
        # a link with three or more corners (its joint, its children's, closures'
        # points, a traced point) is a rigid plate
        corners: list[list] = [[O[k]] + [O[c] for c in range(n) if parent[c] == k] for k in range(n)]
        for j, cl in enumerate(m.closures):
            corners[cl.link - 2].append(pos[self.closure_a[j]])
            if cl.to_link > 1:
                corners[cl.to_link - 2].append(pos[self.closure_b[j]])
        if self.trace is not None:
            geo.trace = pos[self.trace]
            corners[self.trace_link].append(geo.trace)
        for k, pts in enumerate(corners):
            distinct = [p for i, p in enumerate(pts) if all(np.linalg.norm(p - q) > 1e-9 for q in pts[:i])]
            if len(distinct) >= 3:
                c = np.mean(distinct, axis=0)
                geo.plates.append(sorted(distinct, key=lambda p: math.atan2(p[1] - c[1], p[0] - c[0])))
            elif len(distinct) == 2 and k == self.trace_link:
                geo.bars.append((distinct[0], distinct[1]))  # a traced point off a link's only joint
        for j, cl in enumerate(m.closures):
            a_pt, b_pt = pos[self.closure_a[j]], pos[self.closure_b[j]]
            if cl.kind == "revolute":
                geo.joints.append(a_pt)
                if cl.to_link == 1:
                    geo.fixed.append(b_pt)
            else:
                k = cl.to_link - 2
                base = 0.0 if cl.to_link == 1 else self._angle(pos, self.origin[k], self.along[k])
                geo.guides.append((b_pt, base + cl.angle, cl.to_link == 1))
                geo.blocks.append((a_pt, base + cl.angle))
        for act, (i0, i1) in zip(m.actuators, self.actuator_ends):
            geo.actuators.append((pos[i0], pos[i1]))
            for link, i in ((act.from_link, i0), (act.to_link, i1)):  # pinned at both ends
                geo.joints.append(pos[i])
                if link == 1:
                    geo.fixed.append(pos[i])
            for link, i in ((act.from_link, i0), (act.to_link, i1)):  # off its link's line: a plate corner
                if link > 1:
                    k = link - 2
                    if min(np.linalg.norm(pos[i] - O[k]), np.linalg.norm(pos[i] - E[k])) > 1e-9:
                        geo.bars.append((O[k], pos[i]) if np.linalg.norm(pos[i] - O[k]) < np.linalg.norm(
                            pos[i] - E[k]) else (E[k], pos[i]))
        for load, i in zip(self.loads, self.load_points):  # world axes: the force's direction is constant
            geo.loads.append((pos[i], np.asarray(load.force, dtype=float) / np.hypot(*load.force)))
            k = load.link - 2  # a point past its link's ends (a payload hung beyond a boom's head) is held by a bar
            if min(np.linalg.norm(pos[i] - O[k]), np.linalg.norm(pos[i] - E[k])) > 1e-9 and not _between(
                    pos[i], O[k], E[k]):
                geo.bars.append((O[k], pos[i]) if np.linalg.norm(pos[i] - O[k]) < np.linalg.norm(
                    pos[i] - E[k]) else (E[k], pos[i]))
        for spring, (i0, i1) in zip(self.springs, self.spring_ends):
            geo.springs.append((pos[i0], pos[i1]))
            for link, i in ((spring.from_link, i0), (spring.to_link, i1)):
                geo.joints.append(pos[i])
                if link == 1:
                    geo.fixed.append(pos[i])
        for k, revolute in self.joint_springs:  # a coil at a pin; a zigzag along a slide, from its base to its block
            if revolute:
                geo.coils.append((O[k], self._angle(pos, self.origin[k], self.along[k])))
            else:
                base = pos[self.ground_end] if parent[k] < 0 else E[parent[k]]
                if np.linalg.norm(O[k] - base) > 1e-9:
                    geo.springs.append((base, O[k]))
        return geo


def _between(p, a, b) -> bool:
    """Whether point ``p`` lies on the segment a-b (a link's bar already draws it)."""
    d = np.asarray(b) - a
    span = float(np.dot(d, d))
    if span == 0.0:
        return False
    s = float(np.dot(np.asarray(p) - a, d)) / span
    return 0.0 <= s <= 1.0 and float(np.linalg.norm(np.asarray(a) + s * d - p)) <= 1e-9 * max(1.0, span ** 0.5)


def zigzag(p0, p1) -> np.ndarray:
    """A spring's drawing between two points: straight ends, a zigzag of :data:`SPRING_TURNS` points either side
    of the line in its middle, its width a tenth of its length (points, in the points' own axes)."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    d = p1 - p0
    across = np.array([-d[1], d[0]]) * 0.1
    k = 2 * SPRING_TURNS
    s = np.concatenate([[0.0, 0.2], 0.2 + 0.6 * (np.arange(k) + 0.5) / k, [0.8, 1.0]])
    side = np.concatenate([[0.0, 0.0], np.where(np.arange(k) % 2, -0.5, 0.5), [0.0, 0.0]])
    return p0 + s[:, None] * d + side[:, None] * across


def coil(centre, radius: float, angle: float) -> np.ndarray:
    """A torsion spring's drawing at a joint: a spiral of :data:`COIL_TURNS` turns out to ``radius``, its
    outer end along ``angle`` (the link's, so that it winds up as the link turns).  Points, in ``centre``'s axes."""
    s = np.linspace(0.0, 1.0, 12 * COIL_TURNS + 1)
    a = angle + 2 * math.pi * COIL_TURNS * (s - 1.0)
    r = radius * (0.25 + 0.75 * s)
    return np.asarray(centre, dtype=float) + np.column_stack([r * np.cos(a), r * np.sin(a)])


def frame_geometry(model: Mechanism, z: np.ndarray, trace=None) -> FrameGeometry:
    """Drawing primitives of the mechanism at joint coordinates ``z`` (``trace``: see :func:`trace_point`).

    Examples
    --------
    >>> import grubler
    >>> res = grubler.simulate("thesis-fourbar", t_end=0.5)
    >>> g = frame_geometry(res.model, res.z[0], trace=trace_point("tip", res.model))
    >>> g.trace.round(9).tolist()                     # m: the rocker's tip at t = 0
    [1.0, 0.0]
    """
    sketch = Sketch(model, trace)
    return sketch.geometry(sketch.positions(np.asarray(z, dtype=float)[None, :])[0])


def trace_point(spec: str | None, model: Mechanism):
    """Parse a trace spec: 'tip', or 'linkK:u,v' (a point of link K in its frame).

    Examples
    --------
    >>> from grubler import load_scene
    >>> fourbar = load_scene("thesis-fourbar").mechanism
    >>> trace_point("link3:0.4,0.1", fourbar)         # (link index, point in the link's frame)
    (1, (0.4, 0.1))
    >>> trace_point("tip", fourbar)                   # the last link's far end
    (2, (0.8, 0.0))
    >>> trace_point("link9:0,0", fourbar)
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: --trace: link9 is not a moving link (2..4)
    """
    if spec in (None, ""):
        return None
    if spec == "tip":
        k = model.n_links - 1
        return k, (model.links[k].a, 0.0)
    try:
        name, coords = spec.split(":")
        u_text, v_text = coords.split(",")
        k = number(name.removeprefix("link"), "--trace", integer=True) - 2
        u, v = number(u_text, "--trace"), number(v_text, "--trace")
    except (ValueError, InputError):
        raise SceneError("--trace", f"expected 'tip' or 'linkK:u,v' (e.g. link3:0.4,0), got {brief(spec)}") from None
    if not 0 <= k < model.n_links:
        raise SceneError("--trace", f"link{k + 2} is not a moving link (2..{model.n_links + 1})")
    return k, (u, v)


def trace_path(model: Mechanism, zs: np.ndarray, point) -> np.ndarray:
    """World positions of a link point along a trajectory, (rows, 2).

    Examples
    --------
    >>> import grubler
    >>> res = grubler.simulate("thesis-fourbar", t_end=0.5)
    >>> path = trace_path(res.model, res.z, trace_point("link3:0.4,0.1", res.model))
    >>> path.shape, path[0].round(4).tolist()         # one (x, y) per row of the run, m
    ((51, 2), [0.3134, 0.3964])
    """
    k, local = point
    return link_points(model, zs, [k], [local])[:, 0, :]


def fit_view(model: Mechanism, zs: np.ndarray, extra: np.ndarray | None = None, margin: float = 0.08):
    """Axis limits holding every point of the motion, equal scale, with a margin."""
    sketch = Sketch(model)
    pts = sketch.drawn_points(sketch.positions(zs)).reshape(-1, 2)
    return _view(pts if extra is None or not len(extra) else np.vstack([pts, extra]), margin)


def _view(points: np.ndarray, margin: float = 0.08):
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = max(float(np.max(hi - lo)), 1e-3)
    pad = margin * span + 0.05 * span
    return (lo[0] - pad, hi[0] + pad), (lo[1] - pad, hi[1] + pad)


class Drawer:
    """Draws frames on one axes with fixed limits; re-used for every frame."""

    def __init__(self, ax, model: Mechanism, xlim, ylim):
        self.ax, self.model = ax, model
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        span = max(xlim[1] - xlim[0], ylim[1] - ylim[0])
        self.r = 0.018 * span  # joint radius, m
        self.guide_len = 2.0 * span
        self.artists = []

    def clear(self):
        for a in self.artists:
            a.remove()
        self.artists = []

    def draw(self, geo: FrameGeometry, label: str = ""):
        self.clear()
        ax, r, A = self.ax, self.r, self.artists
        for p, angle, fixed in geo.guides:
            d = np.array([math.cos(angle), math.sin(angle)]) * self.guide_len
            A += ax.plot([p[0] - d[0], p[0] + d[0]], [p[1] - d[1], p[1] + d[1]], "--", color=GUIDE_COLOUR,
                         lw=1.0, zorder=1)
            if fixed:
                A.append(self._hatch(p, angle))
        for corners in geo.plates:
            A.append(ax.add_patch(Polygon(corners, closed=True, fc=LINK_COLOUR, ec=LINK_COLOUR, alpha=0.35,
                                          lw=2.0, zorder=2)))
        for p0, p1 in geo.bars:
            A += ax.plot([p0[0], p1[0]], [p0[1], p1[1]], "-", color=LINK_COLOUR, lw=4, solid_capstyle="round",
                         zorder=2)
        for p0, p1 in geo.actuators:
            barrel = p0 + BARREL_SHARE * (np.asarray(p1) - p0)
            A += ax.plot([p0[0], p1[0]], [p0[1], p1[1]], "-", color="0.25", lw=2.5, zorder=2.5)
            A += ax.plot([p0[0], barrel[0]], [p0[1], barrel[1]], "-", color=CYLINDER_COLOUR, lw=9,
                         solid_capstyle="butt", zorder=2.6)
        for p0, p1 in geo.springs:
            zz = zigzag(p0, p1)
            A += ax.plot(zz[:, 0], zz[:, 1], "-", color=SPRING_COLOUR, lw=1.8, zorder=2.5)
        for c, angle in geo.coils:
            cc = coil(c, 2.6 * r, angle)
            A += ax.plot(cc[:, 0], cc[:, 1], "-", color=SPRING_COLOUR, lw=1.8, zorder=3.5)
        for p, u in geo.loads:  # an arrow of a fixed size in points, ending at the load's point
            A.append(ax.annotate("", xy=tuple(p), xytext=(-40 * u[0], -40 * u[1]), textcoords="offset points",
                                 arrowprops={"arrowstyle": "-|>", "color": LOAD_COLOUR, "lw": 2.0}, zorder=5))
        for c, angle in geo.blocks:
            u = np.array([math.cos(angle), math.sin(angle)])
            v = np.array([-u[1], u[0]])
            corners = [c + 2.2 * r * u * sx + 1.3 * r * v * sy for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            A.append(ax.add_patch(Polygon(corners, closed=True, fc=BLOCK_COLOUR, ec="black", lw=0.8, zorder=3)))
        for p in geo.fixed:
            A.append(self._hatch(p - np.array([0.0, 1.6 * r]), 0.0))
        for c in geo.joints:
            A.append(ax.add_patch(Circle(c, r, fc="white", ec=JOINT_COLOUR, lw=2.0, zorder=4)))
        if geo.trace is not None:
            A.append(ax.add_patch(Circle(geo.trace, 0.5 * r, fc=TRACE_COLOUR, ec="black", lw=0.8, zorder=5)))
        if label:
            A.append(ax.text(0.02, 0.97, label, transform=ax.transAxes, va="top", fontsize=10, family="monospace"))

    def _hatch(self, p, angle):
        # ground hatching: a short base line with slanted strokes below it
        u = np.array([math.cos(angle), math.sin(angle)])
        v = np.array([-u[1], u[0]])
        w = 3 * self.r
        xs, ys = [], []
        for s in np.linspace(-w, w, 6):
            a = p + s * u - 0.2 * self.r * v
            b = a - 1.2 * self.r * (u + v)
            xs += [a[0], b[0], np.nan]
            ys += [a[1], b[1], np.nan]
        xs += [p[0] - w * u[0] - 0.2 * self.r * v[0], p[0] + w * u[0] - 0.2 * self.r * v[0]]
        ys += [p[1] - w * u[1] - 0.2 * self.r * v[1], p[1] + w * u[1] - 0.2 * self.r * v[1]]
        (line,) = self.ax.plot(xs, ys, "-", color="black", lw=1.0, zorder=1)
        return line


FRAME_SIZE = (960, 720)  # pixels of a film frame without signal strips
STRIP_HEIGHT = 130  # pixels each signal strip adds under the mechanism
MAX_SIGNALS = 4
FONT_SIZE = 13  # points at 100 dpi: the film's axes, ticks and labels
_BAR, _JOINT, _BLOCK = 7, 8, 8  # pixels: link width, joint radius, block half-height
PLATE_COLOUR = "#9fbad6"  # a plate's fill: the link colour, lightened
CURSOR_COLOUR = "#d62728"
# the palette entries every frame draws with; the rest of the 256 come from the background
# ("clear" is never drawn: the GIF writer marks a frame's unchanged pixels with it, transparent, so
# a frame stores only what moved, not the rectangle around everything that did)
_INKS = {"white": "#ffffff", "black": "#000000", "link": LINK_COLOUR, "plate": PLATE_COLOUR, "joint": JOINT_COLOUR,
         "block": BLOCK_COLOUR, "guide": GUIDE_COLOUR, "trace": TRACE_COLOUR, "cursor": CURSOR_COLOUR,
         "cylinder": CYLINDER_COLOUR, "rod": "#404040", "spring": SPRING_COLOUR, "load": LOAD_COLOUR,
         "clear": "#ff00ff"}


def frame_size(n_signals: int = 0, size=FRAME_SIZE) -> tuple[int, int]:
    """Pixels (width, height) of a film frame with ``n_signals`` strips under the mechanism."""
    return int(size[0]), int(size[1] + (STRIP_HEIGHT * n_signals + 50 if n_signals else 0))


def check_frames(duration: float, fps: float, speed: float, n_signals: int = 0, size=FRAME_SIZE) -> int:
    """The frame count of ``duration`` seconds of motion, refused past the output budget.

    The GIF writer holds every frame (a byte a pixel) and the part of it that
    changed; an MP4 is piped out frame by frame.

    Examples
    --------
    >>> check_frames(3.0, fps=12, speed=1.0)           # 3 s of motion at 12 frames a second
    37
    >>> check_frames(1e6, fps=100, speed=1.0)          # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    grubler.errors.LimitError: --fps, --speed or the run's length: the animation's frames would take 138 TB ...
    """
    w, h = frame_size(n_signals, size)
    return check_size(duration * fps / speed + 1, 2 * w * h, "the animation's frames",
                      "--fps, --speed or the run's length")


def frame_rows(t: np.ndarray, fps: float, speed: float) -> np.ndarray:
    """The record's row shown in each frame: the last at or before the frame's time."""
    times = np.arange(t[0], t[-1] + 1e-12, speed / fps)
    return np.clip(np.searchsorted(t, times + 1e-12 * max(1.0, abs(t[-1])), side="right") - 1, 0, len(t) - 1)


def animate(model: Mechanism, t: np.ndarray, zs: np.ndarray, out: str, fps: float = 25, speed: float = 1.0,
            trace: str | None = None, title: str = "", signals=None, size=FRAME_SIZE) -> int:
    """Write a GIF (or an MP4, with ffmpeg) of a trajectory; returns the frame count.

    Frames are taken at ``speed`` seconds of motion per second of film, ``fps``
    frames per second, each showing the record's row at or before its time.
    What does not move (axes, grid, ground, the signals' curves) is drawn once
    by matplotlib; each frame is that picture with the mechanism, the trace so
    far and the signals' cursor drawn over it in a fixed palette (Pillow).

    Parameters
    ----------
    model : Mechanism
    t : ndarray (rows,)
    zs : ndarray (rows, N)
        Real joint coordinates at ``t``.
    out : str
        ``.gif`` or ``.mp4``.
    trace : str, optional
        A point to trace (:func:`trace_point`): drawn on its link as a plate.
    signals : list of (label, ndarray), optional
        Series at ``t`` to draw in strips under the mechanism with a cursor at
        the frame's time (at most :data:`MAX_SIGNALS`).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import grubler
    >>> from PIL import Image
    >>> res = grubler.simulate("thesis-fourbar", t_end=0.5)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     n = animate(res.model, res.t, res.z, str(pathlib.Path(d) / "fourbar.gif"), fps=10, trace="tip")
    ...     with Image.open(pathlib.Path(d) / "fourbar.gif") as gif:
    ...         print(n, gif.n_frames, gif.size)          # 0.5 s at 10 frames a second, 960 x 720 px
    6 6 (960, 720)
    """
    if not (0.01 <= fps <= 100.0 and speed > 0):  # a GIF frame lasts 10 ms to 655 s
        raise SceneError("--fps/--speed", f"fps must be 0.01 to 100 and speed positive, got {fps:g}, {speed:g}")
    if out.endswith(".mp4") and shutil.which("ffmpeg") is None:
        raise SceneError("--out", "MP4 needs ffmpeg on the PATH (apt-get install ffmpeg); write a .gif instead")
    if not (out.endswith(".gif") or out.endswith(".mp4")):
        raise SceneError("--out", f"expected a .gif or .mp4 file name, got {out!r}")
    signals = list(signals or [])
    if len(signals) > MAX_SIGNALS:
        raise InputError("--signals", f"at most {MAX_SIGNALS} signals fit under the mechanism, got {len(signals)}")
    t, zs = np.asarray(t, dtype=float), np.asarray(zs, dtype=float)
    check_frames(t[-1] - t[0], fps, speed, len(signals), size)
    rows = frame_rows(t, fps, speed)
    point = trace_point(trace, model)
    sketch = Sketch(model, point)
    pos = sketch.positions(zs[rows])  # every point of every frame: one kernel call
    path = trace_path(model, zs, point) if point else None  # at every row of the record
    film = _Film(model, sketch, pos, path, t, signals, title, size, interval=speed / fps)
    frames = (film.frame(f, r) for f, r in enumerate(rows))
    if out.endswith(".gif"):
        first = next(frames)
        first.save(out, save_all=True, append_images=frames, duration=round(1000.0 / fps), loop=0,
                   optimize=True, transparency=film.ink["clear"])
    else:
        _mp4(frames, out, fps, film.size)
    return len(rows)


def still_figure(model: Mechanism, t: np.ndarray, zs: np.ndarray, fps: float = 25, speed: float = 1.0,
                 trace: str | None = None, title: str = "", signals=None, size=FRAME_SIZE):
    """The matplotlib figure a film's frames are drawn over (axes, ground, the signals' strips), left open.

    What :func:`animate` rasterises once; here to be looked at or checked (its texts, their places).
    """
    t, zs = np.asarray(t, dtype=float), np.asarray(zs, dtype=float)
    rows = frame_rows(t, fps, speed)
    point = trace_point(trace, model)
    sketch = Sketch(model, point)
    path = trace_path(model, zs, point) if point else None
    return _Film(model, sketch, sketch.positions(zs[rows]), path, t, list(signals or []), title, size,
                 keep_figure=True, interval=speed / fps).figure


def time_label(t: float, interval: float) -> str:
    """A frame's time, to as many decimals as tell one frame from the next (at least 2).

    A film of Andrews' squeezer (0.03 s of motion at 0.4 ms a frame) labelled to
    the hundredth would show "t = 0.02 s" on a dozen frames running.

    >>> time_label(1.234, 0.04), time_label(0.01523, 0.0004)
    ('t = 1.23 s', 't = 0.0152 s')
    """
    decimals = min(9, max(2, math.ceil(-math.log10(interval) - 1e-9))) if interval > 0 else 2
    return f"t = {t:.{decimals}f} s"


def sampling_warnings(model: Mechanism, t: np.ndarray, zs: np.ndarray, fps: float, speed: float) -> list[str]:
    """Why a film of this record would show a joint stroboscopically, one line each ([] when it would not).

    A frame shows the record's row at or before its time: the record's own grid
    (the run's ``--dt-out``) and the frames' (``--fps``, ``--speed``) must both
    follow the fastest joint to within 1/8 turn.
    """
    from grubler.views.plotting import coarse_sampling

    t, zs = np.asarray(t, dtype=float), np.asarray(zs, dtype=float)
    thetas = {n: i for i, n in enumerate(model.free_names) if n.startswith("theta")}  # zs's columns: real joints
    rows = frame_rows(t, fps, speed)
    out = [coarse_sampling(t, {n: zs[:, i] for n, i in thetas.items()}, "--dt-out"),
           coarse_sampling(t[rows], {n: zs[rows, i] for n, i in thetas.items()}, "--fps", "frame", speed)]
    return [w for w in out if w]


def _mp4(frames, out: str, fps: float, size) -> None:
    """Pipe RGB frames to ffmpeg (H.264, yuv420p: what players take)."""
    import subprocess

    cmd = ["ffmpeg", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{size[0]}x{size[1]}",
           "-r", f"{fps:g}", "-i", "-", "-an", "-vcodec", "libx264", "-pix_fmt", "yuv420p", out]
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        for im in frames:
            proc.stdin.write(im.convert("RGB").tobytes())
        proc.stdin.close()
    except BrokenPipeError:  # ffmpeg stopped: its message says why
        pass
    except BaseException:  # no frames to finish the film with: no half a film either
        proc.kill()
        proc.wait()
        Path(out).unlink(missing_ok=True)
        raise
    err = proc.stderr.read().decode(errors="replace").strip()
    if proc.wait() != 0:
        raise SceneError("--out", f"ffmpeg failed writing {brief(out)}: {brief(err, 200) if err else 'no message'}")


def _to_palette(rgb: np.ndarray, palette: list[int], never: int):
    """An RGB picture as a palette image, each colour its nearest entry but ``never``.

    Exact, unlike Pillow's cached lookup, which turns white into a near-white.
    """
    from PIL import Image

    packed = (rgb[..., 0].astype(np.int32) << 16) | (rgb[..., 1].astype(np.int32) << 8) | rgb[..., 2]
    colours, inverse = np.unique(packed.ravel(), return_inverse=True)
    c = np.stack([colours >> 16, (colours >> 8) & 255, colours & 255], axis=1).astype(np.int32)
    pal = np.asarray(palette, dtype=np.int32).reshape(256, 3)
    distance = ((c[:, None, :] - pal[None, :, :]) ** 2).sum(axis=2)
    distance[:, never] = np.iinfo(np.int32).max
    nearest = np.argmin(distance, axis=1).astype(np.uint8)
    im = Image.fromarray(nearest[inverse].reshape(packed.shape), mode="P")
    im.putpalette(palette)
    return im


def _rgb(colour: str) -> tuple[int, int, int]:
    return tuple(int(round(255 * c)) for c in matplotlib.colors.to_rgb(colour))


class _Film:
    """The still background (matplotlib, once) and the frames drawn over it (Pillow)."""

    def __init__(self, model: Mechanism, sketch: Sketch, pos: np.ndarray, path, t: np.ndarray, signals, title: str,
                 size, keep_figure: bool = False, interval: float = 0.04):
        from PIL import Image, ImageFont

        self.interval = interval  # s of motion between frames: the time label's resolution

        signals = [strip_signal(label, values) for label, values in signals]
        self.sketch, self.pos, self.path, self.t, self.signals = sketch, pos, path, t, signals
        drawn = sketch.drawn_points(pos).reshape(-1, 2)
        xlim, ylim = _view(drawn if path is None else np.vstack([drawn, path]))
        top, bottom, left, right = 40, 55, 80, 25
        # the mechanism's panel as tall as its view needs at the frame's width (a
        # slider-crank is wide and flat), at most the frame's height
        width = size[0] - left - right
        tall = width * (ylim[1] - ylim[0]) / (xlim[1] - xlim[0])
        mech_h = int(round(min(max(tall, 0.4 * width), size[1] - top - bottom))) + top + bottom
        w, h = frame_size(len(signals), (size[0], mech_h))
        self.size = w, h
        with plt.rc_context({"font.size": FONT_SIZE}):
            fig = plt.figure(figsize=(w / 100, h / 100), dpi=100)
            ax = fig.add_axes([left / w, 1 - (mech_h - bottom) / h, 1 - (left + right) / w,
                               (mech_h - bottom - top) / h])
            ax.grid(True, alpha=0.25)
            if title:
                fig.suptitle(title, y=1 - 8 / h, va="top", fontsize=FONT_SIZE + 2)
            drawer = Drawer(ax, model, xlim, ylim)
            ax.apply_aspect()
            self.ax = ax
            self.scale = self._px(np.array([[1.0, 0.0]]))[0, 0] - self._px(np.array([[0.0, 0.0]]))[0, 0]
            drawer.r = _JOINT / self.scale
            geo0 = sketch.geometry(pos[0])
            static = FrameGeometry(guides=[g for g in geo0.guides if g[2]], fixed=geo0.fixed)
            drawer.draw(static)
            self.strips = []
            for i, (label, values) in enumerate(signals):
                y0 = mech_h + i * STRIP_HEIGHT + 25
                sax = fig.add_axes([left / w, 1 - (y0 + STRIP_HEIGHT - 30) / h, 1 - (left + right) / w,
                                    (STRIP_HEIGHT - 30) / h])
                _plot_signal(sax, t, np.asarray(values, dtype=float), wrapped="wrapped to" in label)
                sax.set_title(label, loc="left", fontsize=FONT_SIZE, pad=3)
                sax.yaxis.get_major_formatter().set_useOffset(False)  # no "+1.2e4" over the strip's title
                sax.grid(True, alpha=0.3)
                sax.set_xlim(t[0], t[-1])
                if i < len(signals) - 1:
                    sax.tick_params(labelbottom=False)
                else:
                    sax.set_xlabel("t [s]")
                self.strips.append(sax)
            fig.canvas.draw()
            for sax in self.strips:  # a power of ten the ticks leave out joins the title, not the title's corner
                power = sax.yaxis.get_offset_text()
                if power.get_text():
                    sax.set_title(f"{sax.get_title(loc='left')}, axis in units of {power.get_text()}", loc="left",
                                  fontsize=FONT_SIZE, pad=3)
                    power.set_visible(False)
                    fig.canvas.draw()
            rgb = Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy())
            # strip geometry in pixels: cursor x of each frame, the curve's value as a dot
            self.strip_px = []
            for sax, (_, values) in zip(self.strips, signals):
                bb = sax.get_window_extent()
                self.strip_px.append((sax, h - bb.y1, h - bb.y0, np.asarray(values, dtype=float)))
            self.path_px = None if path is None else self._px(path)
            self.pos_px = self._px(pos.reshape(-1, 2)).reshape(pos.shape)
            if keep_figure:
                self.figure = fig
                return
            plt.close(fig)
        inks = list(_INKS)
        self.ink = {k: i for i, k in enumerate(inks)}
        rest = rgb.quantize(colors=256 - len(inks), method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
        palette = [c for k in inks for c in _rgb(_INKS[k])] + rest.getpalette()[: 3 * (256 - len(inks))]
        palette += [0] * (768 - len(palette))
        self.base = _to_palette(np.asarray(rgb), palette, never=self.ink["clear"])
        self.traced = 0
        font_path = f"{matplotlib.get_data_path()}/fonts/ttf/DejaVuSans.ttf"
        self.font = ImageFont.truetype(font_path, int(round(FONT_SIZE * 100 / 72)))
        bb = ax.get_window_extent()
        self.label_at = (bb.x0 + 10, h - bb.y1 + 8)

    def _px(self, xy: np.ndarray) -> np.ndarray:
        """World (m) to frame pixels (x right, y down)."""
        d = self.ax.transData.transform(xy)
        d[:, 1] = self.size[1] - d[:, 1]
        return d

    def frame(self, f: int, row: int):
        """Frame ``f``, showing the record's row ``row``."""
        from PIL import ImageDraw

        ink = self.ink
        if self.path_px is not None and row > self.traced:  # the trace grows on the base, under every later frame
            seg = self.path_px[self.traced: row + 1]
            ImageDraw.Draw(self.base).line([tuple(p) for p in seg], fill=ink["trace"], width=2)
            self.traced = row
        im = self.base.copy()
        d = ImageDraw.Draw(im)
        geo = self.sketch.geometry(self.pos[f])
        px = self._map
        for p, angle, fixed in geo.guides:
            if not fixed:
                c, u = px(p), np.array([math.cos(angle), -math.sin(angle)]) * 2 * self.size[0]
                d.line([tuple(c - u), tuple(c + u)], fill=ink["guide"], width=1)
        for corners in geo.plates:
            d.polygon([tuple(px(c)) for c in corners], fill=ink["plate"], outline=ink["link"], width=3)
        for p0, p1 in geo.bars:
            a, b = px(p0), px(p1)
            d.line([tuple(a), tuple(b)], fill=ink["link"], width=_BAR)
            for c in (a, b):  # round caps
                d.ellipse([c[0] - _BAR / 2, c[1] - _BAR / 2, c[0] + _BAR / 2, c[1] + _BAR / 2], fill=ink["link"])
        for p0, p1 in geo.actuators:
            a, b = px(p0), px(p1)
            d.line([tuple(a), tuple(b)], fill=ink["rod"], width=3)
            d.line([tuple(a), tuple(a + BARREL_SHARE * (b - a))], fill=ink["cylinder"], width=2 * _BAR)
        for p0, p1 in geo.springs:
            d.line([tuple(q) for q in zigzag(px(p0), px(p1))], fill=ink["spring"], width=3)
        for c, angle in geo.coils:  # the image's y points down: the world's angle turns the other way
            d.line([tuple(q) for q in coil(px(c), 2.6 * _JOINT, -angle)], fill=ink["spring"], width=3)
        for p, u in geo.loads:  # the image's y points down
            tip, u = px(p), np.array([u[0], -u[1]])
            tail, side = tip - LOAD_ARROW_PX * u, np.array([-u[1], u[0]])
            d.line([tuple(tail), tuple(tip)], fill=ink["load"], width=3)
            d.polygon([tuple(tip), tuple(tip - 12 * u + 6 * side), tuple(tip - 12 * u - 6 * side)], fill=ink["load"])
        for c, angle in geo.blocks:
            c = px(c)
            u = np.array([math.cos(angle), -math.sin(angle)])
            v = np.array([-u[1], u[0]])
            pts = [c + 1.7 * _BLOCK * u * sx + _BLOCK * v * sy for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            d.polygon([tuple(q) for q in pts], fill=ink["block"], outline=ink["black"], width=1)
        for c in geo.joints:
            c = px(c)
            d.ellipse([c[0] - _JOINT, c[1] - _JOINT, c[0] + _JOINT, c[1] + _JOINT], fill=ink["white"],
                      outline=ink["joint"], width=3)
        if geo.trace is not None:
            c = px(geo.trace)
            d.ellipse([c[0] - 5, c[1] - 5, c[0] + 5, c[1] + 5], fill=ink["trace"], outline=ink["black"])
        label = time_label(self.t[row], self.interval)
        box = d.textbbox(self.label_at, label, font=self.font)
        d.rectangle([box[0] - 4, box[1] - 3, box[2] + 4, box[3] + 3], fill=ink["white"])  # off the grid lines
        d.text(self.label_at, label, fill=ink["black"], font=self.font)
        for sax, y_top, y_bottom, values in self.strip_px:
            cx, cy = sax.transData.transform((self.t[row], values[row]))
            cy = self.size[1] - cy
            d.line([(cx, y_top), (cx, y_bottom)], fill=ink["cursor"], width=2)
            d.ellipse([cx - 5, cy - 5, cx + 5, cy + 5], fill=ink["cursor"])
        return im

    def _map(self, p) -> np.ndarray:
        return self._px(np.asarray(p, dtype=float).reshape(1, 2))[0]


def strip_signal(label: str, values) -> tuple[str, np.ndarray]:
    """A signal as its strip draws it: a pressure in bar, a turning angle wrapped to [-pi, pi).

    The label says which (``motor.theta2 [rad], wrapped to ±π (38 turns)``); the
    cursor's dot follows the values returned.

    Examples
    --------
    >>> strip_signal("cylinder.pressure_a [Pa]", np.array([1e7, 2e7]))
    ('cylinder.pressure_a [bar]', array([100., 200.]))
    """
    from grubler.views.plotting import BAR, PRESSURE_UNIT, turns, wrapped_label

    values = np.asarray(values, dtype=float)
    if label.endswith(f"[{PRESSURE_UNIT}]"):
        return label[: -len(PRESSURE_UNIT) - 1] + "bar]", values / BAR
    if label.endswith("[rad]") and turns(values) > 1.0:
        return wrapped_label(label, values), (values + math.pi) % (2.0 * math.pi) - math.pi
    return label, values


def _plot_signal(ax, t: np.ndarray, values: np.ndarray, wrapped: bool = False) -> None:
    """A strip's curve: as it is, or its min/max band and mean where denser than the strip can show.

    A ``wrapped`` angle (already in [-pi, pi)) is broken where it wraps, not joined across the strip.
    """
    from grubler.views.plotting import ENVELOPE_BINS, envelope

    if len(t) > 2 * ENVELOPE_BINS:
        tb, lo, hi, mean = envelope(t, values, ENVELOPE_BINS)
        if wrapped:  # a bin that spans a wrap: its band reaches across (the crank was on both sides), no mean
            across = hi - lo > math.pi
            lo, hi, mean = np.where(across, -math.pi, lo), np.where(across, math.pi, hi), np.where(across, np.nan, mean)
        (line,) = ax.plot(*(_break_wraps(tb, mean) if wrapped else (tb, mean)), lw=1.2)
        ax.fill_between(tb, lo, hi, color=line.get_color(), alpha=0.3, lw=0)
    else:
        ax.plot(*(_break_wraps(t, values) if wrapped else (t, values)), lw=1.2)


def _break_wraps(t: np.ndarray, values: np.ndarray):
    """A wrapped angle with a NaN where it jumps by more than half a turn: no line drawn across the strip."""
    cut = np.flatnonzero(np.abs(np.diff(values)) > math.pi) + 1
    return np.insert(t, cut, t[cut]), np.insert(values, cut, np.nan)
