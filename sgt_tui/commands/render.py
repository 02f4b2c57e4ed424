"""sgt render: motion file or script -> preview GIF or MP4 with sound, contact sheet,
side-by-side comparison."""

from __future__ import annotations

import argparse
import sys

from core.counting import number, plural

HELP = "render motion (or a script) to a preview GIF or an MP4 with sound, and a contact sheet"
DESCRIPTION = """\
Render a motion file (.json/.npz written by sgt) or a script (.sgt, generated first)
offscreen to a looping 15 fps GIF (-o OUT.gif) or a 15 fps MP4 video with the speech
(-o OUT.mp4: H.264 and AAC; the audio of every utterance at its place on the performance
clock, from the script the take was generated from). Every frame shows a shaded
mannequin per speaker, side by side (one with --speaker NAME), the word being spoken,
a timeline of the controls (pose in green, style in red), a playhead and the time.

--sheet also writes a PNG contact sheet, a row per speaker (wrapped when long): with
--sheet-at strokes (the default) a picture at every pose control's stroke, captioned with
the gesture, the word it marks and the frame; with --sheet-at even, 8 evenly spaced frames
with the word spoken then. Speakers are told apart by a label and the colour of the body.
--view chooses the camera: three-quarter (default: from the front-left and a little above,
so a reach towards the listener stands out from the body), front, side (the character's right side:
depth shows left-right), top, or face (a close-up of the head that follows it).
--face-inset draws a close-up of each speaker's face in the top right corner of every
picture: auto (default) where the head is drawn under 96 pixels tall (at the default
320x320 it is about 50), on, or off. --compare renders a second take beside the first,
labelled (one speaker).

Without --utterance the whole performance is rendered: each speaker's track, listening
between its lines. Motion files from before the performance clock (version 1) have no
tracks: their utterances are rendered one after another, and an MP4 has no sound.

Offscreen GL: EGL, falling back to OSMesa (set SGT_GL=egl|osmesa to choose)."""


#: The camera views (renders.mannequin.VIEWS; spelled out here so that --help imports no numpy).
VIEWS = ("three-quarter", "front", "side", "top", "face")
#: The face's close-up (renders.face_closeup.INSET_MODES, spelled out for the same reason).
FACE_INSETS = ("auto", "on", "off")


#: The most worker processes ``--jobs`` defaults to (each holds a GL context and a copy of the take).
MAX_DEFAULT_JOBS = 8


def register(sub) -> None:
    from sgt_tui.commands.common import positive_int, utterance_number

    p = sub.add_parser("render", help=HELP, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="INPUT", help="motion file (.json/.npz) or script (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT", required=True,
                   help="write the .gif or .mp4 here ('-': a GIF on standard output, not a terminal)")
    p.add_argument("--sheet", metavar="PNG", help="also write a contact sheet PNG")
    p.add_argument("--sheet-at", choices=("strokes", "even"), default="strokes",
                   help="the sheet's pictures: every pose control's stroke (default) or 8 evenly spaced frames")
    p.add_argument("--view", choices=VIEWS, default="three-quarter",
                   help="camera: three-quarter (default), front, side (depth left-right), top or face (a close-up)")
    p.add_argument("--face-inset", choices=FACE_INSETS, default="auto",
                   help="a close-up of the face in each picture's corner: auto (default: where the head is small), on, off")
    p.add_argument("--compare", metavar="MOTION", help="render this second take side by side")
    p.add_argument("--size", metavar="WxH", default="320x320", help="frame size in pixels, WxH or N (default 320x320)")
    p.add_argument("--utterance", type=utterance_number, metavar="N", help="only utterance N (the first is 1)")
    p.add_argument("--speaker", metavar="NAME", help="only this speaker's track")
    p.add_argument("--jobs", type=positive_int, metavar="N",
                   help=f"worker processes drawing the frames of a long take (default: the CPUs this process may use, "
                        f"at most {MAX_DEFAULT_JOBS}; 1: draw in this process); the output is the same for any N")
    add_script_options(p)
    p.set_defaults(run=run)


def add_script_options(p) -> None:
    from sgt_tui.commands.common import ENGINE_CHOICES, add_seed_option

    p.add_argument("--engine", choices=ENGINE_CHOICES, help="generation engine for script input (default: the generator's default)")
    add_seed_option(p, "random seed for script input")


