"""The mechanism model: geometry, inertia, joints and closures, immutable.

A generalised planar open chain (MODEL.md section 2): ground (link 1) and moving
links 2 .. N+1, in series unless a link names another predecessor (an earlier
link or the ground: the chain is then a tree).  Between a link and its predecessor sit two joints in
series, a slide ``B`` along an axis fixed in the predecessor (perpendicular to its
vector) and a revolute ``theta``; the existence factors say which one is real.  The
fictitious one is locked: a locked slide keeps its value, a locked revolute keeps
its angle relative to the predecessor.  Closures tie a point of one link to a point
(revolute) or a line (prismatic) of another, usually the chain's tip to the ground.

The model never changes during a run; everything that does lives in the state
(a :class:`~grubler.mechanism.simulate.Simulator` holds it).  The integrated coordinates ``z`` are the joint variables of
the real joints only: a slide's ``B`` or a revolute's angle relative to its
predecessor.  The thesis's absolute coordinates ``q`` (B1, theta2, B2, theta3, ...)
are the affine image ``q = q_locked + S z``.
"""

from __future__ import annotations

import ctypes
import re
from dataclasses import dataclass, field, replace

import numpy as np

from grubler import binding
from grubler.errors import InputError, Problems, SceneError, raise_all
from grubler.limits import number

G_STANDARD = 9.81

REVOLUTE = "R"
PRISMATIC = "P"
MAX_LINKS = 1024  # moving links a chain may have: the kernel's GRB_MAX_LINKS (grubler.h)



def kutzbach_mobility(n_bodies: int, n_lower_pairs: int, n_higher_pairs: int = 0) -> int:
    """Planar Grübler/Kutzbach mobility, M = 3 (n - 1) - 2 j1 - j2.

    Parameters
    ----------
    n_bodies : int
        Links, the ground included.
    n_lower_pairs : int
        One-freedom joints (revolute, prismatic).
    n_higher_pairs : int
        Two-freedom joints (cam, rolling with slip).

    Examples
    --------
    >>> from grubler import kutzbach_mobility
    >>> kutzbach_mobility(4, 4)       # four-bar: 4 links (ground included), 4 revolutes
    1
    >>> kutzbach_mobility(6, 7)       # Watt or Stephenson six-bar
    1
    >>> kutzbach_mobility(5, 5)       # five-bar: two inputs
    2
    """
    return 3 * (n_bodies - 1) - 2 * n_lower_pairs - n_higher_pairs


@dataclass(frozen=True)
class Link:
    """One moving link and the joint pair that attaches it to its predecessor.

    Parameters
    ----------
    joint : {'R', 'P'}
        Which joint of the pair is real: ``'R'`` (existence factors 0, 1) or
        ``'P'`` (1, 0).
    a : float
        Length of the link vector A_k, m (>= 0; 0 for a block).
    p, q : float
        Mass centre along and perpendicular to A_k, m.
    m : float
        Mass, kg (> 0).  The default, 1 kg, serves code that builds links by
        hand; a scene file must state every link's mass.
    I : float
        Centroidal moment of inertia, kg m^2 (>= 0).
    damping : float
        Viscous damping of the real joint, N m s/rad or N s/m (>= 0).
    parent : int or None
        The predecessor this link's joint pair hangs from, thesis numbering:
        1 the ground, or an earlier moving link.  None (the default) is the
        previous link, a serial chain.  The pair sits at the predecessor's
        point (a, B) as in the serial chain, so two links hanging from one
        predecessor differ in their slide B: a ternary link carries its two
        children on the line across its vector's end.

    Examples
    --------
    >>> from grubler import Link
    >>> crank = Link("R", a=0.2, p=0.1, m=1.0, I=0.1)   # a 0.2 m crank turning about its revolute
    >>> crank.joint, crank.a, crank.m, crank.existence
    ('R', 0.2, 1.0, (0, 1))
    """

    joint: str
    a: float
    p: float = 0.0
    q: float = 0.0
    m: float = 1.0
    I: float = 0.0
    damping: float = 0.0
    parent: int | None = None

    @property
    def existence(self) -> tuple[int, int]:
        """Existence factors (slide, revolute) of the joint pair."""
        return (1, 0) if self.joint == PRISMATIC else (0, 1)


