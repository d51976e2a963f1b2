"""Scenes: a mechanism, its loads and its initial state, from TOML or a preset.

The schema is documented in ``docs/scenes.md``; every preset in ``presets/`` is an
example.  Angles are radians when given as numbers; strings such as ``"60 deg"``,
``"pi/3"`` or ``"-2*pi/3"`` are accepted too.

Examples
--------
>>> scene = load_scene("thesis-fourbar")
>>> scene.mechanism.free_names
['theta2', 'theta3', 'theta4']
>>> parse_angle_or_number("-pi/3", "initial.theta4")
-1.0471975511965976
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path

import numpy as np

from grubler.mechanism.builders import BUILDERS
from grubler.mechanism.dynamics import METHODS
from grubler.errors import InputError, Problems, SceneError, raise_all
from grubler.limits import (brief, did_you_mean, parse_angle, parse_angle_or_number, parse_length, parse_number,
                            parse_toml, read_text)
from grubler.mechanism.model import (Actuator, Closure, JointSpring, Link, Mechanism, PointLoad, Spring,
                                     coordinate_names, link_problems)
from grubler.quantities import ANGLE_UNIT, scene_field

def parse_coordinate(name: str, value, field: str) -> float:
    """A joint coordinate's value: a revolute's angle (:func:`parse_angle`), rad, or a
    slide's length B, m (:func:`~grubler.limits.parse_length`: a number, or text such as '0.2 m')."""
    return parse_length(value, field) if name.startswith("B") else parse_angle(value, field)


def parse_at(text: str, drive: str | None, field: str = "--at") -> tuple[str, float]:
    """A joint coordinate and its value as ``--at`` gives them: ``VALUE`` (the drive's) or ``NAME=VALUE``.

    The one reading of ``--at`` for ``grubler info`` and ``grubler linearize``: the
    value with its unit (:func:`parse_coordinate`), spaced or not.

    Examples
    --------
    >>> name, value = parse_at("theta2=30deg", "theta2")
    >>> name, round(math.degrees(value), 9)
    ('theta2', 30.0)
    >>> parse_at("30 deg", "theta2") == parse_at("theta2 = 30 deg", "theta2")
    True
    """
    if not isinstance(text, str) or not text.strip():
        raise SceneError(field, "needs a value: '30 deg' (the drive joint's) or NAME=VALUE (theta2=30deg)")
    name, eq, value = text.partition("=")
    if not eq:
        if not drive:
            raise SceneError(field, f"this scene has no drive joint: name the coordinate, NAME={brief(text.strip())}")
        name, value = drive, text
    name = name.strip()
    if not re.fullmatch(r"(theta|B)\d+", name):
        raise SceneError(field, f"{brief(name)} is not a joint coordinate (theta2, B3, ...): write "
                                "NAME=VALUE or the drive joint's VALUE alone")
    return name, parse_coordinate(name, value.strip(), field)


def coordinate_text(name: str, value: float, digits: int = 6, radians: bool = False) -> str:
    """A joint coordinate as people read it, with its unit: '-99.5296 deg' (and, with
    ``radians``, ' (-1.73712 rad)'), or a slide's '0.25 m'.

    Examples
    --------
    >>> coordinate_text("theta2", -math.pi / 2, radians=True)
    '-90 deg (-1.5708 rad)'
    >>> coordinate_text("B2", 0.25)
    '0.25 m'
    """
    if name.startswith("B"):
        return f"{value:.{digits}g} m"
    deg = f"{math.degrees(value) + 0.0:.{digits}g} deg"  # (+ 0.0: no negative zero)
    return deg + (f" ({value + 0.0:.{digits}g} rad)" if radians else "")


@dataclass(frozen=True)
class Scene:
    """A mechanism with its loads, initial rates and run settings.

    Attributes
    ----------
    mechanism : Mechanism
        Its ``q_ref`` holds the initial coordinates (locked values and guesses).
    initial_rates : ndarray
        Real joint rates at t = 0 (held one kept, others made consistent).
    torque, load_torque : float
        Constant efforts on the drive and load joints.
    method : str
        Closure method, 'exact' or 'penalty'.
    t_end, dt_out : float
        Default run length and output interval, s.

    Examples
    --------
    >>> import grubler
    >>> sc = grubler.load_scene("slider-crank")
    >>> sc.torque, sc.method, sc.t_end, sc.mechanism.n_links
    (1.0, 'exact', 10.0, 3)
    """

    mechanism: Mechanism
    initial_rates: np.ndarray
    torque: float = 0.0
    load_torque: float = 0.0
    method: str = "exact"
    t_end: float = 10.0
    dt_out: float = 0.01

    @property
    def name(self) -> str:
        return self.mechanism.name


