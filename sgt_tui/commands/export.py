"""sgt export: motion -> BVH (joint rotations), CSV (joint positions), JSON or NPZ; glTF and
other rigs (VRM, Mixamo, SMPL-X, NAO/Pepper) with --rig."""

from __future__ import annotations

import argparse
import sys

from core.counting import plural

HELP = "export motion as BVH, CSV, JSON, NPZ or glTF, for sgt's skeleton or another rig"
DESCRIPTION = """\
Export a motion file (or a script, generated first) by the output's extension, or
--format ('-o -' writes to standard output: JSON unless --format says otherwise):

  .bvh   upper-body hierarchy with joint rotations (ZXY Euler, degrees), metres, 1/15 s
  .csv   one row per frame: frame,time,<joint>_x,<joint>_y,<joint>_z,... in metres
  .json  sgt motion file (all utterances kept)
  .npz   sgt motion file, binary
  .glb   glTF 2.0 binary: skeleton, skinned mannequin, animation (15 fps); with a face,
         the mannequin's head with 52 ARKit morph targets, animated (--rig sgt)
  .vrma  VRM Animation (--rig vrm; its .glb is a plain glTF of the VRM skeleton); with a
         face, VRM expression tracks (aa ih ou ee oh, blinks, happy angry sad relaxed
         surprised, look up/down/left/right)

The face (lip sync, blinks, gaze, expressions) alone, with --face or by the name:
  .livelink.csv   --face livelink: Unreal's Live Link Face recording (Timecode,
                  BlendShapeCount, the 52 blendshapes, head and eye angles in radians)
  .arkit.csv      --face arkit: frame,time,utterance, the 52 ARKit weights, the gaze
  .arkit.npz      the same as arrays (weights, names, gaze, time, utterance)
  .arkit.json     the same as JSON, a frame per line

The behaviour of a script, not its motion:
  .bml   --format bml: BML per utterance (speech with <sync> points at the marks, <gesture>,
         <gaze>, <faceLexeme>) for a realizer such as Greta; read back by 'sgt import'

--rig NAME retargets to another skeleton or robot:
  sgt     sgt's own joints (default)            .bvh .glb (.csv .json .npz as above)
  vrm     VRM humanoid bone names, T-pose       .glb .vrma .bvh
  mixamo  mixamorig: bone names, T-pose         .glb .bvh
  smplx   SMPL-X body joints                    .npz (SMPL-X/AMASS keys) .glb .bvh
  nao     NAO v6 joint angles (NAOqi names)     .json (angleInterpolation) .csv
  pepper  Pepper joint angles (NAOqi names)     .json (angleInterpolation) .csv

A script is one performance: every speaker has one continuous track over all of it
(its lines, listening motion between them). .json/.npz motion files hold all utterances and
tracks; every other format holds one speaker's track: with several speakers, one file per
speaker (take.bvh -> take.guide.bvh, take.visitor.bvh; take.livelink.csv ->
take.guide.livelink.csv) or, with --speaker NAME, one. A
sidecar OUT.timeline.json (take.bvh.timeline.json) says where each utterance starts in the
files (frames and seconds) and where its audio starts; CSV rows also name the utterance playing
(the timeline's "index" and the CSV's column count from 0). With --utterance N (the first is
1), only that utterance's own motion is written; --speaker with it must be its speaker. Motion files from before the
performance clock (version 1) have no tracks: their utterances are joined one after
another. '-o -' writes to standard output (JSON unless --format says otherwise). Formats
are documented in docs/formats.md."""

FORMATS = ("bvh", "csv", "json", "npz", "glb", "vrma", "bml")
#: The face's files (renders.face_export.FACE_KINDS; spelled out here so that --help imports no numpy).
FACE_KINDS = {"livelink": ("csv",), "arkit": ("csv", "npz", "json")}
#: What each --rig writes (renders.rigs owns the rigs; tests keep the names in step).
RIG_OUTPUTS = {
    "sgt": ("bvh", "glb", "csv", "json", "npz"),
    "vrm": ("glb", "vrma", "bvh"),
    "mixamo": ("glb", "bvh"),
    "smplx": ("npz", "glb", "bvh"),
    "nao": ("json", "csv"),
    "pepper": ("json", "csv"),
}


