"""sgt train: train the controllable generator on a corpus (CPU)."""

from __future__ import annotations

import argparse
import itertools

from core.counting import plural

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
OUT/generator.pt to model/weights/generator.pt to ship it.

--engine flow trains the flow engine's network instead (conditional flow matching: it samples a
take from the seed's noise rather than regressing the average one; docs/model.md, "The flow
engine"): OUT/flow.pt holds the weights of the epoch with the lowest validation FGD, OUT/last.pt
the last epoch's; the same command resumes it. Of the network's options it takes --epochs,
--steps, --batch, --threads, --minutes, --window, --hidden, --device, --seed and --fresh (its
own defaults below), and its own --times, --teacher and --substeps; the others are the
regressor's and are refused with it. The shipped flow is two runs: a flow ('--epochs 100
--threads 1 -o RUN', its best epoch RUN/flow.pt), then that flow distilled into 4 sampler
steps ('--teacher RUN/flow.pt --times 0,0.4,0.7,0.9 --threads 1').
Export it for 'sgt generate --engine flow --weights OUT/flow.pt' with 'python
scripts/export_onnx.py --weights OUT/flow.pt' (PyTorch runs it meanwhile).

--engine matching builds the matching engine's database instead (no network, no
epochs: seconds to minutes): every take of --data (no validation split: the database
holds them all), or the train split of --corpus, as OUT/matching_db.npz. Takes shorter
than a segment (1.2 s) are left out with a warning. Generate with it:
'sgt generate FILE -o OUT.json --engine matching --database OUT/matching_db.npz'
(also 'sgt build' and 'sgt serve' take --database)."""


def register(sub) -> None:
    from model.engines import NETWORK_ENGINES
    from model.training.train_config import DISTIL_DEFAULTS as D
    from model.training.train_config import FlowConfig, TrainConfig
    from sgt_tui.commands.common import non_negative_float, non_negative_int, positive_float, positive_int, seed, share

    p = sub.add_parser("train", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    src = p.add_mutually_exclusive_group()
    src.add_argument("--corpus", default="data/corpus", help="corpus folder made by 'sgt corpus' (default data/corpus)")
    src.add_argument("--data", metavar="DIR",
                     help="train on your own motion instead: BVH takes with WAV audio and TextGrid/JSON word "
                          "timings, in the GENEA/Trinity layout (Motion/, Audio/, Transcripts/) or one flat folder; "
                          "the last tenth of the takes (at least one) is the validation split (with --engine matching: "
                          "none, every take goes into the database)")
    p.add_argument("-o", "--out", default="runs/default", help="output folder (default runs/default)")
    p.add_argument("--engine", choices=(*NETWORK_ENGINES, "matching"), default="neural",
                   help="neural (default): train the network, OUT/generator.pt; flow: train the flow engine's "
                        "network, OUT/flow.pt; matching: build the matching engine's database of the takes, "
                        "OUT/matching_db.npz (for 'sgt generate --engine matching --database OUT/matching_db.npz'); "
                        "the network's options below do not apply to it")
    network = p.add_argument_group("the network's training (--engine neural; --engine flow takes those marked 'flow')")
    network_options = []

    def add(*names, **kw) -> None:
        network_options.append(network.add_argument(*names, **kw))

    def both(neural, flow) -> str:
        return f"default {neural}" if neural == flow else f"default {neural}; flow: {flow}"

    # options both networks take default to None: each engine fills in its own default
    add("--epochs", type=positive_int, help=f"epochs ({both(TrainConfig.epochs, FlowConfig.epochs)})")
    add("--steps", type=positive_int,
        help=f"steps per epoch ({both(TrainConfig.steps_per_epoch, FlowConfig.steps_per_epoch)})")
    add("--batch", type=positive_int, help=f"windows per step ({both(TrainConfig.batch, FlowConfig.batch)})")
    add("--threads", type=positive_int, help=f"CPU threads ({both(TrainConfig.threads, FlowConfig.threads)})")
    add("--minutes", type=positive_float, help="stop after this much time (at the end of an epoch); flow too")
    add("--no-gan", action="store_true", help="switch the adversarial term off")
    add("--gan-weight", type=non_negative_float, default=TrainConfig.beta,
        help=f"weight of the adversarial term (default {TrainConfig.beta:g}; --no-gan sets 0)")
    add("--ctrl-weight", type=non_negative_float, default=TrainConfig.ctrl,
        help=f"weight of the L1 term on pose-controlled frames, 0 = off (default {TrainConfig.ctrl:g})")
    add("--style-weight", type=non_negative_float, default=TrainConfig.gamma,
        help=f"weight of the style-consistency term (Eq. 7 gamma; default {TrainConfig.gamma:g})")
    add("--vel-weight", type=non_negative_float, default=TrainConfig.vel,
        help=f"weight of the L1 velocity term, 0 = off (default {TrainConfig.vel:g})")
    add("--hist-weight", type=non_negative_float, default=TrainConfig.hist,
        help="weight of the Hellinger distance between the generated and reference joint-speed histograms "
             f"(too few still and fast frames is what a regression makes), 0 = off (default {TrainConfig.hist:g})")
    add("--kl", type=non_negative_float, default=TrainConfig.kl,
        help="KL weight of the conditional-VAE noise: a training-only encoder reads each reference window "
             f"so that each seed is a different take, not the average one; 0 = off (default {TrainConfig.kl:g})")
    add("--p-prior", type=share, default=TrainConfig.p_prior,
        help="with --kl: share of uncontrolled training windows whose noise comes from the prior (windows with "
             f"controls always get the prior's; default {TrainConfig.p_prior:g})")
    add("--restyle", type=share, default=TrainConfig.p_restyle, metavar="P",
        help="share of speech windows trained on a style request other than their own, with the style "
             f"and adversarial terms only, so style controls reach the whole range (default {TrainConfig.p_restyle:g})")
    add("--window", type=positive_int,
        help=f"training window in frames ({both(TrainConfig.window, FlowConfig.window)})")
    add("--device", choices=("auto", "cpu"), default=TrainConfig.device,
        help="auto: CUDA when present, else the CPU (default auto); flow too")
    add("--seed", type=seed, default=0, help="the training's random seed (default 0); flow too")
    add("--fresh", action="store_true", help="ignore an existing checkpoint; flow too")
    add("--hidden", type=positive_int, default=128, help="network width (default 128); flow too")
    add("--no-gru", action="store_true", help="convolutions only (faster, see docs/model.md)")
    add("--teacher", metavar="FLOW.pt",
        help="flow only: distil these trained flow weights into a sampler of the --times steps instead of training a "
             "flow (the student starts as the teacher and learns to land where it lands in --substeps steps per step; "
             f"defaults then: {D['epochs']} epochs of {D['steps_per_epoch']} steps of {D['batch']} windows, learning rate "
             f"{D['lr']:g}, weights averaged with decay {D['ema']:g})")
    add("--times", type=_times, metavar="T0,T1,...",
        help="flow only: the sampler's time points, from 0 and rising below 1, one network call each "
             "(default: the teacher's, or 0,0.5,0.8)")
    add("--substeps", type=positive_int, default=4, help="flow only, with --teacher: the teacher's steps per student step (default 4)")
    add("--smooth", type=non_negative_int, default=5, metavar="TAPS",
        help="taps of the in-network low-pass on free frames, 0 = off (default 5, see docs/model.md)")
    # (dest, flag, default) of each network option: --engine matching refuses them when given, --engine
    # flow those of FLOW_OPTIONS' complement
    p.set_defaults(run=run, network_options=tuple((a.dest, a.option_strings[0], a.default) for a in network_options))


#: The network options that --engine flow takes (the rest are the regressor's loss and architecture).
FLOW_OPTIONS = ("epochs", "steps", "batch", "threads", "minutes", "window", "device", "seed", "fresh", "hidden", "teacher",
                "times", "substeps")
#: The options only --engine flow takes.
FLOW_ONLY = ("teacher", "times", "substeps")


def _times(text: str) -> list[float]:
    """``--times``: comma-separated flow times, from 0 and rising below 1."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of numbers") from None
    if values[0] != 0.0 or any(b <= a for a, b in itertools.pairwise(values)) or values[-1] >= 1.0:
        raise argparse.ArgumentTypeError(f"'{text}': the times must start at 0 and rise below 1 (e.g. 0,0.4,0.7,0.9)")
    return values


