"""Snapshots of the main screens of `sgt edit` (SVG, in tests/__snapshots__/test_editor_snapshots/).

After a deliberate change of the layout, look at the report, then refresh them with
`python3 -m pytest tests/test_editor_snapshots.py --snapshot-update`.
"""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pytest_textual_snapshot")

from sgt_tui.app.main import EditorApp  # noqa: E402
from sgt_tui.editor.files import ScriptFile  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def app(tmp_path, monkeypatch):
    monkeypatch.setenv("SGT_EDITOR_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)  # the status line shows the name relative to here
    text = (ROOT / "examples" / "mall_guide.sgt").read_text().replace("[pose:point_up]", "[pose:point_upp]")
    Path("mall_guide.sgt").write_text(text)
    return EditorApp(ScriptFile.open("mall_guide.sgt"), engine="rules", cursor_blink=False)


def at(row: int, col: int):
    async def run_before(pilot) -> None:
        pilot.app.area.move_cursor((row, col))
        await pilot.pause()

    return run_before


def test_main_screen_80x24(app, snap_compare):
    assert snap_compare(app, terminal_size=(80, 24), run_before=at(8, 20))


def test_main_screen_on_an_error_120x40(app, snap_compare):
    assert snap_compare(app, terminal_size=(120, 40), run_before=at(9, 32))


def test_library(app, snap_compare):
    async def run_before(pilot) -> None:
        await pilot.press("f3", "down", "down", "2")
        await pilot.pause(0.1)
        preview = pilot.app.screen.query_one("#library-preview")
        preview.play(False)
        preview.action_seek(6)
        await pilot.pause(0.1)

    assert snap_compare(app, terminal_size=(80, 24), run_before=run_before)


def test_style_dialog(app, snap_compare):
    async def run_before(pilot) -> None:
        pilot.app.area.move_cursor((8, 15))
        await pilot.press(*["shift+right"] * 9, "f4", "left", "left", "down", "right")
        await pilot.pause()

    assert snap_compare(app, terminal_size=(80, 24), run_before=run_before)


def test_problems_list(app, snap_compare):
    assert snap_compare(app, terminal_size=(80, 24), press=["f2"])


def test_unsaved_changes_dialog_shows_its_keys(app, snap_compare):
    assert snap_compare(app, terminal_size=(80, 24), press=["x", "ctrl+q"])


def test_library_filtered(app, snap_compare):
    async def run_before(pilot) -> None:
        await pilot.press("f3", "p", "o", "i", "n", "t")
        await pilot.pause(0.1)
        preview = pilot.app.screen.query_one("#library-preview")
        preview.play(False)
        preview.action_seek(6)
        await pilot.pause(0.1)

    assert snap_compare(app, terminal_size=(80, 24), run_before=run_before)


def test_overlapping_poses_at_80x24(tmp_path, monkeypatch, snap_compare):
    monkeypatch.setenv("SGT_EDITOR_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    Path("overlap.sgt").write_text("guide: [pose:wave] [pose:point_right] look over <speed:+0.5>there</speed> "
                                   "at the big shelf\n")
    app = EditorApp(ScriptFile.open("overlap.sgt"), engine="rules", cursor_blink=False)
    assert snap_compare(app, terminal_size=(80, 24))
