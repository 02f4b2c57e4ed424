"""The pose editor of `sgt view` (docs/view.md, "Pose it yourself"), in Debian's headless Chromium driven
over the DevTools protocol with real mouse and key events (tests/test_view_browser.py's Browser), against
the real command in its own process:

- a new gesture of three keyframes is posed (a wrist pressed, moved and released; undo and redo; a hand
  shape picked; a label typed), saved, put at a word of the script, and the take the page loads again
  shows it: the file read back by `sgt library show` is the keyframes saved, exactly; the stroke frame of
  the take has the posed arm's directions within 1 degree, at the skeleton's bone lengths; `sgt check`
  and `sgt fmt --check` pass on the edited script;
- the hostile side, with curl against the same server: a write without the edit token, from another
  Origin, into a folder that is not one of the script's gesture folders, or over a file that changed
  since the page read it, writes nothing.

Set SGT_VIEW_SCREENSHOTS=FOLDER to keep the screenshots (docs/view-pose.png comes from it).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
from test_view_browser import CHROMIUM, SHOTS, Browser, View

from core.skeleton import BONE_LENGTHS, BONES, JOINT_INDEX
from library.posing import rest_pose
from sgt_tui.view.page import DECIMALS

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = "@library gestures\n@seed 4\n\nguide: Look at the shelf over there, by the lifts.\n"
NAME = "reach_up"


def sgt(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sgt_tui", *args], check=False, cwd=cwd or ROOT, capture_output=True, text=True, timeout=180)


def _folder(tmp_path_factory, name: str) -> Path:
    folder = tmp_path_factory.mktemp(name)
    (folder / "gestures").mkdir()
    (folder / "talk.sgt").write_text(SCRIPT)
    return folder


def _directions(positions: np.ndarray) -> dict[str, np.ndarray]:
    """Each bone's unit direction, by its child joint's name, from joints (10, 3)."""
    return {c: (positions[JOINT_INDEX[c]] - positions[JOINT_INDEX[p]]) / np.linalg.norm(positions[JOINT_INDEX[c]] - positions[JOINT_INDEX[p]])
            for p, c in BONES}


def _angle(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b / np.linalg.norm(a) / np.linalg.norm(b))))))


# -- the browser ------------------------------------------------------------------------------------------------


@pytest.fixture()
def browser():
    if CHROMIUM is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium)")
    b = Browser(1100, 760)
    yield b
    b.close()


def drag(browser: Browser, start, end, steps: int = 12) -> None:
    """A real left-button drag on the page: press at ``start``, move in ``steps`` to ``end``, release."""
    (x0, y0), (x1, y1) = start, end
    browser.cmd("Input.dispatchMouseEvent", type="mouseMoved", x=x0, y=y0)
    browser.cmd("Input.dispatchMouseEvent", type="mousePressed", x=x0, y=y0, button="left", buttons=1, clickCount=1)
    for i in range(1, steps + 1):
        x, y = x0 + (x1 - x0) * i / steps, y0 + (y1 - y0) * i / steps
        browser.cmd("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y, button="left", buttons=1)
    browser.cmd("Input.dispatchMouseEvent", type="mouseReleased", x=x1, y=y1, button="left", buttons=0, clickCount=1)


def handle(browser: Browser, name: str) -> tuple[float, float]:
    """Where the pose editor's handle ``name`` is, in the page's CSS pixels."""
    x, y = browser.js(f"sgtView.pose.onCanvas({json.dumps(name)})")
    left, top = browser.js("(() => { const r = document.getElementById('scene').getBoundingClientRect(); return [r.x, r.y]; })()")
    return left + x, top + y


def pose_state(browser: Browser) -> dict:
    return browser.js("sgtView.pose.state()")


def type_into(browser: Browser, selector: str, text: str) -> None:
    """A click in the text field, ctrl+a, the text typed, Enter."""
    browser.click(selector)
    browser.cmd("Input.dispatchKeyEvent", type="keyDown", key="a", code="KeyA", windowsVirtualKeyCode=65, modifiers=2,
                commands=["selectAll"])  # what ctrl+a does in a text field (headless Chromium has no key bindings)
    browser.cmd("Input.dispatchKeyEvent", type="keyUp", key="a", code="KeyA", windowsVirtualKeyCode=65, modifiers=2)
    browser.cmd("Input.insertText", text=text)
    browser.cmd("Input.dispatchKeyEvent", type="keyDown", key="Enter", code="Enter", windowsVirtualKeyCode=13, text="\r")
    browser.cmd("Input.dispatchKeyEvent", type="keyUp", key="Enter", code="Enter", windowsVirtualKeyCode=13)


def shot(browser: Browser, name: str) -> None:
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        browser.screenshot(Path(SHOTS) / name)


def test_a_gesture_posed_in_the_page_is_saved_put_at_a_word_and_played_in_the_take(tmp_path_factory, browser):
    folder = _folder(tmp_path_factory, "pose")
    script = folder / "talk.sgt"
    view = View(str(script))
    try:
        browser.open(view.address)
        browser.key("p", "KeyP", 80)  # the pose editor
        browser.wait("sgtView.pose.state().active && sgtView.pose.state().handsReady", 30, "the pose editor")
        browser.key("1", "Digit1", 49)  # the front camera
        time.sleep(0.3)
        st = pose_state(browser)
        assert [k["label"] for k in st["gesture"]["keyframes"]] == ["start", "stroke", "retract"] and st["key"] == 1
        assert browser.js("document.getElementById('pose-word').selectedIndex") == 0  # "choose a word", none chosen yet
        type_into(browser, "#pose-name", NAME)
        browser.wait(f"sgtView.pose.state().gesture.name === '{NAME}'", 10, "the name typed")

        # the stroke: the right wrist pressed, moved up and out, released
        wrist = handle(browser, "right_wrist")
        drag(browser, wrist, (wrist[0] - 70, wrist[1] - 170))
        st = pose_state(browser)
        stroke_pose = st["gesture"]["keyframes"][1]["pose"]
        assert st["driven"] == ["right_arm"], st
        moved = np.asarray(st["joints"][JOINT_INDEX["right_wrist"]])
        assert moved[1] > 1.2, f"the wrist did not go up: {moved}"
        browser.cmd("Input.dispatchKeyEvent", type="keyDown", key="z", code="KeyZ", windowsVirtualKeyCode=90, modifiers=2)
        browser.cmd("Input.dispatchKeyEvent", type="keyUp", key="z", code="KeyZ", windowsVirtualKeyCode=90, modifiers=2)
        assert pose_state(browser)["gesture"]["keyframes"][1]["pose"] != stroke_pose  # undone
        browser.cmd("Input.dispatchKeyEvent", type="keyDown", key="Z", code="KeyZ", windowsVirtualKeyCode=90, modifiers=2 | 8)
        browser.cmd("Input.dispatchKeyEvent", type="keyUp", key="Z", code="KeyZ", windowsVirtualKeyCode=90, modifiers=2 | 8)
        assert pose_state(browser)["gesture"]["keyframes"][1]["pose"] == stroke_pose  # redone
        # the elbow out a little (its own handle: the wrist stays)
        elbow = handle(browser, "right_elbow")
        drag(browser, elbow, (elbow[0] - 25, elbow[1] + 5), steps=6)
        st = pose_state(browser)
        assert np.allclose(st["joints"][JOINT_INDEX["right_wrist"]], moved, atol=1e-9)
        # the right hand: its shape picked with the keys
        browser.js("document.getElementById('pose-right-hand').focus()")
        before = pose_state(browser)["gesture"]["keyframes"][1]["hands"]["right_hand"]
        browser.key("ArrowDown", "ArrowDown", 40)
        browser.wait(f"sgtView.pose.state().gesture.keyframes[1].hands.right_hand !== '{before}'", 10, "the hand shape picked")
        browser.js("document.activeElement.blur()")

        # the first keyframe: the preparation, half way up
        browser.key(",", "Comma", 188)
        browser.wait("sgtView.pose.state().key === 0", 5, "the first keyframe")
        type_into(browser, "#pose-label", "prepare")
        browser.js("document.activeElement.blur()")
        wrist = handle(browser, "right_wrist")
        drag(browser, wrist, (wrist[0] - 30, wrist[1] - 70))
        browser.wait("sgtView.pose.state().handsReady", 10)

        posed = pose_state(browser)["gesture"]
        assert [k["label"] for k in posed["keyframes"]] == ["prepare", "stroke", "retract"]
        assert [k["stroke"] for k in posed["keyframes"]] == [False, True, False]
        browser.click("#pose-save")
        browser.wait("sgtView.pose.state().saved", 30, "the gesture saved")
        saved = pose_state(browser)
        path = folder / "gestures" / f"{NAME}.toml"
        assert path.is_file() and saved["saved"]["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
        assert not list((folder / "gestures").glob(".*")), "a temporary file was left"
        browser.key(".", "Period", 190)  # the stroke again, its TOML shown
        browser.wait("sgtView.pose.state().key === 1 && sgtView.pose.state().handsReady", 10, "the stroke keyframe")
        browser.click("#pose-text summary")
        time.sleep(0.3)
        shot(browser, "view-pose.png")

        # sgt library show reads back the keyframes saved, exactly, and they are the ones posed (to the last digits)
        shown = sgt("library", "show", NAME, "--dir", str(folder / "gestures"), "--json")
        assert shown.returncode == 0, shown.stderr
        shown = json.loads(shown.stdout)
        spec = tomllib.loads(path.read_text())
        assert [k["time"] for k in shown["keyframes"]] == [k["time"] for k in spec["keyframes"]] == [0.0, 0.5, 1.2]
        assert [k["stroke"] for k in shown["keyframes"]] == [False, True, False]
        assert shown["drives"] == ["right_arm"]
        held = {}
        for k_shown, k_file, k_saved, k_posed in zip(shown["keyframes"], spec["keyframes"], saved["gesture"]["keyframes"],
                                                     posed["keyframes"]):
            assert k_shown["label"] == k_file.get("label") == k_posed["label"]
            for bone in ("right_elbow", "right_wrist"):
                if bone in k_file:
                    assert k_shown["bones"][bone] == k_file[bone]  # the same numbers, every digit
                    held[bone] = k_file[bone]
                i = 3 * [c for _, c in BONES].index(bone)
                value = held.get(bone, "rest")
                got = k_saved["pose"][i:i + 3]
                assert value == "rest" and got == k_posed["pose"][i:i + 3] or value == got  # the page's is the file's
                assert np.abs(np.asarray(got) - k_posed["pose"][i:i + 3]).max() < 1e-12  # and the posed one
            for hand in ("right_hand", "right_palm"):
                assert k_shown["hands"].get(hand) == k_file.get(hand)
        assert spec["keyframes"][1]["right_hand"] == saved["gesture"]["keyframes"][1]["hands"]["right_hand"] != "relaxed"

        # Use at this word: [pose:reach_up] before "shelf"; the page loads the take again
        take_id = browser.state()["takeId"]
        shelf = browser.js("Array.from(document.querySelectorAll('.tl-word')).find((e) => e.textContent === 'shelf').dataset.word")
        browser.click(f".tl-word[data-word='{shelf}']")
        browser.wait("sgtView.pose.state().word && sgtView.pose.state().word.word === 'shelf'", 10, "the word chosen")
        browser.click("#pose-use")
        # the take the page shows (its id) is the server's with the gesture in it
        browser.wait(f"fetch('api/take?take=0').then((r) => r.json()).then((d) => d.id === sgtView.state().takeId && "
                     f"d.controls.some((c) => c.name === '{NAME}'))", 120, "the take loaded again with the gesture")
        assert browser.state()["takeId"] != take_id
        assert script.read_text() == SCRIPT.replace("the shelf", f"the [pose:{NAME}] shelf")
        doc = browser.js("fetch('api/take?take=0').then((r) => r.json())")
        control = next(c for c in doc["controls"] if c["name"] == NAME)
        frame = control["stroke_frame"]
        positions = np.asarray(doc["speakers"][0]["positions"]).reshape(-1, 10, 3)[frame]
        dirs = _directions(positions)
        stroke = np.asarray(saved["gesture"]["keyframes"][1]["pose"]).reshape(9, 3)
        names = [c for _, c in BONES]
        errors = {b: _angle(dirs[b], stroke[names.index(b)]) for b in ("right_elbow", "right_wrist")}
        assert max(errors.values()) < 1.0, errors
        lengths = {c: float(np.linalg.norm(positions[JOINT_INDEX[c]] - positions[JOINT_INDEX[p]])) for p, c in BONES}
        rounding = math.sqrt(3) * 10.0 ** -DECIMALS  # the page's joints are rounded to DECIMALS: both ends of a bone
        for bone, length in lengths.items():
            assert abs(length - BONE_LENGTHS[bone]) <= rounding, (bone, length, BONE_LENGTHS[bone])
        browser.key("p", "KeyP", 80)  # back to the take
        browser.js(f"sgtView.seek({frame / doc['fps']})")
        time.sleep(0.5)
        shot(browser, "view-pose-take.png")

        checked = sgt("check", str(script))
        assert checked.returncode == 0, checked.stdout + checked.stderr
        formatted = sgt("fmt", "--check", str(script))
        assert formatted.returncode == 0, formatted.stdout + formatted.stderr
    finally:
        view.stop()
    assert view.proc.returncode == 0


# -- the hostile side -----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    folder = _folder(tmp_path_factory, "pose-hostile")
    (folder / "outside").mkdir()
    view = View(str(folder / "talk.sgt"))
    view.folder = folder
    view.token = re.search(r"#edit=([^&\s]+)", view.address).group(1)
    yield view
    view.stop()


def _gesture(name: str = "mine") -> dict:
    rest = [float(x) for x in rest_pose()]
    up = list(rest)
    up[21:27] = [-0.6, 0.8, 0.0, 0.0, 1.0, 0.0]  # the right arm up
    keys = [{"time": 0.0, "label": "start", "stroke": False, "pose": rest, "hands": _hands()},
            {"time": 0.5, "label": "stroke", "stroke": True, "pose": up, "hands": _hands()},
            {"time": 1.0, "label": "retract", "stroke": False, "pose": rest, "hands": _hands()}]
    return {"name": name, "duration": 1.0, "keyframes": keys}


def _hands() -> dict:
    return {"left_hand": "relaxed", "left_palm": "in", "right_hand": "relaxed", "right_palm": "in"}


def post(view, path: str, body: dict, *, token: str | None = "ok", origin: str | None = None) -> tuple[int, dict]:
    """``curl`` POST to sgt view's pose route ``path`` as the page would (the token, its Origin), or not."""
    args = ["curl", "-sS", "-o", "-", "-w", "\n%{http_code}", "-X", "POST", "-H", "Content-Type: application/json",
            "--data-binary", json.dumps(body)]
    if token:
        args += ["-H", f"X-SGT-Edit: {view.token if token == 'ok' else token}"]
    args += ["-H", f"Origin: {origin or view.url.rstrip('/')}"]
    out = subprocess.run([*args, f"{view.url}api/pose/{path}"], check=False, capture_output=True, text=True, timeout=60).stdout
    text, _, status = out.rpartition("\n")
    return int(status), json.loads(text)


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _script_sha(view) -> str:
    return hashlib.sha256((view.folder / "talk.sgt").read_bytes()).hexdigest()