def run(args) -> int:
    import sys
    from pathlib import Path

    from sgt_tui.commands.common import existing_folder, output_folder
    from sgt_tui.errors import InputError

    if args.engine == "matching":
        _no_network_options(args)
    elif args.engine == "flow":
        _no_network_options(args, allowed=FLOW_OPTIONS)
    else:
        _no_network_options(args, allowed=tuple(dest for dest, _, _ in args.network_options if dest not in FLOW_ONLY))
    if args.teacher:
        from sgt_tui.commands.common import existing_file

        args.teacher = str(existing_file(args.teacher))
    if args.data:
        existing_folder(args.data, "--data")
    elif not Path(args.corpus).exists():
        raise InputError(f"--corpus {args.corpus}: no such corpus; make one with: sgt corpus -o {args.corpus}")
    output_folder(args.out)
    if args.engine == "matching":
        return _build_database(args)

    from model.training.train import TrainConfig, train
    from sgt_tui.progress import ProgressBar

    if args.data:
        loaded = _user_data(Path(args.data))
        if loaded is None:
            return 1
        train_clips, val_clips = loaded
    else:
        train_clips, val_clips = _corpus_split(Path(args.corpus), "train"), _corpus_split(Path(args.corpus), "val")
    if args.engine == "flow":
        return _train_flow(args, train_clips, val_clips)
    _engine_defaults(args, TrainConfig)
    cfg = TrainConfig(epochs=args.epochs, steps_per_epoch=args.steps, batch=args.batch, minutes=args.minutes,
                      beta=0.0 if args.no_gan else args.gan_weight, seed=args.seed,
                      threads=args.threads, gamma=args.style_weight, ctrl=args.ctrl_weight, vel=args.vel_weight, hist=args.hist_weight,
                      kl=args.kl, p_prior=args.p_prior, p_restyle=args.restyle, window=args.window, device=args.device,
                      net={"hidden": args.hidden, "gru": not args.no_gru, "smooth": args.smooth})
    try:
        train(train_clips, val_clips, Path(args.out), cfg, resume=not args.fresh, progress=ProgressBar("train"),
              log=lambda s: print(s, file=sys.stderr))
    except ValueError as exc:  # no clip as long as a training window, a checkpoint not resumed, a loss that diverged
        print(f"sgt train: error: {exc}", file=sys.stderr)
        return 1
    weights = Path(args.out) / "generator.pt"
    if not weights.is_file():  # (a checkpoint whose epochs were all done, resumed in a folder without its weights)
        print(f"sgt train: error: no weights: {weights} is missing and the checkpoint in {args.out} has no epoch left "
              "to train; train afresh with --fresh", file=sys.stderr)
        return 1
    print(f"weights: {weights} (best validation epoch); last epoch: {Path(args.out) / 'last.pt'}", file=sys.stderr)
    return 0


