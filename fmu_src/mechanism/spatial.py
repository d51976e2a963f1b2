"""Spatial mechanisms: the imaginary-joints chain in three dimensions.

The Python face of the spatial kernel (``kernel/spatial``, grubler_spatial.h).
A :class:`SpatialMechanism` is a tree of :class:`SpatialLink` rows in
Denavit-Hartenberg form (Craig's modified convention: the link's frame is its
parent's turned by ``alpha`` about the parent's x axis, moved ``a`` along it,
turned by ``theta`` about the new z axis, the joint axis, and moved ``d``
along it) and :class:`SpatialClosure` rows that tie a point (and an axis) of
one link to another link or the ground.  Each link's joint is the thesis's
imaginary pair on its z axis, a revolute and a slide, with the existence
factors choosing ``R``, ``P`` or ``C`` (cylindrical: both).  A spherical joint
is three revolutes on intersecting axes (:func:`spherical_joint`).

The kernel solves the closures exactly with their Lagrange multipliers and
keeps them by projection; where the closure rows are dependent (a planar loop
seen as spatial, a spherical four-bar, whose joint axes meet in one point) the
motion stays exact and the multipliers are the minimum-norm ones:
:meth:`SpatialMechanism.determinacy` says which are fixed by the motion.

Presets: :func:`rssr` (a crank-rocker between skew shafts), :func:`rssp` (a
spatial slider-crank),
:func:`spherical_fourbar` and :func:`planar_fourbar` (the thesis four-bar
written as spatial, which reproduces the planar kernel), :func:`hooke_joint`
(a universal joint as a spherical four-bar), :func:`bennett` (the
overconstrained, mobile 4R loop) and :func:`bricard` (IFToMM benchmark A04);
:data:`PRESETS` names them.

Examples
--------
>>> m = rssr()
>>> m.n_coords, m.n_rows, m.coordinate_names[0]
(5, 3, 'crank.theta')
>>> y0 = m.assembled_start(crank=0.3)
>>> res = m.simulate(y0, t_end=0.2, dt_out=0.1)
>>> bool(abs(res.closure_error()).max() < 1e-10)
True

The joint kinds (existence factors of the revolute and the slide), the closure
kinds (kernel code, rows), gravity's size, the presets and A04's joints:

>>> JOINTS["C"], CLOSURE_KINDS["revolute"], GRAVITY
((1, 1), (1, 5), 9.81)
>>> sorted(PRESETS)
['bennett', 'bricard', 'hooke-joint', 'planar-fourbar-3d', 'rssp', 'rssr', 'spherical-fourbar']
>>> BRICARD_JOINTS[2]    # joint 3 (the benchmark's point P3) and its axis, at the start
((1, -1, 0), (1, 0, 0))
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field

import numpy as np

from grubler import binding
from grubler.errors import InputError, IntegrationError

__all__ = ["SpatialLink", "SpatialClosure", "SpatialMechanism", "SpatialResult", "spherical_joint", "rssr",
           "rssr_geometry", "rssp", "rssp_geometry", "spherical_fourbar", "spherical_fourbar_geometry", "planar_fourbar", "JOINTS",
           "CLOSURE_KINDS", "GRAVITY"]

GRAVITY = 9.81
# the existence factors (revolute, prismatic) of each joint kind on a link's z axis
# (F, fixed: neither, a rigid DH offset for a frame one row cannot reach)
JOINTS = {"R": (1, 0), "P": (0, 1), "C": (1, 1), "F": (0, 0)}
# closure kinds, their codes in the kernel and their row counts
CLOSURE_KINDS = {"spherical": (0, 3), "revolute": (1, 5), "cylindrical": (2, 4)}
# the closure's reaction components, in its frame on the target (n1, n2, v)
REACTION_NAMES = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
# the link table's columns (grs_link): a, alpha, theta, d, revolute, prismatic, parent, m, com (3),
# inertia (xx, xy, xz, yy, yz, zz), damping_r, damping_p
_L_COLUMNS = 19
_L_FIELDS = ("a", "alpha", "theta", "d", "joint", "joint", "parent", "mass", "com", "com", "com", "inertia",
             "inertia", "inertia", "inertia", "inertia", "inertia", "damping", "damping")
_CL_COLUMNS = 15
_CL_FIELDS = ("kind", "link", "to", "point", "point", "point", "axis", "axis", "axis", "to_point", "to_point",
              "to_point", "to_axis", "to_axis", "to_axis")


def _vector(value, field_name: str, size: int = 3) -> np.ndarray:
    try:
        v = np.array(value, dtype=float).reshape(size)
    except (TypeError, ValueError):
        raise InputError(field_name, f"expected {size} numbers, got {value!r}") from None
    if not np.all(np.isfinite(v)):
        raise InputError(field_name, f"every number must be finite, got {v.tolist()}")
    return v


@dataclass(frozen=True)
class SpatialLink:
    """One moving link: its DH row, joint, parent and inertia.

    Attributes
    ----------
    name : str
        What the coordinates are called after (``name.theta``, ``name.d``).
    a, alpha, theta, d : float
        The DH row (m, rad, rad, m); a real joint variable adds its coordinate
        to ``theta`` (revolute) or ``d`` (slide), a locked one keeps the value.
    joint : {'R', 'P', 'C', 'F'}
        The real joint on the z axis: revolute, prismatic, cylindrical (both)
        or fixed (neither: a rigid offset).
    parent : int
        An earlier link's index, -1 the ground.
    mass : float
        kg.
    com : 3 floats
        The mass centre in the link's frame, m.
    inertia : 3 x 3
        The inertia tensor about the mass centre in the link's axes, kg m^2.
    damping : (float, float)
        Viscous damping on theta (N m s/rad) and on d (N s/m).

    Examples
    --------
    >>> arm = SpatialLink("arm", a=0.2, alpha=math.pi / 2, joint="C", mass=1.0)
    >>> arm.row(0)[:7].tolist()    # the kernel's row: a, alpha, theta, d, revolute, slide, parent
    [0.2, 1.5707963267948966, 0.0, 0.0, 1.0, 1.0, -1.0]
    >>> SpatialMechanism([arm]).coordinate_names    # a cylindrical joint: both of its variables
    ('arm.theta', 'arm.d')
    """

    name: str
    a: float = 0.0
    alpha: float = 0.0
    theta: float = 0.0
    d: float = 0.0
    joint: str = "R"
    parent: int = -1
    mass: float = 0.0
    com: tuple = (0.0, 0.0, 0.0)
    inertia: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    damping: tuple = (0.0, 0.0)

    def row(self, k: int) -> np.ndarray:
        """The link's row of the kernel's table (checks what the kernel cannot: kinds and shapes)."""
        where = f"links[{k}]"
        if self.joint not in JOINTS:
            raise InputError(f"{where}.joint", f"{self.joint!r} is not a joint kind: one of R, P, C, F")
        inertia = np.array(self.inertia, dtype=float)
        if inertia.shape != (3, 3):
            raise InputError(f"{where}.inertia", f"expected a 3 x 3 tensor, got shape {inertia.shape}")
        if not np.allclose(inertia, inertia.T, rtol=0, atol=1e-12 * max(1.0, np.abs(inertia).max())):
            raise InputError(f"{where}.inertia", "the inertia tensor must be symmetric")
        damping = _vector(self.damping, f"{where}.damping", 2)
        com = _vector(self.com, f"{where}.com")
        rev, pris = JOINTS[self.joint]
        values = [self.a, self.alpha, self.theta, self.d, rev, pris, self.parent, self.mass, *com,
                  inertia[0, 0], inertia[0, 1], inertia[0, 2], inertia[1, 1], inertia[1, 2], inertia[2, 2],
                  *damping]
        try:
            return np.array(values, dtype=float)
        except (TypeError, ValueError):
            raise InputError(where, f"every field must be a number, got {values!r}") from None


@dataclass(frozen=True)
class SpatialClosure:
    """A closure between two links (or a link and the ground).

    Attributes
    ----------
    kind : {'spherical', 'revolute', 'cylindrical'}
        3, 5 or 4 constraint rows.
    link, to : int
        The closing link and its target (-1: the ground).
    point, to_point : 3 floats
        The joint's point in ``link``'s frame and in ``to``'s frame (the
        world's on the ground), m.
    axis, to_axis : 3 floats
        The joint axis in each frame (unit; not read for a spherical joint).

    Examples
    --------
    >>> ball = SpatialClosure("spherical", link=2, point=(0.8, 0, 0), to_point=(1.0, 0, 0))
    >>> ball.row(0)[:6].tolist()    # kind code, link, to (the ground), point
    [0.0, 2.0, -1.0, 0.8, 0.0, 0.0]
    >>> m = planar_fourbar("spherical")
    >>> m.closures[0].kind, m.n_rows
    ('spherical', 3)
    """

    kind: str
    link: int
    to: int = -1
    point: tuple = (0.0, 0.0, 0.0)
    to_point: tuple = (0.0, 0.0, 0.0)
    axis: tuple = (0.0, 0.0, 1.0)
    to_axis: tuple = (0.0, 0.0, 1.0)

    def row(self, c: int) -> np.ndarray:
        where = f"closures[{c}]"
        if self.kind not in CLOSURE_KINDS:
            raise InputError(f"{where}.kind", f"{self.kind!r} is not a closure kind: one of "
                             + ", ".join(CLOSURE_KINDS))
        vectors = [_vector(getattr(self, f), f"{where}.{f}") for f in ("point", "axis", "to_point", "to_axis")]
        return np.array([CLOSURE_KINDS[self.kind][0], self.link, self.to, *np.concatenate(vectors)], dtype=float)


@dataclass
class SpatialResult:
    """A spatial run: times ``t`` (T) and states ``y`` (T x 2N) over its mechanism.

    Examples
    --------
    >>> m = rssr()
    >>> res = m.simulate(m.assembled_start(), t_end=0.1, dt_out=0.05)
    >>> res.t.tolist(), res.z.shape, res.energy().shape
    ([0.0, 0.05, 0.1], (3, 5), (3, 2))
    >>> bool(res.closure_error().max() < 1e-10)
    True
    """

    mechanism: "SpatialMechanism"
    t: np.ndarray
    y: np.ndarray
    tau: np.ndarray | None = None
    steps: int = 0
    passages: int = 0  # change points passed (the motion crossing where two assembly branches meet)

    @property
    def z(self) -> np.ndarray:
        return self.y[:, :self.mechanism.n_coords]

    @property
    def zd(self) -> np.ndarray:
        return self.y[:, self.mechanism.n_coords:]

    def energy(self) -> np.ndarray:
        """Kinetic and potential energy per row (T x 2), J."""
        return np.array([self.mechanism.dynamics(y, self.tau)[2] for y in self.y])

    def closure_error(self) -> np.ndarray:
        """The largest closure violation per row, m (or rad)."""
        m = self.mechanism
        if m.n_rows == 0:
            return np.zeros(len(self.t))
        return np.array([np.abs(m.constraint(y[:m.n_coords])[0]).max() for y in self.y])


class SpatialMechanism:
    """A spatial chain with its closures: the immutable model of a spatial run.

    Parameters
    ----------
    links : sequence of SpatialLink
    closures : sequence of SpatialClosure
    gravity : 3 floats
        The gravity acceleration in the world, m/s^2 (default 9.81 along -z).

    Raises
    ------
    InputError
        A field the kernel's check (grs_check, the one place validity is
        decided) refuses, named as ``links[k].field`` or ``closures[c].field``.

    Examples
    --------
    A pendulum: a point mass of 1 kg 0.5 m out on a revolute about z, gravity along -y,
    let go level: its angular acceleration is -g / 0.5.

    >>> m = SpatialMechanism([SpatialLink("pendulum", mass=1.0, com=(0.5, 0, 0))], gravity=(0, -9.81, 0))
    >>> zdd, lam, (ke, pe) = m.dynamics([0.0, 0.0])
    >>> round(float(zdd[0]), 9), float(ke)
    (-19.62, 0.0)
    >>> SpatialMechanism([SpatialLink("pendulum", mass=-1.0)])
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: links[0].mass: expected a mass >= 0
    """

    def __init__(self, links, closures=(), gravity=(0.0, 0.0, -GRAVITY)):
        self.links = tuple(links)
        self.closures = tuple(closures)
        if not self.links:
            raise InputError("links", "a spatial mechanism needs at least one moving link")
        if len(self.links) > 64:
            raise InputError("links", f"{len(self.links)} links: at most 64")
        self.gravity = _vector(gravity, "gravity")
        self._links = np.ascontiguousarray([l.row(k) for k, l in enumerate(self.links)], dtype=float)
        self._closures = np.ascontiguousarray(
            [c.row(i) for i, c in enumerate(self.closures)] if self.closures else np.zeros((0, _CL_COLUMNS)))
        self._lib = binding.spatial_library()
        self._model = binding.SpatialModel(len(self.links), len(self.closures), binding.address(self._links),
                                           binding.address(self._closures) if self.closures else None,
                                           (ctypes.c_double * 3)(*self.gravity))
        row, column = ctypes.c_int(0), ctypes.c_int(0)
        status = self._lib.grs_check(ctypes.byref(self._model), ctypes.byref(row), ctypes.byref(column))
        if status != binding.OK:
            raise self._refusal(row.value, column.value)
        self.n_coords = self._lib.grs_n_coords(ctypes.byref(self._model))
        self.n_rows = self._lib.grs_n_rows(ctypes.byref(self._model))
        names = []
        for l in self.links:
            rev, pris = JOINTS[l.joint]
            names += [f"{l.name}.theta"] * rev + [f"{l.name}.d"] * pris
        self.coordinate_names = tuple(names)
        self._work = np.zeros(self._lib.grs_work_size(ctypes.byref(self._model)))
        self._lib.grs_work_init(ctypes.byref(self._model), binding.address(self._work), self._work.size)
        lengths = [abs(l.a) + abs(l.d) for l in self.links] + [float(np.abs(c.point).max()) for c in self.closures]
        self.scale = max(max(lengths), 1e-3)

    # -- refusals ---------------------------------------------------------------
    def _refusal(self, row: int, column: int) -> InputError:
        if column == -2:
            return InputError("gravity", "every component must be finite")
        if row >= 0:
            field_name = f"links[{row}].{_L_FIELDS[column]}" if 0 <= column < _L_COLUMNS else "links"
            reasons = {"joint": "a joint kind (the model needs one real coordinate at least)", "parent":
                       f"an earlier link's index or -1 (the ground): link {row} may hang from links -1..{row - 1}",
                       "mass": "a mass >= 0", "inertia": "a physical inertia tensor about the mass centre "
                       "(positive semi-definite, each principal moment at most the sum of the others)",
                       "damping": "a damping >= 0"}
            reason = reasons.get(_L_FIELDS[column] if column >= 0 else "", "a finite number")
            return InputError(field_name, f"expected {reason}")
        c = -1 - row
        field_name = f"closures[{c}].{_CL_FIELDS[column]}" if 0 <= column < _CL_COLUMNS else "closures"
        reasons = {"link": f"a link index in -1..{len(self.links) - 1}",
                   "to": f"a link index in -1..{len(self.links) - 1}, not the closing link itself",
                   "axis": "a unit vector", "to_axis": "a unit vector", "kind": "a known closure kind"}
        reason = reasons.get(_CL_FIELDS[column] if column >= 0 else "", "a finite number")
        return InputError(field_name, f"expected {reason}")

    # -- evaluations --------------------------------------------------------------
    def _ref(self):
        return ctypes.byref(self._model)

    def _state(self, y, size: int, name: str = "y") -> np.ndarray:
        try:
            y = np.ascontiguousarray(y, dtype=float)
        except (TypeError, ValueError):
            raise InputError(name, f"expected {size} numbers, got {y!r}") from None
        if y.shape != (size,):
            raise InputError(name, f"expected {size} numbers, got shape {y.shape}")
        if not np.all(np.isfinite(y)):
            raise InputError(name, f"every number must be finite, got {y.tolist()}")
        return y

    def _efforts(self, tau) -> np.ndarray | None:
        return None if tau is None else self._state(tau, self.n_coords, "tau")

    def dynamics(self, y, tau=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Accelerations (N), closure multipliers (M) and energies (KE, PE) at state y."""
        y = self._state(y, 2 * self.n_coords)
        tau = self._efforts(tau)
        zdd, lam, energy = np.zeros(self.n_coords), np.zeros(max(self.n_rows, 1)), np.zeros(2)
        status = self._lib.grs_dynamics(self._ref(), binding.address(y), None if tau is None else binding.address(tau),
                                        binding.address(self._work), binding.address(zdd), binding.address(lam),
                                        binding.address(energy))
        if status != binding.OK:
            raise IntegrationError(f"spatial dynamics: {binding.status_message(status)}")
        return zdd, lam[:self.n_rows], energy

    def constraint(self, z) -> tuple[np.ndarray, np.ndarray]:
        """Closure violation phi (M) and its Jacobian (M x N) at z."""
        z = self._state(z, self.n_coords, "z")
        phi, J = np.zeros(max(self.n_rows, 1)), np.zeros((max(self.n_rows, 1), self.n_coords))
        self._lib.grs_constraint(self._ref(), binding.address(z), binding.address(phi), binding.address(J),
                                 binding.address(self._work))
        return phi[:self.n_rows], J[:self.n_rows]

    def frames(self, z) -> tuple[np.ndarray, np.ndarray]:
        """Each link's frame at z: origins (L x 3) and rotations (L x 3 x 3, the link's axes as columns)."""
        z = self._state(z, self.n_coords, "z")
        out = np.zeros((len(self.links), 12))
        self._lib.grs_frames(self._ref(), binding.address(z), binding.address(self._work), binding.address(out))
        return out[:, :3].copy(), out[:, 3:].reshape(-1, 3, 3).copy()

    def points(self, y, link, local) -> np.ndarray:
        """World positions (rows x P x 3) of points local (P x 3) on links link (P; -1 the world) over states y."""
        y = np.ascontiguousarray(np.atleast_2d(y), dtype=float)
        link = np.ascontiguousarray(link, dtype=np.int32)
        local = np.ascontiguousarray(local, dtype=float).reshape(-1, 3)
        out = np.zeros((y.shape[0], len(link), 3))
        status = self._lib.grs_link_points_rows(self._ref(), y.shape[0], binding.address(y), len(link),
                                                binding.address(link), binding.address(local),
                                                binding.address(self._work), binding.address(out))
        if status != binding.OK:
            raise InputError("link", f"a link index in -1..{len(self.links) - 1}")
        return out

    def closure_frame(self, c: int) -> np.ndarray:
        """Closure c's frame on its target (rows n1, n2, v, in the target's axes)."""
        out = np.zeros(9)
        self._lib.grs_closure_frame(self._ref(), int(c), binding.address(out))
        return out.reshape(3, 3)

    def reactions(self, y, tau=None) -> tuple[np.ndarray, np.ndarray]:
        """Closure reactions (C x 6: force, moment on the closing link, in the closure's frame) and
        joint reactions (L x 6: force, moment about the joint origin, of the parent on each link, in its axes)."""
        y = self._state(y, 2 * self.n_coords)
        tau = self._efforts(tau)
        closures, joints = np.zeros((max(len(self.closures), 1), 6)), np.zeros((len(self.links), 6))
        status = self._lib.grs_reactions(self._ref(), binding.address(y),
                                         None if tau is None else binding.address(tau), binding.address(self._work),
                                         binding.address(closures), binding.address(joints))
        if status != binding.OK:
            raise IntegrationError(f"spatial reactions: {binding.status_message(status)}")
        return closures[:len(self.closures)], joints

    def determinacy(self, z, rcond: float = 1e-8) -> tuple[np.ndarray, int]:
        """Per closure row, how much of its multiplier the motion leaves free (0 determinate, 1 wholly
        free), and the rank of the closure Jacobian at z."""
        z = self._state(z, self.n_coords, "z")
        out, rank = np.zeros(max(self.n_rows, 1)), ctypes.c_int(0)
        status = self._lib.grs_determinacy(self._ref(), binding.address(z), float(rcond),
                                           binding.address(self._work), binding.address(out), ctypes.byref(rank))
        if status != binding.OK:
            raise InputError("rcond", f"expected a number in (0, 1), got {rcond!r}")
        return out[:self.n_rows], rank.value

    def joint_determinacy(self, z, rcond: float = 1e-8) -> np.ndarray:
        """Per link (L x 6, as :meth:`reactions`' joints table), how much of each joint reaction component the
        closures' internal loads can change (N or N m per unit multiplier; 0: determinate)."""
        z = self._state(z, self.n_coords, "z")
        out, rank = np.zeros((len(self.links), 6)), ctypes.c_int(0)
        status = self._lib.grs_joint_determinacy(self._ref(), binding.address(z), float(rcond),
                                                 binding.address(self._work), binding.address(out),
                                                 ctypes.byref(rank))
        if status != binding.OK:
            raise InputError("rcond", f"expected a number in (0, 1), got {rcond!r}")
        return out

    def determinacy_report(self, z, rcond: float = 1e-8) -> list[str]:
        """In words: which reaction components of each closure, and of each joint, are determinate at z."""
        free, rank = self.determinacy(z, rcond)
        lines, r = [], 0
        for c, cl in enumerate(self.closures):
            kind = cl.kind
            names = {"spherical": ("Fx", "Fy", "Fz"), "revolute": ("Fx", "Fy", "Fz", "My", "Mx"),
                     "cylindrical": ("Fx", "Fy", "My", "Mx")}[kind]
            # row u.n1 carries the moment about n2 (My), row u.n2 the moment about n1 (Mx)
            det = [n for i, n in enumerate(names) if free[r + i] < 1e-6]
            ind = [n for i, n in enumerate(names) if free[r + i] >= 1e-6]
            lines.append(f"closure {c} ({kind}): determinate {', '.join(det) or 'none'}; "
                         f"indeterminate {', '.join(ind) or 'none'}")
            r += len(names)
        lines.append(f"closure Jacobian rank {rank} of {self.n_rows} rows")
        joints = self.joint_determinacy(z, rcond)
        for k, link in enumerate(self.links):
            ind = [n for n, v in zip(REACTION_NAMES, joints[k]) if v >= 1e-6]
            if ind:
                lines.append(f"joint of {link.name}: indeterminate {', '.join(ind)} (link axes)")
        if not joints.any() or np.all(joints < 1e-6):
            lines.append("every joint reaction is determinate")
        return lines

    def project(self, y) -> np.ndarray:
        """y projected onto the closures (minimum norm, positions then rates)."""
        y = self._state(y, 2 * self.n_coords).copy()
        self._lib.grs_project(self._ref(), self.scale, binding.address(y), binding.address(self._work))
        return y

    def assemble(self, z, zd=None, held=(0,)) -> np.ndarray:
        """A closed state near the sketch z: the coordinates ``held`` kept, the others solved.

        Raises
        ------
        InputError
            The loop cannot close there (``z``), naming the closest violation reached.
        """
        z = self._state(z, self.n_coords, "z").copy()
        zd = np.zeros(self.n_coords) if zd is None else self._state(zd, self.n_coords, "zd").copy()
        held = np.ascontiguousarray(held, dtype=np.int32)
        closest = ctypes.c_double(0.0)
        status = self._lib.grs_assemble(self._ref(), len(held), binding.address(held), self.scale,
                                        binding.address(z), binding.address(zd), ctypes.byref(closest),
                                        binding.address(self._work))
        if status == binding.NOT_CLOSED and closest.value == 2.0:
            raise InputError("z", "the loop cannot be closed near this sketch: the rows close only with a "
                             "revolute or cylindrical closure's axes reversed (sketch nearer the intended branch)")
        if status == binding.NOT_CLOSED:
            raise InputError("z", f"the loop cannot be closed near this sketch (closest violation "
                             f"{closest.value:.3g} m)")
        if status != binding.OK:
            raise InputError("held", f"coordinate indices in 0..{self.n_coords - 1}")
        return np.concatenate([z, zd])

    def simulate(self, y0, t_end: float, dt_out: float, tau=None, rtol: float = 1e-10, atol: float = 1e-10,
                 tableau: str = "dop853", max_steps: int = 1_000_000) -> SpatialResult:
        """Integrate from y0 (closed: see :meth:`assemble`) over [0, t_end], a row every dt_out.

        ``tau``: constant generalised efforts (N, one per coordinate), or None.
        """
        if not (math.isfinite(t_end) and t_end > 0):
            raise InputError("t_end", f"expected a finite time > 0, got {t_end!r}")
        if not (math.isfinite(dt_out) and 0 < dt_out <= t_end):
            raise InputError("dt_out", f"expected a finite interval in (0, t_end], got {dt_out!r}")
        if tableau not in ("dop853", "rk45"):
            raise InputError("tableau", f"{tableau!r}: the spatial advance has dop853 and rk45")
        y = self._state(y0, 2 * self.n_coords, "y0").copy()
        tau = self._efforts(tau)
        if self.n_rows:
            violation = np.abs(self.constraint(y[:self.n_coords])[0]).max()
            if not violation <= 1e-9 * self.scale:
                raise InputError("y0", f"the start does not close the loops (violation {violation:.3g} m): "
                                 "assemble it first (SpatialMechanism.assemble)")
        n_out = int(round(t_end / dt_out))
        times = np.ascontiguousarray(np.linspace(0.0, n_out * dt_out, n_out + 1)[1:])
        code = binding.TABLEAU_CODE[tableau]
        stepper = np.zeros(self._lib.grs_stepper_size(code, self.n_coords))
        settings = binding.SpatialSettings(code, rtol, atol, max(t_end, dt_out), max_steps, self.scale,
                                           None if tau is None else binding.address(tau))
        out = np.zeros((n_out, 2 * self.n_coords))
        t, h, steps, where = ctypes.c_double(0.0), ctypes.c_double(0.0), ctypes.c_long(0), ctypes.c_double(0.0)
        status = self._lib.grs_advance(self._ref(), ctypes.byref(settings), ctypes.byref(t), ctypes.byref(h),
                                       ctypes.byref(steps), binding.address(y), binding.address(times), n_out,
                                       binding.address(out), binding.address(self._work), binding.address(stepper),
                                       ctypes.byref(where))
        if status != binding.OK:
            raise IntegrationError(f"spatial run stopped at t = {where.value:.6g} s: {binding.status_message(status)}")
        passages = int(self._lib.grs_passages(binding.address(stepper), code, self.n_coords))
        return SpatialResult(self, np.concatenate([[0.0], times]), np.vstack([y0, out]), tau, int(steps.value),
                             passages)

    def start(self, **coordinates) -> np.ndarray:
        """A sketch z with the named coordinates (``crank=0.3`` for ``crank.theta``) set, the rest 0."""
        z = np.zeros(self.n_coords)
        for name, value in coordinates.items():
            key = name if "." in name else f"{name}.theta"
            if key not in self.coordinate_names:
                raise InputError(name, f"not a coordinate: one of {', '.join(self.coordinate_names)}")
            z[self.coordinate_names.index(key)] = value
        return z

    def assembled_start(self, z=None, rates=None, **coordinates) -> np.ndarray:
        """The preset's sketch (``self.sketch``) with the named coordinates set, closed holding the first."""
        z = np.array(getattr(self, "sketch", np.zeros(self.n_coords)) if z is None else z, dtype=float)
        for name, value in coordinates.items():
            key = name if "." in name else f"{name}.theta"
            if key not in self.coordinate_names:
                raise InputError(name, f"not a coordinate: one of {', '.join(self.coordinate_names)}")
            z[self.coordinate_names.index(key)] = value
        return self.assemble(z, rates, held=(0,))