def register(sub) -> None:
    from sgt_tui.commands.common import utterance_number

    p = sub.add_parser("export", help=HELP, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="MOTION", help="motion file (.json/.npz) or script (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT", required=True,
                   help="output file: .bvh, .csv, .json, .npz, .glb, .vrma or .bml ('-': standard output, JSON unless --format)")
    p.add_argument("--format", choices=FORMATS, help="output format (default: from OUT's extension)")
    p.add_argument("--rig", choices=tuple(RIG_OUTPUTS), metavar="NAME",
                   help="target skeleton or robot: " + ", ".join(RIG_OUTPUTS) + " (default: sgt)")
    p.add_argument("--utterance", type=utterance_number, metavar="N", help="only utterance N (the first is 1)")
    p.add_argument("--speaker", metavar="NAME", help="only this speaker's track (one file)")
    p.add_argument("--face", choices=tuple(FACE_KINDS),
                   help="write the face instead of the body: livelink (Live Link Face .csv) or arkit (.csv, .npz, .json); "
                        "implied by OUT.livelink.csv, OUT.arkit.csv|npz|json")
    from sgt_tui.commands.render import add_script_options

    add_script_options(p)
    p.set_defaults(run=run)


def run(args) -> int:
    from sgt_tui.commands.clips import load_performance
    from sgt_tui.commands.common import STDOUT, inputs_of, output_file, output_format, shown
    from sgt_tui.errors import InputError, UsageError

    fmt = output_format(args.output, args.format, FORMATS, what="export")
    if fmt == "bml":
        return _export_bml(args)
    face = face_kind(args.output, args.face)
    if face is not None:
        if args.rig is not None:
            raise UsageError(f"--face {face} and --rig {args.rig}: the face's files are the same for every rig: drop --rig")
        if fmt not in FACE_KINDS[face]:
            raise UsageError(f"-o {args.output}: --face {face} writes {', '.join('.' + f for f in FACE_KINDS[face])}, "
                             f"not .{fmt}")
    rig = args.rig or ("vrm" if fmt == "vrma" else "sgt")
    if fmt not in RIG_OUTPUTS[rig]:
        raise UsageError(f"-o {args.output}: --rig {rig} writes {', '.join('.' + f for f in RIG_OUTPUTS[rig])}, not .{fmt}")
    binary = fmt in ("npz", "glb", "vrma")
    inputs = inputs_of(args.input)
    out = output_file(args.output, binary=binary, inputs=inputs)
    sidecar = None if args.output == STDOUT else output_file(str(timeline_path(out)), "-o", inputs=inputs)
    if sidecar is not None:  # named by sgt, not the user: never written through a link planted there
        from core.fileio import Inside

        from pathlib import Path

        if Path(sidecar).parent.is_dir():  # (a folder still to be made holds no link)
            with Inside(Path(sidecar).parent) as folder:
                folder.check(Path(sidecar).name)
    take = load_performance(args.input, args.utterance, engine=args.engine, seed=args.seed, speaker=args.speaker)

    from core.motion import save_motion
    from renders.clips import concat_clips, speaker_name, track_clip, utterance_frames

    clips, tracks = take.clips, take.tracks
    if args.speaker is not None:
        names = [speaker_name(t.speaker) for t in tracks] or sorted({speaker_name(c.speaker) for c in clips})
        if args.speaker not in names:
            raise UsageError(f"--speaker {args.speaker}: no such speaker in {args.input} (it has {', '.join(names)})")
        tracks = [t for t in tracks if speaker_name(t.speaker) == args.speaker]
        clips = [c for c in clips if speaker_name(c.speaker) == args.speaker]
    if face is None and rig == "sgt" and fmt in ("json", "npz"):
        save_motion(out, clips, format=fmt, tracks=tracks, source=take.source, engine=take.engine)
        print(f"wrote {shown(out)}: {plural(len(clips), 'utterance')}, {plural(len(tracks), 'track')}", file=sys.stderr)
        return 0
    if not tracks:  # one utterance, or a version 1 file: the utterances one after another
        outputs = [(out, concat_clips(clips), utterance_frames(sum(c.n_frames for c in clips), clips, joined=True))]
    elif len(tracks) == 1:
        outputs = [(out, track_clip(tracks[0], clips), utterance_frames(tracks[0].n_frames, clips))]
    else:
        if args.output == STDOUT:
            raise UsageError(f"-o -: {args.input} has {len(tracks)} speakers; name one with --speaker or write files")
        paths = speaker_paths(out, [speaker_name(t.speaker) for t in tracks], _face_suffix(args.output))
        outputs = [(output_file(str(p), binary=binary, inputs=inputs), track_clip(t, clips),
                    utterance_frames(t.n_frames, [c for c in clips if c.speaker == t.speaker]))
                   for p, t in zip(paths, tracks)]  # every output checked before the first is written
    if face is not None:
        faceless = [speaker_name(c.speaker) for _, c, _ in outputs if c.face is None]
        if faceless:
            raise InputError(f"{args.input} has no face for {', '.join(faceless)} (a motion file made before faces, "
                             "or generated without one): generate it again")
    for target, clip, frames in outputs:
        own = [u for u in dict.fromkeys(frames) if u is not None]
        note = _write(target, clip, rig, fmt, frames, face)
        print(f"wrote {shown(target)}: {plural(len(own), 'utterance')}, {plural(clip.n_frames, 'frame')}"
              + (f"; {note}" if note else ""),
              file=sys.stderr)
    if sidecar is not None:
        _write_timeline(sidecar, clips, [(o[0], o[1].speaker) for o in outputs], bool(tracks))
        print(f"wrote {shown(sidecar)}: where each utterance and its audio start", file=sys.stderr)
    return 0


