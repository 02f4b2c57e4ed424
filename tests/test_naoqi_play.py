"""sgt play-nao (renders/naoqi_play.py) against a fake qi session (tests/fake_qi/qi.py) that
records the calls and their times, run as a user runs the command."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FRAME = 1 / 15


def sgt(*args, cwd, fake_qi=True, log=None):
    path = [str(ROOT)] + ([str(ROOT / "tests" / "fake_qi")] if fake_qi else [])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(path), FAKE_QI_LOG=str(log or cwd / "calls.json"))
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *map(str, args)], check=False, capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
def take(tmp_path_factory):
    folder = tmp_path_factory.mktemp("nao")
    (folder / "t.sgt").write_text("guide: [pose:wave] Hello there, [pose:point_right] look over there.\n")
    r = sgt("export", "t.sgt", "--rig", "nao", "-o", "t.nao.json", "--engine", "keyframe", cwd=folder, fake_qi=False)
    assert r.returncode == 0, r.stderr
    return folder, json.loads((folder / "t.nao.json").read_text())


def test_audio_and_motion_start_together_after_the_first_key(take):
    folder, doc = take
    r = sgt("play-nao", "t.nao.json", "--url", "tcp://10.0.0.7:9559", "--audio", "/home/nao/t.wav", cwd=folder)
    assert r.returncode == 0, r.stderr
    calls = json.loads((folder / "calls.json").read_text())
    assert [(c["service"], c["method"], c["async"]) for c in calls] == [
        ("Session", "connect", False), ("ALMotion", "wakeUp", False), ("ALAudioPlayer", "loadFile", False),
        ("ALMotion", "getAngles", False), ("ALMotion", "angleInterpolation", False),
        ("ALAudioPlayer", "play", True), ("ALMotion", "angleInterpolation", True)]
    assert calls[0]["args"] == ["tcp://10.0.0.7:9559"] and calls[2]["args"] == ["/home/nao/t.wav"]
    settle, audio, motion = calls[4], calls[5], calls[6]
    names, first, times, absolute = settle["args"]
    assert names == doc["names"] and absolute is True
    assert first == [a[0] for a in doc["angleLists"]]  # the first key itself, not the move's start
    assert min(times) >= 1.0 and len(set(times)) == 1
    assert audio["args"] == [7]  # the file loaded before
    # The robot stands at the first key before the audio starts, and the audio starts within a frame of the motion.
    assert audio["at"] >= settle["done"]
    assert abs(motion["at"] - audio["at"]) < FRAME
    names, angles, times, absolute = motion["args"]
    assert angles == [a[1:] for a in doc["angleLists"]]
    assert times[0][0] == pytest.approx(FRAME, abs=1e-6) and times[0][-1] == pytest.approx((len(doc["angleLists"][0]) - 1) * FRAME, abs=1e-6)
    assert "audio and motion started" in r.stderr


def test_dry_run_prints_the_calls_on_the_robots_clock(take):
    folder, _ = take
    r = sgt("play-nao", "t.nao.json", "--audio", "/home/nao/t.wav", "--dry-run", cwd=folder, fake_qi=False,
            log=folder / "none.json")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert [line.split()[2].split("(")[0] for line in lines] == [
        "ALMotion.wakeUp", "ALAudioPlayer.loadFile", "ALMotion.getAngles", "ALMotion.angleInterpolation",
        "ALAudioPlayer.play", "ALMotion.angleInterpolation"]
    start_of_play = float(lines[4].split()[0])
    assert start_of_play >= 1.0 and lines[4].endswith("[async]") and float(lines[5].split()[0]) == start_of_play
    assert not (folder / "none.json").exists() and r.stderr.startswith("dry run: would play")


def test_missing_sdk_and_bad_takes_are_one_line(take, tmp_path):
    folder, _ = take
    r = sgt("play-nao", "t.nao.json", cwd=folder, fake_qi=False)
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "'pip install qi'" in r.stderr
    (tmp_path / "bad.json").write_text('{"names": ["HeadYaw"], "angleLists": [[0.1, "x"]]}')
    r = sgt("play-nao", "bad.json", "--dry-run", cwd=tmp_path)
    assert r.returncode == 1 and r.stderr == ("sgt play-nao: error: bad.json: angleLists of HeadYaw: every joint needs "
                                              "the same number (at least 1) of angles in radians\n")
