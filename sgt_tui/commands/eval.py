"""sgt eval: the metrics table (SGToolkit Table 1, Kucherenko et al. Tables 1-3) on held-out data."""

from __future__ import annotations

import argparse

HELP = "evaluate the generator on the held-out split (FGD, PCS, SCS, jerk, Hellinger...)"
DESCRIPTION = """\
Evaluate the generator and the baselines on a held-out split of the corpus and print a
table like SGToolkit's Table 1, with Kucherenko et al.'s motion statistics: FGD (features
of the shipped motion autoencoder), PCS (a 5-frame pose control mid-clip, with and without
the exact blend), SCS (style controls from the reference), APE, speed, acceleration and
jerk (and jerk relative to the reference), Hellinger distances of speed histograms for
all joints, elbows and wrists, and the beat alignment of the motion with the speech onsets
(with shuffled-audio rows for the model's and the teacher's chance level). Then requested
versus achieved style for -2, -1, +1, +2 on each style dimension, with the slope
(--no-style skips it). See
docs/metrics.md."""


def register(sub) -> None:
    from sgt_tui.commands.common import DEFAULT_ENGINE, EVAL_ENGINES, SMOOTHING_CHOICES, add_take_posture_option, positive_int, seed

    p = sub.add_parser("eval", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--corpus", default="data/corpus", help="corpus folder (default data/corpus)")
    p.add_argument("--split", default="test", choices=("test", "val", "train", "all"),
                   help="which clips (default test); 'all': every clip, for a held-out corpus built with another "
                        "seed (sgt corpus -o data/heldout --hours 1 --seed 1), whose FGD is steadier: see docs/metrics.md")
    p.add_argument("--engine", choices=EVAL_ENGINES, default=DEFAULT_ENGINE,
                   help=f"the engine of the model rows: {' or '.join(EVAL_ENGINES)} (default {DEFAULT_ENGINE})")
    p.add_argument("--weights", help="generator weights (default: the shipped ones)")
    p.add_argument("--database", metavar="PATH",
                   help="the matching engine's database (default: the shipped model/weights/matching_db.npz)")
    p.add_argument("--extractor", default="default", help="FGD feature extractor weights (default: the shipped ones)")
    p.add_argument("-o", "--output", metavar="JSON",
                   help="also write the rows as JSON ('-': standard output, the tables then go to stderr)")
    p.add_argument("--limit", type=positive_int, help="only the first N clips (quick look)")
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument("--no-style", action="store_true", help="skip the requested-versus-achieved style table")
    p.add_argument("--smoothing", choices=SMOOTHING_CHOICES, default=None,
                   help="the post-filter of the model rows (default: the engine's, as sgt generate: one_euro for "
                        "neural, none for matching)")
    add_take_posture_option(p)
    p.set_defaults(run=run)


def run(args) -> int:
    import json
    import sys
    from pathlib import Path

    from core.fileio import atomic_write_text
    from sgt_tui.commands.common import existing_file, is_stdout, output_file, shown
    from sgt_tui.errors import InputError

    if not Path(args.corpus).exists():
        raise InputError(f"--corpus {args.corpus}: no such corpus; make one with: sgt corpus -o {args.corpus}")
    weights = str(existing_file(args.weights)) if args.weights else None
    database = str(existing_file(args.database)) if args.database else None
    extractor = args.extractor if args.extractor == "default" else str(existing_file(args.extractor))
    out = output_file(args.output, inputs=[weights, database, None if extractor == "default" else extractor]) if args.output else None

    from model.matching import DatabaseError
    from model.training.corpus import CorpusError
    from model.training.evaluate import evaluate_corpus, format_style_following
    from model.training.fgd import ExtractorError
    from model.training.metrics import format_table
    from model.weights import WeightsError
    from sgt_tui.progress import ProgressBar

    try:
        result = evaluate_corpus(args.corpus, split=args.split, weights=weights, extractor=extractor,
                                 seed=args.seed, progress=ProgressBar("eval"), limit=args.limit,
                                 smoothing=args.smoothing, with_style=not args.no_style,
                                 takes=not args.no_take_posture, engine=args.engine, database=database)
    except (WeightsError, ExtractorError, CorpusError, DatabaseError) as exc:
        raise InputError(str(exc)) from None
    except (FileNotFoundError, ValueError) as exc:
        raise InputError(f"{exc}\n  make a corpus with: sgt corpus -o {args.corpus}") from None
    rows, style = (result, None) if args.no_style else result
    table = sys.stderr if out is not None and is_stdout(out) else sys.stdout
    print(format_table(rows), file=table)
    if style is not None:
        print(format_style_following(style), file=table)
    if out is not None:
        clean = [{k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()} for r in rows]
        atomic_write_text(out, json.dumps({"conditions": clean, "style_following": style}, indent=2) + "\n")
        if not is_stdout(out):
            print(f"wrote {shown(out)}", file=sys.stderr)
    return 0
