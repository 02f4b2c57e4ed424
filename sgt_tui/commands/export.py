"""sgt export: motion -> BVH (joint rotations), CSV (joint positions), JSON or NPZ; glTF and
other rigs (VRM, Mixamo, SMPL-X, NAO/Pepper) with --rig."""

from __future__ import annotations

import argparse
import sys

HELP = "export motion as BVH, CSV, JSON, NPZ or glTF, for sgt's skeleton or another rig"
DESCRIPTION = """\
Export a motion file (or a script, generated first) by the output's extension, or
--format ('-o -' writes to standard output: JSON unless --format says otherwise):

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
joined one after another. '-o -' writes to standard output (JSON unless --format says
otherwise). Formats are documented in docs/formats.md."""

FORMATS = ("bvh", "csv", "json", "npz", "glb", "vrma")
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
                   help="output file: .bvh, .csv, .json, .npz, .glb or .vrma ('-': standard output, JSON unless --format)")
    p.add_argument("--format", choices=FORMATS, help="output format (default: from OUT's extension)")
    p.add_argument("--rig", choices=tuple(RIG_OUTPUTS), metavar="NAME",
                   help="target skeleton or robot: " + ", ".join(RIG_OUTPUTS) + " (default: sgt)")
    p.add_argument("--utterance", type=utterance_number, metavar="N", help="only utterance N (0-based)")
    from sgt_tui.commands.render import add_script_options

    add_script_options(p)
    p.set_defaults(run=run)


def run(args) -> int:
    from sgt_tui.commands.clips import load_clips
    from sgt_tui.commands.common import output_file, output_format, shown

    from sgt_tui.commands.clips import load_clips
    from sgt_tui.commands.common import output_file, output_format, shown
    from sgt_tui.errors import UsageError

    fmt = output_format(args.output, args.format, FORMATS, what="export")
    rig = args.rig or ("vrm" if fmt == "vrma" else "sgt")
    if fmt not in RIG_OUTPUTS[rig]:
        raise UsageError(f"-o {args.output}: --rig {rig} writes {', '.join('.' + f for f in RIG_OUTPUTS[rig])}, not .{fmt}")
    out = output_file(args.output, binary=fmt in ("npz", "glb", "vrma"))
    clips = load_clips(args.input, args.utterance, engine=args.engine, seed=args.seed)

    from core.motion import save_motion
    from renders.clips import concat_clips
    from renders.export import write_bvh, write_csv

    note = ""
    if rig == "sgt" and fmt in ("json", "npz"):
        save_motion(out, clips, format=fmt)
        frames = sum(c.n_frames for c in clips)
    else:
        clip = concat_clips(clips)
        frames = clip.n_frames
        if rig == "sgt" and fmt in ("bvh", "csv"):
            (write_bvh if fmt == "bvh" else write_csv)(out, clip)
        else:
            from renders.rig_export import write_rig_file

            note = write_rig_file(out, clip, rig, "." + fmt)
    print(f"wrote {shown(out)}: {len(clips)} utterance(s), {frames} frames" + (f"; {note}" if note else ""), file=sys.stderr)
    return 0
