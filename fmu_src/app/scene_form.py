"""The scene as the page edits it: presets, the TOML it reads and writes, the form's fields and their edits.

A scene travels as the parsed TOML the CLI reads (a dict), so every edit goes
through :func:`grubler.scene_from_dict`, the same checks and the same messages
as ``grubler simulate my_scene.toml``; :func:`scene_toml` writes it back in that
format.  A refusal reaches the page as :func:`error_of` words it.

Examples
--------
>>> import tomllib
>>> data = preset_data("fourbar-crank-rocker")
>>> tomllib.loads(scene_toml(data)) == data
True
>>> fields(data)[0]["key"]
'mechanism.type'
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from functools import lru_cache


from grubler.app.elements import LINK_FIELDS, completed, element_menus, element_unit, link_word
from grubler.errors import GrublerError, InputError, SceneError
from grubler.limits import brief, parse_toml
from grubler.mechanism.analysis import classify
from grubler.mechanism.builders import BUILDER_DOCS
from grubler.mechanism.scene import preset_names, preset_text, scene_from_dict
from grubler.quantities import scene_field

MAX_KEY_PARTS = 4  # names in a scene field's dotted key: a scene's are TABLE.NAME, TABLE[N].NAME or NAME


def preset_data(name: str) -> dict:
    """A preset's scene as parsed TOML."""
    if name not in preset_names():
        raise SceneError("preset", f"no such preset: {brief(name)}")
    return tomllib.loads(preset_text(name))


def parse_scene_text(text: str) -> dict:
    """TOML text (a file the user opened, a shared link) as scene data, checked as a scene."""
    if not isinstance(text, str):
        raise SceneError("scene", f"must be TOML text, got {type(text).__name__}")
    data = parse_toml(text, "scene")
    scene_from_dict(data)  # the CLI's checks, now: a bad file is refused where it is opened
    return data


@lru_cache(maxsize=1)
def catalog() -> dict:
    """The presets (name, chain, inversion) and the mechanism types, each with its example preset."""
    presets, types = [], {}
    for name in preset_names():
        data = preset_data(name)
        c = classify(scene_from_dict(data, name).mechanism)
        presets.append({"name": name, "chain": c.chain, "kind": c.name,
                        "description": str(data.get("description", ""))})
        kind = data.get("mechanism", {}).get("type")
        if kind and kind not in types:
            types[kind] = {"type": kind, "example": name, "doc": BUILDER_DOCS.get(kind, "")}
    return {"presets": presets, "types": [types[k] for k in BUILDER_DOCS if k in types]}


def scene_toml(data: dict) -> str:
    """Scene data as TOML text the CLI reads (``tomllib.loads(scene_toml(d)) == d``)."""
    top = [(k, v) for k, v in data.items() if not isinstance(v, dict) and not _is_tables(v)]
    lines = [f"{_key(k)} = {_value(v)}" for k, v in top]
    for k, v in data.items():
        if isinstance(v, dict):
            lines += ["", f"[{_key(k)}]"] + [f"{_key(a)} = {_value(b)}" for a, b in v.items()]
        elif _is_tables(v):
            for table in v:
                lines += ["", f"[[{_key(k)}]]"] + [f"{_key(a)} = {_value(b)}" for a, b in table.items()]
    return "\n".join(lines).lstrip("\n") + "\n"


def _is_tables(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(t, dict) for t in v)


def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if v != v else ("inf" if v > 0 else "-inf"))
    if isinstance(v, str):
        return json.dumps(v)  # a JSON string is a TOML basic string (its escapes are TOML's)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(a)} = {_value(b)}" for a, b in v.items()) + "}"
    raise SceneError("scene", f"cannot write {type(v).__name__} values to TOML")


def echoed(data):
    """Scene data as the page is sent it back: a number that is not finite as TOML's word for it.

    A refused NaN (``gravity = nan``) is shown in its field with the reason
    next to it; JSON has no NaN, and the word, sent back, is refused the same way.
    """
    if isinstance(data, float) and not math.isfinite(data):
        return _value(data)
    if isinstance(data, dict):
        return {k: echoed(v) for k, v in data.items()}
    if isinstance(data, list):
        return [echoed(v) for v in data]
    return data


# -- the form: every number of the scene, named as the TOML names it, with its unit ------------------
_TEXT = {"name", "description", "kind", "type", "joint", "existence", "parent", "link", "to_link", "method"}


