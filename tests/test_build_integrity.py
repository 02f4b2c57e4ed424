"""sgt build cannot lie: one build at a time per output folder, a manifest checked against the
files it lists, outputs that never overwrite inputs, and the warnings sgt check gives.
(Interrupts: tests/test_build_interrupts.py; the rest of the build: tests/test_build.py.)"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from sgt_tui.build import outputs
from sgt_tui.build.lock import LOCK
from sgt_tui.cli import main

ROOT = Path(__file__).resolve().parents[1]
SKIP = {outputs.MANIFEST, outputs.STATE, LOCK}

OVERLAP = """\
@seed 2
guide: Look [pose:point_right] [pose:wave] there now.
guide: A second line, [pose:open_arms] without trouble.
"""


def build(*args) -> int:
    return main(["build", *map(str, args)])


def manifest(out: Path) -> dict:
    return json.loads((out / outputs.MANIFEST).read_text())


def listed(out: Path) -> dict[str, dict]:
    return {r["path"]: r for s in manifest(out)["scripts"] for r in s["outputs"]}


def assert_consistent(out: Path) -> None:
    """The manifest describes every file in ``out``, and only those."""
    records = listed(out)
    present = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file() and p.name not in SKIP}
    assert present == set(records), f"files {sorted(present ^ set(records))} are not what the manifest lists"
    for path, r in records.items():
        data = (out / path).read_bytes()
        assert (hashlib.sha256(data).hexdigest(), len(data)) == (r["sha256"], r["bytes"]), \
            f"{path}: the manifest's sha256 does not describe the file"


def contents(out: Path) -> dict[str, bytes]:
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*"))
            if p.is_file() and p.name not in SKIP}


@pytest.fixture
def game(tmp_path, monkeypatch):
    src = tmp_path / "game"
    src.mkdir()
    for s in range(6):
        lines = [f"guide: Scene {s} line {i}, [pose:beat_right] spoken for the lock test." for i in range(10)]
        (src / f"scene{s}.sgt").write_text("\n".join(lines) + "\n")
    monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / "cache"))
    return src


def _cli(*args) -> list[str]:
    return [sys.executable, "-m", "sgt_tui.cli", "build", *map(str, args)]


def test_two_builds_into_one_folder_take_turns_and_the_manifest_describes_every_file(game, tmp_path):
    """Finding 5 of issue 21: two builds with different engines into one folder, the second
    started while the first is writing. The second waits for the first (saying so, with its
    pid), one with --no-wait refuses at once, and the folder ends as the second build made
    it: every file as the manifest says, and the next build finds it up to date.

    The first build is stopped (SIGSTOP) once it has written its first output, so that the
    second one meets it mid-way every time: without the lock the second would write every
    script meanwhile, and the first, continued, would write the rest and a manifest that
    describes the files it wrote before, which the second replaced."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SGT_CACHE_DIR": str(tmp_path / "cache")}
    out = tmp_path / "out"
    # a keyframe build elsewhere first: what the second build makes, to compare with
    ref = subprocess.run(_cli(game, "-o", tmp_path / "ref", "-j", "1", "-q", "--engine", "keyframe"), env=env,
                         capture_output=True, text=True, timeout=600, check=False)
    assert ref.returncode == 0, ref.stderr
    first = subprocess.Popen(_cli(game, "-o", out, "-j", "1", "-q"), env=env, stderr=subprocess.PIPE, text=True)
    second = None
    try:
        deadline = time.monotonic() + 300
        while not list(out.glob("scene*.json")) and first.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)
        first.send_signal(signal.SIGSTOP)
        assert first.poll() is None, "the first build ended before the second started"
        refused = subprocess.run(_cli(game, "-o", out, "-j", "1", "--engine", "keyframe", "--no-wait"), env=env,
                                 capture_output=True, text=True, timeout=120, check=False)
        second = subprocess.Popen(_cli(game, "-o", out, "-j", "1", "--engine", "keyframe"), env=env,
                                  stderr=subprocess.PIPE, text=True)
        said = second.stderr.readline()  # that it waits; without the lock, its summary once it is done
        first.send_signal(signal.SIGCONT)
        assert first.wait(600) == 0, first.stderr.read()
        said += second.stderr.read()
        assert second.wait(600) == 0, said
    finally:
        for proc in (first, second):
            if proc is not None and proc.poll() is None:
                proc.send_signal(signal.SIGCONT)
                proc.kill()
                proc.wait()
    assert_consistent(out)
    assert manifest(out)["settings"]["engine"] == "keyframe"
    assert contents(out) == contents(tmp_path / "ref")
    assert said.startswith(f"sgt build: waiting for another build into {out} to finish (pid {first.pid})")
    assert refused.returncode == 1
    assert refused.stderr.strip().splitlines() == [
        (f"sgt build: error: {out} is being built by another sgt build (pid {first.pid}); run again when it ends "
         "(without --no-wait it waits for it)")]
    again = subprocess.run(_cli(game, "-o", out, "-j", "1", "--engine", "keyframe"), env=env, capture_output=True,
                           text=True, timeout=600, check=False)
    assert "0 utterances generated, 60 cached, 6 scripts up to date" in again.stderr
    assert not (out / LOCK).exists()  # the holder removes it as it lets go


