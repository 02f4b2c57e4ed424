"""Nothing hostile gets in: files a command writes, removes or reads that the user did not name
stay inside their folder, whatever a repository plants there (core/fileio.py's ``Inside`` and
``resolved_inside``), and work is never lost in silence.

Every hostile input is made here: a symbolic link planted in a build's OUT with a manifest that
lists the victim's sha256 and size; a manifest listing ``../elsewhere/take.json``, an absolute
path and a link out; a motion file whose script is ``/etc/passwd`` or a script outside the
folder; a link where ``sgt align`` or the language server writes a timings file (with and
without --force, dangling); a script whose name is too long for a recovery file name; an
unwritable recovery folder; a script with an unknown escape (SGT106); a script with hard links.
The real commands run (``sgt build``, ``sgt view`` over HTTP, ``sgt render``, ``sgt align``,
``sgt lsp`` through pytest-lsp, ``sgt edit`` in tmux and through Textual's pilot, ``sgt fmt``),
and each test checks the victim's bytes and existence, the exit status, one line, no traceback.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = "guide: Hello there, [pose:wave] welcome.\n"
PRECIOUS = b"precious: nothing may touch this\n"


def sgt(*args: str, cwd: Path, timeout: float = 300, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, **(env or {})}, check=False)


def lines(text: str) -> list[str]:
    return [x for x in text.splitlines() if x.strip()]


def no_traceback(r: subprocess.CompletedProcess) -> None:
    assert "Traceback" not in r.stderr + r.stdout, r.stderr


@pytest.fixture
def victim(tmp_path) -> Path:
    folder = tmp_path / "victimdir"
    folder.mkdir()
    (folder / "victim.txt").write_bytes(PRECIOUS)
    return folder / "victim.txt"


def untouched(victim: Path) -> None:
    assert victim.is_file() and not victim.is_symlink() and victim.read_bytes() == PRECIOUS


# -- sgt build ------------------------------------------------------------------------------------

@pytest.fixture
def built(tmp_path) -> Path:
    """game/a.sgt built into out/ (the keyframe engine: fast, and the same rules for every engine)."""
    (tmp_path / "game").mkdir()
    (tmp_path / "game" / "a.sgt").write_text(SCRIPT)
    r = sgt("build", "game", "-o", "out", "-j", "1", "-q", "--engine", "keyframe", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    return tmp_path / "out"


def _list_in_manifest(out: Path, *records: dict) -> None:
    """Add ``records`` to the manifest as the outputs of a script that is gone (so they are stale)."""
    doc = json.loads((out / "manifest.json").read_text())
    doc["scripts"].append({"source": "gone.sgt", "status": "ok", "exports": [], "outputs": list(records),
                           "utterances": []})
    (out / "manifest.json").write_text(json.dumps(doc))


def _record(path: str, data: bytes) -> dict:
    return {"path": path, "sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}


def test_build_never_deletes_a_file_outside_out_through_a_planted_link(built, victim, tmp_path):
    """The audit's case: OUT/evil -> ../victimdir and the manifest lists evil/victim.txt with its
    sha256 and size; the build removed victimdir/victim.txt as a stale output, exit 0, silently."""
    (built / "evil").symlink_to("../victimdir")
    _list_in_manifest(built, _record("evil/victim.txt", PRECIOUS), _record("../victimdir/victim.txt", PRECIOUS),
                      _record(str(victim), PRECIOUS))
    r = sgt("build", "game", "-o", "out", "-j", "1", "-q", "--engine", "keyframe", cwd=tmp_path)
    no_traceback(r)
    assert r.returncode == 0, r.stderr
    untouched(victim)
    warned = lines(r.stderr)
    assert len(warned) == 3, r.stderr  # one line for each, naming the path
    assert warned[0].startswith("sgt build: warning: not removed out/evil/victim.txt: out/evil is a symbolic link")
    assert "../victimdir/victim.txt goes up a folder" in warned[1] and "is an absolute path" in warned[2]
    assert (built / "evil").is_symlink()  # the link itself is the user's to remove


@pytest.mark.parametrize("planted, status", [("a.json", 1), ("sub", 1), ("manifest.json", 2), (".sgt-build-state.json", 2),
                                             (".sgt-build.lock", 2)])
def test_build_never_writes_through_a_planted_link(tmp_path, victim, planted, status):
    """A link where an output, the manifest, the state or the lock goes (or a folder of outputs
    that is a link) is refused with one line naming it; nothing outside OUT is written,
    truncated or removed (temporaries a killed build leaves are removed only inside OUT)."""
    (tmp_path / "game" / "sub").mkdir(parents=True)
    (tmp_path / "game" / "a.sgt").write_text(SCRIPT)
    (tmp_path / "game" / "sub" / "b.sgt").write_text(SCRIPT)
    out = tmp_path / "out"
    out.mkdir()
    temporary = victim.parent / ".b.json.abcdefgh.tmp"  # what a killed build leaves beside an output
    temporary.write_bytes(PRECIOUS)
    (out / planted).symlink_to(os.path.relpath(victim.parent if planted == "sub" else victim, out))
    r = sgt("build", "game", "-o", "out", "-j", "1", "-q", "--engine", "keyframe", cwd=tmp_path)
    untouched(victim)
    assert temporary.read_bytes() == PRECIOUS
    no_traceback(r)
    assert r.returncode == status, r.stderr
    assert sorted(p.name for p in victim.parent.iterdir()) == [temporary.name, "victim.txt"]
    refused = [x for x in lines(r.stderr) if "symbolic link" in x]
    assert len(refused) == 1 and f"out/{planted}" in refused[0] and "remove the link" in refused[0], r.stderr
    assert (out / planted).is_symlink()


def test_build_reads_a_hostile_manifest_in_bounded_memory(built, tmp_path):
    """A manifest nested 1.5 million deep (3 MB) gave a RecursionError traceback; now it is no
    manifest (everything is checked again), exit 0, and the build's peak memory stays small
    (measured by a fresh parent process, over the build and its workers)."""
    (built / "manifest.json").write_text("[" * 1_500_000 + "]" * 1_500_000)
    measure = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:]); "
               "print('peak', resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(r.returncode)")
    r = subprocess.run([sys.executable, "-c", measure, sys.executable, "-m", "sgt_tui.cli", "build", "game", "-o", "out",
                        "-j", "1", "-q", "--engine", "keyframe"], cwd=tmp_path, capture_output=True, text=True,
                       timeout=300, check=False)
    no_traceback(r)
    *said, peak = lines(r.stderr)
    assert r.returncode == 0 and said == [], r.stderr
    assert json.loads((built / "manifest.json").read_text())["format"] == "sgt-build"
    assert int(peak.split()[1]) < 1024 * 1024, peak  # KiB: under 1 GiB


# -- sgt view of a build folder, sgt render of a motion file ---------------------------------------

class View:
    """``sgt view FOLDER`` running, asked over HTTP."""

    def __init__(self, folder: Path, cwd: Path) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "sgt_tui.cli", "view", str(folder), "--port", "0"], cwd=cwd,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        first = self.proc.stderr.readline()
        found = re.search(r"http://127\.0\.0\.1:\d+/", first)
        if not found:
            self.proc.kill()
            raise AssertionError(f"sgt view did not start: {first}{self.proc.stderr.read()}")
        self.address = found.group(0)

    def get(self, path: str) -> tuple[int, dict]:
        try:
            with urllib.request.urlopen(self.address + path, timeout=120) as answer:
                return answer.status, json.loads(answer.read())
        except urllib.error.HTTPError as exc:
            return exc.code, json.loads(exc.read())

    def close(self) -> str:
        self.proc.send_signal(signal.SIGINT)
        try:
            _, err = self.proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            _, err = self.proc.communicate()
        return err


def _motion_naming(out: Path, name: str, source: str) -> None:
    """OUT/name: a copy of a.json naming ``source`` as its script, listed in the manifest."""
    doc = json.loads((out / "a.json").read_text())
    doc["source"] = source
    (out / name).write_text(json.dumps(doc))


def test_view_of_a_build_folder_reads_nothing_outside_it(built, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    shutil.copy(built / "a.json", elsewhere / "take.json")
    (built / "link.json").symlink_to("../elsewhere/take.json")
    # a.sgt as it was built, outside the folder: compiling it would give the take its speech
    (tmp_path / "secret").mkdir()
    shutil.copy(tmp_path / "game" / "a.sgt", tmp_path / "secret" / "a.sgt")
    _motion_naming(built, "passwd.json", "/etc/passwd")
    _motion_naming(built, "outside.json", "../secret/a.sgt")
    _list_in_manifest(built, _record("../elsewhere/take.json", b""), _record(str(elsewhere / "take.json"), b""),
                      _record("link.json", b""), _record("passwd.json", b""), _record("outside.json", b""))
    view = View(built, tmp_path)
    try:
        _, status = view.get("api/status")
        takes = {t["name"]: i for i, t in enumerate(status["takes"])}
        assert set(takes) == {"a.json", "passwd.json", "outside.json", "../elsewhere/take.json",
                              str(elsewhere / "take.json"), "link.json"}
        answers = {name: view.get(f"api/take?take={i}") for name, i in takes.items()}
        _, status = view.get("api/status")
    finally:
        err = view.close()
    assert "Traceback" not in err and "internal error" not in err, err
    assert answers["a.json"][0] == 200
    for name, how in (("../elsewhere/take.json", "('..'"), (str(elsewhere / "take.json"), "(an absolute path"),
                      ("link.json", "(a link")):
        code, doc = answers[name]
        assert code == 422 and "leads outside" in doc["error"] and how in doc["error"], doc
        (shown,) = [t["error"] for t in status["takes"] if t["name"] == name]
        assert shown == doc["error"] and "\n" not in shown  # the page's take error: one line
    for name, why in (("passwd.json", "/etc/passwd as its script, outside"), ("outside.json", "secret/a.sgt as its script, outside")):
        code, doc = answers[name]
        assert code == 200 and doc["audio"] is None and why in doc["audio_note"], doc  # shown, without speech
    assert "root:" not in err


def test_render_of_a_motion_file_naming_etc_passwd_reads_no_such_file(built, tmp_path):
    _motion_naming(built, "passwd.json", "/etc/passwd")
    r = sgt("render", "out/passwd.json", "-o", "x.mp4", cwd=tmp_path)
    no_traceback(r)
    assert r.returncode == 1 and not (tmp_path / "x.mp4").exists()
    assert "root:" not in r.stderr and "SGT" not in r.stderr  # never compiled, so nothing of it is shown
    (line,) = lines(r.stderr)
    assert "names /etc/passwd as its script, which is not a .sgt script: not read" in line


# -- names sgt chooses beside a named output: export's sidecar, say's WAVs --------------------------

def test_export_never_writes_its_sidecar_through_a_planted_link(built, victim, tmp_path):
    """``-o take.bvh`` names the BVH; ``take.bvh.timeline.json`` is sgt's own name beside it: a link
    planted there is refused before any work, and nothing is written."""
    (tmp_path / "take.bvh.timeline.json").symlink_to(victim)
    r = sgt("export", "out/a.json", "-o", "take.bvh", cwd=tmp_path)
    no_traceback(r)
    untouched(victim)
    assert r.returncode != 0 and not (tmp_path / "take.bvh").exists()
    (line,) = lines(r.stderr)
    assert "take.bvh.timeline.json" in line and "link" in line


def test_say_never_writes_its_wavs_through_a_planted_link(tmp_path, victim):
    """``sgt say`` names its WAVs itself (STEM_000.wav in STEM_speech/): a link planted at one is
    refused, and the file it points to keeps its bytes."""
    (tmp_path / "a.sgt").write_text(SCRIPT)
    (tmp_path / "a_speech").mkdir()
    (tmp_path / "a_speech" / "a_000.wav").symlink_to(victim)
    r = sgt("say", "a.sgt", cwd=tmp_path)
    no_traceback(r)
    untouched(victim)
    assert r.returncode != 0
    assert "a_000.wav" in r.stderr and "link" in r.stderr


# -- sgt align and the language server's sgt.writeTimings -----------------------------------------

SAID = "Well, hello there my friend. How are you today?"


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    """SAID spoken by espeak-ng, as a recording."""
    import numpy as np  # lazy: only these tests make a recording
    import soundfile as sf  # lazy: only these tests make a recording

    from dsl.speech import _espeak, synthesize  # lazy: espeak-ng

    if _espeak.find_library() is None:
        pytest.skip("libespeak-ng not installed")
    folder = tmp_path_factory.mktemp("rec")
    spans = [m.span() for m in re.finditer(r"[\w']+", SAID)]
    speech = synthesize(SAID, spans, cache_dir=folder / "syn")
    x, sr = sf.read(str(speech.audio_path))
    sf.write(str(folder / "rec.wav"), np.concatenate([np.zeros(sr // 4), x, np.zeros(sr // 4)]), sr)
    return folder / "rec.wav"


@pytest.fixture
def talk(tmp_path, recording) -> Path:
    shutil.copy(recording, tmp_path / "rec.wav")
    (tmp_path / "talk.sgt").write_text(f"@audio rec.wav\nbot: {SAID}\n")
    return tmp_path / "talk.sgt"


@pytest.mark.parametrize("force", [False, True])
def test_align_never_writes_through_a_planted_timings_link(talk, victim, tmp_path, force):
    """REC.timings.json -> precious.txt: --force overwrote it; now refused, with or without
    --force, one line, and the link stays."""
    link = tmp_path / "rec.timings.json"
    link.symlink_to(os.path.relpath(victim, tmp_path))
    r = sgt("align", "talk.sgt", *(["--force"] if force else []), cwd=tmp_path)
    untouched(victim)
    no_traceback(r)
    assert r.returncode == 2, r.stderr
    assert link.is_symlink() and os.readlink(link) == os.path.relpath(victim, tmp_path)
    (line,) = lines(r.stderr)
    assert f"cannot write rec.timings.json: it is a symbolic link (to {os.readlink(link)})" in line


def test_align_does_not_follow_a_dangling_timings_link(talk, tmp_path):
    """Without --force a dangling link was followed and its target created."""
    link = tmp_path / "rec.timings.json"
    made = tmp_path / "elsewhere" / "made.json"
    (tmp_path / "elsewhere").mkdir()
    link.symlink_to(made)
    r = sgt("align", "talk.sgt", cwd=tmp_path)
    assert not os.path.lexists(made)
    no_traceback(r)
    assert r.returncode == 2
    assert link.is_symlink()
    (line,) = lines(r.stderr)
    assert "is a symbolic link" in line


def test_align_never_replaces_a_timings_file_that_appears_while_it_aligns(talk, tmp_path, monkeypatch, capsys):
    """The "exists" check was long before the write: a file made meanwhile (by an editor, by the
    language server) was replaced. Now the file is created exclusively."""
    import dsl.speech.recording as recording_module  # lazy: the command's own module, patched for the race
    from sgt_tui.cli import main  # lazy: in this process, to make the race happen

    real = recording_module.aligner_timings
    target = tmp_path / "rec.timings.json"

    def slow(*args, **kwargs):
        target.write_bytes(PRECIOUS)  # the user's own file, written while the aligner works
        return real(*args, **kwargs)

    monkeypatch.setattr(recording_module, "aligner_timings", slow)
    assert main(["align", str(talk)]) == 1
    assert target.read_bytes() == PRECIOUS
    err = capsys.readouterr().err
    assert "appeared while the recording was aligned: not replaced" in err and "Traceback" not in err


@pytest.fixture
def lsp_workspace(tmp_path, recording) -> tuple[Path, Path]:
    """A workspace folder ws/ and a folder beside it (outside the workspace) with a recording."""
    ws, outside = tmp_path / "ws", tmp_path / "outside"
    ws.mkdir()
    outside.mkdir()
    shutil.copy(recording, ws / "said.wav")
    shutil.copy(recording, outside / "said.wav")
    return ws, outside


async def _write_timings(ws: Path, text: str) -> str:
    """Open ws/t.sgt with ``text`` in ``sgt lsp`` (workspace ws) and run sgt.writeTimings on line 2:
    the error's message, or "" when it was written."""
    from lsprotocol import types as lsp  # lazy: only these tests speak LSP
    from pygls.exceptions import JsonRpcException  # lazy: as above
    from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities  # lazy: as above

    config = ClientServerConfig(server_command=[sys.executable, "-m", "sgt_tui.cli", "lsp"])
    client: LanguageClient = await config.start(None)
    try:
        await client.initialize_session(lsp.InitializeParams(
            capabilities=client_capabilities("visual-studio-code"), root_uri=ws.as_uri(),
            workspace_folders=[lsp.WorkspaceFolder(ws.as_uri(), "ws")]))

        @client.feature(lsp.WORKSPACE_APPLY_EDIT)
        def apply_edit(params: lsp.ApplyWorkspaceEditParams):
            return lsp.ApplyWorkspaceEditResult(applied=True)

        path = ws / "t.sgt"
        path.write_text(text)
        client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(path.as_uri(), "sgt", 1, text)))
        try:
            await client.workspace_execute_command_async(lsp.ExecuteCommandParams("sgt.writeTimings", [path.as_uri(), 2]))
        except JsonRpcException as exc:  # the server's error answer
            return str(exc)
        return ""
    finally:
        await client.shutdown_session()


