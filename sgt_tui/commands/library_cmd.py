"""``sgt library``: list, show and add gestures of the motion library."""

from __future__ import annotations

import math

from core.counting import no_utterance, plural

HELP = "list, inspect and extend the gesture library"


def register(subparsers) -> None:
    from sgt_tui.commands.common import utterance_number

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

    sheet = sub.add_parser("sheet", help="draw the gestures' strokes, front and side, into a PNG contact sheet")
    sheet.add_argument("names", nargs="*", metavar="NAME", help="gestures to draw (default: all)")
    sheet.add_argument("-o", "--output", required=True, metavar="OUT.png",
                       help="write the PNG here ('-': standard output, not a terminal)")
    sheet.add_argument("--tag", action="append", default=[], help="only gestures with this tag")
    sheet.add_argument("--columns", type=_columns, default=5, metavar="N", help="gestures per row (default 5)")
    sheet.add_argument("--size", default="150", metavar="N|WxH", help="pixels of one view (default 150)")
    sheet.add_argument("--view", type=_views, default=("front", "side"), metavar="VIEW[,VIEW...]",
                       help="camera views per gesture, side by side: front, side, three-quarter, top "
                            "(default front,side)")
    sheet.add_argument("--dir", action="append", default=[], metavar="D", help="extra gesture folder")

    ad = sub.add_parser("add", help="save a span of a motion file, a BVH take or a glTF animation as a new gesture",
                        description="Save a span of a motion file (.json, .npz), a motion capture take (.bvh) or a "
                                    "glTF animation (.glb, .gltf) as a new gesture. Takes are mapped onto sgt's "
                                    "skeleton by their joint names and resampled to 15 fps.")
    ad.add_argument("name")
    ad.add_argument("--from", dest="source", required=True, metavar="FILE",
                    help="a motion file (.json, .npz), a BVH take (.bvh) or a glTF animation (.glb, .gltf)")
    ad.add_argument("--frames", required=True, metavar="A:B",
                    help="the span, B exclusive: the file's own frame numbers (a take's, at its own rate) "
                         "or seconds (1.5s:3s)")
    ad.add_argument("--utterance", type=utterance_number, metavar="N",
                    help="the motion file's utterance N (the first is 1; default: 1)")
    ad.add_argument("--to", metavar="DIR", help="gesture folder (default: first configured)")
    ad.add_argument("--description", default="")
    ad.add_argument("--tags", default="", help="comma-separated tags")
    ad.add_argument("--stroke", default=None, metavar="F",
                    help="the stroke's frame, counted as --frames counts (or seconds: 2.1s); default: where "
                         "the span's fastest movement ends")
    ad.add_argument("--map", metavar="MAP.toml",
                    help="a take's joint names for sgt's joints, a TOML line each (right_elbow = \"R_Elbow\"), "
                         "for a skeleton sgt does not know by name")
    ad.add_argument("--fps-in", type=_fps_in, default=None, metavar="auto|N",
                    help="a take's frame rate (default auto: a BVH's Frame Time, a glTF animation's key rate)")
    ad.add_argument("--animation", metavar="NAME", help="the glTF animation to read, when the file has several")
    ad.add_argument("--force", action="store_true", help="overwrite an existing file")

    p.set_defaults(run=run, _library_parser=p)


def run(args) -> int:
    from sgt_tui.errors import UsageError

    cmd = getattr(args, "library_command", None)
    if cmd == "list":
        return _list(args)
    if cmd == "show":
        return _show(args)
    if cmd == "sheet":
        return _sheet(args)
    if cmd == "add":
        return _add(args)
    raise UsageError("choose a subcommand: list, show, sheet or add")


def _origin(g) -> str:
    return "built-in" if g.origin == "built-in" else g.origin


#: The width of ``library list``'s tags column; longer lists go on, whole, on the next lines.
TAGS_WIDTH = 30


def _tag_lines(tags) -> list[str]:
    """``tags`` joined with ", " in lines of at most :data:`TAGS_WIDTH` characters (a longer
    tag on a line of its own), every tag whole."""
    lines: list[str] = []
    for tag in tags:
        if lines and len(lines[-1]) + len(tag) + 3 <= TAGS_WIDTH:  # (room for the comma that may follow)
            lines[-1] += f", {tag}"
        else:
            if lines:
                lines[-1] += ","
            lines.append(tag)
    return lines or [""]