_TOP = {"name", "description", "kind", "gravity", "mechanism", "ground", "closure", "drive", "load",
        "initial", "simulate", "actuator", "spring", "joint_spring", "point_load"}
_ACTUATOR_KEYS = {"name", "from_link", "from_point", "to_link", "to_point"}
# the force elements' tables: each key, and how it is read (a length, a pair of lengths, a number or angle)
_SPRING_KEYS = {"name": None, "from_link": "link", "from_point": "pair", "to_link": "link", "to_point": "pair",
                "stiffness": "number", "free_length": "length", "preload": "number", "damping": "number",
                "gas_force": "number", "gas_column": "length", "gas_exponent": "number"}
_JOINT_SPRING_KEYS = {"name": None, "joint": None, "stiffness": "number", "free": "number", "preload": "number",
                      "friction": "number", "friction_speed": "number"}
_POINT_LOAD_KEYS = {"name": None, "link": "link", "point": "pair", "force": "numbers", "moment": "number"}
_FORCE_TABLES = (("spring", Spring, _SPRING_KEYS, ("from_link", "from_point", "to_link", "to_point")),
                 ("joint_spring", JointSpring, _JOINT_SPRING_KEYS, ("joint",)),
                 ("point_load", PointLoad, _POINT_LOAD_KEYS, ("link",)))
_LINK_KEYS = {"joint", "existence", "a", "p", "q", "m", "I", "damping", "parent"}
_CLOSURE_KEYS = {"type", "point", "angle", "psi", "link", "at", "to_link", "gain", "damping"}


def _check_keys(table: dict, allowed: set, prefix: str):
    """Refuses every unknown key of a table at once."""
    raise_all(SceneError(f"{prefix}.{key}" if prefix else key,
                         f"unknown key{did_you_mean(key, allowed)}; expected one of {', '.join(sorted(allowed))}")
              for key in table if key not in allowed)


def _table(data: dict, key: str, prefix: str = "") -> dict:
    v = data.get(key, {})
    if not isinstance(v, dict):
        raise SceneError(prefix + key, f"must be a table, got {type(v).__name__}")
    return v


def _joint(d: dict, field: str) -> str:
    if "existence" in d:
        ef = d["existence"]
        if not (isinstance(ef, list) and len(ef) == 2 and all(x in (0, 1) for x in ef)):
            raise SceneError(f"{field}.existence", f"must be a pair of 0/1 factors, got {brief(ef)}")
        if sum(ef) != 1:
            raise SceneError(
                f"{field}.existence",
                f"{ef} makes {'both' if sum(ef) == 2 else 'neither'} joint of the pair real; "
                "exactly one must be (prismatic [1, 0] or revolute [0, 1])")
        j = "P" if ef == [1, 0] else "R"
        if "joint" in d and d["joint"] != j:
            raise SceneError(f"{field}.joint", f"{brief(d['joint'])} contradicts existence {ef}")
        return j
    j = d.get("joint")
    if "joint" not in d:
        raise SceneError(f"{field}.joint", "is required: 'R' (revolute) or 'P' (prismatic)")
    if j not in ("R", "P"):
        raise SceneError(f"{field}.joint", f"must be 'R' (revolute) or 'P' (prismatic), got {brief(j)}")
    return j


def _parent(value, field: str, k: int) -> int:
    """A link's predecessor (thesis numbering, 1 the ground) from "ground", "linkJ" or the number J."""
    if isinstance(value, str):
        text = value.strip()
        if text == "ground":
            return 1
        match = re.fullmatch(r"link(\d+)", text)
        value = int(match.group(1)) if match else value
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value < k:
        earlier = ("the ground" if k == 2
                   else f'the ground ("ground" or 1) or an earlier link ("link2" .. "link{k - 1}")')
        raise SceneError(f"{field}.parent", f"must name {earlier}: a link hangs from a predecessor, got {brief(value)}")
    return value