def choices(key: str) -> list[str] | None:
    """The words the scene reader takes for a field, when they are a short list (the form offers a menu)."""
    head, leaf = key.split(".")[0], key.rsplit(".", 1)[-1]
    if key == "mechanism.type":
        return list(BUILDER_DOCS)
    if head.startswith("closure") and leaf == "type":
        return ["revolute", "prismatic", "none"]
    if leaf == "method":
        return ["exact", "penalty"]
    if head.startswith("link") and leaf == "joint":
        return ["R", "P"]
    if leaf.endswith("_side"):
        return ["left", "right"]
    if leaf.startswith("branch"):
        return ["open", "crossed"]
    return None


def unit(key: str) -> str:
    """The unit a scene field is written in, for the form's label ('' for words and counts)."""
    return scene_field(key).unit


def fields(data: dict) -> list[dict]:
    """The form: one entry per editable value, its dotted key (the name errors use), value and unit."""
    out = []
    menus = element_menus(data)  # a force element's links and joint: menus of the scene's own

    def add(prefix, table):
        for k, v in table.items():
            key = f"{prefix}{k}"
            if k in ("name", "description", "kind") and not prefix:
                continue
            if isinstance(v, dict):
                add(key + ".", v)
            elif _is_tables(v):
                for j, t in enumerate(v):
                    # a force element's every field: those its table leaves out at the reader's value
                    add(f"{key}[{j}].", completed(k, t))
            else:
                u = element_unit(key, table)
                entry = {"key": key, "value": v, "unit": unit(key) if u is None else u,
                         "text": k in _TEXT or isinstance(v, bool)}
                if choices(key):
                    entry["choices"] = choices(key)
                if key in menus:
                    entry["choices"] = menus[key]
                    if k in {leaf for leafs in LINK_FIELDS.values() for leaf in leafs}:
                        entry["value"] = link_word(v)  # 3 shown as 'link3', its menu's word; the scene keeps 3
                out.append(entry)
    add("", data)
    return out


def edit(data: dict, key: str, text) -> dict:
    """Scene data with the value at dotted ``key`` set from the form's ``text`` (a number, a list or words)."""
    if not isinstance(key, str) or not re.fullmatch(r"[A-Za-z0-9_]+(\[\d+\])?(\.[A-Za-z0-9_]+(\[\d+\])?)*", key):
        raise InputError("field", f"not a scene field: {brief(key)}")
    if key.count(".") >= MAX_KEY_PARTS:
        raise InputError("field", f"not a scene field: {brief(key)} has {key.count('.') + 1} parts; a scene's "
                                  f"field has at most {MAX_KEY_PARTS} (TABLE.NAME, TABLE[N].NAME)")
    out = json.loads(json.dumps(data))
    *path, leaf = re.findall(r"([A-Za-z0-9_]+)(?:\[(\d+)\])?", key)
    table = out
    for name, index in path:
        table = table.setdefault(name, {})
        if index:
            if not (isinstance(table, list) and int(index) < len(table)):
                raise InputError(key, "no such table in this scene")
            table = table[int(index)]
        if not isinstance(table, dict):
            raise InputError(key, "no such table in this scene")
    table[leaf[0]] = _typed(text)
    return out


def _typed(text):
    """A form value as TOML would hold it: numbers as numbers, '[x, y]' as a list, else the text."""
    if not isinstance(text, str):
        return text
    s = text.strip()
    if s.startswith("[") and s.endswith("]"):
        return [_typed(p) for p in s[1:-1].split(",") if p.strip()]
    try:
        return int(s) if re.fullmatch(r"[+-]?\d+", s) else float(s)
    except ValueError:
        return s


def error_of(exc: BaseException) -> dict:
    """A refusal as the page shows it: the field it belongs next to, and one line."""
    if isinstance(exc, GrublerError):
        field = getattr(exc, "field", "") or ""
        reason = getattr(exc, "reason", None) or str(exc)
        return {"field": field, "reason": " ".join(str(reason).split())[:1000]}
    return {"field": "", "reason": f"internal error ({type(exc).__name__}); the server's log has the details"}


__all__ = ["preset_data", "parse_scene_text", "catalog", "scene_toml", "echoed", "choices", "unit", "fields", "edit", "error_of"]
