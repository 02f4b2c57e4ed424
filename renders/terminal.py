"""Stick figures for a terminal: joint positions projected from 3D, drawn with braille dots.

Each character cell holds 2 x 4 braille dots (U+2800..U+28FF), so a 30 x 15 cell panel is a
60 x 60 dot picture. The skeleton (:mod:`core.skeleton`, y up, metres, facing +z) is turned
about the vertical axis by ``yaw`` degrees so that depth shows (a hand reaching forward moves
sideways on screen), projected orthographically and scaled to a fixed box, so the figure
does not jump when a hand goes up. Bones are lines, the head a circle with a tick towards
the nose. Hands: given the hand joints (:func:`figure_points`), the palm and every finger are
lines drawn :data:`HAND_SCALE` times their size about the wrist, so a pointing index, a thumbs
up, an open hand or a fist show as different marks; without them, small blobs. Plain Python
and numpy: no terminal library.
"""

from __future__ import annotations

import math

import numpy as np

from core.hands import HAND_JOINTS, SIDES, HandTrack, hand_positions
from core.skeleton import BONES, JOINT_INDEX, N_JOINTS

BRAILLE_BASE = 0x2800
#: Bit of the dot at (row % 4, column % 2) inside a braille cell.
DOT_BITS = ((0x01, 0x08), (0x02, 0x10), (0x04, 0x20), (0x40, 0x80))
#: The box in metres (after turning) that fits the figure: x from -0.8 to 0.8,
#: y from 0.8 (below the pelvis) to 2.25 (a hand raised high); what leaves it is clipped.
BOX = (-0.8, 0.8, 0.8, 2.25)
DEFAULT_YAW = 25.0
HEAD_RADIUS = 0.11
#: Hands are drawn this many times their size (about the wrist): a finger is then 5 to 10 dots.
HAND_SCALE = 1.8

_HEAD_BONES = {("neck", "nose"), ("nose", "head_top")}
_LINES = [(JOINT_INDEX[a], JOINT_INDEX[b]) for a, b in BONES if (a, b) not in _HEAD_BONES]


class BrailleCanvas:
    """A cols x rows cell canvas of (2 * cols) x (4 * rows) dots; (0, 0) is the top left dot."""

    def __init__(self, cols: int, rows: int) -> None:
        self.cols, self.rows = max(1, cols), max(1, rows)
        self.width, self.height = 2 * self.cols, 4 * self.rows
        self.cells = bytearray(self.cols * self.rows)

    def dot(self, x: float, y: float) -> None:
        xi, yi = int(round(x)), int(round(y))
        if 0 <= xi < self.width and 0 <= yi < self.height:
            self.cells[(yi >> 2) * self.cols + (xi >> 1)] |= DOT_BITS[yi & 3][xi & 1]

    def line(self, x0: float, y0: float, x1: float, y1: float) -> None:
        n = int(max(abs(x1 - x0), abs(y1 - y0))) + 1
        for i in range(n + 1):
            t = i / n
            self.dot(x0 + (x1 - x0) * t, y0 + (y1 - y0) * t)

    def circle(self, cx: float, cy: float, r: float) -> None:
        n = max(8, int(2 * math.pi * r * 1.5))
        for i in range(n):
            a = 2 * math.pi * i / n
            self.dot(cx + r * math.cos(a), cy + r * math.sin(a))

    def blob(self, x: float, y: float) -> None:
        for dx in (-0.5, 0.5):
            for dy in (-0.5, 0.5):
                self.dot(x + dx, y + dy)

    def lines(self) -> list[str]:
        c = self.cols
        return ["".join(chr(BRAILLE_BASE + b) for b in self.cells[r * c : (r + 1) * c]) for r in range(self.rows)]


def figure_points(positions: np.ndarray, hands: HandTrack | None) -> np.ndarray:
    """What :func:`stick_figure` draws, per frame: the body's joints (T, 10, 3), then with
    ``hands`` the hand joints of the left and right hand (T, 10 + 40, 3)."""
    p = np.asarray(positions, dtype=np.float64)
    if hands is None:
        return p
    h = hand_positions(p, hands).reshape(len(p), 2 * len(HAND_JOINTS), 3)
    return np.concatenate([p, h], axis=1)


def project(positions: np.ndarray, yaw: float = DEFAULT_YAW) -> np.ndarray:
    """(..., J, 3) joint positions -> (..., J, 2) screen metres (x right, y up)."""
    p = np.asarray(positions, dtype=np.float64)
    a = math.radians(yaw)
    x = p[..., 0] * math.cos(a) + p[..., 2] * math.sin(a)
    return np.stack([x, p[..., 1]], axis=-1)


def stick_figure(positions: np.ndarray, cols: int, rows: int, yaw: float = DEFAULT_YAW) -> list[str]:
    """One frame's joint positions (10, 3), or with the hands' (50, 3) (:func:`figure_points`),
    drawn in ``cols`` x ``rows`` braille cells."""
    canvas = BrailleCanvas(cols, rows)
    x0, x1, y0, y1 = BOX
    scale = min(canvas.width / (x1 - x0), canvas.height / (y1 - y0))
    ox = canvas.width / 2 - scale * (x0 + x1) / 2
    oy = canvas.height / 2 + scale * (y0 + y1) / 2
    pts = project(positions, yaw)
    sx = ox + scale * pts[:, 0]
    sy = oy - scale * pts[:, 1]
    for a, b in _LINES:
        canvas.line(sx[a], sy[a], sx[b], sy[b])
    spine = JOINT_INDEX["spine"]  # a short pelvis under the spine
    canvas.line(sx[spine] - 0.12 * scale, sy[spine], sx[spine] + 0.12 * scale, sy[spine])
    nose, top = JOINT_INDEX["nose"], JOINT_INDEX["head_top"]
    hx, hy = (sx[nose] + sx[top]) / 2, (sy[nose] + sy[top]) / 2
    canvas.circle(hx, hy, max(1.5, HEAD_RADIUS * scale))
    canvas.line(hx, hy, sx[nose] + (sx[nose] - hx) * 0.3, sy[nose] + (sy[nose] - hy) * 0.3)
    if len(pts) == N_JOINTS:
        for w in ("left_wrist", "right_wrist"):
            canvas.blob(sx[JOINT_INDEX[w]], sy[JOINT_INDEX[w]])
        return canvas.lines()
    n = len(HAND_JOINTS)
    for s, side in enumerate(SIDES):
        w = JOINT_INDEX[f"{side}_wrist"]
        hx = sx[w] + HAND_SCALE * (sx[N_JOINTS + s * n : N_JOINTS + (s + 1) * n] - sx[w])
        hy = sy[w] + HAND_SCALE * (sy[N_JOINTS + s * n : N_JOINTS + (s + 1) * n] - sy[w])
        for root in ("index_mcp", "little_mcp", "thumb_cmc"):  # the palm
            k = HAND_JOINTS.index(root)
            canvas.line(sx[w], sy[w], hx[k], hy[k])
        for d in range(5):  # each digit's three segments
            for k in range(4 * d, 4 * d + 3):
                canvas.line(hx[k], hy[k], hx[k + 1], hy[k + 1])
    return canvas.lines()