def scene_from_dict(data: dict, name: str = "") -> Scene:
    """Build a Scene from parsed TOML (see docs/scenes.md).

    Raises
    ------
    SceneError
        Naming the field at fault; :class:`~grubler.errors.SceneErrors` (one
        line per problem) when a scene has several problems: every check that
        does not need another's result runs before anything is refused.

    Examples
    --------
    >>> import grubler
    >>> sc = grubler.scene_from_dict({"link2": {"joint": "R", "a": 0.5, "m": 1.0}, "closure": {"type": "none"},
    ...                               "drive": {"joint": "theta2", "torque": 0.5}}, name="pendulum")
    >>> sc.mechanism.name, sc.torque
    ('pendulum', 0.5)
    """
    data = dict(data)
    if data.get("dimension") == 3:  # the other form: said so, rather than its every key refused as unknown
        raise SceneError("dimension", "a spatial scene (dimension = 3): `grubler simulate` and `grubler animate` take "
                                      "it; in Python, grubler.mechanism.spatial_scene.load_spatial_scene")
    found = Problems()
    link_keys = sorted((k for k in data if re.fullmatch(r"link\d+", k)), key=lambda k: int(k[4:]))
    with found.check():
        _check_keys({k: v for k, v in data.items() if k not in link_keys}, _TOP, "")
    built: dict = {}
    builder_failed = False
    if "mechanism" in data:
        with found.check():
            builder_failed = True
            mech = _table(data, "mechanism")
            kind = mech.get("type")
            if not isinstance(kind, str) or kind not in BUILDERS:
                raise SceneError("mechanism.type",
                                 f"unknown builder {brief(kind)}; choose one of {', '.join(BUILDERS)}")
            built = BUILDERS[kind](mech, "mechanism")
            builder_failed = False
    # links: the builder's, each overridable field by field
    links_data = [dict(d) for d in built.get("links", [])]
    for key in link_keys:
        with found.check():
            idx = int(key[4:]) - 2
            if idx < 0:
                raise SceneError(key, "moving links are numbered from 2 (link 1 is the ground)")
            table = _table(data, key)
            while len(links_data) <= idx:
                links_data.append({})
            if "existence" in table:
                links_data[idx].pop("joint", None)
            links_data[idx].update(table)
            _check_keys(table, _LINK_KEYS, key)
    if builder_failed:
        # a [linkN] table beside a builder overrides the built link field by field:
        # without the built link it cannot be judged as a whole one (its keys were)
        links_data = []
    elif not links_data:
        found.add(SceneError("link2", "a scene needs links ([link2], [link3], ...) or a [mechanism] builder"))
    links: list[Link | None] = []
    for i, d in enumerate(links_data):
        links.append(_link(d, f"link{i + 2}", i + 2, len(links_data), found))
    n = len(links)
    ground = dict(built.get("ground", {}))
    with found.check():
        ground.update(_table(data, "ground"))
        _check_keys(ground, {"a1", "theta1"}, "ground")
    # closures: one [closure] table, or an array [[closure]] for several loops
    closures = []
    if n:
        with found.check():
            for d, f in _closure_tables(built, data):
                with found.check():
                    closures.append(_closure(d, f, [link.a if link is not None else 0.0 for link in links]))
    # initial coordinates and rates
    names = coordinate_names(max(n, 1))
    initial = dict(built.get("initial", {}))
    with found.check():
        initial.update(_table(data, "initial"))
        _check_keys(initial, set(names) | {f"{x}_d" for x in names}, "initial")
    q0 = [_collect(found, initial.get(x, 0.0), f"initial.{x}") for x in names]
    qd0 = [_collect(found, initial.get(f"{x}_d", 0.0), f"initial.{x}_d") for x in names]
    drive, load, sim = {}, {}, {}
    with found.check():
        drive = _table(data, "drive")
        _check_keys(drive, {"joint", "torque", "inertia"}, "drive")
    with found.check():
        load = _table(data, "load")
        _check_keys(load, {"joint", "torque"}, "load")
    with found.check():
        sim = _table(data, "simulate")
        _check_keys(sim, {"t_end", "dt_out", "method"}, "simulate")
    method = sim.get("method", "exact")
    if not isinstance(method, str) or method not in METHODS:
        found.add(SceneError("simulate.method", f"must be one of {', '.join(METHODS)}, got {brief(method)}"))
    t_end = _collect(found, sim.get("t_end", 10.0), "simulate.t_end", positive=True)
    dt_out = _collect(found, sim.get("dt_out", 0.01), "simulate.dt_out", positive=True)
    torque = _collect(found, drive.get("torque", 0.0), "drive.torque")
    load_torque = _collect(found, load.get("torque", 0.0), "load.torque")
    a1 = _collect(found, ground.get("a1", 0.0), "ground.a1")
    theta1 = _collect(found, ground.get("theta1", 0.0), "ground.theta1")
    gravity = _collect(found, data.get("gravity", 9.81), "gravity")
    drive_inertia = _collect(found, drive.get("inertia", 0.0), "drive.inertia")
    actuators = []
    with found.check():
        actuators = _actuators(data.get("actuator", []), n)
    forces = []
    for table, cls, keys, required in _FORCE_TABLES:
        with found.check():
            forces += _force_elements(data.get(table, []), table, cls, keys, required, n)
    found.raise_all()
    # what needs the whole chain (its loops, its joints' names) is checked on it
    mechanism = Mechanism(
        links=tuple(links),
        closures=tuple(closures),
        q_ref=tuple(q0),
        a1=a1,
        theta1=theta1,
        gravity=gravity,
        drive=drive.get("joint", built.get("drive")),
        drive_inertia=drive_inertia,
        load=load.get("joint"),
        name=str(data.get("name", name)),
        kind=str(data.get("kind", "")),
        description=str(data.get("description", "")),
        actuators=tuple(actuators),
        forces=tuple(forces),
    )
    for problem in mechanism.problems(initial_rates=qd0):  # the mechanism passed: what is left is its rates
        found.add(problem)
    if torque != 0.0 and mechanism.drive is None:
        found.add(SceneError("drive.joint", "a drive torque needs the joint it acts on"))
    if load_torque != 0.0 and mechanism.load is None:
        found.add(SceneError("load.joint", "a load torque needs the joint it acts on"))
    found.raise_all()
    return Scene(mechanism, mechanism.zd_from_qd(qd0), torque, load_torque, method, t_end, dt_out)


