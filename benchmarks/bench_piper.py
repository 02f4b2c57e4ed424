"""Check: the natural voice (@voice joe, piper) against the forced aligner, and its speed.

    python benchmarks/bench_piper.py [--voices joe en-us]

1. Word onsets: 20 sentences synthesized with each voice; every word's start as the engine
   gives it (piper: the model's phoneme alignments; espeak-ng: its word events) against the
   start the project's forced aligner (pocketsphinx, ``dsl.speech.align.align_words``, what
   ``sgt align`` runs) finds in the same audio: median, 90th percentile and largest
   difference (ms), over the words the aligner places (its first mismatch, if any, ends a
   sentence's count).
2. Speed: seconds of synthesis per second of speech (real-time factor) with a cold speech
   cache, the worker already started (piper runs onnxruntime on one thread); and the worker's
   start (loading the voice's model) once.
"""

from __future__ import annotations

import argparse
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_face import SENTENCES as FACE_SENTENCES  # benchmarks/ is the script's folder

#: bench_face's eight sentences (bilabials, labiodentals, rounded and open vowels) and more of
#: a guide's and a host's lines, 20 in all
SENTENCES = FACE_SENTENCES + [
    "The shoe store is on your left, just past the fountain.",
    "Could you tell me where the nearest train station is?",
    "We opened the new wing of the museum in the spring.",
    "Turn right at the corner and walk for two blocks.",
    "Thank you so much for coming to see us this evening.",
    "The weather should be sunny and warm for the rest of the week.",
    "Remember to bring your ticket and a photo card.",
    "Our team will answer every question after the talk.",
    "She sells sea shells by the sea shore every summer.",
    "The elevator is behind you, next to the coffee shop.",
    "Let me show you how the machine works, step by step.",
    "Good morning, and welcome to the science center.",
]


def spans_of(text: str) -> list[tuple[int, int]]:
    return [(m.start(), m.end()) for m in re.finditer(r"[\w']+", text)]


def onsets(voice: str, cache: Path) -> None:
    from dsl.speech import synthesize
    from dsl.speech.align import align_words
    from dsl.speech.recording import read_audio

    diffs = []
    for text in SENTENCES:
        spans = spans_of(text)
        speech = synthesize(text, spans, voice=voice, cache_dir=cache)
        samples, sr = read_audio(speech.audio_path)
        times, mismatch = align_words(samples, sr, [text[a:b] for a, b in spans])
        upto = mismatch[0] if mismatch is not None else len(spans)
        diffs += [abs(w.start - t[0]) * 1000 for w, t in zip(speech.words[:upto], times[:upto])]
    p90 = float(np.percentile(diffs, 90))
    print(f"   {voice:6s} {len(diffs)} words: median {statistics.median(diffs):.1f} ms, "
          f"90th percentile {p90:.1f} ms, largest {max(diffs):.1f} ms")


def speed(voice: str, cache: Path) -> None:
    from dsl.speech import piper, synthesize

    if piper._server is not None:  # started by part 1: its start is measured here
        piper._server.stop()
        piper._server = None
    t0 = time.perf_counter()
    synthesize("Hello.", [(0, 5)], voice=voice, cache_dir=cache / "warm")
    start = time.perf_counter() - t0
    spent = spoken = 0.0
    for text in SENTENCES:
        t0 = time.perf_counter()
        speech = synthesize(text, spans_of(text), voice=voice, cache_dir=cache / "cold")
        spent += time.perf_counter() - t0
        spoken += speech.duration
    what = "worker start (model load)" if piper.voice_of(voice) else "first synthesis (fork server start)"
    print(f"   {voice:6s} {spoken:.1f} s of speech in {spent:.2f} s: real-time factor {spent / spoken:.3f}; "
          f"{what} {start:.2f} s")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--voices", nargs="+", default=["joe", "en-us"])
    args = ap.parse_args()
    print("1. word onsets: the engine's against the forced aligner's on the same audio")
    for voice in args.voices:
        onsets(voice, Path(tempfile.mkdtemp(prefix="sgt-piper-")))
    print("2. synthesis speed (cold speech cache)")
    for voice in args.voices:
        speed(voice, Path(tempfile.mkdtemp(prefix="sgt-piper-")))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