@dataclass(frozen=True)
class Closure:
    """A joint that closes a loop between two links of the chain.

    Parameters
    ----------
    kind : {'revolute', 'prismatic'}
    link : int
        Link carrying the closing point (thesis numbering, 2 .. N+1).
    point : (float, float)
        That point in the link's frame (along A, perpendicular to A), m.
    to_link : int
        Link carrying the target point or line; 1 is the ground.
    to_point : (float, float)
        Target point, or a point of the line, in ``to_link``'s frame (the ground's
        frame is the world frame), m.
    angle : float
        Prismatic only: direction of the line in ``to_link``'s frame, rad.
    psi : float
        Prismatic only: held orientation of ``link`` relative to ``to_link``, rad.
    gain, damping : float
        Penalty closure only (the thesis's imaginary joint): stiffness G
        (N/m and N m/rad) and damping C (N s/m and N m s/rad).

    Examples
    --------
    >>> from grubler import Closure
    >>> pin = Closure("revolute", link=4, point=(0.8, 0.0), to_point=(1.0, 0.0))  # link 4's tip on the ground pivot (1, 0)
    >>> pin.to_link, pin.to_point
    (1, (1.0, 0.0))
    """

    kind: str
    link: int
    point: tuple[float, float]
    to_link: int = 1
    to_point: tuple[float, float] = (0.0, 0.0)
    angle: float = 0.0
    psi: float = 0.0
    gain: float = 1.0e4
    damping: float = 100.0

    @property
    def dim(self) -> int:
        return 2


@dataclass(frozen=True)
class Actuator:
    """A linear actuator (a hydraulic or pneumatic cylinder, a solenoid, a strut) between two links.

    Its force acts along the line through its two points, positive pushing them
    apart; the mechanism takes that force as an input and gives the actuator's
    length and rate.

    Parameters
    ----------
    name : str
        Names its input and outputs (``<name>_force``, ``<name>_length``,
        ``<name>_rate``): a letter, then letters, digits or underscores.
    from_link, to_link : int
        The links carrying its two points, thesis numbering (1 the ground).
    from_point, to_point : (float, float)
        The points in their link's frame (along, across its vector), m; a
        ground point is in the world frame.
    """

    name: str
    from_link: int
    from_point: tuple[float, float]
    to_link: int
    to_point: tuple[float, float]


@dataclass(frozen=True)
class Spring:
    """A spring, a damper and a gas spring in parallel between a point of one link and a point of another.

    Its force acts along the line through its two points, positive pushing
    them apart; at length L and rate L' (docs/scenes.md, ``[[spring]]``)::

        F = preload - stiffness (L - free_length) - damping L' + F_gas
        F_gas = gas_force (gas_column / h) ** gas_exponent,   h = gas_column + L - free_length

    the polytropic law p V^n = p0 V0^n of a gas spring of bore area A, with
    ``gas_force`` = p0 A its gas force at the free length and ``gas_column`` =
    V0 / A its gas column there (0: no gas).  Its stored energy (0 at the free
    length) enters the potential energy, its damper's power the dissipation.

    Parameters
    ----------
    name : str
        Names its outputs (``<name>_force``, ``<name>_length``, ...).
    from_link, to_link : int
        The links carrying its two points, thesis numbering (1 the ground).
    from_point, to_point : (float, float)
        The points in their link's frame (along, across its vector), m; a
        ground point is in the world frame.
    stiffness : float
        N/m (>= 0).
    free_length : float
        Its length at rest, m (>= 0).
    preload : float
        The force it pushes apart with at its free length, N (negative: pulls).
    damping : float
        A viscous damper in parallel, N s/m (>= 0).
    gas_force, gas_column, gas_exponent : float
        p0 A (N, >= 0), V0 / A (m, > 0 with a gas force) and the polytropic
        exponent n (> 0: 1 isothermal, 1.4 adiabatic air).

    Examples
    --------
    >>> from grubler import Spring
    >>> Spring("return", from_link=1, from_point=(0.0, 0.0), to_link=2, to_point=(0.1, 0.0), stiffness=200.0,
    ...        free_length=0.05).stiffness
    200.0
    """

    name: str
    from_link: int
    from_point: tuple[float, float]
    to_link: int
    to_point: tuple[float, float]
    stiffness: float = 0.0
    free_length: float = 0.0
    preload: float = 0.0
    damping: float = 0.0
    gas_force: float = 0.0
    gas_column: float = 0.0
    gas_exponent: float = 1.0

    table = "spring"  # its table in a scene file


@dataclass(frozen=True)
class JointSpring:
    """A torsion spring at a revolute (a linear spring at a slide) with Coulomb friction, at a real joint.

    Its effort on the joint's coordinate z (a revolute's angle relative to its
    predecessor, or a slide's B)::

        Q = preload - stiffness (z - free) - friction tanh(z' / friction_speed)

    in N m (N on a slide).  The Coulomb friction is regularised: it rises over
    rates of the order of ``friction_speed`` (docs/scenes.md says how far a
    loaded joint creeps for it).  The joint's viscous damper is its link's
    ``damping``.

    Parameters
    ----------
    name : str
    joint : str
        The real joint's coordinate, ``'theta3'`` or ``'B2'``.
    stiffness : float
        N m/rad, or N/m on a slide (>= 0).
    free : float
        The coordinate where the spring is relaxed: rad (relative to the
        predecessor) or m.
    preload : float
        Its effort at ``free``, N m or N, along +z.
    friction : float
        Coulomb friction, N m or N (>= 0).
    friction_speed : float
        The regularisation's rate scale, rad/s or m/s (> 0 with friction).

    Examples
    --------
    >>> from grubler import JointSpring
    >>> JointSpring("hinge", joint="theta3", stiffness=20.0, free=0.5).joint
    'theta3'
    """

    name: str
    joint: str
    stiffness: float = 0.0
    free: float = 0.0
    preload: float = 0.0
    friction: float = 0.0
    friction_speed: float = 1e-3

    table = "joint_spring"


