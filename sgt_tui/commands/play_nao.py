"""sgt play-nao: play a NAO or Pepper take on the robot with its speech (renders/naoqi_play.py)."""

from __future__ import annotations

import sys

HELP = "play a NAO/Pepper take (sgt export --rig nao) on the robot with its speech"
DESCRIPTION = """\
Play TAKE (the angleInterpolation file of 'sgt export --rig nao|pepper -o take.nao.json') on
a robot through NAOqi's Python 3 'qi' API: wake the motion up, load the speech on the robot,
move to the take's first key (at most 1 rad/s, at least 1 s) and wait there, then start the
audio (ALAudioPlayer.play) and the rest of the take (ALMotion.angleInterpolation) together,
as two asynchronous calls, so that frame i lands i/15 s into the audio. --dry-run prints the
calls with their times and needs no robot.

The audio is a WAV on the robot whose sample 0 is the take's frame 0, as 'sgt say --mix'
writes it; copy it there first:
  sgt say take.sgt -o speech --mix take.wav
  scp take.wav nao@ROBOT:/home/nao/take.wav
  sgt play-nao take.nao.json --url tcp://ROBOT:9559 --audio /home/nao/take.wav
"""


def register(sub) -> None:
    import argparse

    p = sub.add_parser("play-nao", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("take", metavar="TAKE", help="the .json of 'sgt export --rig nao|pepper'")
    p.add_argument("--url", default="tcp://127.0.0.1:9559", help="the robot's NAOqi (default: tcp://127.0.0.1:9559)")
    p.add_argument("--audio", metavar="PATH", help="the speech, a WAV at this path on the robot (none: motion only)")
    p.add_argument("--no-wake", action="store_true", help="do not call ALMotion.wakeUp first")
    p.add_argument("--dry-run", action="store_true", help="print the calls instead of making them")
    p.set_defaults(run=run)


def run(args) -> int:
    from core.reading import loads_json, read_bytes
    from renders.naoqi_play import DrySession, TakeError, connect, play, read_take
    from sgt_tui.errors import InputError

    try:
        take = read_take(loads_json(read_bytes(args.take, "motion file")))
    except (TakeError, ValueError) as exc:  # (a JSON error is a ValueError)
        raise InputError(f"{args.take}: {exc}") from None
    if args.dry_run:
        session = DrySession(sys.stdout)
    else:
        try:
            session = connect(args.url)
        except (ImportError, RuntimeError) as exc:
            raise InputError(str(exc)) from None
    result = play(session, take, args.audio, wake=not args.no_wake)
    print(("dry run: would play" if args.dry_run else "played") + f" {take.n_frames} frames ({take.n_frames / 15:.2f} s) of {len(take.names)} joints after "
          f"{result['settle']:.2f} s to the first key; audio and motion started {result['skew'] * 1000:.1f} ms apart",
          file=sys.stderr)
    return 0
