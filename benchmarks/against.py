"""Side-by-side runs: a benchmark measures today's tree and an earlier revision in one run.

    from against import BASELINE, tree_of
    with tree_of("742c655") as old:   # the revision's files, exported to a temporary folder
        run_the_same_measurement(old)

The exported tree holds the revision's committed files (`git archive`), shipped weights
included; a child process imports it first by running with ``cwd=tree`` and
``PYTHONPATH=tree`` (before the editable install of this checkout on ``sys.path``). Each
benchmark that compares takes ``--before REV`` (default :data:`BASELINE`, ``--before none``
measures today's tree only).

Run as a script, it times ``sgt render`` of a long scene (default
``benchmarks/scenes/reception.sgt``: 92 s, two speakers, 1,375 frames at 640x320) for a
revision (default ``main``) and today's tree in the same run:

    python benchmarks/against.py                      # main and today's tree, GIF and MP4
    python benchmarks/against.py --before 742c655 --repeat 3

Each tree generates its own take of the scene first (not timed: its own speech files, for the
MP4's sound), then each render is a fresh ``sgt render`` process, the trees taking turns so
that a change in the machine's load hits both: wall time, and CPU time of the render and its
worker processes. Today's tree renders with ``--jobs 1`` and with its default; a tree without
``--jobs`` renders once. The load average before each render is printed beside it (on a
shared machine the figures move with it), and whether every ``--jobs`` gave the same bytes.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: The code the speed goals of issue 21 are measured against (the last commit before it).
BASELINE = "742c655"


@contextlib.contextmanager
def tree_of(rev: str):
    """A temporary folder holding revision ``rev`` of this repository (removed afterwards)."""
    with tempfile.TemporaryDirectory(prefix=f"sgt-{rev}-") as tmp:
        archive = subprocess.run(["git", "archive", rev], cwd=ROOT, capture_output=True, check=False)
        if archive.returncode != 0:
            raise SystemExit(f"--before {rev}: not a revision of {ROOT} ({archive.stderr.decode().strip()})")
        subprocess.run(["tar", "-x", "-C", tmp], input=archive.stdout, check=True)
        yield Path(tmp)


def env_for(tree: Path, **extra: str) -> dict[str, str]:
    """The environment of a child process that imports ``tree``'s sgt."""
    return {**os.environ, "PYTHONPATH": str(tree), **extra}


@contextlib.contextmanager
def trees(before: str | None):
    """(label, tree) pairs to measure: the earlier revision first (unless ``before`` is None or
    "none"), then today's tree."""
    if not before or before == "none":
        yield [("now", ROOT)]
        return
    with tree_of(before) as old:
        yield [(f"before ({before})", old), ("now", ROOT)]


def add_before_option(parser) -> None:
    parser.add_argument("--before", metavar="REV", default=BASELINE,
                        help=f"also measure this git revision in the same run (default {BASELINE}, the code before "
                             "issue 21; 'none': today's tree only)")


def _sgt(tree: Path, args: list[str], cwd: Path, timeout: float) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *args], cwd=cwd, env=env_for(tree),
                          capture_output=True, text=True, timeout=timeout, check=False)


def _children_cpu() -> float:
    """CPU seconds of the finished child processes (and of their finished children: workers)."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _render(tree: Path, folder: Path, fmt: str, jobs: str | None, timeout: float) -> dict:
    out = folder / f"take.{jobs or 'default'}.{fmt}"
    load = os.getloadavg()[0]
    cpu, wall = _children_cpu(), time.perf_counter()
    r = _sgt(tree, ["render", "take.json", "-o", out.name, *(["--jobs", jobs] if jobs else [])], folder, timeout)
    wall, cpu = time.perf_counter() - wall, _children_cpu() - cpu
    if r.returncode != 0:
        raise SystemExit(f"{tree}: sgt render failed: {r.stderr.strip().splitlines()[-1:]}")
    data = out.read_bytes()
    out.unlink()
    return {"wall": wall, "cpu": cpu, "load": load, "bytes": data}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description="sgt render of a long scene: an earlier revision and today's tree "
                                            "side by side")
    p.add_argument("--before", metavar="REV", default="main",
                   help="the revision to measure beside today's tree (default main; 'none': today's tree only)")
    p.add_argument("--scene", default=str(ROOT / "benchmarks" / "scenes" / "reception.sgt"))
    p.add_argument("--formats", default="gif,mp4", help="comma-separated: gif, mp4")
    p.add_argument("--repeat", type=int, default=1, help="renders of each kind (the median is shown)")
    p.add_argument("--timeout", type=float, default=900, help="seconds any one command may take")
    args = p.parse_args(argv)
    formats = [f.strip() for f in args.formats.split(",") if f.strip()]
    if bad := [f for f in formats if f not in ("gif", "mp4")]:
        p.error(f"--formats: {', '.join(bad)} is not gif or mp4")
    scene = Path(args.scene)
    print(f"{scene.name}; {os.cpu_count()} CPUs; load average at the start {os.getloadavg()[0]:.2f} "
          "(a shared machine: the figures move with the load)")
    with trees(args.before) as measured, tempfile.TemporaryDirectory(prefix="sgt-against-") as tmp:
        runs = []  # (label, tree, folder, jobs options)
        for i, (label, tree) in enumerate(measured):
            folder = Path(tmp) / str(i)
            folder.mkdir()
            shutil.copy(scene, folder / "scene.sgt")
            t = time.perf_counter()
            r = _sgt(tree, ["generate", "scene.sgt", "-o", "take.json"], folder, args.timeout)
            if r.returncode != 0:
                raise SystemExit(f"{label}: sgt generate failed: {r.stderr.strip().splitlines()[-1:]}")
            has_jobs = "--jobs" in _sgt(tree, ["render", "--help"], folder, 60).stdout
            runs.append((label, tree, folder, ["1", None] if has_jobs else [None]))
            print(f"{label}: generated the take in {time.perf_counter() - t:.1f} s (not timed below)")
        results: dict = {}
        for fmt in formats:
            for _ in range(args.repeat):
                for label, tree, folder, options in runs:  # the trees take turns
                    for jobs in options:
                        results.setdefault((fmt, label, jobs), []).append(_render(tree, folder, fmt, jobs, args.timeout))
        print(f"{'format':6} {'tree':22} {'--jobs':>7} {'wall s':>8} {'CPU s':>8} {'load':>6}  same bytes")
        for fmt in formats:
            medians = {}
            for label, _, _, options in runs:
                outs = {r["bytes"] for jobs in options for r in results[(fmt, label, jobs)]}
                for jobs in options:
                    rs = results[(fmt, label, jobs)]
                    medians[(label, jobs)] = wall = statistics.median(r["wall"] for r in rs)
                    cpu = statistics.median(r["cpu"] for r in rs)
                    load = " ".join(f"{r['load']:.1f}" for r in rs)
                    print(f"{fmt:6} {label:22} {jobs or 'default':>7} {wall:8.1f} {cpu:8.1f} {load:>6}  "
                          f"{'yes' if len(outs) == 1 else f'no ({len(outs)} files)'}")
            if len(runs) == 2:
                (old, *_), (new, *_) = runs
                print(f"{fmt}: today's default {medians[(new, None)]:.1f} s, {medians[(old, None)] / medians[(new, None)]:.2f} "
                      f"times faster than {old}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
