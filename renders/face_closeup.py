"""The face seen close: the head's box in a picture, the close-up inset of the previews, and the
expressions side by side with how far apart they are.

**The inset.** At the default size (320 px) the whole figure leaves the head about 50 pixels
tall; :class:`FaceInset` draws the same frame from the ``face`` view (:data:`renders.mannequin.VIEWS`,
a camera that follows the head), cropped to the head, into a corner of each picture of a GIF, an
MP4 or a sheet (:mod:`renders.animate`). ``auto`` (the default) draws it where the head is drawn
under :data:`INSET_BELOW` pixels tall, ``on`` always, ``off`` never; never on the ``face`` view
itself.

**The expressions.** Every expression of :data:`core.face.EXPRESSIONS` is drawn on the mannequin
at rest, eyes ahead, and every pair is measured two ways:

- **weights**: the Euclidean distance between their 52 ARKit blendshape weights (the vectors of
  :func:`core.face.expression_weights`, each weight 0 to 1);
- **pixels**: the mean absolute difference of the head as ``sgt render`` draws it (RGB, 0 to 255,
  over the three channels and every pixel of :func:`head_box`) at a given size and view, and
  the same for one eye shut (:func:`wink_distance`), the yardstick of a change that shows.

:func:`brow_tilt` measures, on the pixels, which way the brows slant. :func:`render_expression_sheet`
draws them all, a row per view (``docs/face_expressions.png``: ``python scripts/face_expressions.py``,
which also prints the tables).
"""

from __future__ import annotations

import io
from itertools import combinations

import numpy as np

from core.face import EXPRESSIONS, FaceTrack, blendshapes, expression_weights
from core.fileio import atomic_write
from core.skeleton import REST_POSE, positions_from_pose
from renders import face_rig, overlay
from renders.mannequin import VIEWS, FaceFrames, Mannequin, project

#: Points of the head's outline in its own frame: its ellipsoid, and below it the lowest point of
#: the chin of an open jaw (0.125 m below the head's centre).
_OUTLINE = np.concatenate([face_rig.uv_sphere(12, 24)[0] * face_rig.HEAD_RADII, [[0.0, -0.125, 0.04]]])

#: The inset's modes (``sgt render --face-inset``).
INSET_MODES = ("auto", "on", "off")
#: ``auto`` draws the inset where the head is drawn shorter than this (pixels): at 320 px the
#: head is about 50 pixels tall, from about 600 px up it reads by itself.
INSET_BELOW = 96
#: The inset's side as a share of the picture's shorter side.
INSET_SHARE = 0.34


def rest_positions() -> np.ndarray:
    """The joints (10, 3) of the rest pose, where the expressions are drawn."""
    return positions_from_pose(REST_POSE[None])[0]


def head_box(positions, width: int, height: int, view: str) -> tuple[int, int, int, int]:
    """The pixel box (x0, y0, x1, y1) round the head and chin of a figure at joint ``positions``
    (10, 3) in a ``width`` x ``height`` picture from ``view``: the projected head (its ellipsoid)
    and the chin's lowest point, one pixel more each way, inside the picture."""
    rot, centre = (a[0] for a in face_rig.head_frames(np.asarray(positions, np.float64)[None]))
    pixels = project(centre + _OUTLINE @ rot.T, width, height, view, head=centre)
    x0, y0 = np.floor(pixels.min(axis=0)).astype(int) - 1
    x1, y1 = np.ceil(pixels.max(axis=0)).astype(int) + 1
    return max(0, int(x0)), max(0, int(y0)), min(width, int(x1)), min(height, int(y1))


# -- the inset -------------------------------------------------------------------------------------

def inset_side(mode: str, view: str, width: int, height: int) -> int:
    """The inset's side in pixels for a ``width`` x ``height`` picture from ``view`` (0: none)."""
    if mode not in INSET_MODES:
        raise ValueError(f"unknown face inset '{mode}': use {', '.join(INSET_MODES)}")
    if mode == "off" or VIEWS[view].on_head:
        return 0
    if mode == "auto":
        _, y0, _, y1 = head_box(rest_positions(), width, height, view)
        if y1 - y0 >= INSET_BELOW:
            return 0
    return max(16, round(INSET_SHARE * min(width, height)))