def parse_field(value, field: str) -> float:
    """A number of the scene read as its field's kind says (:func:`grubler.quantities.scene_field`, the one
    table): an angle (rad, or text with its unit), a length (m, or text in m, cm, mm), anything else a plain
    number in its SI unit, an angle's or a length's text refused there.

    Examples
    --------
    >>> parse_field("30 deg", "initial.theta2") == math.radians(30), parse_field("300 mm", "link2.a")
    (True, 0.3)
    >>> try:
    ...     parse_field("1 deg", "link2.m")
    ... except SceneError as exc:
    ...     print(exc)
    link2.m: '1 deg' is not a plain number: write the value in kg as a number (2.5)
    """
    unit = scene_field(field).unit
    if unit in (ANGLE_UNIT, "rad or m"):  # (a joint spring's free position: an angle, or a slide's number)
        return parse_angle_or_number(value, field)
    if unit == "m":
        return parse_length(value, field)
    return parse_number(value, field, unit)


def _collect(found: Problems, value, field: str, positive: bool = False) -> float:
    """A number of the scene (:func:`parse_field`; 0.0 when refused, the refusal recorded in ``found``)."""
    with found.check():
        v = parse_field(value, field)
        if positive and v <= 0:
            raise SceneError(field, f"must be positive, got {v}")
        return v
    return 0.0


def _link(d: dict, f: str, k: int, count: int, found: Problems) -> Link | None:
    """Link ``k`` from its table (None when refused: every problem of it recorded in ``found``)."""
    if not d:
        found.add(SceneError(f, f"missing: links must be numbered without gaps (link2 .. link{count + 1})"))
        return None
    before = len(found)
    num = {}
    for key in _LINK_PARAMS:
        if key in d:
            with found.check():
                num[key] = parse_field(d[key], f"{f}.{key}")
    # what is given is judged first, then what is missing
    for key, what in (("a", "the link length, m"), ("m", "the link's mass, kg")):
        if key not in d:
            found.add(SceneError(f"{f}.{key}", f"is required ({what})"))
    joint = parent = None
    with found.check():
        joint = _joint(d, f)
    with found.check():
        parent = _parent(d["parent"], f, k) if "parent" in d else None
    # the values read are judged even when another field of the link is refused (a
    # stand-in joint for a refused one: its problem is told already)
    link = Link(joint=joint or "R", **{"a": 0.0, **num}, parent=parent)
    for problem in link_problems(link, f, k):
        found.add(problem)
    return link if len(found) == before else None


