"""Draw contact sheets of the gesture library (dev tool; needs Pillow).

    python scripts/library_sheet.py [--out /tmp/sheets] [--per-page 6] [NAME ...]

One row per gesture: one cell per keyframe (the nearest frame), each with a front view
(the character faces you, so its RIGHT arm - drawn red - is on YOUR left) and a side view
(the character faces right). The stroke cell has a thick orange frame. Faint lines are the
wrist paths over the whole clip. The right arm is red, the left arm blue, the head green.
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

from core.fileio import atomic_write  # noqa: E402
from core.skeleton import BONES, FPS, JOINT_INDEX, positions_from_pose  # noqa: E402
from library import load_library  # noqa: E402

CELL_W, CELL_H = 150, 170  # one view
LABEL_W = 170
MAX_CELLS = 6
SCALE = 150  # pixels per metre
COLORS = {"right": (210, 40, 40), "left": (40, 80, 220), "head": (30, 150, 60), "body": (90, 90, 90)}


def _bone_color(child: str):
    if child.startswith("right_"):
        return COLORS["right"] if child != "right_shoulder" else COLORS["body"]
    if child.startswith("left_"):
        return COLORS["left"] if child != "left_shoulder" else COLORS["body"]
    if child in ("nose", "head_top"):
        return COLORS["head"]
    return COLORS["body"]


def _project(p: np.ndarray, view: str, ox: float, oy: float):
    """Front view: screen x = world x (character's left on the viewer's right)."""
    h = p[..., 0] if view == "front" else p[..., 2]
    if view == "side":
        h = h - 0.15  # centre the side view a little
    return ox + CELL_W / 2 + h * SCALE, oy + CELL_H - 12 - (p[..., 1] - 0.85) * SCALE


def _draw_view(draw, pos, path_r, path_l, view, ox, oy):
    # ground reference: spine height line and centre line
    cx, _ = _project(np.array([0.0, 1.0, 0.0]), view, ox, oy)
    draw.line([(cx, oy + 14), (cx, oy + CELL_H - 4)], fill=(225, 225, 225))
    for path, col in ((path_r, (240, 170, 170)), (path_l, (170, 185, 240))):
        xs, ys = _project(path, view, ox, oy)
        draw.line(list(zip(xs.tolist(), ys.tolist())), fill=col, width=1)
    for parent, child in BONES:
        a = pos[JOINT_INDEX[parent]]
        b = pos[JOINT_INDEX[child]]
        ax, ay = _project(a, view, ox, oy)
        bx, by = _project(b, view, ox, oy)
        draw.line([(ax, ay), (bx, by)], fill=_bone_color(child), width=3)
    for name in ("right_wrist", "left_wrist", "nose"):
        x, y = _project(pos[JOINT_INDEX[name]], view, ox, oy)
        col = _bone_color(name)
        draw.ellipse([x - 3, y - 3, x + 3, y + 3], fill=col)
    draw.text((ox + 4, oy + 2), view, fill=(120, 120, 120))


def draw_sheet(gestures, out: Path, speed: int = 1, flip: bool = False) -> None:
    from PIL import Image, ImageDraw

    rows = []
    for g in gestures:
        clip = g.clip(speed=speed, flip=flip)
        n = clip.poses.shape[0]
        frames = sorted({min(n - 1, int(round(k.time / g.duration * (n - 1)))) for k in g.keyframes})
        if len(frames) > MAX_CELLS:  # keep first, stroke and last; thin out the rest
            keep = {frames[0], frames[-1]} | ({clip.stroke_frame} if clip.stroke_frame is not None else set())
            rest = [f for f in frames if f not in keep]
            step = len(rest) / (MAX_CELLS - len(keep))
            keep |= {rest[int(i * step)] for i in range(MAX_CELLS - len(keep))}
            frames = sorted(keep)
        rows.append((g, clip, frames))
    max_cells = max(len(f) for _, _, f in rows)
    width = LABEL_W + max_cells * 2 * CELL_W
    height = len(rows) * (CELL_H + 24)
    img = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(img)
    for r, (g, clip, frames) in enumerate(rows):
        oy = r * (CELL_H + 24)
        pos_all = positions_from_pose(clip.poses)
        path_r = pos_all[:, JOINT_INDEX["right_wrist"]]
        path_l = pos_all[:, JOINT_INDEX["left_wrist"]]
        draw.text((6, oy + 6), g.name, fill=(0, 0, 0))
        draw.text((6, oy + 22), f"{g.duration:g}s  {n_frames(clip)} frames", fill=(80, 80, 80))
        draw.text((6, oy + 38), f"stroke frame {clip.stroke_frame}", fill=(80, 80, 80))
        draw.text((6, oy + 54), ", ".join(g.tags)[:26], fill=(80, 80, 80))
        labels = {}
        for k in g.keyframes:
            f = min(clip.poses.shape[0] - 1, int(round(k.time / g.duration * (clip.poses.shape[0] - 1))))
            labels[f] = k.label or ""
        for c, f in enumerate(frames):
            ox = LABEL_W + c * 2 * CELL_W
            pos = pos_all[f]
            _draw_view(draw, pos, path_r, path_l, "front", ox, oy)
            _draw_view(draw, pos, path_r, path_l, "side", ox + CELL_W, oy)
            is_stroke = clip.stroke_frame == f
            box = [ox + 1, oy + 1, ox + 2 * CELL_W - 2, oy + CELL_H + 20]
            draw.rectangle(box, outline=(255, 150, 0) if is_stroke else (210, 210, 210),
                           width=4 if is_stroke else 1)
            draw.text((ox + 8, oy + CELL_H + 4), f"f{f} t={f / FPS:.2f}s {labels.get(f, '')}",
                      fill=(0, 0, 0))
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    atomic_write(out, buf.getvalue())


def n_frames(clip) -> int:
    return int(clip.poses.shape[0])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*")
    ap.add_argument("--out", type=Path, default=Path("/tmp/sheets"))
    ap.add_argument("--per-page", type=int, default=4)
    ap.add_argument("--speed", type=int, default=1)
    ap.add_argument("--flip", action="store_true")
    args = ap.parse_args(argv)
    lib = load_library()
    for p in lib.problems:
        print(f"problem: {p}", file=sys.stderr)
    names = args.names or lib.names()
    gestures = [lib.get(n) for n in names if lib.get(n) is not None]
    for i in range(0, len(gestures), args.per_page):
        page = gestures[i : i + args.per_page]
        out = args.out / f"sheet_{i // args.per_page + 1:02d}.png"
        draw_sheet(page, out, speed=args.speed, flip=args.flip)
        print(out, ", ".join(g.name for g in page))
    return 0


if __name__ == "__main__":
    sys.exit(main())
