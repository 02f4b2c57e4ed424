"""``sgt library``: list, show and add gestures of the motion library."""

from __future__ import annotations

HELP = "list, inspect and extend the gesture library"


def register(subparsers) -> None:
    p = subparsers.add_parser("library", help=HELP, description=HELP.capitalize() + ".")
    sub = p.add_subparsers(dest="library_command", metavar="SUBCOMMAND")

    ls = sub.add_parser("list", help="list the gestures and where they come from")
    ls.add_argument("--tag", action="append", default=[], help="only gestures with this tag")
    ls.add_argument("--json", action="store_true", help="machine-readable output")
    ls.add_argument("--dir", action="append", default=[], metavar="D", help="extra gesture folder")

    sh = sub.add_parser("show", help="describe one gesture")
    sh.add_argument("name")
    sh.add_argument("--speed", type=int, default=1, choices=(1, 2, 3))
    sh.add_argument("--flip", action="store_true")
    sh.add_argument("--json", action="store_true")
    sh.add_argument("--dir", action="append", default=[], metavar="D", help="extra gesture folder")

    ad = sub.add_parser("add", help="save a span of a motion file as a new gesture")
    ad.add_argument("name")
    ad.add_argument("--from", dest="source", required=True, metavar="MOTION_FILE")
    ad.add_argument("--frames", required=True, metavar="A:B", help="frame span, B exclusive")
    ad.add_argument("--utterance", type=int, default=0, metavar="N")
    ad.add_argument("--to", metavar="DIR", help="gesture folder (default: first configured)")
    ad.add_argument("--description", default="")
    ad.add_argument("--tags", default="", help="comma-separated tags")
    ad.add_argument("--stroke", type=int, default=None, metavar="F",
                    help="stroke frame inside the span (default: fastest frame)")
    ad.add_argument("--force", action="store_true", help="overwrite an existing file")

    p.set_defaults(run=run, _library_parser=p)


def run(args) -> int:
    from sgt_tui.errors import UsageError

    cmd = getattr(args, "library_command", None)
    if cmd == "list":
        return _list(args)
    if cmd == "show":
        return _show(args)
    if cmd == "add":
        return _add(args)
    raise UsageError("choose a subcommand: list, show or add")


def _origin(g) -> str:
    return "built-in" if g.origin == "built-in" else g.origin


def _list(args) -> int:
    import json
    from pathlib import Path

    from library import load_library

    lib = load_library([Path(d) for d in args.dir])
    gestures = [g for g in lib if all(t in g.tags for t in args.tag)]
    if args.json:
        print(json.dumps({
            "gestures": [{
                "name": g.name, "duration": g.duration, "tags": g.tags,
                "origin": g.origin, "path": str(g.path),
                "overrides": str(g.overrides) if g.overrides else None,
            } for g in gestures],
            "problems": [{"path": str(p.path), "field": p.field, "message": p.message}
                         for p in lib.problems],
        }, indent=2))
        return 0
    if not gestures:
        print("no gestures" + (f" tagged {', '.join(args.tag)}" if args.tag else ""))
    else:
        width = max(14, max(len(g.name) for g in gestures))
        print(f"{'NAME':<{width}}  {'SECS':>4}  {'TAGS':<30}  FROM")
        for g in gestures:
            tags = ", ".join(g.tags)
            if len(tags) > 30:
                tags = tags[:27] + "..."
            src = _origin(g)
            if g.overrides:
                src += " (overrides)"
            print(f"{g.name:<{width}}  {g.duration:>4.1f}  {tags:<30}  {src}")
        print(f"{len(gestures)} gesture{'s' if len(gestures) != 1 else ''}")
        for g in gestures:
            if g.overrides:
                print(f"  {g.name}: {g.path} overrides {g.overrides}")
    if lib.problems:
        print()
        print(f"{len(lib.problems)} problem{'s' if len(lib.problems) != 1 else ''}:")
        for p in lib.problems:
            print(f"  {p}")
    return 0


