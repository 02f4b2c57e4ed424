"""Benchmark: sgt serve under load, and the streaming engine's latency and motion.

    python benchmarks/bench_serve.py [--clients 8] [--seconds 60] [--workers 2] [--stream-only]
    python benchmarks/bench_serve.py --load-only [--before 742c655] [--rounds 2]

Starts `sgt serve` on 127.0.0.1 (a free port, loopback only) in its own process and prints
1. load: CLIENTS concurrent clients for SECONDS, each posting one 5 s utterance after another
   (plain text, real espeak-ng speech timing, the default engine; 16 sentences in turn, so the
   speech cache warms up as a game's dialogue would): latency p50/p95/p99, throughput, errors
   (anything but 200), the server's CPU per request (the CPU time of the server and its
   children, the speech engine's, over the load, divided by the requests) and its memory (RSS)
   at the start and the end. With ``--before
   REV`` (default 742c655, the code before issue 21; ``none``: today's only) the same load runs
   against a server of that revision too (benchmarks/against.py), the two alternating
   ``--rounds`` times, each server with its own fresh speech cache, so that both see the same
   machine; goal: p95 at most 150 ms with 0 errors at 8 clients, at most 30 ms of CPU a request;
2. streaming: the stated lookahead and the measured one (time advancing frame by frame, each
   word sent when it starts: how far the known speech runs ahead of the last decided frame
   after each message), the compute per network call (median, p99), and how the stream's
   motion compares with the offline engine on the same words (mean angle per bone, speed and
   jerk ratios); then the same for the matching engine's stream (model/matching_stream.py)
   against the offline matching engine, on the words alone and on espeak-ng's audio in 0.2 s
   chunks, with the offline engine's take of another seed as the yardstick (``--engine
   matching`` in ``--stream-only``: that part alone).
The load is bounded in count (CLIENTS threads) and in time (SECONDS), and never leaves the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))  # against.py, also when a test loads this file

from against import add_before_option, trees  # noqa: E402

SENTENCES = [
    "Welcome to the mall! The shops you want are over there, past the fountain.",
    "Good morning everyone, today we will talk about how robots learn to move.",
    "I am sorry, I did not catch that. Could you say it again a little slower?",
    "The food court is upstairs, next to the cinema and the big bookshop.",
    "Please follow me, I will show you the way to the information desk.",
    "Our museum opens at nine and closes at six, every day except Monday.",
    "This painting was made in the sixteenth century by an unknown artist.",
    "You can pay at any counter, or use the machines near the exit doors.",
    "Thank you for waiting. Your table is ready, please come this way now.",
    "On the left you can see the old harbour, where the ships used to land.",
    "If you need help, just wave at me or press the green button on my chest.",
    "The next train to the airport leaves from platform four in ten minutes.",
    "Let me think about that for a second, it is a very good question.",
    "Three things matter here: the speed, the size and the hand you use.",
    "Lunch is served in the garden today, because the weather is so nice.",
    "Goodbye, and have a wonderful afternoon. Come back and see us soon!",
]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """`sgt serve` in a child process on 127.0.0.1; stopped with SIGINT on exit."""

    def __init__(self, *args: str, env: dict | None = None, tree: Path = ROOT) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.proc = subprocess.Popen([sys.executable, "-m", "sgt_tui.cli", "serve", "--port", str(self.port), *args],
                                     cwd=tree, env={**os.environ, "PYTHONPATH": str(tree), **(env or {})},
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def __enter__(self) -> "Server":
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"sgt serve exited with {self.proc.returncode}: {self.proc.stderr.read()}")
            try:
                with urllib.request.urlopen(self.url + "/healthz", timeout=2) as r:
                    if r.status == 200:
                        return self
            except (OSError, urllib.error.URLError):
                time.sleep(0.2)
        self.stop()
        raise RuntimeError("sgt serve did not answer /healthz within 120 s")

    def rss_mb(self) -> float:
        for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
        return float("nan")

    def cpu_s(self) -> float:
        """CPU seconds (user and system) the server has used so far: its own, its finished
        children's and its running children's (the speech engine's), from /proc."""
        tick = os.sysconf("SC_CLK_TCK")
        stats = {}
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
            except OSError:  # gone meanwhile
                continue
            stats[int(stat.parent.name)] = fields
        total, todo = 0, [self.proc.pid]
        while todo:
            pid = todo.pop()
            fields = stats.get(pid)
            if fields is None:
                continue
            total += sum(int(x) for x in fields[11:15])  # utime stime cutime cstime
            todo += [child for child, f in stats.items() if int(f[1]) == pid]
        return total / tick

    def stop(self) -> tuple[int, str]:
        if self.proc.poll() is None:
            self.proc.send_signal(2)  # SIGINT: uvicorn shuts down gracefully
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode, self.proc.stderr.read()

    def __exit__(self, *exc) -> None:
        self.stop()


def post(url: str, body: dict, timeout: float = 60.0) -> tuple[int, float]:
    """(status, seconds) of one POST; a refused connection is status 0."""
    req = urllib.request.Request(url, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"})
    t = time.perf_counter()
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            r.read()
            status = r.status
    except urllib.error.HTTPError as e:
        status = e.code
    except (OSError, urllib.error.URLError):
        status = 0
    return status, time.perf_counter() - t


def load(url: str, clients: int, seconds: float, max_requests: int = 100_000) -> dict:
    """``clients`` threads posting 5 s utterances for ``seconds`` (at most ``max_requests`` in all)."""
    results: list[tuple[int, float]] = []
    lock = threading.Lock()
    stop_at = time.monotonic() + seconds

    def client(k: int) -> None:
        n = k
        while time.monotonic() < stop_at:
            with lock:
                if len(results) >= max_requests:
                    return
            body = {"text": SENTENCES[n % len(SENTENCES)], "seed": n % 100}
            out = post(url + "/v1/generate", body)
            with lock:
                results.append(out)
            n += clients

    started = time.monotonic()
    threads = [threading.Thread(target=client, args=(k,)) for k in range(clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.monotonic() - started
    ok = sorted(s for status, s in results if status == 200)
    q = statistics.quantiles(ok, n=100) if len(ok) >= 2 else [float("nan")] * 99
    return {"requests": len(results), "ok": len(ok), "errors": len(results) - len(ok), "wall_s": wall,
            "throughput": len(ok) / wall, "p50": q[49], "p95": q[94], "p99": q[98],
            "statuses": sorted({status for status, _ in results})}


def stream_figures() -> None:
    import numpy as np

    from core.controls import ControlArrays
    from core.skeleton import FPS
    from dsl import compile_text
    from model import neural, postprocess
    from model.features import AUDIO_DIM, word_features
    from model.runtime import load_runner
    from model.streaming import LOOKAHEAD_S, StreamGenerator

    runner = load_runner(None)
    lags, calls, angles, speed, jerk = [], [], [], [], []
    for n, text in enumerate(SENTENCES):
        words = list(compile_text(f"guide: {text}", timing="estimate").plan.utterances[0].words)
        stream = _feed_frame_by_frame(StreamGenerator(runner, seed=n), words, lags, calls)
        m = len(stream)
        ids, onsets = word_features(words, m)
        offline = postprocess.calm_pauses(postprocess.one_euro(neural.network_motion(
            runner, np.zeros((m, AUDIO_DIM), np.float32), ids, onsets, ControlArrays.empty(m), n, words=words)), words)
        angle, fast, jerky = _compare(stream, offline)
        angles.append(angle)
        speed.append(fast)
        jerk.append(jerky)
    per_frame = sorted(s / k for s, k in calls if k)
    print(f"streaming ({runner.kind}): stated lookahead {LOOKAHEAD_S:.3f} s; measured: after each of {len(lags)} messages "
          f"(time advancing a frame at a time, each word sent when it starts) the last decided frame is "
          f"{min(lags):.3f}-{max(lags):.3f} s behind the known speech (the frame grid adds < 1/{FPS} s)")
    print(f"  compute per decided frame (one network call): median {statistics.median(per_frame) * 1000:.2f} ms, "
          f"p99 {per_frame[int(0.99 * (len(per_frame) - 1))] * 1000:.2f} ms (n={len(per_frame)})")
    print(f"  vs the offline engine on the same words ({len(SENTENCES)} sentences): mean angle per bone "
          f"{statistics.mean(angles):.1f} deg, speed x{statistics.mean(speed):.2f}, jerk x{statistics.mean(jerk):.2f}")
    audio_stream_figures(runner)


def matching_stream_figures() -> None:
    """The matching engine's stream (model/matching_stream.py) as :func:`stream_figures` measures
    the network's: the lag after each message and the compute per decided frame (time advancing
    a frame at a time), then its motion against the offline matching engine (``matching.match``
    and ``matching.finish``, its take drawn with the same seed, the pauses held) on the same words,
    and on espeak-ng's audio in 0.2 s chunks with the words that start in each; the offline
    engine's take of another seed (seed + 100) against the same offline take is the yardstick."""
    import numpy as np

    from core.controls import ControlArrays
    from dsl import compile_text
    from dsl.speech.audio import read_wav, resample_poly
    from model import matching, postprocess
    from model.features import SAMPLE_RATE, audio_features, silence_features, word_features
    from model.matching_stream import MatchingStreamGenerator
    from model.streaming import LOOKAHEAD_S

    db = matching.load()

    def offline(features, words, seed, m):
        ids, onsets = word_features(words, m)
        arrays = ControlArrays.empty(m)
        raw = matching.match(db, features, ids, onsets, arrays, seed, matching.draw_take(db, seed), None,
                             postprocess.pause_frames(words, m))
        return matching.finish(raw, arrays, words=words)

    lags, calls, rows = [], [], {"words": [], "audio": [], "yardstick": []}
    for n, text in enumerate(SENTENCES):
        words = list(compile_text(f"guide: {text}", timing="estimate").plan.utterances[0].words)
        stream = _feed_frame_by_frame(MatchingStreamGenerator(db, seed=n), words, lags, calls)
        m = len(stream)
        off = offline(silence_features(m), words, n, m)
        rows["words"].append(_compare(stream, off))
        rows["yardstick"].append(_compare(offline(silence_features(m), words, n + 100, m), off))
        # with the speech audio, in 0.2 s chunks
        u = compile_text(f"guide: {text}").plan.utterances[0]
        data, rate = read_wav(u.audio_path)
        x, words = data[:, 0], list(u.words)
        stream = _feed_audio(MatchingStreamGenerator(db, seed=n), x, rate, words, [])
        m = len(stream)
        audio16 = resample_poly(x, SAMPLE_RATE, rate).astype(np.float32)
        rows["audio"].append(_compare(stream, offline(audio_features(audio16, m), words, n, m)))
    per_frame = sorted(s / k for s, k in calls if k)
    print(f"matching stream: stated lookahead {LOOKAHEAD_S:.3f} s; measured: after each of {len(lags)} messages the last "
          f"decided frame is {min(lags):.3f}-{max(lags):.3f} s behind the known speech")
    print(f"  compute per decided frame (a search every 12 frames): median {statistics.median(per_frame) * 1000:.2f} ms, "
          f"mean {statistics.mean(per_frame) * 1000:.2f} ms, p99 {per_frame[int(0.99 * (len(per_frame) - 1))] * 1000:.2f} ms, "
          f"max {per_frame[-1] * 1000:.2f} ms (n={len(per_frame)})")
    for name, label in (("words", "the words alone"), ("audio", "espeak-ng's audio in 0.2 s chunks"),
                        ("yardstick", "(yardstick) the offline engine's take of another seed")):
        angle, speed, jerk = (statistics.mean(r[i] for r in rows[name]) for i in range(3))
        print(f"  {label} vs the offline matching engine ({len(SENTENCES)} sentences): mean angle per bone "
              f"{angle:.1f} deg, speed x{speed:.2f}, jerk x{jerk:.2f}")


def _feed_frame_by_frame(gen, words, lags: list, calls: list):
    """Feed ``words`` to the stream ``gen`` as a TTS says them (each word when it starts), time
    advancing one frame at a time; appends to ``lags`` how far the known speech runs ahead of
    the last decided frame after each message, and to ``calls`` (seconds, frames decided) per
    message. Returns every frame, the rest after ``finish``."""
    import numpy as np

    from core.skeleton import FPS

    pending, frames, emitted = list(words), [], 0
    for k in range(1, int(words[-1].end * FPS) + 2):
        t = k / FPS
        starting = [w for w in pending if w.start <= t]
        pending = pending[len(starting):]
        t0 = time.perf_counter()
        got = [gen.add_words(starting)] if starting else []
        got.append(gen.known_until(t))
        calls.append((time.perf_counter() - t0, sum(map(len, got))))
        emitted += sum(map(len, got))
        frames += got
        if emitted:
            lags.append(gen.known - (emitted - 1) / FPS)
    frames.append(gen.finish())
    return np.concatenate(frames)


def _feed_audio(gen, x, rate: int, words, per_chunk: list):
    """Feed the speech ``x`` (at ``rate``) to the stream ``gen`` in 0.2 s chunks, each with the
    words that start in it; appends the seconds of each chunk's calls to ``per_chunk``."""
    import numpy as np

    from dsl.speech.audio import StreamResampler
    from model.features import SAMPLE_RATE

    resampler, out, pending = StreamResampler(rate, SAMPLE_RATE), [gen.add_audio(np.zeros(0, np.float32))], list(words)
    step = int(0.2 * rate)
    for at in range(0, len(x), step):
        end = min(len(x), at + step) / rate
        starting = [w for w in pending if w.start < end]
        pending = pending[len(starting):]
        t0 = time.perf_counter()
        if starting:
            out.append(gen.add_words(starting))
        out.append(gen.add_audio(resampler.push(x[at : at + step])))
        out.append(gen.known_until(end))
        per_chunk.append(time.perf_counter() - t0)
    out += [gen.add_audio(resampler.flush()), gen.finish()]
    return np.concatenate(out)


def _compare(stream, offline) -> tuple[float, float, float]:
    """Mean angle per bone (degrees), speed and jerk ratios of ``stream`` against ``offline``."""
    import numpy as np

    a, b = stream.reshape(-1, 9, 3), offline.reshape(-1, 9, 3)
    angle = float(np.degrees(np.arccos(np.clip((a * b).sum(-1), -1, 1))).mean())
    speed = np.abs(np.diff(stream, axis=0)).mean() / np.abs(np.diff(offline, axis=0)).mean()
    jerk = np.abs(np.diff(stream, 3, axis=0)).mean() / np.abs(np.diff(offline, 3, axis=0)).mean()
    return angle, float(speed), float(jerk)


def audio_stream_figures(runner) -> None:
    """The stream fed espeak-ng's audio in 0.2 s chunks at 22.05 kHz (each with the words that
    start in it) against the offline engine on the same audio and words, and against the
    stream of the words alone; the compute per audio chunk."""
    import numpy as np

    from core.controls import ControlArrays
    from dsl import compile_text
    from dsl.speech.audio import read_wav, resample_poly
    from model import neural, postprocess
    from model.features import SAMPLE_RATE, audio_features, word_features
    from model.streaming import StreamGenerator

    with_audio, words_only, per_chunk = [], [], []
    for n, text in enumerate(SENTENCES):
        u = compile_text(f"guide: {text}").plan.utterances[0]
        data, rate = read_wav(u.audio_path)
        x = data[:, 0]
        words = list(u.words)  # on the audio's clock (the audio starts at the first frame here)
        stream = _feed_audio(StreamGenerator(runner, seed=n), x, rate, words, per_chunk)
        m = len(stream)
        audio16 = resample_poly(x, SAMPLE_RATE, rate).astype(np.float32)
        ids, onsets = word_features(words, m)
        offline = postprocess.calm_pauses(postprocess.one_euro(neural.network_motion(
            runner, audio_features(audio16, m), ids, onsets, ControlArrays.empty(m), n, words=words)), words)
        with_audio.append(_compare(stream, offline))
        words_gen = StreamGenerator(runner, seed=n)
        alone = np.concatenate([words_gen.add_words(words), words_gen.finish()])
        k = min(len(alone), m)
        words_only.append(_compare(alone[:k], offline[:k]))
    for name, rows in (("with its audio", with_audio), ("of the words alone", words_only)):
        angle, speed, jerk = (statistics.mean(r[i] for r in rows) for i in range(3))
        print(f"  stream {name} vs the offline engine on the same audio ({len(SENTENCES)} espeak-ng sentences, "
              f"0.2 s chunks at 22.05 kHz): mean angle per bone {angle:.1f} deg, speed x{speed:.2f}, jerk x{jerk:.2f}")
    per_chunk.sort()
    print(f"  compute per 0.2 s audio chunk (resampling, features, the frames it decides): median "
          f"{statistics.median(per_chunk) * 1000:.1f} ms, p99 {per_chunk[int(0.99 * (len(per_chunk) - 1))] * 1000:.1f} ms "
          f"(n={len(per_chunk)})")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clients", type=int, default=8)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--stream-only", action="store_true")
    ap.add_argument("--engine", choices=("all", "neural", "matching"), default="all",
                    help="the streams measured (default: both)")
    ap.add_argument("--load-only", action="store_true", help="skip the streaming figures")
    ap.add_argument("--rounds", type=int, default=1, help="load runs per tree, alternating (default 1)")
    add_before_option(ap)
    args = ap.parse_args()
    if not args.load_only:
        if args.engine != "matching":
            stream_figures()
        if args.engine != "neural":
            matching_stream_figures()
    if args.stream_only:
        return 0
    import tempfile

    print(f"load: {args.clients} clients x {args.seconds:g} s, 5 s utterances, {args.workers} workers; "
          f"load average before {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    with trees(args.before) as measured, tempfile.TemporaryDirectory() as tmp:
        runs: dict[str, list[dict]] = {label: [] for label, _ in measured}
        for r in range(args.rounds):
            for k, (label, tree) in enumerate(measured):
                cache = Path(tmp) / f"cache{r}-{k}"  # each server warms its own speech cache, as a fresh one would
                with Server("--workers", str(args.workers), "--queue", str(2 * args.clients), tree=tree,
                            env={"SGT_CACHE_DIR": str(cache)}) as server:
                    post(server.url + "/v1/generate", {"text": SENTENCES[0]})  # one warm-up request
                    rss_start, cpu_start = server.rss_mb(), server.cpu_s()
                    res = load(server.url, args.clients, args.seconds)
                    res["rss"] = (rss_start, server.rss_mb())
                    res["cpu_ms"] = 1000 * (server.cpu_s() - cpu_start) / max(1, res["requests"])
                runs[label].append(res)
                print(f"  {label:16s} round {r + 1}: {res['requests']} requests, {res['errors']} errors (statuses "
                      f"{res['statuses']}), {res['throughput']:.1f}/s; latency p50 {res['p50'] * 1000:.0f} ms, "
                      f"p95 {res['p95'] * 1000:.0f} ms, p99 {res['p99'] * 1000:.0f} ms; server CPU "
                      f"{res['cpu_ms']:.1f} ms per request; server RSS "
                      f"{res['rss'][0]:.0f} -> {res['rss'][1]:.0f} MiB", flush=True)
    p95 = {label: statistics.median(r["p95"] for r in rs) for label, rs in runs.items()}
    for label, rs in runs.items():
        errors = sum(r["errors"] for r in rs)
        cpu = statistics.median(r["cpu_ms"] for r in rs)
        print(f"{label}: p95 {p95[label] * 1000:.0f} ms (median of {len(rs)} rounds), {errors} errors, "
              f"server CPU {cpu:.1f} ms per request{' -> ok' if p95[label] <= 0.15 and cpu <= 30 and not errors else ''}")
    if len(p95) == 2:
        before, now = p95.values()
        print(f"now / before (p95): {now / before:.2f} ({before / now:.1f}x faster); load average after "
              f"{os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
