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
    p = sub.add_parser("corpus", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--out", metavar="DIR", default="data/corpus", help="output folder (default: data/corpus)")
    p.add_argument("--hours", type=float, default=2.0, help="at least this many hours of motion (default: 2)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    p.add_argument("--jobs", type=int, default=1, metavar="N", help="worker processes (default: 1)")
    p.add_argument("--clips-per-shard", type=int, default=None, metavar="N", help=argparse.SUPPRESS)
    p.set_defaults(run=run)


def run(args) -> int:
    import sys
    import time

    from sgt_tui.errors import UsageError
    from sgt_tui.progress import ProgressBar

    if args.hours <= 0:
        raise UsageError("--hours must be positive")
    if args.jobs < 1:
        raise UsageError("--jobs must be at least 1")
    from model.training.corpus import CorpusError, build_corpus

    started = time.monotonic()
    try:
        m = build_corpus(args.out, hours=args.hours, seed=args.seed, jobs=args.jobs,
                         clips_per_shard=args.clips_per_shard, progress=ProgressBar("corpus"),
                         log=lambda s: print(s, file=sys.stderr))
    except CorpusError as exc:
        print(f"sgt corpus: error: {exc}", file=sys.stderr)
        return 1
    counts = ", ".join(f"{k} {v}" for k, v in m["split_counts"].items())
    print(f"{args.out}: {len(m['clips'])} clips ({counts}), {m['total_hours']:.2f} h of motion, "
          f"built in {time.monotonic() - started:.0f} s")
    return 0
