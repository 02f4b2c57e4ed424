"""sgt build: outputs, manifest, incremental rebuilds, byte-identical builds, errors, kill -9
and resume, progress, Ray. Keys themselves: tests/test_build_keys.py."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from processes import children

from core.motion import load_motion
from sgt_tui.build.outputs import STATE
from sgt_tui.cli import main
from sgt_tui.progress import BuildProgress

ROOT = Path(__file__).resolve().parents[1]

ACT1 = """\
@seed 5
guide: Welcome to the mall! [pose:open_arms] How can I help?
guide: The shelf is over [pose:point_right x2] there.
"""
ACT2 = """\
@voice robot: en-us+m3
robot: [pose:wave] Hello.
robot: <speed:-1>I am slower</speed> now.
"""
BAD = """\
guide: hi [pose:point_rigth] and more
guide: fine <speed:+9>too fast</speed>
"""


@pytest.fixture
def env(tmp_path, monkeypatch):
    """A source tree and a private sgt cache (speech and build)."""
    src = tmp_path / "game"
    (src / "act1").mkdir(parents=True)
    (src / "act1" / "intro.sgt").write_text(ACT1)
    (src / "act2.sgt").write_text(ACT2)
    monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path


def build(*args) -> int:
    return main(["build", *map(str, args)])


def files(folder: Path) -> dict[str, bytes]:
    """Every file but the build's record of output sizes and times (outputs.STATE)."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != STATE}


def manifest(out: Path) -> dict:
    return json.loads((out / "manifest.json").read_text())


def cached_flags(out: Path) -> dict[str, list[bool]]:
    return {s["source"]: [u["cached"] for u in s.get("utterances", [])] for s in manifest(out)["scripts"]}


def without_cached(doc: dict) -> dict:
    for s in doc["scripts"]:
        for u in s.get("utterances", []):
            u.pop("cached")
    return doc


def test_layout_mirrors_the_sources_and_the_manifest_hashes_every_output(env, capsys):
    out = env / "out"
    assert build(env / "game", "-o", out, "--bvh", "--wav", "--glb", "-j", "1") == 0
    got = files(out)
    assert set(got) == {"manifest.json", "act1/intro.json", "act1/intro.bvh", "act1/intro.glb", "act1/intro_001.wav",
                        "act1/intro_002.wav", "act2.json", "act2.bvh", "act2.glb", "act2_001.wav", "act2_002.wav"}
    doc = manifest(out)
    import hashlib

    listed = {r["path"]: r for s in doc["scripts"] for r in s["outputs"]}
    assert set(listed) == set(got) - {"manifest.json"}
    for path, record in listed.items():
        assert record["sha256"] == hashlib.sha256(got[path]).hexdigest() and record["bytes"] == len(got[path])
    assert cached_flags(out) == {"act1/intro.sgt": [False, False], "act2.sgt": [False, False]}
    clips = load_motion(out / "act1" / "intro.json")
    assert [c.text for c in clips] == ["Welcome to the mall! How can I help?", "The shelf is over there."]
    # a control keeps the line it was written on
    assert [c.line for c in clips[1].controls if c.kind == "pose"] == [3]
    assert got["act1/intro_001.wav"][:4] == b"RIFF"
    assert "4 utterances generated, 0 cached" in capsys.readouterr().err


def test_a_rebuild_with_nothing_changed_writes_nothing(env, capsys):
    out = env / "out"
    assert build(env / "game", "-o", out, "--bvh", "-j", "1") == 0
    stamps = {p: p.stat().st_mtime_ns for p in out.rglob("*.*") if p.name not in ("manifest.json", STATE)}
    before = files(out)
    capsys.readouterr()
    assert build(env / "game", "-o", out, "--bvh", "-j", "1") == 0
    assert "0 utterances generated, 4 cached, 2 scripts up to date" in capsys.readouterr().err
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    assert without_cached(json.loads(files(out)["manifest.json"])) == without_cached(json.loads(before["manifest.json"]))
    assert cached_flags(out) == {"act1/intro.sgt": [True, True], "act2.sgt": [True, True]}


