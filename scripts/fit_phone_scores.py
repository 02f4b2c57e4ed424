"""Fit dsl/speech/phone_fit.json: how well each phone of a correct transcript fits its audio.

The transcript check of recordings (``dsl/speech/align.py``, :func:`poor_fits`) rejects a word
whose phones fit the recording far worse than the same phones usually do. "Usually" is this
table: per ARPAbet phone, the median and the spread (standard deviation + 0.3) of its
relative score (:func:`dsl.speech.align.relative_scores`: the phone's acoustic score per frame
over the recording's median word's) in correct transcripts.

The recordings it is fitted on are made as ``tests/recordings.py`` makes the test corpus (gaps
of silence and room noise, breaths, clicks, 8-48 kHz, mono/stereo, WAV/FLAC/MP3), from other
recipes (seeds 1000 on) and other sentences (:data:`FIT_SENTENCES`, none of the corpus's),
spoken by the synthetic voices only (espeak-ng and Festival): the corpus's human recordings
and sentences stay unseen, so ``benchmarks/bench_timing.py --corpus`` measures the check on
what it was not fitted to.

    python scripts/fit_phone_scores.py [--recordings 48] [--jobs 2]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import recordings as R  # noqa: E402  (tests/recordings.py)

FIT_SENTENCES = [
    "The little boat drifted slowly across the lake.",
    "Please bring me a cup of tea with some milk.",
    "Our neighbours painted their fence bright yellow.",
    "The museum opens at nine on Saturday mornings.",
    "Every winter the birds fly south to warmer places.",
    "He forgot his umbrella on the crowded bus.",
    "Could you show me the way to the station?",
    "The children laughed at the clever puppet show.",
    "A strong wind blew the papers off the desk.",
    "She plays the violin in the city orchestra.",
    "We found an old map in the attic yesterday.",
    "The baker sells fresh bread before sunrise.",
    "Turn off the lights when you leave the office.",
    "My grandfather grew tomatoes behind the barn.",
    "The train to Boston was delayed by an hour.",
    "Somebody left a note under the front door.",
]
SPREAD_FLOOR = 0.3  # added to each phone's standard deviation: a floor for phones that vary little
MIN_COUNT = 5  # phones seen fewer times are left out (the check uses the median phone for them)
FIRST = 1000  # the recipes' numbers (tests/recordings.spec_of): the test corpus uses 0-71


def _spec(i: int) -> dict:
    """Recipe ``i`` of tests/recordings.py with :data:`FIT_SENTENCES`, a synthetic voice in
    place of a human speaker."""
    voices = [s for s in R.SPEAKERS if ":" in s]
    out = R.spec_of(i, FIT_SENTENCES)
    return out if ":" in out["speaker"] else dict(out, speaker=voices[i % len(voices)])


def _scores(args) -> list[tuple[str, float]]:
    """(phone, relative score) of every phone of recording ``i``'s correct transcript."""
    i, folder = args
    from dsl.speech import align as A
    from dsl.speech.recording import read_audio

    rec = R.make_recording(i, Path(folder), R.Sources(Path(folder) / "sources", FIT_SENTENCES), _spec(i))
    samples, sr = read_audio(rec.path)
    _, phones = A._Aligner().align(A.aligner_input(samples, sr).pcm, R.words_of(rec.text))
    out = []
    for word in A.relative_scores(phones or []):
        out += word or []
    return out


def main(argv=None) -> int:
    import json
    from multiprocessing import Pool

    from core.fileio import atomic_write_text, json_text
    from dsl.speech.align import PHONE_FIT_FILE

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--recordings", type=int, default=48, help="recordings to fit on (default 48)")
    ap.add_argument("--jobs", type=int, default=2, help="recordings aligned at a time (default 2)")
    ap.add_argument("-o", "--output", default=str(PHONE_FIT_FILE), help=f"default {PHONE_FIT_FILE}")
    args = ap.parse_args(argv)
    why = R.available()
    if why:
        print(f"fit_phone_scores: {why}", file=sys.stderr)
        return 1
    with tempfile.TemporaryDirectory() as tmp, Pool(args.jobs) as pool:
        found = pool.map(_scores, [(FIRST + i, tmp) for i in range(args.recordings)], chunksize=1)
    by_phone: dict[str, list[float]] = {}
    for rows in found:
        for phone, r in rows:
            by_phone.setdefault(phone, []).append(r)
    phones = {p: {"median": round(float(np.median(v)), 4), "spread": round(float(np.std(v)) + SPREAD_FLOOR, 4),
                  "count": len(v)} for p, v in sorted(by_phone.items()) if len(v) >= MIN_COUNT}
    doc = {"made_by": "python scripts/fit_phone_scores.py", "recordings": args.recordings,
           "voices": "espeak-ng and Festival (tests/recordings.py recipes 1000 on, FIT_SENTENCES)",
           "spread": f"standard deviation + {SPREAD_FLOOR}", "phones": phones}
    atomic_write_text(args.output, json_text(doc, indent=1) + "\n")
    n = sum(len(rows) for rows in found)
    print(f"wrote {args.output}: {len(phones)} phones from {n} phone alignments in {args.recordings} recordings")
    print(json.dumps({p: (v["median"], v["spread"]) for p, v in phones.items()}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
