"""Offline forced alignment of a transcript to audio with pocketsphinx 5 (bundled en-us model).

Pronunciations: words are looked up in the bundled CMU dictionary (lower case, curly
apostrophes straightened). Words that are not there get a pronunciation *built* for them:
numbers are spelled out, with alternative readings the aligner chooses from ("1999" ->
"nineteen ninety nine" | "nineteen hundred ninety nine" | "one thousand nine hundred ninety
nine"),
hyphenated words are joined from their parts, and anything else falls back to a crude
letter-to-phone guess (one ARPAbet phone per letter). The guess is poor phonetically but
lets the aligner absorb the word's audio, so its neighbours stay well timed.

Digital silence (as in synthesized speech) makes the aligner fail, so a small fixed-seed
dither (about -70 dBFS) is added before decoding; results are deterministic.
"""

from __future__ import annotations

import re

import numpy as np

from core.interrupts import import_optional

from . import audio
from .audio import resample_poly
from .types import SpeechError

FRAME_RATE = 100  # pocketsphinx frames per second (default -frate)
#: Word insertion "penalty" of the decode that may leave words out (>1: a bonus per word kept),
#: chosen on the 22 recordings of benchmarks/bench_timing.py (espeak-ng with noise, LibriVox,
#: tests' sentence): at 1 (no bonus) correct transcripts lose words the acoustic model hears
#: poorly ("How" after a sentence break, still lost at 10 in tests/test_speech_recording.py);
#: at 30 no correct transcript lost a word and every added word was left out; from 100 on the
#: search gets unstable (a correct sentence lost 9 words in a row).
OPTIONAL_WORD_BONUS = 30.0
#: Voice outside every aligned word, seconds, that makes the recording say more than the
#: transcript (a breath or a click is shorter; on correct transcripts of the recordings in
#: benchmarks/bench_timing.py, no gap held more than 5 ms of voice).
EXTRA_SPEECH = 0.10
ALIGN_SR = 16000

_LETTERS = {
    "a": "AE", "b": "B", "c": "K", "d": "D", "e": "EH", "f": "F", "g": "G", "h": "HH", "i": "IH",
    "j": "JH", "k": "K", "l": "L", "m": "M", "n": "N", "o": "AA", "p": "P", "q": "K", "r": "R",
    "s": "S", "t": "T", "u": "AH", "v": "V", "w": "W", "x": "K S", "y": "Y", "z": "Z",
}
_ONES = "zero one two three four five six seven eight nine ten eleven twelve thirteen fourteen fifteen " \
        "sixteen seventeen eighteen nineteen".split()
_TENS = "_ _ twenty thirty forty fifty sixty seventy eighty ninety".split()


