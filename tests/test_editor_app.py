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
from textual.widgets import Button, Input, OptionList  # noqa: E402
from textual.widgets._toast import Toast  # noqa: E402

from core.skeleton import FPS  # noqa: E402
from sgt_tui.app.main import EditorApp  # noqa: E402
from sgt_tui.app.screens import AskScreen, ChoiceScreen, KeysScreen, LibraryScreen, ProblemsScreen, StyleScreen  # noqa: E402
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


def drive(app: EditorApp, steps, size=SIZE, notifications: bool = False):
    """Run ``steps(pilot)`` against the app in a headless terminal (with toasts if ``notifications``)."""
    async def main():
        async with app.run_test(size=size, notifications=notifications) as pilot:
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


def test_a_look_mark_at_a_speaker_of_another_line_is_no_problem(tmp_path):
    """`[look:bob]` names nobody until a line is bob's: typing that line clears the warning on
    ann's line, as `sgt check` judges the script."""
    app = make_app(script(tmp_path, "ann: [look:bob] Hello there.\n"))

    async def steps(pilot):
        assert [d.code for d in app.analysis.diagnostics] == ["SGT214"] and "W" in gutter(app, 0)
        await pilot.press("ctrl+end")
        await type_text(pilot, "bob: Hi.")
        await settle(pilot, app)
        assert app.analysis.diagnostics == [] and not app.area.diagnostics and "W" not in gutter(app, 0)

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
        pose = next(line for line in text.split("\n") if line.startswith("pose"))
        assert "point" in pose and "*" in pose and "<speed" in text and "shelf" in text  # the name, its stroke
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
        assert app.player.frame == min(frame + 2 + FPS, app.player.n_frames - 1)  # shift+right: 1 s on
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
        await pilot.press("ctrl+o")  # neural -> flow -> keyframe (the order: matching, the default, first)
        assert app.engine == "flow"
        await pilot.press("ctrl+o")
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
        for word in ("save", "keys", "probs", "lib", "style", "play", "gen", "gif", "quit"):  # ^z: room for ^p
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
    out = _sgt("edit", str(tmp_path))  # as sgt check says of a folder: an input it cannot read
    assert out.returncode == 1 and "folder" in out.stderr
    out = _sgt("edit", str(tmp_path / "fine.sgt"))
    assert out.returncode == 2 and "terminal" in out.stderr
    assert "edit" in _sgt("--help").stdout


def test_every_key_is_documented():
    from sgt_tui.app.main import ACTIONS

    doc = (ROOT / "docs" / "editor.md").read_text()
    for a in ACTIONS:
        assert f"| `{a.key}` | {a.title} |" in doc, a.key


def test_no_key_has_two_meanings():
    """An action's key (f6: suggest gestures) is not also a text key (the text area's f6 selects
    the line, but the action takes the key first): not in the keys screen, not in docs/editor.md."""
    import re

    from sgt_tui.app.actions import TEXT_KEYS
    from sgt_tui.app.main import ACTIONS

    doc = (ROOT / "docs" / "editor.md").read_text()
    text_editing = next(p for p in doc.split("\n\n") if p.startswith("Text editing is the usual"))
    documented = set(re.findall(r"`([^`]+)`", text_editing))
    listed = set(re.findall(r"[\w+]+", " ".join(TEXT_KEYS)))
    for a in ACTIONS:
        assert a.key not in documented and a.key not in listed, a.key


# -- issue 13 §4: the tmux audit's findings, one test each ------------------------------------------------------

def test_choice_dialogs_show_their_keys_as_written(tmp_path):
    app = make_app(script(tmp_path, "guide: one\n"))

    async def steps(pilot):
        await type_text(pilot, "x")
        await pilot.press("ctrl+q")
        assert isinstance(app.screen, ChoiceScreen)
        labels = [b.label for b in app.screen.query(Button)]
        assert [lb.plain for lb in labels] == ["[s] save and quit", "[q] quit without saving", "[c] cancel"]
        assert not any(span for lb in labels for span in lb.spans)  # no markup read into them: nothing struck
        await pilot.press("c")

    drive(app, steps)


