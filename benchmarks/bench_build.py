"""Benchmark: `sgt build` from scratch, with nothing changed, and with one line changed,
for today's tree and an earlier revision in the same run (benchmarks/against.py).

    python benchmarks/bench_build.py [--before 742c655] [--utterances 10000] [--per-script 100] [--jobs 2]
    python benchmarks/bench_build.py --threads [--utterances 40]   # 1 process x 2 threads or 2 x 1?

Makes a game-sized source tree: ``--utterances`` lines in scripts of ``--per-script`` lines
each, in folders of ten scripts. Each line is a sentence of 6-16 words from a fixed
vocabulary (all distinct), a third of them with a pose control, a sixth with a style span,
a few with a pause, two speakers with their own voices. Each tree (``--before REV`` first,
exported by git, then today's; ``--before none``: today's only) builds its own copy of it,
with its own sgt cache, and each build is the whole command (`python -m sgt_tui.cli build
SRC -o OUT -q`, interpreter start and imports included, cwd the tree):

1. from scratch: an empty sgt cache (speech timing and utterances), ``--jobs`` workers;
2. a rebuild with nothing changed (target: under 5 s), ``--repeat`` times, the trees in turn;
3. one line changed in one script (target: under 3 s), the same lines in both copies, in turn.

Each figure comes with the CPU time the build used (its processes and all they started) and
the load average: the machine is shared, and wall times move with what else runs.
Before each timed build the page cache is written back (``os.sync()``, untimed), so that a
build does not pay for the previous one's writes (2 GB of outputs after 10,000 utterances).
``--reuse DIR`` keeps the copies in DIR, and a second run with it times only the rebuilds.

Targets (issue 21): 10,000 utterances from scratch in at most 5 minutes on this machine's 2
cores. ``--threads`` measures instead the choice of one torch thread per worker: the same
utterances generated (warm speech cache) by one process with 2 torch threads and by 2
worker processes with one thread each.
"""

from __future__ import annotations

import argparse
import os
import random
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from against import add_before_option, env_for, trees

from model.engines import DEFAULT_ENGINE

ROOT = Path(__file__).resolve().parent.parent

WORDS = ("the a shelf river valley merchant apples today we look at how this that over there north south gate "
         "tower market bread coins sword shield lantern morning evening quickly slowly friend stranger road "
         "bridge king queen village forest mountain castle door window table chair light").split()
GESTURES = ("point_right", "point_left", "open_arms", "beat_right", "beat_both", "wave", "shrug", "point_self")


