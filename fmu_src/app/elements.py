"""The scene's force elements as the page edits them: each one's fields in the form, adding one, removing one.

A spring (``[[spring]]``), a joint spring (``[[joint_spring]]``) or a load
(``[[point_load]]``) is data of the scene (docs/scenes.md): the form shows
every field of its kind, the ones the table leaves out at the value the scene
reader gives them, so that a damper or a gas law is typed in where the spring
is.  A new element starts where the sketch closes, doing nothing yet (a spring
at its free length, a torsion spring relaxed), at stiffnesses of the
mechanism's own scale; the scene reader then checks it as it checks a file.

Examples
--------
>>> from grubler.app.drawing import _sketch
>>> from grubler.app.scene_form import preset_data
>>> data = add_element(preset_data("fourbar-crank-rocker"), "spring", _sketch)
>>> data["spring"][0]["name"], data["spring"][0]["from_link"], data["spring"][0]["to_link"]
('spring1', 'ground', 'link2')
>>> "spring" in remove_element(data, "spring[0]")
False
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

from grubler.errors import InputError
from grubler.limits import brief
from grubler.mechanism.model import FORCE_ELEMENTS
from grubler.quantities import ANGLE_UNIT, force_field, force_fields

# each kind's class (its fields' defaults are the scene reader's), by its scene table
KINDS = {cls.table: cls for cls in FORCE_ELEMENTS}
G = 9.81  # m/s^2: a new element's scale is the mechanism's weight


def element_key(key: str) -> tuple[str, int, str] | None:
    """A form key of a force element's field, split: ``spring[0].gas_force`` -> ('spring', 0, 'gas_force')."""
    found = re.fullmatch(r"(spring|joint_spring|point_load)\[(\d+)\]\.([A-Za-z0-9_]+)", key)
    return (found[1], int(found[2]), found[3]) if found else None


def element_unit(key: str, table: dict | None = None) -> str | None:
    """The unit of a force element's field in the form, as the element's kind reads it (None: not one).

    A pair (``from_point``, ``force``) has its parts' unit; a joint spring's
    unit is the revolute's or the slide's as its ``joint`` says.
    """
    parts = element_key(key)
    if parts is None:
        return None
    kind, _, leaf = parts
    leaf = {"from_point": "from_point_x", "to_point": "to_point_x", "point": "point_x", "force": "force_x"}.get(leaf,
                                                                                                           leaf)
    if leaf not in force_fields(kind):
        return ""
    joint = (table or {}).get("joint")
    on_slide = joint.strip().startswith("B") if kind == "joint_spring" and isinstance(joint, str) else None
    if kind == "joint_spring" and leaf == "free" and on_slide is False:
        return ANGLE_UNIT  # an angle, typed in radians or as '30 deg' as every angle of the scene
    return force_field(kind, leaf, on_slide).unit


def completed(kind: str, table: dict) -> dict:
    """A ``kind`` element's table with every field, in its kind's order: those ``table`` leaves out at the value
    the scene reader gives them (a table of no such kind: as it is)."""
    cls = KINDS.get(kind)
    if cls is None:
        return table
    out = {}
    for f in dataclasses.fields(cls):
        if f.name in table:
            out[f.name] = table[f.name]
        elif f.name != "name" and f.default is not dataclasses.MISSING:
            out[f.name] = list(f.default) if isinstance(f.default, tuple) else f.default
    return {**out, **table}  # what the kind has no field for stays, for the reader to refuse by name


def _unused(data: dict, kind: str) -> str:
    taken = {t.get("name") for k in KINDS for t in data.get(k, []) if isinstance(t, dict)}
    taken |= {t.get("name") for t in data.get("actuator", []) if isinstance(t, dict)} if isinstance(
        data.get("actuator"), list) else set()
    return next(f"{kind}{j}" for j in range(1, 10_000) if f"{kind}{j}" not in taken)


def _sig(v: float, digits: int = 2) -> float:
    """``v`` to ``digits`` significant figures: a new element's round numbers."""
    return float(f"{v:.{digits}g}") if v else 0.0


