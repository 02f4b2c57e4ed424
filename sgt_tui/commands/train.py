"""sgt train: train the controllable generator on a corpus (CPU)."""

from __future__ import annotations

import argparse

HELP = "train the gesture generator on a corpus"
DESCRIPTION = """\
Train the controllable generator (SGToolkit Eq. 7: Huber pose term, adversarial term,
style-consistency term) on a corpus made by 'sgt corpus', or on your own BVH takes
(--data). The learning rate follows a cosine decay over the epochs. Checkpoints after
every epoch; running the same command again resumes. Runs on several processes or GPUs
when launched by torchrun (DistributedDataParallel; gloo on CPU, NCCL on CUDA), e.g.
'torchrun --nproc_per_node 4 -m sgt_tui.cli train --corpus DIR -o OUT'; --batch is then
the global batch, split over the processes. Per-epoch losses and validation
figures go to OUT/metrics.jsonl; OUT/generator.pt holds the weights of the epoch with the
best validation score (PCS/0.014 + SCS/0.249), OUT/last.pt the last epoch's. Copy
OUT/generator.pt to model/weights/generator.pt to ship it."""


def register(sub) -> None:
    from model.training.train_config import TrainConfig
    from sgt_tui.commands.common import non_negative_float, non_negative_int, positive_float, positive_int, seed, share

    p = sub.add_parser("train", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    src = p.add_mutually_exclusive_group()
    src.add_argument("--corpus", default="data/corpus", help="corpus folder made by 'sgt corpus' (default data/corpus)")
    src.add_argument("--data", metavar="DIR",
                     help="train on your own motion instead: BVH takes with WAV audio and TextGrid/JSON word "
                          "timings, in the GENEA/Trinity layout (Motion/, Audio/, Transcripts/) or one flat folder; "
                          "the last tenth of the takes (at least one) is the validation split")
    p.add_argument("-o", "--out", default="runs/default", help="output folder (default runs/default)")
    p.add_argument("--epochs", type=positive_int, default=TrainConfig.epochs, help=f"epochs (default {TrainConfig.epochs})")
    p.add_argument("--steps", type=positive_int, default=TrainConfig.steps_per_epoch, help=f"steps per epoch (default {TrainConfig.steps_per_epoch})")
    p.add_argument("--batch", type=positive_int, default=TrainConfig.batch, help=f"windows per step (default {TrainConfig.batch})")
    p.add_argument("--threads", type=positive_int, default=TrainConfig.threads, help=f"CPU threads (default {TrainConfig.threads})")
    p.add_argument("--minutes", type=positive_float, help="stop after this much time (at the end of an epoch)")
    p.add_argument("--no-gan", action="store_true", help="switch the adversarial term off")
    p.add_argument("--gan-weight", type=non_negative_float, default=TrainConfig.beta,
                   help=f"weight of the adversarial term (default {TrainConfig.beta:g}; --no-gan sets 0)")
    p.add_argument("--ctrl-weight", type=non_negative_float, default=TrainConfig.ctrl,
                   help=f"weight of the L1 term on pose-controlled frames, 0 = off (default {TrainConfig.ctrl:g})")
    p.add_argument("--style-weight", type=non_negative_float, default=TrainConfig.gamma,
                   help=f"weight of the style-consistency term (Eq. 7 gamma; default {TrainConfig.gamma:g})")
    p.add_argument("--vel-weight", type=non_negative_float, default=TrainConfig.vel,
                   help=f"weight of the L1 velocity term, 0 = off (default {TrainConfig.vel:g})")
    p.add_argument("--hist-weight", type=non_negative_float, default=TrainConfig.hist,
                   help="weight of the Hellinger distance between the generated and reference joint-speed histograms "
                        f"(too few still and fast frames is what a regression makes), 0 = off (default {TrainConfig.hist:g})")
    p.add_argument("--kl", type=non_negative_float, default=TrainConfig.kl,
                   help="KL weight of the conditional-VAE noise: a training-only encoder reads each reference window "
                        f"so that each seed is a different take, not the average one; 0 = off (default {TrainConfig.kl:g})")
    p.add_argument("--p-prior", type=share, default=TrainConfig.p_prior,
                   help="with --kl: share of uncontrolled training windows whose noise comes from the prior (windows with "
                        f"controls always get the prior's; default {TrainConfig.p_prior:g})")
    p.add_argument("--restyle", type=share, default=TrainConfig.p_restyle, metavar="P",
                   help="share of speech windows trained on a style request other than their own, with the style "
                        f"and adversarial terms only, so style controls reach the whole range (default {TrainConfig.p_restyle:g})")
    p.add_argument("--window", type=positive_int, default=TrainConfig.window,
                   help=f"training window in frames (default {TrainConfig.window})")
    p.add_argument("--device", choices=("auto", "cpu"), default=TrainConfig.device,
                   help="auto: CUDA when present, else the CPU (default auto)")
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument("--fresh", action="store_true", help="ignore an existing checkpoint")
    p.add_argument("--hidden", type=positive_int, default=128, help="network width")
    p.add_argument("--no-gru", action="store_true", help="convolutions only (faster, see docs/model.md)")
    p.add_argument("--smooth", type=non_negative_int, default=5, metavar="TAPS",
                   help="taps of the in-network low-pass on free frames, 0 = off (default 5, see docs/model.md)")
    p.set_defaults(run=run)


def run(args) -> int:
    import sys
    from pathlib import Path

    from sgt_tui.commands.common import existing_folder, output_folder
    from sgt_tui.errors import InputError

    if args.data:
        existing_folder(args.data, "--data")
    elif not Path(args.corpus).exists():
        raise InputError(f"--corpus {args.corpus}: no such corpus; make one with: sgt corpus -o {args.corpus}")
    output_folder(args.out)

    from model.training.train import TrainConfig, train
    from sgt_tui.progress import ProgressBar

    if args.data:
        loaded = _user_data(Path(args.data))
        if loaded is None:
            return 1
        train_clips, val_clips = loaded
    else:
        corpus = Path(args.corpus)
        from model.training.corpus import CorpusError, load_corpus

        try:
            train_clips = load_corpus(corpus, "train")
            val_clips = load_corpus(corpus, "val")
        except (CorpusError, OSError, ValueError) as exc:
            raise InputError(f"cannot load the corpus at {corpus}: {exc}\n  make one with: sgt corpus -o {corpus}") from None
    cfg = TrainConfig(epochs=args.epochs, steps_per_epoch=args.steps, batch=args.batch, minutes=args.minutes,
                      beta=0.0 if args.no_gan else args.gan_weight, seed=args.seed,
                      threads=args.threads, gamma=args.style_weight, ctrl=args.ctrl_weight, vel=args.vel_weight, hist=args.hist_weight,
                      kl=args.kl, p_prior=args.p_prior, p_restyle=args.restyle, window=args.window, device=args.device,
                      net={"hidden": args.hidden, "gru": not args.no_gru, "smooth": args.smooth})
    try:
        train(train_clips, val_clips, Path(args.out), cfg, resume=not args.fresh, progress=ProgressBar("train"),
              log=lambda s: print(s, file=sys.stderr))
    except ValueError as exc:  # e.g. no clip as long as a training window
        print(f"sgt train: error: {exc}", file=sys.stderr)
        return 1
    print(f"weights: {Path(args.out) / 'generator.pt'} (best validation epoch); last epoch: {Path(args.out) / 'last.pt'}",
          file=sys.stderr)
    return 0


def _user_data(root):
    """(train, val) clips from a BVH folder (model/loaders.py), or None after printing the error."""
    import sys

    from model.features import silence_features
    from model.training.loaders import LoaderError, load_folder

    try:
        clips = load_folder(root)
    except LoaderError as exc:
        print(f"sgt train: error: {exc}", file=sys.stderr)
        return None
    for c in clips:
        if "audio" not in c:
            print(f"sgt train: warning: take '{c['id']}' has no audio; it trains with silence", file=sys.stderr)
            c["audio"] = silence_features(len(c["poses"]))
    if len(clips) < 2:
        print(f"sgt train: error: {root} has {len(clips)} take(s); at least 2 are needed (one for validation)", file=sys.stderr)
        return None
    n_val = max(1, len(clips) // 10)
    print(f"{len(clips)} takes from {root}: {len(clips) - n_val} for training, {n_val} for validation", file=sys.stderr)
    return clips[:-n_val], clips[-n_val:]