def make_tree(root: Path, n: int, per_script: int, seed: int = 0) -> list[Path]:
    rng = random.Random(seed)
    scripts = []
    header = "@voice guide: en-us\n@voice robot: en-us+m3\n@rate robot: 175\n@seed 3\n"
    for s in range((n + per_script - 1) // per_script):
        lines = [header]
        for i in range(min(per_script, n - s * per_script)):
            words = [rng.choice(WORDS) for _ in range(rng.randint(6, 16))]
            words[0] = f"{words[0].capitalize()}{s}x{i}"  # every line distinct
            r = rng.random()
            if r < 0.33:
                at = rng.randrange(len(words))
                words[at] = f"[pose:{rng.choice(GESTURES)}] {words[at]}"
            elif r < 0.5:
                a = rng.randrange(len(words) - 2)
                words[a] = f"<speed:{rng.choice(['-1', '+1', '+2'])}>{words[a]}"
                words[a + 2] = f"{words[a + 2]}</speed>"
            elif r < 0.55:
                words[len(words) // 2] += " [pause 200ms]"
            lines.append(f"{rng.choice(['guide', 'robot'])}: {' '.join(words)}.\n")
        path = root / f"act{s // 10:02d}" / f"scene{s:03d}.sgt"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("".join(lines), encoding="utf-8")
        scripts.append(path)
    return scripts


class Copy:
    """One tree's copy of the sources, its output folder and its sgt cache."""

    def __init__(self, label: str, tree: Path, folder: Path) -> None:
        self.label, self.tree = label, tree
        self.src, self.out = folder / "src", folder / "out"
        self.env = env_for(tree, SGT_CACHE_DIR=str(folder / "cache"))

    def build(self, jobs: int, engine: str) -> tuple[float, float]:
        """(wall seconds, CPU seconds of the build and every process it started)."""
        cmd = [sys.executable, "-m", "sgt_tui.cli", "build", str(self.src), "-o", str(self.out), "-q", "--jobs",
               str(jobs), "--engine", engine]
        # Write back what earlier builds left in the page cache first (2 GB after 10,000 utterances),
        # so that a build's fsyncs do not wait for the previous build's files (untimed).
        os.sync()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, env=self.env, cwd=self.tree, capture_output=True, text=True, check=False)
        dt = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if proc.returncode != 0:
            raise SystemExit(f"{self.label}: build failed ({proc.returncode}): {proc.stderr[-2000:]}")
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        return dt, cpu


def load() -> str:
    return open("/proc/loadavg").read().split()[0] if os.path.exists("/proc/loadavg") else "?"


def bench_builds(args) -> None:
    tmp = Path(args.reuse) if args.reuse else Path(tempfile.mkdtemp(prefix="sgt-bench-build-"))
    try:
        with trees(args.before) as pairs:
            copies = [Copy(label, tree, tmp / f"tree{i}") for i, (label, tree) in enumerate(pairs)]
            print(f"{args.utterances} utterances in scripts of {args.per_script}, --jobs {args.jobs}, engine "
                  f"{args.engine}, {os.cpu_count()} CPUs; trees: {', '.join(c.label for c in copies)}")
            for c in copies:
                if args.reuse and (c.out / "manifest.json").is_file():  # built by an earlier run: rebuilds only
                    print(f"{c.label}: {c.out} built before; rebuilds only")
                    continue
                shutil.rmtree(c.src, ignore_errors=True)
                make_tree(c.src, args.utterances, args.per_script)
                print(f"{c.label}: from scratch, load before {load()} ...", flush=True)
                t, cpu = c.build(args.jobs, args.engine)
                size = sum(p.stat().st_size for p in c.out.rglob("*") if p.is_file())
                print(f"{c.label}: from scratch {t:.1f} s ({t / args.utterances * 1000:.1f} ms per utterance, "
                      f"{args.utterances / t:.1f} utterances/s), CPU {cpu:.0f} s ({cpu / t:.2f} cores); outputs "
                      f"{size / 2**20:.0f} MiB; load after {load()}", flush=True)
            if args.scratch_only:
                return
            times: dict[str, list] = {c.label: [] for c in copies}
            for _ in range(args.repeat):
                for c in copies:
                    times[c.label].append(c.build(args.jobs, args.engine))
            for c in copies:
                walls = [t for t, _ in times[c.label]]
                print(f"{c.label}: nothing changed: median {statistics.median(walls):.2f} s, min {min(walls):.2f} s "
                      f"(target < 5 s; {args.repeat} runs); load {load()}")
            times = {c.label: [] for c in copies}
            rng = random.Random(1)
            for _ in range(args.repeat):
                scripts = sorted(copies[0].src.rglob("*.sgt"))
                pick = rng.randrange(len(scripts))
                line = None
                for c in copies:
                    path = sorted(c.src.rglob("*.sgt"))[pick]
                    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
                    line = line if line is not None else rng.randrange(5, len(lines))
                    lines[line] = lines[line].rstrip("\n").rstrip(".") + " again.\n"
                    path.write_text("".join(lines), encoding="utf-8")
                    times[c.label].append(c.build(args.jobs, args.engine))
            for c in copies:
                walls = [t for t, _ in times[c.label]]
                print(f"{c.label}: one line changed: median {statistics.median(walls):.2f} s, min {min(walls):.2f} s "
                      f"(target < 3 s; {args.repeat} runs); load {load()}")
    finally:
        if args.keep or args.reuse:
            print(f"kept {tmp} (rerun the rebuilds with --reuse {tmp} --before {args.before})")
        else:
            shutil.rmtree(tmp, ignore_errors=True)


def bench_threads(args) -> None:
    """Utterances per second: one process with two torch threads against two one-thread workers."""
    sys.path.insert(0, str(ROOT))
    tmp = Path(tempfile.mkdtemp(prefix="sgt-bench-threads-"))
    os.environ["SGT_CACHE_DIR"] = str(tmp / "cache")
    try:
        per = max(1, args.utterances // 2)
        scripts = make_tree(tmp / "src", 2 * per, per)
        from model.generate import generate

        for s in scripts:  # warm the speech cache: time generation only
            generate(s, engine="keyframe")
        import torch

        torch.set_num_threads(2)
        generate(scripts[0], utterances=[0])  # load the model
        t0 = time.perf_counter()
        for s in scripts:
            generate(s)
        one = time.perf_counter() - t0
        print(f"1 process x 2 torch threads: {2 * per / one:.2f} utterances/s ({one:.1f} s for {2 * per}); load {load()}")
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn"), initializer=_one_thread) as pool:
            list(pool.map(_generate_first, [str(s) for s in scripts]))  # start and load
            t0 = time.perf_counter()
            list(pool.map(_generate, [str(s) for s in scripts]))
            two = time.perf_counter() - t0
        print(f"2 processes x 1 torch thread: {2 * per / two:.2f} utterances/s ({two:.1f} s); load {load()}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _one_thread() -> None:
    sys.path.insert(0, str(ROOT))
    from sgt_tui.build.work import one_thread

    one_thread()


def _generate_first(path: str) -> None:
    from model.generate import generate

    generate(Path(path), utterances=[0])


def _generate(path: str) -> None:
    from model.generate import generate

    generate(Path(path))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--utterances", type=int, default=10000)
    ap.add_argument("--per-script", type=int, default=100)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--engine", default=DEFAULT_ENGINE)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--threads", action="store_true", help="measure 1 process x 2 threads against 2 x 1 instead")
    ap.add_argument("--scratch-only", action="store_true", help="only the build from scratch")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    ap.add_argument("--reuse", metavar="DIR", help="build the copies in DIR and keep them; if DIR holds copies "
                    "built before, time only the rebuilds")
    add_before_option(ap)
    args = ap.parse_args()
    (bench_threads if args.threads else bench_builds)(args)


if __name__ == "__main__":
    main()