def test_one_line_changed_regenerates_one_utterance(env, capsys):
    out = env / "out"
    assert build(env / "game", "-o", out, "-j", "1") == 0
    act2 = (out / "act2.json").read_bytes()
    # a comment above moves every line; one utterance's text changes
    (env / "game" / "act1" / "intro.sgt").write_text("# moved\n" + ACT1.replace("over [pose", "right over [pose"))
    capsys.readouterr()
    assert build(env / "game", "-o", out, "-j", "1") == 0
    assert "1 utterance generated, 3 cached, 1 script up to date" in capsys.readouterr().err
    assert cached_flags(out) == {"act1/intro.sgt": [True, False], "act2.sgt": [True, True]}
    assert (out / "act2.json").read_bytes() == act2
    clips = load_motion(out / "act1" / "intro.json")
    assert clips[1].text == "The shelf is right over there."
    # the cached utterance's controls follow its new line
    assert [c.line for c in clips[0].controls if c.kind == "pose"] == [3]


def test_an_edit_is_generated_by_the_warm_worker_alone(env, monkeypatch, capsys):
    """One utterance to regenerate with --jobs 2: the build waits for the worker it started
    while reading the scripts instead of starting a second one (whose imports would share the
    two cores with it and with the build), and the result is the same as with one job."""
    from sgt_tui.build import runners

    out = env / "out"
    assert build(env / "game", "-o", out, "-j", "1") == 0
    started = []
    close = runners.LocalPool.close

    def counting_close(self, wait=True):
        started.append(len(self.pool._processes or {}))  # the executor's worker processes
        close(self, wait)

    monkeypatch.setattr(runners.LocalPool, "close", counting_close)
    (env / "game" / "act1" / "intro.sgt").write_text(ACT1.replace("over [pose", "right over [pose"))
    capsys.readouterr()
    assert build(env / "game", "-o", out, "-j", "2") == 0
    assert "1 utterance generated, 3 cached" in capsys.readouterr().err
    assert started[0] == 1  # (build() closes the pool again afterwards: nothing left to count)
    two = (out / "act1" / "intro.json").read_bytes()
    monkeypatch.setenv("SGT_CACHE_DIR", str(env / "cache2"))
    assert build(env / "game", "-o", env / "one", "-j", "1") == 0
    assert (env / "one" / "act1" / "intro.json").read_bytes() == two


def test_builds_are_byte_identical_across_folders_caches_and_worker_counts(env, monkeypatch):
    assert build(env / "game", "-o", env / "a", "--bvh", "--glb", "--wav", "-j", "1") == 0
    # a clean cache, two worker processes, another output folder
    monkeypatch.setenv("SGT_CACHE_DIR", str(env / "cache2"))
    assert build(env / "game", "-o", env / "b", "--bvh", "--glb", "--wav", "-j", "2") == 0
    # the first cache again: everything cached
    monkeypatch.setenv("SGT_CACHE_DIR", str(env / "cache"))
    assert build(env / "game", "-o", env / "c", "--bvh", "--glb", "--wav", "-j", "2") == 0
    a, b, c = files(env / "a"), files(env / "b"), files(env / "c")
    docs = [json.loads(x.pop("manifest.json")) for x in (a, b, c)]
    assert a == b == c
    assert without_cached(docs[0]) == without_cached(docs[1]) == without_cached(docs[2])
    assert cached_flags(env / "c") == {"act1/intro.sgt": [True, True], "act2.sgt": [True, True]}