def number_words(n: int) -> list[str]:
    """English words for a non-negative integer (years like 1999 read as "nineteen ninety nine")."""
    if n < 20:
        return [_ONES[n]]
    if n < 100:
        return [_TENS[n // 10]] + ([_ONES[n % 10]] if n % 10 else [])
    if n < 1000:
        return [_ONES[n // 100], "hundred"] + (number_words(n % 100) if n % 100 else [])
    if 1100 <= n < 10000 and n % 100 and (n // 100) % 10:
        return number_words(n // 100) + (["oh"] + number_words(n % 100) if n % 100 < 10 else number_words(n % 100))
    if n < 1_000_000:
        return number_words(n // 1000) + ["thousand"] + (number_words(n % 1000) if n % 1000 else [])
    return [w for d in str(n) for w in number_words(int(d))]


def cardinal_words(n: int) -> list[str]:
    """Plain cardinal reading: 1999 -> "one thousand nine hundred ninety nine"."""
    if n < 1000:
        return number_words(n)
    if n < 1_000_000:
        return cardinal_words(n // 1000) + ["thousand"] + (cardinal_words(n % 1000) if n % 1000 else [])
    return number_words(n)


def number_variants(n: int) -> list[list[str]]:
    """Readings of an integer a speaker (or espeak) may use; the aligner picks the best."""
    out = [number_words(n), cardinal_words(n)]
    if 1100 <= n < 10000 and (n // 100) % 10:
        out.append(number_words(n // 100) + ["hundred"] + (number_words(n % 100) if n % 100 else []))
    uniq = []
    for v in out:
        if v not in uniq:
            uniq.append(v)
    return uniq


def normalise_for_dict(word: str) -> str:
    return word.lower().replace("\u2019", "'").replace("\u2018", "'").replace("\u02bc", "'").strip("'-")


class _Aligner:
    def __init__(self) -> None:
        try:
            pocketsphinx = import_optional("pocketsphinx")
        except ImportError as e:  # pragma: no cover - dependency is declared
            raise SpeechError(f"pocketsphinx is not installed ({e}); supply a TextGrid or JSON timings file") from None
        self.ps = pocketsphinx

    def pronunciations(self, decoder, word: str) -> list[str]:
        w = normalise_for_dict(word)
        if w.isdigit() and len(w) <= 6:
            out = []
            for variant in number_variants(int(w)):
                phones = [decoder.lookup_word(x) for x in variant]
                if all(phones):
                    out.append(" ".join(phones))
            if out:
                return out
        one = self.pronunciation(decoder, word)
        return [one] if one else []

    def pronunciation(self, decoder, word: str) -> str | None:
        w = normalise_for_dict(word)
        if not w:
            return None
        found = decoder.lookup_word(w)
        if found:
            return found
        parts = [p for p in re.split(r"[-_]", w) if p]
        phones: list[str] = []
        for p in parts:
            if p.isdigit():
                for nw in number_words(int(p)):
                    ph = decoder.lookup_word(nw)
                    if ph:
                        phones.append(ph)
                continue
            ph = decoder.lookup_word(p)
            if ph is None:
                letters = [_LETTERS[c] for c in p if c in _LETTERS]
                digits = [decoder.lookup_word(_ONES[int(c)]) for c in p if c.isdigit()]
                ph = " ".join(letters + [d for d in digits if d]) or None
            if ph:
                phones.append(ph)
        return " ".join(phones) or None

    def _tokens(self, decoder, words: list[str]) -> list[str | None]:
        tokens: list[str | None] = []
        for i, w in enumerate(words):
            key = normalise_for_dict(w)
            if key and not key.isdigit() and decoder.lookup_word(key):
                tokens.append(key)
                continue
            variants = self.pronunciations(decoder, w)
            if not variants:
                tokens.append(None)
                continue
            name = f"sgtword{i}"
            for v, phones in enumerate(variants):
                decoder.add_word(name if v == 0 else f"{name}({v + 1})", phones, True)
            tokens.append(name)
        return tokens

    def align(self, samples: np.ndarray, sample_rate: int, words: list[str]) -> tuple[list[tuple[float, float]], list[int]]:
        """(start, end) seconds for each word, and the indices of words the recording does not
        say (:meth:`absent_words`); raises SpeechError when alignment fails."""
        x = np.asarray(samples, dtype=np.float64)
        if sample_rate != ALIGN_SR:
            x = resample_poly(x, ALIGN_SR, int(sample_rate))
        x = x + np.random.default_rng(12345).normal(0.0, 3e-4, len(x))
        pcm = (np.clip(x, -1.0, 1.0) * 32767.0).astype("<i2").tobytes()
        tokens: list[str | None] = []
        segs: list = []
        for beams in ({}, {"beam": 1e-80, "wbeam": 1e-60, "pbeam": 1e-80}):  # default first; wide if it fails
            decoder = self.ps.Decoder(lm=None, loglevel="FATAL", **beams)
            tokens = self._tokens(decoder, words)
            usable = [t for t in tokens if t is not None]
            if not usable:
                raise SpeechError("none of the transcript's words can be aligned; supply a TextGrid or JSON timings file")
            try:
                decoder.set_align_text(" ".join(usable))
                decoder.start_utt()
                decoder.process_raw(pcm, full_utt=True)
                decoder.end_utt()
                segs = [(s.word, s.start_frame, s.end_frame) for s in (decoder.seg() or [])]
            except RuntimeError:
                segs = []
            segs = [s for s in segs if not (s[0].startswith("<") or s[0].startswith("[") or s[0] == "(NULL)")]
            if len(segs) == len(usable):
                break
        else:
            raise SpeechError("automatic alignment with pocketsphinx failed (the audio did not match the "
                              "transcript well enough); supply a TextGrid (e.g. from Montreal Forced "
                              "Aligner) or a JSON timings file")
        times: list[tuple[float, float] | None] = []
        it = iter(segs)
        for t in tokens:
            if t is None:
                times.append(None)
            else:
                _, a, b = next(it)
                times.append((a / FRAME_RATE, (b + 1) / FRAME_RATE))
        absent = self.absent_words(pcm, words)
        return _fill_gaps(times, words), absent

    def absent_words(self, pcm: bytes, words: list[str]) -> list[int]:
        """Indices of the words the recording does not say: a second decode where every word
        may be left out (a JSGF grammar of optional words, each rewarded by
        :data:`OPTIONAL_WORD_BONUS`, so only a word whose audio is clearly not there is left
        out). Words without a pronunciation are never reported."""
        decoder = self.ps.Decoder(lm=None, loglevel="FATAL", wip=OPTIONAL_WORD_BONUS)
        names = []
        for i, w in enumerate(words):
            variants = self.pronunciations(decoder, w)
            key = normalise_for_dict(w)
            if variants and key and not key.isdigit():  # the dictionary's other pronunciations too
                v = 2
                while (alt := decoder.lookup_word(f"{key}({v})")) and v < 10:
                    variants.append(alt)
                    v += 1
            if not variants:
                continue
            for v, phones in enumerate(variants):
                decoder.add_word(f"sgtw{i}" if v == 0 else f"sgtw{i}({v + 1})", phones, True)
            names.append(f"[sgtw{i}]")
        if not names:
            return []
        grammar = "#JSGF V1.0;\ngrammar transcript;\npublic <s> = " + " ".join(names) + ";\n"
        try:
            decoder.add_jsgf_string("transcript", grammar)
            decoder.activate_search("transcript")
            decoder.start_utt()
            decoder.process_raw(pcm, full_utt=True)
            decoder.end_utt()
            said = {int(s.word[4:].split("(")[0]) for s in (decoder.seg() or []) if s.word.startswith("sgtw")}
        except RuntimeError:
            return []  # no verdict: the forced alignment stands
        if not said:
            return []
        return [int(n[5:-1]) for n in names if int(n[5:-1]) not in said]


def _fill_gaps(times: list[tuple[float, float] | None], words: list[str]) -> list[tuple[float, float]]:
    """Words without a pronunciation (no letters at all) get a share of their neighbours' gap."""
    out: list[tuple[float, float]] = []
    n = len(times)
    i = 0
    while i < n:
        if times[i] is not None:
            out.append(times[i])
            i += 1
            continue
        j = i
        while j < n and times[j] is None:
            j += 1
        t0 = out[-1][1] if out else (times[j][0] if j < n else 0.0)
        t1 = times[j][0] if j < n else t0
        k = j - i
        for m in range(k):
            a = t0 + (t1 - t0) * m / k
            out.append((a, t0 + (t1 - t0) * (m + 1) / k))
        i = j
    return out


_aligner: _Aligner | None = None


def align_words(samples: np.ndarray, sample_rate: int, words: list[str]):
    """Align ``words`` to a recording: ((start, end) seconds per word, trimmed to the voice),
    and the first place the recording and the words disagree, as (word index, seconds,
    reason), or None. Raises SpeechError when the alignment fails altogether."""
    global _aligner
    if _aligner is None:
        _aligner = _Aligner()
    times, absent = _aligner.align(samples, sample_rate, words)
    mask, hop = audio.voice_activity(samples, sample_rate)
    times = trim_to_voice(times, mask, hop, sample_rate)
    return times, first_mismatch(words, times, absent, mask, hop, sample_rate)


def trim_to_voice(times, mask: np.ndarray, hop: int, sample_rate: int) -> list[tuple[float, float]]:
    """Each word's interval cut to its first and last voiced frame (the aligner's frames are
    10 ms and it gives a word the silence next to it), then grown over voice the aligner left
    outside every word next to it (up to :data:`EXTRA_SPEECH`: a soft onset such as an "n"
    it started late). A word with no voiced frame is left as it is."""
    out = []
    for a, b in times:
        fa, fb = int(a * sample_rate) // hop, -(-int(round(b * sample_rate)) // hop)
        idx = np.flatnonzero(mask[fa:fb])
        if len(idx):
            a2 = max(a, (fa + int(idx[0])) * hop / sample_rate)
            b2 = min(b, (fa + int(idx[-1]) + 1) * hop / sample_rate)
            if a2 < b2:
                a, b = a2, b2
        out.append((a, b))
    reach = int(EXTRA_SPEECH * sample_rate) // hop
    for k, (a, b) in enumerate(out):
        fa, fb = int(round(a * sample_rate)) // hop, -(-int(round(b * sample_rate)) // hop)
        lo = -(-int(round(out[k - 1][1] * sample_rate)) // hop) if k else 0
        hi = int(round(out[k + 1][0] * sample_rate)) // hop if k + 1 < len(out) else len(mask)
        if 0 <= fa < len(mask) and mask[fa]:
            f = fa
            while f > lo and mask[f - 1] and fa - f <= reach:
                f -= 1
            if fa - f <= reach:
                a = f * hop / sample_rate
        if 0 < fb <= len(mask) and mask[fb - 1]:
            g = fb
            while g < min(hi, len(mask)) and mask[g] and g - fb <= reach:
                g += 1
            if g - fb <= reach:
                b = min(g * hop / sample_rate, len(mask) * hop / sample_rate)
        out[k] = (a, b)
    return out


def first_mismatch(words, times, absent, mask, hop, sample_rate):
    """The earliest of: a word the recording does not say (``absent``), and a stretch of voice
    of :data:`EXTRA_SPEECH` or more outside every word (speech the transcript lacks).
    (word index, seconds, reason) or None."""
    found = []
    if absent:
        k = absent[0]
        found.append((times[k][0], k, f"word {k + 1} ({words[k]!r}) is not in the recording: the aligner "
                                      f"finds no audio for it (it would be at {times[k][0]:.2f} s)"))
    n_frames = len(mask)
    bounds = [0] + [f for a, b in times for f in (int(a * sample_rate) // hop, -(-int(round(b * sample_rate)) // hop))]
    bounds.append(n_frames)
    for g in range(len(times) + 1):  # gap g lies before word g
        lo, hi = bounds[2 * g], bounds[2 * g + 1]
        idx = np.flatnonzero(mask[lo:hi]) if hi > lo else np.zeros(0, dtype=int)
        if len(idx) * hop / sample_rate >= EXTRA_SPEECH:
            t = (lo + int(idx[0])) * hop / sample_rate
            where = (f"between {words[g - 1]!r} and {words[g]!r}" if 0 < g < len(words)
                     else f"before {words[0]!r}" if g == 0 else f"after {words[-1]!r}")
            found.append((t, min(g, len(words) - 1),
                          f"the recording has {len(idx) * hop / sample_rate:.2f} s of speech at {t:.2f} s "
                          f"{where} that the transcript does not have"))
            break
    if not found:
        return None
    t, k, reason = min(found)
    return k, t, reason
