"""Benchmark of `sgt edit`: keystroke-to-diagnostics, regenerate-and-show, CPU while the preview plays,
and a 1 MB script (first screen, keystroke to screen) side by side with the code before issue 21.

    python benchmarks/bench_edit.py [--lines 500] [--repeat 15] [--seconds 4]
    python benchmarks/bench_edit.py --large-only [--before 742c655] [--large-lines 10000] [--keys 30]

1. Keystroke to diagnostics on a 500-line script (target: under 50 ms): one character typed into
   an utterance, then (a) the editor's analysis alone and (b) the whole path in the running app,
   from the key reaching the document to the diagnostics, timeline and preview updated in the
   widgets (the screen repaints on its next frame), not counting the 80 ms typing debounce.
2. Regenerate and show a 10-second utterance with warm models (target: under 0.5 s): in the app,
   ctrl+g until the new motion is in the preview; the worker process and the speech cache are
   warm. Uses the neural engine when model/weights/generator.pt exists; without it, the rules
   engine and the neural network with untrained weights (same computation, so same speed).
3. CPU while the preview plays at 15 fps: process CPU time / wall time of the real `sgt edit` in a
   tmux terminal (headless Textual when tmux is missing), playing and paused.
4. A long script (10,000 lines, 1.1 MB; target: first screen within 1 s of a short script's,
   editing responsive), measured on the real `sgt edit` in tmux, for the code before issue 21
   (``--before REV``, default 742c655; see benchmarks/against.py) and today's, in one run:
   (a) first screen: from starting the command to the status line on the terminal, for a
   one-line script and the long one (the command's start-up, about 1-2 s here, is in both);
   (b) the first analysis shown (the status line's problem count); (c) keystroke to screen:
   a character typed into utterance 1 until tmux shows it, one key every 150 ms (a fast
   typist), once the analysis is shown (and, today, also while the first analysis runs).

Prints medians. Figures vary with machine load.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import random
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def ms(values) -> str:
    return f"median {statistics.median(values) * 1000:7.1f} ms   min {min(values) * 1000:7.1f} ms   (n={len(values)})"


def ten_second_utterance() -> str:
    words = ("we have three new shops on the ground floor and a cinema upstairs so take the lift "
             "behind you then turn left at the fountain and you will see the big blue sign").split()
    return "guide: [pose:wave] Welcome! " + " ".join(words) + " [pose:point_right] over there."


def keystroke(lines: int, repeat: int) -> None:
    from bench_check import make_script

    from sgt_tui.editor.analysis import Analyser

    text = make_script(lines)
    path = Path(tempfile.mkdtemp()) / "big.sgt"
    path.write_text(text)
    a = Analyser(path)
    t = time.perf_counter()
    first = a.run(text)
    cold = time.perf_counter() - t
    rows = text.split("\n")
    rng = random.Random(0)
    times = []
    for _ in range(repeat):
        u = rng.choice(first.utterances)
        rows[u.line - 1] += "a"
        t = time.perf_counter()
        a.run("\n".join(rows))
        times.append(time.perf_counter() - t)
    print(f"script: {len(rows)} lines, {len(first.utterances)} utterances; first analysis {cold * 1000:.0f} ms")
    print(f"{'keystroke -> diagnostics (analysis)':<44} {ms(times)}")
    edit_times = asyncio.run(_app_keystrokes(path, repeat))
    print(f"{'keystroke -> diagnostics shown (app)':<44} {ms(edit_times)}   (after the 80 ms typing debounce)")


async def _app_keystrokes(path: Path, repeat: int) -> list[float]:
    from sgt_tui.app.main import EditorApp
    from sgt_tui.app.services import ANALYSIS_DELAY
    from sgt_tui.editor.files import ScriptFile

    app = EditorApp(ScriptFile.open(path), engine="rules", cursor_blink=False)
    marks: dict[str, float] = {}
    replace, shown = app.doc.replace, app.update_cursor_info

    def timed_replace(*a, **kw):  # the key reaches the document
        marks["edit"] = time.perf_counter()
        return replace(*a, **kw)

    def timed_shown(*a, **kw):  # the last step of showing an analysis: timeline and preview updated
        shown(*a, **kw)
        marks["shown"] = time.perf_counter()

    app.doc.replace, app.update_cursor_info = timed_replace, timed_shown
    from_edit = []
    async with app.run_test(size=(80, 24)) as pilot:
        await pilot.pause()
        rng = random.Random(1)
        for _ in range(repeat):
            u = rng.choice(app.analysis.utterances)
            app.area.move_cursor((u.line - 1, 12))
            await pilot.pause()
            await pilot.press("a")
            while app.shown_version != app.doc.version:
                await asyncio.sleep(0.001)
            from_edit.append(marks["shown"] - marks["edit"] - ANALYSIS_DELAY)
    return from_edit


def regenerate(repeat: int) -> None:
    from model.weights import DEFAULT_WEIGHTS

    tmp = Path(tempfile.mkdtemp())
    os.environ["SGT_EDITOR_CACHE"] = str(tmp / "cache")
    path = tmp / "ten.sgt"
    path.write_text(ten_second_utterance() + "\n")
    if DEFAULT_WEIGHTS.exists():
        runs = [("neural", None, "neural engine, shipped weights")]
    else:
        # No trained weights yet: time the rules engine, and the neural engine's network with
        # untrained weights (the same computation, so the same speed; the motion is meaningless).
        from model.net import GestureNet
        from model.weights import save_weights

        untrained = tmp / "untrained.pt"
        save_weights(untrained, GestureNet(None), meta={"note": "untrained, for timing only"})
        runs = [("rules", None, "rules engine (model/weights/generator.pt missing)"),
                ("neural", str(untrained), "neural engine, untrained weights (speed only)")]
    for engine, weights, label in runs:
        times, seconds = asyncio.run(_app_regenerate(path, engine, repeat, weights))
        print(f"{'regenerate and show, warm: ' + engine:<44} {ms(times)}   ({seconds:.1f} s utterance; {label})")


async def _app_regenerate(path: Path, engine: str, repeat: int, weights: str | None):
    from core.skeleton import FPS
    from sgt_tui.app.main import EditorApp
    from sgt_tui.editor.files import ScriptFile

    app = EditorApp(ScriptFile.open(path), engine=engine, cursor_blink=False, weights=weights)
    out = []
    seconds = 0.0
    async with app.run_test(size=(80, 24)) as pilot:
        await pilot.pause()
        for i in range(repeat + 1):  # the first run warms the worker, models and speech cache
            app.takes.generated.clear()
            t = time.perf_counter()
            await pilot.press("ctrl+g")
            while not app.player.label.startswith("generated"):
                if not app.jobs.busy and "failed" in app.last_message:
                    raise SystemExit(app.last_message)
                await asyncio.sleep(0.002)
            if i:
                out.append(time.perf_counter() - t)
            seconds = app.player.n_frames / FPS
    return out, seconds


def cpu_while_playing(seconds: float) -> None:
    if shutil.which("tmux"):
        playing, paused = _tmux_cpu(seconds)
        where = "real terminal (tmux)"
    else:
        playing, paused = asyncio.run(_headless_cpu(seconds))
        where = "headless Textual"
    print(f"{'CPU while the preview plays (15 fps)':<44} {playing * 100:5.1f} % of one core   ({where}, {seconds:g} s)")
    print(f"{'CPU while paused (idle editor)':<44} {paused * 100:5.1f} % of one core")


def _proc_cpu(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _tmux_cpu(seconds: float) -> tuple[float, float]:
    tmp = Path(tempfile.mkdtemp())
    path = tmp / "play.sgt"
    path.write_text(ten_second_utterance() + "\n")
    sock = f"sgt-bench-{os.getpid()}"
    launch = "import sys; from sgt_tui.cli import main; sys.exit(main())"
    cmd = (f"cd {shlex.quote(str(ROOT))} && SGT_EDITOR_CACHE={shlex.quote(str(tmp / 'c'))} TERM=xterm-256color "
           f"exec {shlex.quote(sys.executable)} -c {shlex.quote(launch)} edit {shlex.quote(str(path))} --engine rules")

    def tmux(*args):
        return subprocess.run(["tmux", "-L", sock, *args], capture_output=True, text=True, timeout=30).stdout

    tmux("new-session", "-d", "-s", "b", "-x", "80", "-y", "24", cmd)
    try:
        deadline = time.monotonic() + 60
        while "utterance 1" not in tmux("capture-pane", "-p", "-t", "b") and time.monotonic() < deadline:
            time.sleep(0.2)
        pid = int(tmux("display-message", "-p", "-t", "b", "#{pane_pid}").strip())
        time.sleep(1.0)

        def measure() -> float:
            c0, t0 = _proc_cpu(pid), time.monotonic()
            time.sleep(seconds)
            return (_proc_cpu(pid) - c0) / (time.monotonic() - t0)

        paused = measure()
        tmux("send-keys", "-t", "b", "F5")
        time.sleep(0.3)
        playing = measure()
        return playing, paused
    finally:
        tmux("kill-server")


async def _headless_cpu(seconds: float) -> tuple[float, float]:
    from sgt_tui.app.main import EditorApp
    from sgt_tui.editor.files import ScriptFile

    tmp = Path(tempfile.mkdtemp())
    path = tmp / "play.sgt"
    path.write_text(ten_second_utterance() + "\n")
    app = EditorApp(ScriptFile.open(path), engine="rules", cursor_blink=False)
    async with app.run_test(size=(80, 24)) as pilot:
        await pilot.pause(0.5)

        async def measure() -> float:
            c0, t0 = time.process_time(), time.monotonic()
            await asyncio.sleep(seconds)
            return (time.process_time() - c0) / (time.monotonic() - t0)

        paused = await measure()
        await pilot.press("f5")
        playing = await measure()
    return playing, paused


class _Terminal:
    """`sgt edit FILE` of one source tree in a tmux terminal of its own (100x30)."""

    def __init__(self, tree: Path, path: Path, cache: Path) -> None:
        self.sock = f"sgt-bench-{os.getpid()}-{time.monotonic_ns()}"
        launch = "import sys; from sgt_tui.cli import main; sys.exit(main())"
        self.cmd = (f"cd {shlex.quote(str(tree))} && PYTHONPATH={shlex.quote(str(tree))} "
                    f"SGT_EDITOR_CACHE={shlex.quote(str(cache))} TERM=xterm-256color exec "
                    f"{shlex.quote(sys.executable)} -c {shlex.quote(launch)} edit {shlex.quote(str(path))} --engine rules")

    def tmux(self, *args: str) -> str:
        return subprocess.run(["tmux", "-L", self.sock, *args], capture_output=True, text=True, timeout=30).stdout

    def start(self) -> float:
        t = time.perf_counter()
        self.tmux("new-session", "-d", "-s", "b", "-x", "100", "-y", "30", self.cmd)
        return t

    def screen(self) -> str:
        return self.tmux("capture-pane", "-p", "-t", "b")

    def wait(self, test, timeout: float = 600.0) -> float:
        """Poll the screen until ``test(screen)``; the time it first held."""
        deadline = time.perf_counter() + timeout
        while time.perf_counter() < deadline:
            if test(self.screen()):
                return time.perf_counter()
        raise SystemExit(f"timed out; the screen shows:\n{self.screen()}")

    def close(self) -> None:
        self.tmux("kill-server")


def _status(screen: str) -> str:
    return screen.split("\n", 1)[0]


def _analysed(screen: str) -> bool:  # the status line has the problem count (and the utterance)
    return "utt 1/" in _status(screen)


def _type_and_time(term: _Terminal, marker: str, interval: float) -> list[float]:
    """Type ``marker`` one key at a time at the start of line 4 (utterance 1); each key's time
    from send-keys until the terminal shows it."""
    out = []
    for k in range(1, len(marker) + 1):
        t = time.perf_counter()
        term.tmux("send-keys", "-t", "b", "-l", marker[k - 1])
        shown = marker[:k] + "guide:"
        out.append(term.wait(lambda s: shown in s, timeout=60) - t)
        time.sleep(max(0.0, interval - (time.perf_counter() - t)))
    return out


def large_script(before: str | None, lines: int, repeat: int, keys: int) -> None:
    from against import trees
    from bench_check import make_script

    if not shutil.which("tmux"):
        print("large script: tmux is not installed; skipped")
        return
    tmp = Path(tempfile.mkdtemp())
    big, small = tmp / "long.sgt", tmp / "short.sgt"
    big.write_text(make_script(lines))
    small.write_text("guide: Hello there.\n")
    size = big.stat().st_size
    print(f"long script: {lines} lines, {size / 1e6:.1f} MB; load before: {os.getloadavg()[0]:.2f}")
    rows = []
    with trees(before) as measured:
        for label, tree in measured:
            firsts = {"short": [], "long": []}
            analysed, during, after = [], [], []
            for i in range(repeat):
                for kind, path in (("short", small), ("long", big)):
                    term = _Terminal(tree, path, tmp / f"cache-{label[:3]}-{kind}-{i}")
                    try:
                        t0 = term.start()
                        shown = term.wait(lambda s: "engine rules" in _status(s))
                        firsts[kind].append(shown - t0)
                        if kind == "short":
                            continue
                        if i == 0 and not _analysed(term.screen()):  # typing while the first analysis runs
                            term.tmux("send-keys", "-t", "b", "Down", "Down", "Down", "Home")
                            time.sleep(0.3)
                            during = _type_and_time(term, "qz" * (keys // 2), 0.15)
                            term.tmux("send-keys", "-t", "b", *["BSpace"] * len(during))
                        analysed.append(term.wait(_analysed) - t0)
                        if i == 0:
                            if not during:
                                term.tmux("send-keys", "-t", "b", "Down", "Down", "Down", "Home")
                            time.sleep(1.0)
                            after = _type_and_time(term, "xj" * (keys // 2), 0.15)
                    finally:
                        term.close()
            rows.append((label, firsts, analysed, during, after))
    print(f"{'':<22} {'first screen, short':>20} {'first screen, 1 MB':>19} {'analysis shown':>15} "
          f"{'key->screen (analysing)':>24} {'key->screen':>22}")
    for label, firsts, analysed, during, after in rows:
        def med(v):
            return f"{statistics.median(v):.2f} s" if v else "-"

        def lat(v):
            return f"{statistics.median(v) * 1000:.0f} ms (max {max(v) * 1000:.0f})" if v else "- (no screen yet)"
        print(f"{label:<22} {med(firsts['short']):>20} {med(firsts['long']):>19} {med(analysed):>15} "
              f"{lat(during):>24} {lat(after):>22}")
    print(f"(medians of {repeat} starts; key->screen: {keys} keys, median and max; load after: {os.getloadavg()[0]:.2f})")


def main() -> int:
    from against import add_before_option

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lines", type=int, default=500)
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--seconds", type=float, default=4.0, help="how long to measure CPU use")
    ap.add_argument("--large-lines", type=int, default=10_000, help="lines of the long script (10,000: 1.1 MB)")
    ap.add_argument("--large-repeat", type=int, default=3, help="starts of each script per tree")
    ap.add_argument("--keys", type=int, default=30, help="keys typed to time keystroke to screen")
    ap.add_argument("--large-only", action="store_true", help="only the long script, side by side")
    add_before_option(ap)
    args = ap.parse_args()
    if not args.large_only:
        keystroke(args.lines, args.repeat)
        regenerate(max(3, args.repeat // 3))
        cpu_while_playing(args.seconds)
    large_script(args.before, args.large_lines, args.large_repeat, args.keys)
    return 0


if __name__ == "__main__":
    sys.exit(main())
