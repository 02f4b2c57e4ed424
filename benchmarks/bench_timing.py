"""Check: are word times where the audio says they are? (issue 10, "timing that is true")

    python benchmarks/bench_timing.py [--rates 80 160 300] [--cache DIR]

Measured against an energy envelope computed here, independently of dsl/speech/audio.py
(10 ms Hann windows every 1 ms instead of 5 ms rectangular frames, a -40 dB threshold
relative to the loudest window instead of -34 dB, no shared code):

1. Synthesized speech (espeak-ng), a set of sentences at each rate: for every word, its
   *energy offset* is the end of the last window above the threshold between its start and
   the next word's start (the end of the audio for the last word). Prints, per rate, the
   median and max of |reported end - energy offset| in ms, and how many words end more
   than one frame (1/15 s) late.
2. ``[pause]`` mid-clause: the word before a pause must be over before the silence. Prints
   the energy (dB re. the loudest window) of the audio between the end of the inserted
   silence and the next word's start: anything above the threshold is audio of the previous
   word played after the pause.
3. Recorded speech (the sentences of 1 spoken by espeak-ng at @rate 130 and 200, padded with
   0.3 s of noise 60 dB under the speech, which also runs under it), aligned automatically:
   how far the first word's start is before the voice onset and the last word's end after the
   voice offset (ms), the voice measured on the clean audio.
4. Transcripts that do not match: each recording of 3, and the LibriVox sentences of
   pocketsphinx's test data when installed, aligned with its transcript, with a word added
   to it, and with a word left out (in the middle): how many are rejected as mismatches, and
   whether the word named is the one changed (or a neighbour).
5. Recordings with pauses (issue 27; ``--corpus``, or ``--corpus-only`` for just this part):
   the corpus of tests/recordings.py, 72 recordings made from the human speech Debian ships
   (pocketsphinx-testdata's LibriVox reader and "cards" speaker, the alsa-utils phrases) and
   from espeak-ng and Festival voices, 2-4 sentences each joined by 0.5-4 s of silence or room
   noise (-60 to -40 dBFS), with breaths and clicks in the gaps, leading and trailing
   silence, each sentence starting right at a gap's end, at 8-48 kHz, mono and stereo, WAV,
   FLAC and MP3. Each is aligned with its correct transcript and with one word added, dropped
   and changed: how many correct transcripts are rejected (the goal: none), how many wrong
   ones are rejected (and name the changed word or a neighbour), and how far the words start
   from their known onsets (every word of the synthetic voices, the first word of every human
   sentence; median, 90th percentile, ms). ``--jobs N`` aligns N recordings at a time.

Run it on another checkout (e.g. the commit before a change) with ``--root PATH`` to compare.
"""

from __future__ import annotations

import argparse
import re
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

SENTENCES = [
    "Well, hello there my friend. How are you today?",
    "The quick brown fox jumps over the lazy dog.",
    "Take your time. Enjoy your visit, and come back soon!",
    "I think that we should go now, before the rain starts.",
    "Please look at the shelf on your left; the apples are fresh.",
    "She sat in the garden in 1999, and I don't know why.",
    "Turn right at the fountain, then walk straight ahead.",
    "Nothing is lost. Everything is on the screen in front of you.",
]
PAUSES = [  # (text, the word the pause goes before)
    ("I think that we should go now.", "that"),
    ("Look at this map of the city.", "of"),
    ("The kitchen is just around the corner.", "around"),
    ("We can start whenever you are ready.", "whenever"),
]
LIBRIVOX = Path("/usr/share/pocketsphinx/test/data/librivox")
FRAME = 1 / 15
WIN_S, HOP_S, THRESH_DB = 0.010, 0.001, -40.0


def spans_of(text: str) -> list[tuple[int, int]]:
    return [m.span() for m in re.finditer(r"[\w'\-]+", text)]


def read_wav(path: Path) -> tuple[np.ndarray, int]:
    import soundfile as sf

    x, sr = sf.read(str(path), dtype="float64", always_2d=True)
    return x.mean(axis=1), sr