def _link_number(value, field: str, n: int) -> int:
    """A link of an n-link chain (thesis numbering, 1 the ground) from "ground", "linkK" or the number K."""
    if isinstance(value, str):
        text = value.strip()
        match = re.fullmatch(r"link(\d+)", text)
        value = 1 if text == "ground" else int(match.group(1)) if match else value
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= n + 1:
        raise SceneError(field, f'link {brief(value)} does not exist: name the ground ("ground" or 1) or a moving '
                                f'link ("link2" .. "link{n + 1}")')
    return value


def _actuators(given, n: int) -> list[Actuator]:
    """The scene's [[actuator]] tables: a name and two points, each on a link or the ground."""
    if isinstance(given, dict):
        given = [given]
    if not (isinstance(given, list) and all(isinstance(d, dict) for d in given)):
        raise SceneError("actuator", "must be an array of tables [[actuator]]")
    out = []
    for j, d in enumerate(given):
        f = f"actuator[{j}]"
        _check_keys(d, _ACTUATOR_KEYS, f)
        for key in ("name", "from_link", "from_point", "to_link", "to_point"):
            if key not in d:
                raise SceneError(f"{f}.{key}", "is required (an actuator has a name and two points, each on a link "
                                               "or the ground)")
        out.append(Actuator(str(d["name"]) if isinstance(d["name"], str) else d["name"],
                            _link_number(d["from_link"], f"{f}.from_link", n), _pair(d["from_point"], f"{f}.from_point"),
                            _link_number(d["to_link"], f"{f}.to_link", n), _pair(d["to_point"], f"{f}.to_point")))
    return out


def _force_elements(given, table: str, cls, keys: dict, required: tuple, n: int) -> list:
    """The scene's [[spring]], [[joint_spring]] or [[point_load]] tables (docs/scenes.md): each a force element."""
    if isinstance(given, dict):
        given = [given]
    if not (isinstance(given, list) and all(isinstance(d, dict) for d in given)):
        raise SceneError(table, f"must be an array of tables [[{table}]]")
    out = []
    for j, d in enumerate(given):
        f = f"{table}[{j}]"
        _check_keys(d, set(keys), f)
        for key in required:
            if key not in d:
                raise SceneError(f"{f}.{key}", f"is required (a {table.replace('_', ' ')} needs "
                                               f"{', '.join(required)})")
        values = {"name": d.get("name", f"{table}{j + 1}")}
        if not isinstance(values["name"], str):
            raise SceneError(f"{f}.name", f"must be a name (a letter, then letters, digits or underscores), got "
                                          f"{brief(values['name'])}")
        if "joint" in d:
            if not (isinstance(d["joint"], str) and re.fullmatch(r"(theta|B)\d+", d["joint"].strip())):
                raise SceneError(f"{f}.joint", f"must name a real joint's coordinate (theta3, B2, ...), got "
                                               f"{brief(d['joint'])}")
            values["joint"] = d["joint"].strip()
        for key, how in keys.items():
            if key not in d or how is None:
                continue
            field = f"{f}.{key}"
            if how == "link":
                values[key] = _link_number(d[key], field, n)
            elif how == "pair":
                values[key] = _pair(d[key], field)
            elif how == "numbers":
                v = d[key]
                if not (isinstance(v, (list, tuple)) and len(v) == 2):
                    raise SceneError(field, f"must be [x, y], got {brief(v)}")
                values[key] = tuple(parse_number(x, field, "N") for x in v)  # a load's force, world x and y
            elif how == "length":
                values[key] = parse_length(d[key], field)
            elif key == "free" and isinstance(values.get("joint"), str) and values["joint"].startswith("B"):
                values[key] = parse_length(d[key], field)
            else:
                values[key] = parse_field(d[key], field)
        out.append(cls(**values))
    return out