def _show(args) -> int:
    import json
    import sys
    from pathlib import Path

    from library import load_library

    lib = load_library([Path(d) for d in args.dir])
    g = lib.get(args.name)
    if g is None:
        hint = lib.suggest(args.name)
        msg = f"sgt library: no gesture named '{args.name}'"
        if hint:
            msg += f"; did you mean '{hint}'?"
        print(msg, file=sys.stderr)
        return 1
    clip = g.clip(speed=args.speed, flip=args.flip)
    if args.json:
        print(json.dumps({
            "name": g.name, "description": g.description, "tags": g.tags,
            "duration": g.duration, "origin": g.origin, "path": str(g.path),
            "overrides": str(g.overrides) if g.overrides else None,
            "speed": args.speed, "flip": args.flip,
            "frames": clip.n_frames, "stroke_frame": clip.stroke_frame,
            "keyframes": [{
                "time": k.time, "label": k.label, "stroke": k.stroke,
                "bones": {b: (list(v) if v is not None else "rest") for b, v in k.bones.items()},
            } for k in g.keyframes],
        }, indent=2))
        return 0
    import textwrap

    print(f"{g.name}  ({_origin(g)})")
    print(f"  file:     {g.path}")
    if g.overrides:
        print(f"  replaces: {g.overrides}")
    for line in textwrap.wrap(g.description or "(no description)", 76):
        print(f"  {line}")
    print(f"  tags:     {', '.join(g.tags) or '-'}")
    extra = f" x{args.speed}" + (" flipped" if args.flip else "")
    print(f"  duration: {g.duration:g} s at x1; {clip.n_frames} frames at{extra}")
    print(f"  stroke:   frame {clip.stroke_frame}" if clip.stroke_frame is not None
          else "  stroke:   none")
    print("  keyframes:")
    for k in g.keyframes:
        mark = " *stroke*" if k.stroke else ""
        bones = ", ".join(k.bones) or "-"
        head = f"    {k.time:5.2f}s {k.label or '':<9}{mark}"
        for i, line in enumerate(textwrap.wrap(bones, 80 - 30) or ["-"]):
            print(f"{head if i == 0 else '':<30}{line}")
    return 0


def _parse_span(text: str, n: int) -> tuple[int, int]:
    from sgt_tui.errors import UsageError

    try:
        a_txt, b_txt = text.split(":")
        a = int(a_txt) if a_txt.strip() else 0
        b = int(b_txt) if b_txt.strip() else n
    except ValueError:
        raise UsageError(f"--frames must look like A:B (two frame numbers), got '{text}'") from None
    if a < 0 or b > n or b - a < 2:
        raise ValueError(
            f"frames {a}:{b} are not a span of at least 2 frames inside 0:{n} "
            f"(the utterance has {n} frames; B is exclusive)"
        )
    return a, b


def _add(args) -> int:
    import re
    import sys
    from pathlib import Path

    from library.extract import spec_text_from_poses
    from core.motion import MotionFileError, load_motion

    if not re.fullmatch(r"[a-z][a-z0-9_]*", args.name):
        print(f"sgt library add: name '{args.name}' must be lower-case letters, digits and "
              "'_', starting with a letter", file=sys.stderr)
        return 1
    try:
        clips = load_motion(args.source)
    except MotionFileError as exc:
        print(f"sgt library add: {exc}", file=sys.stderr)
        return 1
    if not 0 <= args.utterance < len(clips):
        print(f"sgt library add: utterance {args.utterance} does not exist "
              f"({args.source} has {len(clips)}: 0..{len(clips) - 1})", file=sys.stderr)
        return 1
    poses = clips[args.utterance].poses
    try:
        a, b = _parse_span(args.frames, len(poses))
    except ValueError as exc:
        print(f"sgt library add: {exc}", file=sys.stderr)
        return 1
    if args.stroke is not None and not a <= args.stroke < b:
        print(f"sgt library add: --stroke {args.stroke} is outside the span {a}:{b}",
              file=sys.stderr)
        return 1
    folder = Path(args.to) if args.to else _default_folder()
    target = folder / f"{args.name}.toml"
    if target.exists() and not args.force:
        print(f"sgt library add: {target} exists; use --force to overwrite", file=sys.stderr)
        return 1
    tags = [t.strip() for t in args.tags.split(",") if t.strip()]
    description = args.description or f"Recorded from {Path(args.source).name}, frames {a}:{b}."
    stroke = None if args.stroke is None else args.stroke - a
    text, err = spec_text_from_poses(args.name, poses[a:b], description=description, tags=tags,
                                     stroke=stroke)
    from core.fileio import atomic_write_text

    atomic_write_text(target, text)
    print(f"wrote {target} ({b - a} frames; max error {err:.1f} degrees on re-load)")
    return 0


def _default_folder():
    from pathlib import Path

    from library.config import configured_paths

    folders, _ = configured_paths()
    return Path(folders[0]) if folders else Path("gestures")
