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

MOTION_SUFFIXES = (".json", ".npz")
SCRIPT_SUFFIXES = (".sgt",)


def register(sub) -> None:
    p = sub.add_parser("render", help=HELP, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="INPUT", help="motion file (.json/.npz) or script (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT.gif", required=True, help="write the GIF here")
    p.add_argument("--sheet", metavar="PNG", help="also write a contact sheet PNG")
    p.add_argument("--compare", metavar="MOTION", help="render this second take side by side")
    p.add_argument("--size", metavar="WxH", default="320x320", help="frame size in pixels (default 320x320)")
    p.add_argument("--utterance", type=int, metavar="N", help="only utterance N (0-based)")
    add_script_options(p)
    p.set_defaults(run=run)


def add_script_options(p) -> None:
    p.add_argument("--engine", metavar="NAME", help="generation engine for script input (default: the generator's default)")
    p.add_argument("--seed", type=int, metavar="N", help="random seed for script input")


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

    from sgt_tui.errors import UsageError

    if Path(path).suffix.lower() not in allowed:
        raise UsageError(f"{option} {path}: expected a {' or '.join(allowed)} file")


class InputError(Exception):
    """A bad input file; the message was printed already when ``printed`` is set."""

    def __init__(self, message: str, printed: bool = False) -> None:
        super().__init__(message)
        self.printed = printed


def load_clips(path_text: str, utterance: int | None, engine: str | None = None, seed: int | None = None):
    """Clips of a motion file or a script (generated), narrowed to ``utterance``.

    Raises UsageError (missing file, unknown type, no such utterance) or InputError.
    """
    from sgt_tui.errors import UsageError
    from sgt_tui.commands.common import existing_file

    path = existing_file(path_text)
    suffix = path.suffix.lower()
    if suffix in MOTION_SUFFIXES:
        from core.motion import MotionFileError, load_motion

        try:
            clips = load_motion(path)
        except MotionFileError as exc:
            raise InputError(str(exc)) from None
    elif suffix in SCRIPT_SUFFIXES:
        from model.generate import GenerateError, generate_clips
        from sgt_tui.commands.common import print_diagnostics
        from sgt_tui.progress import ProgressBar

        try:
            clips = generate_clips(path, engine=engine, seed=seed,
                                   utterances=[utterance] if utterance is not None else None,
                                   progress=ProgressBar("generate"))
        except GenerateError as exc:
            if exc.diagnostics:
                print_diagnostics(exc.diagnostics, {str(path): exc.source})
                raise InputError(str(exc), printed=True) from None
            raise InputError(str(exc)) from None
        if utterance is not None:
            if not clips:
                raise UsageError(f"no utterance {utterance} in {path}")
            return clips
    else:
        raise UsageError(f"{path}: unknown input type '{suffix or '(none)'}' (use .json, .npz or .sgt)")
    if not clips:
        raise InputError(f"{path}: no utterances")
    from renders.clips import pick

    try:
        return pick(clips, utterance)
    except IndexError as exc:
        raise UsageError(f"{path}: {exc}") from None


def report_input_error(command: str, exc: InputError) -> int:
    if not exc.printed:
        print(f"sgt {command}: error: {exc}", file=sys.stderr)
    return 1


def run(args) -> int:
    from pathlib import Path

    from sgt_tui.errors import UsageError

    _check_suffix(args.output, (".gif",), "-o")
    if args.sheet:
        _check_suffix(args.sheet, (".png",), "--sheet")
    size = parse_size(args.size)
    if args.utterance is not None and args.utterance < 0:
        raise UsageError(f"--utterance must be 0 or more, not {args.utterance}")
    try:
        from renders.clips import concat_clips

        clip = concat_clips(load_clips(args.input, args.utterance, args.engine, args.seed))
        other = None
        if args.compare:
            other = concat_clips(load_clips(args.compare, args.utterance, args.engine, args.seed))
    except InputError as exc:
        return report_input_error("render", exc)

    from renders.animate import render_gif, render_sheet
    from renders.gl import RenderSetupError
    from renders.mannequin import Mannequin
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
        print(f"sgt render: error: {exc}", file=sys.stderr)
        return 1
    try:
        info = render_gif(clip, args.output, size=size, compare=other, labels=labels,
                          progress=ProgressBar("render"), mannequin=m)
        print(f"wrote {args.output}: {info['frames']} frames, {info['duration_s']:.2f} s, "
              f"{info['width']}x{info['height']}, {info['bytes'] / 1024:.0f} KiB ({info['platform']})",
              file=sys.stderr)
        if args.sheet:
            s = render_sheet(clip, args.sheet, size=size, mannequin=m)
            print(f"wrote {args.sheet}: {len(s['frames'])} frames, {s['width']}x{s['height']}", file=sys.stderr)
    except OSError as exc:
        print(f"sgt render: error: cannot write output: {exc}", file=sys.stderr)
        return 1
    finally:
        m.close()
    return 0
