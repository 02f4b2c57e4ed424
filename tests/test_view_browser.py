"""sgt view in a real browser: Debian's headless Chromium, driven over the DevTools protocol
(a WebSocket; the `websockets` package sgt already needs), opens the page that `sgt view`
serves (the real command, in its own process) and checks, with real mouse and key events:

- the page loads with nothing from outside this machine, draws its model (WebGL) and plays:
  the pose changes between two screenshots;
- a click on a pose control in the timeline goes to its stroke, and the screenshot of that
  frame, from sgt's front and side cameras, has the silhouette of sgt's own render of it
  (renders.mannequin);
- the mannequin's face moves as sgt's does (renders.face_rig): its parts where sgt puts them, a
  mouth that opens and shuts and eyes that blink on the screen;
- the speech and the motion share one clock: the time the page drew against the audio
  element's, at speed 1 and 2, and after a click on a word;
- saving the script reloads the page's take (and a broken save shows its errors and keeps it);
- a VRM character chosen in the page plays the take's VRM Animation: its forearm points where
  sgt's does at a stroke, and its expressions take the weights of the animation's.

Skipped, saying why, without Chromium (`apt-get install chromium`). Set
SGT_VIEW_SCREENSHOTS=FOLDER to keep the pages' screenshots there (docs/view.png comes from it).
"""

from __future__ import annotations

import base64
import contextlib
import io
import json
import os
import queue
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from core.face import ARKIT_INDEX, N_BLENDSHAPES, FaceTrack
from core.hands import hand_positions
from core.motion import load_motion_file
from core.skeleton import FPS
from renders import face_rig
from renders.clips import track_clip
from renders.face_export import vrm_expressions
from renders.gltf import glb_bytes
from renders.mannequin import BACKGROUND, FaceFrames, Mannequin
from renders.rigs import get_rig
from sgt_tui.cli import main

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium is not installed (apt-get install chromium)")

ROOT = Path(__file__).resolve().parent.parent
DIALOGUE = ("@seed 3\nguide: Look at the shelf [pose:point_right] over there, by the lifts.\n@gap -600ms\n"
            "visitor: Thanks, [pose:nod] I see it [pose:point_left] now.\n")
SCRIPT = ("@seed 5\nguide: Hello and welcome! [pose:open_arms] Look at the shelf [pose:point_right] over there.\n"
          "guide: It has everything you need for the garden, and the lifts are right behind you.\n")
WIDTH, HEIGHT = 800, 640
SHOTS = os.environ.get("SGT_VIEW_SCREENSHOTS")