# -- builders ------------------------------------------------------------------------------------------------------
def _rod_inertia(mass: float, length: float, axis: int, radius: float = 0.005) -> np.ndarray:
    """A slender rod's inertia about its centre, along axis (0 x, 1 y, 2 z)."""
    transverse = mass * (3 * radius ** 2 + length ** 2) / 12
    I = np.eye(3) * transverse
    I[axis, axis] = mass * radius ** 2 / 2
    return I


def spherical_joint(name: str, parent: int, at: int, a: float = 0.0, alpha: float = 0.0, d: float = 0.0, *,
                    mass=0.0, com=(0, 0, 0), inertia=np.zeros((3, 3)),
                    theta=(0.0, math.pi / 2, 0.0)) -> list[SpatialLink]:
    """A spherical joint as three revolutes on axes through one point, and the body it carries.

    The first axis is the row (a, alpha, d) from ``parent``, as any joint's; the
    second is across it (alpha -pi/2), the third across the second (alpha
    pi/2), all through the same point.  The two links between are massless
    (``name1``, ``name2``); the third (``name``) is the body.  ``at`` is the
    index the first of the three will have in the link list (their parents are
    parent, at, at + 1).  The body's z axis makes the angle theta[1] (plus the
    second coordinate) with the first axis, and the joint locks (the first and
    third axes line up) where that angle is 0 or pi, so a builder points the
    first axis away from where the body goes.

    Examples
    --------
    >>> [(l.name, l.parent, l.mass) for l in spherical_joint("ball", 0, 1, a=0.1, mass=2.0)]
    [('ball1', 0, 0.0), ('ball2', 1, 0.0), ('ball', 2, 2.0)]
    """
    return [SpatialLink(f"{name}1", a=a, alpha=alpha, d=d, theta=theta[0], parent=parent),
            SpatialLink(f"{name}2", alpha=-math.pi / 2, theta=theta[1], parent=at),
            SpatialLink(name, alpha=math.pi / 2, theta=theta[2], parent=at + 1, mass=mass, com=tuple(com),
                        inertia=tuple(map(tuple, np.asarray(inertia))))]