@dataclass(frozen=True)
class PointLoad:
    """A constant force (world axes) and moment on a link, at a point of it.

    Parameters
    ----------
    name : str
    link : int
        A moving link, thesis numbering.
    point : (float, float)
        Where the force acts, in the link's frame (along, across its vector), m.
    force : (float, float)
        N, world axes.
    moment : float
        N m, counter-clockwise.

    Examples
    --------
    >>> from grubler import PointLoad
    >>> PointLoad("payload", link=3, point=(0.8, 0.0), force=(0.0, -50.0)).force
    (0.0, -50.0)
    """

    name: str
    link: int
    point: tuple[float, float] = (0.0, 0.0)
    force: tuple[float, float] = (0.0, 0.0)
    moment: float = 0.0

    table = "point_load"


FORCE_ELEMENTS = (Spring, JointSpring, PointLoad)
# columns of the force-element table (ModelArrays.forces; the kernel's GRB_F_*), one row per element
(F_KIND, F_LINK, F_X, F_Y, F_TO_LINK, F_TO_X, F_TO_Y, F_STIFFNESS, F_FREE, F_PRELOAD, F_DAMPING, F_GAS_FORCE,
 F_GAS_COLUMN, F_GAS_EXPONENT, F_FRICTION, F_FRICTION_SPEED, F_FX, F_FY, F_MZ) = range(19)
FORCE_KIND = {Spring: 0, JointSpring: 1, PointLoad: 2}  # GRB_FORCE_SPRING, _JOINT, _LOAD
# the kernel column each field of an element (as the native FMU names its parameters) sits in
FORCE_COLUMN = {"from_link": F_LINK, "from_point_x": F_X, "from_point_y": F_Y, "to_link": F_TO_LINK,
                "to_point_x": F_TO_X, "to_point_y": F_TO_Y, "stiffness": F_STIFFNESS, "free_length": F_FREE,
                "free": F_FREE, "preload": F_PRELOAD, "damping": F_DAMPING, "gas_force": F_GAS_FORCE,
                "gas_column": F_GAS_COLUMN, "gas_exponent": F_GAS_EXPONENT, "friction": F_FRICTION,
                "friction_speed": F_FRICTION_SPEED, "link": F_LINK, "point_x": F_X, "point_y": F_Y,
                "force_x": F_FX, "force_y": F_FY, "moment": F_MZ}


def force_row(element, joint_link: int = 0) -> np.ndarray:
    """A force element's row of the kernel's table, links in thesis numbering (1 the ground).

    ``joint_link``: a joint spring's link (the one whose real joint its coordinate is).
    """
    row = np.zeros(19)
    row[F_KIND] = FORCE_KIND[type(element)]
    if isinstance(element, Spring):
        row[F_LINK], (row[F_X], row[F_Y]) = element.from_link, element.from_point
        row[F_TO_LINK], (row[F_TO_X], row[F_TO_Y]) = element.to_link, element.to_point
        row[[F_STIFFNESS, F_FREE, F_PRELOAD, F_DAMPING, F_GAS_FORCE, F_GAS_COLUMN, F_GAS_EXPONENT]] = (
            element.stiffness, element.free_length, element.preload, element.damping, element.gas_force,
            element.gas_column, element.gas_exponent)
    elif isinstance(element, JointSpring):
        row[F_LINK] = joint_link
        row[[F_STIFFNESS, F_FREE, F_PRELOAD, F_FRICTION, F_FRICTION_SPEED]] = (
            element.stiffness, element.free, element.preload, element.friction, element.friction_speed)
    else:
        row[F_LINK], (row[F_X], row[F_Y]) = element.link, element.point
        row[[F_FX, F_FY, F_MZ]] = (*element.force, element.moment)
    return row


# names an element may not take: its dotted parameters (NAME.damping) are the scene's own (link2.damping)
_RESERVED_NAME = re.compile(r"link\d+|ground|gravity|closure|initial|drive|load|simulate|mechanism|method|"
                            r"integrator|rtol|atol|max_step|step")
MAX_ACTUATORS = 16  # the kernel's GRB_MAX_ACTUATORS
ACTUATOR_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")
# columns of the actuator table (ModelArrays.actuators), one row per actuator
A_FROM_LINK, A_FROM_X, A_FROM_Y, A_TO_LINK, A_TO_X, A_TO_Y = range(6)

