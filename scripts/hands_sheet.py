"""Draw the hand-shape vocabulary with sgt's mannequin: docs/hands.png (dev tool; needs GL).

    python scripts/hands_sheet.py [--out docs/hands.png] [--size 480]

One cell per shape of core.hands.SHAPES, cropped around the right hand: the forearm raised
with the palm to the listener, except the thumbs (forearm forward, palm in / out) and point
and pinch (forearm forward, palm down / in), the way the library's gestures use them.
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

from core.fileio import atomic_write  # noqa: E402
from core.hands import SHAPES, HandTrack, hand_positions  # noqa: E402
from core.skeleton import JOINT_INDEX, positions_from_pose  # noqa: E402
from library import load_library  # noqa: E402

#: Shape -> (library gesture whose stroke gives the arm, palm).
ARM = {"thumb_up": ("point_front", "in"), "thumb_down": ("point_front", "out"), "point": ("point_front", "down"),
       "pinch": ("point_front", "in")}
DEFAULT_ARM = ("wave", "forward")
CELL = 150


def _pixel(point: np.ndarray, size: int) -> tuple[float, float]:
    from renders.mannequin import YFOV, camera_pose

    cam = camera_pose()
    local = np.linalg.inv(cam) @ np.append(point, 1.0)
    f = size / 2 / np.tan(np.radians(YFOV) / 2)
    return size / 2 + f * local[0] / -local[2], size / 2 - f * local[1] / -local[2]


def main() -> None:
    from PIL import Image, ImageDraw

    from renders import overlay
    from renders.mannequin import Mannequin

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/hands.png")
    ap.add_argument("--size", type=int, default=480)
    args = ap.parse_args()
    lib = load_library(use_config=False)
    m = Mannequin(args.size, args.size)
    cols = 7
    rows = -(-len(SHAPES) // cols)
    sheet = Image.new("RGB", (cols * CELL, rows * (CELL + 22)), overlay.WHITE)
    d = ImageDraw.Draw(sheet)
    font = overlay.font(15, bold=True)
    try:
        for k, shape in enumerate(SHAPES):
            gesture, palm = ARM.get(shape, DEFAULT_ARM)
            clip = lib.get(gesture).clip()
            pos = positions_from_pose(clip.poses[clip.stroke_frame])[None]
            track = HandTrack.constant(1, ("relaxed", shape), ("in", palm))
            hands = hand_positions(pos, track)
            img = Image.fromarray(m.render(pos[0], hands[0]))
            cx, cy = _pixel(hands[0, 1].mean(axis=0) * 0.5 + pos[0, JOINT_INDEX["right_wrist"]] * 0.5, args.size)
            half = args.size * 0.13
            cell = img.crop((int(cx - half), int(cy - half), int(cx + half), int(cy + half))).resize((CELL, CELL))
            r, c = divmod(k, cols)
            sheet.paste(cell, (c * CELL, r * (CELL + 22)))
            d.text((c * CELL + CELL / 2, r * (CELL + 22) + CELL + 11), f"{shape} ({palm})", font=font,
                   fill=overlay.INK, anchor="mm")
    finally:
        m.close()
    buf = io.BytesIO()
    sheet.save(buf, format="PNG")
    atomic_write(args.out, buf.getvalue())
    print(f"wrote {args.out}: {sheet.width}x{sheet.height}")


if __name__ == "__main__":
    main()