@dataclass(frozen=True)
class _RSSR:
    crank: float = 0.1     # r1, m
    offset: float = 0.35   # a: the shafts' common normal, m
    rocker_d: float = 0.05  # the rocker plane's offset along its shaft, m
    height: float = 0.12   # h: the crank plane's height along its shaft, m
    rocker: float = 0.2    # r3, m
    coupler: float = 0.4   # L, m
    twist: float = math.pi / 2  # the angle between the shafts


def rssr_geometry() -> _RSSR:
    """The RSSR preset's dimensions (the crank shaft is the world z axis; the rocker
    shaft crosses the x axis at ``offset``, twisted by ``twist`` about x).

    Examples
    --------
    >>> g = rssr_geometry()
    >>> g.crank, g.coupler, g.rocker, g.offset
    (0.1, 0.4, 0.2, 0.35)
    """
    return _RSSR()


def rssr(gravity=(0.0, 0.0, -GRAVITY), geometry: _RSSR | None = None) -> SpatialMechanism:
    """A crank-rocker between skew shafts: revolute crank, spherical, coupler, spherical, revolute rocker.

    Tree: the crank on the world z axis (its plane at ``height``), a spherical
    joint at the crank pin carrying the coupler (whose own z axis runs along
    it, to the far ball at (0, 0, L)); the rocker a second branch from the
    ground, its shaft through (offset, 0, 0) along Rx(twist) e_z.  The loop
    closes with a spherical pin between the coupler's far end and the
    rocker's.  Coordinates: crank, the ball's three angles, rocker: two
    degrees of freedom, the crank's and the coupler's spin about its own axis.
    ``geometry``: other dimensions (``dataclasses.replace(rssr_geometry(), ...)``).

    Examples
    --------
    >>> m = rssr()
    >>> m.coordinate_names
    ('crank.theta', 'coupler1.theta', 'coupler2.theta', 'coupler.theta', 'rocker.theta')
    >>> m.determinacy(m.assembled_start()[:m.n_coords])[1]    # rank 3 of 3 rows: not overconstrained
    3
    """
    g = rssr_geometry() if geometry is None else geometry
    links = [SpatialLink("crank", d=g.height, mass=0.5, com=(g.crank / 2, 0, 0),
                         inertia=tuple(map(tuple, _rod_inertia(0.5, g.crank, 0))))]
    links += spherical_joint("coupler", 0, 1, a=g.crank, mass=1.0, com=(0, 0, g.coupler / 2),
                             inertia=_rod_inertia(1.0, g.coupler, 2, radius=0.01))
    links.append(SpatialLink("rocker", a=g.offset, alpha=g.twist, d=g.rocker_d, parent=-1, mass=0.8,
                             com=(g.rocker / 2, 0, 0), inertia=tuple(map(tuple, _rod_inertia(0.8, g.rocker, 0)))))
    closure = SpatialClosure("spherical", link=3, to=4, point=(0, 0, g.coupler), to_point=(g.rocker, 0, 0))
    m = SpatialMechanism(links, [closure], gravity)
    m.sketch = _rssr_sketch(g, 0.0)
    return m