def _closure_tables(built: dict, data: dict) -> list[tuple[dict, str]]:
    """The closure tables of a scene (the builder's, overridden field by field), with their field names."""
    base = built.get("closure", {})
    base = [dict(d) for d in base] if isinstance(base, list) else [dict(base)]
    given = data.get("closure", [])
    if isinstance(given, dict):
        given = [given]
    elif not (isinstance(given, list) and all(isinstance(d, dict) for d in given)):
        raise SceneError("closure", "must be a table [closure] or an array of tables [[closure]]")
    if len(base) > 1 and given and len(given) != len(base):
        raise SceneError("closure", f"the builder makes {len(base)} closures: override them as {len(base)} "
                                    "[[closure]] tables, in order (an empty one keeps its closure as built)")
    while len(base) < len(given):
        base.append({})
    for d, g in zip(base, given):
        d.update(g)
    single = len(base) == 1
    return [(d, "closure" if single else f"closure[{j}]") for j, d in enumerate(base)
            if d.get("type", "none") != "none" or not single]


def _closure(d: dict, f: str, lengths: list[float]) -> Closure:
    """One closure from its table (``lengths``: the links' a); ``f`` names it in errors."""
    n = len(lengths)
    _check_keys(d, _CLOSURE_KEYS, f)
    ctype = d.get("type", "none")
    if ctype not in ("revolute", "prismatic"):
        choices = "'none', 'revolute' or 'prismatic'" if f == "closure" else "'revolute' or 'prismatic'"
        raise SceneError(f"{f}.type", f"must be {choices}, got {brief(ctype)}")
    cl_link = d.get("link", n + 1)
    if not (isinstance(cl_link, int) and not isinstance(cl_link, bool) and 2 <= cl_link <= n + 1):
        raise SceneError(f"{f}.link", f"must be a moving link 2..{n + 1}, got {brief(cl_link)}")
    to_link = d.get("to_link", 1)
    if not (isinstance(to_link, int) and not isinstance(to_link, bool) and 1 <= to_link <= n + 1):
        raise SceneError(f"{f}.to_link", f"must be a link 1..{n + 1}, got {brief(to_link)}")
    if "point" not in d:
        raise SceneError(f"{f}.point", "is required: [x, y] of the pivot, or a point of the line")
    return Closure(
        kind=ctype,
        link=cl_link,
        point=_pair(d.get("at", [lengths[cl_link - 2], 0.0]), f"{f}.at"),
        to_link=to_link,
        to_point=_pair(d["point"], f"{f}.point"),
        angle=parse_field(d.get("angle", 0.0), f"{f}.angle"),
        psi=parse_field(d.get("psi", 0.0), f"{f}.psi"),
        gain=parse_field(d.get("gain", 1.0e4), f"{f}.gain"),
        damping=parse_field(d.get("damping", 100.0), f"{f}.damping"),
    )


def _pair(v, field: str) -> tuple[float, float]:
    if not (isinstance(v, (list, tuple)) and len(v) == 2):
        raise SceneError(field, f"must be [x, y], got {brief(v)}")
    return (parse_length(v[0], field), parse_length(v[1], field))


def preset_names() -> list[str]:
    """Names of the presets shipped with the package.

    Examples
    --------
    >>> import grubler
    >>> names = grubler.preset_names()
    >>> "thesis-fourbar" in names, "watt-ii" in names
    (True, True)
    """
    folder = resources.files("grubler") / "presets"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def preset_text(name: str) -> str:
    return (resources.files("grubler") / "presets" / f"{name}.toml").read_text()


def load_scene(source: str | Path) -> Scene:
    """A scene from a preset name, a TOML file path, or TOML text.

    Raises
    ------
    SceneError
        Naming the field at fault.

    Examples
    --------
    >>> import grubler
    >>> grubler.load_scene("thesis-slider-crank").mechanism.name     # a preset
    'thesis-slider-crank'
    >>> pendulum = grubler.load_scene('''
    ... [link2]
    ... joint = "R"
    ... a = 0.5
    ... m = 1.0
    ... [closure]
    ... type = "none"
    ... ''')                                                          # TOML text (or a file's path)
    >>> pendulum.mechanism.n_links, pendulum.mechanism.mobility
    (1, 1)
    """
    src = str(source)
    if src in preset_names():
        text, name = preset_text(src), src
    elif "\n" not in src and len(src) < 4096 and Path(src).is_file():
        # a file first: a file name may well contain '=' (run=3.toml)
        text, name = read_text(src, "scene"), Path(src).stem
    elif "\n" in src or "=" in src:
        text, name = src, ""
    elif src.endswith(".toml") or "/" in src or "\\" in src:
        # meant as a file: say so, rather than list presets
        raise SceneError("scene", f"no such file: {brief(src)}")
    else:
        raise SceneError("scene", f"{brief(src)} is neither a preset nor a TOML file{did_you_mean(src, preset_names())} "
                                  "(`grubler presets` lists the presets)")
    try:
        data = parse_toml(text, "scene")
    except InputError as exc:
        raise SceneError(exc.field, exc.reason) from None
    return scene_from_dict(data, name)