def envelope(x: np.ndarray, sr: int) -> tuple[np.ndarray, int, int]:
    """dB (re. the loudest window) of 10 ms Hann windows every 1 ms; window and hop in samples."""
    win, hop = int(round(WIN_S * sr)), int(round(HOP_S * sr))
    n = max(0, (len(x) - win) // hop + 1)
    w = np.hanning(win)
    frames = np.lib.stride_tricks.sliding_window_view(x, win)[::hop][:n]
    e = (frames * frames * w).sum(axis=1) / w.sum()
    db = 10 * np.log10(np.maximum(e, 1e-20))
    return db - db.max(), win, hop


def energy_offset(db, win, hop, sr, t0: float, t1: float) -> float | None:
    """End (s) of the last window above the threshold that starts at or after t0 - half a window
    and ends by t1 (so the next word's onset is not counted)."""
    c0 = int(np.ceil((t0 * sr - win / 2) / hop))
    c1 = int(np.floor((t1 * sr - win) / hop)) + 1
    c0, c1 = max(c0, 0), min(c1, len(db))
    idx = np.flatnonzero(db[c0:c1] > THRESH_DB)
    if len(idx) == 0:
        return None
    return ((c0 + idx[-1]) * hop + win / 2 + hop / 2) / sr


def energy_onset(db, win, hop, sr, t0: float = 0.0) -> float | None:
    c0 = max(0, int(np.ceil((t0 * sr - win / 2) / hop)))
    idx = np.flatnonzero(db[c0:] > THRESH_DB)
    return None if len(idx) == 0 else ((c0 + idx[0]) * hop + win / 2 - hop / 2) / sr


def word_ends(rates, cache: Path) -> None:
    from dsl.speech import synthesize

    print("1. word end - energy offset (ms), synthesized speech,"
          f" {len(SENTENCES)} sentences, {sum(len(spans_of(s)) for s in SENTENCES)} words")
    for rate in rates:
        errs, gap_errs, late = [], [], 0
        worst = ("", 0.0)
        for text in SENTENCES:
            spans = spans_of(text)
            s = synthesize(text, spans, rate=rate, cache_dir=cache)
            x, sr = read_wav(s.audio_path)
            db, win, hop = envelope(x, sr)
            for k, w in enumerate(s.words):
                t1 = s.words[k + 1].start if k + 1 < len(s.words) else s.duration
                off = energy_offset(db, win, hop, sr, w.start, max(t1, w.start + 1e-3))
                if off is None:
                    continue
                err = w.end - off
                errs.append(abs(err))
                if t1 - off > 0.02:  # a silence follows the word: its end is not the next start
                    gap_errs.append(abs(err))
                late += err > FRAME
                if abs(err) > abs(worst[1]):
                    worst = (w.word, err)
        print(f"   @rate {rate:3d}: median {1000 * statistics.median(errs):6.1f}  max {1000 * max(errs):6.1f}"
              f"  ({worst[0]!r} {1000 * worst[1]:+.0f}); before a silence: median"
              f" {1000 * statistics.median(gap_errs):6.1f} max {1000 * max(gap_errs):6.1f} ({len(gap_errs)} words);"
              f" > 1 frame late: {late}/{len(errs)}")


def pauses(cache: Path) -> None:
    from dsl.speech import synthesize

    print("2. audio between the end of a [pause 500ms] and the next word's start (dB re. loudest; "
          f"above {THRESH_DB:.0f} = the previous word leaks past the pause)")
    for text, before in PAUSES:
        spans = spans_of(text)
        k = next(i for i, (a, b) in enumerate(spans) if text[a:b] == before)
        s = synthesize(text, spans, [(spans[k][0], 0.5)], cache_dir=cache)
        x, sr = read_wav(s.audio_path)
        win, hop = int(round(WIN_S * sr)), int(round(HOP_S * sr))
        zeros = np.flatnonzero(x[: int(s.words[k].start * sr)] == 0)
        runs = np.split(zeros, np.flatnonzero(np.diff(zeros) > 1) + 1)
        run = max(runs, key=len)  # the inserted silence: the longest run of exact zeros
        a, b = (run[-1] + 1) / sr, s.words[k].start
        seg = x[run[-1] + 1: int(b * sr)]
        power = float((seg * seg).mean()) if len(seg) else 0.0
        level = 10 * np.log10(max(power, 1e-20) / _peak_power(x, win, hop))
        print(f"   {text!r} before {before!r}: {1000 * (b - a):5.1f} ms of audio, {level:6.1f} dB")


def _peak_power(x, win, hop) -> float:
    frames = np.lib.stride_tricks.sliding_window_view(x, win)[::hop]
    w = np.hanning(win)
    return float(((frames * frames * w).sum(axis=1) / w.sum()).max())


def recordings(recs, cache: Path) -> None:
    from dsl.speech import load_recording

    recs = [r for r in recs if r[2] is not None]
    print(f"3. recorded speech ({len(recs)} espeak-ng sentences with noise, see 4), aligned automatically: first"
          " word's start before the voice onset, last word's end after the voice offset (ms; the voice"
          " measured on the clean audio)")
    lead, tail = [], []
    for text, wav, (on, off) in recs:
        s = load_recording(wav, text, spans_of(text), cache_dir=cache)
        lead.append(on - s.words[0].start)
        tail.append(s.words[-1].end - off)
    print(f"   first start before voice: median {1000 * statistics.median(lead):4.0f} max {1000 * max(lead):4.0f}"
          f" min {1000 * min(lead):4.0f}; last end after voice: median {1000 * statistics.median(tail):4.0f}"
          f" max {1000 * max(tail):4.0f} min {1000 * min(tail):4.0f}")


EXTRA_WORDS = ["carriage", "really", "wonderful", "people", "yesterday"]


def _recordings(cache: Path, folder: Path) -> list[tuple[str, Path, tuple[float, float] | None]]:
    """(transcript, WAV, (voice onset, offset) s or None): the sentences spoken by espeak-ng at two rates, padded with 0.3 s of
    -60 dB noise on each side and with the noise under the speech (as a recording would be),
    and the LibriVox sentences when installed."""
    import soundfile as sf

    from dsl.speech import synthesize

    out = []
    rng = np.random.default_rng(0)
    for rate in (130, 200):
        for i, text in enumerate(SENTENCES):
            s = synthesize(text, spans_of(text), rate=rate, cache_dir=cache)
            x, sr = read_wav(s.audio_path)
            pad = np.zeros(int(0.3 * sr))
            y = np.concatenate([pad, x, pad])
            y = y + rng.normal(0, 10 ** (-60 / 20) * np.abs(x).max(), len(y))
            path = folder / f"espeak-{rate}-{i}.wav"
            sf.write(str(path), y, sr)
            db, win, hop = envelope(x, sr)
            truth = (0.3 + energy_onset(db, win, hop, sr), 0.3 + energy_offset(db, win, hop, sr, 0.0, len(x) / sr))
            out.append((text, path, truth))
    if (LIBRIVOX / "transcription").is_file():
        for line in (LIBRIVOX / "transcription").read_text().splitlines():
            m = re.match(r"<s> (.*) </s> \((.*)\)", line)
            if m:
                out.append((m.group(1), LIBRIVOX / f"{m.group(2)}.wav", None))
    return out


def mismatches(recs, cache: Path) -> None:
    from dsl.speech import SpeechError, load_recording

    print(f"4. transcripts against recordings ({len(recs)}: espeak-ng at @rate 130 and 200 with noise, LibriVox),"
          " aligned automatically:")
    rejected = {"right": 0, "a word added": 0, "a word left out": 0}
    total = dict.fromkeys(rejected, 0)
    named = dict.fromkeys(rejected, 0)
    for i, (text, wav, _) in enumerate(recs):
        words = [text[a:b] for a, b in spans_of(text)]
        k = len(words) // 2
        cases = [("right", words, None),
                 ("a word added", words[:k] + [EXTRA_WORDS[i % len(EXTRA_WORDS)]] + words[k:], k),
                 ("a word left out", words[:k] + words[k + 1:], k)]
        for kind, ws, at in cases:
            t = " ".join(ws)
            total[kind] += 1
            try:
                load_recording(wav, t, spans_of(t), cache_dir=cache)
            except SpeechError as e:
                if e.kind != "mismatch":
                    print(f"   {wav.name} {kind}: {e.message}")
                    continue
                rejected[kind] += 1
                named[kind] += at is not None and e.word_index is not None and abs(e.word_index - at) <= 1
                if kind == "right":
                    print(f"   wrongly rejected: {wav.name}: {e.reason}")
    for kind in rejected:
        extra = f", the word named within one of the change: {named[kind]}" if kind != "right" else ""
        print(f"   {kind:16s}: rejected {rejected[kind]}/{total[kind]}{extra}")


def _corpus_one(args):
    """Align one corpus recording with its transcript and the three wrong ones (in a worker)."""
    rec, index = args
    sys.path.insert(0, str(ROOT / "tests"))
    import recordings as R

    from dsl.speech import SpeechError, load_recording

    out = []
    with tempfile.TemporaryDirectory() as cache:
        for kind, text, at in [("correct", rec.text, None)] + R.wrong_transcripts(rec, index):
            try:
                s = load_recording(rec.path, text, R.spans_of(text), cache_dir=Path(cache))
            except SpeechError as e:
                out.append((kind, at, e.kind, e.word_index, e.message, None))
                continue
            onsets = [(w.start, o) for w, o in zip(s.words, rec.onsets) if o is not None] if kind == "correct" else []
            out.append((kind, at, None, None, "", onsets))
    return rec.name, out


def corpus(folder: Path, jobs: int) -> None:
    import time
    from multiprocessing import Pool

    sys.path.insert(0, str(ROOT / "tests"))
    import recordings as R

    why = R.available()
    if why:
        print(f"5. recordings with pauses: skipped ({why})")
        return
    t0 = time.perf_counter()
    recs = R.corpus(folder / "corpus")
    made = time.perf_counter() - t0
    t0 = time.perf_counter()
    with Pool(jobs) as pool:
        results = pool.map(_corpus_one, [(r, i) for i, r in enumerate(recs)], chunksize=1)
    took = time.perf_counter() - t0
    print(f"5. recordings with pauses: {len(recs)} recordings of tests/recordings.py ({made:.0f} s to make),"
          f" each with its correct transcript and one word added, dropped and changed ({took:.0f} s, {jobs} jobs):")
    kinds = ["correct", "added", "dropped", "changed"]
    rejected, named, failed = dict.fromkeys(kinds, 0), dict.fromkeys(kinds, 0), dict.fromkeys(kinds, 0)
    errors = []
    for name, out in results:
        for kind, at, ekind, index, message, onsets in out:
            if ekind is not None:
                rejected[kind] += 1
                failed[kind] += ekind != "mismatch"
                named[kind] += at is not None and index is not None and abs(index - at) <= 1
                if kind == "correct":
                    print(f"   wrongly rejected: {name}: {message}")
            elif kind != "correct":
                print(f"   accepted with a word {kind}: {name}")
            errors += [abs(start - onset) for start, onset in onsets or []]
    n = len(results)
    wrong = sum(rejected[k] for k in kinds[1:])
    print(f"   correct transcripts rejected: {rejected['correct']}/{n}")
    for kind in kinds[1:]:
        print(f"   a word {kind:8s}: rejected {rejected[kind]}/{n} ({failed[kind]} of them as an alignment failure),"
              f" the word named within one of the change: {named[kind]}")
    print(f"   wrong transcripts rejected: {wrong}/{3 * n} ({100 * wrong / (3 * n):.1f} %)")
    e = np.array(errors) * 1000
    print(f"   word start - known onset, {len(e)} words: median {np.median(e):.1f} ms, 90th percentile"
          f" {np.percentile(e, 90):.1f} ms, within 20 ms: {100 * np.mean(e <= 20):.0f} %")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rates", type=int, nargs="+", default=[80, 160, 300])
    ap.add_argument("--cache", type=Path, default=None, help="speech cache (default: a fresh temporary folder)")
    ap.add_argument("--quick", action="store_true", help="leave out 4 (the slowest: 63 alignments)")
    ap.add_argument("--root", type=Path, default=ROOT, help="checkout to measure (default: this one)")
    ap.add_argument("--corpus", action="store_true", help="also 5, the recordings with pauses (288 alignments)")
    ap.add_argument("--corpus-only", action="store_true", help="only 5")
    ap.add_argument("--jobs", type=int, default=2, help="recordings aligned at a time in 5 (default 2)")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(args.root))
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache or Path(tmp)
        if not args.corpus_only:
            word_ends(args.rates, cache)
            pauses(cache)
            recs = _recordings(cache, Path(tmp))
            recordings(recs, cache)
            if not args.quick:
                mismatches(recs, cache)
        if args.corpus or args.corpus_only:
            corpus(Path(tmp), max(1, args.jobs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