def test_a_killed_build_leaves_the_folder_unlocked(tmp_path):
    """The kernel drops the lock with its holder: kill -9 never leaves a folder locked."""
    out = tmp_path / "out"
    code = ("import sys, time; from pathlib import Path; from sgt_tui.build.lock import locked\n"
            "with locked(Path(sys.argv[1])):\n    print('locked', flush=True); time.sleep(60)\n")
    holder = subprocess.Popen([sys.executable, "-c", code, str(out)], env={**os.environ, "PYTHONPATH": str(ROOT)},
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        from sgt_tui.build.lock import Busy, locked

        with pytest.raises(Busy, match=f"pid {holder.pid}"), locked(out, wait=False):
            pass
        holder.kill()
        holder.wait()
        with locked(out, wait=False):  # the lock file is still there; nobody holds it
            assert (out / LOCK).read_text().split()[0] == str(os.getpid())
    finally:
        if holder.poll() is None:
            holder.kill()
            holder.wait()


@pytest.fixture
def small(tmp_path, monkeypatch):
    src = tmp_path / "src"
    src.mkdir()
    (src / "a.sgt").write_text("guide: Hello there, [pose:wave] friend.\nguide: The shelf is [pose:point_right] there.\n")
    (src / "b.sgt").write_text("robot: [pose:nod] Yes.\n")
    monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / "cache"))
    return src


def _settle(src: Path, out: Path, *extra) -> None:
    """Build, and build again once the outputs are old enough to be trusted by their size,
    times and inode (outputs.RACY_NS): from then on a rebuild reads none of them."""
    assert build(src, "-o", out, "-j", "1", "-q", "--engine", "keyframe", *extra) == 0
    time.sleep(outputs.RACY_NS / 1e9 + 0.2)
    assert build(src, "-o", out, "-j", "1", "-q", "--engine", "keyframe", *extra) == 0


def test_a_rebuild_trusts_intact_outputs_without_reading_them(small, tmp_path, monkeypatch):
    out = tmp_path / "out"
    _settle(small, out, "--bvh")
    reads = []
    real = outputs._read
    monkeypatch.setattr(outputs, "_read", lambda path: (reads.append(path), real(path))[1])
    assert build(small, "-o", out, "-j", "1", "-q", "--engine", "keyframe", "--bvh") == 0
    assert reads == []