def _list(args) -> int:
    import json

    from library import load_library

    lib = load_library(_folders(args.dir))
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
        print(f"{'NAME':<{width}}  {'SECS':>4}  {'TAGS':<{TAGS_WIDTH}}  FROM")
        for g in gestures:
            src = _origin(g)
            if g.overrides:
                src += " (overrides)"
            first, *more = _tag_lines(g.tags)
            print(f"{g.name:<{width}}  {g.duration:>4.1f}  {first:<{TAGS_WIDTH}}  {src}")
            for line in more:  # every tag shown: the rest on lines of their own
                print(f"{'':<{width}}  {'':>4}  {line}")
        print(plural(len(gestures), "gesture"))
        for g in gestures:
            if g.overrides:
                print(f"  {g.name}: {g.path} overrides {g.overrides}")
    if lib.problems:
        print()
        print(f"{plural(len(lib.problems), 'problem')}:")
        for p in lib.problems:
            print(f"  {p}")
    return 0


def _show(args) -> int:
    import json

    from core.skeleton import mirror_name
    from library import load_library
    from sgt_tui.errors import UsageError

    lib = load_library(_folders(args.dir))
    g = lib.get(args.name)
    if g is None:  # a name that matches nothing: a usage error, as `--utterance 50` is
        hint = lib.suggest(args.name)
        raise UsageError(f"no gesture named '{args.name}'" + (f"; did you mean '{hint}'?" if hint else ""))
    clip = g.clip(speed=args.speed, flip=args.flip)
    keyframes = [k.mirrored() for k in g.keyframes] if args.flip else list(g.keyframes)
    frames = g.key_frames(args.speed)
    limbs = [mirror_name(limb) for limb in g.spec.limbs] if args.flip else list(g.spec.limbs)
    if args.json:
        print(json.dumps({
            "name": g.name, "description": g.description, "tags": g.tags,
            "duration": g.duration, "origin": g.origin, "path": str(g.path),
            "overrides": str(g.overrides) if g.overrides else None,
            "speed": args.speed, "flip": args.flip,
            "frames": clip.n_frames, "stroke_frame": clip.stroke_frame, "drives": limbs,
            "variant_of": g.spec.variant_of,
            "keyframes": [{
                "time": k.time, "frame": int(f), "label": k.label, "stroke": k.stroke,
                "bones": {b: (list(v) if v is not None else "rest") for b, v in k.bones.items()},
                "hands": dict(k.hands),
            } for k, f in zip(keyframes, frames)],
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
    print(f"  drives:   {', '.join(limbs)} (the generator moves the rest)")
    if g.spec.variant_of:
        print(f"  variant of: {g.spec.variant_of}")
    print("  keyframes" + (" (mirrored):" if args.flip else ":"))
    for k, f in zip(keyframes, frames):
        mark = " *stroke*" if k.stroke else ""
        head = f"    {k.time:5.2f}s f{int(f):<3} {k.label or '':<9}{mark}"
        bones = [f"{b} {_direction(v)}" for b, v in k.bones.items()] + [f"{h} {v}" for h, v in k.hands.items()] or ["-"]
        for i, line in enumerate(bones):
            print(f"{head if i == 0 else '':<36}{line}")
    return 0


def _columns(text: str) -> int:
    from sgt_tui.commands.common import positive_int

    n = positive_int(text)
    if n > 20:
        import argparse

        raise argparse.ArgumentTypeError(f"at most 20 columns, got {n}")
    return n


def _views(text: str) -> tuple[str, ...]:
    import argparse

    from sgt_tui.commands.render import VIEWS

    views = tuple(v.strip() for v in text.split(","))
    for v in views:
        if v not in VIEWS:
            raise argparse.ArgumentTypeError(f"unknown view '{v}': use {', '.join(VIEWS)}, comma-separated")
    if len(set(views)) != len(views):
        raise argparse.ArgumentTypeError(f"a view is named twice in '{text}'")
    return views


def _sheet(args) -> int:
    import sys
    from pathlib import Path

    from library import load_library
    from sgt_tui.commands.common import STDOUT, output_file, shown
    from sgt_tui.commands.render import parse_size
    from sgt_tui.errors import InputError, UsageError

    if args.output != STDOUT and Path(args.output).suffix.lower() != ".png":
        raise UsageError(f"-o {args.output}: expected a .png file")
    size = parse_size(args.size)
    lib = load_library(_folders(args.dir))
    for name in args.names:
        if name not in lib:
            hint = lib.suggest(name)
            raise UsageError(f"no gesture named '{name}'" + (f"; did you mean '{hint}'?" if hint else ""))
    gestures = [lib.get(n) for n in args.names] if args.names else list(lib)
    gestures = [g for g in gestures if all(t in g.tags for t in args.tag)]
    if not gestures:
        raise UsageError("no gestures to draw" + (f" tagged {', '.join(args.tag)}" if args.tag else ""))
    out = output_file(args.output, binary=True)

    from renders.gl import RenderSetupError
    from renders.library_sheet import render_library_sheet
    from renders.mannequin import Mannequin
    from sgt_tui.progress import ProgressBar

    try:
        m = Mannequin(*size)
    except RenderSetupError as exc:
        raise InputError(str(exc)) from None
    try:
        info = render_library_sheet(gestures, out, columns=args.columns, view=size, views=args.view, mannequin=m,
                                    progress=ProgressBar("sheet"))
    finally:
        m.close()
    print(f"wrote {shown(out)}: {plural(len(info['names']), 'gesture')} ({', '.join(info['views'])}), "
          f"{info['width']}x{info['height']}", file=sys.stderr)
    return 0


def _folders(dirs: list[str]) -> list:
    """The --dir folders, each checked: a missing one, or a file, is an input error (exit 1), not ignored."""
    from sgt_tui.commands.common import existing_folder

    return [existing_folder(d, "--dir") for d in dirs]


def _direction(v) -> str:
    return "rest" if v is None else "[" + ", ".join(f"{x:.3f}" for x in v) + "]"


def _fps_in(text: str) -> float | None:
    """``--fps-in``: "auto" (None) or frames a second, as a BVH frame time may give them."""
    import argparse

    if text == "auto":
        return None
    from sgt_tui.commands.common import positive_float

    fps = positive_float(text)
    if not 1.0 <= fps <= 10000.0:
        raise argparse.ArgumentTypeError(f"{text} frames a second: give 1 to 10000, or auto")
    return fps


def _frame_number(text: str, fps: float) -> int:
    """A frame number, or seconds ("1.5s") at ``fps``; ValueError for anything else."""
    text = text.strip()
    if text.endswith("s"):
        seconds = float(text[:-1])
        if not math.isfinite(seconds) or abs(seconds) > 1e7:
            raise ValueError(text)
        return round(seconds * fps)
    return int(text)


def _parse_span(text: str, n: int, fps: float | None = None, what: str = "the utterance") -> tuple[int, int]:
    """``--frames``: (A, B) inside 0:n, at most a gesture's longest at ``fps`` (default 15)."""
    from core.skeleton import FPS, frame_count
    from library.spec import MAX_DURATION
    from sgt_tui.errors import UsageError

    fps = FPS if fps is None else fps
    try:
        a_txt, b_txt = text.split(":")
        a = _frame_number(a_txt, fps) if a_txt.strip() else 0
        b = _frame_number(b_txt, fps) if b_txt.strip() else n
    except ValueError:
        raise UsageError(f"--frames must look like A:B (two frame numbers, or seconds: 1.5s:3s), got '{text}'") from None
    rate = "" if fps == FPS else f" at {fps:g} fps"
    if a < 0 or b > n or b - a < 2:
        raise UsageError(
            f"--frames {a}:{b} is not a span of at least 2 frames inside 0:{n} "
            f"({what} has {n} frames{rate}; B is exclusive)"
        )
    if math.floor((b - 1 - a) / fps * FPS + 1e-6) + 1 > frame_count(MAX_DURATION):  # the frames it resamples to
        raise UsageError(f"--frames {a}:{b} is {(b - a) / fps:.2f} s{rate}; a gesture may be at most "
                         f"{MAX_DURATION:g} s: take a shorter span")
    return a, b


def _stroke(args, a: int, b: int, fps: float) -> int | None:
    """``--stroke`` as a frame of the source (None: not given), inside the span."""
    from sgt_tui.errors import UsageError

    if args.stroke is None:
        return None
    try:
        f = _frame_number(args.stroke, fps)
    except ValueError:
        raise UsageError(f"--stroke must be a frame number (or seconds: 2.1s), got '{args.stroke}'") from None
    if not a <= f < b:
        raise UsageError(f"--stroke {args.stroke} is outside the span {a}:{b}")
    return f


def _add(args) -> int:
    import re
    from pathlib import Path

    from core.fileio import atomic_write_text, check_not_input, check_output
    from core.skeleton import FPS
    from library.extract import spec_text_from_poses
    from sgt_tui.commands.common import existing_file, output_folder, shown, text
    from sgt_tui.errors import UsageError

    if not re.fullmatch(r"[a-z][a-z0-9_]*", args.name):
        raise UsageError(f"name '{args.name}' must be lower-case letters, digits and '_', starting with a letter")
    source = existing_file(args.source)
    map_file = existing_file(args.map) if args.map else None
    folder = output_folder(args.to or str(_default_folder()), "--to")
    target = folder / f"{args.name}.toml"
    if target.exists() and not args.force:
        raise UsageError(f"{target} exists; use --force to overwrite")
    check_output(target)
    check_not_input(target, [source] + ([map_file] if map_file else []), "--to")
    tags = [t.strip() for t in text(args.tags, "--tags").split(",") if t.strip()]
    description = text(args.description, "--description")
    source_name = Path(args.source).name.encode("utf-8", "surrogateescape").decode("utf-8", "replace")  # for the spec file
    if source.suffix.lower() in TAKE_SUFFIXES:
        poses, hands, stroke, a, b, fps, source_stroke = _from_take(args, source, map_file)
        description = description or f"Recorded from {source_name}, frames {a}:{b} at {fps:g} fps."
        where = f" at {FPS} fps from frames {a}:{b} at {fps:g} fps, the stroke at frame {source_stroke}"
    else:
        for option, value in (("--map", args.map), ("--fps-in", args.fps_in), ("--animation", args.animation)):
            if value is not None:
                raise UsageError(f"{option} is for takes ({', '.join(TAKE_SUFFIXES)}), not for motion files")
        poses, hands, stroke, a, b = _from_motion_file(args, source)
        description = description or f"Recorded from {source_name}, frames {a}:{b}."
        where = ""
    spec, err = spec_text_from_poses(args.name, poses, description=description, tags=tags, stroke=stroke, hands=hands)
    atomic_write_text(target, spec)
    print(f"wrote {shown(target)} ({len(poses)} frames{where}; max error {err:.1f} degrees on re-load)")
    return 0


#: The takes ``sgt library add`` reads besides motion files: BVH and glTF.
TAKE_SUFFIXES = (".bvh", ".glb", ".gltf")


def _from_motion_file(args, source):
    """(poses, hands, stroke frame in them or None, a, b) of the span of a motion file."""
    from core.motion import MotionFileError, load_motion
    from core.skeleton import FPS
    from sgt_tui.errors import InputError, UsageError

    try:
        clips = load_motion(source)
    except MotionFileError as exc:
        raise InputError(str(exc)) from None
    index = 0 if args.utterance is None else args.utterance  # the first by default
    if not 0 <= index < len(clips):
        raise UsageError(f"{args.source}: {no_utterance(index, range(len(clips)), what='the motion')}")
    poses, hands = clips[index].poses, clips[index].hands
    a, b = _parse_span(args.frames, len(poses))
    stroke = _stroke(args, a, b, FPS)
    return poses[a:b], hands.take(slice(a, b)), None if stroke is None else stroke - a, a, b


def _from_take(args, source, map_file):
    """(poses at 15 fps, None, their stroke frame, a, b, the take's rate, the stroke's frame in the
    take) of the span of a BVH
    take or a glTF animation: mapped by joint names (``--map``), sgt's proportions for the torso,
    head and shoulders, resampled through the stroke (the take's own pose there)."""
    from core.skeleton import FPS
    from library.extract import find_stroke, resample_through
    from model.training.gltf_take import GltfTake
    from model.training.loaders import Bvh, LoaderError, MappingError, bvh_to_poses, read_bvh
    from sgt_tui.errors import InputError, UsageError

    if args.utterance is not None:
        raise UsageError("--utterance is for motion files; a take is one recording")
    bvh = source.suffix.lower() == ".bvh"
    if bvh and args.animation is not None:
        raise UsageError("--animation is for glTF files (.glb, .gltf)")
    mapping = _read_map(map_file) if map_file else None
    try:
        if bvh:
            take = read_bvh(source)
            fps, n = (_whole(take.fps) if args.fps_in is None else args.fps_in), len(take.motion)
        else:
            take = GltfTake(source, args.animation, args.fps_in)
            fps, n = take.fps, take.n_frames
    except LoaderError as exc:
        raise InputError(str(exc)) from None
    a, b = _parse_span(args.frames, n, fps, "the take")
    stroke = _stroke(args, a, b, fps)
    try:
        span = Bvh(take.joints, 1.0 / fps, take.motion[a:b], take.name) if bvh else take.span(a, b, mapping)
        poses = bvh_to_poses(span, mapping=mapping, fps=fps, sgt_proportions=True)
    except MappingError as exc:
        raise InputError(_unmapped(source, exc)) from None
    except LoaderError as exc:
        raise InputError(str(exc)) from None
    if stroke is None:
        stroke = a + find_stroke(poses, fps)
    poses, at = resample_through(poses, fps, stroke - a)
    if len(poses) < 2:
        raise UsageError(f"--frames {a}:{b} is {(b - a) / fps:.3f} s: less than 2 frames at {FPS} fps")
    return poses, None, at, a, b, fps, stroke


def _whole(fps: float) -> float:
    """A BVH's rate from its Frame Time, to the whole number of frames a second it rounds
    (Blender writes 0.033333 for 30 fps)."""
    return float(round(fps)) if abs(fps - round(fps)) < 1e-4 * fps else fps


def _read_map(path) -> dict[str, str | list[str]]:
    """A ``--map`` file: sgt joint = the take's joint name (or a list of names, tried in order)."""
    import tomllib

    from core.reading import InputFileError, read_bytes
    from library.spec import _close, toml_error
    from model.training.loaders import DEFAULT_MAPPING
    from sgt_tui.errors import InputError

    try:
        data = tomllib.loads(read_bytes(path, "configuration").decode("utf-8"))
    except InputFileError as exc:
        raise InputError(f"{path}: {exc.reason}") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        message, line, col = toml_error(exc)
        raise InputError(f"{path}:{line}:{col}: {message}" if line else f"{path}: {message}") from None
    joints = list(DEFAULT_MAPPING)
    for key, value in data.items():
        if key not in DEFAULT_MAPPING:
            hint = _close(key, joints)
            raise InputError(f"{path}: '{key}' is not one of sgt's joints" + (f" (did you mean '{hint[0]}'?)" if hint else "")
                             + f"; the keys are {', '.join(joints)}")
        if not (isinstance(value, str) and value) and not (
                isinstance(value, list) and value and all(isinstance(v, str) and v for v in value)):
            raise InputError(f"{path}: {key} must be the take's joint name in quotes "
                             f"({key} = \"NAME\"), or a list of names tried in order")
    return data


def _unmapped(source, exc) -> str:
    """One line for a take whose joints sgt cannot find: which, the take's joints, and a --map
    line to write (with the take's likeliest name for the first)."""
    import difflib

    from model.training.loaders import DEFAULT_MAPPING, _key, listed

    def shown(name: str) -> str:
        return name if name.isprintable() else name.encode("unicode_escape").decode("ascii")

    names = [shown(n) for n in exc.names]
    first = exc.missing[0]
    wanted = [_key(c) for c in (first, *DEFAULT_MAPPING[first])]
    # the likeliest of the joints no sgt joint took (not the other arm's, already mapped)
    scored = [(max(difflib.SequenceMatcher(None, _key(n), w).ratio() for w in wanted), shown(n)) for n in exc.free]
    best = max(scored, default=(0.0, ""))
    guess = best[1] if best[0] >= 0.75 else "THEIR_NAME"
    return (f"{source}: no joint for {', '.join(exc.missing)} among its joints ({listed(names)}); "
            f"name them in a --map file, a line per joint: {first} = \"{guess}\" (see docs/library.md)")


def _default_folder():
    from pathlib import Path

    from library.config import configured_paths

    folders, _ = configured_paths()
    return Path(folders[0]) if folders else Path("gestures")
