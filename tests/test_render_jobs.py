"""`sgt render --jobs N`: a long take's frames drawn in worker processes give the same GIF and
MP4 bytes as one process, and ctrl+c leaves no worker behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from processes import alive, spawned_workers

from renders.animate import PARALLEL_FRAMES

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = """@voice a: en-us
@voice b: en-gb
a: [pose:wave] Good morning, and welcome to the front desk of the hotel.
b: [pose:point_self] Thank you. I have a room booked for two nights, under my name.
a: [pose:nod] Yes, here it is. [pose:point_right] The lifts are on your right.
"""


def _sgt(*args, timeout=600):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *args], env=env, capture_output=True, text=True,
                          timeout=timeout, check=False)


@pytest.fixture(scope="module")
def take(tmp_path_factory):
    d = tmp_path_factory.mktemp("jobs")
    (d / "scene.sgt").write_text(SCRIPT)
    r = _sgt("generate", str(d / "scene.sgt"), "-o", str(d / "take.json"), "--engine", "keyframe")
    assert r.returncode == 0, r.stderr
    return d / "take.json"


def _frames(stderr: str) -> int:
    line = next(x for x in stderr.splitlines() if x.startswith("wrote "))
    return int(line.split(": ", 1)[1].split(" frames")[0])


def test_a_gif_is_the_same_bytes_for_any_jobs(take, tmp_path):
    outs = []
    for jobs in (1, 2):
        out = tmp_path / f"jobs{jobs}.gif"
        r = _sgt("render", str(take), "-o", str(out), "--size", "96", "--jobs", str(jobs))
        assert r.returncode == 0, r.stderr
        assert _frames(r.stderr) >= PARALLEL_FRAMES  # long enough to be drawn by the workers
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]


def test_an_mp4_with_sound_is_the_same_bytes_for_any_jobs_and_every_run(take, tmp_path):
    """The MP4 (H.264 and the speech's AAC) of `sgt render`: the same bytes from two runs with
    --jobs 1 and one with --jobs 2 (renders.video.X264_OPTIONS: x264's canonical code, one
    encoder thread)."""
    outs = []
    for run, jobs in enumerate((1, 1, 2)):
        out = tmp_path / f"run{run}.mp4"
        r = _sgt("render", str(take), "-o", str(out), "--size", "96", "--jobs", str(jobs))
        assert r.returncode == 0, r.stderr
        assert _frames(r.stderr) >= PARALLEL_FRAMES
        assert "with sound" in r.stderr
        outs.append(out.read_bytes())
    assert outs[0] == outs[1] == outs[2]


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc to see the render's processes")
@pytest.mark.parametrize("delay", [0.0, 3.0])
def test_ctrl_c_leaves_no_worker(take, tmp_path, delay):
    """SIGINT to the process group (a terminal's ctrl+c) as the workers start, and while they
    draw: the render ends with 130 and one line, no worker left, no output written."""
    out = tmp_path / "take.gif"
    p = subprocess.Popen([sys.executable, "-m", "sgt_tui.cli", "render", str(take), "-o", str(out), "--jobs", "2"],
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, start_new_session=True)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 120
        while p.poll() is None and time.monotonic() < deadline and len(workers) < 2:
            workers = spawned_workers(p.pid)
            time.sleep(0.005)
        time.sleep(delay)
        assert p.poll() is None, "the render ended before the interrupt: make the take longer"
        os.killpg(p.pid, signal.SIGINT)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
    assert workers, "no worker process was started"
    assert p.returncode in (130, -signal.SIGINT), err
    assert err.splitlines() == ["interrupted"], err
    deadline = time.monotonic() + 20
    while [w for w in workers if alive(w)] and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [w for w in workers if alive(w)], "worker processes outlived the interrupted render"
    assert not out.exists()
