"""A contact sheet of library gestures: each gesture's stroke from a few camera views.

Every gesture gets one mannequin picture of its stroke frame (hands included) per view,
by default the front (the character faces you, so its right hand is on your left) and its
right side (it faces the right of the picture: what points at the listener points right),
side by side with its name under them; the views' names head the sheet.
``docs/library.png`` is this sheet of the whole built-in library at 150 pixels a view
(``sgt library sheet -o docs/library.png``).
"""

from __future__ import annotations

import io
import math

from core.fileio import atomic_write
from core.hands import hand_positions
from core.skeleton import positions_from_pose
from renders import overlay
from renders.mannequin import Mannequin

#: Gestures per row of the sheet, the size (pixels) of one view, and the views drawn.
COLUMNS = 5
VIEW = (150, 150)
VIEWS = ("front", "side")


def stroke_views(mannequin, clip, views=VIEWS) -> list:
    """The images (H, W, 3) of ``clip``'s stroke frame (its last frame when it has none), one per view."""
    f = clip.stroke_frame if clip.stroke_frame is not None else clip.n_frames - 1
    pos = positions_from_pose(clip.poses[f : f + 1])
    hands = hand_positions(pos, clip.hands.take(slice(f, f + 1)))[0]
    return [mannequin.render(pos[0], hands, view=v) for v in views]


def render_library_sheet(gestures, path, *, columns: int = COLUMNS, view=VIEW, views=VIEWS, mannequin=None,
                         progress=None) -> dict:
    """Write a PNG contact sheet of ``gestures`` (library :class:`~library.Gesture` objects) to
    ``path``: ``columns`` gestures a row, each as one ``view`` (width, height) picture per
    camera view in ``views`` (:data:`renders.mannequin.VIEWS`); returns its size, the gesture
    names in order and the views."""
    from PIL import Image, ImageDraw

    gestures = list(gestures)
    views = tuple(views)
    w, h = view
    k = len(views)
    s = overlay.scale(w, h)
    caption = max(16, round(22 * s))
    header = max(14, round(18 * s))
    cols = max(1, min(columns, len(gestures)))
    rows = max(1, math.ceil(len(gestures) / cols))
    sheet = Image.new("RGB", (cols * k * w, header + rows * (h + caption)), overlay.WHITE)
    d = ImageDraw.Draw(sheet)
    name_font = overlay.font(max(9, round(14 * s)), bold=True)
    view_font = overlay.font(max(8, round(11 * s)))
    for c in range(cols):
        for i, v in enumerate(views):
            d.text(((c * k + i + 0.5) * w, header / 2), v, font=view_font, fill=overlay.SOFT_INK, anchor="mm")
    own = mannequin is None
    m = mannequin or Mannequin(w, h)
    try:
        for n, g in enumerate(gestures):
            if progress:
                progress(n, len(gestures), g.name)
            r, c = divmod(n, cols)
            x, y = c * k * w, header + r * (h + caption)
            for i, image in enumerate(stroke_views(m, g.clip(), views)):
                sheet.paste(Image.fromarray(image), (x + i * w, y))
            d.text((x + k * w / 2, y + h + caption / 2), g.name, font=name_font, fill=overlay.INK, anchor="mm")
            if c:
                d.line([(x, y), (x, y + h + caption - 1)], fill=overlay.TRACK, width=1)
        if progress:
            progress(len(gestures), len(gestures), "")
        buf = io.BytesIO()
        sheet.save(buf, format="PNG", optimize=True)
        atomic_write(path, buf.getvalue())
        return {"width": sheet.width, "height": sheet.height, "names": [g.name for g in gestures], "views": views}
    finally:
        if own:
            m.close()