def test_a_failed_job_shows_one_whole_message_and_f2_lists_it(tmp_path):
    app = make_app(script(tmp_path, "guide: hello [pose:wave] there\n"), engine="neural",
                   weights=str(tmp_path / "no-weights.pt"))

    async def steps(pilot):
        for _ in range(2):  # failing twice still leaves one notification
            await pilot.press("ctrl+g")
            await until(pilot, lambda: not app.jobs.busy and "failed" in app.last_message)
            await pilot.pause(0.1)
        toasts = list(app.screen.query(Toast))
        assert len(toasts) == 1
        message = app.last_message
        assert message.startswith("generate utterance 1 (neural) failed: generator weights not found")
        assert toasts[0].render().plain == message  # whole, not cut
        await pilot.press("f2")
        assert isinstance(app.screen, ProblemsScreen)
        listed = [(d.name, d.message) for d in app.screen.diagnostics]
        assert ("generation", message.removesuffix(" (F2 lists it)")) in listed

    drive(app, steps, notifications=True)


def test_crowded_pose_spans_stay_visible_at_80x24(tmp_path):
    """Two gestures on one word: the compiler resolves them (the second waits for the first's
    stroke), and at 80x24 the timeline shows both names in its one pose row."""
    app = make_app(script(tmp_path, "guide: [pose:wave] [pose:point_right] look over there at the big shelf\n"))

    async def steps(pilot):
        rows = str(app.timeline.render()).split("\n")
        pose = [r for r in rows if r.startswith("pose")]
        assert len(pose) == 1 and "[wave" in pose[0] and "point_right" in pose[0]
        assert "*" in pose[0] and "!" in pose[0]  # wave's stroke on time, point_right's late (it waits)

    drive(app, steps)


def test_overlapping_spans_without_room_are_marked():
    """Spans that do overlap (style spans nest; a motion file may hold overlapping poses) and
    have no row of their own at 80x24 are marked '+' where they start, and the lane says 'pose+'."""
    from sgt_tui.editor.timeline import Span, TimelineData, layout

    data = TimelineData([], [Span("pose", "wave", 0, 30, "wave"), Span("pose", "nod", 10, 20, "nod")], 60)
    rows, _ = layout(data, 80, max_lanes=1)
    pose = [r.text for r in rows if r.lane.startswith("pose")]
    lanes = [r.lane for r in rows if r.lane.startswith("pose")]
    assert lanes == ["pose+"] and "+" in pose[0]


def test_go_to_a_line_or_an_utterance_by_key_and_from_the_palette(tmp_path):
    app = make_app(script(tmp_path, "@rate 150\nguide: one\n\nguide: two\nguide: three\n"))

    async def steps(pilot):
        await pilot.press("ctrl+l")
        assert isinstance(app.screen, AskScreen)
        await type_text(pilot, "3")
        await pilot.press("enter")
        assert app.area.cursor_location == (2, 0)
        await pilot.press("ctrl+l")
        await type_text(pilot, "u3")
        await pilot.press("enter")
        assert app.area.cursor_location == (4, 0)
        await pilot.press("ctrl+l")
        await type_text(pilot, "u9")
        await pilot.press("enter")
        assert "no utterance 9" in app.last_message and app.area.cursor_location == (4, 0)
        await pilot.press("ctrl+p")
        await type_text(pilot, "Go to utterance")
        await pilot.pause(0.3)
        await pilot.press("enter")
        await pilot.pause()
        assert isinstance(app.screen, AskScreen) and app.screen.query_one(Input).value == "u"
        await type_text(pilot, "2")
        await pilot.press("enter")
        assert app.area.cursor_location == (3, 0)

    drive(app, steps)


def test_ctrl_home_ctrl_end_and_home_on_a_wrapped_line(tmp_path):
    long = "guide: " + " ".join(["words"] * 30)
    app = make_app(script(tmp_path, f"guide: first\n{long}\nguide: last one\n"))

    async def steps(pilot):
        area = app.area
        assert len(long) > 2 * area.content_size.width  # wrapped over several rows
        area.move_cursor((1, len(long) - 3))
        await pilot.press("home")
        assert area.cursor_location == (1, 0)  # the line's start, not its last row's
        await pilot.press("end")
        assert area.cursor_location == (1, len(long))
        await pilot.press("ctrl+home")
        assert area.cursor_location == (0, 0)
        await pilot.press("ctrl+end")
        assert area.cursor_location == (3, 0)

    drive(app, steps)


