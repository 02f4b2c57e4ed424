"""sgt export: motion -> BVH (joint rotations), CSV (joint positions), JSON or NPZ."""

from __future__ import annotations

import argparse
import sys

HELP = "export motion as BVH, CSV, JSON or NPZ"
DESCRIPTION = """\
Export a motion file (or a script, generated first) by the output's extension:

  .bvh   upper-body hierarchy with joint rotations (ZXY Euler, degrees), metres, 1/15 s
  .csv   one row per frame: frame,time,<joint>_x,<joint>_y,<joint>_z,... in metres
  .json  sgt motion file (all utterances kept)
  .npz   sgt motion file, binary

BVH and CSV hold one take: without --utterance the utterances are joined one after
another. Formats are documented in docs/formats.md."""

SUFFIXES = (".bvh", ".csv", ".json", ".npz")


def register(sub) -> None:
    p = sub.add_parser("export", help=HELP, description=DESCRIPTION,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="MOTION", help="motion file (.json/.npz) or script (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="output file: .bvh, .csv, .json or .npz")
    p.add_argument("--utterance", type=int, metavar="N", help="only utterance N (0-based)")
    from sgt_tui.commands.render import add_script_options

    add_script_options(p)
    p.set_defaults(run=run)


def run(args) -> int:
    from pathlib import Path

    from sgt_tui.errors import UsageError
    from sgt_tui.commands.render import InputError, load_clips, report_input_error

    suffix = Path(args.output).suffix.lower()
    if suffix not in SUFFIXES:
        raise UsageError(f"-o {args.output}: unknown export type '{suffix or '(none)'}' (use .bvh, .csv, .json or .npz)")
    if args.utterance is not None and args.utterance < 0:
        raise UsageError(f"--utterance must be 0 or more, not {args.utterance}")
    try:
        clips = load_clips(args.input, args.utterance, args.engine, args.seed)
    except InputError as exc:
        return report_input_error("export", exc)

    from core.motion import MotionFileError, save_motion
    from renders.clips import concat_clips
    from renders.export import write_bvh, write_csv

    try:
        if suffix in (".json", ".npz"):
            save_motion(args.output, clips)
            frames = sum(c.n_frames for c in clips)
        else:
            clip = concat_clips(clips)
            (write_bvh if suffix == ".bvh" else write_csv)(args.output, clip)
            frames = clip.n_frames
    except (OSError, MotionFileError) as exc:
        print(f"sgt export: error: cannot write {args.output}: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {args.output}: {len(clips)} utterance(s), {frames} frames", file=sys.stderr)
    return 0