def _rssr_sketch(g: _RSSR, phi: float) -> np.ndarray:
    """A closed configuration at crank angle phi, from the loop's geometry (the assembly polishes it)."""
    p = np.array([g.crank * math.cos(phi), g.crank * math.sin(phi), g.height])
    axis = np.array([0.0, -math.sin(g.twist), math.cos(g.twist)])
    centre = np.array([g.offset, 0.0, 0.0]) + g.rocker_d * axis
    x0 = np.array([1.0, 0.0, 0.0])
    y0 = np.cross(axis, x0)
    # the rocker angle psi with |centre + r3 (cos psi x0 + sin psi y0) - p| = L: A cos + B sin = C
    q = centre - p
    A, B = 2 * g.rocker * q @ x0, 2 * g.rocker * q @ y0
    C = g.coupler ** 2 - q @ q - g.rocker ** 2
    psi = math.atan2(B, A) + math.acos(max(-1.0, min(1.0, C / math.hypot(A, B))))
    pin = centre + g.rocker * (math.cos(psi) * x0 + math.sin(psi) * y0)
    return np.array([phi, *_ball_angles(phi, pin - p, g.coupler), psi])


def _ball_angles(phi: float, span, length: float) -> tuple[float, float, float]:
    """The three angles of the ball at a crank pin (crank angle phi about z) that point the coupler along span."""
    c = np.asarray(span) / length  # the coupler's direction, in the crank's axes:
    cc = np.array([c[0] * math.cos(phi) + c[1] * math.sin(phi), -c[0] * math.sin(phi) + c[1] * math.cos(phi), c[2]])
    # the ball's first axis is the crank's z; the coupler's z is at polar angle t2 and azimuth t1 from it
    t1, t2 = math.atan2(cc[1], cc[0]), math.acos(max(-1.0, min(1.0, cc[2])))
    return t1, t2 - math.pi / 2, 0.0


