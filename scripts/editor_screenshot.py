"""Make docs/editor.png: `sgt edit` at 80x24 on the shipped example, as the editor guide shows it.

    python scripts/editor_screenshot.py [-o docs/editor.png] [--svg FILE]

The example (examples/mall_guide.sgt) with one gesture misspelt (point_upp), the cursor in
utterance 2 and the draft preview at 1.3 s: Textual's SVG screenshot of the headless app,
turned into a PNG with cairosvg (a documentation tool only: pip install cairosvg) in DejaVu
Sans Mono.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import re
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


async def screenshot(size: tuple[int, int]) -> str:
    from core.skeleton import FPS
    from sgt_tui.app.main import EditorApp
    from sgt_tui.editor.files import ScriptFile

    tmp = Path(tempfile.mkdtemp())
    os.environ["SGT_EDITOR_CACHE"] = str(tmp / "cache")
    os.chdir(tmp)  # the status line shows the name relative to here
    text = (ROOT / "examples" / "mall_guide.sgt").read_text().replace("[pose:point_up]", "[pose:point_upp]")
    Path("mall_guide.sgt").write_text(text)
    app = EditorApp(ScriptFile.open("mall_guide.sgt"), engine="rules", cursor_blink=False)
    async with app.run_test(size=size) as pilot:
        await pilot.pause()
        app.area.move_cursor((8, 20))
        await pilot.pause()
        app.preview.action_seek(round(1.3 * FPS))
        await pilot.pause(0.2)
        return app.export_screenshot(title="sgt edit")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--out", type=Path, default=ROOT / "docs" / "editor.png")
    ap.add_argument("--svg", type=Path, help="also keep the SVG")
    ap.add_argument("--size", default="80x24")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    svg = asyncio.run(screenshot((w, h)))
    # Textual names Fira Code; fontconfig would pick a proportional font for it here
    svg = svg.replace('"Fira Code"', '"DejaVu Sans Mono"').replace("Fira Code, monospace", "DejaVu Sans Mono, monospace")
    # DejaVu Sans Mono has no braille: the stick figure's runs are drawn in DejaVu Sans
    svg = re.sub(r"<text ([^>]*)>([^<]*[\u2800-\u28ff][^<]*)</text>",
                 lambda m: f'<text {m.group(1)} style="font-family: DejaVu Sans">{m.group(2)}</text>', svg)
    if args.svg:
        args.svg.write_text(svg, encoding="utf-8")
    import cairosvg

    cairosvg.svg2png(bytestring=svg.encode("utf-8"), write_to=str(args.out.resolve()))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
