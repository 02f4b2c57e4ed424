"""Evaluate several training runs of one recipe (seeds) and report every model-card figure as mean ± sd.

For each run folder (made by ``sgt train -o RUN``) this runs, on ``RUN/generator.pt`` (the
best validation epoch):

- ``sgt eval --split test --weights RUN/generator.pt -o RUN/eval_test.json`` (FGD, PCS, SCS,
  jerk, Hellinger, beat alignment and its shuffled-audio row, requested-vs-achieved style);
- ``python scripts/real_speech_check.py --weights ... --json RUN/real_speech.json`` (human
  recordings: wrist speed speaking vs silent, correlation with loudness);
- ``python scripts/pause_check.py --weights ... --json RUN/pause.json`` (wrist speed inside
  ``[pause]`` spans vs speech);

each skipped when its JSON is newer than the weights (``--force`` reruns). Then it prints one
Markdown table, a column per run and mean ± sd (sample standard deviation) over the runs, the
validation score of each run's kept epoch (the model card's decision rule: the run with the
lowest PCS/0.014 + SCS/0.249 is shipped) and writes everything to ``--summary``:

    python scripts/final_eval.py runs/final_s0 runs/final_s1 runs/final_s2 [--corpus data/corpus] [--summary runs/final_summary.json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def _stale(out: Path, weights: Path) -> bool:
    return not out.exists() or out.stat().st_mtime < weights.stat().st_mtime


def _run(argv: list[str], log: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    print("$", " ".join(argv), file=sys.stderr, flush=True)
    with open(log, "w") as f:
        rc = subprocess.call(argv, cwd=ROOT, env=env, stdout=f, stderr=subprocess.STDOUT)
    if rc != 0:
        raise SystemExit(f"failed ({rc}): {' '.join(argv)}; see {log}")


def evaluate_run(run: Path, *, split: str, seeds: int, force: bool, corpus: str) -> dict:
    weights = run / "generator.pt"
    if not weights.exists():
        raise SystemExit(f"{weights}: no such file (is the run finished?)")
    py = sys.executable
    jobs = {
        "eval": (run / f"eval_{split}.json",
                 [py, "-m", "sgt_tui.cli", "eval", "--corpus", corpus, "--split", split, "--weights", str(weights),
                  "-o", str(run / f"eval_{split}.json")]),
        "real": (run / "real_speech.json",
                 [py, "scripts/real_speech_check.py", "--weights", str(weights), "--seeds", str(seeds),
                  "--out", str(run / "real_speech"), "--json", str(run / "real_speech.json")]),
        "pause": (run / "pause.json",
                  [py, "scripts/pause_check.py", "--weights", str(weights), "--seeds", str(seeds), "--json", str(run / "pause.json")]),
    }
    for out, argv in jobs.values():
        if force or _stale(out, weights):
            _run(argv, run / f"{out.stem}.log")
    from model.weights import load_weights  # lazy: torch

    meta = load_weights(weights)[1]["meta"]
    return {"run": str(run), "meta_validation": meta.get("validation", {}), "epochs_done": meta.get("epochs_done"),
            **{name: json.loads(out.read_text()) for name, (out, _) in jobs.items()}}


def figures(r: dict) -> dict[str, float]:
    """The model-card figures of one run, by name."""
    rows = {row["name"]: row for row in r["eval"]["conditions"]}
    nan = float("nan")

    def g(name, key):
        v = rows.get(name, {}).get(key)
        return nan if v is None else float(v)

    val = r["meta_validation"]
    f = {
        "val score (PCS/0.014 + SCS/0.249)": val.get("val_pcs", nan) / 0.014 + val.get("val_scs", nan) / 0.249,
        "val PCS raw": val.get("val_pcs", nan), "val SCS": val.get("val_scs", nan),
        "FGD free": g("model", "fgd"), "FGD pose": g("model+pose", "fgd"), "FGD style": g("model+style", "fgd"),
        "FGD teacher (rules)": g("rules", "fgd"), "FGD mean pose": g("mean pose", "fgd"),
    }
    f["FGD free / teacher"] = f["FGD free"] / f["FGD teacher (rules)"]
    f.update({
        "SCS (model+style)": g("model+style", "scs"),
        "PCS raw": g("model+pose raw", "pcs"), "PCS after blend": g("model+pose", "pcs"),
        "jerk / ref, free": g("model", "jerk_ratio"), "jerk / ref, pose": g("model+pose", "jerk_ratio"),
        "jerk / ref, style": g("model+style", "jerk_ratio"),
        "Hellinger all, free": g("model", "hellinger"), "Hellinger all, teacher": g("rules", "hellinger"),
        "BA model": g("model", "beat_align"), "BA shuffled audio": g("shuffled audio", "beat_align"),
        "BA teacher shuffled": g("rules, shuffled", "beat_align"),
        "BA teacher": g("rules", "beat_align"),
    })
    for dim, s in (r["eval"].get("style_following") or {}).items():
        for req, ach in zip(s["requested"], s["achieved"]):
            f[f"style {dim} at {req:+g}"] = float(ach)
        f[f"style {dim} slope"] = float(s["slope"])
    h = r["real"]["human"]
    f.update({"real speech: speaking / silent wrist speed": h["ratio"], "real speech: corr(loudness, speed)": h["corr"],
              "real speech: corr over 1 s": h["corr_1s"], "real speech: BA": h["ba"], "real speech: BA shuffled": h["ba_shuffled"]})
    p, s = r["pause"]["pause"], r["pause"]["speaking"]
    f.update({"pause: median wrist m/s": p["median"], "speech: median wrist m/s": s["median"],
              "pause: mean wrist m/s": p["mean"], "speech: mean wrist m/s": s["mean"],
              "pause: peak wrist m/s": p["peak"], "speech: peak wrist m/s": s["peak"]})
    return f


def fmt(v: float) -> str:
    if not np.isfinite(v):
        return "-"
    return f"{v:.3f}" if abs(v) < 10 else f"{v:.1f}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="run folders made by sgt train -o")
    ap.add_argument("--corpus", default="data/corpus",
                    help="the corpus the runs were trained on (default data/corpus)")
    ap.add_argument("--split", default="test", choices=("test", "val"))
    ap.add_argument("--seeds", type=int, default=5, help="takes per condition for the real-speech and pause checks")
    ap.add_argument("--force", action="store_true", help="rerun every evaluation")
    ap.add_argument("--summary", default="runs/final_summary.json", help="JSON of every figure (default runs/final_summary.json)")
    args = ap.parse_args()
    results = [evaluate_run(Path(r), split=args.split, seeds=args.seeds, force=args.force,
                            corpus=str(Path(args.corpus).resolve())) for r in args.runs]
    per_run = [figures(r) for r in results]
    names = list(dict.fromkeys(k for f in per_run for k in f))
    stats = {}
    print("| figure | " + " | ".join(Path(r).name for r in args.runs) + " | mean ± sd |")
    print("|---|" + "---|" * (len(args.runs) + 1))
    for k in names:
        vals = np.array([f.get(k, float("nan")) for f in per_run], float)
        mean, sd = float(np.nanmean(vals)), float(np.nanstd(vals, ddof=1)) if np.isfinite(vals).sum() > 1 else float("nan")
        stats[k] = {"values": vals.tolist(), "mean": mean, "sd": sd}
        print(f"| {k} | " + " | ".join(fmt(v) for v in vals) + f" | {fmt(mean)} ± {fmt(sd)} |")
    score = "val score (PCS/0.014 + SCS/0.249)"
    best = int(np.nanargmin(stats[score]["values"]))
    print(f"\nshipped by the decision rule (lowest validation score): {args.runs[best]} "
          f"(score {stats[score]['values'][best]:.3f})")
    from core.fileio import atomic_write_text

    atomic_write_text(Path(args.summary), json.dumps({"runs": args.runs, "split": args.split, "figures": stats,
                                                      "chosen": args.runs[best], "results": results}, indent=2) + "\n")
    print(f"wrote {args.summary}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