def test_scripts_with_errors_are_reported_and_the_others_built(env, capsys):
    (env / "game" / "bad.sgt").write_text(BAD)
    out = env / "out"
    assert build(env / "game", env / "missing.sgt", "-o", out, "-j", "1") == 1
    err = capsys.readouterr().err
    bad = env / "game" / "bad.sgt"
    # every problem, as sgt check reports them
    assert main(["check", str(bad)]) == 1
    check_lines = [line for line in capsys.readouterr().out.splitlines() if ": error: " in line]
    assert len(check_lines) == 2
    for line in check_lines:
        assert line in err
    assert "missing.sgt:" in err and "cannot read the script" in err
    assert "built 2 of 4 scripts" in err and "2 failed" in err
    assert (out / "game" / "act2.json").is_file() and (out / "game" / "act1" / "intro.json").is_file()
    status = {s["source"]: s["status"] for s in manifest(out)["scripts"]}
    assert status == {"game/act1/intro.sgt": "ok", "game/act2.sgt": "ok", "game/bad.sgt": "failed", "missing.sgt": "failed"}
    # fixed: the next build makes it and the others stay cached
    bad.write_text(BAD.replace("point_rigth", "point_right").replace("+9", "+1"))
    assert build(env / "game", "-o", env / "out2", "-j", "1", "-q") == 0
    assert capsys.readouterr().err == ""


def test_a_script_named_like_the_manifest_is_refused_not_overwritten(env, capsys):
    (env / "game" / "manifest.sgt").write_text(ACT2)
    out = env / "out"
    assert build(env / "game", "-o", out, "-j", "1", "-q") == 1
    assert "manifest.sgt: its motion file would be" in capsys.readouterr().err
    assert manifest(out)["format"] == "sgt-build"
    assert {s["source"]: s["status"] for s in manifest(out)["scripts"]}["manifest.sgt"] == "failed"


def test_a_script_that_starts_failing_loses_its_outputs_and_a_removed_one_too(env):
    out = env / "out"
    assert build(env / "game", "-o", out, "--bvh", "-j", "1", "-q") == 0
    (env / "game" / "act2.sgt").write_text(BAD)
    (env / "game" / "act1" / "intro.sgt").rename(env / "game" / "act1" / "intro.txt")
    assert build(env / "game", "-o", out, "--bvh", "-j", "1", "-q") == 1
    assert set(files(out)) == {"manifest.json"}


def test_a_damaged_cache_entry_is_regenerated(env, capsys):
    out = env / "out"
    assert build(env / "game", "-o", out, "-j", "1", "-q") == 0
    reference = files(out)
    entries = sorted(p for p in (env / "cache" / "build").rglob("*") if p.is_file())
    assert len(entries) == 4
    entries[0].write_bytes(entries[0].read_bytes()[:-10])
    assert build(env / "game", "-o", env / "again", "-j", "1") == 0
    assert "1 utterance generated, 3 cached" in capsys.readouterr().err
    again = files(env / "again")
    reference.pop("manifest.json"), again.pop("manifest.json")
    assert again == reference


def test_an_output_edited_by_hand_is_rewritten(env):
    out = env / "out"
    assert build(env / "game", "-o", out, "-j", "1", "-q") == 0
    good = (out / "act2.json").read_bytes()
    (out / "act2.json").write_text("{}")
    assert build(env / "game", "-o", out, "-j", "1", "-q") == 0
    assert (out / "act2.json").read_bytes() == good
    # the same size, another content: the recorded size and time no longer match, so it is read again
    (out / "act2.json").write_bytes(good.replace(b'"text"', b'"txet"'))
    assert build(env / "game", "-o", out, "-j", "1", "-q") == 0
    assert (out / "act2.json").read_bytes() == good


def test_usage_errors(env, capsys):
    (env / "empty").mkdir()
    assert build(env / "empty", "-o", env / "out") == 2
    assert "no .sgt scripts under" in capsys.readouterr().err
    (env / "file").write_text("x")
    assert build(env / "game", "-o", env / "file") == 2
    assert build(env / "game", "-o", env / "out", "--jobs", "0") == 2
    assert build(env / "game", "-o", env / "out", "--ray", "auto", "--jobs", "2") == 2
    assert not (env / "out").exists()


