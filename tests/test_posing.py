"""A gesture made by hand (library/posing.py) and the script edits a pose editor makes (dsl/marks.py):
the spec file written reads back exactly the keyframes saved (and writes the same text again), saving
refuses what it must, and a [pose:NAME] mark or an @library line keeps the layout `sgt fmt` keeps."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core import ik
from core.fileio import LinkRefused
from dsl.fmt import format_source
from dsl.marks import MarkError, add_library, insert_mark, word_position
from library import load_library
from library.posing import Draft, DraftError, FileChanged, GestureExists, new_draft, save
from library.spec import parse_spec_text

LIB = load_library(use_config=False)


@pytest.mark.parametrize("name", LIB.names())
def test_every_builtin_gesture_reads_back_exactly_and_writes_the_same_text_again(name):
    spec = LIB.get(name).spec
    draft = Draft.from_spec(spec).canonical()
    text = draft.spec_text()
    again = parse_spec_text(text, Path(f"{name}.toml"))
    assert all(np.array_equal(a.reshape(-1), k.pose) for a, k in zip(again.key_dirs, draft.keys))  # the keyframes saved, every bit
    assert all(np.abs(a - b).max() < 1e-15 for a, b in zip(again.key_dirs, spec.key_dirs))  # the gesture's, to the last digits
    held = [(k.time, k.label, k.stroke, k.hands) for k in Draft.from_spec(spec).keys]  # the hands as they are at each keyframe
    assert [(k.time, k.label, k.stroke, k.hands) for k in Draft.from_spec(again).keys] == held
    assert Draft.from_spec(again, drives=draft.drives).canonical().spec_text() == text


def test_posed_keyframes_read_back_exactly(tmp_path):
    rng = np.random.default_rng(4)
    for i in range(30):
        draft = new_draft(f"posed_{i}")
        target = np.array([-0.2, 1.4, 0.2]) + rng.normal(scale=0.2, size=3)
        draft.keys[1].pose = ik.set_head(ik.solve_arm(draft.keys[1].pose, "right", target, swivel=float(rng.uniform(-60, 60))),
                                         *rng.uniform(-30, 30, size=3))
        saved = save(draft, tmp_path)
        read = parse_spec_text(saved.path.read_text(), saved.path)
        assert np.array_equal(read.key_dirs[1].reshape(-1), saved.draft.keys[1].pose)
        # what is saved is what was posed, to the last digits
        assert np.abs(saved.draft.keys[1].pose - draft.keys[1].pose).max() < 1e-15


def test_saving_refuses_an_existing_gesture_a_changed_file_and_a_link(tmp_path):
    draft = new_draft("mine")
    draft.keys[1].pose = ik.solve_arm(draft.keys[1].pose, "left", [0.4, 1.5, 0.3])
    first = save(draft, tmp_path)
    with pytest.raises(GestureExists):
        save(draft, tmp_path)
    with pytest.raises(GestureExists, match="built in"):
        save(new_draft("wave"), tmp_path, elsewhere="built in")
    first.path.write_text(first.path.read_text() + "# by hand\n")
    with pytest.raises(FileChanged):
        save(draft, tmp_path, replace=True, expected_sha256=first.sha256)
    assert first.path.read_text().endswith("# by hand\n")
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(LinkRefused):
        save(new_draft("other"), tmp_path, subfolder="link")
    assert not list((tmp_path / "elsewhere").iterdir())


@pytest.mark.parametrize("bad", [None, {"name": "Bad Name", "duration": 1, "keyframes": []},
                                 {"name": "ok", "duration": 99, "keyframes": [{}]},
                                 {**new_draft("ok").to_dict(), "keyframes": [{"time": 0, "pose": [0] * 27}]},
                                 {**new_draft("ok").to_dict(), "extra": 1}])
def test_a_pages_gesture_is_checked_field_by_field(bad):
    with pytest.raises(DraftError) as e:
        Draft.from_dict(bad)
    assert "\n" not in str(e.value)


def _fmt(source: str) -> str:
    """What `sgt fmt` makes of a script's text (a byte-order mark is not part of the text it formats)."""
    return format_source(source.lstrip("\ufeff"))


