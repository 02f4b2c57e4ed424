"""The hostile audit of issue 21, finding by finding: each input it reported, as a test that
failed on the code it audited (742c655) and passes now.

Commands run as the user runs them (a subprocess where a crash would end the process, the
command's ``main`` in-process elsewhere); services in their own process on 127.0.0.1 only
(tests/test_serve_process.py).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def sgt(*args: str, cwd: Path, timeout: float = 120, stdin=None) -> subprocess.CompletedProcess:
    """``sgt ARGS`` in a process of its own (a crash or a hang ends only it)."""
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, stdin=stdin if stdin is not None else subprocess.DEVNULL,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "SGT_CACHE_DIR": str(cwd / ".cache")})


# -- 1 and 2: a voice variant killed the process and read any file ---------------------------


@pytest.mark.parametrize("variant", ["a" * 40, "../../../../../../etc/passwd"])
@pytest.mark.parametrize("command", ["check", "compile", "generate"])
def test_a_hostile_voice_variant_is_a_diagnostic(tmp_path, variant, command):
    """`@voice en-us+aaaa...` (40 characters) aborted `sgt check` (exit 134, a buffer overflow
    inside espeak-ng); `@voice en-us+../../../../etc/passwd` passed and `sgt compile` printed
    the file line by line. Both are SGT211 now, before espeak-ng sees them."""
    (tmp_path / "s.sgt").write_text(f"@voice en-us+{variant}\nguide: hi there.\n")
    args = {"check": ["check", "s.sgt"], "compile": ["compile", "s.sgt", "-o", "plan.json"],
            "generate": ["generate", "s.sgt", "-o", "take.json"]}[command]
    r = sgt(*args, cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    out = r.stdout + r.stderr  # check prints its report on stdout, the others on stderr
    assert "SGT211" in out and "unknown voice variant" in out
    assert "root:" not in out and "Bad voice attribute" not in out
    assert "Traceback" not in r.stderr


def test_sgt_voices_lists_the_variants(tmp_path):
    r = sgt("voices", "--variants", cwd=tmp_path)
    assert r.returncode == 0
    names = [line.split()[0] for line in r.stdout.splitlines()[:-1]]
    assert "m3" in names and "f2" in names and "variants" in r.stdout.splitlines()[-1]
    (tmp_path / "ok.sgt").write_text(f"@voice en-gb+{names[0]}\nguide: hi there.\n")
    assert sgt("check", "ok.sgt", cwd=tmp_path).returncode == 0


# -- 3: outputs that are inputs were destroyed ------------------------------------------------

SCRIPT = "guide: Hello [pose:wave] there.\nvisitor: And hello to you.\n"


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> Path:
    """The script and its take, generated once for the module."""
    where = tmp_path_factory.mktemp("made")
    (where / "s.sgt").write_text(SCRIPT)
    r = sgt("generate", "s.sgt", "-o", "take.json", "--engine", "keyframe", cwd=where)
    assert r.returncode == 0, r.stderr
    return where


@pytest.fixture()
def folder(tmp_path, made):
    """A folder of the test's own holding a copy of the script and its take."""
    for name in ("s.sgt", "take.json"):
        shutil.copyfile(made / name, tmp_path / name)
    return tmp_path


@pytest.mark.parametrize("args", [
    ["compile", "s.sgt", "-o", "s.sgt"],
    ["compile", "s.sgt", "--npz", "s.sgt", "-o", "plan.json"],
    ["generate", "s.sgt", "--format", "json", "-o", "s.sgt"],
    ["export", "s.sgt", "--format", "json", "-o", "s.sgt"],
    ["export", "take.json", "-o", "take.json", "--rig", "nao"],
    ["export", "take.json", "-o", "hard.json", "--rig", "nao"],
    ["export", "take.json", "-o", "soft.json", "--rig", "nao"],
    ["say", "rec.sgt", "--mix", "rec.wav"],  # the recording the script names
    ["say", "rec.sgt", "--mix", "rec-link.wav"],
    ["compile", "rec.sgt", "-o", "rec.json"],  # its timings file
])
def test_an_output_that_is_an_input_is_refused_before_any_work(folder, args):
    """Each of these exited 0 and replaced its input (the README's NAO line among them); hard
    and symbolic links to the input too. Now: exit 2, one line, every file as it was."""
    os.link(folder / "take.json", folder / "hard.json")
    (folder / "soft.json").symlink_to("take.json")
    (folder / "rec.wav").write_bytes(b"RIFF....WAVE")
    (folder / "rec-link.wav").symlink_to("rec.wav")
    (folder / "rec.json").write_text('[{"word": "hello", "start": 0.1, "end": 0.4}]')
    (folder / "rec.sgt").write_text("@audio rec.wav timings=rec.json\nguide: hello.\n")
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    r = sgt(*args, cwd=folder)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "the output is an input of this command" in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before


