"""The perspective view of a spatial mechanism: a pinhole camera, its fit, and what a frame shows.

Computation only (no figure): :class:`Camera` projects world points to pixels;
:func:`orbit_camera` places one on a sphere about a target (azimuth about the
up direction, the one gravity points against, elevation above the horizontal);
:func:`fit_camera` takes the distance at which every point of a whole motion lies
inside the picture; :class:`SpatialSketch` says which points of which links a
drawing needs (links as tubes between their joints, joint axes, slides' guides,
ball joints, the ground) so that one kernel call per film places them all;
:func:`draw_list` orders a frame's parts far to near (the painter's depth sort).
:mod:`grubler.views.spatial_film` rasterises them.

Examples
--------
>>> cam = orbit_camera(azimuth=0.0, elevation=0.0, distance=2.0, target=(0, 0, 0), up=(0, 0, 1),
...                    size=(200, 100), focal=100.0)
>>> uv, depth = cam.project([[0.0, 0.0, 0.0], [0.0, 0.5, 0.5]])
>>> uv.round(6).tolist(), depth.tolist()      # the target at the centre; +y to the right, +z up
([[100.0, 50.0], [125.0, 25.0]], [2.0, 2.0])

The default view, its lens (the picture's height seen from the camera) and side, in degrees:

>>> [round(math.degrees(a), 9) for a in (FIELD_OF_VIEW, AZIMUTH, ELEVATION)]
[30.0, -55.0, 25.0]

A fit keeps the title's band free (``TITLE_PX`` at the top) where a film or the app writes one:

>>> cam = fit_camera([[0, 0, 0], [1, 1, 1]], size=(400, 300), top=TITLE_PX)
>>> bool(cam.project([[0, 0, 0], [1, 1, 1]])[0][:, 1].min() > TITLE_PX)
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from grubler.errors import SceneError
from grubler.limits import brief, parse_angle, parse_length

__all__ = ["Camera", "orbit_camera", "fit_camera", "parse_camera", "up_direction", "SpatialSketch", "draw_list",
           "ground_grid", "FIELD_OF_VIEW", "AZIMUTH", "ELEVATION", "TITLE_PX"]

FIELD_OF_VIEW = math.radians(30)  # the picture's height, seen from the camera: a normal lens's
AZIMUTH, ELEVATION = math.radians(-55), math.radians(25)  # the default view: from the front right, above
MARGIN = 0.06  # of the half-picture left free around a fitted motion
TITLE_PX = 36  # px at the picture's top a film's or the app's title line takes: a fit leaves it free


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: its place, the point it looks at, the up direction and the focal length in pixels.

    A point p is seen at depth ``(p - position) . f`` along the view direction f,
    and drawn at ``(w/2 + F x / depth, h/2 - F y / depth)`` with x and y its
    distances right of and above the view axis.

    Examples
    --------
    From 2 m up the z axis looking down, y up in the picture: +x is to the right.

    >>> cam = Camera(np.array([0.0, 0, 2]), np.zeros(3), np.array([0.0, 1, 0]), focal=100.0, size=(200, 100))
    >>> uv, depth = cam.project([[0.5, 0.0, 0.0], [0.0, 0.0, 3.0]])
    >>> uv[0].tolist(), depth.tolist(), bool(np.isnan(uv[1]).all())    # the second is behind the camera
    ([125.0, 50.0], [2.0, -1.0], True)
    """

    position: np.ndarray
    target: np.ndarray
    up: np.ndarray
    focal: float
    size: tuple
    centre: tuple | None = None  # where the view axis meets the picture, px (default its middle)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The picture's right and up directions and the view direction, in the world."""
        f = self.target - self.position
        f = f / np.linalg.norm(f)
        r = np.cross(f, self.up)
        if np.linalg.norm(r) < 1e-9:  # looking straight along up: any right will do
            r = np.cross(f, _square(self.up))
        r = r / np.linalg.norm(r)
        return r, np.cross(r, f), f

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (..., 2) and depths (...) of world points (..., 3); a depth <= 0 is behind."""
        q = np.asarray(points, dtype=float) - self.position
        r, u, f = self.basis()
        depth = q @ f
        safe = np.where(depth > 1e-12, depth, np.nan)  # behind the camera: no place in the picture
        cu, cv = self.centre or (self.size[0] / 2, self.size[1] / 2)
        uv = np.stack([cu + self.focal * (q @ r) / safe, cv - self.focal * (q @ u) / safe], axis=-1)
        return uv, depth


def _square(up) -> np.ndarray:
    """A horizontal reference direction: world x made square to up (world y where up is along x)."""
    up = np.asarray(up, dtype=float)
    for e in (np.array([1.0, 0, 0]), np.array([0, 1.0, 0])):
        h = e - (e @ up) * up
        if np.linalg.norm(h) > 1e-6:
            return h / np.linalg.norm(h)
    raise AssertionError("unreachable: x and y cannot both be along up")


def up_direction(gravity) -> np.ndarray:
    """The view's up: against gravity (world z without gravity).

    >>> up_direction((0, -9.81, 0)).tolist(), up_direction((0, 0, 0)).tolist()
    ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
    """
    g = np.asarray(gravity, dtype=float)
    n = np.linalg.norm(g)
    return -g / n + 0.0 if n > 0 else np.array([0.0, 0.0, 1.0])  # (+ 0.0: no negative zero)


def _direction(azimuth: float, elevation: float, up) -> np.ndarray:
    """From the target towards the camera: azimuth about up from the horizontal reference, elevation above."""
    up = np.asarray(up, dtype=float) / np.linalg.norm(up)
    h1 = _square(up)
    h2 = np.cross(up, h1)
    return math.cos(elevation) * (math.cos(azimuth) * h1 + math.sin(azimuth) * h2) + math.sin(elevation) * up


def _focal(size, fov: float) -> float:
    return size[1] / 2 / math.tan(fov / 2)


def orbit_camera(azimuth: float, elevation: float, distance: float, target, up=(0, 0, 1), size=(960, 720),
                 focal: float | None = None, fov: float = FIELD_OF_VIEW) -> Camera:
    """A camera ``distance`` from ``target`` at ``azimuth`` (about up, from world x) and ``elevation``, rad.

    Examples
    --------
    >>> cam = orbit_camera(math.pi / 2, 0.0, 2.0, target=(0, 0, 0))    # on the y axis, level
    >>> cam.position.round(12).tolist(), cam.focal == 720 / 2 / math.tan(FIELD_OF_VIEW / 2)
    ([0.0, 2.0, 0.0], True)
    """
    up = np.asarray(up, dtype=float) / np.linalg.norm(up)
    target = np.asarray(target, dtype=float)
    position = target + distance * _direction(azimuth, elevation, up)
    return Camera(position, target, up, focal or _focal(size, fov), tuple(size))


def fit_camera(points, azimuth: float = AZIMUTH, elevation: float = ELEVATION, up=(0, 0, 1), size=(960, 720),
               distance: float | None = None, fov: float = FIELD_OF_VIEW, margin: float = MARGIN,
               top: float = 0.0) -> Camera:
    """A camera looking at the middle of ``points`` (every point of a motion, P x 3) from the given side,
    fitted to the picture below a band of ``top`` px (where a title is written; 0: the whole picture).

    Without a ``distance``, the nearest at which every point lies inside the
    picture, ``margin`` of the half-picture free: for a point at x right of the
    view axis and w nearer than the target, F |x| / (D - w) <= (1 - margin) W / 2
    gives D >= F |x| / ((1 - margin) W / 2) + w; the largest such D over the
    points (and over their heights) is the fit.  The picture's centre is then
    moved to the middle of the points' image and, at a fitted distance, the
    focal length scaled so that they fill it (a given distance keeps the lens:
    the distance is the zoom).

    Examples
    --------
    >>> box = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    >>> cam = fit_camera(box, size=(400, 300))
    >>> uv, depth = cam.project(box)
    >>> bool(np.all((uv >= 0) & (uv <= (400, 300))) and np.all(depth > 0))
    True
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not len(pts):
        raise SceneError("camera", "no finite point to look at")
    if top:  # the fit below the band, then the picture's centre moved down by it
        camera = fit_camera(pts, azimuth, elevation, up, (size[0], size[1] - top), distance, fov, margin)
        cu, cv = camera.centre or (size[0] / 2, (size[1] - top) / 2)
        return Camera(camera.position, camera.target, camera.up, camera.focal, tuple(size), (cu, cv + top))
    up = np.asarray(up, dtype=float) / np.linalg.norm(up)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    target = (lo + hi) / 2
    extent = max(float(np.linalg.norm(hi - lo)), 1e-3)
    focal = _focal(size, fov)
    if distance is None:
        probe = orbit_camera(azimuth, elevation, 1.0, target, up, size, focal)
        r, u, f = probe.basis()
        q = pts - target
        toward = -(q @ f)  # how much nearer the camera than the target
        half_w, half_h = (1 - margin) * size[0] / 2, (1 - margin) * size[1] / 2
        need = np.maximum(focal * np.abs(q @ r) / half_w, focal * np.abs(q @ u) / half_h) + toward
        distance = max(float(need.max()), float(toward.max()) + 0.05 * extent, 1e-3)
        fitted = True
    else:
        fitted = False
    camera = orbit_camera(azimuth, elevation, distance, target, up, size, focal)
    uv, depth = camera.project(pts)
    if not np.all(depth > 0):  # a set distance with points behind the camera: looked at as it is
        return camera
    off = uv - (size[0] / 2, size[1] / 2)  # the points' image about the view axis, px
    lo, hi = off.min(axis=0), off.max(axis=0)
    scale = 1.0
    if fitted:
        spans = np.maximum(hi - lo, 1e-9)
        scale = float(min((1 - margin) * size[0] / spans[0], (1 - margin) * size[1] / spans[1]))
    centre = (size[0] / 2 - scale * (lo[0] + hi[0]) / 2, size[1] / 2 - scale * (lo[1] + hi[1]) / 2)
    return Camera(camera.position, camera.target, camera.up, focal * scale, tuple(size), centre)