class FaceInset:
    """Close-ups of the head, ``side`` pixels square, for the top right corner of ``width`` x
    ``height`` pictures: the same frame drawn by the picture's own mannequin from the ``face``
    view, cropped to the head (the camera follows the head, so the crop is the head's box at
    rest in that view, made square) and scaled down (smooth: the crop is about twice the side)."""

    def __init__(self, side: int, width: int, height: int) -> None:
        self.side = int(side)
        x0, y0, x1, y1 = head_box(rest_positions(), width, height, "face")
        half = 0.5 * max(x1 - x0, y1 - y0)
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        self.crop = tuple(round(v) for v in (cx - half, cy - half, cx + half, cy + half))
        s = overlay.scale(width, height)
        self.margin = max(2, round(6 * s))
        self.top = max(2, round(46 * s))  # under the spoken word's box (renders.overlay.draw_word)
        self.border = max(1, round(2 * s))

    def image(self, mannequin: Mannequin, positions, hands, face, tint):
        """The close-up (a PIL image, ``side`` square) of one frame, drawn by ``mannequin``."""
        from PIL import Image

        x0, y0, x1, y1 = self.crop
        inside = (max(0, x0), max(0, y0), min(mannequin.width, x1), min(mannequin.height, y1))
        # Only the crop is drawn (the rest of the picture would be thrown away); what lies outside
        # the picture is black, as an image's crop has it.
        pixels = mannequin.render(positions, hands, view="face", tint=tint, face=face, region=inside)
        img = Image.fromarray(pixels)
        if inside != self.crop:
            canvas = Image.new("RGB", (x1 - x0, y1 - y0))
            canvas.paste(img, (inside[0] - x0, inside[1] - y0))
            img = canvas
        return img.resize((self.side, self.side), Image.LANCZOS)

    def draw(self, picture, mannequin: Mannequin, positions, hands, face, tint, color) -> None:
        """The close-up in the top right corner of PIL ``picture`` (in place), framed in ``color``."""
        from PIL import ImageDraw

        x = picture.width - self.side - self.margin
        y = self.top
        b = self.border
        ImageDraw.Draw(picture).rectangle([x - b, y - b, x + self.side + b - 1, y + self.side + b - 1], fill=tuple(color))
        picture.paste(self.image(mannequin, positions, hands, face, tint), (x, y))


# -- the expressions -------------------------------------------------------------------------------

def face_image(mannequin: Mannequin, weights, view: str, positions=None) -> np.ndarray:
    """The picture (H, W, 3) of blendshape ``weights`` (52,) on the mannequin at rest (or at
    ``positions``), eyes ahead."""
    face = FaceTrack(np.asarray(weights, np.float32)[None], np.zeros((1, 2, 2), np.float32))
    p = rest_positions() if positions is None else positions
    return mannequin.render(p, view=view, face=FaceFrames(face)[0])


def head_crops(mannequin: Mannequin, view: str, names=None) -> dict[str, np.ndarray]:
    """Each expression's head (:func:`head_box`) as drawn from ``view`` at the mannequin's size."""
    names = list(EXPRESSIONS) if names is None else list(names)
    x0, y0, x1, y1 = head_box(rest_positions(), mannequin.width, mannequin.height, view)
    return {n: face_image(mannequin, expression_weights(n), view)[y0:y1, x0:x1] for n in names}


def pixel_distance(a: np.ndarray, b: np.ndarray) -> float:
    """The mean absolute difference of two pictures (RGB, 0 to 255)."""
    return float(np.mean(np.abs(np.asarray(a, np.float64) - np.asarray(b, np.float64))))


def weight_distances(names=None) -> dict[tuple[str, str], float]:
    """Every pair of expressions: the Euclidean distance between their (52,) weights."""
    names = list(EXPRESSIONS) if names is None else list(names)
    return {(a, b): float(np.linalg.norm(expression_weights(a) - expression_weights(b))) for a, b in combinations(names, 2)}


def pixel_distances(mannequin: Mannequin, view: str, names=None) -> dict[tuple[str, str], float]:
    """Every pair of expressions: :func:`pixel_distance` of their heads drawn from ``view``."""
    crops = head_crops(mannequin, view, names)
    return {(a, b): pixel_distance(crops[a], crops[b]) for a, b in combinations(crops, 2)}


def wink_distance(mannequin: Mannequin, view: str) -> float:
    """:func:`pixel_distance` between the resting head and the head with one eye shut (the
    mean of the left and the right eye's) drawn from ``view``: closing an eye is a change the
    preview shows at 320 px (the face's tests check blinks there)."""
    x0, y0, x1, y1 = head_box(rest_positions(), mannequin.width, mannequin.height, view)
    rest = face_image(mannequin, blendshapes({}), view)[y0:y1, x0:x1]
    return float(np.mean([pixel_distance(rest, face_image(mannequin, blendshapes({eye: 1.0}), view)[y0:y1, x0:x1])
                          for eye in ("eyeBlinkLeft", "eyeBlinkRight")]))


