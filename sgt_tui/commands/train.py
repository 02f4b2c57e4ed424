"""sgt train: train the controllable generator on a corpus (CPU)."""

from __future__ import annotations

import argparse

HELP = "train the gesture generator on a corpus"
DESCRIPTION = """\
Train the controllable generator (SGToolkit Eq. 7: Huber pose term, adversarial term,
style-consistency term) on a corpus made by 'sgt corpus'. Checkpoints after every
epoch; running the same command again resumes. Per-epoch metrics go to
OUT/metrics.jsonl and the weights to OUT/generator.pt (copy them to
model/weights/generator.pt to ship them)."""


def register(sub) -> None:
    from model.train_config import TrainConfig

    p = sub.add_parser("train", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--corpus", default="data/corpus", help="corpus folder (default data/corpus)")
    p.add_argument("-o", "--out", default="runs/default", help="output folder (default runs/default)")
    p.add_argument("--epochs", type=int, default=TrainConfig.epochs, help=f"epochs (default {TrainConfig.epochs})")
    p.add_argument("--steps", type=int, default=TrainConfig.steps_per_epoch, help=f"steps per epoch (default {TrainConfig.steps_per_epoch})")
    p.add_argument("--batch", type=int, default=TrainConfig.batch, help=f"windows per step (default {TrainConfig.batch})")
    p.add_argument("--threads", type=int, default=TrainConfig.threads, help=f"CPU threads (default {TrainConfig.threads})")
    p.add_argument("--minutes", type=float, help="stop after this much time (at the end of an epoch)")
    p.add_argument("--no-gan", action="store_true", help="switch the adversarial term off")
    p.add_argument("--ctrl-weight", type=float, default=TrainConfig.ctrl,
                   help=f"weight of the L1 term on pose-controlled frames, 0 = off (default {TrainConfig.ctrl:g})")
    p.add_argument("--vel-weight", type=float, default=TrainConfig.vel,
                   help=f"weight of the L1 velocity term, 0 = off (default {TrainConfig.vel:g})")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--fresh", action="store_true", help="ignore an existing checkpoint")
    p.add_argument("--hidden", type=int, default=128, help="network width")
    p.add_argument("--no-gru", action="store_true", help="convolutions only (faster, see docs/model.md)")
    p.set_defaults(run=run)


def run(args) -> int:
    import sys
    from pathlib import Path

    from model.train import TrainConfig, train
    from sgt_tui.progress import ProgressBar

    corpus = Path(args.corpus)
    try:
        from model.corpus import load_corpus

        train_clips = load_corpus(corpus, "train")
        val_clips = load_corpus(corpus, "val")
    except (FileNotFoundError, ValueError) as exc:
        print(f"sgt train: error: cannot load the corpus at {corpus}: {exc}\n  make one with: sgt corpus -o {corpus}", file=sys.stderr)
        return 1
    cfg = TrainConfig(epochs=args.epochs, steps_per_epoch=args.steps, batch=args.batch, minutes=args.minutes,
                      beta=0.0 if args.no_gan else TrainConfig.beta, seed=args.seed,
                      threads=args.threads, ctrl=args.ctrl_weight, vel=args.vel_weight,
                      net={"hidden": args.hidden, "gru": not args.no_gru})
    train(train_clips, val_clips, Path(args.out), cfg, resume=not args.fresh, progress=ProgressBar("train"),
          log=lambda s: print(s, file=sys.stderr))
    print(f"weights: {Path(args.out) / 'generator.pt'}", file=sys.stderr)
    return 0