def parse_camera(text: str, field: str = "--camera") -> tuple[float, float, float | None]:
    """``AZIMUTH,ELEVATION[,DISTANCE]`` as the command line gives it: two angles with their unit (the rule of
    every angle typed, :func:`grubler.limits.parse_angle`) and a length (m, or with its unit).

    Examples
    --------
    >>> az, el, d = parse_camera("30 deg, 20 deg, 1.5 m")
    >>> round(math.degrees(az), 9), round(math.degrees(el), 9), d
    (30.0, 20.0, 1.5)
    >>> parse_camera("-90deg,pi/6")[2] is None
    True
    """
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) not in (2, 3) or not all(parts):
        raise SceneError(field, f"expected AZIMUTH,ELEVATION[,DISTANCE] such as '30 deg,20 deg,1.5 m', "
                                f"got {brief(text)}")
    az, el = parse_angle(parts[0], f"{field} azimuth"), parse_angle(parts[1], f"{field} elevation")
    if not abs(el) < math.pi / 2:
        raise SceneError(f"{field} elevation", f"must be between -90 and 90 deg (not looking straight along "
                                               f"the vertical), got {math.degrees(el):g} deg")
    distance = None
    if len(parts) == 3:
        distance = parse_length(parts[2], f"{field} distance")
        if not distance > 0:
            raise SceneError(f"{field} distance", f"must be positive, got {distance:g}")
    return az, el, distance