def test_outputs_changed_behind_the_builds_back_are_made_again_and_reported(small, tmp_path, capsys):
    """An output rewritten in place with the same size and its old modification time, one
    whose size differs and one removed: the next build finds each, makes it again and says
    so (the size and time alone, which the previous builds trusted, said "up to date")."""
    out = tmp_path / "out"
    _settle(small, out, "--bvh")
    good = contents(out)
    a = out / "a.json"
    st = a.stat()
    with open(a, "r+b") as f:  # same size, same modification time, other content
        data = f.read()
        f.seek(0)
        f.write(data.replace(b'"text"', b'"txet"', 1))
    os.utime(a, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert a.stat().st_size == st.st_size and a.stat().st_mtime_ns == st.st_mtime_ns
    (out / "a.bvh").write_bytes(good["a.bvh"] + b"\n")
    (out / "b.json").unlink()
    capsys.readouterr()
    assert build(small, "-o", out, "-j", "1", "--engine", "keyframe", "--bvh") == 0
    err = capsys.readouterr().err
    for name, why in (("a.json", "changed"), ("a.bvh", "changed"), ("b.json", "removed")):
        assert f"sgt build: warning: {out / name} did not match the manifest ({why} since the last build): made again" in err
    assert "b.bvh" not in err
    assert contents(out) == good
    assert_consistent(out)
    assert build(small, "-o", out, "-j", "1", "--engine", "keyframe", "--bvh", "-q") == 0
    assert capsys.readouterr().err == ""


def test_an_output_changed_in_the_tick_it_was_looked_at_is_not_trusted(tmp_path):
    """The racy case: a file changed in place in the same clock tick as the look that recorded
    its size and times keeps them all; a state entry that young never vouches for it."""
    path = tmp_path / "x"
    path.write_bytes(b"data")
    st = path.stat()
    digest = hashlib.sha256(b"data").hexdigest()
    changed = max(st.st_mtime_ns, st.st_ctime_ns)
    young = outputs._seen(st) + [digest, changed + 1_000_000]
    old = outputs._seen(st) + [digest, changed + outputs.RACY_NS + 1]
    assert not outputs.trusted(young, st, digest)
    assert outputs.trusted(old, st, digest)
    assert not outputs.trusted(old, st, "another digest")


# -- outputs that are inputs ------------------------------------------------------------------


def _recording(folder: Path, name: str = "rec.wav") -> None:
    t = np.arange(16000) / 16000
    sf.write(str(folder / name), 0.3 * np.sin(2 * np.pi * 220 * t), 16000)


TIMINGS = json.dumps([{"word": "Well", "start": 0.1, "end": 0.4}, {"word": "hello", "start": 0.5, "end": 0.9}])


def test_an_output_that_is_a_scripts_timings_file_fails_that_script_and_the_others_build(small, tmp_path, capsys):
    """lobby.sgt speaks rec.wav timed by lobby.json; built into its own folder its motion file
    would be lobby.json: lobby.sgt is reported and not built, lobby.json is left as it was,
    the other scripts build."""
    _recording(small)
    (small / "lobby.json").write_text(TIMINGS)
    (small / "lobby.sgt").write_text("@audio rec.wav timings=lobby.json\nguide: Well hello.\n")
    assert build(small, "-o", small, "-j", "1", "--engine", "keyframe") == 1
    err = capsys.readouterr().err
    assert (f"sgt build: error: {small / 'lobby.sgt'}: not built: its output {small / 'lobby.json'} is the timings "
            f"file that it reads; writing it would destroy it: build into another folder (-o) or rename the file") in err
    assert (small / "lobby.json").read_text() == TIMINGS
    status = {s["source"]: s["status"] for s in manifest(small)["scripts"]}
    assert status == {"a.sgt": "ok", "b.sgt": "ok", "lobby.sgt": "failed"}
    assert (small / "a.json").is_file()
    # built into another folder, it builds
    assert build(small, "-o", tmp_path / "elsewhere", "-j", "1", "-q", "--engine", "keyframe") == 0


def test_outputs_that_are_inputs_through_links_or_of_another_script_are_refused(small, tmp_path, capsys):
    data = tmp_path / "data"
    data.mkdir()
    _recording(data)
    (data / "t.json").write_text(TIMINGS)
    (small / "rec.sgt").write_text(f"@audio {data / 'rec.wav'} timings={data / 't.json'}\nguide: Well hello.\n")
    out = tmp_path / "out"
    out.mkdir()
    os.link(data / "t.json", out / "a.json")  # a's motion file would be rec.sgt's timings file (a hard link)
    (out / "b_001.wav").symlink_to(data / "rec.wav")  # b's speech would be written through the link
    assert build(small, "-o", out, "-j", "1", "--engine", "keyframe", "--wav") == 1
    err = capsys.readouterr().err
    assert (f"{small / 'a.sgt'}: not built: its output {out / 'a.json'} is the timings file {data / 't.json'} that "
            f"{small / 'rec.sgt'} reads") in err
    assert (f"{small / 'b.sgt'}: not built: its output {out / 'b_001.wav'} is the recording {data / 'rec.wav'} that "
            f"{small / 'rec.sgt'} reads") in err
    assert (data / "t.json").read_text() == TIMINGS and (out / "a.json").read_text() == TIMINGS
    assert sf.info(str(data / "rec.wav")).frames == 16000
    assert {s["source"]: s["status"] for s in manifest(out)["scripts"]} == {"a.sgt": "failed", "b.sgt": "failed",
                                                                           "rec.sgt": "ok"}


def test_an_up_to_date_output_that_another_script_starts_reading_is_kept_and_its_script_reported(small, tmp_path, capsys):
    """b.sgt is built; then c.sgt names b's motion file as its timings (a mistake: it is no
    timings file). b's next build would overwrite c's input: b is reported, and its motion
    file is neither rewritten nor removed as a failed script's outputs are."""
    out = tmp_path / "out"
    assert build(small, "-o", out, "-j", "1", "-q", "--engine", "keyframe") == 0
    motion = (out / "b.json").read_bytes()
    _recording(small)
    (small / "c.sgt").write_text(f"@audio rec.wav timings={out / 'b.json'}\nguide: Well hello.\n")
    assert build(small, "-o", out, "-j", "1", "--engine", "keyframe") == 1
    err = capsys.readouterr().err
    assert f"{small / 'b.sgt'}: not built: its output {out / 'b.json'} is the file that {small / 'c.sgt'} reads" in err
    assert (out / "b.json").read_bytes() == motion


def test_a_manifest_that_is_an_input_refuses_the_build_before_any_work(small, tmp_path, capsys):
    _recording(small)
    (small / "manifest.json").write_text(TIMINGS)
    (small / "m.sgt").write_text("@audio rec.wav timings=manifest.json\nguide: Well hello.\n")
    before = {p.name: p.read_bytes() for p in small.iterdir()}
    assert build(small, "-o", small, "-j", "1", "--engine", "keyframe") == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        (f"sgt build: error: {small / 'manifest.json'}, the build's manifest, is the timings file "
         f"{small / 'manifest.json'} that {small / 'm.sgt'} reads; writing it would destroy it: build into another "
         f"folder (-o)")]
    assert {p.name: p.read_bytes() for p in small.iterdir()} == before