def test_read_only_outputs_are_refused_even_as_root(folder):
    (folder / "ro.json").write_text("mine")
    (folder / "ro.json").chmod(0o444)
    r = sgt("generate", "s.sgt", "-o", "ro.json", "--engine", "keyframe", cwd=folder)
    assert r.returncode == 1 and "read-only" in r.stderr
    assert (folder / "ro.json").read_text() == "mine"


def test_every_output_is_checked_before_the_first_is_written(folder):
    """With the sidecar's name taken by a folder, export wrote the BVH, then failed."""
    (folder / "e.bvh.timeline.json").mkdir()
    r = sgt("export", "take.json", "-o", "e.bvh", cwd=folder)
    assert r.returncode == 2 and "is a folder" in r.stderr
    assert not list(folder.glob("e.*.bvh")) and not (folder / "e.bvh").exists()


def test_several_exports_of_one_take_keep_their_sidecars(folder):
    for out in ("t.bvh", "t.csv"):
        assert sgt("export", "take.json", "-o", out, cwd=folder).returncode == 0
    import json

    for out, suffix in (("t.bvh", ".bvh"), ("t.csv", ".csv")):
        timeline = json.loads((folder / f"{out}.timeline.json").read_text())
        assert all(name.endswith(suffix) for name in timeline["files"].values())


# -- 4: special and huge inputs -----------------------------------------------------------------


@pytest.mark.parametrize("command", ["check", "compile", "generate"])
def test_a_fifo_or_a_device_as_a_script_is_refused_not_read(tmp_path, command):
    os.mkfifo(tmp_path / "fifo.sgt")  # blocked check/compile/generate forever
    (tmp_path / "zero.sgt").symlink_to("/dev/zero")  # was read until a MemoryError traceback
    for name, kind in (("fifo.sgt", "FIFO"), ("zero.sgt", "character device")):
        args = [command, name] + (["-o", "out.json"] if command != "check" else [])
        r = sgt(*args, cwd=tmp_path, timeout=60)
        out = r.stdout + r.stderr
        assert r.returncode == 1 and "SGT601" in out and kind in out and "Traceback" not in out, out


def test_deeply_nested_timings_are_a_diagnostic(tmp_path):
    import numpy as np

    from dsl.speech.audio import wav_bytes

    (tmp_path / "rec.wav").write_bytes(wav_bytes(np.sin(np.arange(20000) / 7.0) * 0.3, 16000))
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)  # a RecursionError traceback
    (tmp_path / "s.sgt").write_text("@audio rec.wav timings=deep.json\nguide: hello there.\n")
    r = sgt("check", "s.sgt", cwd=tmp_path)
    out = r.stdout + r.stderr
    assert r.returncode == 1 and "SGT608" in out and "nested" in out and "Traceback" not in out, out


@pytest.mark.parametrize("what", ["folder", "fifo"])
def test_a_folder_or_fifo_as_a_recording_says_what_it_is(tmp_path, what):
    """Reported as 'not found' before; a FIFO would block the reader."""
    target = tmp_path / "rec.wav"
    target.mkdir() if what == "folder" else os.mkfifo(target)
    (tmp_path / "s.sgt").write_text("@library lib.toml\n@audio rec.wav\nguide: hello there.\n")
    (tmp_path / "lib.toml").write_text("not a folder")
    r = sgt("check", "s.sgt", cwd=tmp_path, timeout=60)
    out = r.stdout + r.stderr
    assert r.returncode == 1 and out.count("SGT612") == 2, out
    assert ("is a folder" if what == "folder" else "is a FIFO") in out and "gesture folder 'lib.toml' is a file" in out