# -- what a drawing of a spatial mechanism shows ----------------------------------------------------------------
@dataclass
class SpatialSketch:
    """The points (each fixed to a link, -1 the ground) and the parts a drawing of ``mechanism`` needs.

    ``segments``: (i, j, body, kind) with kind 'link' (a tube of the body),
    'ground', 'axis' (a joint's axis) or 'guide' (a slide's); ``markers``: (i,
    body, kind) with kind 'revolute', 'slide', 'ball', 'fixed' or 'pin' (a
    ground attachment).  ``body`` is the link drawn (-1 the ground).  A link whose
    joints all sit at one point (a spherical linkage's, whose axes meet) is
    drawn as the arc between its axes on a sphere of its mass centre's radius;
    the massless links inside a ball joint are not drawn: the ball is.  Where such a
    body's mass centre is on its own axis it is a shaft with a yoke on each pin it
    holds, and where it is at the meeting point a cross (the Hooke joint's).

    Examples
    --------
    The Hooke joint: two shafts (a tube and a yoke of three each), the cross's two bars, a
    short axis line at each of the four pins; a bearing on each shaft and the four pins.

    >>> from grubler.mechanism.spatial import hooke_joint
    >>> sketch = SpatialSketch(hooke_joint(), np.zeros((1, 3)))    # the motion's coordinates: one row here
    >>> [sum(kind == k for *_, kind in sketch.segments) for k in ("link", "axis")]
    [10, 4]
    >>> [sum(kind == k for *_, kind in sketch.markers) for k in ("pin", "revolute")]
    [2, 4]
    """

    mechanism: object
    zs: np.ndarray
    links: list = field(default_factory=list)
    local: list = field(default_factory=list)
    segments: list = field(default_factory=list)
    markers: list = field(default_factory=list)

    def __post_init__(self):
        m = self.mechanism
        L = m.links
        scale = m.scale
        arm = 0.08 * scale  # half a joint axis drawn
        children = {k: [] for k in range(-1, len(L))}
        for k, link in enumerate(L):
            children[link.parent].append(k)
        # each body's joint points, in its frame: its own origin, each child's attachment and offset, closures'
        own = {k: [np.zeros(3)] for k in range(len(L))}
        own[-1] = []
        axis_in = {}  # each child's joint axis in its parent's frame
        for k, link in enumerate(L):
            axis_in[k] = np.array([0.0, -math.sin(link.alpha), math.cos(link.alpha)])
            own[link.parent] += [np.array([link.a, 0, 0]), np.array([link.a, 0, 0]) + link.d * axis_in[k]]
        closure_axes = {k: [] for k in range(-1, len(L))}
        for c in m.closures:
            own[c.link].append(np.asarray(c.point, dtype=float))
            own[c.to].append(np.asarray(c.to_point, dtype=float))
            if c.kind != "spherical":
                closure_axes[c.link].append(np.asarray(c.axis, dtype=float))
                closure_axes[c.to].append(np.asarray(c.to_axis, dtype=float))
        eps = 1e-9 * scale

        def coincident(k):
            pts = own[k]
            return all(np.linalg.norm(p - pts[0]) < eps for p in pts) if pts else True

        in_ball = {k for k, link in enumerate(L) if link.mass == 0 and coincident(k) and link.joint == "R"
                   and children[k]}
        # each body's pins besides its own joint: (axis in its frame, the body across: a child or a closure's other)
        pins = {k: [(axis_in[c], c) for c in children[k]] for k in range(len(L))}
        for c in m.closures:
            if c.kind != "spherical":
                pins[c.link].append((np.asarray(c.axis, dtype=float), c.to))
                if c.to >= 0:
                    pins[c.to].append((np.asarray(c.to_axis, dtype=float), c.link))

        def meeting(k):  # a body between axes that meet (a spherical linkage's): how it is drawn, or None
            link = L[k]
            axes = [np.array([0, 0, 1.0])] + [a for a, _ in pins[k]]
            if not (coincident(k) and link.mass > 0 and any(np.linalg.norm(np.cross(axes[0], a)) > 1e-9
                                                              for a in axes[1:])):
                return None
            com = np.asarray(link.com, dtype=float)
            if np.linalg.norm(com) < eps:
                return "cross"  # its mass centre at the meeting point: a Hooke joint's cross
            if np.linalg.norm(np.cross(com, axes[0])) < 1e-9 * np.linalg.norm(com):
                return "shaft"  # its mass centre on its own axis: a shaft with a yoke on each pin
            return "arcs"

        shape = {k: meeting(k) for k in range(len(L))}
        yoked = {k for k, v in shape.items() if v in ("shaft", "cross")}
        for k, link in enumerate(L):
            body = k
            if k in in_ball:
                continue
            # the body's tubes: origin to each child's attachment, then along the child's axis by its offset
            axes = [np.array([0, 0, 1.0])] + [axis_in[c] for c in children[k]] + closure_axes[k]
            concurrent = shape[k] is not None
            if shape[k] == "arcs":
                radius = float(np.linalg.norm(link.com)) or 0.3 * scale
                self._arcs(k, axes, radius, body)
            elif shape[k] == "cross":
                half = self._cross_half(link)
                for a in axes:
                    a = a / np.linalg.norm(a)
                    self._segment((k, -half * a), (k, half * a), body, "link")
            elif shape[k] == "shaft":
                self._shaft(k, link, pins[k], body)
            else:
                self._body(k, children[k], L, axis_in, body, "link")
                for c in m.closures:
                    if c.link == k and np.linalg.norm(c.point) > eps:
                        self._segment((k, np.zeros(3)), (k, np.asarray(c.point, float)), body, "link")
                    if c.to == k and np.linalg.norm(c.to_point) > eps:
                        self._segment((k, np.zeros(3)), (k, np.asarray(c.to_point, float)), body, "link")
                if len(own[k]) == 1 and np.linalg.norm(link.com) > eps:  # a tip: to its far end, as a rod's
                    self._segment((k, np.zeros(3)), (k, 2 * np.asarray(link.com, float)), body, "link")
            # its joint
            ball = link.parent in in_ball
            kind = "ball" if ball else {"R": "revolute", "P": "slide", "C": "slide", "F": "fixed"}[link.joint]
            origin = self._point(k, np.zeros(3))
            if k in yoked:
                # a shaft's or a cross's joints are its pins, drawn where the yokes hold them; a shaft's bearing
                # on the ground sits on its axis, at its mass centre
                if shape[k] == "shaft" and link.parent == -1:
                    self.markers.append((self._point(k, np.asarray(link.com, dtype=float)), -1, "pin"))
                continue
            if not ball and link.joint in "RC" and not (concurrent and coincident(link.parent)):
                self.segments.append((self._point(k, np.array([0, 0, -arm])), self._point(k, np.array([0, 0, arm])),
                                      body, "axis"))
            if concurrent and link.joint == "R":
                self.segments.append((origin, self._point(k, np.array([0, 0, 1.25 * radius])), body, "axis"))
            if link.joint in "PC":
                self._guide(k, link, axis_in[k], arm)
            self.markers.append((origin, body, kind))
            if link.parent == -1:
                self.markers.append((self._point(-1, np.array([link.a, 0, 0])), -1, "pin"))
        arcs_on_ground = [c for c in children[-1] if shape[c] == "arcs"]
        if coincident(-1) and arcs_on_ground and len(children[-1]) > 1:
            radius = max(float(np.linalg.norm(L[c].com)) for c in children[-1]) or 0.3 * scale
            self._arcs(-1, [axis_in[c] for c in children[-1]] + closure_axes[-1], radius, -1, kind="ground")
        else:
            self._body(-1, children[-1], L, axis_in, -1, "ground")
        for c in m.closures:
            if c.to == -1 and not coincident(-1) and np.linalg.norm(c.to_point) > eps:
                self._segment((-1, np.zeros(3)), (-1, np.asarray(c.to_point, float)), -1, "ground")
        for c in m.closures:
            if c.link in yoked and c.to in yoked:
                continue  # a pin in a yoke: the yoke draws it
            kind = {"spherical": "ball", "revolute": "revolute", "cylindrical": "slide"}[c.kind]
            p = self._point(c.link, np.asarray(c.point, float))
            self.markers.append((p, c.link, kind))
            if c.kind != "spherical":
                axis = np.asarray(c.axis, float)
                self.segments.append((self._point(c.link, c.point - arm * axis), self._point(c.link, c.point + arm * axis),
                                      c.link, "axis"))
            if c.to == -1:
                self.markers.append((self._point(-1, np.asarray(c.to_point, float)), -1, "pin"))

    # -- construction ---------------------------------------------------------------------------------------
    def _point(self, link: int, local) -> int:
        local = np.asarray(local, dtype=float)
        for i, (l, p) in enumerate(zip(self.links, self.local)):
            if l == link and np.array_equal(p, local):
                return i
        self.links.append(link)
        self.local.append(local)
        return len(self.links) - 1

    def _segment(self, a, b, body, kind):
        self.segments.append((self._point(*a), self._point(*b), body, kind))

    def _body(self, k, kids, L, axis_in, body, kind):
        for c in kids:
            attach = np.array([L[c].a, 0.0, 0.0])
            if L[c].a:
                self._segment((k, np.zeros(3)), (k, attach), body, kind)
            if L[c].d and L[c].joint not in "PC":  # a slide's offset is its coordinate: its guide shows it
                self._segment((k, attach), (k, attach + L[c].d * axis_in[c]), body, kind)

    def _cross_half(self, link) -> float:
        """A cross's arm, centre to pin: its bars' half-length from its largest moment of inertia (two bars of
        half-length c across each other: I = m (2c)^2 / 12 about the axis square to both, as one bar's)."""
        largest = float(np.linalg.eigvalsh(np.asarray(link.inertia, dtype=float)).max())
        half = math.sqrt(3 * largest / link.mass) if link.mass > 0 else 0.0
        return half or 0.1 * self._reach()

    def _reach(self) -> float:
        """The mechanism's size for parts its rows do not measure: its links' lengths, or twice the farthest
        mass centre (a spherical linkage's rows are all zero)."""
        return max(self.mechanism.scale, *(2 * float(np.linalg.norm(l.com)) for l in self.mechanism.links))

    def _shaft(self, k, link, pins, body):
        """A shaft on its own axis (to twice its mass centre, as a rod's) and, for each pin it holds, a yoke: a
        bridge across the shaft and two arms to the pin's ends, as far out as the part across reaches."""
        L = self.mechanism.links
        com = np.asarray(link.com, dtype=float)
        w = com / np.linalg.norm(com)  # from the meeting point towards the shaft
        base = None
        for axis, other in pins:
            p = axis - (axis @ w) * w
            if np.linalg.norm(p) < 1e-9:
                continue  # a pin along the shaft: no yoke holds it
            p = p / np.linalg.norm(p)
            across = L[other] if other >= 0 else None
            reach = (self._cross_half(across) if across is not None and across.mass > 0
                     and np.linalg.norm(across.com) < 1e-9 * self._reach() else np.linalg.norm(com) / 3)
            base = reach * w
            self._segment((k, base - reach * p), (k, base + reach * p), body, "link")
            for end in (reach * p, -reach * p):
                self._segment((k, base + end), (k, end), body, "link")
                self.segments.append((self._point(k, end - 0.4 * reach * p), self._point(k, end + 0.4 * reach * p),
                                      body, "axis"))
                self.markers.append((self._point(k, end), body, "revolute"))
        self._segment((k, np.zeros(3) if base is None else base), (k, 2 * com), body, "link")

    def _arcs(self, k, axes, radius, body, kind="link", pieces=10):
        """Great-circle arcs of ``radius`` joining the link's axes in turn (a spherical linkage's link)."""
        axes = [a / np.linalg.norm(a) for a in axes]
        for a, b in zip(axes, axes[1:]):
            angle = math.acos(max(-1.0, min(1.0, float(a @ b))))
            if angle < 1e-9:
                continue
            s = np.linspace(0.0, 1.0, pieces + 1)
            pts = [(math.sin((1 - x) * angle) * a + math.sin(x * angle) * b) / math.sin(angle) * radius for x in s]
            for p, q in zip(pts, pts[1:]):
                self._segment((k, p), (k, q), body, kind)
        if kind == "link":  # the joints: where the axes pierce the sphere
            for a in axes:
                self.markers.append((self._point(k, radius * a), body, "revolute"))

    def _guide(self, k, link, axis, arm):
        """A slide's guide on its parent: along the axis over the motion's travel, and a little beyond."""
        m = self.mechanism
        name = f"{link.name}.d"
        travel = link.d + (self.zs[:, m.coordinate_names.index(name)] if len(self.zs) else np.zeros(1))
        lo, hi = float(np.min(travel)) - arm, float(np.max(travel)) + arm
        start = np.array([link.a, 0.0, 0.0])
        self._segment((link.parent, start + lo * axis), (link.parent, start + hi * axis), link.parent, "guide")

    # -- placing ----------------------------------------------------------------------------------------------
    def positions(self, ys) -> np.ndarray:
        """World positions (rows x P x 3) of the sketch's points over states ys (rows x 2N), one kernel call."""
        return self.mechanism.points(ys, self.links, np.array(self.local))