def with_overrides(scene: Scene, **changes) -> Scene:
    """A copy of a scene with some run settings changed.

    Examples
    --------
    >>> fourbar = load_scene("thesis-fourbar")
    >>> longer = with_overrides(fourbar, t_end=2.0, torque=1.5)     # run settings: a Scene's fields
    >>> longer.t_end, longer.torque, fourbar.t_end
    (2.0, 1.5, 10.0)
    """
    return replace(scene, **changes)


_LINK_PARAMS = ("a", "p", "q", "m", "I", "damping")
# a force element's numbers a sweep may set, as NAME.field (the native FMU's parameters of the same names)
ELEMENT_PARAMS = {"spring": ("stiffness", "free_length", "preload", "damping", "gas_force", "gas_column",
                             "gas_exponent"),
                  "joint_spring": ("stiffness", "free", "preload", "friction", "friction_speed"),
                  "point_load": ("force_x", "force_y", "moment")}


def _element_value(element, field_: str) -> float:
    """One of :data:`ELEMENT_PARAMS` of a force element (a load's force_x and force_y are its force's parts)."""
    if field_ in ("force_x", "force_y"):
        return element.force[field_ == "force_y"]
    return getattr(element, field_)


def parameter_names(scene: Scene) -> list[str]:
    """The dotted names :func:`override` and :func:`parameter` accept for a scene.

    Examples
    --------
    >>> names = parameter_names(load_scene("thesis-fourbar"))
    >>> [n for n in names if n.startswith("link2.")]
    ['link2.a', 'link2.p', 'link2.q', 'link2.m', 'link2.I', 'link2.damping']
    """
    m = scene.mechanism
    names = ["gravity"]
    for k in range(2, m.n_links + 2):
        names += [f"link{k}.{f}" for f in _LINK_PARAMS]
    if m.closures:
        names += ["closure.gain", "closure.damping"]
    for e in m.forces:
        names += [f"{e.name}.{f}" for f in ELEMENT_PARAMS[e.table]]
    names += ["drive_joint", "load_joint", "drive.inertia", "drive.torque", "load.torque"]
    for x in m.coordinate_names:
        names += [f"initial.{x}", f"initial.{x}_d"]
    return names


def parameter(scene: Scene, name: str):
    """A scene's value of one dotted parameter (see :func:`parameter_names`).

    Examples
    --------
    >>> fourbar = load_scene("thesis-fourbar")
    >>> parameter(fourbar, "link2.a"), parameter(fourbar, "gravity")
    (0.2, 9.81)
    >>> parameter(fourbar, "link9.a")                 # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    grubler.errors.SceneError: link9.a: no such parameter of this scene (it has: gravity, link2.a, ...)
    """
    m = scene.mechanism
    if name == "gravity":
        return m.gravity
    if name in ("drive_joint", "load_joint"):
        return getattr(m, name.split("_")[0])
    if name == "drive.inertia":
        return m.drive_inertia
    if name == "drive.torque":
        return scene.torque
    if name == "load.torque":
        return scene.load_torque
    head, _, field_ = name.partition(".")
    if head.startswith("link") and head[4:].isdigit() and field_ in _LINK_PARAMS:
        k = int(head[4:]) - 2
        if 0 <= k < m.n_links:
            return getattr(m.links[k], field_)
    if head == "closure" and field_ in ("gain", "damping") and m.closures:
        return getattr(m.closures[0], field_)
    for e in m.forces:
        if head == e.name and field_ in ELEMENT_PARAMS[e.table]:
            return _element_value(e, field_)
    if head == "initial":
        names = m.coordinate_names
        if field_ in names:
            return m.q_ref[names.index(field_)]
        if field_.endswith("_d") and field_[:-2] in names:
            return float((m.S @ scene.initial_rates)[names.index(field_[:-2])])
    raise SceneError(name, f"no such parameter of this scene (it has: {', '.join(parameter_names(scene))})")



