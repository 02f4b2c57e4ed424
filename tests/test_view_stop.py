"""Ctrl+c stops `sgt view` quietly at any moment: the real command in its own process, sent
SIGINT as a terminal's ctrl+c sends it, with pages long-polling /api/wait (some just gone),
twice in a row, right after it printed its address, while a saved script is generated again,
while a page waits for a take being loaded, and while a client does not read its answer.

Each time: exit status 0 (the clean stop of a server, as `sgt serve` has it), nothing printed
after the two lines it starts with, never a traceback (uvicorn cancels what still runs 1 s after
ctrl+c, and printed a traceback per request it cancelled), and soon: a take being generated is
cancelled, not waited for. The long polls still open are answered 503 "sgt view is stopping".
"""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from sgt_tui.cli import main

ROOT = Path(__file__).resolve().parent.parent
SHORT = "@seed 2\nguide: Look at the marmalade [pose:point_right] on the shelf over there.\n"
#: Long enough that generating it, or compiling its speech again, takes seconds.
LONG = "@seed 1\n" + "".join(f"guide: Sentence number {i} is about the marmalade [pose:point_right] on the shelf "
                              f"over there, and the garden beyond.\n" for i in range(80))


class View:
    """`sgt view ARGS --port 0` in its own process, its standard error in a file."""

    def __init__(self, folder: Path, *args: str) -> None:
        self.log = folder / f"view-{time.monotonic_ns()}.log"
        with open(self.log, "w") as log:
            self.proc = subprocess.Popen([sys.executable, "-m", "sgt_tui", "view", *args, "--port", "0"], cwd=ROOT,
                                         stdout=subprocess.DEVNULL, stderr=log)
        deadline = time.monotonic() + 120
        while (m := re.search(r"^sgt view: http://127\.0\.0\.1:(\d+)/", self.log.read_text(), re.MULTILINE)) is None:
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.proc.kill()
                pytest.fail(f"sgt view did not start: {self.log.read_text()[-2000:]}")
            time.sleep(0.02)
        self.port = int(m.group(1))
        self.url = f"http://127.0.0.1:{self.port}/"

    def get(self, path: str) -> dict:
        with urllib.request.urlopen(self.url + path, timeout=60) as r:
            return json.load(r)

    def ctrl_c(self, *, again_after: float | None = None) -> tuple[int, str, float]:
        """SIGINT (twice, ``again_after`` seconds apart); (exit status, standard error, seconds to exit)."""
        started = time.monotonic()
        self.proc.send_signal(signal.SIGINT)
        if again_after is not None:
            time.sleep(again_after)
            if self.proc.poll() is None:
                self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(60)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        return self.proc.returncode, self.log.read_text(), time.monotonic() - started

    def wait_poll(self, version: int) -> socket.socket:
        """A page's long poll: GET /api/wait?version=N, its answer not read yet."""
        s = socket.create_connection(("127.0.0.1", self.port))
        s.sendall(f"GET /api/wait?version={version} HTTP/1.1\r\nHost: 127.0.0.1:{self.port}\r\n\r\n".encode())
        return s


def quiet(code: int, log: str, seconds: float, limit: float = 3.0, codes=(0,)) -> None:
    """A clean stop: status 0, nothing after the two lines sgt view starts with, soon."""
    said = log.splitlines()
    assert code in codes, log[-3000:]
    assert "Traceback" not in log and len(said) <= 2, "\n".join(said[2:])[-3000:]
    assert seconds < limit, f"sgt view took {seconds:.1f} s to stop"


def answer(s: socket.socket) -> tuple[int, str]:
    """(status, body) of the answer on a long poll's socket (0, "" when the server closed it unanswered)."""
    s.settimeout(10)
    data = b""
    while chunk := s.recv(65536):
        data += chunk
    s.close()
    head, _, body = data.partition(b"\r\n\r\n")
    return (int(head.split()[1]), body.decode()) if head else (0, "")


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("stop")
    (folder / "talk.sgt").write_text(SHORT)
    (folder / "long.sgt").write_text(LONG)
    return folder


@pytest.fixture(scope="module")
def long_take(folder) -> Path:
    """A motion file of LONG (8 minutes), beside its script: viewing it compiles its speech again."""
    takes = folder / "takes"
    takes.mkdir()
    (takes / "a.sgt").write_text(SHORT)
    (takes / "long.sgt").write_text(LONG)
    for name in ("a", "long"):
        assert main(["generate", str(takes / f"{name}.sgt"), "-o", str(takes / f"{name}.json")]) == 0
    return takes / "long.json"


