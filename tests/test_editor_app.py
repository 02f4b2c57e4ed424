"""`sgt edit` driven through Textual's Pilot: every action of the editor, at 80x24."""

from __future__ import annotations

import asyncio
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("textual")

from textual.keys import _character_to_key  # noqa: E402
from textual.widgets import OptionList  # noqa: E402

from sgt_tui.app.main import EditorApp  # noqa: E402
from sgt_tui.app.screens import ChoiceScreen, LibraryScreen, ProblemsScreen, StyleScreen  # noqa: E402
from sgt_tui.editor.files import ScriptFile  # noqa: E402
from sgt_tui.editor.recovery import RecoveryFile  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SIZE = (80, 24)


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SGT_EDITOR_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("SGT_RECOVERY_DIR", raising=False)
    return tmp_path / "cache"


def script(tmp_path, text: str, name: str = "s.sgt") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def make_app(path: Path, **kw) -> EditorApp:
    kw.setdefault("engine", "rules")
    return EditorApp(ScriptFile.open(path), cursor_blink=False, gif_size=(48, 48), **kw)


def drive(app: EditorApp, steps, size=SIZE):
    """Run ``steps(pilot)`` against the app in a headless terminal."""
    async def main():
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            await steps(pilot)
    asyncio.run(main())


async def type_text(pilot, text: str) -> None:
    await pilot.press(*[("enter" if c == "\n" else _character_to_key(c)) for c in text])


async def settle(pilot, app: EditorApp) -> None:
    """Wait for the debounced analysis to run and its result to be applied."""
    await pilot.pause(0.15)
    await app.workers.wait_for_complete()
    await pilot.pause()
    assert app.shown_version == app.doc.version