# columns of the link table (ModelArrays.links), one row per moving link
L_M, L_I, L_P, L_Q, L_A, L_APRED, L_DAMP, L_REV, L_SLIDE0, L_THETA0, L_PARENT = range(11)
# columns of the closure table (ModelArrays.closures), one row per closure
(CL_KIND, CL_LINK, CL_TO, CL_PX, CL_PY, CL_TX, CL_TY, CL_ANGLE, CL_PSI, CL_GAIN,
 CL_DAMP) = range(11)
REVOLUTE_CLOSURE, PRISMATIC_CLOSURE = 0.0, 1.0


@dataclass(frozen=True)
class ModelArrays:
    """The model's numbers as two tables, built once: what the compiled kernel reads.

    ``links`` has one row per moving link: m, I, p, q, a, the predecessor's vector
    length (a1 for link 2), damping, 1.0 if the revolute is the real joint, the
    locked slide and absolute angle (``q_locked``) the real joints add to, and the
    predecessor as a 0-based moving-link index (-1 the ground).
    ``closures`` has one row per closure: kind (0 revolute, 1 prismatic), the
    closing link and the target link as 0-based moving-link indices (-1 for the
    ground), point, to_point, angle, psi, penalty gain and damping.  The other
    fields are views of these columns.
    """

    links: np.ndarray  # (N, 11) float
    closures: np.ndarray  # (C, 11) float
    actuators: np.ndarray  # (A, 6) float
    forces: np.ndarray  # (F, 19) float: the force elements, links 0-based (-1 the ground)
    m: np.ndarray
    I: np.ndarray
    p: np.ndarray
    q: np.ndarray
    a: np.ndarray
    a_pred: np.ndarray  # length of each link's predecessor vector (a1 for link 2)
    damping: np.ndarray
    revolute: np.ndarray  # bool per pair: the revolute is the real joint
    gain: np.ndarray  # penalty stiffness per constraint row
    closure_damping: np.ndarray
    drive: int  # index in z, -1 for none
    load: int
    drive_inertia: float  # reflected rotor inertia on z[drive]
    theta1: float
    gravity: float
    struct: object  # the kernel's grb_model over these tables (grubler.binding.Model)
    c: int  # its address, what the kernel's functions take

    def _struct(self):
        return binding.model_struct(self.links, self.closures, self.theta1, self.gravity, self.drive, self.load,
                                    self.drive_inertia, self.actuators, self.forces)

    # the struct holds the tables' addresses: never carry it to another process
    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if k not in ("c", "struct")}

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)
        struct = self._struct()
        object.__setattr__(self, "struct", struct)
        object.__setattr__(self, "c", ctypes.addressof(struct))

    @staticmethod
    def of(model: "Mechanism") -> "ModelArrays":
        # the kernel builds the tables from the scene's quantities, as in the native FMU
        links = model.links
        revolute = np.array([l.joint == REVOLUTE for l in links], dtype=np.int32)
        fields = np.array([[l.a, l.p, l.q, l.m, l.I, l.damping] for l in links], dtype=float)
        cfields = np.array([(PRISMATIC_CLOSURE if c.kind == "prismatic" else REVOLUTE_CLOSURE, c.link, c.to_link,
                             *c.point, *c.to_point, c.angle, c.psi, c.gain, c.damping) for c in model.closures],
                           dtype=float).reshape(len(model.closures), 11)
        parent = np.array([pk - 2 for pk in model.parents], dtype=np.int32)
        L, C = binding.scene_tables(revolute, parent, fields, model.a1, model.theta1,
                                    np.array(model.q_ref, dtype=float), cfields)
        L.setflags(write=False)
        C.setflags(write=False)
        drive = -1 if model.drive is None else model.free_index(model.drive)
        load = -1 if model.load is None else model.free_index(model.load)
        A = np.array([(a.from_link - 2, *a.from_point, a.to_link - 2, *a.to_point) for a in model.actuators],
                     dtype=float).reshape(len(model.actuators), 6)
        A.setflags(write=False)
        F = model.force_table()
        F[:, [F_LINK, F_TO_LINK]] -= 2  # the kernel's links are 0-based, -1 the ground
        F.setflags(write=False)
        struct = binding.model_struct(L, C, model.theta1, model.gravity, drive, load, model.drive_inertia, A, F)
        return ModelArrays(
            links=L, closures=C, actuators=A, forces=F,
            m=L[:, L_M], I=L[:, L_I], p=L[:, L_P], q=L[:, L_Q], a=L[:, L_A], a_pred=L[:, L_APRED],
            damping=L[:, L_DAMP], revolute=L[:, L_REV] != 0.0,
            gain=np.repeat(C[:, CL_GAIN], 2), closure_damping=np.repeat(C[:, CL_DAMP], 2),
            drive=drive, load=load, drive_inertia=float(model.drive_inertia),
            theta1=float(model.theta1), gravity=float(model.gravity), struct=struct, c=ctypes.addressof(struct),
        )


