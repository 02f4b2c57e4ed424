"""sgt export: motion -> BVH (joint rotations), CSV (joint positions), JSON or NPZ; glTF and
other rigs (VRM, Mixamo, SMPL-X, NAO/Pepper) with --rig."""

from __future__ import annotations

import argparse
import sys

HELP = "export motion as BVH, CSV, JSON, NPZ or glTF, for sgt's skeleton or another rig"
DESCRIPTION = """\
Export a motion file (or a script, generated first) by the output's extension:

  .bvh   upper-body hierarchy with joint rotations (ZXY Euler, degrees), metres, 1/15 s
  .csv   one row per frame: frame,time,<joint>_x,<joint>_y,<joint>_z,... in metres
  .json  sgt motion file (all utterances kept)
  .npz   sgt motion file, binary
  .glb   glTF 2.0 binary: skeleton, skinned mannequin, animation (15 fps)
  .vrma  VRM Animation (the .glb of --rig vrm)

--rig NAME retargets to another skeleton or robot:
  sgt     sgt's own joints (default)            .bvh .glb (.csv .json .npz as above)
  vrm     VRM humanoid bone names, T-pose       .glb .vrma .bvh
  mixamo  mixamorig: bone names, T-pose         .glb .bvh
  smplx   SMPL-X body joints                    .npz (SMPL-X/AMASS keys) .glb .bvh
  nao     NAO v6 joint angles (NAOqi names)     .json (angleInterpolation) .csv
  pepper  Pepper joint angles (NAOqi names)     .json (angleInterpolation) .csv

All but .json/.npz motion files hold one take: without --utterance the utterances are
joined one after another. Formats are documented in docs/formats.md."""

SUFFIXES = (".bvh", ".csv", ".json", ".npz", ".glb", ".vrma")
#: What each --rig writes (renders.rigs owns the rigs; tests keep the names in step).
RIG_OUTPUTS = {
    "sgt": (".bvh", ".glb", ".csv", ".json", ".npz"),
    "vrm": (".glb", ".vrma", ".bvh"),
    "mixamo": (".glb", ".bvh"),
    "smplx": (".npz", ".glb", ".bvh"),
    "nao": (".json", ".csv"),
    "pepper": (".json", ".csv"),
}


def register(sub) -> None:
    p = sub.add_parser("export", help=HELP, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="MOTION", help="motion file (.json/.npz) or script (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="output file: .bvh, .csv, .json, .npz, .glb or .vrma")
    p.add_argument("--rig", choices=tuple(RIG_OUTPUTS), metavar="NAME",
                   help="target skeleton or robot: " + ", ".join(RIG_OUTPUTS) + " (default: sgt)")
    p.add_argument("--utterance", type=int, metavar="N", help="only utterance N (0-based)")
    from sgt_tui.commands.render import add_script_options

    add_script_options(p)
    p.set_defaults(run=run)


def run(args) -> int:
    from pathlib import Path

    from sgt_tui.commands.render import InputError, load_clips, report_input_error
    from sgt_tui.errors import UsageError

    suffix = Path(args.output).suffix.lower()
    if suffix not in SUFFIXES:
        raise UsageError(f"-o {args.output}: unknown export type '{suffix or '(none)'}' (use {', '.join(SUFFIXES)})")
    rig = args.rig or ("vrm" if suffix == ".vrma" else "sgt")
    if suffix not in RIG_OUTPUTS[rig]:
        raise UsageError(f"-o {args.output}: --rig {rig} writes {', '.join(RIG_OUTPUTS[rig])}, not {suffix}")
    if args.utterance is not None and args.utterance < 0:
        raise UsageError(f"--utterance must be 0 or more, not {args.utterance}")
    try:
        clips = load_clips(args.input, args.utterance, args.engine, args.seed)
    except InputError as exc:
        return report_input_error("export", exc)

    from core.motion import MotionFileError, save_motion
    from renders.clips import concat_clips
    from renders.export import write_bvh, write_csv

    note = ""
    try:
        if rig == "sgt" and suffix in (".json", ".npz"):
            save_motion(args.output, clips)
            frames = sum(c.n_frames for c in clips)
        elif rig == "sgt" and suffix in (".bvh", ".csv"):
            clip = concat_clips(clips)
            (write_bvh if suffix == ".bvh" else write_csv)(args.output, clip)
            frames = clip.n_frames
        else:
            from renders.rig_export import write_rig_file

            clip = concat_clips(clips)
            note = write_rig_file(args.output, clip, rig, suffix)
            frames = clip.n_frames
    except (OSError, MotionFileError) as exc:
        print(f"sgt export: error: cannot write {args.output}: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {args.output}: {len(clips)} utterance(s), {frames} frames" + (f"; {note}" if note else ""), file=sys.stderr)
    return 0