def parse_size(text: str) -> tuple[int, int]:
    """``WxH`` or ``N`` (square) in pixels, each 16..4096; a UsageError otherwise."""
    from sgt_tui.errors import UsageError

    parts = text.lower().replace("×", "x").split("x")
    try:
        w, h = (int(parts[0]), int(parts[-1])) if len(parts) in (1, 2) else (None, None)
    except ValueError:
        w = h = None
    if w is None or h is None:
        raise UsageError(f"--size must look like 320x320 or 320, not '{text}'")
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

    from core.fileio import same_file
    from renders.clips import speaker_name
    from sgt_tui.commands.clips import load_performance
    from sgt_tui.commands.common import STDOUT, inputs_of, one_stdout, output_file, shown
    from sgt_tui.errors import UsageError

    _check_suffix(args.output, (".gif", ".mp4"), "-o")
    video = args.output != STDOUT and Path(args.output).suffix.lower() == ".mp4"
    if args.sheet is not None:
        _check_suffix(args.sheet, (".png",), "--sheet")
    size = parse_size(args.size)
    one_stdout(**{"-o": args.output, "--sheet": args.sheet})
    inputs = inputs_of(args.input, args.compare)
    out = output_file(args.output, binary=True, inputs=inputs)
    sheet_out = output_file(args.sheet, "--sheet", binary=True, inputs=inputs) if args.sheet is not None else None
    if sheet_out is not None and args.output != STDOUT and (args.sheet == args.output or same_file(args.sheet, args.output)):
        raise UsageError(f"-o and --sheet name one file ({args.sheet}): the sheet would overwrite the animation")
    take = load_performance(args.input, args.utterance, engine=args.engine, seed=args.seed, speaker=args.speaker)
    clips, labels, tints = _panel_clips(take, args.speaker, args.input)
    rows = labels or tuple(speaker_name(c.speaker) for c in clips)  # the sheet's rows
    if args.compare:
        if len(clips) > 1:
            raise UsageError(f"--compare shows one speaker beside another take: choose one with --speaker "
                             f"({', '.join(labels)})")
        other = load_performance(args.compare, args.utterance, engine=args.engine, seed=args.seed)
        clips += _panel_clips(other, args.speaker, args.compare)[0][:1]
        tints = tints * 2  # one speaker, two takes: the labels tell them apart
        a, b = Path(args.input).stem, Path(args.compare).stem
        if a == b:
            a, b = str(args.input), str(args.compare)
        labels = rows = (f"A {a}", f"B {b}")
    audio = rate = None
    if video:
        audio, rate = _audio(take, args.input)

    from core.workers import default_jobs
    from renders.animate import render_gif, render_mp4, render_sheet
    from renders.frames import WorkerDied
    from renders.gl import RenderSetupError
    from renders.mannequin import Mannequin
    from renders.video import VideoError
    from sgt_tui.errors import InputError
    from sgt_tui.progress import ProgressBar

    jobs = args.jobs or min(default_jobs(), MAX_DEFAULT_JOBS)
    try:
        m = Mannequin(*size)
    except RenderSetupError as exc:
        raise InputError(str(exc)) from None
    try:
        if video:
            try:
                info = render_mp4(clips, out, labels=labels, audio=audio, sample_rate=rate, size=size,
                                  progress=ProgressBar("render"), mannequin=m, view=args.view, tints=tints,
                                  face_inset=args.face_inset, jobs=jobs)
            except (VideoError, WorkerDied) as exc:
                raise InputError(str(exc)) from None
            sound = "with sound" if audio is not None else "no sound"
        else:
            try:
                info = render_gif(clips[0], out, size=size, others=clips[1:], labels=labels,
                                  progress=ProgressBar("render"), mannequin=m, view=args.view, tints=tints,
                                  face_inset=args.face_inset, jobs=jobs)
            except WorkerDied as exc:
                raise InputError(str(exc)) from None
            sound = ""
        print(f"wrote {shown(out)}: {plural(info['frames'], 'frame')}, {info['duration_s']:.2f} s, "
              f"{info['width']}x{info['height']}, {info['bytes'] / 1024:.0f} KiB"
              f"{', ' + sound if sound else ''} ({info['platform']})", file=sys.stderr)
        if sheet_out is not None:
            s = render_sheet(clips, sheet_out, labels=rows, size=size, at=args.sheet_at, view=args.view, tints=tints,
                             title=f"{Path(args.input).name} · {args.view} view", mannequin=m, face_inset=args.face_inset)
            print(f"wrote {shown(sheet_out)}: {sheet_summary(s['rows'], args.sheet_at)}, {s['width']}x{s['height']}",
                  file=sys.stderr)
    finally:
        m.close()
    return 0


def sheet_summary(rows: list[dict], at: str) -> str:
    """What a sheet shows, from :func:`renders.animate.render_sheet`'s rows: ``5 strokes of 2
    rows``; ``8 evenly spaced frames (no marked gestures) of 1 row`` for a row without pose
    controls (``at`` "strokes"); both, naming the rows without, when they are mixed."""

    strokes = sum(r["pictures"] for r in rows if r["at"] == "strokes")
    even = [r for r in rows if r["at"] == "even"]
    parts = [plural(strokes, "stroke")] if strokes or not even else []
    if even:
        parts.append(plural(sum(r["pictures"] for r in even), "evenly spaced frame"))
    what = " and ".join(parts)
    if at == "strokes" and even:
        who = "" if len(even) == len(rows) else ", ".join(r["label"] for r in even) + ": "
        what += f" ({who}no marked gestures)"
    return f"{what} of {plural(len(rows), 'row')}"


