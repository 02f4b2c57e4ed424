"""Smoke tests of the real `sgt edit` in a terminal: tmux runs it, send-keys types, the file is checked.

Skipped when tmux is not installed. Each test uses its own tmux server (-L), never the user's.
"""

from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")

ROOT = Path(__file__).resolve().parent.parent
LAUNCH = "import sys; from sgt_tui.cli import main; sys.exit(main())"


class Tmux:
    def __init__(self, tmp: Path) -> None:
        self.socket = f"sgt-test-{os.getpid()}-{tmp.name}"
        self.tmp = tmp

    def __call__(self, *args: str, check: bool = True) -> str:
        out = subprocess.run(["tmux", "-L", self.socket, *args], capture_output=True, text=True, timeout=30)
        if check and out.returncode != 0:
            raise AssertionError(f"tmux {' '.join(args)}: {out.stderr}")
        return out.stdout

    def start(self, script: Path) -> None:
        env = f"SGT_EDITOR_CACHE={shlex.quote(str(self.tmp / 'cache'))} TERM=xterm-256color"
        cmd = (f"cd {shlex.quote(str(ROOT))} && {env} {shlex.quote(sys.executable)} -c {shlex.quote(LAUNCH)} "
               f"edit {shlex.quote(str(script))} --engine rules; echo EXIT=$? > {shlex.quote(str(self.tmp / 'exit'))}")
        self("new-session", "-d", "-s", "t", "-x", "100", "-y", "30", cmd)

    def screen(self) -> str:
        return self("capture-pane", "-p", "-t", "t", check=False)

    def wait_for(self, text: str, timeout: float = 60.0) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            shown = self.screen()
            if text in shown:
                return shown
            time.sleep(0.1)
        raise AssertionError(f"{text!r} never appeared; the screen shows:\n{self.screen()}")

    def wait_gone(self, text: str, timeout: float = 10.0) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            shown = self.screen()
            if text not in shown:
                return shown
            time.sleep(0.05)
        raise AssertionError(f"{text!r} is still on the screen:\n{self.screen()}")

    def keys(self, *keys: str, literal: bool = False) -> None:
        self("send-keys", "-t", "t", *(["-l"] if literal else []), *keys)
        time.sleep(0.15)

    def close(self) -> None:
        self("kill-server", check=False)


@pytest.fixture
def tmux(tmp_path):
    t = Tmux(tmp_path)
    yield t
    t.close()


def test_type_save_and_quit_in_tmux(tmux, tmp_path):
    script = tmp_path / "lobby.sgt"
    script.write_text("guide: Look at [pose:wave] the shelf\n")
    tmux.start(script)
    tmux.wait_for("engine rules")
    tmux.wait_for("utterance 1")
    tmux.keys("guide: typed in tmux", literal=True)
    tmux.keys("Enter")
    tmux.keys("Down")
    tmux.keys("End")
    tmux.keys("Left", "Left", "Left", "Left", "Left", "Left", "Left", "Left", "Left", "Left", "Left", "Left")
    tmux.keys("M-Right")  # alt+right: the pose control moves to the next word
    tmux.keys("F3")
    tmux.wait_for("Library ·")
    tmux.keys("Escape")
    tmux.keys("C-s")
    tmux.wait_for("lobby.sgt │ ok")  # no [+]: saved
    tmux.wait_for("saved ")
    assert script.read_text() == "guide: typed in tmux\nguide: Look at the [pose:wave] shelf\n"
    tmux.keys("C-q")
    deadline = time.monotonic() + 20
    while not (tmp_path / "exit").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert (tmp_path / "exit").read_text().strip() == "EXIT=0"


def test_a_dropped_terminal_keeps_the_unsaved_work(tmux, tmp_path):
    script = tmp_path / "s.sgt"
    script.write_text("guide: saved\n")
    tmux.start(script)
    tmux.wait_for("engine rules")
    tmux.keys("guide: not saved yet", literal=True)
    tmux.keys("Enter")
    tmux.wait_for("s.sgt [+]")
    tmux.close()  # like a dropped SSH connection: the terminal hangs up
    recovery = tmp_path / "cache" / "recovery"
    deadline = time.monotonic() + 20
    while not list(recovery.glob("s.sgt.*.json")) and time.monotonic() < deadline:
        time.sleep(0.1)
    found = list(recovery.glob("s.sgt.*.json"))
    assert found, "no recovery file"
    assert json.loads(found[0].read_text())["text"] == "guide: not saved yet\nguide: saved\n"
    assert script.read_text() == "guide: saved\n"


def _exit_code(tmux, tmp_path) -> str:
    deadline = time.monotonic() + 20
    while not (tmp_path / "exit").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    return (tmp_path / "exit").read_text().strip()