class Browser:
    """Headless Chromium and one page, over the DevTools protocol."""

    def __init__(self, width: int = WIDTH, height: int = HEIGHT) -> None:
        from websockets.sync.client import connect

        self.profile = tempfile.mkdtemp(prefix="sgt-chromium-")
        self.proc = subprocess.Popen(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={self.profile}", "--remote-debugging-port=0",
             "--autoplay-policy=no-user-gesture-required", f"--window-size={width},{height}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        port_file = Path(self.profile) / "DevToolsActivePort"
        deadline = time.monotonic() + 30
        while not (port_file.is_file() and port_file.read_text().strip()):
            if time.monotonic() > deadline or self.proc.poll() is not None:
                self.close()
                pytest.fail("Chromium did not start")
            time.sleep(0.05)
        port = port_file.read_text().split()[0]
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json", timeout=10) as r:
            page = next(t for t in json.load(r) if t["type"] == "page")
        self.stack = contextlib.ExitStack()
        self.ws = self.stack.enter_context(connect(page["webSocketDebuggerUrl"], max_size=None, open_timeout=10))
        self.n = 0
        self.events: list[dict] = []
        for domain in ("Page", "Network", "Runtime"):
            self.cmd(f"{domain}.enable")
        self.cmd("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1, mobile=False)

    def cmd(self, method: str, **params):
        self.n += 1
        self.ws.send(json.dumps({"id": self.n, "method": method, "params": params}))
        while True:
            message = json.loads(self.ws.recv(timeout=60))
            if message.get("id") == self.n:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message["result"]
            self.events.append(message)

    def js(self, expression: str):
        r = self.cmd("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails']}")
        return r["result"].get("value")

    def wait(self, expression: str, timeout: float = 30.0, what: str = ""):
        deadline = time.monotonic() + timeout
        while True:
            value = self.js(expression)
            if value:
                return value
            if time.monotonic() > deadline:
                raise AssertionError(f"waited {timeout:g} s for {what or expression}; the page says {self.state()}")
            time.sleep(0.1)

    def open(self, url: str) -> None:
        self.events.clear()
        self.cmd("Page.navigate", url=url)
        self.wait("window.sgtView && sgtView.ready", 45, "the page to load its take")

    def state(self) -> dict:
        return self.js("window.sgtView ? sgtView.state() : null")

    def click(self, selector: str) -> None:
        """A real left click in the middle of the element (scrolled into view)."""
        x, y = self.js(f"(() => {{ const e = document.querySelector({json.dumps(selector)}); e.scrollIntoView({{block: 'nearest', "
                       "inline: 'center'}); const r = e.getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; })()")
        for kind in ("mousePressed", "mouseReleased"):
            self.cmd("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1)

    def key(self, key: str, code: str, keycode: int) -> None:
        self.cmd("Input.dispatchKeyEvent", type="keyDown", key=key, code=code, windowsVirtualKeyCode=keycode,
                 text=key if len(key) == 1 else "")
        self.cmd("Input.dispatchKeyEvent", type="keyUp", key=key, code=code, windowsVirtualKeyCode=keycode)

    def canvas(self, square: bool = False) -> np.ndarray:
        """A screenshot of the 3D view (its middle square: what a square render of sgt's camera sees)."""
        x, y, w, h = self.js("(() => { const r = document.getElementById('scene').getBoundingClientRect(); "
                             "return [r.x, r.y, r.width, r.height]; })()")
        if square:
            x, w = x + (w - h) / 2, h
        shot = self.cmd("Page.captureScreenshot", format="png",
                        clip={"x": x, "y": y, "width": int(w), "height": int(h), "scale": 1})
        from PIL import Image

        return np.asarray(Image.open(io.BytesIO(base64.b64decode(shot["data"]))).convert("RGB"))

    def screenshot(self, path: Path) -> None:
        path.write_bytes(base64.b64decode(self.cmd("Page.captureScreenshot", format="png")["data"]))

    def requests(self) -> list[str]:
        return [e["params"]["request"]["url"] for e in self.events if e.get("method") == "Network.requestWillBeSent"]

    def close(self) -> None:
        try:
            if getattr(self, "stack", None) is not None:
                self.stack.close()
        finally:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
            shutil.rmtree(self.profile, ignore_errors=True)


class View:
    """`sgt view ARGS` in its own process; ``url`` is the address it printed without its fragment, ``address`` with it
    (the run's edit token: `#edit=...`)."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "sgt_tui", "view", *args], cwd=ROOT, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, text=True)
        self.lines: queue.Queue = queue.Queue()  # what it prints
        self.reader = threading.Thread(target=lambda: [self.lines.put(line) for line in self.proc.stderr], daemon=True)
        self.reader.start()
        said = []
        deadline = time.monotonic() + 90
        while True:
            try:
                line = self.lines.get(timeout=max(0.1, deadline - time.monotonic()))
            except queue.Empty:
                self.stop()
                pytest.fail(f"sgt view printed no address: {''.join(said)}")
            said.append(line)
            if line.startswith("sgt view: http://"):
                self.address = line.split()[2]  # with the run's edit token (#edit=...): the page may write
                self.url = self.address.split("#")[0]
                return

    def stop(self) -> str:
        """Ctrl+c; what it printed after its address."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)  # as ctrl+c
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.reader.join(10)
        return "".join(self.lines.get() for _ in range(self.lines.qsize()))


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("view")
    (folder / "guide.sgt").write_text(SCRIPT)
    assert main(["generate", str(folder / "guide.sgt"), "-o", str(folder / "take.json")]) == 0
    return folder


@pytest.fixture(scope="module")
def take(folder):
    """The take as sgt has it: the track's clip (controls on the performance clock) and its hand joints."""
    motion = load_motion_file(folder / "take.json")
    clip = track_clip(motion.tracks[0], motion.clips)
    return clip, hand_positions(clip.positions, clip.hands)


@pytest.fixture(scope="module")
def server(folder):
    view = View(str(folder / "take.json"))
    yield view
    view.stop()
    assert view.proc.returncode == 0  # ctrl+c is a clean stop


@pytest.fixture(scope="module")
def browser():
    b = Browser()
    yield b
    b.close()


def silhouette(image: np.ndarray) -> np.ndarray:
    return np.abs(image.astype(int) - np.array(BACKGROUND)).sum(axis=-1) > 40


def overlap(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max(1, (a | b).sum()))


def test_the_page_loads_offline_and_the_animation_plays(server, browser):
    browser.open(server.url)
    origin = server.url.rstrip("/")
    elsewhere = [u for u in browser.requests() if not u.startswith((origin + "/", "blob:", "data:"))]
    assert not elsewhere, f"the page asked for something outside sgt view: {elsewhere}"
    problems = [e for e in browser.events if e.get("method") == "Runtime.exceptionThrown"]
    assert not problems, problems[0]["params"]["exceptionDetails"]
    assert browser.state()["problem"] == ""
    still = browser.canvas()
    assert silhouette(still).mean() > 0.02, "no model on the page"
    browser.key(" ", "Space", 32)
    browser.wait("sgtView.state().time > 0.3", 10, "the animation to play")
    first, a = browser.canvas(), browser.state()
    time.sleep(0.8)
    second, b = browser.canvas(), browser.state()
    assert a["playing"] and b["playing"] and b["frame"] >= a["frame"] + 5, (a, b)
    changed = (np.abs(first.astype(int) - second.astype(int)).sum(axis=-1) > 60).mean()
    assert changed > 0.004, f"the pose did not change between frames {a['frame']} and {b['frame']} ({changed:.4f} of the pixels)"
    browser.key(" ", "Space", 32)
    assert not browser.state()["playing"]


def test_a_click_on_a_pose_control_shows_its_stroke_as_sgt_renders_it(server, browser, take):
    clip, hands = take
    point = next(c for c in clip.controls if c.name == "point_right")
    browser.open(server.url)
    side = None
    for view, press in (("front", lambda: browser.click('#views button[data-view="front"]')),
                        ("side", lambda: browser.key("2", "Digit2", 50))):
        press()
        browser.click('.tl-pose[data-name="point_right"]')
        browser.js("document.querySelectorAll('#caption, #views').forEach((e) => { e.style.visibility = 'hidden'; })")
        browser.wait(f"sgtView.state().frame === {point.stroke_frame} && sgtView.state().view === '{view}'", 10,
                     f"the stroke of point_right (frame {point.stroke_frame}) from the {view}")
        time.sleep(0.3)
        page = browser.canvas(square=True)
        side = side or page.shape[0]
        with Mannequin(side, side) as m:
            ours = m.render(clip.positions[point.stroke_frame], hands[point.stroke_frame], view=view,
                            face=FaceFrames(clip.face)[point.stroke_frame])
            rest = m.render(clip.positions[0], hands[0], view=view)
        match = overlap(silhouette(page), silhouette(ours))
        other = overlap(silhouette(page), silhouette(rest))
        if SHOTS:
            from PIL import Image

            Image.fromarray(np.concatenate([page, ours], axis=1)).save(Path(SHOTS) / f"view_stroke_{view}.png")
        browser.js("document.querySelectorAll('#caption, #views').forEach((e) => { e.style.visibility = ''; })")
        assert match > 0.95 and match > other + 0.1, \
            f"{view}: the page's stroke overlaps sgt's render of frame {point.stroke_frame} by {match:.3f} (frame 0: {other:.3f})"


def _dark(image: np.ndarray, at, r: int) -> int:
    """The dark pixels of ``image`` within ``r`` of ``at`` (x, y)."""
    x, y = np.round(at).astype(int)
    return int((image[y - r:y + r + 1, x - r:x + r + 1].astype(int).sum(-1) < 240).sum())


def test_the_mannequins_face_moves_as_sgt_draws_it(server, browser, take):
    clip, _ = take
    face = clip.face
    maps = face_rig.part_transforms(face.weights, face.gaze, face_rig.GAZE_GAIN)
    mouth = maps[:, face_rig.PART_INDEX["mouth"], 1, 1]  # the opening's half height
    blink = np.minimum(face.weight("eyeBlinkLeft"), face.weight("eyeBlinkRight"))
    shut = int(np.argmax(blink))
    awake = min(np.flatnonzero(blink == 0), key=lambda f: abs(f - shut))  # the eyes open, near it
    frames = {"jaw open": int(np.argmax(mouth)), "lips closed": int(np.argmin(mouth)), "blink": shut, "eyes open": int(awake)}
    assert mouth[frames["jaw open"]] > 0.01 and blink[shut] > 0.9, "the take has no open mouth or no blink to show"
    browser.open(server.url)
    browser.js("sgtView.setView('front'); document.querySelectorAll('#caption, #views').forEach((e) => { e.style.visibility = 'hidden'; })")
    seen = {}
    for what, f in frames.items():
        browser.js(f"sgtView.seek({f} / {FPS})")
        browser.wait(f"sgtView.state().frame === {f}", 10, f"frame {f}")
        time.sleep(0.2)
        drawn = browser.js("sgtView.face(0)")
        for k, (name, *_) in enumerate(face_rig.PARTS):  # where sgt puts each part, in the head's frame
            assert np.allclose(drawn[name], maps[f, k], atol=1e-5), f"frame {f}: the page's {name} is not sgt's"
        image = browser.canvas()
        # dark pixels: the inside of an open mouth, a pupil in an open eye (lips and lids are lighter)
        seen[what] = {"mouth": _dark(image, browser.js("sgtView.onCanvas(0, 'mouth')"), 3),
                      "eyes": [_dark(image, browser.js(f"sgtView.onCanvas(0, '{e}')"), 4) for e in ("pupil_l", "pupil_r")]}
        if SHOTS:
            from PIL import Image

            x, y = np.round(browser.js("sgtView.onCanvas(0, 'head')")).astype(int)
            Image.fromarray(image[y - 60:y + 60, x - 60:x + 60]).resize((360, 360)).save(
                Path(SHOTS) / f"view_face_{what.replace(' ', '_')}.png")
    assert seen["jaw open"]["mouth"] >= 8 and seen["lips closed"]["mouth"] <= 1, f"the mouth did not open and shut: {seen}"
    assert min(seen["eyes open"]["eyes"]) >= 8 and max(seen["blink"]["eyes"]) <= 1, f"the eyes did not blink: {seen}"
    browser.js("document.querySelectorAll('#caption, #views').forEach((e) => { e.style.visibility = ''; })")


def test_speech_and_motion_share_one_clock(server, browser):
    browser.open(server.url)
    assert browser.state()["hasAudio"], "the take's speech did not load"

    def samples(n: int, gap: float) -> list[tuple[float, float, float]]:
        """(the time the page drew last, moved on by the seconds since at the speed; the audio
        element's time; the wall clock), read in one go."""
        out = []
        for _ in range(n):
            s = browser.js("(() => { const s = sgtView.state(); "
                           "return [s.time + s.sinceDrawn * s.speed, s.audioTime, performance.now() / 1000, s.audioPaused]; })()")
            assert not s[3], "the speech is not playing"
            out.append(tuple(s[:3]))
            time.sleep(gap)
        return out

    def check(got, speed: float) -> None:
        for page, sound, _ in got:
            assert abs(page - sound) < 0.06, f"at {speed}x the page's clock said {page:.3f} s while the speech was at {sound:.3f} s"
        rate = (got[-1][1] - got[0][1]) / (got[-1][2] - got[0][2])
        assert abs(rate - speed) < 0.2 * speed, f"the speech ran at {rate:.2f}x, not {speed}x"

    browser.key(" ", "Space", 32)
    browser.wait("sgtView.state().time > 0.1 && !sgtView.state().audioPaused", 10, "the speech to play")
    check(samples(5, 0.25), 1.0)
    browser.key("]", "BracketRight", 221)  # 1.5x
    browser.key("]", "BracketRight", 221)  # 2x
    assert browser.state()["audioRate"] == 2
    check(samples(4, 0.25), 2.0)
    browser.key(" ", "Space", 32)
    word = browser.js("[...document.querySelectorAll('.tl-word')].map((e) => parseFloat(e.dataset.seek))")[4]
    browser.click(".tl-word:nth-child(5)")
    browser.wait(f"Math.abs(sgtView.state().time - {word}) < 1e-6", 5, f"the page to go to the word at {word} s")
    assert abs(browser.state()["audioTime"] - word) < 0.01, "the speech did not go where the page went"


def test_the_page_reloads_when_the_script_is_saved(folder, browser):
    script = folder / "live.sgt"
    script.write_text("guide: Hello there [pose:wave] and welcome.\n")
    view = View(str(script))
    try:
        browser.open(view.url)
        before = browser.state()
        browser.key("l", "KeyL", 76)  # loop, so that it still plays when the new take comes
        browser.key(" ", "Space", 32)
        script.write_text("guide: Hello there [pose:wave] and welcome. The lifts are behind you.\n")  # saved
        browser.wait(f"sgtView.state().takeId > {before['takeId']}", 40, "the page to load the saved script")
        after = browser.state()
        assert after["words"] == before["words"] + 5 and after["playing"] and not after["audioPaused"]
        assert "lifts" in browser.js("[...document.querySelectorAll('.tl-word')].map((e) => e.textContent).join(' ')")
        if SHOTS:
            browser.screenshot(Path(SHOTS) / "view_reloaded.png")
        script.write_text("guide: Hello there [pose:wavee] and welcome.\n")  # a mistake
        browser.wait("sgtView.state().problem.includes('1 error')", 40, "the page to show the error")
        assert browser.state()["takeId"] == after["takeId"]  # the last take that worked stays
        assert "unknown gesture 'wavee'" in browser.js("document.getElementById('details').textContent")
    finally:
        view.stop()


def _timeline(browser) -> dict:
    """The timeline as drawn: the playhead's x on the screen, the span of it in view (from the
    labels' right edge to the timeline's right edge), and where time 0 is and the pixels a second
    (from the ruler's ticks and their seconds)."""
    return browser.js("""(() => {
      const root = document.getElementById('timeline');
      const ticks = [...root.querySelectorAll('.tl-tick')].map((e) => [e.getBoundingClientRect().x, parseFloat(e.textContent)]);
      const head = root.querySelector('.tl-playhead').getBoundingClientRect();
      const pps = (ticks[1][0] - ticks[0][0]) / (ticks[1][1] - ticks[0][1]);
      const right = root.getBoundingClientRect().x + root.clientLeft + root.clientWidth - head.width; // no scroll bar
      return {head: head.x, left: root.querySelector('.tl-label').getBoundingClientRect().right, right,
              zero: ticks[0][0] - ticks[0][1] * pps, pps};
    })()""")


def _followed(browser, what: str) -> dict:
    """After a jump while paused: the page drew its time, and the timeline's playhead is there, in view."""
    state = browser.state()
    assert not state["playing"], what
    line = _timeline(browser)
    at = line["zero"] + state["time"] * line["pps"]
    assert abs(line["head"] - at) < 1.5, f"{what}: the playhead is at x {line['head']:.1f}, not at {state['time']:.3f} s (x {at:.1f})"
    assert line["left"] - 0.5 <= line["head"] <= line["right"] + 0.5, \
        f"{what}: the playhead (x {line['head']:.1f}) is out of the timeline's view ({line['left']:.1f} to {line['right']:.1f})"
    return state


def test_the_timeline_follows_jumps_and_scrubs_while_paused(server, browser, take):
    clip, _ = take
    strokes = sorted(c.stroke_frame for c in clip.controls if c.kind == "pose" and c.stroke_frame is not None)
    browser.open(server.url)
    for _ in range(3):  # zoomed in 8x: the take is several timelines wide
        browser.key("+", "Equal", 187)
    assert browser.js("(() => { const r = document.getElementById('timeline'); return r.scrollWidth > 3 * r.clientWidth; })()")
    _followed(browser, "at the start")

    def jump(what: str, press, until: str) -> dict:
        press()
        browser.wait(until, 10, what)
        time.sleep(0.15)  # a frame drawn since
        return _followed(browser, what)

    jump("End", lambda: browser.key("End", "End", 35), "sgtView.state().time === sgtView.state().duration")
    jump("Home", lambda: browser.key("Home", "Home", 36), "sgtView.state().time === 0")
    for f in strokes:  # '.': the next stroke
        assert jump(f"'.' to frame {f}", lambda: browser.key(".", "Period", 190), f"sgtView.state().frame === {f}")["frame"] == f
    jump("shift+left", lambda: browser.cmd("Input.dispatchKeyEvent", type="keyDown", key="ArrowLeft", code="ArrowLeft",
                                           windowsVirtualKeyCode=37, modifiers=8), "sgtView.state().frame === "
         f"{strokes[-1] - FPS}")
    browser.cmd("Input.dispatchKeyEvent", type="keyUp", key="ArrowLeft", code="ArrowLeft", windowsVirtualKeyCode=37, modifiers=8)
    point = next(c for c in clip.controls if c.name == "point_right")
    # the stroke's control out of view (the timeline followed End to the take's end), then clicked
    jump("End, before a click", lambda: browser.key("End", "End", 35), "sgtView.state().time === sgtView.state().duration")
    assert browser.js("(() => { const r = document.getElementById('timeline').getBoundingClientRect(); const e = "
                      "document.querySelector('.tl-pose[data-name=\"point_right\"]').getBoundingClientRect(); "
                      "return e.right < r.left || e.left > r.right; })()")
    jump("a click on point_right", lambda: browser.click('.tl-pose[data-name="point_right"]'),
         f"sgtView.state().frame === {point.stroke_frame}")
    if SHOTS:
        browser.screenshot(Path(SHOTS) / "view_jumped.png")
    # a scrub: the slider pressed at 30 % of its length, dragged to 90 %, let go
    x0, y, width = browser.js("(() => { const r = document.getElementById('scrub').getBoundingClientRect(); "
                              "return [r.x, r.y + r.height / 2, r.width]; })()")
    browser.cmd("Input.dispatchMouseEvent", type="mousePressed", x=x0 + 0.3 * width, y=y, button="left", clickCount=1)
    for k in range(1, 7):
        browser.cmd("Input.dispatchMouseEvent", type="mouseMoved", x=x0 + (0.3 + 0.1 * k) * width, y=y, button="left")
    browser.cmd("Input.dispatchMouseEvent", type="mouseReleased", x=x0 + 0.9 * width, y=y, button="left", clickCount=1)
    state = jump("a scrub", lambda: None, "sgtView.state().time > 0.8 * sgtView.state().duration")
    if SHOTS:
        browser.screenshot(Path(SHOTS) / "view_scrubbed.png")
    assert abs(state["time"] / state["duration"] - 0.9) < 0.05, state


def test_pages_open_when_sgt_view_stops_say_so_and_it_stops_quietly(folder, browser):
    """Ctrl+c with the page open (its long poll waiting) and a second tab just closed."""
    view = View(str(folder / "take.json"))
    browser.open(view.url)
    other = Browser(400, 300)
    try:
        other.open(view.url)
    finally:
        other.close()  # a tab just gone
    started = time.monotonic()
    said = view.stop()
    assert view.proc.returncode == 0 and said.count("\n") <= 1 and "Traceback" not in said, said
    assert time.monotonic() - started < 3
    problem = browser.wait("sgtView.state().problem", 10, "the page to say that sgt view stopped")
    assert problem.startswith("sgt view is stopping"), problem


def _captions_by_frame(browser, n_frames: int) -> list[list[str]]:
    """The caption over the view at every frame, as the page drew it after a seek to the frame."""
    return browser.js(f"""(async () => {{
      const out = [];
      for (let f = 0; f < {n_frames}; f++) {{
        sgtView.seek(f / {FPS});
        await new Promise((resolve) => requestAnimationFrame(() => resolve()));
        if (sgtView.state().frame !== f) throw new Error(`drew frame ${{sgtView.state().frame}}, not ${{f}}`);
        out.push([...document.querySelectorAll('#caption .spoken')].map((e) => e.textContent));
      }}
      return out;
    }})()""")


def _rendered_captions(motion) -> list[list[str]]:
    """The word `sgt render` captions each frame with (renders.overlay), per speaker's track, as
    the page shows them: the word, or 'speaker: word' for each speaker of a dialogue."""
    from renders.clips import speaker_name
    from renders.overlay import frame_word

    clips = [track_clip(t, motion.clips) for t in motion.tracks]
    out = []
    for f in range(motion.tracks[0].n_frames):
        words = [(speaker_name(c.speaker), frame_word(c.words, f)) for c in clips]
        out.append([w if len(clips) == 1 else f"{who}: {w}" for who, w in words if w])
    return out


@pytest.fixture(scope="module")
def dialogue(folder):
    """A take of two speakers, the second interrupting the first (their words overlap)."""
    (folder / "dialogue.sgt").write_text(DIALOGUE)
    assert main(["generate", str(folder / "dialogue.sgt"), "-o", str(folder / "dialogue.json")]) == 0
    view = View(str(folder / "dialogue.json"))
    yield view, load_motion_file(folder / "dialogue.json")
    view.stop()


@pytest.mark.parametrize("which", ["guide", "dialogue"])
def test_the_caption_is_the_word_sgt_render_shows_at_every_frame_and_at_every_stroke(which, folder, server, dialogue, browser):
    view, motion = (server, load_motion_file(folder / "take.json")) if which == "guide" else dialogue
    expected = _rendered_captions(motion)
    browser.open(view.url)
    got = _captions_by_frame(browser, len(expected))
    wrong = [(f, got[f], expected[f]) for f in range(len(expected)) if got[f] != expected[f]]
    assert not wrong, f"{len(wrong)} frames captioned otherwise than sgt render's (frame, page, render): {wrong[:6]}"
    assert sum(bool(c) for c in expected) > len(expected) / 3  # words to compare
    assert which == "guide" or any(len(c) == 2 for c in expected)  # the dialogue: both speaking at once
    controls = browser.js("[...document.querySelectorAll('.tl-pose')].map((e) => e.dataset.strokeFrame)")
    assert len(controls) >= 2
    for stroke in controls:  # a click on each pose control: the caption at its stroke
        if not stroke:
            continue
        browser.click(f".tl-pose[data-stroke-frame='{stroke}']")
        browser.wait(f"sgtView.state().frame === {stroke}", 10, f"the stroke at frame {stroke}")
        time.sleep(0.1)
        shown = browser.js("[...document.querySelectorAll('#caption .spoken')].map((e) => e.textContent)")
        assert shown == expected[int(stroke)], f"at the stroke of frame {stroke} the page says {shown}, sgt render {expected[int(stroke)]}"


#: The VRM preset expressions the test character has (with no morph targets bound: the weights
#: are what is checked).
VRM_FACE = ("aa", "ou", "blink")


def _test_vrm(tmp: Path, clip) -> Path:
    """A VRM 1.0 character: sgt's vrm rig, T-pose, with its skinned mannequin (renders.gltf),
    declared a VRM (VRMC_vrm) instead of a VRM Animation, with the expressions :data:`VRM_FACE`."""
    still = type(clip)(poses=clip.poses[:1], positions=clip.positions[:1], hands=None)
    data = glb_bytes(still, get_rig("vrm"))
    (length,) = struct.unpack_from("<I", data, 12)
    doc = json.loads(data[20:20 + length])
    binary = data[20 + length:]
    humanoid = doc["extensions"].pop("VRMC_vrm_animation")["humanoid"]
    doc.pop("animations")
    doc["extensionsUsed"] = ["VRMC_vrm"]
    doc["extensions"]["VRMC_vrm"] = {
        "specVersion": "1.0", "humanoid": humanoid, "expressions": {"preset": {name: {} for name in VRM_FACE}},
        "meta": {"name": "sgt test mannequin", "version": "1", "authors": ["sgt tests"],
                 "licenseUrl": "https://vrm.dev/licenses/1.0/", "avatarPermission": "onlyAuthor",
                 "commercialUsage": "personalNonProfit", "allowRedistribution": False, "modification": "prohibited"}}
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    path = tmp / "test.vrm"
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + len(binary))
                     + struct.pack("<I4s", len(text), b"JSON") + text + binary)
    return path


def test_a_vrm_character_plays_the_take(server, browser, take, tmp_path):
    clip, _ = take
    point = next(c for c in clip.controls if c.name == "point_right")
    browser.open(server.url)
    node = browser.cmd("DOM.querySelector", nodeId=browser.cmd("DOM.getDocument")["root"]["nodeId"], selector="#vrmfile")["nodeId"]
    browser.cmd("DOM.setFileInputFiles", nodeId=node, files=[str(_test_vrm(tmp_path, clip))])
    browser.wait("sgtView.state().rig === 'vrm' && sgtView.state().characters === 1", 30, "the VRM character")
    browser.click('.tl-pose[data-name="point_right"]')
    browser.wait(f"sgtView.state().frame === {point.stroke_frame}", 10, "the stroke")
    time.sleep(0.2)
    bones, expressions = browser.js("sgtView.bones(0)"), browser.js("sgtView.expressions(0)")
    forearm = np.subtract(bones["rightHand"], bones["rightLowerArm"])
    theirs = clip.positions[point.stroke_frame]
    ours = theirs[8 + 1] - theirs[8]  # right_wrist - right_elbow
    angle = np.degrees(np.arccos(np.clip(np.dot(forearm, ours) / np.linalg.norm(forearm) / np.linalg.norm(ours), -1, 1)))
    assert angle < 8, f"the VRM character's right forearm is {angle:.1f} degrees from sgt's at the stroke"
    weights = {name: float(w[point.stroke_frame]) for name, w in vrm_expressions(clip.face).items() if name in VRM_FACE}
    assert expressions == pytest.approx(weights, abs=1e-3), "the character's expressions are not the take's"
    browser.js(f"sgtView.seek({int(np.argmax(vrm_expressions(clip.face)['blink']))} / {FPS})")
    browser.wait("sgtView.expressions(0).blink > 0.9", 10, "the VRM character to blink")
    if SHOTS:
        browser.screenshot(Path(SHOTS) / "view_vrm.png")
    assert browser.state()["problem"] == ""


def _page_face(face: dict, n_frames: int):
    """The page's face of a speaker (sgt_tui.view.page.face_of) as a FaceTrack."""
    weights = np.zeros((n_frames, N_BLENDSHAPES))
    weights[:, [ARKIT_INDEX[c] for c in face["channels"]]] = np.reshape(face["weights"], (n_frames, -1))
    return FaceTrack(weights, np.reshape(face["gaze"], (n_frames, 2, 2)))


def screenshots(out: Path) -> None:
    """The documentation's pictures of the page (python3 tests/test_view_browser.py docs):
    view.png, the shipped example at the stroke of its `point_right x2`; view_dialogue.png, the
    two speakers of examples/game_dialogue.sgt; view_stroke.png, the page's frame of that
    stroke beside sgt's own render of it (what the test compares)."""
    from PIL import Image

    browser = Browser(1100, 720)
    try:
        for name, script, control, view_name in (("view.png", "mall_guide.sgt", "point_right", "three-quarter"),
                                                 ("view_dialogue.png", "game_dialogue.sgt", "point_front", "front")):
            view = View(str(ROOT / "examples" / script))
            try:
                browser.open(view.url)
                browser.js(f"sgtView.setView('{view_name}')")
                browser.click(f'.tl-pose[data-name="{control}"]')
                browser.wait("sgtView.state().time > 0", 10)
                time.sleep(0.5)
                browser.screenshot(out / name)
                if name == "view.png":  # the page's frame and sgt's render of it, side by side
                    with urllib.request.urlopen(view.url + "api/take") as r:
                        speaker = json.load(r)["speakers"][0]
                    frame = browser.state()["frame"]
                    browser.js("sgtView.setView('front'); document.querySelectorAll('#caption, #views')"
                               ".forEach((e) => { e.style.visibility = 'hidden'; })")
                    time.sleep(0.5)
                    page = browser.canvas(square=True)
                    positions = np.reshape(speaker["positions"], (-1, 10, 3))
                    hands = np.reshape(speaker["hands"], (-1, 2, 20, 3))[frame]
                    face = _page_face(speaker["face"], len(positions))
                    with Mannequin(page.shape[0], page.shape[0]) as m:
                        ours = m.render(positions[frame], hands, view="front", face=FaceFrames(face)[frame])
                    Image.fromarray(np.concatenate([page, ours], axis=1)).save(out / "view_stroke.png")
            finally:
                view.stop()
    finally:
        browser.close()
    print(f"wrote {out}/view.png, {out}/view_dialogue.png, {out}/view_stroke.png")


if __name__ == "__main__":
    screenshots(Path(sys.argv[1] if len(sys.argv) > 1 else "docs"))