def _export_bml(args) -> int:
    """``--format bml``: the script's behaviour (its marks on its words), from a script only."""
    from pathlib import Path

    from core.fileio import atomic_write_text
    from dsl.bml import write_bml
    from dsl.compiler import compile_file
    from sgt_tui.commands.common import exit_code, inputs_of, output_file, print_diagnostics, shown
    from sgt_tui.errors import UsageError
    from sgt_tui.progress import ProgressBar

    for option in ("rig", "face", "speaker", "utterance"):
        if getattr(args, option) is not None:
            raise UsageError(f"--{option} and BML: a BML file holds every utterance of the script; drop --{option}")
    if Path(args.input).suffix.lower() != ".sgt":
        raise UsageError(f"{args.input}: BML is written from a script (.sgt), whose marks stand on words; "
                         "a motion file has no words to put them on")
    out = output_file(args.output, inputs=inputs_of(args.input))
    result = compile_file(args.input, progress=ProgressBar("speech"))
    print_diagnostics(result.diagnostics, {args.input: result.script.source})
    if result.plan is None:
        return exit_code(result.diagnostics) or 1
    from library import load_library  # (the script's gestures, for their classes)

    text, notes = write_bml(result.script, result.plan, load_library(extra_dirs=result.script.header.library_dirs))
    atomic_write_text(out, text)
    print(f"wrote {shown(out)}: {plural(len(result.plan.utterances), 'BML block')}"
          + (f"; left out: {', '.join(notes)}" if notes else ""), file=sys.stderr)
    return exit_code(result.diagnostics)