@dataclass(frozen=True)
class _RSSP:
    crank: float = 0.1    # r1, m
    height: float = 0.12  # the crank plane's height along its shaft, m
    offset: float = 0.3   # the slide's line crosses the x axis here, m
    twist: float = math.pi / 2  # the slide's direction Rx(twist) e_z: along -y
    coupler: float = 0.5  # L, m


def rssp_geometry() -> _RSSP:
    """The RSSP preset's dimensions (crank on the world z axis; the slide's line through (offset, 0, 0)
    along Rx(twist) e_z).

    Examples
    --------
    >>> g = rssp_geometry()
    >>> g.crank, g.coupler, g.offset
    (0.1, 0.5, 0.3)
    """
    return _RSSP()


def rssp(gravity=(0.0, 0.0, -GRAVITY), geometry: _RSSP | None = None) -> SpatialMechanism:
    """A spatial slider-crank: revolute crank, spherical, coupler, spherical, a slider on a line skew to the
    crank shaft.

    The crank and the ball at its pin are the RSSR's; the slider is a second branch from the ground, a
    prismatic joint whose axis is the slide's line, its ball at the slider frame's origin.
    Coordinates: crank, the ball's three angles, the slide.
    ``geometry``: other dimensions (``dataclasses.replace(rssp_geometry(), ...)``).

    Examples
    --------
    >>> m = rssp()
    >>> m.coordinate_names[-1], m.n_rows
    ('slider.d', 3)
    """
    g = rssp_geometry() if geometry is None else geometry
    links = [SpatialLink("crank", d=g.height, mass=0.5, com=(g.crank / 2, 0, 0),
                         inertia=tuple(map(tuple, _rod_inertia(0.5, g.crank, 0))))]
    links += spherical_joint("coupler", 0, 1, a=g.crank, mass=1.0, com=(0, 0, g.coupler / 2),
                             inertia=_rod_inertia(1.0, g.coupler, 2, radius=0.01))
    block = 1.0 * (0.04 ** 2 + 0.04 ** 2) / 12
    links.append(SpatialLink("slider", a=g.offset, alpha=g.twist, joint="P", parent=-1, mass=1.0,
                             inertia=((block, 0, 0), (0, block, 0), (0, 0, block))))
    m = SpatialMechanism(links, [SpatialClosure("spherical", link=3, to=4, point=(0, 0, g.coupler))], gravity)
    phi = 0.0
    p = np.array([g.crank, 0.0, g.height])
    axis, start = np.array([0.0, -math.sin(g.twist), math.cos(g.twist)]), np.array([g.offset, 0.0, 0.0])
    along = axis @ (p - start)
    s = along + math.sqrt(along ** 2 - (p - start) @ (p - start) + g.coupler ** 2)
    m.sketch = np.array([phi, *_ball_angles(phi, start + s * axis - p, g.coupler), s])
    return m