def test_quiet_prints_nothing_and_the_bar_counts(env, capsys):
    assert build(env / "game", "-o", env / "out", "-j", "1", "--quiet") == 0
    assert capsys.readouterr().err == ""

    class Tty:
        def __init__(self):
            self.text = ""

        def isatty(self):
            return True

        def write(self, s):
            self.text += s

        def flush(self):
            pass

    from sgt_tui.build import Progress

    stream = Tty()
    bar = BuildProgress(stream)
    bar(Progress(total=10, done=2, cached=2))
    bar._last = 0.0
    bar._first = (bar._first[0] - 4.0, 2)  # 4 s ago, then 4 generated: 1 s each, 4 left
    bar(Progress(total=10, done=6, cached=2, failed=0))
    assert "6/10 utterances, 2 cached, 0 failed" in stream.text and "ETA 4s" in stream.text
    bar(Progress(total=10, done=9, cached=2, failed=1))
    assert stream.text.endswith("\n") and "1 failed" in stream.text and "ETA 0s" in stream.text


def _entries(cache: Path) -> int:
    return sum(1 for p in (cache / "build").rglob("*") if p.is_file() and not p.name.startswith("."))


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_kill_9_mid_build_leaves_no_half_written_output_and_the_next_run_finishes(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    lines = [f"guide: Line {i} of scene {s}, [pose:beat_right] said slowly and clearly for the test." for s in range(4)
             for i in range(6)]
    for s in range(4):
        (src / f"scene{s}.sgt").write_text("\n".join(lines[s * 6 : s * 6 + 6]) + "\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SGT_CACHE_DIR": str(tmp_path / "cache")}
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "sgt_tui.cli", "build", str(src), "-o", str(out), "--bvh", "-j", "1", "-q"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 240
        while _entries(tmp_path / "cache") < 8 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        workers = children(proc.pid)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait(30)
    assert proc.returncode == -signal.SIGKILL
    deadline = time.monotonic() + 20  # the workers end with the build that started them
    while [w for w in workers if _alive(w)] and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [w for w in workers if _alive(w)], "worker processes outlived the killed build"
    done = _entries(tmp_path / "cache")
    assert 8 <= done < 24, f"the kill did not land mid-way ({done} of 24 utterances were cached)"
    assert not (out / "manifest.json").exists()
    for path in out.glob("*.json"):  # whatever was written is whole
        assert len(load_motion(path)) == 6

    resumed = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    flags = [f for s in manifest(out)["scripts"] for f in [u["cached"] for u in s["utterances"]]]
    assert flags.count(True) >= done and flags.count(False) == 24 - flags.count(True)
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]

    env["SGT_CACHE_DIR"] = str(tmp_path / "clean")
    clean = subprocess.run(cmd[:6] + [str(tmp_path / "clean_out")] + cmd[7:], env=env, capture_output=True, text=True,
                           timeout=600)
    assert clean.returncode == 0, clean.stderr
    a, b = files(out), files(tmp_path / "clean_out")
    a.pop("manifest.json"), b.pop("manifest.json")
    assert a == b and len(a) == 8


def test_ray_builds_the_same_bytes(env, capsys):
    pytest.importorskip("ray")
    assert build(env / "game", "-o", env / "local", "--bvh", "-j", "1", "-q") == 0
    os.environ["SGT_CACHE_DIR"] = str(env / "ray-cache")  # monkeypatch restores it (set by the fixture)
    capsys.readouterr()
    assert build(env / "game", "-o", env / "ray", "--bvh", "--ray", "-j", "2", "-q") == 0
    assert capsys.readouterr().err == ""  # --quiet: nothing of Ray's either
    a, b = files(env / "local"), files(env / "ray")
    assert cached_flags(env / "ray") == {"act1/intro.sgt": [False, False], "act2.sgt": [False, False]}
    a.pop("manifest.json"), b.pop("manifest.json")
    assert a == b


def test_a_file_name_that_is_not_utf8_builds_and_the_manifest_stays_json(env):
    name = os.fsdecode(b"sc\x80ne.sgt")
    (env / "game" / name).write_text(ACT2)
    out = env / "out"
    assert build(env / "game", "-o", out, "-j", "1", "-q", "--engine", "keyframe") == 0
    assert name in {s["source"] for s in manifest(out)["scripts"]}
    assert (out / os.fsdecode(b"sc\x80ne.json")).is_file()