def _panel_clips(take, speaker: str | None, name: str):
    """The clips to draw side by side, their labels and their tints: each speaker's track on
    the performance clock (only ``speaker``'s when given), or, without tracks, the utterances
    one after another. A speaker's tint is its place among the take's speakers, so it keeps
    its colour with --speaker."""
    from renders.clips import concat_clips, speaker_name, track_clip
    from renders.mannequin import speaker_tint
    from sgt_tui.errors import UsageError

    names = [speaker_name(t.speaker) for t in take.tracks] or list(dict.fromkeys(speaker_name(c.speaker) for c in take.clips))
    if speaker is not None and speaker not in names:
        raise UsageError(f"--speaker {speaker}: no such speaker in {name} (it has {', '.join(names)})")
    if take.tracks:
        tracks = [t for t in take.tracks if speaker is None or speaker_name(t.speaker) == speaker]
        clips = [track_clip(t, take.clips) for t in tracks]
        labels = tuple(speaker_name(t.speaker) for t in tracks) if len(tracks) > 1 else None
        return clips, labels, [speaker_tint(names.index(speaker_name(t.speaker))) for t in tracks]
    chosen = [c for c in take.clips if speaker is None or speaker_name(c.speaker) == speaker]
    tint = speaker_tint(names.index(speaker) if speaker is not None and len(names) > 1 else 0)
    return [concat_clips(chosen)], None, [tint]


def _audio(take, name: str, within=None):
    """The performance's speech mixed on the clock of what is rendered: (samples, rate), or
    (None, None) for a take without audio offsets (a version 1 motion file). ``within``: the
    folder the take's script must be in (see :func:`script_of`)."""
    from core.skeleton import FPS
    from renders.audio_mix import mix

    if any(c.audio_offset is None for c in take.clips):
        print(f"note: {name} is a motion file from before the performance clock: the video has no sound "
              "(generate it again for sound)", file=sys.stderr)
        return None, None
    paths = _speech_files(take, name, within)
    if take.tracks:
        parts = [(paths[c.index], c.start + c.audio_offset) for c in take.clips]
        frames = take.tracks[0].n_frames
    else:  # one after another
        parts, at = [], 0
        for c in take.clips:
            parts.append((paths[c.index], at / FPS + c.audio_offset))
            at += c.n_frames
        frames = at
    return mix(parts, frames)


def script_of(take, name: str, within=None):
    """The script a motion file names as the one it was generated from (its ``"source"``), as
    a path to compile for its speech: a ``.sgt`` file (links resolved), inside the folder
    ``within`` when given (a build folder ``sgt view`` shows); an InputError (one line, the
    take then has no speech) for anything else, which is never read."""
    import os
    from pathlib import Path

    from core.fileio import LinkRefused, resolved_inside
    from sgt_tui.errors import InputError

    if not take.source:
        raise InputError(f"{name} does not name the script it was generated from, so its speech is unknown; "
                         "render the script, or a GIF")
    source = Path(take.source)
    if within is not None:
        try:
            real = Path(resolved_inside(within, source))
        except LinkRefused:
            raise InputError(f"{name} names {source} as its script, outside {within}: not read, so the take has no "
                             "speech; view the script itself, or build with --wav") from None
    else:
        real = Path(os.path.realpath(source))
    if real.suffix.lower() != ".sgt":
        raise InputError(f"{name} names {source} as its script, which is not a .sgt script: not read, so the take "
                         "has no speech; render a GIF, or generate the take again")
    if not real.is_file():
        raise InputError(f"{name} was generated from {source}, which is not there any more; render a GIF, "
                         "or generate the take again")
    return real


def _speech_files(take, name: str, within=None) -> dict:
    """Utterance index -> its speech audio, from the script the take was generated from
    (:func:`script_of`, compiled again; its speech is cached), checked against the take."""
    from dsl.compiler import compile_file
    from sgt_tui.commands.common import print_diagnostics
    from sgt_tui.errors import InputError
    from sgt_tui.progress import ProgressBar

    source = script_of(take, name, within)
    result = compile_file(source, timing="speech", utterances=[c.index for c in take.clips], progress=ProgressBar("speech"))
    if result.plan is None:
        print_diagnostics(result.diagnostics, {str(source): result.script.source})
        raise InputError(f"{source} (the script of {name}) has errors", printed=True)
    planned = {u.index: u for u in result.plan.utterances}
    for c in take.clips:
        u = planned.get(c.index)
        if u is None or u.text != c.text or u.n_frames != c.n_frames or abs(u.audio_offset - c.audio_offset) > 1e-3:
            raise InputError(f"{source} has changed since {name} was generated (utterance {number(c.index)}: "
                             f"{c.text!r}); generate the take again")
    return {c.index: planned[c.index].audio_path for c in take.clips}