@dataclass(frozen=True)
class _Spherical4:
    ground: float = math.radians(70)   # alpha1: between the input and output shafts
    crank: float = math.radians(25)    # alpha2: input link
    coupler: float = math.radians(60)  # alpha3
    rocker: float = math.radians(55)   # alpha4: output link
    radius: float = 0.1                # of the arcs the links are drawn on, m


def spherical_fourbar_geometry() -> _Spherical4:
    """The spherical four-bar preset's angular link lengths (every joint axis through the origin).

    Examples
    --------
    >>> g = spherical_fourbar_geometry()
    >>> [round(math.degrees(a), 9) for a in (g.ground, g.crank, g.coupler, g.rocker)]
    [70.0, 25.0, 60.0, 55.0]
    """
    return _Spherical4()


def spherical_fourbar(gravity=(0.0, 0.0, -GRAVITY), geometry: _Spherical4 | None = None) -> SpatialMechanism:
    """A spherical crank-rocker: four revolutes whose axes meet at the origin.

    The input turns about the world z axis; its far axis is at ``crank`` from
    it (the coupler's joint, DH alpha = crank); the output is a second branch,
    its shaft at ``ground`` from the input's (DH alpha = ground); the coupler
    closes on the output with a revolute whose axes are at ``coupler`` from
    the coupler's own z and at ``rocker`` from the output's.  The closure's
    three force rows vanish identically (every joint is at the origin), so the
    loop is overconstrained as a spatial one: the motion is exact and those
    reactions are indeterminate.  ``geometry``: other angular lengths
    (``dataclasses.replace(spherical_fourbar_geometry(), rocker=...)``; the
    preset's by default).

    Examples
    --------
    >>> m = spherical_fourbar()
    >>> m.n_rows, m.determinacy(m.assembled_start()[:m.n_coords])[1]    # 5 rows of rank 2
    (5, 2)
    """
    g = geometry or spherical_fourbar_geometry()
    R = g.radius

    def arc_body(mass, angle):  # a link drawn as the arc from its z axis to Rx(angle) e_z, radius R
        mid = 0.5 * angle
        com = (0.0, -R * math.sin(mid), R * math.cos(mid))
        return dict(mass=mass, com=com, inertia=tuple(map(tuple, np.diag([1e-4, 2e-4, 2e-4]) * mass)))

    links = [SpatialLink("crank", **arc_body(0.3, g.crank)),
             SpatialLink("coupler", alpha=g.crank, parent=0, **arc_body(0.5, g.coupler)),
             SpatialLink("rocker", alpha=g.ground, parent=-1, **arc_body(0.4, g.rocker))]
    closure = SpatialClosure("revolute", link=1, to=2, axis=(0, -math.sin(g.coupler), math.cos(g.coupler)),
                             to_axis=(0, -math.sin(g.rocker), math.cos(g.rocker)))
    m = SpatialMechanism(links, [closure], gravity)
    m.sketch = np.array([0.0, 1.0, 1.0])
    return m


# the thesis four-bar (MODEL.md section 4): m, I, p along the link, a; ground pin at (1, 0)
_THESIS_FOURBAR = dict(m=(1.0, 2.0, 3.0), I=(0.1, 0.2, 0.3), p=(0.1, 0.4, 0.4), a=(0.2, 0.8, 0.8), ground=1.0)


