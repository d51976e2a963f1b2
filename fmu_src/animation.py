"""Drawing a mechanism to scale, and animating a trajectory.

The geometry of a frame comes from the same kinematics the simulator integrates
(:func:`grubler.kinematics.chain_kinematics`); this module only decides how each
part looks: links as bars, revolute joints as circles, prismatic joints as a block
on its guide with the guide's axis drawn, fixed pivots hatched.  The view is fitted
once to every point of the whole motion, so nothing is clipped and nothing jumps.
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass, field

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import animation as mpl_animation  # noqa: E402
from matplotlib.patches import Circle, Polygon  # noqa: E402

from .errors import InputError, SceneError  # noqa: E402
from .limits import brief, check_size, number  # noqa: E402
from .kinematics import chain_kinematics, point_on_link  # noqa: E402
from .model import PRISMATIC, Mechanism  # noqa: E402

LINK_COLOUR = "#1f4e79"
JOINT_COLOUR = "#d62728"  # used for revolute joints only: tests find them by it
BLOCK_COLOUR = "#2ca02c"
GUIDE_COLOUR = "#7f7f7f"
TRACE_COLOUR = "#ff7f0e"


@dataclass
class FrameGeometry:
    """What one frame shows, in world coordinates (m)."""

    bars: list = field(default_factory=list)  # [(p0, p1), ...]
    joints: list = field(default_factory=list)  # revolute centres
    fixed: list = field(default_factory=list)  # ground pivots (hatched)
    blocks: list = field(default_factory=list)  # (centre, axis angle)
    guides: list = field(default_factory=list)  # (point, axis angle, fixed?)
    plates: list = field(default_factory=list)  # ternary (or higher) links: their joints' corners

    def points(self) -> np.ndarray:
        pts = [p for bar in self.bars for p in bar] + self.joints + self.fixed + [b[0] for b in self.blocks]
        return np.array(pts, dtype=float).reshape(-1, 2)


def frame_geometry(model: Mechanism, z: np.ndarray) -> FrameGeometry:
    """Drawing primitives of the mechanism at joint coordinates ``z``."""
    kin = chain_kinematics(model, z, np.zeros(model.n_links))
    geo = FrameGeometry()
    n = model.n_links
    parent = [pk - 2 for pk in model.parents]  # each link's predecessor, -1 the ground
    # where each link's vector ends: its children hang off there (plus their slides)
    ends = []
    for k, link in enumerate(model.links):
        end, _, _ = point_on_link(kin, k, (link.a, 0.0))
        ends.append(end)
        geo.bars.append((kin.origin[k].copy(), end))
        for c in range(k + 1, n):
            if parent[c] == k and not np.allclose(end, kin.origin[c]):
                geo.bars.append((end, kin.origin[c].copy()))  # the slide's offset along the axis
    ground_end = np.array([model.a1 * math.cos(model.theta1), model.a1 * math.sin(model.theta1)])
    for k, link in enumerate(model.links):
        axis_angle = math.atan2(kin.axis[k][1], kin.axis[k][0])
        if link.joint == PRISMATIC:
            base = ground_end if parent[k] < 0 else ends[parent[k]]
            geo.guides.append((base, axis_angle, parent[k] < 0))
            geo.blocks.append((kin.origin[k].copy(), axis_angle))
        else:
            geo.joints.append(kin.origin[k].copy())
            if parent[k] < 0:
                geo.fixed.append(kin.origin[k].copy())
    # a link with three or more joints (its own, its children's, closures' points) is a plate
    corners: list[list] = [[kin.origin[k].copy()] + [kin.origin[c].copy() for c in range(n) if parent[c] == k]
                           for k in range(n)]
    for cl in model.closures:
        corners[cl.link - 2].append(point_on_link(kin, cl.link - 2, cl.point)[0])
        if cl.to_link > 1:
            corners[cl.to_link - 2].append(point_on_link(kin, cl.to_link - 2, cl.to_point)[0])
    for pts in corners:
        distinct = [p for i, p in enumerate(pts) if all(np.linalg.norm(p - q) > 1e-9 for q in pts[:i])]
        if len(distinct) >= 3:
            c = np.mean(distinct, axis=0)
            geo.plates.append(sorted(distinct, key=lambda p: math.atan2(p[1] - c[1], p[0] - c[0])))
    for cl in model.closures:
        a_pt, _, _ = point_on_link(kin, cl.link - 2, cl.point)
        if cl.kind == "revolute":
            geo.joints.append(a_pt)
            if cl.to_link == 1:
                geo.fixed.append(np.asarray(cl.to_point, float))
        else:
            base_angle = 0.0 if cl.to_link == 1 else kin.theta[cl.to_link - 2]
            if cl.to_link == 1:
                origin = np.asarray(cl.to_point, float)
            else:
                origin, _, _ = point_on_link(kin, cl.to_link - 2, cl.to_point)
            geo.guides.append((origin, base_angle + cl.angle, cl.to_link == 1))
            geo.blocks.append((a_pt, base_angle + cl.angle))
    return geo


def trace_point(spec: str | None, model: Mechanism):
    """Parse a trace spec: 'tip', or 'linkK:u,v' (a point of link K in its frame)."""
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
    """World positions of a link point along a trajectory."""
    k, local = point
    zero = np.zeros(model.n_links)
    return np.array([point_on_link(chain_kinematics(model, z, zero), k, local)[0] for z in zs])


def fit_view(model: Mechanism, zs: np.ndarray, extra: np.ndarray | None = None, margin: float = 0.08):
    """Axis limits holding every point of the motion, equal scale, with a margin."""
    pts = [frame_geometry(model, z).points() for z in zs]
    allp = np.vstack(pts + ([extra] if extra is not None and len(extra) else []))
    lo, hi = allp.min(axis=0), allp.max(axis=0)
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
        for c, angle in geo.blocks:
            u = np.array([math.cos(angle), math.sin(angle)])
            v = np.array([-u[1], u[0]])
            corners = [c + 2.2 * r * u * sx + 1.3 * r * v * sy for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            A.append(ax.add_patch(Polygon(corners, closed=True, fc=BLOCK_COLOUR, ec="black", lw=0.8, zorder=3)))
        for p in geo.fixed:
            A.append(self._hatch(p - np.array([0.0, 1.6 * r]), 0.0))
        for c in geo.joints:
            A.append(ax.add_patch(Circle(c, r, fc="white", ec=JOINT_COLOUR, lw=2.0, zorder=4)))
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


def check_frames(duration: float, fps: float, speed: float, size=(6.4, 5.2), dpi: int = 80) -> int:
    """The frame count of ``duration`` seconds of motion, refused past the output budget.

    The GIF writer holds every frame in memory (RGBA at the figure's size).
    """
    return check_size(duration * fps / speed + 1, 4 * size[0] * size[1] * dpi * dpi, "the animation's frames",
                      "--fps, --speed or the run's length")


def animate(model: Mechanism, t: np.ndarray, zs: np.ndarray, out: str, fps: int = 25, speed: float = 1.0,
            trace: str | None = None, title: str = "", size=(6.4, 5.2), dpi: int = 80) -> int:
    """Write a GIF (or MP4 with ffmpeg) of a trajectory; returns the frame count.

    Frames are taken at ``speed`` seconds of motion per second of film, ``fps``
    frames per second.
    """
    if not (0.01 <= fps <= 100.0 and speed > 0):  # a GIF frame lasts 10 ms to 655 s
        raise SceneError("--fps/--speed", f"fps must be 0.01 to 100 and speed positive, got {fps:g}, {speed:g}")
    if out.endswith(".mp4") and shutil.which("ffmpeg") is None:
        raise SceneError("--out", "MP4 needs ffmpeg on the PATH (apt-get install ffmpeg); write a .gif instead")
    if not (out.endswith(".gif") or out.endswith(".mp4")):
        raise SceneError("--out", f"expected a .gif or .mp4 file name, got {out!r}")
    check_frames(t[-1] - t[0], fps, speed, size, dpi)
    times = np.arange(t[0], t[-1] + 1e-12, speed / fps)
    idx = np.clip(np.searchsorted(t, times - 1e-12), 0, len(t) - 1)
    point = trace_point(trace, model)
    path = trace_path(model, zs, point) if point else None
    xlim, ylim = fit_view(model, zs, path)
    fig, ax = plt.subplots(figsize=size, dpi=dpi)
    ax.grid(True, alpha=0.25)
    if title:
        ax.set_title(title, fontsize=10)
    drawer = Drawer(ax, model, xlim, ylim)
    (trace_line,) = ax.plot([], [], "-", color=TRACE_COLOUR, lw=1.2, zorder=1)

    def update(i):
        j = idx[i]
        drawer.draw(frame_geometry(model, zs[j]), f"t = {t[j]:7.3f} s")
        if path is not None:
            trace_line.set_data(path[: j + 1, 0], path[: j + 1, 1])
        return drawer.artists

    writer = mpl_animation.PillowWriter(fps=fps) if out.endswith(".gif") else mpl_animation.FFMpegWriter(fps=fps)
    anim = mpl_animation.FuncAnimation(fig, update, frames=len(idx), blit=False)
    anim.save(out, writer=writer)
    plt.close(fig)
    return len(idx)