def test_f3_toggles_the_library_and_q_closes_read_only_panels(tmp_path):
    app = make_app(script(tmp_path, "guide: hello [pose:nope]\n"))

    async def steps(pilot):
        await pilot.press("f3")
        assert isinstance(app.screen, LibraryScreen)
        await pilot.press("f3")
        assert not isinstance(app.screen, LibraryScreen) and app.doc.text == "guide: hello [pose:nope]\n"
        for key, panel in (("f2", ProblemsScreen), ("f1", KeysScreen)):
            await pilot.press(key)
            assert isinstance(app.screen, panel)
            await pilot.press("q")
            assert not isinstance(app.screen, panel)
        assert app.doc.text == "guide: hello [pose:nope]\n"  # q closed them, it typed nothing

    drive(app, steps)


def test_library_filters_as_you_type(tmp_path):
    app = make_app(script(tmp_path, "guide: hello world\n"))

    async def steps(pilot):
        app.area.move_cursor((0, 9))
        await pilot.press("f3")
        screen = app.screen
        await type_text(pilot, "point")
        assert screen.shown and len(screen.shown) < len(screen.names)
        assert all("point" in n or any("point" in t for t in screen.library.get(n).tags) for n in screen.shown)
        assert screen.query_one(OptionList).option_count == len(screen.shown) and screen.current == screen.shown[0]
        first = screen.shown[0]
        await type_text(pilot, "zzz")
        assert screen.shown == [] and screen.current is None
        await pilot.press("backspace", "backspace", "backspace", "2")  # digits stay the speed keys
        assert screen.shown[0] == first and screen.speed == 2
        await pilot.press("enter")
        assert app.doc.text == f"guide: [pose:{first} x2] hello world\n"

    drive(app, steps)


def _with_fixes(app: EditorApp) -> EditorApp:
    """Give did-you-mean diagnostics their replacement fixes, as the rules do once every
    did-you-mean is a Fix (another branch); diagnostics that already have fixes are kept."""
    import dataclasses

    from core import rules

    run = app.analyses.analyser.run

    def fixed(d):
        if d.fixes or not d.suggestions:
            return d
        return dataclasses.replace(d, fixes=rules.replacements(d.file, d.line, d.col, d.length, d.suggestions))

    def patched(text, **kw):
        a = run(text, **kw)
        a.diagnostics = [fixed(d) for d in a.diagnostics]
        a.by_line = {line: [fixed(d) for d in found] for line, found in a.by_line.items()}
        return a

    app.analyses.analyser.run = patched
    return app


def test_problems_show_the_did_you_mean_and_apply_its_fix_with_one_key(tmp_path):
    app = _with_fixes(make_app(script(tmp_path, "guide: fine\nguide: hello [pose:wavee] world\n")))

    async def steps(pilot):
        await pilot.press("f2")
        screen = app.screen
        prompt = screen.query_one(OptionList).get_option_at_index(0).prompt.plain
        assert "unknown gesture 'wavee'" in prompt and "did you mean 'wave'" in prompt
        assert "f: replace with 'wave'" in prompt
        await pilot.press("f")
        assert app.doc.lines[1] == "guide: hello [pose:wave] world"
        await settle(pilot, app)
        assert app.analysis.errors == 0
        await pilot.press("ctrl+z")  # one undo step
        await settle(pilot, app)
        assert app.doc.lines[1] == "guide: hello [pose:wavee] world"
        app.area.move_cursor((1, 22))  # in "wavee": the quick fix from the editor
        await pilot.pause()
        assert "^f: replace with 'wave'" in str(app.query_one("#message").render())
        await pilot.press("ctrl+f")
        assert app.doc.lines[1] == "guide: hello [pose:wave] world"
        await pilot.press("ctrl+f")
        assert "no suggested fix" in app.last_message

    drive(app, steps)


def test_palette_lists_each_action_once_with_its_key_and_the_footer_shows_ctrl_p(tmp_path):
    from textual.command import CommandList
    from textual.widgets._footer import FooterKey

    app = make_app(script(tmp_path, "guide: hello\n"))

    async def steps(pilot):
        assert any(k.key == "ctrl+p" for k in app.screen.query(FooterKey))
        await pilot.press("ctrl+p")
        await pilot.pause(0.5)
        commands = app.screen.query_one(CommandList)
        titles = [commands.get_option_at_index(i).prompt.plain.split("\n")[0]
                  for i in range(commands.option_count)]
        assert sum(t.startswith("Quit") for t in titles) == 1 and sum(t.startswith("Keys") for t in titles) == 1
        assert "Problems  f2" in titles and "Motion library  f3" in titles and "Save  ctrl+s" in titles
        assert len(titles) == len(set(titles))

    drive(app, steps)