@pytest.mark.parametrize("what", ["duration", "keyframes", "huge"])
def test_gesture_specs_beyond_the_bounds_are_refused_by_the_checker(tmp_path, what):
    """200,000 keyframes passed check and compile, then generate asked for 3.18 GiB; duration =
    1e300 overflowed into 13 frames, with a numpy warning."""
    (tmp_path / "lib").mkdir()
    if what == "duration":
        body, message = "duration = 1e300\n[[keyframes]]\ntime = 0.0\nright_elbow = [0, -1, 0]\n", "longer than a gesture may be"
    else:
        n = 1000 if what == "keyframes" else 200_000
        body = "duration = 1.0\n" + "".join(f"[[keyframes]]\ntime = {i / 300000:.8f}\n" for i in range(n))
        message = "at most 150" if what == "keyframes" else "a gesture spec may be at most 1.0 MiB"
    (tmp_path / "lib" / "huge.toml").write_text(f'name = "huge"\ndescription = "x"\n{body}\n')
    (tmp_path / "s.sgt").write_text("@library lib\nguide: hello [pose:huge] there.\n")
    check = sgt("check", "s.sgt", cwd=tmp_path)
    generate = sgt("generate", "s.sgt", "-o", "t.json", "--engine", "keyframe", cwd=tmp_path)
    assert check.returncode == generate.returncode == 1
    assert message in check.stdout + check.stderr and "Traceback" not in generate.stderr


def test_motion_files_with_nan_are_refused_at_load_with_frame_and_bone(folder):
    import json

    doc = json.loads((folder / "take.json").read_text())
    doc["tracks"][0]["poses"][3][4] = float("nan")
    (folder / "nan.json").write_text(json.dumps(doc))
    for out in ("n.bvh", "n.glb"):  # a LinAlgError traceback; a glTF with NaN in it
        r = sgt("export", "nan.json", "-o", out, cwd=folder)
        assert r.returncode == 1 and "frame 3" in r.stderr and "not a finite number" in r.stderr, r.stderr
        assert not (folder / out).exists()


def test_broken_and_empty_inputs_are_one_line_each(folder):
    (folder / "empty.npz").write_bytes(b"")
    (folder / "header.sgt").write_text("@seed 3\n")
    for args in (["render", "empty.npz", "-o", "x.gif"], ["export", "header.sgt", "-o", "x.bvh"]):
        r = sgt(*args, cwd=folder)
        assert r.returncode == 1 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


# -- 7: smaller ------------------------------------------------------------------------------


def test_library_dir_that_does_not_exist_is_an_error(tmp_path):
    r = sgt("library", "show", "wave", "--dir", "/nonexistent", cwd=tmp_path)
    assert r.returncode == 1 and "no such folder" in r.stderr


@pytest.mark.parametrize("args", [["compile", "s.sgt", "-o", ""], ["compile", "s.sgt", "--npz", ""],
                                  ["render", "take.json", "-o", "x.gif", "--sheet", ""]])
def test_an_empty_output_name_is_refused_not_standard_output(folder, args):
    r = sgt(*args, cwd=folder)
    assert r.returncode == 2 and r.stdout == "" and "Traceback" not in r.stderr, (r.stdout[:200], r.stderr)
    assert not (folder / "x.gif").exists()


def test_the_service_exits_1_when_it_cannot_listen(tmp_path):
    import socket

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        r = sgt("serve", "--port", str(port), cwd=tmp_path)  # uvicorn exited 3
    assert r.returncode == 1 and "in use" in r.stderr and "--port 0" in r.stderr
    r = sgt("serve", "--host", "no-such-host.invalid", "--token", "t" * 20, cwd=tmp_path)
    assert r.returncode == 1 and "no such address" in r.stderr


def test_an_output_named_with_control_characters_is_printed_escaped(folder):
    """A name that a terminal would obey (ESC [2J clears the screen) or that is not UTF-8 is
    printed with those characters escaped, in the message that names it."""
    name = "o\x1b[2J\u202e.json"
    r = sgt("compile", "s.sgt", "-o", name, cwd=folder)
    assert r.returncode == 0, r.stderr
    assert (folder / name).exists()
    assert "\x1b" not in r.stderr and "\u202e" not in r.stderr
    assert "o\\x1b[2J\\u202e.json" in r.stderr, r.stderr


def test_a_script_named_with_control_characters_is_named_escaped_in_its_diagnostics(tmp_path):
    name = "e\x1b[31m.sgt"
    (tmp_path / name).write_text("guide: Hello [pose:nope] there.\n")
    r = sgt("check", name, cwd=tmp_path)
    assert r.returncode == 1 and "\x1b" not in r.stdout + r.stderr
    assert "e\\x1b[31m.sgt:1:20: error: [SGT201]" in r.stdout + r.stderr, r.stdout + r.stderr