def _engine_defaults(args, config) -> None:
    """The options both networks take and the command line left out, from the engine's
    settings ``config`` (TrainConfig, FlowConfig, or such settings: distillation's)."""
    for dest, field in (("epochs", "epochs"), ("steps", "steps_per_epoch"), ("batch", "batch"), ("threads", "threads"),
                        ("window", "window")):
        if getattr(args, dest) is None:
            setattr(args, dest, getattr(config, field))


def _train_flow(args, train_clips, val_clips) -> int:
    """sgt train --engine flow: the flow engine's network, OUT/flow.pt."""
    import sys
    from dataclasses import replace
    from pathlib import Path

    from model.training.train_config import DISTIL_DEFAULTS
    from model.training.train_flow import FlowConfig, train_flow
    from sgt_tui.progress import ProgressBar

    base = replace(FlowConfig(), **DISTIL_DEFAULTS) if args.teacher else FlowConfig()
    _engine_defaults(args, base)
    net = {} if args.teacher else {"hidden": args.hidden}  # a student has its teacher's architecture
    if args.times:
        net["times"] = args.times
    cfg = FlowConfig(epochs=args.epochs, steps_per_epoch=args.steps, batch=args.batch, lr=base.lr, ema=base.ema, minutes=args.minutes,
                     window=args.window, seed=args.seed, threads=args.threads, device=args.device, net=net,
                     teacher=args.teacher, substeps=args.substeps)
    from model.weights import WeightsError

    try:
        train_flow(train_clips, val_clips, Path(args.out), cfg, resume=not args.fresh, progress=ProgressBar("train"),
                   log=lambda s: print(s, file=sys.stderr))
    except (ValueError, WeightsError) as exc:  # no clip as long as a window; a checkpoint made with other settings;
        # a teacher that is not flow weights
        print(f"sgt train: error: {exc}", file=sys.stderr)
        return 1
    out = Path(args.out)
    print(f"weights: {out / 'flow.pt'} (best validation epoch); last epoch: {out / 'last.pt'}; use them: "
          f"sgt generate FILE -o OUT.json --engine flow --weights {out / 'flow.pt'}", file=sys.stderr)
    return 0


def _corpus_split(corpus, split: str) -> list:
    """The clips of a corpus's split; a corpus that cannot be read: one line, exit 1."""
    from model.training.corpus import CorpusError, load_corpus
    from sgt_tui.errors import InputError

    try:
        return load_corpus(corpus, split)
    except (CorpusError, OSError, ValueError) as exc:
        raise InputError(f"cannot load the corpus at {corpus}: {exc}\n  make one with: sgt corpus -o {corpus}") from None