def _gestures_folder(view) -> str:
    out = subprocess.run(["curl", "-sS", f"{view.url}api/pose/info"], check=False, capture_output=True, text=True, timeout=60).stdout
    info = json.loads(out)
    (only,) = info["folders"]
    return only["path"]


def test_a_write_without_the_edit_token_writes_nothing(hostile):
    before = _files(hostile.folder)
    for token in (None, "not-the-token"):
        status, body = post(hostile, "save", {"gesture": _gesture(), "folder": _gestures_folder(hostile)}, token=token)
        assert status == 403 and "edit token" in body["error"], body
        status, body = post(hostile, "use", {"name": "wave", "utterance": 0, "word": 1, "sha256": _script_sha(hostile)}, token=token)
        assert status == 403, body
    assert _files(hostile.folder) == before


def test_a_write_from_another_origin_writes_nothing(hostile):
    before = _files(hostile.folder)
    for origin in ("http://attacker.example", "null"):
        status, body = post(hostile, "save", {"gesture": _gesture(), "folder": _gestures_folder(hostile)}, origin=origin)
        assert status == 403, body
        status, body = post(hostile, "use", {"name": "wave", "utterance": 0, "word": 1, "sha256": _script_sha(hostile)}, origin=origin)
        assert status == 403, body
    assert _files(hostile.folder) == before