SCRIPTS = [
    "@seed 4\n\nguide: Look at the shelf over there.\n",
    "# a comment\nguide: \"Look\" at it, l'amour [pose:nod] now.\n",
    "\ufeff@seed 1\r\nguide: Look at the shelf.\r\nvisitor: Thanks, I see it.\r\n",
]


@pytest.mark.parametrize("source", SCRIPTS)
def test_a_mark_before_any_word_keeps_the_layout_sgt_fmt_keeps(source):
    formatted = _fmt(source)
    assert formatted == source.lstrip("\ufeff")
    u = 0
    while True:
        try:
            word_position(source, u, 0)
        except MarkError:
            break
        w = 0
        while True:
            try:
                line, col = word_position(source, u, w)
            except MarkError:
                break
            edited = insert_mark(source, line, col, "point_right")
            assert _fmt(edited) == edited.lstrip("\ufeff"), (u, w, edited)
            assert edited.replace("[pose:point_right] ", "", 1) == source
            w += 1
        u += 1
    assert u >= 1


def test_a_library_line_goes_into_the_header():
    for source in SCRIPTS:
        edited = add_library(source, "gestures")
        assert "@library gestures" in edited
        assert _fmt(edited) == edited.lstrip("\ufeff")


def test_no_word_there_is_one_line():
    with pytest.raises(MarkError, match="no word"):
        insert_mark(SCRIPTS[0], 3, 2, "nod")
    with pytest.raises(MarkError, match="no utterance"):
        word_position(SCRIPTS[0], 5, 0)


def test_the_editors_pose_session_moves_in_screen_axes_keeps_limits_and_undoes(tmp_path):
    from core.skeleton import BONE_LENGTHS, BONES, JOINT_INDEX, positions_from_pose
    from sgt_tui.editor.posing import STEP, PoseSession, screen_axes

    s = PoseSession()
    wrist = positions_from_pose(s.current.pose)[JOINT_INDEX["right_wrist"]]
    assert s.move(0, 3, 0)
    moved = positions_from_pose(s.current.pose)
    assert np.allclose(moved[JOINT_INDEX["right_wrist"]], wrist + 3 * STEP * screen_axes()[1], atol=1e-12)  # up on the screen
    for p, c in BONES:
        assert abs(np.linalg.norm(moved[JOINT_INDEX[c]] - moved[JOINT_INDEX[p]]) - BONE_LENGTHS[c]) < 1e-6
    for _ in range(200):  # far past the arm's reach: it stops there
        s.move(1, 0, 0)
    x = positions_from_pose(s.current.pose)
    assert np.linalg.norm(x[JOINT_INDEX["right_wrist"]] - x[JOINT_INDEX["right_shoulder"]]) <= ik.reach("right")[1] + 1e-12
    stretched = s.current.pose.copy()
    assert s.undo() and not np.array_equal(s.current.pose, stretched) and s.redo() and np.array_equal(s.current.pose, stretched)
    s.select(4)  # the head
    for _ in range(40):
        s.move(1, 0, 0)
    assert ik.head_angles(s.current.pose)[0] == pytest.approx(ik.HEAD_LIMITS["yaw"][1])
    assert s.add_key() and len(s.draft.keys) == 4 and s.key == 2 and s.current.label == "hold"
    assert s.mirror() and s.draft.driven() == ("head", "left_arm")
    s.rename("mine")
    first = s.save(tmp_path)
    s.move(0, 1, 0)
    first.path.write_text(first.path.read_text() + "# by hand\n")
    with pytest.raises(FileChanged):
        s.save(tmp_path, replace=True)