def parameter_value(name: str, value):
    """One dotted parameter's value read as :func:`override` reads it, the scene apart: a length
    (:func:`~grubler.limits.parse_length`), an angle or number, or a joint's name.

    Every number goes through the same gate as the scene file's; a sweep checks each of its
    values with it before running any point.

    Examples
    --------
    >>> parameter_value("link2.a", "300 mm")
    0.3
    >>> parameter_value("initial.theta2", "90 deg") == math.pi / 2
    True
    """
    if name in ("drive_joint", "load_joint"):
        if value is not None and not isinstance(value, str):
            raise SceneError(name, f"must be a coordinate name (or empty for none), got {brief(value)}")
        return value
    return parse_field(value, name)


def override(scene: Scene, values: dict) -> Scene:
    """A copy of a scene with dotted parameters changed, re-validated.

    Parameters
    ----------
    scene : Scene
    values : dict
        ``{'link2.a': 0.25, 'initial.theta2_d': 3.0, 'drive_joint': 'theta2', ...}``;
        an empty string for ``drive_joint`` / ``load_joint`` means none.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Naming the parameter, for an unknown name or a value the model refuses.

    Examples
    --------
    >>> s = override(load_scene("thesis-fourbar"), {"link2.m": 1.5, "drive.torque": 2.0})
    >>> s.mechanism.links[0].m, s.torque
    (1.5, 2.0)
    """
    known = set(parameter_names(scene))
    for name in values:
        if name not in known:
            parameter(scene, name)  # raises with the list of known names
    m = scene.mechanism
    ov = {}
    for name, v in values.items():
        ov[name] = parameter_value(name, v)
    links = tuple(replace(link, **{f: ov[f"link{i + 2}.{f}"] for f in _LINK_PARAMS if f"link{i + 2}.{f}" in ov})
                  for i, link in enumerate(m.links))
    closures = m.closures
    if closures and ("closure.gain" in ov or "closure.damping" in ov):
        # one penalty tuning for every loop: a six-bar's two closures alike
        closures = tuple(replace(c, gain=ov.get("closure.gain", c.gain), damping=ov.get("closure.damping", c.damping))
                         for c in closures)
    forces = []
    for e in m.forces:
        changes = {f: ov[f"{e.name}.{f}"] for f in ELEMENT_PARAMS[e.table] if f"{e.name}.{f}" in ov}
        if "force_x" in changes or "force_y" in changes:
            changes["force"] = (changes.pop("force_x", e.force[0]), changes.pop("force_y", e.force[1]))
        forces.append(replace(e, **changes))
    names = m.coordinate_names
    q_ref = tuple(ov.get(f"initial.{x}", v) for x, v in zip(names, m.q_ref))
    qd = [ov.get(f"initial.{x}_d", v) for x, v in zip(names, m.S @ scene.initial_rates)]
    model = m.replace(links=links, closures=closures, forces=tuple(forces), q_ref=q_ref,
                      gravity=ov.get("gravity", m.gravity),
                      drive=ov.get("drive_joint", m.drive) or None, load=ov.get("load_joint", m.load) or None,
                      drive_inertia=ov.get("drive.inertia", m.drive_inertia))
    out = replace(scene, mechanism=model, initial_rates=model.zd_from_qd(qd),
                  torque=parse_field(ov.get("drive.torque", scene.torque), "drive.torque"),
                  load_torque=parse_field(ov.get("load.torque", scene.load_torque), "load.torque"))
    if out.torque != 0.0 and model.drive is None:
        raise SceneError("drive.torque", "a drive torque needs the joint it acts on")
    if out.load_torque != 0.0 and model.load is None:
        raise SceneError("load.torque", "a load torque needs the joint it acts on")
    return out



# the public names (the API reference's): the rest is the package's inside
__all__ = ["Scene", "load_scene", "scene_from_dict", "preset_names", "parameter_names", "parameter", "override",
           "with_overrides"]