@pytest.mark.parametrize("where", [
    {"folder": "OUTSIDE"}, {"folder": "ELSEWHERE"}, {"folder": "GESTURES/.."}, {"new_folder": "../escaped"},
    {"new_folder": "/tmp/escaped"}, {"new_folder": ".."}, {"new_folder": "LINK"}, {}])
def test_a_gesture_outside_the_scripts_gesture_folders_is_not_written(hostile, where):
    folder = hostile.folder
    link = folder / "LINK"
    if not link.exists():
        link.symlink_to(folder / "outside")  # a folder beside the script that is a link elsewhere
    before = _files(folder)
    gestures = _gestures_folder(hostile)
    body = {"gesture": _gesture(), "script_sha256": _script_sha(hostile)}
    elsewhere = folder.parent / "elsewhere"  # a folder outside the script's
    elsewhere.mkdir(exist_ok=True)
    body.update({k: v.replace("OUTSIDE", str(folder / "outside")).replace("ELSEWHERE", str(elsewhere)).replace("GESTURES", gestures)
                 for k, v in where.items()})
    status, answer = post(hostile, "save", body)
    assert status == 403, answer
    assert "nothing was written" in answer["error"] or "folder" in answer["error"], answer
    assert "\n" not in answer["error"]
    assert _files(folder) == before
    assert not (folder.parent / "escaped").exists() and not Path("/tmp/escaped").exists() and not list(elsewhere.iterdir())


