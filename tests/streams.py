"""Helpers for the tests of the streams (model/streaming.py, model/matching_stream.py)."""

from __future__ import annotations

from core.skeleton import FPS
from model.streaming import LOOKAHEAD_S


def assert_each_frame_waits_for_its_lookahead(gen, words) -> int:
    """A TTS says each word (with its end) when it starts; time advances one frame at a time.
    Every frame of the stream ``gen`` needs the speech known exactly LOOKAHEAD_S past it: it is
    emitted by the first message after which that much is known, never before. Returns the
    frames emitted."""
    pending = list(words)
    emitted = 0
    for k in range(1, int(words[-1].end * FPS) + 30):
        t = k / FPS
        before = gen.known
        starting = [w for w in pending if w.start <= t]
        pending = pending[len(starting):]
        frames = [gen.add_words(starting)] if starting else []
        frames.append(gen.known_until(t))
        for i in range(sum(map(len, frames))):
            frame_time = (emitted + i) / FPS
            assert before < frame_time + LOOKAHEAD_S - 1e-9 <= gen.known
        emitted += sum(map(len, frames))
    return emitted
