"""The face's close-up in `sgt view`, in a real browser (the harness of tests/test_view_browser.py:
Debian's headless Chromium over the DevTools protocol, the real `sgt view` in its own process):
the "face" button puts the camera on the first speaker's head, as `sgt render --view face` does
(the page's picture and sgt's render of the frame have the same silhouette), the camera follows
the head as the take plays, and the button pressed again shows the next speaker's face.

Skipped, saying why, without Chromium. SGT_VIEW_SCREENSHOTS=FOLDER keeps the screenshots
(view_face_close.png: the page's close-up beside sgt's render of it).
"""

from __future__ import annotations

import json
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from test_view_browser import CHROMIUM, SHOTS, Browser, View, _page_face, overlap, silhouette

from renders.mannequin import FaceFrames, Mannequin
from sgt_tui.cli import main

pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium is not installed (apt-get install chromium)")

SCRIPT = ("@seed 3\nguide: <face:angry>I am not pleased about this at all.</face>\n"
          "visitor: <face:afraid>Oh no, what was that noise behind the shelf?</face>\n")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("face_view")
    (folder / "two.sgt").write_text(SCRIPT)
    assert main(["generate", str(folder / "two.sgt"), "-o", str(folder / "take.json")]) == 0
    view = View(str(folder / "take.json"))
    yield view
    view.stop()


@pytest.fixture(scope="module")
def browser():
    b = Browser()
    yield b
    b.close()


def _sgt_close_up(url: str, speaker: int, frame: int, side: int) -> np.ndarray:
    """sgt's own render (renders.mannequin, view "face") of ``speaker`` at ``frame`` of the page's take."""
    with urllib.request.urlopen(url + "api/take") as r:
        s = json.load(r)["speakers"][speaker]
    positions = np.reshape(s["positions"], (-1, 10, 3))
    hands = np.reshape(s["hands"], (-1, 2, 20, 3))
    face = _page_face(s["face"], len(positions))
    with Mannequin(side, side) as m:
        return m.render(positions[frame], hands[frame], view="face", tint=s["tint"], face=FaceFrames(face)[frame])


def test_the_face_button_shows_each_speakers_face_close_as_sgt_renders_it(server, browser):
    browser.open(server.url)
    browser.js("document.getElementById('caption').style.visibility = 'hidden'")
    # A frame in the middle of the visitor's line, so that both faces have an expression on.
    duration = browser.state()["duration"]
    browser.js(f"sgtView.seek({0.8 * duration})")
    browser.wait("sgtView.state().time > 0", 10)
    shots = []
    for speaker in (0, 1):
        browser.click('#views button[data-view="face"]')
        browser.wait(f"sgtView.state().view === 'face' && sgtView.state().faceOf === {speaker}", 10,
                     f"the face view of speaker {speaker}")
        browser.js("document.getElementById('views').style.visibility = 'hidden'")
        time.sleep(0.3)
        page = browser.canvas(square=True)
        browser.js("document.getElementById('views').style.visibility = ''")
        frame = browser.state()["frame"]
        ours = _sgt_close_up(server.url, speaker, frame, page.shape[0])
        other = _sgt_close_up(server.url, 1 - speaker, frame, page.shape[0])
        match = overlap(silhouette(page), silhouette(ours))
        shots.append(np.concatenate([page, ours], axis=1))
        # The head fills the picture: what is not background is most of it (a body view: under a tenth).
        assert silhouette(page).mean() > 0.35, f"speaker {speaker}: the close-up shows no head"
        assert match > 0.95, f"speaker {speaker}: the page's close-up overlaps sgt's render of frame {frame} by {match:.3f}"
        # It is this speaker's face: the other's face differs where it shows its expression.
        assert np.abs(page.astype(int) - other.astype(int)).mean() > np.abs(page.astype(int) - ours.astype(int)).mean()
    if SHOTS:
        from PIL import Image

        Image.fromarray(np.concatenate(shots, axis=0)).save(Path(SHOTS) / "view_face_close.png")
    # The camera follows the head as the take plays: the head stays in the middle of the view.
    browser.key(" ", "Space", 32)
    browser.wait("sgtView.state().time > 0.5", 10, "the take to play")
    time.sleep(0.5)
    browser.key(" ", "Space", 32)
    width, height = browser.js("(() => { const r = document.getElementById('scene').getBoundingClientRect(); "
                               "return [r.width, r.height]; })()")
    x, y = browser.js("sgtView.onCanvas(1, 'head')")
    assert abs(x - width / 2) < 2 and abs(y - height / 2) < 2, (x, y, width, height)