def test_outputs_are_on_the_performance_clock_with_tracks_and_hands_from_the_cache(env):
    from core.hands import HandTrack
    from core.motion import load_motion_file

    assert build(env / "game", "-o", env / "a", "--bvh", "-j", "1", "-q") == 0
    assert build(env / "game", "-o", env / "b", "--bvh", "-j", "1", "-q") == 0  # every utterance from the cache
    assert cached_flags(env / "b")["act1/intro.sgt"] == [True, True]
    for out in ("a", "b"):
        m = load_motion_file(env / out / "act1" / "intro.json")
        first, second = m.clips
        assert first.start == 0 and second.start >= first.start + first.n_frames / 15  # one after the other on the clock
        assert first.audio_offset is not None and second.audio_offset is not None
        assert len(m.tracks) == 1 and m.tracks[0].n_frames >= second.start_frame + second.n_frames
        # point_right's hand shape survives the cache (a relaxed hand would lose it)
        rest = HandTrack.rest(second.n_frames)
        assert np.abs(second.hands.fingers - rest.fingers).max() > 10
    a, b = files(env / "a"), files(env / "b")
    a.pop("manifest.json"), b.pop("manifest.json")  # it says which utterances came from the cache
    assert a == b


def test_a_rebuild_analyses_only_the_scripts_whose_inputs_changed(env, monkeypatch, capsys):
    """An unchanged script is taken from the manifest without being parsed again; a change to
    anything its analysis read (its bytes, a gesture file of its @library folder, a new gesture
    file there, a recording, the options, SGT_LIBRARY_PATH) analyses it again, and a gesture
    edited that way regenerates the utterances that use it."""
    import dsl.compiler

    game = env / "game"
    (game / "moves").mkdir()
    spec = (ROOT / "library" / "gestures" / "beat_both.toml").read_text()
    (game / "moves" / "my_beat.toml").write_text(spec.replace('name = "beat_both"', 'name = "my_beat"'))
    (game / "act3.sgt").write_text("@library ./moves\nguide: Look [pose:my_beat] at this.\n@gap 1s\n")  # a warning
    analysed = []
    real = dsl.compiler.load_script
    monkeypatch.setattr(dsl.compiler, "load_script", lambda path, **kw: (analysed.append(Path(path).name), real(path, **kw))[1])
    out = env / "out"

    def rebuild(*extra) -> list[str]:
        analysed.clear()
        assert build(game, "-o", out, "-j", "1", *extra) == 0
        return sorted(set(analysed))

    assert rebuild() == ["act2.sgt", "act3.sgt", "intro.sgt"]
    capsys.readouterr()
    assert rebuild() == []  # nothing changed: nothing parsed
    err = capsys.readouterr().err
    assert "0 utterances generated, 5 cached, 3 scripts up to date" in err
    assert "SGT118" in err and "act3.sgt:3" in err  # its warning, shown again from the record
    (game / "act2.sgt").write_text(ACT2 + "# a comment\n")
    assert rebuild() == ["act2.sgt"]
    motion = (out / "act3.json").read_bytes()
    (game / "moves" / "my_beat.toml").write_text(spec.replace('name = "beat_both"', 'name = "my_beat"')
                                                 .replace("duration = 0.8", "duration = 1.2"))
    capsys.readouterr()
    assert rebuild() == ["act3.sgt"]
    assert "1 utterance generated" in capsys.readouterr().err and (out / "act3.json").read_bytes() != motion
    (game / "moves" / "other.toml").write_text(spec.replace('name = "beat_both"', 'name = "other"'))
    assert rebuild() == ["act3.sgt"]
    assert rebuild("--seed", "9") == ["act2.sgt", "act3.sgt", "intro.sgt"]
    assert rebuild("--seed", "9") == []
    monkeypatch.setenv("SGT_LIBRARY_PATH", str(game / "moves"))
    assert rebuild("--seed", "9") == ["act2.sgt", "act3.sgt", "intro.sgt"]
    (out / "act2.json").unlink()  # an output gone: its script is built (and so analysed) again
    assert rebuild("--seed", "9") == ["act2.sgt"]
