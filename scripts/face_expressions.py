"""The face's expressions, drawn and measured (dev tool; needs GL).

    python scripts/face_expressions.py [--out docs/face_expressions.png] [--size 320] [--view three-quarter]

Draws every expression of core.face.EXPRESSIONS at the default render size from the default view
and the front (the heads' pixels 1:1, and the front's again three times larger) and in the face
close-up (docs/face_expressions.png), and prints, as Markdown, for every pair of
expressions: the Euclidean distance between their 52 blendshape weights and the mean absolute
difference (RGB, 0-255) of the head as drawn, in both views; the smallest pair of each; the
difference one eye shut makes (the yardstick); and the brows' slant of each expression in the
close-up (renders/face_closeup.py has the measures).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main() -> None:
    from core.face import EXPRESSIONS, expression_weights
    from renders.animate import DEFAULT_SIZE
    from renders.face_closeup import (
        brow_tilt,
        face_image,
        pixel_distances,
        render_expression_sheet,
        rest_positions,
        weight_distances,
        wink_distance,
    )
    from renders.mannequin import DEFAULT_VIEW, Mannequin

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/face_expressions.png")
    ap.add_argument("--size", type=int, default=DEFAULT_SIZE[0], help="the picture's side (default: sgt render's)")
    ap.add_argument("--view", default=DEFAULT_VIEW, help="the body view (default: sgt render's)")
    args = ap.parse_args()
    views = (args.view, "face")
    m = Mannequin(args.size, args.size)
    try:
        weights = weight_distances()
        pixels = {v: pixel_distances(m, v) for v in views}
        winks = {v: wink_distance(m, v) for v in views}
        tilts = {n: brow_tilt(face_image(m, expression_weights(n), "face"), rest_positions(), "face") for n in EXPRESSIONS}
        rows = [(v, 1) for v in dict.fromkeys((args.view, "front"))] + [("front", 3), ("face", 1)]
        info = render_expression_sheet(args.out, size=(args.size, args.size), rows=rows, mannequin=m)
    finally:
        m.close()
    print(f"wrote {args.out}: {info['width']}x{info['height']}\n")
    print(f"| pair | weights | pixels, {args.view} | pixels, face |")
    print("|---|---|---|---|")
    for pair in sorted(weights, key=lambda p: pixels[args.view][p]):
        print(f"| {pair[0]} / {pair[1]} | {weights[pair]:.2f} | {pixels[args.view][pair]:.2f} | {pixels['face'][pair]:.2f} |")
    print(f"| one eye shut / resting | | {winks[args.view]:.2f} | {winks['face']:.2f} |")
    print()
    for name, table in (("weights", weights), *((f"pixels, {v}", pixels[v]) for v in views)):
        pair = min(table, key=table.get)
        print(f"smallest ({name}): {pair[0]} / {pair[1]} {table[pair]:.2f}")
    for v in views:
        pair = min(pixels[v], key=pixels[v].get)
        print(f"smallest over one eye shut ({v}): {pixels[v][pair] / winks[v]:.2f}")
    print("\nbrow slant in the close-up (degrees; + inner ends lower):",
          ", ".join(f"{n} {t:+.0f}" for n, t in tilts.items()))


if __name__ == "__main__":
    main()