def planar_fourbar(closure: str = "revolute", gravity=(0.0, -GRAVITY, 0.0)) -> SpatialMechanism:
    """The thesis four-bar written as a spatial chain in the x-y plane (gravity along -y).

    Three revolutes on parallel z axes (DH alpha = 0, a = the previous link's
    length), the coordinates the planar kernel's relative angles; the tip of
    link 4 closes on the ground pin at (1, 0, 0) with a revolute closure (5
    rows, of which the motion fixes two: the other three reactions are
    indeterminate) or a spherical one (3 rows).  Each link's inertia about its
    z axis is the planar I; the moments across it do not enter a planar motion.

    Examples
    --------
    >>> m = planar_fourbar()
    >>> m.coordinate_names, m.n_rows
    (('link2.theta', 'link3.theta', 'link4.theta'), 5)
    >>> [round(math.degrees(v), 6) for v in m.assembled_start()[:3]]    # the thesis's start
    [0.0, 60.0, -120.0]
    """
    f = _THESIS_FOURBAR
    links, previous = [], 0.0
    for k in range(3):
        I = f["I"][k]
        links.append(SpatialLink(f"link{k + 2}", a=previous, parent=k - 1, mass=f["m"][k], com=(f["p"][k], 0, 0),
                                 inertia=((I, 0, 0), (0, I, 0), (0, 0, I))))
        previous = f["a"][k]
    cl = SpatialClosure(closure, link=2, to=-1, point=(f["a"][2], 0, 0), to_point=(f["ground"], 0, 0))
    m = SpatialMechanism(links, [cl], gravity)
    m.sketch = np.array([0.0, math.pi / 3, -2 * math.pi / 3])  # the thesis's start: theta3 = pi/3, theta4 = -pi/3
    return m


# -- the universal (Hooke) joint, the Bennett and the Bricard linkages ------------------------------------------------
@dataclass(frozen=True)
class _Hooke:
    shaft_angle: float = math.radians(30)  # beta: between the input and the output shaft
    shaft: float = 0.3                     # each shaft's length from the cross, m
    shaft_mass: float = 1.0                # kg (shaft and yoke)
    cross: float = 0.05                    # the cross's arm, centre to pin, m
    cross_mass: float = 0.2                # kg


def hooke_joint_geometry() -> _Hooke:
    """The Hooke joint preset's dimensions (the input shaft is the world z axis, the output shaft
    Rx(shaft_angle) e_z, both through the cross's centre at the origin).

    Examples
    --------
    >>> g = hooke_joint_geometry()
    >>> round(math.degrees(g.shaft_angle), 9), g.shaft, g.cross
    (30.0, 0.3, 0.05)
    """
    return _Hooke()


def hooke_joint(gravity=(0.0, 0.0, -GRAVITY), shaft_angle: float | None = None) -> SpatialMechanism:
    """A universal (Hooke) joint as a spherical four-bar: input shaft, cross, output shaft.

    Every joint axis passes through the cross's centre: the input shaft turns about the
    world z axis, its yoke carries the cross on a pin square to the shaft (DH alpha
    pi/2), the cross's second pin is square to its first (pi/2) and to the output
    shaft (pi/2), which turns about Rx(shaft_angle) e_z.  The spherical four-bar's
    link angles are thus shaft_angle (the ground), pi/2, pi/2, pi/2.  The cross closes
    on the output yoke with a revolute closure (5 rows, rank 2, as any spherical
    four-bar's: the closure's forces are indeterminate, its moments square to the pin
    are not).  Coordinates: input, cross (about the input yoke's pin), output.

    Examples
    --------
    At the start the input yoke's pin lies in the shafts' plane: the output turns
    1 / cos(shaft_angle) times as fast as the input, the speed ratio's largest.

    >>> m = hooke_joint()
    >>> y0 = m.assemble(m.sketch, [1.0, 0.0, 0.0])    # the input at 1 rad/s
    >>> round(float(y0[5] / y0[3]), 9), round(1 / math.cos(math.radians(30)), 9)
    (1.154700538, 1.154700538)
    >>> hooke_joint(shaft_angle=math.radians(85))
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: shaft_angle: expected an angle in [0, 80) degrees, got 1.4835298641951802 rad
    """
    g = hooke_joint_geometry()
    beta = g.shaft_angle if shaft_angle is None else float(shaft_angle)
    if not (math.isfinite(beta) and 0.0 <= beta < math.radians(80)):
        raise InputError("shaft_angle", f"expected an angle in [0, 80) degrees, got {beta!r} rad")
    shaft = tuple(map(tuple, _rod_inertia(g.shaft_mass, g.shaft, 2, radius=0.01)))
    arm = g.cross_mass / 2 * (2 * g.cross) ** 2 / 12  # each of the cross's two bars about a transverse axis
    spin = g.cross_mass / 2 * 0.005 ** 2 / 2
    # the cross's bars lie along its z (the input yoke's pin) and its y (the output yoke's pin)
    cross = ((2 * arm, 0, 0), (0, arm + spin, 0), (0, 0, arm + spin))
    links = [SpatialLink("input", mass=g.shaft_mass, com=(0, 0, -g.shaft / 2), inertia=shaft),
             SpatialLink("cross", alpha=math.pi / 2, parent=0, mass=g.cross_mass, inertia=cross),
             SpatialLink("output", alpha=beta, parent=-1, mass=g.shaft_mass, com=(0, 0, g.shaft / 2), inertia=shaft)]
    closure = SpatialClosure("revolute", link=1, to=2, axis=(0, -1, 0), to_axis=(0, -1, 0))
    m = SpatialMechanism(links, [closure], gravity)
    # input 0: its yoke's pin along -y, in the shafts' plane; the output yoke's pin is then along x
    m.sketch = np.array([0.0, math.pi / 2, math.pi / 2])
    return m


@dataclass(frozen=True)
class _Bennett:
    a1: float = 0.15                 # m: links 1 and 3 (a1 = a3)
    alpha1: float = math.radians(45)  # their twist (alpha1 = alpha3)
    alpha2: float = math.radians(75)  # links 2 and 4's twist (alpha2 = alpha4)
    mass: float = 0.5                # kg per metre of link

    @property
    def a2(self) -> float:
        """Links 2 and 4's length from Bennett's condition a1 / sin(alpha1) = a2 / sin(alpha2), m."""
        return self.a1 * math.sin(self.alpha2) / math.sin(self.alpha1)


def bennett_geometry() -> _Bennett:
    """The Bennett preset's dimensions: opposite links equal, a1 / sin(alpha1) = a2 / sin(alpha2).

    Examples
    --------
    >>> g = bennett_geometry()
    >>> g.a1, round(g.a2, 9), round(math.degrees(g.alpha1), 9), round(math.degrees(g.alpha2), 9)
    (0.15, 0.204903811, 45.0, 75.0)
    """
    return _Bennett()