def ground_grid(points, up, lines: int = 8) -> list[tuple[np.ndarray, np.ndarray]]:
    """A square grid on the floor under ``points`` (square to ``up``, through their lowest), spaced by a round
    number (1, 2 or 5 x 10^k m) so that about ``lines`` lines cross the motion's footprint.

    Examples
    --------
    >>> lines = ground_grid([[0, 0, 0], [1, 1, 0.5]], up=(0, 0, 1))    # 0.1 m apart, a step beyond each side
    >>> len(lines), [p.round(12).tolist() for p in lines[0]]
    (26, [[-0.1, -0.1, 0.0], [-0.1, 1.1, 0.0]])
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    up = np.asarray(up, dtype=float) / np.linalg.norm(up)
    h1 = _square(up)
    h2 = np.cross(up, h1)
    floor = float((pts @ up).min())
    a, b = pts @ h1, pts @ h2
    span = max(float(a.max() - a.min()), float(b.max() - b.min()), 1e-3)
    raw = span / lines
    step = min((k * 10.0 ** math.floor(math.log10(raw)) for k in (1, 2, 5, 10)), key=lambda s: abs(s - raw))
    a0, a1 = math.floor(a.min() / step - 1) * step, math.ceil(a.max() / step + 1) * step
    b0, b1 = math.floor(b.min() / step - 1) * step, math.ceil(b.max() / step + 1) * step
    out = []
    for x in np.arange(a0, a1 + step / 2, step):
        out.append((x * h1 + b0 * h2 + floor * up, x * h1 + b1 * h2 + floor * up))
    for y in np.arange(b0, b1 + step / 2, step):
        out.append((a0 * h1 + y * h2 + floor * up, a1 * h1 + y * h2 + floor * up))
    return out


def draw_list(camera: Camera, sketch: SpatialSketch, frame: np.ndarray) -> list[tuple]:
    """One frame's parts, far to near: ('segment', body, kind, (u0, v0, u1, v1), depth) and ('marker', body,
    kind, (u, v), depth), from the sketch's world points at that frame (P x 3).  A part with a point
    behind the camera is left out.

    Examples
    --------
    >>> from grubler.mechanism.spatial import rssr
    >>> m = rssr()
    >>> y0 = m.assembled_start()
    >>> sketch = SpatialSketch(m, y0[None, :m.n_coords])
    >>> frame = sketch.positions(y0[None])[0]
    >>> parts = draw_list(fit_camera(frame), sketch, frame)
    >>> len(parts) == len(sketch.segments) + len(sketch.markers), all(a[4] >= b[4] for a, b in zip(parts, parts[1:]))
    (True, True)
    """
    uv, depth = camera.project(frame)
    parts = []
    for i, j, body, kind in sketch.segments:
        if depth[i] > 0 and depth[j] > 0:
            # by its farther end: a joint at either end of a tube is drawn after the tube, over it
            parts.append(("segment", body, kind, (*uv[i], *uv[j]), max(depth[i], depth[j])))
    for i, body, kind in sketch.markers:
        if depth[i] > 0:
            parts.append(("marker", body, kind, tuple(uv[i]), depth[i] * (1 - 1e-9)))
    parts.sort(key=lambda p: -p[4])
    return parts