async def until(pilot, condition, timeout: float = 90.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        await pilot.pause(0.1)


def gutter(app: EditorApp, y: int) -> str:
    area = app.area
    return area.render_line(y).text[: area.gutter_width]


# -- 1. editing with live diagnostics ----------------------------------------------------------------

def test_typing_shows_live_diagnostics_with_marks_not_only_colour(tmp_path):
    app = make_app(script(tmp_path, "guide: hello world\nguide: fine\n"))

    async def steps(pilot):
        assert app.analysis.errors == 0 and "E" not in gutter(app, 0)
        await pilot.press("end")
        await type_text(pilot, " [pose:wavee]")
        await settle(pilot, app)
        assert app.analysis.errors == 1
        assert app.area.diagnostics[0][0].message == "unknown gesture 'wavee'"
        assert "E" in gutter(app, 0) and "E" not in gutter(app, 1)
        underlined = [s for s in app.area.render_line(0)._segments if s.style and s.style.underline]
        assert "".join(s.text for s in underlined) == "wavee"
        message = str(app.query_one("#message").render())
        assert "error" in message and "wavee" in message and "did you mean 'wave'" in message
        await pilot.press("left", "backspace")  # "wave" is a gesture: the problem goes away
        await settle(pilot, app)
        assert app.analysis.errors == 0 and not app.area.diagnostics

    drive(app, steps)


def test_problems_list_and_next_problem_jump(tmp_path):
    app = make_app(script(tmp_path, "guide: fine\nguide: [pose:nope] a\nguide: <speed:9>b</speed>\n"))

    async def steps(pilot):
        await pilot.press("f2")
        assert isinstance(app.screen, ProblemsScreen)
        assert app.screen.query_one(OptionList).highlighted == 0
        await pilot.press("down", "enter")
        assert not isinstance(app.screen, ProblemsScreen)
        assert app.area.cursor_location == (2, 8)  # the out-of-range speed on line 3
        await pilot.press("ctrl+n")  # wraps to the first problem
        assert app.area.cursor_location == (1, 13)

    drive(app, steps)


# -- 2. timeline --------------------------------------------------------------------------------------------

def test_timeline_follows_the_utterance_at_the_cursor(tmp_path):
    app = make_app(script(tmp_path, (ROOT / "examples" / "mall_guide.sgt").read_text()))

    async def steps(pilot):
        tl = app.timeline
        assert "utterance 1" in tl.border_title and tl.data.words[0][0] == "Hello"
        app.area.move_cursor((8, 3))
        await pilot.pause()
        assert "utterance 2" in tl.border_title and "estimated" in tl.border_title
        kinds = {s.kind: s for s in tl.data.spans}
        assert kinds["pose"].name == "point_right" and kinds["style"].name == "speed"
        text = str(tl.render())
        assert "[point_right" in text and "<speed" in text and "shelf" in text
        app.area.move_cursor((10, 3))
        await pilot.pause()
        assert any(s.kind == "pause" for s in tl.data.spans) and "‥pause" in str(tl.render())

    drive(app, steps)


# -- 3. preview --------------------------------------------------------------------------------------------

def test_preview_animates_only_while_playing_and_visible(tmp_path):
    app = make_app(script(tmp_path, "guide: [pose:wave] hello there, how are you today?\n"))

    async def steps(pilot):
        preview = app.preview
        assert app.player.n_frames > 10 and not preview.animating
        assert any(c != "\u2800" and 0x2800 <= ord(c) <= 0x28FF for c in str(preview.render()))
        await pilot.press("f5")
        assert preview.animating and app.player.playing
        await pilot.pause(0.4)
        assert app.player.frame > 0
        await pilot.press("f3")  # the library covers the main screen: its preview stops
        assert isinstance(app.screen, LibraryScreen) and not preview.animating
        await pilot.press("escape")
        await pilot.pause()
        assert preview.animating
        await pilot.press("f5")
        assert not preview.animating
        frame = app.player.frame
        await pilot.pause(0.3)
        assert app.player.frame == frame
        preview.focus()
        await pilot.press("right", "right", "shift+right")
        assert app.player.frame == frame + 2 + 15 or app.player.frame == app.player.n_frames - 1
        assert app.timeline.playhead == app.player.frame

    drive(app, steps)


# -- 4. motion library ---------------------------------------------------------------------------------------

def test_library_previews_and_inserts_at_the_cursor(tmp_path):
    app = make_app(script(tmp_path, "guide: hello world\n"))

    async def steps(pilot):
        app.area.move_cursor((0, 9))
        await pilot.press("f3")
        screen = app.screen
        assert isinstance(screen, LibraryScreen)
        options = screen.query_one(OptionList)
        options.highlighted = screen.names.index("point_right")
        await pilot.pause()
        await pilot.press("2", "ctrl+f")  # letters filter the list: flip is ctrl+f
        g = screen.library.get("point_right")
        assert screen.player.n_frames == g.clip(speed=2, flip=True).n_frames
        await pilot.pause(0.2)
        assert screen.query_one("#library-preview").animating
        await pilot.press("enter")
        assert app.doc.text == "guide: [pose:point_right x2 flip] hello world\n"
        await settle(pilot, app)
        assert app.analysis.errors == 0

    drive(app, steps)


# -- 5. style --------------------------------------------------------------------------------------------------

def test_style_sliders_and_presets_write_style_tags(tmp_path):
    app = make_app(script(tmp_path, "guide: hello big world\n"))

    async def steps(pilot):
        app.area.move_cursor((0, 8))
        await pilot.press(*["shift+right"] * 8)  # "ello big" -> whole words "hello big"
        await pilot.press("f4")
        assert isinstance(app.screen, StyleScreen)
        await pilot.press("right", "right", "down", "left", "enter")
        assert app.doc.text == "guide: <speed:+1 space:-0.5>hello big</speed> world\n"
        app.area.move_cursor((0, 48))  # in "world"
        await pilot.press("f4", "s")
        assert app.doc.lines[0].endswith("<sad>world</sad>")
        await settle(pilot, app)
        assert app.analysis.errors == 0
        styles = app.analysis.utterances[0].utterance.styles
        assert [s.name for s in styles] == ["speed", "sad"]

    drive(app, steps)


# -- 6. move a pose control -------------------------------------------------------------------------------------

def test_alt_arrows_move_the_pose_control_word_by_word(tmp_path):
    app = make_app(script(tmp_path, "guide: Look at [pose:wave] the shelf\n"))

    async def steps(pilot):
        app.area.move_cursor((0, 17))
        await pilot.press("alt+right")
        assert app.doc.lines[0] == "guide: Look at the [pose:wave] shelf"
        await pilot.press("alt+left", "alt+left", "alt+left")
        assert app.doc.lines[0] == "guide: [pose:wave] Look at the shelf"
        await pilot.press("alt+left")
        assert "first word" in str(app.query_one("#message").render())
        await settle(pilot, app)
        assert app.analysis.utterances[0].utterance.poses[0].word_index == 0

    drive(app, steps)


# -- 7. jobs ------------------------------------------------------------------------------------------------------

def test_generate_and_render_in_the_background(tmp_path):
    path = script(tmp_path, "guide: [pose:wave] hello there.\n")
    app = make_app(path)

    async def steps(pilot):
        key = app.current_key
        await pilot.press("ctrl+g")
        assert app.query_one("#jobbar").display  # the progress bar shows while it runs
        await type_text(pilot, "x")  # the editor still takes keys while the job runs
        assert app.doc.text.startswith("x")
        await until(pilot, lambda: app.takes.has(key))
        assert app.takes.generated[key][0] == "rules"
        await pilot.press("ctrl+z")  # back to the generated text: the preview shows the generated motion
        await settle(pilot, app)
        assert app.player.label.startswith("generated") and app.timeline.data.timing == "speech"
        await pilot.press("f9")
        gif = path.with_name("s.u1.gif")  # utterance 1, counted from 1 as in the status line
        await until(pilot, gif.exists, 240)
        await until(pilot, lambda: not app.jobs.busy)
        assert gif.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
        assert not app.query_one("#jobbar").display

    drive(app, steps)


def test_jobs_cancel_and_missing_weights_errors(tmp_path):
    long = "".join(f"guide: line {i} [pose:wave] says more words here and there.\n" for i in range(60))
    app = make_app(script(tmp_path, long), engine="neural", weights=str(tmp_path / "no-weights.pt"))

    async def steps(pilot):
        assert "no weights" in str(app.query_one("#status").render())
        await pilot.press("ctrl+g")
        await until(pilot, lambda: not app.jobs.busy)
        assert "weights not found" in app.last_message and "sgt train" in app.last_message
        await pilot.press("ctrl+o")  # neural -> keyframe
        assert app.engine == "keyframe"
        await pilot.press("f8")
        await pilot.pause(0.05)
        await pilot.press("ctrl+t")
        await until(pilot, lambda: not app.jobs.busy)
        assert "cancelled" in app.last_message

    drive(app, steps)


# -- 8. undo and redo ---------------------------------------------------------------------------------------------

def test_one_history_for_typed_and_action_edits(tmp_path):
    original = "guide: Look at [pose:wave] the shelf\n"
    app = make_app(script(tmp_path, original))

    async def steps(pilot):
        await pilot.press("end")
        await type_text(pilot, " now")
        app.area.move_cursor((0, 17))
        await pilot.press("alt+right")  # action
        app.insert_pose("[pose:nod]")  # action, at the cursor
        app.area.move_cursor((0, 8))
        await pilot.press("f4", "c")  # action: <calm>
        final = app.doc.text
        assert app.area.text == final
        await pilot.press("ctrl+z", "ctrl+z", "ctrl+z", "ctrl+z")
        assert app.doc.text == original and app.area.text == original and not app.doc.modified
        await pilot.press("ctrl+y", "ctrl+y", "ctrl+y", "ctrl+y")
        assert app.doc.text == final and app.area.text == final

    drive(app, steps)


# -- 9. saving, recovery, changes on disk -------------------------------------------------------------------------

def test_save_is_atomic_and_new_files_are_created(tmp_path):
    path = tmp_path / "sub" / "new.sgt"
    path.parent.mkdir()
    app = make_app(path)

    async def steps(pilot):
        assert app.doc.text == "" and "(new)" in str(app.query_one("#status").render())
        await type_text(pilot, "guide: hi [pose:wave] there")
        await pilot.press("ctrl+s")
        assert path.read_text() == "guide: hi [pose:wave] there"
        assert [p.name for p in path.parent.iterdir()] == ["new.sgt"]  # no temporary left behind
        assert "[+]" not in str(app.query_one("#status").render())

    drive(app, steps)


def test_unsaved_work_is_recovered_after_a_crash(tmp_path, cache):
    path = script(tmp_path, "guide: saved\n")
    first = make_app(path)

    async def crash(pilot):
        await type_text(pilot, "guide: unsaved\n")
        first.recovery.write()  # the periodic write
        # the process dies here: no save, no clean exit

    drive(first, crash)
    assert RecoveryFile(path, cache / "recovery").load().text == "guide: unsaved\nguide: saved\n"
    second = make_app(path)

    async def restart(pilot):
        await pilot.pause(0.1)
        assert isinstance(second.screen, ChoiceScreen)
        await pilot.press("r")
        assert second.doc.text == "guide: unsaved\nguide: saved\n" and second.doc.modified
        await pilot.press("ctrl+s")
        assert RecoveryFile(path, cache / "recovery").load() is None

    drive(second, restart)
    assert path.read_text() == "guide: unsaved\nguide: saved\n"


def test_changes_on_disk_are_detected_not_overwritten(tmp_path):
    path = script(tmp_path, "guide: one\n")
    app = make_app(path)

    async def steps(pilot):
        path.write_text("guide: theirs\n")
        assert app.disk.check()  # unmodified buffer: reloaded
        await pilot.pause()
        assert app.doc.text == "guide: theirs\n"
        await type_text(pilot, "guide: mine\n")
        path.write_text("guide: theirs again\n")
        assert app.disk.check()
        await pilot.pause()
        assert app.disk_warned and "CHANGED ON DISK" in str(app.query_one("#status").render())
        await pilot.press("ctrl+s")
        assert isinstance(app.screen, ChoiceScreen)
        await pilot.press("c")
        assert path.read_text() == "guide: theirs again\n"
        await pilot.press("ctrl+s", "o")
        assert path.read_text() == "guide: mine\nguide: theirs\n"

    drive(app, steps)


def test_quit_asks_about_unsaved_changes(tmp_path):
    app = make_app(script(tmp_path, "guide: one\n"))

    async def steps(pilot):
        await type_text(pilot, "x")
        await pilot.press("ctrl+q")
        assert isinstance(app.screen, ChoiceScreen)
        await pilot.press("c")
        assert app.is_running
        await pilot.press("ctrl+q", "q")
        await pilot.pause()

    drive(app, steps)
    assert app.return_code == 0


# -- 10. footer, palette, 80x24 ----------------------------------------------------------------------------------

def test_footer_keys_palette_and_layout(tmp_path):
    app = make_app(script(tmp_path, (ROOT / "examples" / "lecture.sgt").read_text()))

    async def steps(pilot):
        footer = " ".join(str(b.description) for b in app.screen.active_bindings.values()
                          for b in [b.binding] if b.show)
        for word in ("save", "undo", "keys", "probs", "lib", "style", "play", "gen", "gif", "quit"):
            assert word in footer
        area, preview, timeline = app.area, app.preview, app.timeline
        assert area.size.width >= 45 and area.size.height >= 12
        assert preview.size.width >= 24 and timeline.size.height >= 4
        assert app.query_one("#message").region.y == 22 and app.query_one("Footer").region.y == 23
        await pilot.press("f1")
        await pilot.press("escape")
        await pilot.press("ctrl+p")
        await type_text(pilot, "Engine: keyframe")
        await pilot.pause(0.3)
        await pilot.press("enter")
        await pilot.pause()
        assert app.engine == "keyframe"

    drive(app, steps)


def test_bigger_terminal_gives_room_to_the_panels(tmp_path):
    app = make_app(script(tmp_path, (ROOT / "examples" / "lecture.sgt").read_text()))

    async def steps(pilot):
        assert app.timeline.size.height >= 6 and app.preview.size.width >= 36

    drive(app, steps, size=(120, 40))


# -- the command line ---------------------------------------------------------------------------------------------

def _sgt(*args, cwd=None):
    code = "import sys; from sgt_tui.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          cwd=cwd or ROOT, timeout=60, stdin=subprocess.DEVNULL)


def test_cli_errors_are_messages_not_tracebacks(tmp_path):
    bad = tmp_path / "latin.sgt"
    bad.write_bytes("guide: caf\xe9\n".encode("latin-1"))
    out = _sgt("edit", str(bad))
    assert out.returncode == 1 and "not UTF-8" in out.stderr and "Traceback" not in out.stderr
    out = _sgt("edit", str(tmp_path))
    assert out.returncode == 2 and "folder" in out.stderr
    out = _sgt("edit", str(tmp_path / "fine.sgt"))
    assert out.returncode == 2 and "terminal" in out.stderr
    assert "edit" in _sgt("--help").stdout


def test_every_key_is_documented():
    from sgt_tui.app.main import ACTIONS

    doc = (ROOT / "docs" / "editor.md").read_text()
    for a in ACTIONS:
        assert f"| `{a.key}` | {a.title} |" in doc, a.key