def bennett(gravity=(0.0, 0.0, -GRAVITY)) -> SpatialMechanism:
    """The Bennett linkage: four revolutes on skew axes, overconstrained and mobile.

    Denavit-Hartenberg loop: link i runs from axis i to axis i + 1 along their common
    normal, of length a_i and twist alpha_i; a1 = a3, a2 = a4, alpha1 = alpha3,
    alpha2 = alpha4 and a1 / sin(alpha1) = a2 / sin(alpha2) (Bennett 1903).  The world
    is the frame of axis 4 (the ground link's far joint): its z is axis 4, its x the
    common normal to axis 1.  Links 1, 2, 3 are a serial chain (rows alpha4 a4,
    alpha1 a1, alpha2 a2); link 3's end closes on the ground at axis 4 with a revolute
    closure (5 rows, rank 2: a general 4R loop would be rigid).  Coordinates: the joint
    angles theta1..theta3 (DH, between consecutive common normals).  Each link is a
    rod along its common normal.

    Examples
    --------
    The assembled start keeps Bennett's input-output equation
    tan(theta1 / 2) tan(theta2 / 2) = sin((alpha2 + alpha1) / 2) / sin((alpha2 - alpha1) / 2):

    >>> m, g = bennett(), bennett_geometry()
    >>> t1, t2 = m.assembled_start()[:2]
    >>> round(math.tan(t1 / 2) * math.tan(t2 / 2), 9)
    3.346065215
    >>> round(math.sin((g.alpha2 + g.alpha1) / 2) / math.sin((g.alpha2 - g.alpha1) / 2), 9)
    3.346065215
    """
    g = bennett_geometry()
    lengths, twists = (g.a1, g.a2, g.a1, g.a2), (g.alpha1, g.alpha2, g.alpha1, g.alpha2)
    links = []
    for k, name in enumerate(("link1", "link2", "link3")):
        mass = g.mass * lengths[k]
        links.append(SpatialLink(name, a=lengths[k - 1], alpha=twists[k - 1], parent=k - 1, mass=mass,
                                 com=(lengths[k] / 2, 0, 0),
                                 inertia=tuple(map(tuple, _rod_inertia(mass, lengths[k], 0, radius=0.008)))))
    closure = SpatialClosure("revolute", link=2, to=-1, point=(lengths[2], 0, 0),
                             axis=(0, -math.sin(twists[2]), math.cos(twists[2])))
    m = SpatialMechanism(links, [closure], gravity)
    m.sketch = np.array([math.pi / 2, 2.0, -math.pi / 2])  # near the closed pose at theta1 = pi/2
    return m


@dataclass(frozen=True)
class _Bricard:
    rod: float = 1.0      # m: every rod, the ground's too
    mass: float = 1.0     # kg per rod
    section: float = 0.1  # the rods' square cross-section's side, m


def bricard_geometry() -> _Bricard:
    """IFToMM benchmark A04's dimensions: rods of 1 m and 1 kg, square section 0.1 m.

    Examples
    --------
    >>> g = bricard_geometry()
    >>> g.rod, g.mass, g.section
    (1.0, 1.0, 0.1)
    """
    return _Bricard()


# A04's joints: the points and axes of joints 1..6 at the start (the ground link runs from joint 6 to 1)
BRICARD_JOINTS = (((0, 0, 0), (0, 1, 0)), ((1, 0, 0), (0, 0, 1)), ((1, -1, 0), (1, 0, 0)),
                  ((1, -1, 1), (0, 1, 0)), ((0, -1, 1), (0, 0, 1)), ((0, 0, 1), (1, 0, 0)))


def bricard(gravity=(0.0, -GRAVITY, 0.0)) -> SpatialMechanism:
    """The Bricard linkage as IFToMM benchmark A04 specifies it (González et al. 2006).

    Six revolutes in a loop, each link a rod of 1 m and 1 kg (square section 0.1 m),
    gravity along -y; Grübler's count gives no mobility, the axes' layout gives one.
    At the start the joints are at (0,0,0) axis y, (1,0,0) axis z, (1,-1,0) axis x
    (the benchmark's point P3), (1,-1,1) axis y, (0,-1,1) axis z, (0,0,1) axis x
    (:data:`BRICARD_JOINTS`); the ground is the rod from joint 6 to joint 1.  Each
    rod is the common normal of its two axes, so the chain is five DH rows (a 1 m,
    alpha +-pi/2) and rod 5 closes on the ground at joint 6 with a revolute closure
    (5 rows, rank 4).  The benchmark starts at rest there: ``m.sketch`` is that pose
    (all coordinates 0).

    Examples
    --------
    >>> m = bricard()
    >>> m.n_coords, m.n_rows, m.determinacy(m.sketch)[1]    # one freedom where Grubler counts none
    (5, 5, 4)
    """
    g = bricard_geometry()
    L, s = g.rod, g.section
    rod = ((g.mass * 2 * s * s / 12, 0, 0), (0, g.mass * (L * L + s * s) / 12, 0), (0, 0, g.mass * (L * L + s * s) / 12))
    half = math.pi / 2
    # (alpha, a, theta) of each rod's row; worked out from the joints above, the rod k along its frame's x
    rows = ((-half, 0.0, 0.0), (half, L, -half), (-half, L, -half), (half, L, -half), (-half, L, -half))
    links = [SpatialLink(f"rod{k + 1}", a=a, alpha=alpha, theta=theta, parent=k - 1, mass=g.mass, com=(L / 2, 0, 0),
                         inertia=rod) for k, (alpha, a, theta) in enumerate(rows)]
    point, axis = BRICARD_JOINTS[5]
    # joint 6 on rod 5: its end, the axis turned by alpha5 = pi/2 about the rod
    closure = SpatialClosure("revolute", link=4, to=-1, point=(L, 0, 0), axis=(0, -1, 0), to_point=point,
                             to_axis=axis)
    m = SpatialMechanism(links, [closure], gravity)
    m.sketch = np.zeros(5)
    return m


def bricard_p3(m: SpatialMechanism, y) -> np.ndarray:
    """The benchmark's point P3 (rod 2's far end, joint 3) over states y (rows x 3), m.

    Examples
    --------
    >>> m = bricard()
    >>> bricard_p3(m, m.assembled_start()).round(12).tolist()
    [[1.0, -1.0, 0.0]]
    """
    return m.points(y, [1], [(m.links[2].a, 0.0, 0.0)])[:, 0, :]


# name -> builder: every preset takes gravity as its first (optional) argument.  The names are the scene files'
# in presets/spatial/ (each file reproduces its builder: tests/test_spatial_scene.py holds both lists equal), and
# they share the command line with the planar presets: the planar four-bar written as spatial is
# 'planar-fourbar-3d', apart from any planar name.
PRESETS = {"rssr": rssr, "rssp": rssp, "spherical-fourbar": spherical_fourbar, "planar-fourbar-3d": planar_fourbar,
           "hooke-joint": hooke_joint, "bennett": bennett, "bricard": bricard}
__all__ += ["hooke_joint", "hooke_joint_geometry", "bennett", "bennett_geometry", "bricard", "bricard_geometry",
            "bricard_p3", "BRICARD_JOINTS", "PRESETS"]