def test_ctrl_t_cancels_the_job_asked_for_last_and_says_which(tmp_path):
    long = "".join(f"guide: line {i} [pose:wave] says more words here and there.\n" for i in range(60))
    app = make_app(script(tmp_path, long), engine="keyframe")

    async def steps(pilot):
        await pilot.press("f8", "ctrl+g")
        running, queued = app.jobs.runner.current, app.jobs.runner.queue[-1]
        await pilot.press("ctrl+t")
        assert queued.state == "cancelled" and running.state == "running"
        assert app.last_message == ("cancelled generate utterance 1 (keyframe) (queued); "
                                    "generate script (keyframe) keeps running")
        said = []
        say = app.say
        app.say = lambda text, severity="information": (said.append(text), say(text, severity))
        await pilot.press("ctrl+t")
        await until(pilot, lambda: not app.jobs.busy)
        assert running.state == "cancelled"
        assert said[0] == "cancelling generate script (keyframe) (running)"

    drive(app, steps)


def _finished_job(tmp_path: Path, app: EditorApp, op: str):
    """A job of ``op`` finished for the cursor's utterance (its motion made here, by the keyframe engine)."""
    from core.motion import save_motion
    from dsl.compiler import compile_file
    from model.generate import clips_from_plan
    from sgt_tui.editor.jobs import DONE, Job
    from sgt_tui.editor.protocol import JobRequest, JobResult

    plan = compile_file(app.script.path, timing="estimate", source=app.doc.text).plan
    clips = clips_from_plan(plan, engine="keyframe")
    motion = tmp_path / f"{op}.npz"
    save_motion(motion, clips)
    gif = str(tmp_path / "s.u1.gif") if op == "render" else None
    result = JobResult((0,), clips[0].n_frames, "estimate", str(motion), gif, 3 if gif else 0)
    request = JobRequest(op, str(app.script.path), app.doc.text, engine="keyframe", gif=gif)
    return Job("1", f"{op} utterance 1 (keyframe)", request, (app.current_key,), state=DONE, result=result)


def test_a_finished_render_leaves_a_paused_preview_paused(tmp_path):
    from sgt_tui.app.services import JobUpdated

    app = make_app(script(tmp_path, "guide: [pose:wave] hello there, how are you today?\n"))

    async def steps(pilot):
        app.preview.action_seek(5)
        assert not app.player.playing
        app.post_message(JobUpdated(_finished_job(tmp_path, app, "render")))
        await pilot.pause()
        assert app.player.label == "generated · keyframe"
        assert not app.player.playing and app.player.frame == 5 and not app.preview.animating
        app.post_message(JobUpdated(_finished_job(tmp_path, app, "generate")))  # a new generation plays
        await pilot.pause()
        assert app.player.playing and app.preview.animating

    drive(app, steps)


def test_alt_right_then_alt_left_gives_back_the_text(tmp_path):
    original = "guide: Look [pose:wave] <speed:-1>over there</speed> now\n"
    app = make_app(script(tmp_path, original))

    async def steps(pilot):
        app.area.move_cursor((0, 14))
        await pilot.press("alt+right")
        assert app.doc.lines[0] == "guide: Look <speed:-1>over [pose:wave] there</speed> now"
        await pilot.press("alt+left")
        assert app.doc.text == original

    drive(app, steps)


def test_typing_over_a_selection_is_one_undo_step(tmp_path):
    original = "guide: hello world\n"
    app = make_app(script(tmp_path, original))

    async def steps(pilot):
        app.area.move_cursor((0, 7))
        await pilot.press(*["shift+right"] * 5)
        await type_text(pilot, "hey")
        assert app.doc.text == "guide: hey world\n"
        await pilot.press("ctrl+z")
        assert app.doc.text == original and app.area.text == original

    drive(app, steps)


# -- file safety -----------------------------------------------------------------------------------------