def _lsp(coro):
    pytest.importorskip("pytest_lsp")
    return asyncio.run(asyncio.wait_for(coro, 180))


def test_write_timings_writes_nothing_outside_the_workspace(lsp_workspace):
    ws, outside = lsp_workspace
    error = _lsp(_write_timings(ws, f"@audio ../outside/said.wav\nbot: {SAID}\n"))
    assert "outside the workspace and the script's folder: not written" in error, error
    assert sorted(p.name for p in outside.iterdir()) == ["said.wav"]


def test_write_timings_does_not_follow_a_dangling_link(lsp_workspace, tmp_path):
    ws, outside = lsp_workspace
    made = outside / "made.json"
    (ws / "said.timings.json").symlink_to(made)
    error = _lsp(_write_timings(ws, f"@audio said.wav\nbot: {SAID}\n"))
    assert "is a symbolic link" in error and "remove the link" in error, error
    assert not os.path.lexists(made) and (ws / "said.timings.json").is_symlink()


def test_write_timings_still_writes_in_the_workspace(lsp_workspace):
    ws, _ = lsp_workspace
    assert _lsp(_write_timings(ws, f"@audio said.wav\nbot: {SAID}\n")) == ""
    assert json.loads((ws / "said.timings.json").read_text())[0]["word"] == "Well"


