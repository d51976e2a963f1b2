"""The app's 3D view of a spatial preset or a spatial scene's TOML: what the page's ``view3d.js`` draws, as JSON.

The server runs the preset (its scene's drive and length) and sends the sketch
(:class:`grubler.views.perspective.SpatialSketch`: which points make which tubes,
axes, guides and joints), every point's world position at each frame, the floor
grid and the fitted default camera; the page only projects and paints, turning
and zooming the camera under the mouse (the same pinhole as ``grubler animate``).

Examples
--------
>>> view = spatial_view({"name": "rssr", "t_end": 0.2})
>>> len(view["t"]), len(view["frames"][0]) == len(view["links"])
(11, True)
>>> sorted(view["camera"])
['azimuth', 'centre', 'distance', 'elevation', 'fov', 'target', 'up', 'zoom']
"""

from __future__ import annotations

import math

import numpy as np

from grubler.errors import InputError, SceneError
from grubler.limits import MAX_TEXT_BYTES, brief, number
from grubler.mechanism.spatial_scene import is_spatial, load_spatial_scene, spatial_preset_names
from grubler.views.perspective import AZIMUTH, ELEVATION, FIELD_OF_VIEW, TITLE_PX, SpatialSketch, fit_camera, \
    ground_grid, up_direction

__all__ = ["spatial_catalog", "spatial_view", "spatial_text", "MAX_FRAMES"]

MAX_FRAMES = 2001  # frames a view sends: 20 s at 100 a second
FRAME_DT = 0.02  # s between the frames the page plays
CANVAS = (960, 680)  # px: the page's canvas, which the default camera is fitted to


def spatial_catalog() -> dict:
    """The spatial presets the 3D view offers, with their descriptions."""
    return {"presets": [{"name": n, "description": load_spatial_scene(n).description}
                        for n in spatial_preset_names()]}


def _rounded(a) -> list:
    return np.round(np.asarray(a, dtype=float), 7).tolist()


def spatial_text(text) -> tuple:
    """A spatial scene's TOML (a file opened, ``grubler app my_spatial.toml``) checked as the CLI reads it:
    ``(scene, text)``.  A planar scene's TOML is refused (``dimension``), a bad spatial one naming its field."""
    if not isinstance(text, str):
        raise InputError("toml", f"must be a spatial scene's TOML text, got {type(text).__name__}")
    if len(text) > MAX_TEXT_BYTES:
        raise InputError("toml", f"is {len(text)} characters: a scene's TOML has at most {MAX_TEXT_BYTES}")
    text = text if "\n" in text else text + "\n"  # TOML text, not a preset's name or a path
    if not is_spatial(text):
        raise SceneError("dimension", "this is no spatial scene (a spatial scene says dimension = 3): the "
                                      "planar app opens it")
    return load_spatial_scene(text), text


def spatial_view(body: dict) -> dict:
    """A spatial scene's run as the 3D view draws it: ``{"name": preset}`` or ``{"toml": a spatial scene's TOML}``,
    and ``"t_end"``: s (optional, the scene's)."""
    name = body.get("name")
    if "toml" in body:
        scene = spatial_text(body["toml"])[0]
        name = scene.name or "opened scene"
    elif name not in spatial_preset_names():
        raise InputError("name", f"{brief(name)} is not a spatial preset: one of {', '.join(spatial_preset_names())}")
    else:
        scene = load_spatial_scene(name)
    t_end = number(body.get("t_end", scene.t_end), "t_end", low=0.0, low_open=True, high=(MAX_FRAMES - 1) * FRAME_DT,
                   unit="s")
    dt = min(FRAME_DT, t_end)
    res = scene.mechanism.simulate(scene.start(), t_end, dt, tau=scene.tau())
    sketch = SpatialSketch(scene.mechanism, res.z)
    frames = sketch.positions(res.y)
    up = up_direction(scene.mechanism.gravity)
    cam = fit_camera(frames.reshape(-1, 3), AZIMUTH, ELEVATION, up, size=CANVAS, top=TITLE_PX)
    lens = CANVAS[1] / 2 / math.tan(FIELD_OF_VIEW / 2)
    return {
        "name": name,
        "description": scene.description,
        "bodies": [l.name for l in scene.mechanism.links],
        "links": [int(l) for l in sketch.links],
        "segments": [[int(i), int(j), int(b), k] for i, j, b, k in sketch.segments],
        "markers": [[int(i), int(b), k] for i, b, k in sketch.markers],
        "grid": [_rounded(np.concatenate([a, b])) for a, b in ground_grid(frames.reshape(-1, 3), up)],
        "t": _rounded(res.t),
        "frames": [_rounded(f) for f in frames],
        "camera": {"azimuth": AZIMUTH, "elevation": ELEVATION, "fov": FIELD_OF_VIEW,
                   "distance": float(np.linalg.norm(cam.position - cam.target)), "target": _rounded(cam.target),
                   "up": _rounded(up), "zoom": cam.focal / lens,
                   "centre": [cam.centre[0] / CANVAS[0], cam.centre[1] / CANVAS[1]]},
    }
