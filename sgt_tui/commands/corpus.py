"""sgt corpus: build the procedural training corpus (TTS speech + rule-based teacher motion)."""

from __future__ import annotations

import argparse

HELP = "build the procedural training corpus (speech + teacher motion)"
DESCRIPTION = """\
Build a reproducible training corpus for the neural generator: English sentences from
Debian's fortunes files, spoken by espeak-ng with varied voices, rates and pitches, audio
augmented (tempo, pitch, gain, reverb, band limit, noise), and motion from the rule-based
teacher with a random style per clip. The same --seed gives the same corpus; an interrupted
run resumes, keeping finished shards. Needs: apt-get install fortunes fortunes-min."""


def register(sub) -> None:
    from sgt_tui.commands.common import positive_float, positive_int, seed

    p = sub.add_parser("corpus", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--out", metavar="DIR", default="data/corpus", help="output folder (default: data/corpus)")
    p.add_argument("--hours", type=positive_float, default=2.0, help="at least this many hours of motion (default: 2)")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    p.add_argument("--jobs", type=positive_int, default=1, metavar="N", help="worker processes (default: 1)")
    p.add_argument("--clips-per-shard", type=positive_int, default=None, metavar="N", help=argparse.SUPPRESS)
    p.set_defaults(run=run)


def run(args) -> int:
    import sys
    import time

    from sgt_tui.commands.common import output_folder
    from sgt_tui.errors import InputError
    from sgt_tui.progress import ProgressBar

    output_folder(args.out)
    from model.training.corpus import CorpusError, build_corpus

    started = time.monotonic()
    try:
        m = build_corpus(args.out, hours=args.hours, seed=args.seed, jobs=args.jobs,
                         clips_per_shard=args.clips_per_shard, progress=ProgressBar("corpus"),
                         log=lambda s: print(s, file=sys.stderr))
    except CorpusError as exc:
        raise InputError(str(exc)) from None
    counts = ", ".join(f"{k} {v}" for k, v in m["split_counts"].items())
    print(f"{args.out}: {len(m['clips'])} clips ({counts}), {m['total_hours']:.2f} h of motion, "
          f"built in {time.monotonic() - started:.0f} s")
    return 0
