"""Films and stills of spatial mechanisms in perspective (``grubler animate`` on a spatial scene).

The camera, its fit and the depth-sorted parts of each frame come from
:mod:`grubler.views.perspective`; this module only paints them with Pillow, on a
fixed palette: the floor grid and the world axes once, then each frame's tubes
(as wide as a tube seen at its depth), joint axes, guides and joints, far to
near, each shade lighter the farther it is.
"""

from __future__ import annotations

import math

import numpy as np

from grubler.errors import SceneError
from grubler.views.perspective import SpatialSketch, draw_list, fit_camera, ground_grid, up_direction, AZIMUTH, \
    ELEVATION, TITLE_PX

__all__ = ["spatial_film", "film_camera", "FRAME_SIZE"]

FRAME_SIZE = (960, 720)
SHADES = 6  # depth shades per ink: the nearest full, the farthest mixed half with white
_BODY_INKS = ("#1f4e79", "#c05f00", "#2e7d32", "#7b1fa2", "#00838f", "#ad1457", "#6d4c41", "#455a64")
_INKS = {"ground": "#6b6b6b", "axis": "#202020", "revolute": "#d62728", "ball": "#d62728", "slide": "#2ca02c",
         "fixed": "#404040", "pin": "#404040", "guide": "#7f7f7f"}
_FIXED = {"white": "#ffffff", "grid": "#dcdcdc", "text": "#000000", "x": "#d62728", "y": "#2ca02c", "z": "#1f77b4"}
_TUBE_PX, _JOINT_PX = 9.0, 7.5  # at the fitted target's depth


def _rgb(colour: str) -> tuple[int, int, int]:
    return tuple(int(colour[i:i + 2], 16) for i in (1, 3, 5))


class _Palette:
    """Palette indices of every ink at every depth shade (a P-mode picture draws with them)."""

    def __init__(self, n_bodies: int):
        self.colours: list[tuple[int, int, int]] = []
        self.index: dict = {}
        for name, c in _FIXED.items():
            self._add(name, _rgb(c))
        inks = {**_INKS, **{f"body{k}": _BODY_INKS[k % len(_BODY_INKS)] for k in range(n_bodies)}}
        for name, c in inks.items():
            rgb = np.array(_rgb(c), dtype=float)
            for s in range(SHADES):
                mix = 0.5 * s / (SHADES - 1)
                self._add((name, s), tuple(int(round(v)) for v in (1 - mix) * rgb + mix * 255))

    def _add(self, key, rgb):
        self.index[key] = len(self.colours)
        self.colours.append(rgb)

    def flat(self) -> list[int]:
        pal = [v for c in self.colours for v in c]
        return pal + [255] * (768 - len(pal))


def film_camera(sketch: SpatialSketch, frames: np.ndarray, view=None, size=FRAME_SIZE):
    """The film's camera: ``view`` = (azimuth, elevation, distance or None) (:func:`~grubler.views.perspective.parse_camera`),
    the default side where None; the distance fitted to every point of every frame where not given."""
    az, el, distance = view if view is not None else (AZIMUTH, ELEVATION, None)
    up = up_direction(sketch.mechanism.gravity)
    return fit_camera(frames.reshape(-1, 3), az, el, up, size, distance=distance, top=TITLE_PX)


def _background(camera, frames, palette, size, title):
    from PIL import Image, ImageDraw, ImageFont

    im = Image.new("P", size, palette.index["white"])
    im.putpalette(palette.flat())
    draw = ImageDraw.Draw(im)
    up = camera.up
    for a, b in ground_grid(frames.reshape(-1, 3), up):
        _line(draw, camera, a, b, palette.index["grid"], 1)
    # the world axes at the origin, a fifth of the motion's size
    pts = frames.reshape(-1, 3)
    length = 0.2 * max(float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))), 1e-3)
    font = ImageFont.load_default(size=15)
    for k, name in enumerate("xyz"):
        tip = np.eye(3)[k] * length
        uv = _line(draw, camera, np.zeros(3), tip, palette.index[name], 2)
        if uv is not None:
            draw.text((uv[2] + 4, uv[3] - 8), name, fill=palette.index[name], font=font)
    if title:
        draw.text((12, 10), title, fill=palette.index["text"], font=ImageFont.load_default(size=18))
    return im


