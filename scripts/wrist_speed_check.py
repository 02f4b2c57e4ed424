"""How fast do the engines' wrists move, against the re-seeded teacher's and the references'?

The model card compares each engine's free motion (no controls: ``sgt eval``'s ``model`` row)
with the teacher re-seeded (its ``rules`` row) by the wrists' speed: the mean and the 95th
percentile of the per-frame speed of both wrists (m/s), pooled over every frame of every clip.
A regressor that averages strokes away moves its wrists slower on both; a sampler should move
them as the teacher does. Clip ``i`` is generated with seed ``seed + i``, as ``sgt eval`` does,
so the figures belong to the same motions as its rows.

    python scripts/wrist_speed_check.py --corpus data/heldout --seed 0 [--engine flow --engine matching] [--limit N]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from core.controls import ControlArrays
from core.skeleton import JOINTS
from model.engines import EVAL_ENGINES
from model.training import evaluate, metrics
from model.training.corpus import load_corpus

WRISTS = [JOINTS.index("left_wrist"), JOINTS.index("right_wrist")]


def wrist_speeds(motions) -> np.ndarray:
    """Every frame's speed (m/s) of each wrist, pooled over ``motions``."""
    return np.concatenate([metrics.joint_speeds(m)[:, WRISTS].ravel() for m in motions])


def summary(motions) -> dict[str, float]:
    s = wrist_speeds(motions)
    return {"mean": float(s.mean()), "p95": float(np.percentile(s, 95))}


def engine_model(engine: str):
    """What :func:`model.training.evaluate._generate` runs for ``engine`` (the shipped files)."""
    if engine == "matching":
        from model import matching

        return evaluate.MatchingModel(matching.load(None))
    if engine == "flow":
        from model import flow

        return evaluate.FlowModel(flow.load())
    from model.runtime import TorchRunner
    from model.weights import DEFAULT_WEIGHTS, load_weights, takes_of

    net, info = load_weights()
    return TorchRunner(net, takes_of(DEFAULT_WEIGHTS, info))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", default="data/heldout", help="corpus folder (default data/heldout)")
    ap.add_argument("--seed", type=int, default=0, help="the generation seed, as sgt eval --seed (default 0)")
    ap.add_argument("--engine", action="append", choices=EVAL_ENGINES, help="an engine to measure (repeat; default all)")
    ap.add_argument("--limit", type=int, help="only the first N clips")
    args = ap.parse_args(argv)
    clips = load_corpus(Path(args.corpus), None)[: args.limit]
    rows = {"reference": summary([c["poses"] for c in clips]),
            "rules": summary([evaluate._rules(c, args.seed + i) for i, c in enumerate(clips)])}
    for engine in args.engine or EVAL_ENGINES:
        model = engine_model(engine)
        rows[engine] = summary([evaluate._generate(model, c, ControlArrays.empty(len(c["poses"])), args.seed + i,
                                                   smoothing=None) for i, c in enumerate(clips)])
    print(f"{args.corpus} ({len(clips)} clips), seed {args.seed}: wrist speed (m/s) of the free motion")
    for name, r in rows.items():
        versus = "" if name in ("reference", "rules") else \
            f"   {r['mean'] / rows['rules']['mean']:.2f} / {r['p95'] / rows['rules']['p95']:.2f} of the teacher's"
        print(f"  {name:10s} mean {r['mean']:.3f}  p95 {r['p95']:.3f}{versus}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
