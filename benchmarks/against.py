"""Side-by-side runs: a benchmark measures today's tree and an earlier revision in one run.

    from against import BASELINE, tree_of
    with tree_of("742c655") as old:   # the revision's files, exported to a temporary folder
        run_the_same_measurement(old)

The exported tree holds the revision's committed files (`git archive`), shipped weights
included; a child process imports it first by running with ``cwd=tree`` and
``PYTHONPATH=tree`` (before the editable install of this checkout on ``sys.path``). Each
benchmark that compares takes ``--before REV`` (default :data:`BASELINE`, ``--before none``
measures today's tree only).
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: The code the speed goals of issue 21 are measured against (the last commit before it).
BASELINE = "742c655"


@contextlib.contextmanager
def tree_of(rev: str):
    """A temporary folder holding revision ``rev`` of this repository (removed afterwards)."""
    with tempfile.TemporaryDirectory(prefix=f"sgt-{rev}-") as tmp:
        archive = subprocess.run(["git", "archive", rev], cwd=ROOT, capture_output=True)
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