def _line(draw, camera, a, b, ink, width):
    uv, depth = camera.project(np.array([a, b]))
    if not (depth > 0).all():
        return None
    coords = tuple(np.clip(uv.ravel(), -1e5, 1e5))
    draw.line(coords, fill=ink, width=width)
    return coords


def _shade(depth, near, far):
    if far <= near:
        return 0
    return int(min(SHADES - 1, max(0, round((depth - near) / (far - near) * (SHADES - 1)))))


def spatial_film(sketch: SpatialSketch, t: np.ndarray, frames: np.ndarray, out: str, fps: float = 25.0,
                 camera=None, title: str = "", size=FRAME_SIZE) -> int:
    """Write the frames (F x P x 3 world points of ``sketch``) as a GIF, an MP4 (ffmpeg) or, for a .png, the
    first frame alone; returns the frame count written."""
    from PIL import ImageDraw, ImageFont

    camera = camera or film_camera(sketch, frames, size=size)
    palette = _Palette(len(sketch.mechanism.links))
    background = _background(camera, frames, palette, size, title)
    _, depths = camera.project(frames.reshape(-1, 3))
    seen = depths[depths > 0]
    near, far = (float(seen.min()), float(seen.max())) if seen.size else (1.0, 1.0)
    reference = float(np.linalg.norm(camera.target - camera.position))
    font = ImageFont.load_default(size=14)

    def frame(i):
        im = background.copy()
        draw = ImageDraw.Draw(im)
        for what, body, kind, xy, depth in draw_list(camera, sketch, frames[i]):
            s = _shade(depth, near, far)
            grow = reference / depth
            xy = tuple(np.clip(xy, -1e5, 1e5))
            if what == "segment":
                ink = palette.index[(f"body{body}" if kind == "link" else kind, s)]
                width = {"link": _TUBE_PX, "ground": 0.7 * _TUBE_PX, "axis": 2.5, "guide": 3.0}[kind]
                width = max(1, int(round(width * (grow if kind in ("link", "ground") else 1.0))))
                draw.line(xy, fill=ink, width=width)
                if kind in ("link", "ground") and width > 3:  # round ends: tubes meet without notches
                    r = (width - 1) / 2  # (Pillow's ellipse spans both its corners: a pixel wider)
                    for u, v in (xy[:2], xy[2:]):
                        draw.ellipse((u - r, v - r, u + r, v + r), fill=ink)
            else:
                r = _JOINT_PX * grow * (1.3 if kind == "ball" else 1.0)
                u, v = xy
                ink = palette.index[(kind, s)]
                if kind in ("slide", "pin", "fixed"):
                    r *= 1.6 if kind == "slide" else 1.0  # a block: a ball on it still shows it
                    draw.rectangle((u - r, v - r, u + r, v + r), fill=ink, outline=palette.index["text"])
                else:
                    draw.ellipse((u - r, v - r, u + r, v + r), fill=ink if kind == "ball" else palette.index["white"],
                                 outline=ink, width=max(2, int(round(r / 3))))
        draw.text((size[0] - 120, 12), f"t = {t[i]:7.3f} s", fill=palette.index["text"], font=font)
        return im

    if out.endswith(".png"):
        frame(0).save(out)
        return 1
    if out.endswith(".mp4"):
        from grubler.views.animation import _mp4

        _mp4((frame(i) for i in range(len(t))), out, fps, size)
        return len(t)
    if not out.endswith(".gif"):
        raise SceneError("--out", f"expected a .gif, .mp4 or .png file name, got {out!r}")
    first = frame(0)
    first.save(out, save_all=True, append_images=(frame(i) for i in range(1, len(t))),
               duration=round(1000.0 / fps), loop=0, optimize=False)
    return len(t)