def face_kind(output: str, chosen: str | None) -> str | None:
    """The face file an export writes: ``--face``, else what OUT's name says (``.livelink.csv``,
    ``.arkit.csv|npz|json``), else None (the body). A name that says another kind than ``--face``
    is a usage error."""
    from sgt_tui.errors import UsageError

    suffix = _face_suffix(output)
    named = suffix.split(".")[1] if suffix else None
    if chosen is not None and named is not None and named != chosen:
        raise UsageError(f"-o {output} is a {named} file, not --face {chosen}")
    return chosen or named


def _face_suffix(output: str) -> str | None:
    """``.livelink.EXT`` or ``.arkit.EXT`` when OUT's name ends with one (any case; EXT one of
    :data:`FORMATS`, so that ``x.livelink.json`` is refused, not taken for a motion file), else None."""
    name = output.lower()
    for kind in FACE_KINDS:
        for t in FORMATS:
            if name.endswith(f".{kind}.{t}") and len(name) > len(kind) + len(t) + 2:
                return output[-(len(kind) + len(t) + 2):]
    return None


def speaker_paths(out, names: list[str], suffix: str | None = None) -> list:
    """One file per speaker: take.bvh -> take.guide.bvh, take.visitor.bvh; with ``suffix`` (a
    face file's ``.livelink.csv``) the name goes before it: take.guide.livelink.csv. A name is
    made safe for a file name (no '/', NUL or leading dot: 'a/b' -> 'a_b'); names that end up
    alike get a number ('a_b', 'a_b-2')."""
    import re
    from pathlib import Path

    out, taken, paths = Path(out), set(), []
    stem, tail = out.stem, out.suffix
    if suffix and out.name.lower().endswith(suffix.lower()):
        stem, tail = out.name[:-len(suffix)], suffix
    for name in names:
        safe = re.sub(r"[/\\\x00]", "_", name).lstrip(".") or "speaker"
        candidate, n = safe, 1
        while candidate.lower() in taken:
            n += 1
            candidate = f"{safe}-{n}"
        taken.add(candidate.lower())
        paths.append(out.with_name(f"{stem}.{candidate}{tail}"))
    return paths


def timeline_path(out):
    """The sidecar of an export, named after it so that several exports of one take keep theirs:
    take.bvh -> take.bvh.timeline.json."""
    from pathlib import Path

    out = Path(out)
    return out.with_name(out.name + ".timeline.json")


def _write(target, clip, rig: str, fmt: str, frames, face: str | None = None) -> str:
    if face is not None:
        from core.fileio import atomic_write
        from renders.face_export import face_bytes

        atomic_write(target, face_bytes(clip, face, fmt, frames))
        return "Live Link Face" if face == "livelink" else "ARKit weights and gaze"
    from renders.export import write_bvh, write_csv

    if rig == "sgt" and fmt in ("bvh", "csv"):
        if fmt == "bvh":
            write_bvh(target, clip)
        else:
            write_csv(target, clip, frames)
        return ""
    from renders.rig_export import write_rig_file

    return write_rig_file(target, clip, rig, "." + fmt)


def _write_timeline(path, clips, files, tracked: bool) -> None:
    """The sidecar: per utterance its speaker, text, first frame, frames, start and audio
    offset on the exported files' clock, and which file holds each speaker."""
    from pathlib import Path

    from core.fileio import Inside, json_bytes
    from core.skeleton import FPS
    from renders.clips import speaker_name

    at, rows = 0, []
    for i, c in enumerate(clips):
        start = c.start_frame if tracked else at
        at += c.n_frames
        rows.append({"index": i if c.index is None else c.index, "speaker": c.speaker, "text": c.text,
                     "start_frame": start, "frames": c.n_frames, "start": round(start / FPS, 6),
                     "audio_offset": None if c.audio_offset is None else round(c.audio_offset, 6)})
    doc = {"fps": FPS, "files": {speaker_name(s): Path(str(p)).name for p, s in files}, "utterances": rows}
    path = Path(path)
    with Inside(path.parent, create=True) as folder:  # a name sgt chose: no link planted there is followed
        folder.write(path.name, json_bytes(doc, indent=1) + b"\n")