def test_panels_close_with_q_or_f3_and_dialogs_show_their_keys_in_tmux(tmux, tmp_path):
    script = tmp_path / "lobby.sgt"
    script.write_text("guide: hello [pose:wavee] there\n")
    tmux.start(script)
    tmux.wait_for("engine rules")
    tmux.keys("F2")
    tmux.wait_for("Problems (1)")
    tmux.keys("q")  # no escape: tmux's escape-time does not apply
    tmux.wait_gone("Problems (1)")
    tmux.keys("F3")
    tmux.wait_for("Library ·")
    tmux.keys("F3")
    tmux.wait_gone("Library ·")
    tmux.keys("x", literal=True)
    tmux.keys("C-q")
    shown = tmux.wait_for("Unsaved changes")
    for label in ("[s] save and quit", "[q] quit without saving", "[c] cancel"):
        assert label in shown, shown
    tmux.keys("q")
    assert _exit_code(tmux, tmp_path) == "EXIT=0"
    assert script.read_text() == "guide: hello [pose:wavee] there\n"


def test_ctrl_home_ctrl_end_and_home_on_a_wrapped_line_in_tmux(tmux, tmp_path):
    script = tmp_path / "nav.sgt"
    long = "guide: " + " ".join(["words"] * 30)
    script.write_text(f"guide: first\n{long}\nguide: last")
    tmux.start(script)
    tmux.wait_for("utterance 1")
    tmux.keys("C-End")
    tmux.keys("Z", literal=True)
    tmux.wait_for("lastZ")
    tmux.keys("C-Home")
    tmux.keys("A", literal=True)
    tmux.wait_for("Aguide: first")
    tmux.keys("Down")
    tmux.wait_for("utterance 2")
    tmux.keys("End")
    tmux.keys("Home")  # the line wraps over several rows: home goes to its start
    tmux.keys("H", literal=True)
    tmux.wait_for("Hguide: words")
    tmux.keys("C-s")
    tmux.wait_for("saved ")
    assert script.read_text() == f"Aguide: first\nH{long}\nguide: lastZ"
    tmux.keys("C-q")
    assert _exit_code(tmux, tmp_path) == "EXIT=0"


def test_typing_and_ctrl_s_in_one_burst_save_exactly_what_was_typed(tmux, tmp_path):
    """Issue 21: the text and ctrl+s sent by one send-keys (as a paste or a fast macro does)
    said "saved" while the file lacked the text and [+] stayed. Keys are now handled in the
    order they came: ctrl+s saves every key typed before it and none typed after it."""
    script = tmp_path / "burst.sgt"
    script.write_text("guide: first.\n")
    tmux.start(script)
    tmux.wait_for("utterance 1")
    tmux("send-keys", "-t", "t", "guide: x.", "Enter", "C-s", "y", "BSpace", "z")
    tmux.wait_for("saved ")
    tmux.wait_for("zguide: first.")
    # the z typed after ctrl+s is not saved yet (the header's mark may be drawn a frame after the text)
    tmux.wait_for("burst.sgt [+]", timeout=10.0)
    assert script.read_text() == "guide: x.\nguide: first.\n"
    tmux("send-keys", "-t", "t", "BSpace", "C-s")
    shown = tmux.wait_gone("burst.sgt [+]")
    assert script.read_text() == "guide: x.\nguide: first.\n"
    tmux.keys("C-q")
    assert _exit_code(tmux, tmp_path) == "EXIT=0"


def test_a_1_mb_script_shows_its_first_screen_and_takes_keys_while_it_is_analysed(tmux, tmp_path):
    """Issue 21: a 1 MB script showed a blank terminal for about 50 s. The first screen now comes
    before the first analysis (which runs in the background, the status line saying how far it
    is), and typing and saving work meanwhile. (How fast: benchmarks/bench_edit.py --large-only.)"""
    script = tmp_path / "long.sgt"
    line = "guide: Line {i} of the long scene, [pose:beat_right] said once and then again, <speed:+1>quickly</speed>.\n"
    text = "".join(line.format(i=i) for i in range(10_000))
    assert len(text) > 1_000_000
    script.write_text(text)
    tmux.start(script)
    shown = tmux.wait_for("long.sgt", timeout=30)
    assert "guide: Line 0 of the long scene" in shown
    assert "analysing" in shown.splitlines()[0]  # the screen came first: the analysis is on its way
    tmux.keys("A", literal=True)
    shown = tmux.wait_for("Aguide: Line 0")
    assert "utt 1/" not in shown.splitlines()[0]  # typed while the first analysis runs (seconds long)
    tmux.keys("C-s")
    tmux.wait_for("saved ", timeout=30)
    assert script.read_text() == "A" + text
    tmux.wait_for("utt 1/", timeout=300)  # the analysis arrives: the status line has the utterance count
    tmux.keys("C-q")
    assert _exit_code(tmux, tmp_path) == "EXIT=0"