# -- warnings -----------------------------------------------------------------------------------


def _warning_lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if ": warning: [" in line]


def test_build_prints_the_warnings_sgt_check_prints_once_per_script(small, tmp_path, capsys):
    """The SGT401 overlap warnings (with real speech timing, as `sgt check --timing` and `sgt
    generate` give them) and the analysis's (SGT118), once per script: on the build that
    generates, on a rebuild with nothing changed, with two workers, after the lines moved;
    none with --quiet."""
    (small / "o.sgt").write_text(OVERLAP + "@gap 1s\n")
    out = tmp_path / "out"
    assert main(["check", "--timing", str(small / "o.sgt")]) == 0
    expected = _warning_lines("".join(capsys.readouterr()))
    assert any("[SGT401]" in w for w in expected) and any("[SGT118]" in w for w in expected)

    def warnings(*extra) -> list[str]:
        capsys.readouterr()
        assert build(small, "-o", out, "--engine", "keyframe", *extra) == 0
        return _warning_lines(capsys.readouterr().err)

    assert warnings("-j", "1") == expected
    assert warnings("-j", "1") == expected  # up to date: from the build's record
    assert warnings("-j", "2", "--seed", "4") == expected  # other settings: every script analysed and written again
    (small / "o.sgt").write_text("# moved down\n\n" + OVERLAP + "@gap 1s\n")
    assert main(["check", "--timing", str(small / "o.sgt")]) == 0
    moved = _warning_lines("".join(capsys.readouterr()))
    assert moved != expected
    assert warnings("-j", "1", "--seed", "4") == moved  # nothing generated: the keys are the same
    assert warnings("-j", "1", "--seed", "4", "-q") == []


def test_a_fifo_named_as_a_script_is_reported_and_does_not_hang_the_build(small, tmp_path, capsys):
    os.mkfifo(small / "pipe.sgt")  # nobody writes it: opening it to read would wait for ever
    code = ("import sys; from sgt_tui.cli import main; "
            f"sys.exit(main(['build', {str(small / 'pipe.sgt')!r}, {str(small / 'a.sgt')!r}, '-o', "
            f"{str(tmp_path / 'out')!r}, '-j', '1', '--engine', 'keyframe']))")
    r = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(ROOT)},
                       capture_output=True, text=True, timeout=120, check=False)
    assert r.returncode == 1, r.stderr
    assert "pipe.sgt: error: [SGT601] cannot read the script: it is a FIFO" in r.stderr
    assert (tmp_path / "out" / "a.json").is_file()