# -- sgt edit: crash recovery ----------------------------------------------------------------------

def _children(pid: int) -> list[int]:
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append(int(entry))
    return found


@pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")
def test_a_script_with_a_long_name_recovers_after_kill_9(tmp_path):
    """A name of 236+ characters made the recovery file's name too long: nothing was written,
    nothing said, and kill -9 lost the work. The real editor in tmux, killed with SIGKILL."""
    name = "n" * 240 + ".sgt"
    script = tmp_path / name
    script.write_text("guide: saved\n")
    socket = f"sgt-hostile-{os.getpid()}"
    launch = "import sys; from sgt_tui.cli import main; sys.exit(main())"

    def tmux(*args: str) -> str:
        return subprocess.run(["tmux", "-L", socket, *args], capture_output=True, text=True, timeout=30, check=False).stdout

    def wait_for(session: str, text: str, timeout: float = 60) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            screen = tmux("capture-pane", "-p", "-t", session)
            if text in screen:
                return screen
            time.sleep(0.1)
        raise AssertionError(f"{text!r} never appeared:\n{tmux('capture-pane', '-p', '-t', session)}")

    def start(session: str) -> None:
        env = f"SGT_EDITOR_CACHE={shlex.quote(str(tmp_path / 'cache'))} TERM=xterm-256color"
        tmux("new-session", "-d", "-s", session, "-x", "120", "-y", "30",
             f"cd {shlex.quote(str(ROOT))} && {env} {shlex.quote(sys.executable)} -c {shlex.quote(launch)} "
             f"edit {shlex.quote(str(script))} --engine rules; sleep 60")

    try:
        start("first")
        wait_for("first", "engine rules")  # the status line has room for it: the long name is cut in its middle
        tmux("send-keys", "-t", "first", "-l", "guide: not saved yet")
        tmux("send-keys", "-t", "first", "Enter")
        wait_for("first", "[+]")
        recovery = tmp_path / "cache" / "recovery"
        deadline = time.monotonic() + 20
        while not list(recovery.glob("*.json")) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert list(recovery.glob("*.json")), "no recovery file"
        assert "NO CRASH RECOVERY" not in tmux("capture-pane", "-p", "-t", "first")
        (editor,) = _children(int(tmux("display", "-p", "-t", "first", "#{pane_pid}").strip()))
        os.kill(editor, signal.SIGKILL)  # no save, no clean exit, no recovery file removed
        assert script.read_text() == "guide: saved\n"
        start("second")
        wait_for("second", "Recover unsaved work?")
        tmux("send-keys", "-t", "second", "r")
        wait_for("second", "recovered unsaved work")
        tmux("send-keys", "-t", "second", "C-s")
        deadline = time.monotonic() + 20
        while script.read_text() == "guide: saved\n" and time.monotonic() < deadline:
            time.sleep(0.1)
        assert script.read_text() == "guide: not saved yet\nguide: saved\n"
    finally:
        tmux("kill-server")


