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

from .types import SpeechError

FRAME_RATE = 100  # pocketsphinx frames per second (default -frate)
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
            import pocketsphinx
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

    def align(self, samples: np.ndarray, sample_rate: int, words: list[str]) -> list[tuple[float, float]]:
        """(start, end) seconds for each word; raises SpeechError when alignment fails."""
        from math import gcd

        from scipy.signal import resample_poly

        x = np.asarray(samples, dtype=np.float64)
        if sample_rate != ALIGN_SR:
            g = gcd(ALIGN_SR, int(sample_rate))
            x = resample_poly(x, ALIGN_SR // g, int(sample_rate) // g)
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
        return _fill_gaps(times, words)


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


def align_words(samples: np.ndarray, sample_rate: int, words: list[str]) -> list[tuple[float, float]]:
    global _aligner
    if _aligner is None:
        _aligner = _Aligner()
    return _aligner.align(samples, sample_rate, words)