def add_element(data: dict, kind, sketch) -> dict:
    """Scene data with a new force element of ``kind`` ('spring', 'joint_spring' or 'point_load').

    It starts doing nothing or little, every field written out: a spring from a
    ground point below link 2's middle to that middle at its free length, with a
    stiffness whose force reaches the links' weight over a fifth of its length;
    a torsion spring at the drive joint (the first real joint) relaxed where the
    sketch closes; a load of the links' weight, downwards, on the last moving
    link (an open chain's tip, a loop's last link's middle).

    ``sketch`` turns scene data into its model and the coordinates where its
    sketch closes (the drawing's ``_sketch``: passed in, as the drawing imports
    this module for the form).
    """
    from grubler.mechanism.kinematics import link_points

    if kind not in KINDS:
        raise InputError("element", f"must be one of {', '.join(KINDS)}, got {brief(kind)}")
    model, z = sketch(data)
    weight = G * sum(link.m for link in model.links) or G
    out = json.loads(json.dumps(data))
    tables = out.get(kind)
    if isinstance(tables, dict):
        tables = [tables]
    if not isinstance(tables, list):
        tables = []
    name = _unused(out, kind)
    if kind == "spring":
        a = model.links[0].a or 0.1
        along = round(a / 2, 4)
        mid = link_points(model, z[None, :], [0], [(along, 0.0)])[0, 0]
        length = abs(a) / 2
        ground = [round(float(mid[0]), 4) + 0.0, round(float(mid[1]) - length, 4) + 0.0]
        # free where it is drawn: its length between the points as written (a micrometre's rounding)
        free = round(math.dist(ground, mid), 6)
        table = {"name": name, "from_link": "ground", "from_point": ground, "to_link": "link2",
                 "to_point": [along, 0.0], "stiffness": _sig(weight / (0.2 * length)),
                 "free_length": free, "preload": 0.0, "damping": 0.0, "gas_force": 0.0,
                 "gas_column": round(length, 4), "gas_exponent": 1.4}
    elif kind == "joint_spring":
        joint = next((n for n in model.free_names if n.startswith("theta")), model.free_names[0])
        i = model.coordinate_names.index(joint)
        revolute = i % 2 == 1
        k = i // 2
        # the joint's coordinate where the sketch closes, relative to its predecessor (the kernel's position)
        at = float(z[model.free_index(joint)])
        reach = abs(model.links[k].a) or 0.1
        table = {"name": name, "joint": joint,
                 "stiffness": _sig(weight * reach if revolute else weight / (0.2 * reach)),
                 "free": f"{math.degrees(at):.4g} deg" if revolute else round(at, 4),
                 "preload": 0.0, "friction": 0.0, "friction_speed": 1e-3}
    else:  # an open chain's tip; in a loop the last link's middle (its end is a closure's pin, often the ground's)
        k = model.n_links - 1
        along = model.links[k].a if not model.closures else model.links[k].a / 2
        table = {"name": name, "link": k + 2, "point": [round(along, 4), 0.0],
                 "force": [0.0, -_sig(weight)], "moment": 0.0}
    tables.append(table)
    out[kind] = tables
    return out


# the fields of each kind that name a link, and whether the ground is one a designer would pick there (a load
# on the ground does nothing; the reader takes it, so a file that says so is shown as it is)
LINK_FIELDS = {"spring": {"from_link": True, "to_link": True}, "point_load": {"link": False}}


def link_word(value):
    """A link as the scene's menus name it: 1 or "ground" -> 'ground', 3 or "link3" -> 'link3' (else as given)."""
    if isinstance(value, int) and not isinstance(value, bool):
        return "ground" if value == 1 else f"link{value}"
    return value.strip() if isinstance(value, str) else value


def element_menus(data: dict) -> dict[str, list[str]]:
    """The form's menus of a scene's force elements: each field that names a link (its mechanism's links, the
    ground where a designer would pick it) or a joint (its real joints' coordinates), by the field's key.

    A value the scene holds that the menu has not (a link this mechanism lacks, as a file may say) is kept in
    its menu, so that the form shows what the scene says and the reader's refusal next to it.  A mechanism that
    does not build has no menus (its fields stay text, as typed).

    >>> from grubler.app.scene_form import preset_data
    >>> menus = element_menus(preset_data("gas-spring-boom"))
    >>> menus["spring[0].to_link"], menus["point_load[0].link"], menus["joint_spring[0].joint"]
    (['ground', 'link2', 'link3', 'link4'], ['link2', 'link3', 'link4'], ['theta2', 'theta3', 'theta4'])
    """
    from grubler.errors import GrublerError
    from grubler.mechanism.scene import scene_from_dict

    tables = {kind: data.get(kind) for kind in KINDS}
    tables = {kind: [t] if isinstance(t, dict) else t for kind, t in tables.items() if t}
    if not tables:
        return {}
    try:  # the mechanism alone: an element's own bad field must not take its menus away
        model = scene_from_dict({k: v for k, v in data.items() if k not in KINDS}).mechanism
    except GrublerError:
        return {}
    moving = [f"link{k}" for k in range(2, model.n_links + 2)]
    out = {}
    for kind, rows in tables.items():
        if not isinstance(rows, list):
            continue
        for j, table in enumerate(rows):
            if not isinstance(table, dict):
                continue
            wanted = {leaf: (["ground"] if ground else []) + moving
                      for leaf, ground in LINK_FIELDS.get(kind, {}).items()}
            if kind == "joint_spring":
                wanted["joint"] = list(model.free_names)
            for leaf, menu in wanted.items():
                held = link_word(table.get(leaf)) if leaf != "joint" else table.get(leaf)
                if isinstance(held, str) and held and held not in menu:
                    menu = menu + [held]
                out[f"{kind}[{j}].{leaf}"] = menu
    return out


def remove_element(data: dict, key) -> dict:
    """Scene data without the force element ``key`` names (``spring[1]``)."""
    found = re.fullmatch(r"(spring|joint_spring|point_load)\[(\d+)\]", key) if isinstance(key, str) else None
    tables = data.get(found[1]) if found else None
    if isinstance(tables, dict):
        tables = [tables]
    if not found or not isinstance(tables, list) or int(found[2]) >= len(tables):
        raise InputError("element", f"this scene has no force element {brief(key)} to remove")
    out = json.loads(json.dumps(data))
    rest = [t for j, t in enumerate(tables) if j != int(found[2])]
    if rest:
        out[found[1]] = rest
    else:
        out.pop(found[1])
    return out


__all__ = ["KINDS", "LINK_FIELDS", "element_key", "element_unit", "completed", "add_element", "element_menus",
           "link_word", "remove_element"]