def test_an_unwritable_recovery_folder_is_said_once_and_retried(tmp_path, monkeypatch):
    """SGT_RECOVERY_DIR that cannot be written (here: under a file, which stops root too) turned
    recovery off in silence. Now: one notification, the status line says so while it lasts, and
    each write is tried again: once the folder can be written, recovery works (and says so)."""
    pytest.importorskip("textual")
    from sgt_tui.app.main import EditorApp  # lazy: Textual
    from sgt_tui.editor.files import ScriptFile  # lazy: Textual's side of the editor

    blocker = tmp_path / "blocker"
    blocker.write_text("a file, not a folder")
    monkeypatch.setenv("SGT_EDITOR_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("SGT_RECOVERY_DIR", str(blocker / "recovery"))
    path = tmp_path / "s.sgt"
    path.write_text("guide: saved\n")
    app = EditorApp(ScriptFile.open(path), engine="rules", cursor_blink=False, gif_size=(48, 48))
    seen: list[str] = []

    async def main():
        async with app.run_test(size=(120, 24), notifications=True) as pilot:
            app.notify = lambda message, **kw: seen.append(message)  # every notification, counted
            await pilot.pause()
            await pilot.press(*"guide: x")
            app.recovery.write()
            await pilot.press("y")
            app.recovery.write()
            await pilot.pause()
            status = str(app.query_one("#status").render())
            assert "NO CRASH RECOVERY" in status, status
            blocker.unlink()  # the folder can be made now: the next write works
            await pilot.press("z")
            app.recovery.write()
            await pilot.pause()
            assert "NO CRASH RECOVERY" not in str(app.query_one("#status").render())
            assert "crash recovery works again" in app.last_message

    asyncio.run(main())
    warned = [m for m in seen if "crash recovery is off" in m]
    assert len(warned) == 1 and str(blocker) in warned[0] and "\n" not in warned[0], seen
    assert app.recovery.file.load().text.startswith("guide: xyz")


# -- sgt fmt ---------------------------------------------------------------------------------------

def test_fmt_leaves_a_script_with_an_unknown_escape_alone(tmp_path):
    bad = tmp_path / "bad.sgt"
    bad.write_text("guide:   a \\q   b\n")
    r = sgt("fmt", str(bad), cwd=tmp_path)
    no_traceback(r)
    assert r.returncode == 1 and bad.read_text() == "guide:   a \\q   b\n"
    assert "SGT106" in r.stderr and f"sgt fmt: {bad} not formatted: fix its syntax errors first" in r.stderr
    r = sgt("fmt", "--check", str(bad), cwd=tmp_path)
    assert r.returncode == 1 and r.stdout == ""  # no diff offered for it either


def test_fmt_keeps_hard_links(tmp_path):
    a, b = tmp_path / "a.sgt", tmp_path / "b.sgt"
    a.write_text("guide:   hello   there\n")
    os.link(a, b)
    inode = a.stat().st_ino
    r = sgt("fmt", str(a), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert a.read_text() == b.read_text() == "guide: hello there\n"
    assert a.stat().st_ino == b.stat().st_ino == inode and a.stat().st_nlink == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.sgt", "b.sgt"]  # no temporary left
    # one link: replaced atomically, as before
    c = tmp_path / "c.sgt"
    c.write_text("guide:   one\n")
    inode = c.stat().st_ino
    assert sgt("fmt", str(c), cwd=tmp_path).returncode == 0
    assert c.read_text() == "guide: one\n" and c.stat().st_ino != inode