@pytest.mark.parametrize("gone, delay", [
    (0, 0.0),  # three pages waiting
    (1, 0.0),  # one of them closed just now
    (3, 0.05),  # all three closed a moment ago
])
def test_ctrl_c_with_pages_waiting_and_pages_just_gone(folder, gone, delay):
    view = View(folder, str(folder / "talk.sgt"))
    version = view.get("api/status")["version"]
    polls = [view.wait_poll(version) for _ in range(3)]
    time.sleep(0.3)  # the server holds them
    for s in polls[:gone]:
        s.close()
    time.sleep(delay)
    code, log, seconds = view.ctrl_c()
    quiet(code, log, seconds)
    for s in polls[gone:]:  # the pages still there were told
        status, body = answer(s)
        assert status == 503 and json.loads(body)["error"].startswith("sgt view is stopping"), (status, body)


@pytest.mark.parametrize("delay", [0.0, 0.02, 0.2])
def test_ctrl_c_right_after_it_listens_and_twice_in_a_row(folder, delay):
    view = View(folder, str(folder / "talk.sgt"))  # SIGINT as soon as the address is printed
    time.sleep(delay)
    quiet(*view.ctrl_c())
    view = View(folder, str(folder / "talk.sgt"))
    version = view.get("api/status")["version"]
    polls = [view.wait_poll(version) for _ in range(2)]
    time.sleep(0.3)
    polls[0].close()
    # ctrl+c, ctrl+c: the second changes nothing, or finds it exiting (after its last line of
    # Python, where CPython has put back the system's default: death by SIGINT, which a shell
    # shows as 130, with nothing printed)
    quiet(*view.ctrl_c(again_after=delay), codes=(0, -signal.SIGINT))
    polls[1].close()


def _until(what, timeout: float = 60.0, step: float = 0.02):
    deadline = time.monotonic() + timeout
    while not (value := what()):
        assert time.monotonic() < deadline, "waited in vain"
        time.sleep(step)
    return value


def test_ctrl_c_while_the_saved_script_is_generated_again_cancels_it(folder, tmp_path):
    script = tmp_path / "live.sgt"
    script.write_text(SHORT)
    view = View(folder, str(script))
    version = view.get("api/status")["version"]
    poll = view.wait_poll(version)
    script.write_text(LONG)  # saved: 80 utterances to generate, seconds of work
    _until(lambda: view.get("api/status")["takes"][0]["busy"])
    time.sleep(0.5)
    code, log, seconds = view.ctrl_c()
    quiet(code, log, seconds)
    poll.close()


def test_ctrl_c_while_a_page_waits_for_a_take_being_loaded(long_take):
    view = View(long_take.parent, str(long_take.parent))  # a folder: a.json is loaded, long.json when asked
    assert [t["name"] for t in view.get("api/status")["takes"]] == ["a.json", "long.json"]
    got: dict = {}

    def ask() -> None:  # the page asks for long.json: its speech is compiled again, seconds of work
        try:
            with urllib.request.urlopen(view.url + "api/take?take=1", timeout=60) as r:
                got["status"] = r.status
        except urllib.error.HTTPError as exc:
            got["status"], got["body"] = exc.code, json.loads(exc.read())
        except OSError as exc:
            got["status"] = exc

    asking = threading.Thread(target=ask)
    asking.start()
    _until(lambda: view.get("api/status")["takes"][1]["busy"])
    time.sleep(0.3)
    code, log, seconds = view.ctrl_c()
    asking.join(30)
    quiet(code, log, seconds)
    assert got["status"] == 503 and got["body"]["error"].startswith("sgt view is stopping"), got


def test_ctrl_c_while_a_client_does_not_read_its_answer(long_take):
    """The take (about 20 MB of JSON) sent to a client that reads nothing: its connection is cut
    (uvicorn waited 1 s for it, then said so)."""
    view = View(long_take.parent, str(long_take))
    s = socket.socket()
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)
    s.connect(("127.0.0.1", view.port))
    s.sendall(f"GET /api/take HTTP/1.1\r\nHost: 127.0.0.1:{view.port}\r\n\r\n".encode())
    time.sleep(1.5)  # the answer made and stuck in the buffers
    code, log, seconds = view.ctrl_c()
    s.close()
    quiet(code, log, seconds)