def test_a_file_changed_since_the_page_read_it_is_not_written_over(hostile):
    folder = hostile.folder
    gestures = _gestures_folder(hostile)
    # a gesture saved, then changed on disk by someone else: the page's replacement (with the SHA-256 it read) is refused
    status, first = post(hostile, "save", {"gesture": _gesture("changing"), "folder": gestures})
    assert status == 200, first
    target = folder / "gestures" / "changing.toml"
    target.write_text(target.read_text() + "# tuned by hand\n")
    edited = target.read_bytes()
    status, answer = post(hostile, "save", {"gesture": _gesture("changing"), "folder": gestures, "replace": True, "sha256": first["sha256"]})
    assert status == 409 and answer.get("changed") and "changed on disk" in answer["error"], answer
    assert target.read_bytes() == edited
    # without replace, an existing gesture is refused too
    status, answer = post(hostile, "save", {"gesture": _gesture("changing"), "folder": gestures})
    assert status == 409 and answer.get("exists"), answer
    assert target.read_bytes() == edited
    # the script changed since the page read it: no mark, no new folder
    script = folder / "talk.sgt"
    old_sha = _script_sha(hostile)
    script.write_text(SCRIPT.replace("the lifts", "the stairs"))
    now = script.read_bytes()
    before = _files(folder)
    status, answer = post(hostile, "use", {"name": "wave", "utterance": 0, "word": 3, "sha256": old_sha})
    assert status == 409 and answer.get("changed") and "changed on disk" in answer["error"], answer
    status, answer = post(hostile, "save", {"gesture": _gesture("other"), "new_folder": "more", "script_sha256": old_sha})
    assert status == 409 and answer.get("changed"), answer
    assert _files(folder) == before and script.read_bytes() == now