def _user_data(root):
    """(train, val) clips from a BVH folder (model/loaders.py), or None after printing the error."""
    import sys

    clips = _user_takes(root)
    if clips is None:
        return None
    if len(clips) < 2:
        print(f"sgt train: error: {root} has {plural(len(clips), 'take')}; at least 2 are needed (one for validation)", file=sys.stderr)
        return None
    n_val = max(1, len(clips) // 10)
    print(f"{plural(len(clips), 'take')} from {root}: {len(clips) - n_val} for training, {n_val} for validation", file=sys.stderr)
    return clips[:-n_val], clips[-n_val:]


def _user_takes(root):
    """Every take of a BVH folder (model/training/loaders.py) as clips, silence for a take without
    audio (with a warning); None after printing the error."""
    import sys

    from model.features import silence_features
    from model.training.loaders import LoaderError, load_folder
    from sgt_tui.progress import ProgressBar

    try:
        clips = load_folder(root, progress=ProgressBar("takes"))
    except LoaderError as exc:
        print(f"sgt train: error: {exc}", file=sys.stderr)
        return None
    for c in clips:
        if "audio" not in c:
            print(f"sgt train: warning: take '{c['id']}' has no audio; it is used with silence (its speech features "
                  "say nobody speaks)", file=sys.stderr)
            c["audio"] = silence_features(len(c["poses"]))
    return clips


def _no_network_options(args, allowed=()) -> None:
    """Usage error when a network option was set with --engine matching (a value other than its
    default), or with another engine one that its network does not take (not in ``allowed``)."""
    from sgt_tui.errors import UsageError

    given = [flag for dest, flag, default in args.network_options if dest not in allowed and getattr(args, dest) != default]
    if given:
        s = "s" if len(given) > 1 else ""
        why = ("--engine matching builds a database and has no such setting" if args.engine == "matching" else
               f"--engine {args.engine} trains another network, which has no such setting")
        owner = {"matching": "the network's", "neural": "the flow engine's"}.get(args.engine, "the neural engine's")
        raise UsageError(f"{', '.join(given)}: {owner} training option{s}; {why}: leave {'them' if s else 'it'} out")


def _build_database(args) -> int:
    """sgt train --engine matching: the matching engine's database of the takes, OUT/matching_db.npz."""
    import sys
    import time
    from pathlib import Path

    from core.skeleton import FPS
    from sgt_tui.commands.common import output_file, shown
    from sgt_tui.errors import InputError
    from sgt_tui.progress import ProgressBar

    t0 = time.perf_counter()
    out = Path(args.out) / "matching_db.npz"
    if args.data:
        from model.training.loaders import LoaderError, find_takes

        root = Path(args.data)
        try:
            takes = find_takes(root)
        except LoaderError as exc:
            raise InputError(str(exc)) from None
        inputs = [p for t in takes for p in (t.bvh_path, t.audio_path, t.timings_path)]
        output_file(str(out), "-o", inputs=inputs)
        clips = _user_takes(root)
        if clips is None:
            return 1
        source = f"{plural(len(clips), 'take')} of {root} (all of them: a database needs no validation split)"
    else:
        corpus = Path(args.corpus)
        output_file(str(out), "-o", inputs=[p for p in corpus.iterdir() if p.is_file()] if corpus.is_dir() else [corpus])
        clips = _corpus_split(corpus, "train")
        source = f"the {plural(len(clips), 'train-split take')} of {corpus}"
    from model.training import matching_db

    usable = [matching_db.gives_segments(len(c["poses"])) for c in clips]
    short = [c for c, ok in zip(clips, usable) if not ok]
    for c in short:
        n = len(c["poses"])
        print(f"sgt train: warning: take '{c['id']}' is {n / FPS:.2f} s ({plural(n, 'frame')}), shorter than a segment "
              f"({matching_db.min_frames()} frames): left out", file=sys.stderr)
    clips = [c for c, ok in zip(clips, usable) if ok]
    if not clips:
        raise InputError(f"no usable take in {source}: each needs at least {matching_db.min_frames()} frames "
                         f"({matching_db.min_frames() / FPS:.1f} s) of motion")
    print(f"building a matching database of {source}" + (f", {len(short)} left out" if short else ""), file=sys.stderr)
    arrays, meta = matching_db.build_from_clips(clips, progress=ProgressBar("database"))
    if args.data:
        meta.update(source="bvh", data=root.name)
    else:
        meta.update(split="train", corpus=corpus.name)
    digest = matching_db.write(out, arrays, meta)
    print(f"wrote {shown(out)}: {plural(meta['takes'], 'take')}, {plural(meta['frames'], 'frame')} ({meta['frames'] / FPS / 60:.1f} min), "
          f"{meta['candidates']} candidate segments, {_size(out.stat().st_size)}, sha256 {digest}, "
          f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)
    print(f"use it: sgt generate FILE -o OUT.json --engine matching --database {shown(out)}", file=sys.stderr)
    return 0


def _size(n: int) -> str:
    return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{n / 1024:.0f} KiB"