def coordinate_names(n_links: int) -> list[str]:
    """Names of the absolute coordinates in thesis order: B1, theta2, B2, ..."""
    names = []
    for k in range(1, n_links + 1):
        names += [f"B{k}", f"theta{k + 1}"]
    return names


def _finite(fieldname: str, value) -> float:
    # the one gate for numbers (finite, bounded magnitude), whoever builds the model:
    # a scene file, a sweep's override or an FMU's parameter
    if isinstance(value, np.generic):
        value = value.item()
    try:
        return number(value, fieldname)
    except InputError as exc:
        raise SceneError(exc.field, exc.reason) from None


_LINK_FIELD_ORDER = ("joint", "a", "p", "q", "m", "I", "damping", "parent")


def link_problems(link: Link, f: str, k: int) -> list[SceneError]:
    """Every reason link ``k`` (thesis numbering, named ``f`` in messages) is refused; empty if none.

    One problem per field, so that a scene with a negative length and a zero mass
    hears of both (the scene reader and :class:`Mechanism` share this check).  The
    types and numbers are judged here; the rules (a length >= 0, a positive mass,
    an earlier parent, ...) are the kernel's grb_link_check, which the native FMU
    runs too.
    """
    found = Problems()
    if link.joint not in (REVOLUTE, PRISMATIC):
        found.add(SceneError(f"{f}.joint", f"must be 'R' or 'P', got {link.joint!r}"))
    values = {}
    for name in ("a", "p", "q", "m", "I", "damping"):
        with found.check():
            values[name] = _finite(f"{f}.{name}", getattr(link, name))
    pk = k - 1 if link.parent is None else link.parent
    if isinstance(pk, np.integer):
        pk = int(pk)
    if isinstance(pk, bool) or not isinstance(pk, int):
        found.add(SceneError(f"{f}.parent", f"must be the ground (1) or an earlier link 2..{k - 1} "
                                            f"(the chain's predecessor), got {pk!r}"))
        pk = k - 1
    told = {p.field for p in found}
    row = [1.0, pk, *(values.get(name, 1.0) for name in ("a", "p", "q", "m", "I", "damping"))]
    for field_, reason in binding.link_problems(k, row):
        field_ = f + field_[len(f"link{k}"):]
        if field_ not in told:
            found.add(SceneError(field_, reason))
    order = {f"{f}.{name}": i for i, name in enumerate(_LINK_FIELD_ORDER)}
    return sorted(found, key=lambda p: order.get(p.field, len(order)))