def _brow_pixels(image: np.ndarray) -> np.ndarray:
    """The brows' pixels of a picture: dark and brown (red well above blue), unlike the skin,
    the lids, the lips, the pupils and the clothes."""
    r, g, b = (image[..., k].astype(int) for k in range(3))
    return (r + g + b < 360) & (r > b + 12)


def brow_tilt(image: np.ndarray, positions, view: str) -> float:
    """How the brows slant in a picture from ``view`` of a figure at ``positions``, in degrees,
    measured on the brows' pixels above the head's centre: per brow, the line from the mean of
    its outer third to the mean of its inner third; positive when the inner ends are lower (a
    frown's V), negative when higher (worry, sadness); the mean of the two brows."""
    h, w = image.shape[:2]
    centre = face_rig.head_frames(np.asarray(positions, np.float64)[None])[1][0]
    cx, cy = project(centre, w, h, view, head=centre)
    mask = _brow_pixels(image)
    mask[int(cy):] = False
    ys, xs = np.nonzero(mask)
    tilts = []
    for side in (xs < cx, xs >= cx):
        x, y = xs[side].astype(float), ys[side].astype(float)
        if len(x) < 6:
            raise ValueError("no brows in the picture")
        lo, hi = x.min(), x.max()
        third = (hi - lo) / 3
        left, right = x <= lo + third, x >= hi - third
        inner, outer = (right, left) if x.mean() < cx else (left, right)
        drop = y[inner].mean() - y[outer].mean()  # pixels, y down: > 0 when the inner end is lower
        tilts.append(np.degrees(np.arctan2(drop, abs(x[inner].mean() - x[outer].mean()))))
    return float(np.mean(tilts))


def render_expression_sheet(path, *, size=(320, 320), rows=(("three-quarter", 1), ("face", 1)), names=None,
                            mannequin: Mannequin | None = None) -> dict:
    """A PNG of every expression (columns) in rows of (view, magnification): each picture is the
    head (:func:`head_box`) of a ``size`` render from that view, its pixels shown 1:1 (what such a
    render shows) or each as a ``magnification`` square (the same pixels, enlarged), named under it."""
    from PIL import Image, ImageDraw

    names = list(EXPRESSIONS) if names is None else list(names)
    width, height = size
    own = mannequin is None
    m = mannequin or Mannequin(width, height)
    try:
        crops = {view: head_crops(m, view, names) for view in dict.fromkeys(v for v, _ in rows)}
    finally:
        if own:
            m.close()
    pictures = [(f"{view} ({'1:1' if k == 1 else f'x{k}'})", [np.kron(c, np.ones((k, k, 1), np.uint8)) for c in crops[view].values()])
                for view, k in rows]
    pad = 8
    label = overlay.font(14)
    name_font = overlay.font(14, bold=True)
    measure = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    cell = max(max(max(p.shape[1] for p in pics) for _, pics in pictures),
               max(round(measure.textlength(n, font=name_font)) for n in names)) + 2 * pad
    header = max(round(measure.textlength(t, font=label)) for t, _ in pictures) + 2 * pad
    heights = [max(p.shape[0] for p in pics) + pad for _, pics in pictures]
    sheet = Image.new("RGB", (header + cell * len(names), sum(heights) + 24 + 2 * pad), overlay.WHITE)
    d = ImageDraw.Draw(sheet)
    y = pad
    for (title, pics), h in zip(pictures, heights):
        d.text((pad, y + h / 2), title, font=label, fill=overlay.SOFT_INK, anchor="lm")
        for k, pic in enumerate(pics):
            sheet.paste(Image.fromarray(pic), (header + k * cell + (cell - pic.shape[1]) // 2, y + (h - pic.shape[0]) // 2))
        y += h
    for k, n in enumerate(names):
        d.text((header + (k + 0.5) * cell, y + 12), n, font=name_font, fill=overlay.INK, anchor="mm")
    buf = io.BytesIO()
    sheet.save(buf, format="PNG", optimize=True)
    atomic_write(path, buf.getvalue())
    return {"width": sheet.width, "height": sheet.height, "names": names, "rows": tuple(rows)}
