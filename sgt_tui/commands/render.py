"""sgt render: motion file or script -> preview GIF, contact sheet, side-by-side comparison."""

from __future__ import annotations

import argparse
import sys

HELP = "render motion (or a script) to a preview GIF and contact sheet"
DESCRIPTION = """\
Render a motion file (.json/.npz written by sgt) or a script (.sgt, generated first)
offscreen to a looping 15 fps GIF of a shaded mannequin. Every frame shows the word
being spoken, a timeline of the controls (pose in green, style in red), a playhead
and the time.

--sheet also writes a PNG contact sheet: frames sampled along the utterance with the
words under them. --compare renders a second take beside the first, labelled.
Without --utterance all utterances are rendered one after another.

Offscreen GL: EGL, falling back to OSMesa (set SGT_GL=egl|osmesa to choose)."""


def register(sub) -> None:
    from sgt_tui.commands.common import utterance_number

    p = sub.add_parser("render", help=HELP, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="INPUT", help="motion file (.json/.npz) or script (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT.gif", required=True,
                   help="write the GIF here ('-': standard output, not a terminal)")
    p.add_argument("--sheet", metavar="PNG", help="also write a contact sheet PNG")
    p.add_argument("--compare", metavar="MOTION", help="render this second take side by side")
    p.add_argument("--size", metavar="WxH", default="320x320", help="frame size in pixels (default 320x320)")
    p.add_argument("--utterance", type=utterance_number, metavar="N", help="only utterance N (0-based)")
    add_script_options(p)
    p.set_defaults(run=run)


def add_script_options(p) -> None:
    from sgt_tui.commands.common import ENGINE_CHOICES, add_seed_option

    p.add_argument("--engine", choices=ENGINE_CHOICES, help="generation engine for script input (default: the generator's default)")
    add_seed_option(p, "random seed for script input")


def parse_size(text: str) -> tuple[int, int]:
    from sgt_tui.errors import UsageError

    parts = text.lower().replace("×", "x").split("x")
    try:
        w, h = (int(parts[0]), int(parts[1])) if len(parts) == 2 else (None, None)
    except ValueError:
        w = h = None
    if w is None or h is None:
        raise UsageError(f"--size must look like 320x320, not '{text}'")
    if not (16 <= w <= 4096 and 16 <= h <= 4096):
        raise UsageError(f"--size {text}: width and height must be between 16 and 4096")
    return w, h


def _check_suffix(path: str, allowed: tuple[str, ...], option: str) -> None:
    from pathlib import Path

    from sgt_tui.commands.common import STDOUT
    from sgt_tui.errors import UsageError

    if path != STDOUT and Path(path).suffix.lower() not in allowed:
        raise UsageError(f"{option} {path}: expected a {' or '.join(allowed)} file")


def run(args) -> int:
    from pathlib import Path

    from renders.clips import concat_clips
    from sgt_tui.commands.clips import load_clips
    from sgt_tui.commands.common import one_stdout, output_file, shown

    _check_suffix(args.output, (".gif",), "-o")
    if args.sheet:
        _check_suffix(args.sheet, (".png",), "--sheet")
    size = parse_size(args.size)
    one_stdout(**{"-o": args.output, "--sheet": args.sheet})
    gif_out = output_file(args.output, binary=True)
    sheet_out = output_file(args.sheet, "--sheet", binary=True) if args.sheet else None
    clip = concat_clips(load_clips(args.input, args.utterance, engine=args.engine, seed=args.seed))
    other = None
    if args.compare:
        other = concat_clips(load_clips(args.compare, args.utterance, engine=args.engine, seed=args.seed))

    from renders.animate import render_gif, render_sheet
    from renders.gl import RenderSetupError
    from renders.mannequin import Mannequin
    from sgt_tui.errors import InputError
    from sgt_tui.progress import ProgressBar

    labels = None
    if other is not None:
        a, b = Path(args.input).stem, Path(args.compare).stem
        if a == b:
            a, b = str(args.input), str(args.compare)
        labels = (f"A {a}", f"B {b}")
    try:
        m = Mannequin(*size)
    except RenderSetupError as exc:
        raise InputError(str(exc)) from None
    try:
        info = render_gif(clip, gif_out, size=size, compare=other, labels=labels,
                          progress=ProgressBar("render"), mannequin=m)
        print(f"wrote {shown(gif_out)}: {info['frames']} frames, {info['duration_s']:.2f} s, "
              f"{info['width']}x{info['height']}, {info['bytes'] / 1024:.0f} KiB ({info['platform']})",
              file=sys.stderr)
        if sheet_out is not None:
            s = render_sheet(clip, sheet_out, size=size, mannequin=m)
            print(f"wrote {shown(sheet_out)}: {len(s['frames'])} frames, {s['width']}x{s['height']}", file=sys.stderr)
    finally:
        m.close()
    return 0