def _link_number(value, field_name: str) -> float:
    # a link number as the kernel's check reads it (which judges its range and that it is whole)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise SceneError(field_name, f"must be a link number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Mechanism:
    """An N-link generalised chain with its closures: the whole model.

    Parameters
    ----------
    links : sequence of Link
        Moving links 2 .. N+1 in chain order.
    closures : sequence of Closure
        Loop closures; empty for an open chain (a pendulum or arm).
    q_ref : sequence of float
        Absolute coordinates (B1, theta2, ..., B_N, theta_{N+1}) that define the
        locked values of the fictitious joints (and the initial guess).
    a1, theta1 : float
        Ground vector: length (m) and angle (rad).
    gravity : float
        g, m/s^2, acting along -y.
    drive, load : str or None
        Coordinate names (e.g. ``'theta2'``) of the real joints a motor and a
        load act on.
    drive_inertia : float
        Inertia a motor adds to the drive joint (kg m^2, or kg on a slide): the
        rotor's inertia times the gear ratio squared.  It belongs in the
        mechanism's mass matrix, not in a motor model one communication step
        away, because the rotor often outweighs the linkage.
    name, kind, description : str
        Labels: preset name, mechanism type, free text.
    actuators : sequence of Actuator
        Linear actuators between links: each takes a force as an input and
        gives its length and rate.
    forces : sequence of Spring, JointSpring or PointLoad
        Force elements: model data, each with its outputs (force, stored
        energy, ...).

    Examples
    --------
    >>> import math
    >>> from grubler import Closure, Link, Mechanism
    >>> fourbar = Mechanism(
    ...     links=(Link("R", a=0.2, p=0.1, m=1.0, I=0.1), Link("R", a=0.8, p=0.4, m=2.0, I=0.2),
    ...            Link("R", a=0.8, p=0.4, m=3.0, I=0.3)),
    ...     closures=(Closure("revolute", link=4, point=(0.8, 0.0), to_point=(1.0, 0.0)),),
    ...     q_ref=(0.0, 0.0, 0.0, math.pi / 3, 0.0, -math.pi / 3))
    >>> fourbar.mobility, fourbar.free_names
    (1, ['theta2', 'theta3', 'theta4'])
    """

    links: tuple[Link, ...]
    closures: tuple[Closure, ...] = ()
    q_ref: tuple[float, ...] = ()
    a1: float = 0.0
    theta1: float = 0.0
    gravity: float = G_STANDARD
    drive: str | None = None
    load: str | None = None
    drive_inertia: float = 0.0
    name: str = ""
    kind: str = ""
    description: str = ""
    actuators: tuple[Actuator, ...] = ()
    forces: tuple = ()
    # derived structure, filled in __post_init__
    _S: np.ndarray = field(init=False, repr=False, compare=False)
    _q_locked: np.ndarray = field(init=False, repr=False, compare=False)
    _free: tuple[int, ...] = field(init=False, repr=False, compare=False)
    arrays: "ModelArrays" = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "closures", tuple(self.closures))
        object.__setattr__(self, "actuators", tuple(self.actuators))
        object.__setattr__(self, "forces", tuple(self.forces))
        n = len(self.links)
        # the numbers and types here; the mechanism's rules are the kernel's (problems())
        q_ref = tuple(self.q_ref) if len(self.q_ref) else (0.0,) * (2 * n)
        if len(q_ref) != 2 * n:
            raise SceneError("initial", f"needs {2 * n} coordinates for {n} links, got {len(q_ref)}")
        names = coordinate_names(n)
        q_ref = tuple(_finite(f"initial.{nm}", v) for nm, v in zip(names, q_ref))
        object.__setattr__(self, "q_ref", q_ref)
        object.__setattr__(self, "a1", _finite("ground.a1", self.a1))
        object.__setattr__(self, "theta1", _finite("ground.theta1", self.theta1))
        _finite("gravity", self.gravity)
        object.__setattr__(self, "drive_inertia", _finite("drive.inertia", self.drive_inertia))
        self._validate_links()
        self._validate_closures()
        self._validate_actuators()
        self._validate_forces()
        raise_all(self.problems())
        self._build_structure()
        object.__setattr__(self, "arrays", ModelArrays.of(self))

    # -- validation ---------------------------------------------------------
    def _validate_links(self):
        found = Problems()  # every link's every problem in one refusal
        for i, link in enumerate(self.links):
            for problem in link_problems(link, f"link{i + 2}", i + 2):
                found.add(problem)
        found.raise_all()

    def _validate_closures(self):
        for j, cl in enumerate(self.closures):
            f = "closure" if len(self.closures) == 1 else f"closure[{j}]"
            if cl.kind not in ("revolute", "prismatic"):
                raise SceneError(f"{f}.type", f"must be 'revolute' or 'prismatic', got {cl.kind!r}")
            for name in ("link", "to_link"):
                _link_number(getattr(cl, name), f"{f}.{name}")
            for name in ("point", "to_point"):
                v = getattr(cl, name)
                if len(v) != 2:
                    raise SceneError(f"{f}.{name}", f"must be [x, y], got {v!r}")
                for x in v:
                    _finite(f"{f}.{name}", x)
            for name in ("angle", "psi", "gain", "damping"):
                _finite(f"{f}.{name}", getattr(cl, name))

    def _validate_actuators(self):
        n = len(self.links)
        seen, clean = set(), []
        for j, act in enumerate(self.actuators):
            f = f"actuator[{j}]"
            if not (isinstance(act.name, str) and ACTUATOR_NAME.fullmatch(act.name)):
                raise SceneError(f"{f}.name", "must be a letter, then up to 31 letters, digits or underscores "
                                              f"(it names the columns <name>_length, <name>_rate), got {act.name!r}")
            if act.name in seen:
                raise SceneError(f"{f}.name", f"{act.name!r} names another actuator already")
            seen.add(act.name)
            for key in ("from_link", "to_link"):  # the kernel's check judges their range
                k = getattr(act, key)
                if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
                    raise SceneError(f"{f}.{key}", f"link {k!r} does not exist: the mechanism has the ground (1) "
                                                   f"and links 2..{n + 1}")
            points = {}
            for key in ("from_point", "to_point"):
                v = getattr(act, key)
                if not (isinstance(v, (tuple, list)) and len(v) == 2):
                    raise SceneError(f"{f}.{key}", f"must be [x, y], got {v!r}")
                points[key] = tuple(_finite(f"{f}.{key}", x) for x in v)
            clean.append(Actuator(act.name, int(act.from_link), points["from_point"], int(act.to_link),
                                  points["to_point"]))
        object.__setattr__(self, "actuators", tuple(clean))

    def force_field(self, j: int) -> str:
        """Force element j's name in messages, as a scene file spells its table: ``spring[0]``, ``point_load[1]``."""
        element = self.forces[j]
        return f"{element.table}[{sum(type(e) is type(element) for e in self.forces[:j])}]"

    def _validate_forces(self):
        names = set(self.actuator_names)
        clean = []
        for j, element in enumerate(self.forces):
            if type(element) not in FORCE_ELEMENTS:
                raise SceneError("forces", f"must be Spring, JointSpring or PointLoad elements, got {element!r}")
            f = self.force_field(j)
            if not (isinstance(element.name, str) and ACTUATOR_NAME.fullmatch(element.name)):
                raise SceneError(f"{f}.name", "must be a letter, then up to 31 letters, digits or underscores "
                                              f"(it names the columns <name>_force, ...), got {element.name!r}")
            if element.name in names:
                raise SceneError(f"{f}.name", f"{element.name!r} names another actuator or force element already")
            if _RESERVED_NAME.fullmatch(element.name):
                raise SceneError(f"{f}.name", f"{element.name!r} is a scene table's name: its parameters "
                                              f"({element.name}.stiffness, ...) would read as that table's")
            names.add(element.name)
            changes = {}
            for key, value in element.__dict__.items():
                if key in ("name", "joint"):
                    continue
                if key in ("from_link", "to_link", "link"):
                    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                        raise SceneError(f"{f}.{key}", f"link {value!r} does not exist: the mechanism has the ground "
                                                       f"(1) and links 2..{len(self.links) + 1}")
                    changes[key] = int(value)
                elif key in ("from_point", "to_point", "point", "force"):
                    if not (isinstance(value, (tuple, list)) and len(value) == 2):
                        raise SceneError(f"{f}.{key}", f"must be [x, y], got {value!r}")
                    changes[key] = tuple(_finite(f"{f}.{key}", x) for x in value)
                else:
                    changes[key] = _finite(f"{f}.{key}", value)
            if isinstance(element, JointSpring):
                if element.joint not in self.coordinate_names:
                    raise SceneError(f"{f}.joint", f"unknown coordinate {element.joint!r}; expected one of "
                                                   f"{', '.join(self.coordinate_names)}")
                self.free_index(element.joint, f"{f}.joint")  # a real joint: the kernel's rule
            clean.append(replace(element, **changes))
        object.__setattr__(self, "forces", tuple(clean))

    def force_table(self) -> np.ndarray:
        """The force elements as the kernel's rows (F x 19), links thesis-numbered (1 the ground)."""
        rows = [force_row(e, self.coordinate_names.index(e.joint) // 2 + 2 if isinstance(e, JointSpring) else 0)
                for e in self.forces]
        return np.array(rows, dtype=float).reshape(len(rows), 19)

    @property
    def force_names(self) -> list[str]:
        """The force elements' names, in scene order."""
        return [e.name for e in self.forces]

    def problems(self, initial_rates=None) -> list[SceneError]:
        """Every refusal of the mechanism's rules (the kernel's grb_scene_check, which the native FMU runs too).

        With ``initial_rates`` (2N absolute rates, thesis order) the rates of the
        locked coordinates are judged too.  Empty when the mechanism obeys them.
        """
        n = len(self.links)
        names = coordinate_names(n)
        links = np.array([(1.0 if l.joint == REVOLUTE else 2.0, k + 1 if l.parent is None else l.parent,
                           l.a, l.p, l.q, l.m, l.I, l.damping) for k, l in enumerate(self.links)],
                         dtype=float).reshape(n, 8)
        closures = np.array([(1.0 if c.kind == "revolute" else 2.0, c.link, c.to_link, *c.point, *c.to_point,
                              c.angle, c.psi, c.gain, c.damping) for c in self.closures],
                            dtype=float).reshape(len(self.closures), 11)
        actuators = np.array([(a.from_link, *a.from_point, a.to_link, *a.to_point) for a in self.actuators],
                             dtype=float).reshape(len(self.actuators), 6)
        joints = []
        for role in ("drive", "load"):
            joint = getattr(self, role)
            if joint is not None and joint not in names:
                raise SceneError(f"{role}.joint", f"unknown coordinate {joint!r}; expected one of {', '.join(names)}")
            joints.append(-1 if joint is None else names.index(joint))
        found = binding.scene_problems(links, closures, actuators, self.a1, self.theta1, self.gravity,
                                       np.array(self.q_ref, dtype=float), initial_rates, joints[0], joints[1],
                                       self.drive_inertia, self.force_table(),
                                       [self.force_field(j) for j in range(len(self.forces))])
        return [SceneError(f, r) for f, r in found]

    # -- structure ----------------------------------------------------------
    def _build_structure(self):
        n = len(self.links)
        free = tuple(2 * i + (1 if link.joint == REVOLUTE else 0) for i, link in enumerate(self.links))
        S = np.zeros((2 * n, n))
        q_locked = np.zeros(2 * n)
        # theta_k = theta_parent + phi_k: a relative angle moves every angle of its subtree
        rel = self.relative_from_absolute(self.q_ref)
        for i, link in enumerate(self.links):
            if link.joint == PRISMATIC:
                S[2 * i, i] = 1.0
            else:
                for k in range(i, n):
                    if i + 2 in self.path_to_ground(k + 2):
                        S[2 * k + 1, i] = 1.0
        # locked part: slides keep value, revolutes keep relative angle
        locked_rel = np.array(rel, dtype=float)
        for i, link in enumerate(self.links):
            locked_rel[free[i]] = 0.0
        q_locked[0::2] = locked_rel[0::2]
        # the locked relative angles summed from the ground, in the kernel's order (grb_scene_tables)
        locked = np.zeros(n)
        for i in range(n):
            pk = self.parents[i]
            locked[i] = (0.0 if pk == 1 else locked[pk - 2]) + locked_rel[2 * i + 1]
        q_locked[1::2] = locked + self.theta1
        object.__setattr__(self, "_S", S)
        object.__setattr__(self, "_q_locked", q_locked)
        object.__setattr__(self, "_free", free)

    def relative_from_absolute(self, q) -> list[float]:
        """Joint variables (slides and relative angles) from absolute coordinates."""
        q = list(q)
        rel = list(q)
        for i, pk in enumerate(self.parents):
            rel[2 * i + 1] = q[2 * i + 1] - (self.theta1 if pk == 1 else q[2 * pk - 3])
        return rel

    @property
    def parents(self) -> tuple[int, ...]:
        """Each moving link's predecessor, thesis numbering (1 the ground)."""
        return tuple(k + 1 if link.parent is None else int(link.parent) for k, link in enumerate(self.links))

    @property
    def is_tree(self) -> bool:
        """Whether some link hangs from another than the previous link (the chain branches)."""
        return any(pk != k + 1 for k, pk in enumerate(self.parents))

    def path_to_ground(self, link: int) -> list[int]:
        """The links from ``link`` (thesis numbering) down to the ground's child: whose joints move it."""
        path, parents = [], self.parents
        while link > 1:
            path.append(link)
            link = parents[link - 2]
        return path

    def loop_pairs(self, a: int, b: int) -> list[int]:
        """The chain's joint pairs (by the link they attach) on the tree path between links ``a`` and ``b``.

        With a closure between ``a`` and ``b`` they make its loop: in a serial
        chain, the pairs of links lo+1 .. hi.
        """
        pa, pb = self.path_to_ground(a), self.path_to_ground(b)
        common = set(pa) & set(pb)
        return sorted(k for k in pa + pb if k not in common)

    @property
    def n_links(self) -> int:
        """Number of moving links N."""
        return len(self.links)

    @property
    def n_free(self) -> int:
        """Number of integrated joint coordinates (one real joint per pair)."""
        return len(self.links)

    @property
    def n_constraints(self) -> int:
        return sum(cl.dim for cl in self.closures)

    @property
    def mobility(self) -> int:
        """Grübler/Kutzbach mobility 3(n-1) - 2 j1 with one-DOF joints only."""
        return kutzbach_mobility(self.n_links + 1, self.n_links + len(self.closures))

    @property
    def coordinate_names(self) -> list[str]:
        return coordinate_names(self.n_links)

    @property
    def free_names(self) -> list[str]:
        """Names of the real joints' coordinates, in integration order."""
        names = self.coordinate_names
        return [names[i] for i in self._free]

    def free_index(self, name: str, field_name: str = "joint") -> int:
        """Index in ``z`` of the real joint called ``name`` (e.g. 'theta2')."""
        names = self.coordinate_names
        if name not in names:
            raise SceneError(field_name, f"unknown coordinate {name!r}; expected one of {', '.join(names)}")
        idx = names.index(name)
        pair = idx // 2
        problem = binding.coordinate_problem(idx, self.links[pair].joint == REVOLUTE, field_name)
        if problem is not None:
            raise SceneError(*problem)
        return pair

    @property
    def S(self) -> np.ndarray:
        """Constant map from joint rates to absolute coordinate rates (2N x N)."""
        return self._S

    def q_from_z(self, z) -> np.ndarray:
        """Absolute coordinates (thesis order) from joint coordinates."""
        return self._q_locked + self._S @ np.asarray(z, dtype=float)

    def z_from_q(self, q) -> np.ndarray:
        """Joint coordinates of the real joints from absolute coordinates."""
        rel = self.relative_from_absolute(q)
        return np.array([rel[i] for i in self._free])

    def zd_from_qd(self, qd) -> np.ndarray:
        """Real joint rates from absolute coordinate rates (ground fixed)."""
        qd = list(qd)
        rel = list(qd)
        for i, pk in enumerate(self.parents):
            rel[2 * i + 1] = qd[2 * i + 1] - (0.0 if pk == 1 else qd[2 * pk - 3])
        return np.array([rel[i] for i in self._free])

    @property
    def actuator_names(self) -> list[str]:
        """The actuators' names, in scene order."""
        return [a.name for a in self.actuators]

    def joint_is_revolute(self) -> np.ndarray:
        return self.arrays.revolute

    def replace(self, **changes) -> "Mechanism":
        """A copy with some fields changed (re-validated)."""
        kw = {f: getattr(self, f) for f in (
            "links", "closures", "q_ref", "a1", "theta1", "gravity", "drive", "load", "drive_inertia",
            "name", "kind", "description", "actuators", "forces")}
        kw.update(changes)
        return Mechanism(**kw)
