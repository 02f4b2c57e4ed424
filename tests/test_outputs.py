"""No command destroys what its output points at; `-o -` is standard output; one exit-status rule.

Every writing command is run with its output path made a character device (made here with
os.mknod, as root), a FIFO and a symbolic link: afterwards the device is still a device, the
FIFO's reader got a whole file, and the link is still a link whose target holds the output.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from special_files import IS_ROOT, FifoReader, as_unprivileged, char_device, is_char_device, needs_root

from sgt_tui.cli import main

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = "guide: Hello [pose:wave] there.\nguide: And once more.\n"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("inputs")
    script = d / "hello.sgt"
    script.write_text(SCRIPT)
    motion = d / "take.json"
    assert main(["generate", str(script), "-o", str(motion), "--engine", "keyframe"]) == 0
    return {"script": str(script), "motion": str(motion), "dir": d}


def _fake_eval(monkeypatch):
    import model.training.evaluate as evaluate

    rows = [{"name": "model", "fgd": 12.5, "pcs": float("nan")}]
    style = {"speed": {"requested": [-2.0, 2.0], "achieved": [-1.5, 1.5], "slope": 0.75}}
    monkeypatch.setattr(evaluate, "evaluate_corpus",
                        lambda *a, with_style=False, **k: (rows, style) if with_style else rows)


# name -> (suffix of the output, argv for an output path, what a whole file starts with)
WRITERS = {
    "compile -o": (".json", lambda i, out, t: ["compile", i["script"], "--estimate", "-o", out], b"{"),
    "compile --npz": (".npz", lambda i, out, t: ["compile", i["script"], "--estimate", "-o", str(t / "p.json"), "--npz", out], b"PK"),
    "generate json": (".json", lambda i, out, t: ["generate", i["script"], "--engine", "keyframe", "-o", out], b"{"),
    "generate npz": (".npz", lambda i, out, t: ["generate", i["script"], "--engine", "keyframe", "-o", out], b"PK"),
    "render -o": (".gif", lambda i, out, t: ["render", i["motion"], "-o", out, "--size", "32x32", "--utterance", "1"], b"GIF89a"),
    "render --sheet": (".png", lambda i, out, t: ["render", i["motion"], "-o", str(t / "x.gif"), "--sheet", out,
                                                  "--size", "32x32", "--utterance", "1"], b"\x89PNG"),
    "export bvh": (".bvh", lambda i, out, t: ["export", i["motion"], "-o", out], b"HIERARCHY"),
    "export csv": (".csv", lambda i, out, t: ["export", i["motion"], "-o", out], b"frame,time"),
    "export json": (".json", lambda i, out, t: ["export", i["motion"], "-o", out], b"{"),
    "export npz": (".npz", lambda i, out, t: ["export", i["motion"], "-o", out], b"PK"),
    "eval -o": (".json", lambda i, out, t: ["eval", "--corpus", str(i["dir"]), "-o", out], b"{"),
}
# Folder outputs: the file inside the folder that the command writes.
FOLDER_WRITERS = {
    "say": ("hello_001.wav", lambda i, d: ["say", i["script"], "-o", str(d)], b"RIFF"),
    "library add": ("mine.toml", lambda i, d: ["library", "add", "mine", "--from", i["motion"], "--frames", "0:8",
                                               "--to", str(d), "--force"], b"name"),
}


def _run_writer(name, inputs, out: Path, tmp_path, monkeypatch, capsys) -> int:
    if name == "eval -o":
        _fake_eval(monkeypatch)
    if name in WRITERS:
        argv = WRITERS[name][1](inputs, str(out), tmp_path)
    else:
        argv = FOLDER_WRITERS[name][1](inputs, out.parent)
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 0, err
    assert "Traceback" not in err
    return rc


def _target(name, tmp_path) -> tuple[Path, bytes]:
    if name in WRITERS:
        suffix, _, head = WRITERS[name]
        return tmp_path / f"out{suffix}", head
    inner, _, head = FOLDER_WRITERS[name]
    (tmp_path / "folder").mkdir()
    return tmp_path / "folder" / inner, head


ALL = [*WRITERS, *FOLDER_WRITERS]


@needs_root
@pytest.mark.parametrize("name", ALL)
def test_a_device_output_stays_a_device(name, inputs, tmp_path, monkeypatch, capsys):
    out, _ = _target(name, tmp_path)
    char_device(out)
    _run_writer(name, inputs, out, tmp_path, monkeypatch, capsys)
    assert is_char_device(out)


@pytest.mark.parametrize("name", ALL)
def test_a_fifo_output_stays_a_fifo_and_its_reader_gets_the_file(name, inputs, tmp_path, monkeypatch, capsys):
    import stat

    out, head = _target(name, tmp_path)
    reader = FifoReader(out)
    try:
        _run_writer(name, inputs, out, tmp_path, monkeypatch, capsys)
    finally:
        data = reader.close()
    assert stat.S_ISFIFO(os.lstat(out).st_mode)
    assert data.startswith(head)


@pytest.mark.parametrize("name", ALL)
def test_a_symlink_output_stays_a_link_and_its_target_gets_the_file(name, inputs, tmp_path, monkeypatch, capsys):
    out, head = _target(name, tmp_path)
    real = tmp_path / "elsewhere" / ("real" + out.suffix)
    real.parent.mkdir()
    real.write_bytes(b"old")
    out.symlink_to(os.path.relpath(real, out.parent))
    _run_writer(name, inputs, out, tmp_path, monkeypatch, capsys)
    assert out.is_symlink() and real.read_bytes().startswith(head)
    assert sorted(p.name for p in real.parent.iterdir()) == [real.name]


# -- `-o -` -----------------------------------------------------------------------------------


@pytest.mark.parametrize("argv, check", [
    (["compile", "{script}", "--estimate"], lambda out: json.loads(out)["format"] == "sgt-plan"),
    (["compile", "{script}", "--estimate", "-o", "-"], lambda out: json.loads(out)["format"] == "sgt-plan"),
    (["generate", "{script}", "--engine", "keyframe", "-o", "-"], lambda out: json.loads(out)["format"] == "sgt-motion"),
    (["export", "{motion}", "-o", "-"], lambda out: len(json.loads(out)["utterances"]) == 2),
    (["export", "{motion}", "-o", "-", "--format", "csv"], lambda out: out.startswith("frame,time,")),
    (["export", "{script}", "-o", "-", "--format", "bvh", "--engine", "keyframe"], lambda out: out.startswith("HIERARCHY")),
    (["eval", "--corpus", "{dir}", "-o", "-"], lambda out: json.loads(out)["conditions"][0]["fgd"] == 12.5),
])
def test_dash_writes_text_outputs_to_stdout(argv, check, inputs, monkeypatch, capsys):
    _fake_eval(monkeypatch)
    rc = main([a.format(**inputs) for a in argv])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert check(out), out[:300]  # stdout holds the output alone: messages and tables go to stderr


def _run_cli(argv, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *argv], cwd=kw.pop("cwd", ROOT),
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, **kw)


def test_dash_writes_binary_to_a_pipe_and_refuses_a_terminal(inputs, tmp_path):
    import pty

    argv = ["export", inputs["motion"], "-o", "-", "--format", "npz"]
    r = _run_cli(argv, capture_output=True, timeout=120)
    assert r.returncode == 0, r.stderr
    with np.load(io.BytesIO(r.stdout)) as z:
        assert "poses_0" in z.files
    leader, follower = pty.openpty()
    try:
        r = _run_cli(argv + ["--utterance", "1"], stdout=follower, stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(follower)
        os.close(leader)
    assert r.returncode == 2 and "terminal" in r.stderr and "Traceback" not in r.stderr


def test_only_one_output_goes_to_stdout(inputs, capsys):
    assert main(["compile", inputs["script"], "--estimate", "--npz", "-"]) == 2
    assert "standard output" in capsys.readouterr().err
    assert main(["render", inputs["motion"], "-o", "-", "--sheet", "-"]) == 2
    assert main(["say", inputs["script"], "-o", "-"]) == 2


# -- bad outputs: refused before any work, one line, 2 for the wrong kind of path ------------


@pytest.mark.parametrize("argv", [
    ["compile", "{script}", "--estimate", "-o", "."],
    ["compile", "{script}", "--estimate", "-o", "{tmp}"],
    ["compile", "{script}", "--estimate", "-o", "{tmp}/plan.json", "--npz", "{tmp}"],
    ["compile", "{script}", "--estimate", "-o", "{script}/plan.json"],
    ["generate", "{script}", "--engine", "keyframe", "-o", "{tmp}/plan.json/"],
    ["generate", "{script}", "--engine", "keyframe", "-o", "{script}/x/m.json"],
    ["render", "{motion}", "-o", "{tmp}/x.gif", "--sheet", "{tmp}/folder.png"],
    ["export", "{motion}", "-o", "{motion}/x.bvh"],
    ["say", "{script}", "-o", "{script}"],
    ["say", "{script}", "-o", "{script}/sub"],
    ["library", "add", "mine", "--from", "{motion}", "--frames", "0:8", "--to", "{script}"],
    ["corpus", "-o", "{script}", "--hours", "0.001"],
    ["train", "--corpus", "{dir}", "-o", "{script}"],
    ["eval", "--corpus", "{dir}", "-o", "{tmp}"],
])
def test_an_output_of_the_wrong_kind_is_a_usage_error_before_any_work(argv, inputs, tmp_path, capsys):
    (tmp_path / "folder.png").mkdir()
    before = sorted(p.name for p in tmp_path.iterdir())
    rc = main([a.format(tmp=tmp_path, **inputs) for a in argv])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and "error:" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written, no folder made
    assert Path(inputs["script"]).read_text() == SCRIPT


def test_an_unwritable_output_is_an_input_problem_in_one_line(inputs, shared_dir):
    """Permission denied (checked before any work) and a write that fails: exit 1."""
    import shutil

    import sgt_tui.commands.compile  # noqa: F401  (the child cannot import as nobody)
    import sgt_tui.commands.export  # noqa: F401
    import sgt_tui.commands.say  # noqa: F401
    from sgt_tui.commands.common import output_file  # noqa: F401

    shared = shared_dir
    script, motion = shared / "hello.sgt", shared / "take.json"
    shutil.copy(inputs["script"], script)
    shutil.copy(inputs["motion"], motion)
    locked = shared / "locked"
    locked.mkdir()
    locked.chmod(0o555)

    def attempts():
        import contextlib

        lines = []
        for argv in (["compile", str(script), "--estimate", "-o", str(locked / "plan.json")],
                     ["export", str(motion), "-o", str(locked / "sub" / "x.bvh")],
                     ["say", str(script), "-o", str(locked / "speech")],
                     ["generate", str(locked / "hidden" / "x.sgt"), "-o", str(shared / "m.json")]):
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                rc = main(argv)
            lines.append(f"{rc} {err.getvalue().strip()}")
        return lines

    lines = as_unprivileged(attempts)
    assert all(line.startswith("1 ") and "ermission denied" in line for line in lines[:3]), lines
    assert lines[3].startswith("1 ") and "no such file" in lines[3], lines  # reachable, and not there
    assert list(locked.iterdir()) == []


@needs_root
def test_a_full_disk_is_one_line_and_status_1(inputs, tmp_path, capsys):
    out = char_device(tmp_path / "full.json", like="/dev/full")
    rc = main(["generate", inputs["script"], "--engine", "keyframe", "-o", str(out)])
    err = capsys.readouterr().err
    assert rc == 1 and "No space left" in err and err.count("\n") == 1
    assert is_char_device(out, like="/dev/full")


def test_missing_parent_folders_are_created(inputs, tmp_path, capsys):
    out = tmp_path / "a" / "b" / "take.bvh"
    assert main(["export", inputs["motion"], "-o", str(out)]) == 0
    assert out.read_text().startswith("HIERARCHY")


# -- the exit-status rule, the same for every command -----------------------------------------


@pytest.mark.parametrize("argv, code, message", [
    (["generate", "{script}", "-o", "{tmp}/m.json", "--seed", "-5"], 2, "--seed"),
    (["export", "{script}", "-o", "{tmp}/m.bvh", "--seed", "-1"], 2, "--seed"),
    (["render", "{script}", "-o", "{tmp}/m.gif", "--seed", "-3"], 2, "--seed"),
    (["generate", "{script}", "-o", "{tmp}/m.json", "--seed", "2147483648"], 2, "out of range"),
    (["generate", "{script}", "-o", "{tmp}/m.json", "--engine", "keyframe", "--utterance", "50"], 2, "no utterance 50"),
    (["compile", "{script}", "--estimate", "--utterance", "50"], 2, "no utterance 50"),
    (["say", "{script}", "--utterance", "50", "-o", "{tmp}/speech"], 2, "no utterance 50"),
    (["export", "{script}", "-o", "{tmp}/m.bvh", "--engine", "keyframe", "--utterance", "7"], 2, "no utterance 7"),
    (["render", "{motion}", "-o", "{tmp}/m.gif", "--utterance", "7"], 2, "no utterance 7"),
    (["library", "show", "nope"], 2, "no gesture named 'nope'"),
    (["compile", "{tmp}/missing.sgt"], 1, "no such file"),
    (["say", "{tmp}/missing.sgt"], 1, "no such file"),
    (["generate", "{tmp}/missing.sgt", "-o", "{tmp}/m.json"], 1, "no such file"),
    (["render", "{tmp}/missing.sgt", "-o", "{tmp}/m.gif"], 1, "no such file"),
    (["export", "{tmp}/missing.json", "-o", "{tmp}/m.bvh"], 1, "no such file"),
    (["check", "{tmp}/missing.sgt"], 1, "no such file"),
    (["library", "add", "x", "--from", "{tmp}/missing.json", "--frames", "0:5"], 1, "no such file"),
    (["generate", "{script}", "-o", "{tmp}/m.json", "--weights", "{tmp}/missing.pt"], 1, "no such file"),
    (["eval", "--corpus", "{tmp}/missing"], 1, "no such corpus"),
    (["train", "--corpus", "{tmp}/missing"], 1, "no such corpus"),
    (["corpus", "-o", "{tmp}/c", "--hours", "nan"], 2, "--hours"),
    (["generate", "{bad}", "-o", "{tmp}/m.json", "--engine", "keyframe"], 1, "unknown gesture"),
    (["render", "{tmp}/junk.json", "-o", "{tmp}/m.gif"], 1, "JSON"),
])
def test_exit_status_rule(argv, code, message, inputs, tmp_path, capsys):
    bad = tmp_path / "bad.sgt"
    bad.write_text("guide: hi [pose:point_rigth] there\n")
    (tmp_path / "junk.json").write_text("{not json")
    rc = main([a.format(tmp=tmp_path, bad=bad, **inputs) for a in argv])
    out, err = capsys.readouterr()
    assert rc == code, err
    assert message in err + out and "Traceback" not in err  # sgt check reports on stdout
    assert not any(p.name in ("m.json", "m.bvh", "m.gif", "speech", "c") for p in tmp_path.iterdir())


def test_an_unreadable_script_is_status_1(inputs, shared_dir):
    import dsl.compiler  # noqa: F401  (the child cannot import as nobody)
    import sgt_tui.commands.compile  # noqa: F401
    import sgt_tui.progress  # noqa: F401

    if not IS_ROOT and os.geteuid() == os.stat(inputs["script"]).st_uid and os.access("/", os.W_OK):
        pytest.skip("cannot make a file unreadable here")
    shared = shared_dir
    secret = shared / "secret.sgt"
    secret.write_text(SCRIPT)
    secret.chmod(0o000)

    private = shared / "private"
    private.mkdir(mode=0o700)
    (private / "script.sgt").write_text(SCRIPT)

    def attempts():
        import contextlib

        lines = []
        for script in (secret, private / "script.sgt"):
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                rc = main(["compile", str(script), "--estimate", "-o", str(shared / "p.json")])
            lines.append(f"{rc} " + err.getvalue().strip().replace("\n", " | "))
        return lines

    lines = as_unprivileged(attempts)
    assert all(line.startswith("1 ") and "cannot read" in line for line in lines), lines
    assert not (shared / "p.json").exists()


def test_file_names_that_are_not_utf8_are_written_into_json_and_load_back(tmp_path, capsys):
    """A script and an output named with bytes that are not UTF-8 (Python holds them as lone
    surrogates): every JSON that names a file stays valid UTF-8 and gives the name back."""
    odd = os.fsdecode(b"\x80x")  # "\udc80x"
    script = tmp_path / f"{odd}.sgt"
    script.write_text("guide: Hello [pose:wave] there.\nvisitor: Hi [pose:nope].\n")
    fixed = tmp_path / f"{odd}ok.sgt"
    fixed.write_text(SCRIPT)

    assert main(["check", "--format", "json", str(script)]) == 1
    report = json.loads(capsys.readouterr().out.encode("utf-8"))
    assert {d["file"] for d in report["diagnostics"]} == {str(script)}

    plan = tmp_path / "plan.json"
    assert main(["compile", str(fixed), "--estimate", "-o", str(plan)]) == 0
    assert json.loads(plan.read_bytes().decode("utf-8"))["source"] == str(fixed)

    bvh = tmp_path / f"{odd}.bvh"
    assert main(["export", str(fixed), "--engine", "keyframe", "-o", str(bvh)]) == 0
    sidecar = json.loads((tmp_path / f"{odd}.bvh.timeline.json").read_bytes().decode("utf-8"))
    assert [tmp_path / name for name in sidecar["files"].values()] == [bvh]
    assert bvh.read_bytes().startswith(b"HIERARCHY")
