"""ctrl+c stops `sgt build` at any moment with exit status 130 and one line, "interrupted".

A terminal's ctrl+c sends SIGINT to the whole foreground process group: the build's worker
processes too. They used to print a KeyboardInterrupt traceback each when it landed while
they started (Python's site, the imports of sgt); they now start with SIGINT blocked and are
stopped by the build itself. Each test starts a real build in a process group of its own and
signals that group, as the terminal would, at one moment of the build.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from processes import alive, spawned_workers

ROOT = Path(__file__).resolve().parents[1]


def _entries(cache: Path) -> int:
    return sum(1 for p in (cache / "build").rglob("*") if p.is_file() and not p.name.startswith("."))


@pytest.fixture
def tree(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    for s in range(3):
        lines = [f"guide: Line {i} of scene {s}, [pose:beat_right] said slowly for the test." for i in range(8)]
        (src / f"scene{s}.sgt").write_text("\n".join(lines) + "\n")
    return tmp_path


# Put first on a build's PYTHONPATH, this makes a worker process send SIGINT to its process
# group (the build and every worker, as ctrl+c does), or to itself alone, at the moment it
# starts to import the module named by SGT_TEST_SIGINT_AT: deterministic, where a timer hits
# those moments only sometimes.
SITECUSTOMIZE = """
import os, signal, sys, time
TARGET = os.environ.get("SGT_TEST_SIGINT_AT")
GROUP = os.environ.get("SGT_TEST_SIGINT_TO") == "group"
with open("/proc/self/cmdline", "rb") as f:
    WORKER = b"spawn_main" in f.read()
class Hook:
    fired = False
    def find_spec(self, name, path=None, target=None):
        if name == TARGET and not Hook.fired:
            Hook.fired = True
            if GROUP:
                os.killpg(os.getpgrp(), signal.SIGINT)
            else:
                os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.3)  # the signal is handled (or not) inside the import
        return None
if TARGET and WORKER:
    sys.meta_path.insert(0, Hook())
"""


def _env(tree: Path, module: str | None, to: str) -> dict:
    (tree / "boot").mkdir(exist_ok=True)
    (tree / "boot" / "sitecustomize.py").write_text(SITECUSTOMIZE)
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(tree / "boot"), str(ROOT)]),
            "SGT_CACHE_DIR": str(tree / "cache"), "SGT_TEST_SIGINT_AT": module or "", "SGT_TEST_SIGINT_TO": to}


@pytest.mark.parametrize("module", ["multiprocessing.spawn", "numpy", "sgt_tui.build.work", "model.generate"])
def test_a_worker_never_takes_sigint_for_itself(tree, module):
    """SIGINT to one worker alone, while it starts: it carries on (the build stops its workers
    itself), where it used to die with a traceback and fail the build."""
    r = subprocess.run([sys.executable, "-m", "sgt_tui.cli", "build", str(tree / "src"), "-o", str(tree / "out"),
                        "-j", "2", "--engine", "keyframe", "-q"], env=_env(tree, module, "self"),
                       capture_output=True, text=True, timeout=300, check=False)
    assert (r.returncode, r.stderr) == (0, "")


def _loaded(pid: int, library: str) -> bool:
    try:
        with open(f"/proc/{pid}/maps") as f:
            return library in f.read()
    except OSError:
        return False


# (what the test waits for before the delay, a module a worker sends SIGINT at, delay in seconds)
MOMENTS = [
    ("numpy", None, 0.0),  # the build's own imports
    ("worker", "multiprocessing.spawn", 0.0),  # a worker starting: spawn_main
    ("worker", "numpy", 0.0),  # ... unpickling its initializer: sgt's modules
    ("worker", "model.generate", 0.0),  # ... loading the engine
    ("worker", None, 0.1),
    ("generating", None, 0.0),  # the first utterance is in the cache: generating
]


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc to see the build's processes")
@pytest.mark.parametrize("when,module,delay", MOMENTS)
def test_ctrl_c_at_any_moment_of_a_build_prints_one_line_and_leaves_no_worker(tree, when, module, delay):
    cache = tree / "cache"
    env = _env(tree, module, "group")
    out = tree / "out"
    p = subprocess.Popen([sys.executable, "-m", "sgt_tui.cli", "build", str(tree / "src"), "-o", str(out), "-j", "2"],
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 120
        while p.poll() is None and time.monotonic() < deadline and not module:
            workers = spawned_workers(p.pid) or workers
            if ((when == "numpy" and _loaded(p.pid, "_multiarray_umath")) or (when == "worker" and workers)
                    or (when == "generating" and _entries(cache))):
                break
            time.sleep(0.005)
        if not module:
            time.sleep(delay)
            workers = spawned_workers(p.pid) or workers
            assert p.poll() is None, "the build ended before the interrupt: make the tree longer"
            os.killpg(p.pid, signal.SIGINT)  # what ctrl+c on a terminal does
        else:  # a worker sends it
            while p.poll() is None and time.monotonic() < deadline:
                workers = spawned_workers(p.pid) or workers
                time.sleep(0.005)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
    # 130; or now and then death by SIGINT itself, which a shell shows as the same 130 (see
    # tests/test_interrupts.py: CPython ends so when a KeyboardInterrupt escaped an import)
    assert p.returncode in (130, -signal.SIGINT), err
    assert err.splitlines() == ["interrupted"], err
    deadline = time.monotonic() + 20
    while [w for w in workers if alive(w)] and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [w for w in workers if alive(w)], "worker processes outlived the interrupted build"
    assert not (out / "manifest.json").exists()
