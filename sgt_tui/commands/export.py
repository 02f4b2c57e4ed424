"""sgt export: motion -> BVH (joint rotations), CSV (joint positions), JSON or NPZ."""

from __future__ import annotations

import argparse
import sys

HELP = "export motion as BVH, CSV, JSON or NPZ"
DESCRIPTION = """\
Export a motion file (or a script, generated first) by the output's extension, or
--format ('-o -' writes to standard output: JSON unless --format says otherwise):

  .bvh   upper-body hierarchy with joint rotations (ZXY Euler, degrees), metres, 1/15 s
  .csv   one row per frame: frame,time,<joint>_x,<joint>_y,<joint>_z,... in metres
  .json  sgt motion file (all utterances kept)
  .npz   sgt motion file, binary

BVH and CSV hold one take: without --utterance the utterances are joined one after
another. Formats are documented in docs/formats.md."""

FORMATS = ("bvh", "csv", "json", "npz")


def register(sub) -> None:
    from sgt_tui.commands.common import utterance_number

    p = sub.add_parser("export", help=HELP, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="MOTION", help="motion file (.json/.npz) or script (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT", required=True,
                   help="output file: .bvh, .csv, .json or .npz ('-': standard output, JSON unless --format)")
    p.add_argument("--format", choices=FORMATS, help="output format (default: from OUT's extension)")
    p.add_argument("--utterance", type=utterance_number, metavar="N", help="only utterance N (0-based)")
    from sgt_tui.commands.render import add_script_options

    add_script_options(p)
    p.set_defaults(run=run)


def run(args) -> int:
    from sgt_tui.commands.clips import load_clips
    from sgt_tui.commands.common import output_file, output_format, shown

    fmt = output_format(args.output, args.format, FORMATS, what="export")
    out = output_file(args.output, binary=fmt == "npz")
    clips = load_clips(args.input, args.utterance, engine=args.engine, seed=args.seed)

    from core.motion import save_motion
    from renders.clips import concat_clips
    from renders.export import write_bvh, write_csv

    if fmt in ("json", "npz"):
        save_motion(out, clips, format=fmt)
        frames = sum(c.n_frames for c in clips)
    else:
        clip = concat_clips(clips)
        (write_bvh if fmt == "bvh" else write_csv)(out, clip)
        frames = clip.n_frames
    print(f"wrote {shown(out)}: {len(clips)} utterance(s), {frames} frames", file=sys.stderr)
    return 0
