"""Spatial scenes: a :class:`~grubler.mechanism.spatial.SpatialMechanism`, its drive and start, from TOML.

The form (docs/scenes.md, "Spatial scenes") marks itself with ``dimension = 3``;
every file in ``presets/spatial/`` is an example, and each reproduces a builder of
:mod:`grubler.mechanism.spatial`.  Links are ``[[link]]`` tables in DH form (Craig's
modified convention, as :class:`~grubler.mechanism.spatial.SpatialLink`), their
joint ``R``, ``P``, ``C`` (cylindrical), ``F`` (fixed) or ``S``: a spherical joint,
three revolutes on axes through one point (:func:`~grubler.mechanism.spatial.spherical_joint`)
carrying the body the table describes.  A spherical joint is a joint kind of a
``[[link]]`` rather than a table of its own because TOML keeps no order between two
arrays of tables, and the links' order is the coordinates' order.

Every number is read by its field's kind (:func:`grubler.mechanism.scene.parse_field`,
the quantities table): angles in rad, or text with the unit ('90 deg', 'pi/2');
lengths in m, or text ('120 mm').  A refusal names the field as the file spells it
(``link[2].inertia``, ``closure[0].to``), the model check's (the kernel's) included.

Examples
--------
>>> scene = load_spatial_scene("rssr")
>>> scene.mechanism.coordinate_names[:2], scene.drive
(('crank.theta', 'coupler1.theta'), 'crank.theta')
>>> y0 = scene.start()
>>> bool(abs(scene.mechanism.constraint(y0[:scene.mechanism.n_coords])[0]).max() < 1e-12)
True
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path

import numpy as np

from grubler.errors import InputError, Problems, SceneError
from grubler.limits import brief, did_you_mean, parse_toml, read_text
from grubler.mechanism.scene import parse_field
from grubler.mechanism.spatial import JOINTS, CLOSURE_KINDS, GRAVITY, SpatialClosure, SpatialLink, \
    SpatialMechanism, spherical_joint

__all__ = ["SpatialScene", "load_spatial_scene", "spatial_scene_from_dict", "spatial_preset_names", "is_spatial",
           "rod_inertia"]

_TOP = {"dimension", "name", "description", "gravity", "link", "closure", "initial", "drive", "simulate"}
_LINK_KEYS = {"name", "joint", "parent", "a", "alpha", "theta", "d", "mass", "com", "inertia", "rod", "radius",
              "damping"}
_CLOSURE_KEYS = {"kind", "link", "to", "point", "to_point", "axis", "to_axis"}
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
ROD_RADIUS = 0.005  # m: a rod shortcut's radius when none is given (the builders' rods)
_SPHERICAL_THETA = (0.0, math.pi / 2, 0.0)  # spherical_joint's default angles


@dataclass(frozen=True)
class SpatialScene:
    """A spatial mechanism with its start, drive and run settings.

    Attributes
    ----------
    mechanism : SpatialMechanism
    sketch : ndarray (N,)
        The coordinates the assembly starts from (they pick the branch).
    hold : tuple of int
        The coordinates the assembly keeps (default the first).
    rates : ndarray (N,)
        Initial joint rates (the held ones kept, the others made consistent).
    drive : str or None
        The coordinate the constant ``torque`` acts on (N m, or N on a slide).
    t_end, dt_out : float
        Default run length and output interval, s.

    Examples
    --------
    >>> scene = load_spatial_scene("bennett")
    >>> scene.drive, scene.torque, scene.t_end
    ('link1.theta', 0.001, 4.0)
    >>> scene.tau().tolist(), scene.tau(0.0).tolist()
    ([0.001, 0.0, 0.0], [0.0, 0.0, 0.0])
    """

    mechanism: SpatialMechanism
    sketch: np.ndarray
    hold: tuple
    rates: np.ndarray
    drive: str | None = None
    torque: float = 0.0
    t_end: float = 2.0
    dt_out: float = 0.01
    name: str = ""
    description: str = ""

    def tau(self, torque: float | None = None) -> np.ndarray | None:
        """The generalised efforts: ``torque`` (default the scene's) on the drive coordinate, None for none."""
        torque = self.torque if torque is None else torque
        if self.drive is None:
            if torque:
                raise SceneError("drive.joint", "a drive torque needs the coordinate it acts on")
            return None
        tau = np.zeros(self.mechanism.n_coords)
        tau[self.mechanism.coordinate_names.index(self.drive)] = torque
        return tau

    def start(self) -> np.ndarray:
        """The closed initial state y0 = (z, zd), assembled from the sketch holding ``hold``."""
        try:
            return self.mechanism.assemble(self.sketch, self.rates, held=self.hold)
        except InputError as exc:
            raise SceneError("initial", exc.reason) from None


def rod_inertia(mass: float, rod, radius: float = ROD_RADIUS) -> tuple[np.ndarray, np.ndarray]:
    """The mass centre and the inertia tensor (about it, in the link's axes) of a uniform slender rod of
    ``radius`` from the link's origin to the point ``rod``: the ``rod`` shortcut of a ``[[link]]``.

    Examples
    --------
    >>> com, I = rod_inertia(0.5, (0.1, 0.0, 0.0))
    >>> com.tolist(), np.diag(I).round(9).tolist()
    ([0.05, 0.0, 0.0], [6.25e-06, 0.000419792, 0.000419792])
    """
    rod = np.asarray(rod, dtype=float)
    length = float(np.linalg.norm(rod))
    u = rod / length
    transverse = mass * (3 * radius ** 2 + length ** 2) / 12
    along = mass * radius ** 2 / 2
    outer = np.outer(u, u)
    return rod / 2, transverse * (np.eye(3) - outer) + along * outer


def _check_keys(table: dict, allowed: set, prefix: str):
    for key in table:
        if key not in allowed:
            raise SceneError(f"{prefix}.{key}" if prefix else key,
                             f"unknown key{did_you_mean(key, allowed)}; expected one of {', '.join(sorted(allowed))}")


def _tables(data: dict, key: str) -> list[dict]:
    given = data.get(key, [])
    if not (isinstance(given, list) and all(isinstance(d, dict) for d in given)):
        raise SceneError(key, f"must be an array of tables [[{key}]]")
    return given


def _table(data: dict, key: str) -> dict:
    v = data.get(key, {})
    if not isinstance(v, dict):
        raise SceneError(key, f"must be a table [{key}], got {brief(v)}")
    return v


def _vector(value, field: str, size: int = 3) -> np.ndarray:
    """``size`` numbers, each read by the field's kind (a part named field[i])."""
    if not (isinstance(value, list) and len(value) == size):
        raise SceneError(field, f"must be a list of {size} numbers, got {brief(value)}")
    return np.array([parse_field(v, f"{field}[{i}]") for i, v in enumerate(value)])


def _inertia(value, field: str) -> np.ndarray:
    """A 3 x 3 tensor, or its principal moments [Ixx, Iyy, Izz] about the link's axes."""
    if isinstance(value, list) and len(value) == 3 and all(isinstance(row, list) for row in value):
        return np.array([_vector(row, f"{field}[{i}]") for i, row in enumerate(value)])
    if isinstance(value, list) and len(value) == 3:
        return np.diag(_vector(value, field))
    raise SceneError(field, f"must be [Ixx, Iyy, Izz] or a 3 x 3 tensor [[..], [..], [..]] in kg m^2, got "
                            f"{brief(value)}")


def _direction(value, field: str) -> np.ndarray:
    v = _vector(value, field)
    norm = float(np.linalg.norm(v))
    if not norm > 1e-12:
        raise SceneError(field, f"must be a direction (not zero), got {v.tolist()}")
    return v / norm


def _body(d: dict, f: str) -> dict:
    """A link table's mass, mass centre and inertia (given, or from the rod shortcut)."""
    mass = parse_field(d.get("mass", 0.0), f"{f}.mass")
    if "rod" in d:
        for key in ("com", "inertia"):
            if key in d:
                raise SceneError(f"{f}.{key}", "a rod gives the mass centre and inertia: give rod or com and "
                                               "inertia, not both")
        rod = _vector(d["rod"], f"{f}.rod")
        if not np.linalg.norm(rod) > 0:
            raise SceneError(f"{f}.rod", "must be the rod's far end, not the link's origin")
        radius = parse_field(d.get("radius", ROD_RADIUS), f"{f}.radius")
        if not radius >= 0:
            raise SceneError(f"{f}.radius", f"must be >= 0, got {radius}")
        com, inertia = rod_inertia(mass, rod, radius)
    else:
        if "radius" in d:
            raise SceneError(f"{f}.radius", "is the rod's: give rod too")
        com = _vector(d["com"], f"{f}.com") if "com" in d else np.zeros(3)
        inertia = _inertia(d["inertia"], f"{f}.inertia") if "inertia" in d else np.zeros((3, 3))
    return dict(mass=mass, com=tuple(com), inertia=tuple(map(tuple, inertia)))


def _links(tables: list[dict], found: Problems) -> tuple[list[SpatialLink], list[int], dict]:
    """The model's links from the [[link]] tables, each model link's table index, and the index of each name."""
    links: list[SpatialLink] = []
    table_of: list[int] = []
    index: dict = {}
    for j, d in enumerate(tables):
        f = f"link[{j}]"
        with found.check():
            _check_keys(d, _LINK_KEYS, f)
            name = d.get("name")
            if not (isinstance(name, str) and _NAME.fullmatch(name)) or name == "ground":
                raise SceneError(f"{f}.name", f"must be a name (a letter, then letters, digits or underscores; "
                                              f"not 'ground'), got {brief(name)}")
            joint = d.get("joint")
            kinds = (*JOINTS, "S")
            if joint not in kinds:
                raise SceneError(f"{f}.joint", f"must be one of {', '.join(kinds)} (R revolute, P prismatic, "
                                               f"C cylindrical, F fixed, S spherical), got {brief(joint)}")
            names = [f"{name}1", f"{name}2", name] if joint == "S" else [name]
            for n in names:
                if n in index:
                    raise SceneError(f"{f}.name", f"{n!r} names an earlier link already"
                                     + (" (a spherical joint's links are NAME1, NAME2 and NAME)" if joint == "S"
                                        else ""))
            parent = d.get("parent", links[-1].name if links else "ground")
            if parent != "ground" and parent not in index:
                raise SceneError(f"{f}.parent", f"must name the ground ('ground') or an earlier link"
                                 f"{' (' + ', '.join(index) + ')' if index else ''}, got {brief(parent)}")
            row = {k: parse_field(d.get(k, 0.0), f"{f}.{k}") for k in ("a", "alpha", "d")}
            body = _body(d, f)
            damping = d.get("damping", 0.0)
            if isinstance(damping, list):
                damping = tuple(_vector(damping, f"{f}.damping", 2))
            else:
                c = parse_field(damping, f"{f}.damping")
                damping = (c, c)  # one number: the real joint's (a cylindrical joint's both)
            p = -1 if parent == "ground" else index[parent]
            at = len(links)
            if joint == "S":
                # the three revolutes' angles (the second 90 deg: the joint locks where it is 0 or 180 deg)
                theta = tuple(_vector(d.get("theta", list(_SPHERICAL_THETA)), f"{f}.theta"))
                new = spherical_joint(name, p, at, a=row["a"], alpha=row["alpha"], d=row["d"], theta=theta,
                                      mass=body["mass"], com=body["com"], inertia=np.array(body["inertia"]))
                new = [replace(l, damping=damping) for l in new]
            else:
                theta = parse_field(d.get("theta", 0.0), f"{f}.theta")
                new = [SpatialLink(name, row["a"], row["alpha"], theta, row["d"], joint, p, damping=damping,
                                   **body)]
            for k, link in enumerate(new):
                index[link.name] = at + k
            links += new
            table_of += [j] * len(new)
    return links, table_of, index


def _closures(tables: list[dict], index: dict, found: Problems) -> list[SpatialClosure]:
    out = []
    for c, d in enumerate(tables):
        f = f"closure[{c}]"
        with found.check():
            _check_keys(d, _CLOSURE_KEYS, f)
            kind = d.get("kind")
            if kind not in CLOSURE_KINDS:
                raise SceneError(f"{f}.kind", f"must be one of {', '.join(CLOSURE_KINDS)}, got {brief(kind)}")
            ends = {}
            for key, ground_ok in (("link", False), ("to", True)):
                v = d.get(key, "ground" if ground_ok else None)
                if not (v in index or (ground_ok and v == "ground")):
                    raise SceneError(f"{f}.{key}", f"must name a link{' or the ground' if ground_ok else ''} "
                                                   f"({', '.join(index)}), got {brief(v)}")
                ends[key] = -1 if v == "ground" else index[v]
            if ends["link"] == ends["to"]:
                raise SceneError(f"{f}.to", "must be another link than the closing one (or the ground)")
            if kind == "spherical" and ("axis" in d or "to_axis" in d):
                raise SceneError(f"{f}.{'axis' if 'axis' in d else 'to_axis'}", "a spherical closure has no axis")
            vectors = {k: _vector(d[k], f"{f}.{k}") for k in ("point", "to_point") if k in d}
            vectors |= {k: _direction(d[k], f"{f}.{k}") for k in ("axis", "to_axis") if k in d}
            out.append(SpatialClosure(kind, ends["link"], ends["to"], **{k: tuple(v) for k, v in vectors.items()}))
    return out


def _model_field(field: str, table_of: list[int]) -> str:
    """A model check's field (``links[4].inertia``) as the scene spells it (``link[3].inertia``)."""
    m = re.fullmatch(r"links\[(\d+)\](.*)", field)
    if m and int(m[1]) < len(table_of):
        return f"link[{table_of[int(m[1])]}]{m[2]}"
    m = re.fullmatch(r"closures\[(\d+)\](.*)", field)
    return f"closure[{m[1]}]{m[2]}" if m else field


def spatial_scene_from_dict(data: dict, name: str = "") -> SpatialScene:
    """A spatial scene from parsed TOML (see docs/scenes.md, "Spatial scenes").

    Raises
    ------
    SceneError
        Naming the field at fault (several at once as :class:`~grubler.errors.SceneErrors`).

    Examples
    --------
    >>> sc = spatial_scene_from_dict({"dimension": 3, "link": [{"name": "arm", "joint": "R", "alpha": "90 deg",
    ...                                "mass": 1.0, "rod": [0.5, 0, 0]}], "initial": {"arm.theta": "30 deg"}})
    >>> sc.mechanism.coordinate_names, round(math.degrees(sc.sketch[0]), 9)
    (('arm.theta',), 30.0)
    """
    found = Problems()
    with found.check():
        _check_keys(data, _TOP, "")
    if data.get("dimension") != 3:
        found.add(SceneError("dimension", f"a spatial scene says dimension = 3, got {brief(data.get('dimension'))}"))
    link_tables, closure_tables = [], []
    with found.check():
        link_tables = _tables(data, "link")
        if not link_tables:
            raise SceneError("link", "a spatial scene needs [[link]] tables (one moving link at least)")
    with found.check():
        closure_tables = _tables(data, "closure")
    links, table_of, index = _links(link_tables, found)
    closures = _closures(closure_tables, index, found) if len(found) == 0 else []
    gravity = (0.0, 0.0, -GRAVITY)
    if "gravity" in data:
        with found.check():
            gravity = tuple(_vector(data["gravity"], "gravity"))
    tables = {}
    for key, keys in (("initial", None), ("drive", {"joint", "torque"}), ("simulate", {"t_end", "dt_out"})):
        with found.check():
            tables[key] = _table(data, key)
            if keys:
                _check_keys(tables[key], keys, key)
    found.raise_all()
    try:
        mechanism = SpatialMechanism(links, closures, gravity)
    except InputError as exc:
        raise SceneError(_model_field(exc.field, table_of), exc.reason) from None
    coords = mechanism.coordinate_names
    sketch, rates, hold = np.zeros(len(coords)), np.zeros(len(coords)), (0,)
    for key, value in tables["initial"].items():
        with found.check():
            if key == "hold":
                if not (isinstance(value, list) and value and all(v in coords for v in value)):
                    raise SceneError("initial.hold", f"must list the coordinates the assembly keeps (of "
                                                     f"{', '.join(coords)}), got {brief(value)}")
                hold = tuple(coords.index(v) for v in value)
            elif key in coords:
                sketch[coords.index(key)] = parse_field(value, f"initial.{key}")
            elif key.endswith("_d") and key[:-2] in coords:
                rates[coords.index(key[:-2])] = parse_field(value, f"initial.{key}")
            else:
                raise SceneError(f"initial.{key}", f"not a coordinate{did_you_mean(key, coords)} (one of "
                                                   f"{', '.join(coords)}; a rate: NAME_d; or hold)")
    drive, torque = tables["drive"].get("joint"), 0.0
    with found.check():
        if drive is not None and drive not in coords:
            raise SceneError("drive.joint", f"must name a coordinate, got {brief(drive)}{did_you_mean(drive, coords)} "
                                            f"(one of {', '.join(coords)})")
        torque = parse_field(tables["drive"].get("torque", 0.0), "drive.torque")
        if torque and drive is None:
            raise SceneError("drive.joint", "a drive torque needs the coordinate it acts on")
    run = {"t_end": 2.0, "dt_out": 0.01}
    for key in run:
        with found.check():
            run[key] = parse_field(tables["simulate"].get(key, run[key]), f"simulate.{key}")
            if not run[key] > 0:
                raise SceneError(f"simulate.{key}", f"must be positive, got {run[key]}")
    found.raise_all()
    scene = SpatialScene(mechanism, sketch, hold, rates, drive, torque, run["t_end"], run["dt_out"],
                         str(data.get("name", name)), str(data.get("description", "")))
    scene.start()  # a loop that cannot close is the scene's fault: told now, not at the first run
    return scene


def _folder():
    return resources.files("grubler") / "presets" / "spatial"


def spatial_preset_names() -> list[str]:
    """The spatial scenes shipped with the package (``presets/spatial/*.toml``).

    Examples
    --------
    >>> "rssr" in spatial_preset_names()
    True
    """
    return sorted(p.name[:-5] for p in _folder().iterdir() if p.name.endswith(".toml"))


def _source(source) -> tuple[str, str] | None:
    """The TOML text of a source and its name, or None where it is neither a spatial preset nor a file."""
    src = str(source)
    if src in spatial_preset_names():
        return (_folder() / f"{src}.toml").read_text(), src
    if "\n" not in src and len(src) < 4096 and Path(src).is_file():
        return read_text(src, "scene"), Path(src).stem
    if "\n" in src:
        return src, ""
    return None


def is_spatial(source) -> bool:
    """Whether a scene source (preset name, file or TOML text) is a spatial scene: a spatial preset, or TOML
    that says ``dimension = 3``.  What is not readable is left to the planar loader to refuse.

    Examples
    --------
    >>> is_spatial("hooke-joint"), is_spatial("thesis-fourbar"), is_spatial("dimension = 3\\n")
    (True, False, True)
    """
    found = _source(source)
    if found is None:
        return False
    try:  # bounded as every scene's TOML is (limits.parse_toml: nesting depth, huge integers)
        return parse_toml(found[0], "scene").get("dimension") == 3
    except InputError:
        return False


def load_spatial_scene(source) -> SpatialScene:
    """A spatial scene from a spatial preset's name, a TOML file path, or TOML text.

    Raises
    ------
    SceneError
        Naming the field at fault.

    Examples
    --------
    >>> scene = load_spatial_scene("bricard")
    >>> scene.mechanism.coordinate_names[:2], scene.t_end, scene.dt_out
    (('rod1.theta', 'rod2.theta'), 10.0, 0.025)
    >>> load_spatial_scene("rsr")
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: scene: 'rsr' is neither a spatial preset nor a TOML file; did you mean 'rssr'?
    """
    found = _source(source)
    if found is None:
        raise SceneError("scene", f"{brief(str(source))} is neither a spatial preset nor a TOML file"
                                  f"{did_you_mean(str(source), spatial_preset_names())}")
    text, name = found
    try:
        data = parse_toml(text, "scene")
    except InputError as exc:
        raise SceneError(exc.field, exc.reason) from None
    return spatial_scene_from_dict(data, name)
