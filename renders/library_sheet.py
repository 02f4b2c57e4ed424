"""A contact sheet of library gestures: each gesture's stroke, from the front and from the side.

Every gesture gets two mannequin views of its stroke frame (hands included): the front (the
character faces you, so its right hand is on your left) and its right side (it faces right),
with its name under them. ``docs/library.png`` is this sheet of the whole built-in library
(``sgt library sheet -o docs/library.png``).
"""

from __future__ import annotations

import io
import math

import numpy as np

from core.fileio import atomic_write
from core.hands import hand_positions
from core.skeleton import ROOT_POSITION, positions_from_pose
from renders import overlay
from renders.mannequin import AZIMUTH, Mannequin

#: Gestures per row of the sheet, and the size (pixels) of one view.
COLUMNS = 5
VIEW = (150, 150)
#: Turns of the character about the vertical axis (degrees) that show the fixed camera its
#: front and its right side.
FRONT = -AZIMUTH
SIDE = 90.0 - AZIMUTH


def _turned(points: np.ndarray, degrees: float) -> np.ndarray:
    """``points`` (..., 3) turned about the vertical axis through the root."""
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)
    p = np.asarray(points, np.float64) - ROOT_POSITION
    x, z = p[..., 0] * c + p[..., 2] * s, -p[..., 0] * s + p[..., 2] * c
    out = np.stack([x, p[..., 1], z], axis=-1)
    return out + ROOT_POSITION


def stroke_views(mannequin, clip) -> list[np.ndarray]:
    """The front and side images of ``clip``'s stroke frame (its last frame when it has none)."""
    f = clip.stroke_frame if clip.stroke_frame is not None else clip.n_frames - 1
    pos = positions_from_pose(clip.poses[f : f + 1])
    hands = hand_positions(pos, clip.hands.take(slice(f, f + 1)))[0]
    return [mannequin.render(_turned(pos[0], a), _turned(hands, a)) for a in (FRONT, SIDE)]


def render_library_sheet(gestures, path, *, columns: int = COLUMNS, view=VIEW, mannequin=None, progress=None) -> dict:
    """Write a PNG contact sheet of ``gestures`` (library :class:`~library.Gesture` objects) to
    ``path``; returns its size and the gesture names in order."""
    from PIL import Image, ImageDraw

    gestures = list(gestures)
    w, h = view
    s = overlay.scale(w, h)
    caption = max(16, round(22 * s))
    cols = max(1, min(columns, len(gestures)))
    rows = max(1, math.ceil(len(gestures) / cols))
    sheet = Image.new("RGB", (cols * 2 * w, rows * (h + caption)), overlay.WHITE)
    d = ImageDraw.Draw(sheet)
    name_font = overlay.font(max(9, round(14 * s)), bold=True)
    own = mannequin is None
    m = mannequin or Mannequin(w, h)
    try:
        for k, g in enumerate(gestures):
            if progress:
                progress(k, len(gestures), g.name)
            r, c = divmod(k, cols)
            x, y = c * 2 * w, r * (h + caption)
            for i, image in enumerate(stroke_views(m, g.clip())):
                sheet.paste(Image.fromarray(image), (x + i * w, y))
            d.text((x + w, y + h + caption / 2), g.name, font=name_font, fill=overlay.INK, anchor="mm")
            if c:
                d.line([(x, y), (x, y + h + caption - 1)], fill=overlay.TRACK, width=1)
        if progress:
            progress(len(gestures), len(gestures), "")
        buf = io.BytesIO()
        sheet.save(buf, format="PNG", optimize=True)
        atomic_write(path, buf.getvalue())
        return {"width": sheet.width, "height": sheet.height, "names": [g.name for g in gestures]}
    finally:
        if own:
            m.close()