def test_a_failed_save_offers_save_as(tmp_path, monkeypatch, cache):
    import errno

    import sgt_tui.editor.files as files

    path = script(tmp_path, "guide: one\n")
    real_write = files.atomic_write

    def full_disk(target, data):
        if Path(target) == path:
            raise OSError(errno.ENOSPC, "No space left on device")
        real_write(target, data)

    monkeypatch.setattr(files, "atomic_write", full_disk)
    app = make_app(path)
    elsewhere = tmp_path / "elsewhere.sgt"

    async def steps(pilot):
        await type_text(pilot, "x")
        await pilot.press("ctrl+s")
        assert isinstance(app.screen, AskScreen) and "No space left on device" in app.screen.message
        assert app.screen.query_one(Input).value == str(path)
        await pilot.press("escape")
        assert "not saved" in app.last_message and RecoveryFile(path, cache / "recovery").load().text == "xguide: one\n"
        await pilot.press("ctrl+s")
        app.screen.query_one(Input).value = str(elsewhere)
        await pilot.press("enter")
        assert elsewhere.read_text() == "xguide: one\n" and path.read_text() == "guide: one\n"
        assert app.script.path == elsewhere and not app.doc.modified
        assert str(app.query_one("#status").render()).startswith("elsewhere.sgt") or "elsewhere.sgt" in str(
            app.query_one("#status").render())
        await type_text(pilot, "y")
        await pilot.press("ctrl+s")  # later saves go to the new file
        assert elsewhere.read_text() == "xyguide: one\n"

    drive(app, steps)


def test_a_save_into_a_vanished_folder_offers_save_as(tmp_path):
    folder = tmp_path / "sub"
    folder.mkdir()
    path = script(folder, "guide: one\n")
    app = make_app(path)

    async def steps(pilot):
        await type_text(pilot, "x")
        path.unlink()
        folder.rmdir()
        folder.write_text("a file where the folder was")  # the save cannot succeed, even as root
        await pilot.press("ctrl+s")
        if isinstance(app.screen, ChoiceScreen):  # the file is gone from disk: overwrite it
            await pilot.press("o")
        assert isinstance(app.screen, AskScreen) and "cannot save" in app.screen.message
        app.screen.query_one(Input).value = str(tmp_path / "rescued.sgt")
        await pilot.press("enter")
        assert (tmp_path / "rescued.sgt").read_text() == "xguide: one\n"

    drive(app, steps)


def test_saving_a_symlinked_script_keeps_the_link(tmp_path):
    real = script(tmp_path, "guide: one\n", "real.sgt")
    link = tmp_path / "link.sgt"
    link.symlink_to(real)
    app = make_app(link)

    async def steps(pilot):
        await type_text(pilot, "x")
        await pilot.press("ctrl+s")

    drive(app, steps)
    assert link.is_symlink() and real.read_text() == "xguide: one\n"


def test_cli_refuses_devices_fifos_and_folders(tmp_path):
    import os

    fifo = tmp_path / "pipe.sgt"
    os.mkfifo(fifo)
    for target, what in (("/dev/null", "character device"), (str(fifo), "FIFO"), (str(tmp_path), "folder")):
        out = _sgt("edit", target)  # returns at once: a FIFO is never opened; 1 as for sgt check
        assert out.returncode == 1 and what in out.stderr and "Traceback" not in out.stderr, out.stderr


def test_a_burst_of_keys_leaves_one_analysis_in_the_exclusive_worker_group(tmp_path, monkeypatch):
    from sgt_tui.app import services

    # a debounce longer than the burst takes, so the last analysis is certainly still pending
    # when counted (with the shipped delay an idle machine sometimes finished it first)
    monkeypatch.setattr(services, "ANALYSIS_DELAY", 1.0)
    app = make_app(script(tmp_path, "guide: hello\n"))

    async def steps(pilot):
        await pilot.press("end")
        await type_text(pilot, " there")
        pending = [w for w in app.workers if w.group == "analysis" and not w.is_finished]
        assert len(pending) == 1  # each keystroke cancelled the analysis before it
        await settle(pilot, app)

    drive(app, steps)


def test_text_from_the_script_is_shown_as_written_not_read_as_markup(tmp_path):
    app = make_app(script(tmp_path, "guide: hello \\[s\\] [pose:wave] big world\n"))

    async def steps(pilot):
        app.area.move_cursor((0, 7))
        await pilot.press(*["shift+right"] * 27, "f4")
        assert isinstance(app.screen, StyleScreen)
        assert app.screen.query_one("#dialog-title").render().plain == "Style for: hello \\[s\\] [pose:wave] big"
        await pilot.press("escape")
        app.say("inserted [pose:wave] [b]here[/b]")
        await pilot.pause()
        assert str(app.query_one("#message").render()) == "inserted [pose:wave] [b]here[/b]"

    drive(app, steps)
