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

Recordings with pauses (issue 27). What the aligner hears is the recording's speech only:
voice (energy above the noise floor) that holds periodic frames (a vowel) near the speech's
level (:func:`speech_frames`); breaths, clicks and noise between the sentences are turned
down to the room's noise floor (:func:`aligner_pcm`), so no word is aligned to a breath.
Words are trimmed to that speech and grown over speech next to them that the aligner gave to
no word (:func:`trim_to_voice`: the first word after a pause or a stop's closure, often started
0.1-0.3 s into its voice). The transcript is then checked (:func:`first_mismatch`): a word is missing when a
decode in which every word may be left out leaves it out, stretch of speech by stretch
(:func:`stretches`) and again among its neighbours only, and the stretch aligned without it
fits the audio about as well (:meth:`_Aligner._needed`; in a recording sampled under 16 kHz,
whose consonants the model hears poorly, a word the aligner found room for is missing only
when the audio fits clearly better without it); speech is extra when 50 ms or more
of periodic speech lies outside every word, or when the recognizer hears a word where the
alignment has none of that name and putting it into the transcript there makes the stretch
fit far better (also scored against every state of the model, where audio given to silence
costs what it should), the word itself fitting as correct words do (:meth:`_Aligner.extra_words`:
a word left out of the transcript, whose audio the aligner had stretched a neighbour over);
and a word of three phones or more is not what
the recording says there when its phones fit the audio far worse than the same phones fit
in correct transcripts (:func:`poor_fits`: pocketsphinx's second, phone-level pass over the
alignment gives each phone's acoustic score, relative to the best state of each frame; the
table of usual fits is fitted on synthetic voices by ``scripts/fit_phone_scores.py``). A
rejection says what the recognizer (the bundled language model, no transcript) hears at that
place.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections import OrderedDict
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

import numpy as np

from core import cancel
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
#: search gets unstable (a correct sentence lost 9 words in a row). Since the decode runs
#: stretch by stretch (issue 27) it matters less: on the corpus of
#: ``benchmarks/bench_timing.py --corpus`` (in the course of issue 27), 8 rejected one more
#: correct transcript of 72 and 1 fewer wrong one of 216.
OPTIONAL_WORD_BONUS = 30.0
#: How far (seconds) a word is grown over voice next to it that the aligner gave to no word:
#: :data:`GROW` where a pause lies beyond that voice, :data:`EXTRA_NEAR` where it runs into the
#: next word (see :func:`trim_to_voice`).
GROW, EXTRA_NEAR = 0.4, 0.16
#: Voiced (periodic) speech outside every aligned word, seconds, that makes the recording say
#: more than the transcript (a vowel; a breath or a click is not periodic).
EXTRA_VOICE = 0.05
ALIGN_SR = 16000
#: A stretch whose phone-level pass fails (:meth:`_Aligner._phones_by_stretch`) is cut in two
#: between two words, and again, while each half keeps at least this many words.
SPLIT_WORDS = 3
#: Frames (10 ms) of near silence put before and after the audio for the aligner (_padded).
PAD_FRAMES = 25
#: The words are checked stretch by stretch of speech (see :func:`stretches`): a stretch ends
#: where this much (seconds) lies between two words, holds at most this many words, and
#: reaches this far (seconds) into the silence around it.
STRETCH_PAUSE, STRETCH_WORDS, STRETCH_MARGIN = 0.25, 12, 0.3
#: A word left out is looked for again among this many words on each side of it (each; it is
#: left out if every look leaves it out). (1, 2) saved one correct transcript of the corpus
#: and let 39 more wrong ones of 216 through.
NEARBY = (2,)
#: A word the decode leaves out (twice) is still said when its stretch, aligned without it,
#: fits the audio worse by this many frames of the recording's usual fit (the median word's
#: score per frame) or more (:meth:`_Aligner._needed`). On the corpus of
#: ``benchmarks/bench_timing.py --corpus`` the correct words left out cost 41-79 (one
#: espeak-ng MP3), the words wrongly added or changed -7 to +446, gaining from it. In a
#: band-limited recording a word that is not :func:`squeezed` is missing only when it costs
#: this much or more the other way.
ABSENT_COST = 30.0
#: Speech, for the aligner (:func:`speech_frames`): voice that holds frames more periodic than
#: :data:`PERIODIC` at most :data:`SPEECH_RANGE` dB under the recording's speech; voice less
#: than :data:`SPEECH_JOIN` s apart is one stretch; :data:`SPEECH_MARGIN` s around it is kept.
PERIODIC, SPEECH_RANGE, SPEECH_JOIN, SPEECH_MARGIN = 0.6, 20.0, 0.08, 0.1
#: A word fits the recording poorly (:func:`poor_fits`) when its phones score, on average, far
#: worse than the same phones do in correct transcripts (:data:`PHONE_FIT_FILE`): this many
#: spreads of that average (the mean of n phones' z, times sqrt(n): a long word's average wanders
#: less than a short one's; the corpus's correct words reach at most 4.3 at 3 phones and 3.7
#: at 4 to 7). Was 3 spreads of one phone at any length, which let a changed 6-phone word at 2.9
#: through (a 3-phone word: now 2.9, a 6-phone word 2.0). The corpus of
#: ``benchmarks/bench_timing.py --corpus``: no correct transcript rejected either way, 4 more
#: wrong ones of 216 (at 4.5: one correct one in the even-numbered half).
POOR_FIT_Z = 5.0
#: ... the square root of at most this many phones: a word's phones are not independent (the
#: LibriVox reader's 9-phone 'prudently' fits 1.4-1.7 spreads worse on average, a whole word a
#: little off, which sqrt(9) made a rejection in ``bench_timing.py`` part 4), so a word of 6
#: phones or more fails at 2.0 spreads on average. Correct words of 6 or more phones in the
#: corpus: at most 1.64 (4.0 so); no wrong word of 7 or 8 phones that failed before passes.
POOR_FIT_MAX_PHONES = 6
#: ... and has at least this many phones: the fit of a word of one or two phones (a, he, of)
#: rests on a few frames shared with its neighbours. Set after the first run of the whole
#: corpus, where two correct LibriVox transcripts were rejected at 'a' and 'he' (z 3.1, 3.0).
POOR_FIT_PHONES = 3
#: A word is squeezed in where the recording has no room for it when at least this share of its
#: phones last the aligner's shortest (:data:`SHORTEST_PHONE` frames: the audio had none to give
#: them) and its phones fit worse than usual by more than :data:`SQUEEZED_Z` spreads (mean
#: z, unscaled). In the corpus's correct transcripts: at most 1.7 (a LibriVox 'And'); wrong
#: ones caught by it alone: 'pocket' squeezed between 'book' and 'was' (2.2).
SQUEEZED_SHARE, SQUEEZED_Z, SHORTEST_PHONE = 0.6, 2.0, 3
#: A word the recognizer hears where the transcript has none is in the recording
#: (:meth:`_Aligner.extra_words`) when putting it into the transcript there makes the stretch
#: fit the audio better by this many frames of the recording's usual fit (the median word's
#: score per frame) ... Chosen on the even-numbered half of the corpus of
#: ``benchmarks/bench_timing.py --corpus`` (its correct transcripts' best gain: 23; the odd
#: half's: 7): at 20 one correct transcript of 36 there was rejected.
EXTRA_WORD_GAIN = 30.0
#: ... and the word's own phones fit no more than this many spreads worse than they do in
#: correct transcripts (:func:`poor_fits`; a word that fits only where another word's
#: stretched phones fitted worse, as two of the corpus's card readings, is not heard there).
EXTRA_WORD_FIT = 2.0
#: ... or, scored against every state of the model (pocketsphinx's ``compallsen``), when it
#: makes the stretch fit better by this many frames of that scoring's usual fit and by this
#: much per frame of the word. The phone-level scores above are relative to the best *active*
#: state of each frame, so audio that the alignment gives to silence costs nothing where
#: silence alone is active: a dropped 'He' right after a pause gains -0.7 frames so and 19
#: against every state. Chosen on the even-numbered half of the corpus of
#: ``benchmarks/bench_timing.py --corpus`` (its correct transcripts' heard words that fit: at
#: most 1.13 per frame among gains of 10 or more); on the odd half no correct transcript's
#: word reaches it and 2 of its 7 dropped words missed before are caught.
EXTRA_WORD_ALL_GAIN, EXTRA_WORD_ALL_RATE = 10.0, 1.5
#: Per phone, how well correct transcripts' phones fit (``scripts/fit_phone_scores.py`` makes it).
PHONE_FIT_FILE = Path(__file__).with_name("phone_fit.json")
#: Part of the cache key of an alignment: bumped when the words' times or the verdict change.
VERSION = 8
#: Decodes (:meth:`_Aligner.score`, :meth:`_Aligner._said`) remembered in this process, by
#: their audio's digest and words: a transcript edited in one place is checked again with the
#: other stretches' decodes as they were (each is a fresh decoder, so the same inputs give the
#: same answer). A few hundred bytes each.
DECODES_KEPT = 2048

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
        self._free = None  # the recognizer of :meth:`_recognize` (language model, no transcript), made when needed
        self._decodes: OrderedDict = OrderedDict()  # see DECODES_KEPT
        try:
            pocketsphinx = import_optional("pocketsphinx")
        except ImportError as e:  # pragma: no cover - dependency is declared
            raise SpeechError(f"pocketsphinx is not installed ({e}); supply a TextGrid or JSON timings file") from None
        self.ps = pocketsphinx

    def _remembered(self, kind: str, pcm: bytes, key: tuple, compute):
        """``compute()``, or what it gave before for this ``kind``, audio and ``key``."""
        k = (kind, hashlib.blake2b(pcm, digest_size=16).digest(), key)
        if k in self._decodes:
            self._decodes.move_to_end(k)
            return self._decodes[k]
        value = self._decodes[k] = compute()
        while len(self._decodes) > DECODES_KEPT:
            self._decodes.popitem(last=False)
        return value

    def fresh(self) -> None:
        """Forget the recognizer of :meth:`_recognize`: a decoder carries its cepstral mean
        from one utterance to the next, so what it hears in one recording would depend on the
        recordings checked before it in the same process."""
        self._free = None

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

    def _decode(self, pcm: bytes, words: list[str], every_state: bool = False):
        """The forced alignment of ``words`` to ``pcm``: (decoder, tokens, word segments as
        (token, first frame, last frame)), with pocketsphinx's default beams and, if that
        fails, wide ones; None when both fail. Raises SpeechError when no word can be aligned.
        ``every_state``: the phone-level pass scores each frame against every state of the
        model, not the active ones only (see :data:`EXTRA_WORD_ALL_GAIN`)."""
        for beams in ({}, {"beam": 1e-80, "wbeam": 1e-60, "pbeam": 1e-80}):  # default first; wide if it fails
            decoder = self.ps.Decoder(lm=None, loglevel="FATAL", compallsen=every_state, **beams)
            tokens = self._tokens(decoder, words)
            usable = [t for t in tokens if t is not None]
            if not usable:
                raise SpeechError("none of the transcript's words can be aligned; supply a TextGrid or JSON timings file")
            try:
                decoder.set_align_text(" ".join(usable))
                cancel.check()  # each pass is a long call into pocketsphinx: look before it
                decoder.start_utt()
                decoder.process_raw(_padded(pcm), full_utt=True)
                decoder.end_utt()
                segs = [(s.word, s.start_frame - PAD_FRAMES, s.end_frame - PAD_FRAMES) for s in (decoder.seg() or [])]
            except RuntimeError:
                segs = []
            segs = [s for s in segs if not (s[0].startswith("<") or s[0].startswith("[") or s[0] == "(NULL)")]
            if len(segs) == len(usable):
                return decoder, tokens, segs
        return None

    def align(self, pcm: bytes, words: list[str]):
        """((start, end) seconds for each word in ``pcm`` (16 kHz, see :func:`aligner_pcm`): the
        forced alignment, in 10 ms frames; the phones of each word, :meth:`phones`); raises
        SpeechError when alignment fails."""
        found = self._decode(pcm, words)
        if found is None:
            raise SpeechError("automatic alignment with pocketsphinx failed (the audio did not match the "
                              "transcript well enough); supply a TextGrid (e.g. from Montreal Forced "
                              "Aligner) or a JSON timings file")
        decoder, tokens, segs = found
        times: list[tuple[float, float] | None] = []
        it = iter(segs)
        for t in tokens:
            if t is None:
                times.append(None)
            else:
                _, a, b = next(it)
                times.append((max(0.0, a / FRAME_RATE), max(0.0, (b + 1) / FRAME_RATE)))
        times = _fill_gaps(times, words)
        phones = self.phones(decoder, pcm, tokens)
        return times, phones if phones is not None else self._phones_by_stretch(pcm, words, times)

    def _phones_by_stretch(self, pcm: bytes, words: list[str], times) -> list | None:
        """The words' phones (as :meth:`phones`) from each stretch of speech (:func:`stretches`)
        aligned on its own: the phone-level pass over a whole recording fails now and then
        (the corpus of ``benchmarks/bench_timing.py --corpus``: one correct transcript of 72, 20
        wrong ones of 216), over a few seconds far less often; a stretch whose pass fails is
        cut in halves between two words (:data:`SPLIT_WORDS`). A word whose pass fails in
        every cut has None; None when every one fails."""
        x = np.frombuffer(pcm, "<i2")
        out: list = [None] * len(words)
        todo = stretches(times, len(x) / ALIGN_SR)
        while todo:
            first, last, a, b = todo.pop()
            found = self.score(x[int(a * ALIGN_SR): int(b * ALIGN_SR)].tobytes(), words[first:last])
            if found is None and last - first >= 2 * SPLIT_WORDS:  # halves, cut between two words
                k = (first + last) // 2
                cut = (times[k - 1][1] + times[k][0]) / 2
                todo += [(first, k, a, cut), (k, last, cut, b)]
            for k, word in enumerate(found[1] if found else []):
                out[first + k] = word and word[1]
        return out if any(out) else None

    def _phone_pass(self, decoder, pcm: bytes) -> list[tuple[str, int, list[tuple[str, int, int]]]] | None:
        """pocketsphinx's second, phone-level pass over the word alignment ``decoder`` just
        made: every entry, silences too, as (name, first frame, [(phone, frames, acoustic
        score)]); None when the pass fails. The scores are log likelihoods relative to the
        best-scoring state of each frame (pocketsphinx normalises them so), so a phone the
        audio fits well scores near 0."""
        try:
            decoder.set_alignment()
            cancel.check()  # each pass is a long call into pocketsphinx: look before it
            decoder.start_utt()
            decoder.process_raw(_padded(pcm), full_utt=True)
            decoder.end_utt()
            return [(w.name, int(w.start) - PAD_FRAMES, [(ph.name, int(ph.duration), int(ph.score)) for ph in w])
                    for w in decoder.get_alignment()]
        except (RuntimeError, TypeError):
            return None

    def phones(self, decoder, pcm: bytes, tokens: list[str | None]) -> list[list[tuple[str, int, int]] | None] | None:
        """Each word's phones as (phone, frames, acoustic score) from :meth:`_phone_pass`
        (None for a word without a pronunciation; None altogether when the pass fails)."""
        entries = self._phone_pass(decoder, pcm)
        if entries is None:
            return None
        found = [ph for name, _, ph in entries if not name.startswith(("<", "["))]
        if len(found) != sum(t is not None for t in tokens):
            return None
        it = iter(found)
        return [None if t is None else next(it) for t in tokens]

    def score(self, pcm: bytes, words: list[str], every_state: bool = False):
        """How well ``words`` (all of them, in order) fit ``pcm``: (the alignment's total
        acoustic score, silences included, and each word as (first frame, [(phone, frames,
        score)]), None for a word without a pronunciation), or None when the alignment or its
        phone pass fails. Two scores of the same audio compare: the higher fits it better
        (against ``every_state``, :meth:`_decode`, also where the two give a stretch of audio
        to different models)."""
        return self._remembered("score", pcm, (every_state, *words), lambda: self._score_now(pcm, words, every_state))

    def _score_now(self, pcm: bytes, words: list[str], every_state: bool):
        found = self._decode(pcm, words, every_state)
        if found is None:
            return None
        decoder, tokens, _ = found
        entries = self._phone_pass(decoder, pcm)
        if entries is None:
            return None
        placed = [(start, ph) for name, start, ph in entries if not name.startswith(("<", "["))]
        if len(placed) != sum(t is not None for t in tokens):
            return None
        it = iter(placed)
        return sum(s for _, _, ph in entries for _, _, s in ph), [None if t is None else next(it) for t in tokens]

    def absent_words(self, pcm: bytes, words: list[str], times: list[tuple[float, float]], phones=None,
                     band_limited: bool = False) -> list[int]:
        """Indices of the words the recording does not say. The recording is cut into stretches
        of speech (:func:`stretches`: at pauses, and long ones between words), and each stretch
        is decoded with a JSGF grammar of its own words, each optional and rewarded by
        :data:`OPTIONAL_WORD_BONUS`, so only a word whose audio is clearly not there is left
        out. Decoding each stretch on its own keeps the search small (the whole of a 20 s
        recording took two minutes) and starts every stretch with a little of the silence
        before it, so a word right after a pause is looked for where it is. Words without a
        pronunciation are never reported. In a ``band_limited`` recording (:func:`narrowband`)
        a word the aligner gave room is left out only when the audio clearly fits better
        without it (:meth:`_needed`)."""
        x = np.frombuffer(pcm, "<i2")
        absent: list[int] = []
        for first, last, a, b in stretches(times, len(x) / ALIGN_SR):
            said = self._said(x[int(a * ALIGN_SR): int(b * ALIGN_SR)].tobytes(), words, first, last)
            if said is not None:
                absent += [k for k in range(first, last) if k not in said]
        usual = _median_rate(phones)
        return [k for k in absent if not self._heard_nearby(x, words, times, k)
                and not self._needed(x, words, times, k, usual, band_limited and bool(phones) and roomy(phones[k]))]

    def _needed(self, x: np.ndarray, words: list[str], times, k: int, usual: float | None, room: bool = False) -> bool:
        """A third look at a word left out: its stretch fits the audio worse without it, by
        :data:`ABSENT_COST` frames of the recording's ``usual`` fit or more (a word the
        recording says: its audio has nowhere else to go). False when that cannot be told.

        ``room``: a word of a band-limited recording that the aligner gave room (:func:`roomy`).
        The model hears such a recording's consonants poorly (their sound above half its rate
        is missing), so there the word is needed unless the audio fits better without it by
        :data:`ABSENT_COST` or more; where the stretch cannot be scored, the whole recording
        is. The 8 kHz espeak-ng 'left' and 'church' of the corpus of
        ``benchmarks/bench_timing.py --corpus`` fit 9 and 13 frames better left out; the words
        wrongly added or changed at 8 kHz that the aligner gives room, 69 frames or more, but
        for one changed 'elephant' (21 frames, which passes)."""
        if usual is None:
            return False
        first, last, a, b = next(s for s in stretches(times, len(x) / ALIGN_SR) if s[0] <= k < s[1])
        with_it = without = None
        if last - first >= 2:
            seg = x[int(a * ALIGN_SR): int(b * ALIGN_SR)].tobytes()
            with_it, without = self.score(seg, words[first:last]), self.score(seg, words[first:k] + words[k + 1:last])
        if (with_it is None or without is None) and room and len(words) >= 2:
            with_it, without = self.score(x.tobytes(), words), self.score(x.tobytes(), words[:k] + words[k + 1:])
        if with_it is None or without is None:
            return False
        cost = (with_it[0] - without[0]) / -usual
        return cost > -ABSENT_COST if room else cost >= ABSENT_COST

    def _heard_nearby(self, x: np.ndarray, words: list[str], times, k: int) -> bool:
        """A second look at a word left out: the same decode on the word and its neighbours
        only, :data:`NEARBY` of them on each side (from the first one's start to the last
        one's end, :data:`STRETCH_MARGIN` around them). A word the recording says is kept in
        one of them far more often than in the whole stretch, where the search may have
        dropped it for a path that ran early or late; a word it does not say is left out again."""
        for near in NEARBY:
            p, q = max(0, k - near), min(len(words), k + near + 1)
            a = max(0.0, times[p][0] - STRETCH_MARGIN)
            b = min(len(x) / ALIGN_SR, times[q - 1][1] + STRETCH_MARGIN)
            said = self._said(x[int(a * ALIGN_SR): int(b * ALIGN_SR)].tobytes(), words, p, q)
            if said is None or k in said:
                return True
        return False

    def _said(self, pcm: bytes, words: list[str], first: int, last: int) -> set[int] | None:
        """Which of ``words[first:last]`` the optional-word decode of ``pcm`` keeps (None: no
        verdict; every word without a pronunciation counts as said)."""
        return self._remembered("said", pcm, (first, *words[first:last]), lambda: self._said_now(pcm, words, first, last))

    def _said_now(self, pcm: bytes, words: list[str], first: int, last: int) -> set[int] | None:
        decoder = self.ps.Decoder(lm=None, loglevel="FATAL", wip=OPTIONAL_WORD_BONUS)
        names = []
        said = set()
        for i in range(first, last):
            w = words[i]
            variants = self.pronunciations(decoder, w)
            key = normalise_for_dict(w)
            if variants and key and not key.isdigit():  # the dictionary's other pronunciations too
                v = 2
                while (alt := decoder.lookup_word(f"{key}({v})")) and v < 10:
                    variants.append(alt)
                    v += 1
            if not variants:
                said.add(i)
                continue
            for v, phones in enumerate(variants):
                decoder.add_word(f"sgtw{i}" if v == 0 else f"sgtw{i}({v + 1})", phones, True)
            names.append(f"[sgtw{i}]")
        if not names:
            return said
        grammar = "#JSGF V1.0;\ngrammar transcript;\npublic <s> = " + " ".join(names) + ";\n"
        try:
            decoder.add_jsgf_string("transcript", grammar)
            decoder.activate_search("transcript")
            cancel.check()  # each pass is a long call into pocketsphinx: look before it
            decoder.start_utt()
            decoder.process_raw(pcm, full_utt=True)
            decoder.end_utt()
            kept = {int(s.word[4:].split("(")[0]) for s in (decoder.seg() or []) if s.word.startswith("sgtw")}
        except RuntimeError:
            return None  # no verdict: the forced alignment stands
        if not kept:
            return None
        return said | kept

    def extra_words(self, pcm: bytes, words: list[str], times, phones) -> list[tuple[int, str, float, float]]:
        """Words the recording says that the transcript lacks (a word left out of it), as (the
        index of the word it comes before (``len(words)``: after the last), the word, start s,
        end s). Each stretch of speech (:func:`stretches`) is heard by the recognizer (the
        bundled language model, no transcript); a word it hears where the alignment has no word
        of that name is put into the transcript there and the stretch aligned again: the word
        is in the recording when that fits the audio better by :data:`EXTRA_WORD_GAIN` frames
        of the recording's usual fit or more (or, scored against every state, by
        :data:`EXTRA_WORD_ALL_GAIN` frames and :data:`EXTRA_WORD_ALL_RATE` per frame of the
        word) and the word itself fits as well as correct words do (its phones no more than
        :data:`EXTRA_WORD_FIT` spreads worse than usual, see :func:`poor_fits`). Nothing is
        found without ``phones`` (no yardstick)."""
        usual = _median_rate(phones)
        if usual is None:
            return []
        x = np.frombuffer(pcm, "<i2")
        found = []
        for first, last, a, b in stretches(times, len(x) / ALIGN_SR):
            seg = x[int(a * ALIGN_SR): int(b * ALIGN_SR)].tobytes()
            base = every = None
            for heard, f0, f1 in self._recognize(seg):
                t0, t1 = a + f0 / FRAME_RATE, a + (f1 + 1) / FRAME_RATE
                j = max(range(first, last), key=lambda j: min(t1, times[j][1]) - max(t0, times[j][0]))
                if min(t1, times[j][1]) > max(t0, times[j][0]) and normalise_for_dict(words[j]) == heard:
                    continue  # the transcript's own word
                g = j if (t0 + t1) / 2 < (times[j][0] + times[j][1]) / 2 else j + 1
                base = base or self.score(seg, words[first:last])
                if base is None:
                    break
                tried = self.score(seg, words[first:g] + [heard] + words[g:last])
                if tried is None or tried[1][g - first] is None:
                    continue
                start, ph = tried[1][g - first]
                if _fit_z(ph, usual) > EXTRA_WORD_FIT:
                    continue
                frames = sum(d for _, d, _ in ph)
                if (tried[0] - base[0]) / -usual < EXTRA_WORD_GAIN:  # a second look, against every state
                    if every is None:
                        every = self.score(seg, words[first:last], every_state=True) or ()
                    gain = self._gain(seg, every, words[first:g] + [heard] + words[g:last])
                    if gain < max(EXTRA_WORD_ALL_GAIN, EXTRA_WORD_ALL_RATE * frames):
                        continue
                found.append((g, heard, a + start / FRAME_RATE, a + (start + frames) / FRAME_RATE))
        return sorted(found, key=lambda f: f[2])

    def _gain(self, pcm: bytes, base, words: list[str]) -> float:
        """How much better ``words`` fit ``pcm`` than ``base`` (:meth:`score` against every
        state; () when it failed), in frames of the base's usual fit; 0 when not known."""
        usual = _median_rate([w and w[1] for w in base[1]]) if base else None
        tried = self.score(pcm, words, every_state=True) if usual is not None else None
        return (tried[0] - base[0]) / -usual if tried else 0.0

    def _recognize(self, pcm: bytes) -> list[tuple[str, int, int]]:
        """What the recognizer (the bundled en-us language model, no transcript) hears in
        ``pcm``: (word, first frame, last frame), lower case, fillers left out."""
        if self._free is None:  # a single forward pass, bounded: ~0.15 s per second of audio; see fresh()
            self._free = self.ps.Decoder(loglevel="FATAL", fwdflat=False, maxhmmpf=3000)
        try:
            cancel.check()  # each pass is a long call into pocketsphinx: look before it
            self._free.start_utt()
            self._free.process_raw(pcm, full_utt=True)
            self._free.end_utt()
            segs = self._free.seg() or []
        except RuntimeError:
            return []
        return [(s.word.split("(")[0], s.start_frame, s.end_frame) for s in segs
                if not (s.word.startswith("<") or s.word.startswith("[") or s.word == "(NULL)")]

    def heard(self, pcm: bytes, a: float, b: float) -> str:
        """What the recognizer (:meth:`_recognize`) hears between ``a`` and ``b`` seconds,
        lower case; "" for nothing."""
        x = np.frombuffer(pcm, "<i2")[max(0, int(a * ALIGN_SR)): max(0, int(b * ALIGN_SR))]
        return " ".join(w for w, _, _ in self._recognize(x.tobytes()))


@lru_cache(maxsize=1)
def phone_fit() -> dict[str, tuple[float, float]]:
    """{phone: (median, spread)} of :func:`relative_scores` in correct transcripts."""
    table = json.loads(PHONE_FIT_FILE.read_text(encoding="utf-8"))
    return {k: (float(v["median"]), float(v["spread"])) for k, v in table["phones"].items()}


def _median_rate(phones) -> float | None:
    """The recording's usual fit: the median word's acoustic score per frame (negative), or
    None without phones."""
    rates = [sum(s for _, _, s in w) / max(1, sum(d for _, d, _ in w)) for w in phones or [] if w]
    median = float(np.median(rates)) if rates else 0.0
    return median if median < 0 else None


def _fit_z(word, usual: float) -> float:
    """How many spreads worse than in correct transcripts a word's phones ((phone, frames,
    score)) fit, on average, relative to the recording's ``usual`` fit (:func:`_median_rate`)."""
    table = phone_fit()
    other = (float(np.median([m for m, _ in table.values()])), float(np.median([d for _, d in table.values()])))
    fits = [table.get(name, other) for name, _, _ in word]  # (a phone the table lacks: the median phone's)
    return float(np.mean([(s / max(1, d) / usual - m) / spread for (_, d, s), (m, spread) in zip(word, fits)]))


def relative_scores(phones) -> list[list[tuple[str, float]] | None]:
    """Per word, (phone, its acoustic score per frame / the median word's score per frame) for
    each phone: 1 is the recording's usual fit, larger is worse (the scores are negative).
    ``phones``: :meth:`_Aligner.phones`."""
    median = _median_rate(phones)
    if median is None:
        return [None] * len(phones)
    return [None if not w else [(name, s / max(1, d) / median) for name, d, s in w] for w in phones]


def poor_fits(phones) -> list[tuple[int, float, bool]]:
    """(word index, z, squeezed) of the words of :data:`POOR_FIT_PHONES` phones or more whose
    phones fit the recording far worse than correct transcripts' phones do: their mean z
    (:func:`_fit_z`) times the square root of their number (at most
    :data:`POOR_FIT_MAX_PHONES`) above :data:`POOR_FIT_Z`, or
    squeezed (:data:`SQUEEZED_SHARE` of them at :data:`SHORTEST_PHONE` frames) with a mean z
    above :data:`SQUEEZED_Z` (a word the recording does not say there: another word, or one
    squeezed in where there is none). z is the mean."""
    usual = _median_rate(phones)
    if usual is None:
        return []
    out = []
    for k, word in enumerate(phones):
        if word and len(word) >= POOR_FIT_PHONES:
            z = _fit_z(word, usual)
            tight = squeezed(word)
            if z * np.sqrt(min(len(word), POOR_FIT_MAX_PHONES)) > POOR_FIT_Z or (tight and z > SQUEEZED_Z):
                out.append((k, z, tight))
    return out


def squeezed(word) -> bool:
    """Whether the aligner gave :data:`SQUEEZED_SHARE` or more of a word's phones ((phone,
    frames, score)) its shortest time, :data:`SHORTEST_PHONE` frames: it found no room for them."""
    return sum(d <= SHORTEST_PHONE for _, d, _ in word) >= SQUEEZED_SHARE * len(word)


def roomy(word) -> bool:
    """Whether the aligner found room for a word's phones (it has phones and is not :func:`squeezed`)."""
    return bool(word) and not squeezed(word)


def narrowband(sample_rate: int) -> bool:
    """Whether a recording at ``sample_rate`` lacks sound the aligner's 16 kHz model listens
    to: sampled under :data:`ALIGN_SR`, it has nothing above half its rate (a consonant's hiss)."""
    return sample_rate < ALIGN_SR


def stretches(times: list[tuple[float, float]], duration: float) -> list[tuple[int, int, float, float]]:
    """The stretches of speech the words are checked in, as (first word, end word, start s,
    end s): split where :data:`STRETCH_PAUSE` or more lies between two words, and stretches of
    more than :data:`STRETCH_WORDS` words split again at their longest gap between words (in
    the middle half). Each reaches :data:`STRETCH_MARGIN` into the silence around it (at most
    half way to the next stretch)."""
    n = len(times)
    if not n:
        return []
    parts = [[0, n]]
    cuts = [k for k in range(1, n) if times[k][0] - times[k - 1][1] >= STRETCH_PAUSE]
    if cuts:
        bounds = [0] + cuts + [n]
        parts = [[p, q] for p, q in zip(bounds, bounds[1:])]
    done = []
    while parts:
        p, q = parts.pop(0)
        if q - p <= STRETCH_WORDS:
            done.append((p, q))
            continue
        lo, hi = p + (q - p) // 4, q - (q - p) // 4
        k = max(range(max(lo, p + 1), hi + 1), key=lambda k: (times[k][0] - times[k - 1][1], -abs(2 * k - p - q)))
        parts[:0] = [[p, k], [k, q]]
    out = []
    for p, q in done:
        a = max(0.0, times[p][0] - STRETCH_MARGIN)
        if p > 0:
            a = max(a, (times[p - 1][1] + times[p][0]) / 2)
        b = min(duration, times[q - 1][1] + STRETCH_MARGIN)
        if q < n:
            b = min(b, (times[q - 1][1] + times[q][0]) / 2)
        out.append((p, q, a, max(b, a)))
    return out


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
    reason), or None; the reason says what the recognizer hears there. Raises SpeechError
    when the alignment fails altogether.

    The aligner hears only the recording's speech (:func:`speech_frames`): breaths and clicks
    between the sentences are turned down to the room's noise first (:func:`aligner_pcm`), so
    that no word is aligned to a breath; a recording the aligner cannot follow so is aligned
    as it is."""
    global _aligner
    if _aligner is None:
        _aligner = _Aligner()
    _aligner.fresh()
    x16, mask, hop, speech, pcm = aligner_input(samples, sample_rate)
    try:
        times, phones = _aligner.align(pcm, words)
    except SpeechError:  # the recording as it is, breaths and all
        pcm = aligner_pcm(x16, np.ones(len(mask), dtype=bool), hop / sample_rate)
        times, phones = _aligner.align(pcm, words)
    poor = poor_fits(phones)
    extra = _aligner.extra_words(pcm, words, times, phones)
    times = trim_to_voice(times, speech, hop, sample_rate)
    absent = _aligner.absent_words(pcm, words, times, phones, band_limited=narrowband(sample_rate))
    found = first_mismatch(words, times, absent, speech & periodic_frames(x16, len(mask), hop / sample_rate),
                           hop, sample_rate, poor, extra)
    if found is None:
        return times, None
    k, t, reason, (a, b) = found
    said = _aligner.heard(pcm, a, b)
    reason += f"; from {a:.2f} to {b:.2f} s it hears " + (f"'{said}'" if said else "no words")
    return times, (k, t, reason)


class AlignerInput(NamedTuple):
    """A recording as the aligner hears it (:func:`aligner_input`)."""

    x16: np.ndarray  #: the samples at :data:`ALIGN_SR`
    mask: np.ndarray  #: voice, per frame of ``hop`` samples (:func:`audio.voice_activity`)
    hop: int  #: samples (at the recording's rate) per frame of ``mask``
    speech: np.ndarray  #: the voice frames that are speech (:func:`speech_frames`)
    pcm: bytes  #: what the aligner decodes (:func:`aligner_pcm`)


def aligner_input(samples: np.ndarray, sample_rate: int) -> AlignerInput:
    """The recording ``samples`` at ``sample_rate`` prepared for the aligner: resampled to
    :data:`ALIGN_SR`, its voice and speech found, and everything outside the speech turned
    down to the room's noise (:func:`aligner_pcm`)."""
    x16 = np.asarray(samples, dtype=np.float64)
    if sample_rate != ALIGN_SR:
        x16 = resample_poly(x16, ALIGN_SR, int(sample_rate))
    mask, hop = audio.voice_activity(samples, sample_rate)
    speech = speech_frames(x16, mask, hop / sample_rate)
    return AlignerInput(x16, mask, hop, speech, aligner_pcm(x16, speech, hop / sample_rate))


def aligner_pcm(x16: np.ndarray, speech: np.ndarray, frame_s: float) -> bytes:
    """16-bit PCM of the 16 kHz signal for the aligner: outside the speech (and
    :data:`SPEECH_MARGIN` around it) every frame louder than the recording's noise floor is
    turned down to it, so a breath or a click sounds like the room and the noise stays as it
    was (the decoder's noise tracking needs it); a small fixed-seed dither (about -70 dBFS)
    is added, as digital silence makes pocketsphinx fail. Deterministic."""
    x = np.asarray(x16, np.float64)
    step = max(1, int(round(frame_s * ALIGN_SR)))
    n = -(-len(x) // step)
    keep = np.zeros(n, dtype=bool)
    pad = int(round(SPEECH_MARGIN / frame_s))
    for a, b in _runs(speech):
        keep[max(0, a - pad): b + pad] = True
    frames = np.pad(x, (0, n * step - len(x))).reshape(n, step)
    rms = np.sqrt((frames * frames).mean(axis=1))
    floor = float(np.percentile(rms, 10)) if n else 0.0
    gain = np.where(keep, 1.0, np.minimum(1.0, floor / np.maximum(rms, 1e-12)))
    gain = np.convolve(np.pad(gain, 1, mode="edge"), np.ones(3) / 3, mode="valid")  # no step from frame to frame
    x = (frames * gain[:, None]).reshape(-1)[: len(x)] + np.random.default_rng(12345).normal(0.0, 3e-4, len(x))
    return (np.clip(x, -1.0, 1.0) * 32767.0).astype("<i2").tobytes()


def _padded(pcm: bytes) -> bytes:
    """``pcm`` with :data:`PAD_FRAMES` frames of dither before and after it: a recording that
    stops right at its last word's end leaves the aligner no frame to finish in (it fails)."""
    pad = (np.random.default_rng(54321).normal(0.0, 3e-4 * 32767.0, PAD_FRAMES * ALIGN_SR // FRAME_RATE)
           .round().astype("<i2").tobytes())
    return pad + pcm + pad


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], np.asarray(mask, np.int8), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def periodicity(x16: np.ndarray) -> np.ndarray:
    """How periodic (voiced: a vowel, a nasal) the 16 kHz signal is, per 10 ms: the peak of
    the normalised autocorrelation of 40 ms windows, at lags of 2.5 to 14 ms (70-400 Hz),
    above 250 Hz (room noise is mostly low; a breath or hiss is not periodic, about 0.2)."""
    x = np.asarray(x16, np.float64)
    win, step = int(0.04 * ALIGN_SR), int(0.01 * ALIGN_SR)
    n = len(x) // step
    if n == 0:
        return np.zeros(0)
    spec = np.fft.rfft(x)
    spec[np.fft.rfftfreq(len(x), 1 / ALIGN_SR) < 250.0] = 0
    x = np.concatenate([np.fft.irfft(spec, len(x)), np.zeros(win)])
    frames = np.lib.stride_tricks.sliding_window_view(x, win)[::step][:n]
    frames = frames - frames.mean(axis=1, keepdims=True)
    size = 1 << int(np.ceil(np.log2(2 * win)))
    ac = np.fft.irfft(np.abs(np.fft.rfft(frames, size, axis=1)) ** 2, size, axis=1)[:, :win]
    lags = np.arange(ALIGN_SR // 400, ALIGN_SR // 70)
    energy = np.cumsum(frames * frames, axis=1)
    head = energy[:, win - 1 - lags]  # energy of frame[:-lag]
    tail = energy[:, -1:] - np.concatenate([np.zeros((n, 1)), energy[:, :-1]], axis=1)[:, lags]  # frame[lag:]
    r = ac[:, lags] / np.sqrt(np.maximum(head * tail, 1e-30))
    loud = energy[:, -1] > win * 1e-8  # digital silence has no period
    return np.where(loud, r.max(axis=1), 0.0)


def periodic_frames(x16: np.ndarray, n_frames: int, frame_s: float) -> np.ndarray:
    """Per VAD frame (``frame_s`` seconds each): whether the signal is periodic there
    (:func:`periodicity` above :data:`PERIODIC`)."""
    per = periodicity(x16) > PERIODIC
    centre = (np.arange(n_frames) + 0.5) * frame_s  # window k is centred on k * 10 ms + 20 ms
    idx = np.clip(np.round(centre / 0.01 - 2).astype(int), 0, max(len(per) - 1, 0))
    return per[idx] if len(per) else np.zeros(n_frames, dtype=bool)


def speech_frames(x16: np.ndarray, mask: np.ndarray, frame_s: float) -> np.ndarray:
    """The voiced frames (``mask``, :func:`audio.voice_activity`) that are speech: runs of
    voice, joined over dips shorter than :data:`SPEECH_JOIN`, that hold periodic frames (a
    vowel) no more than :data:`SPEECH_RANGE` dB under the recording's speech. A breath, a
    click, a cough of noise or a hum far under the voice is not speech."""
    n = len(mask)
    per = periodic_frames(x16, n, frame_s)
    step = max(1, int(round(frame_s * ALIGN_SR)))
    y = np.resize(np.asarray(x16, np.float64), n * step) if len(x16) else np.zeros(n * step)
    y[len(x16):] = 0.0
    db = 10 * np.log10(np.maximum((y.reshape(n, step) ** 2).mean(axis=1), 1e-20))
    voiced = mask & per
    if not voiced.any():
        return mask.copy()  # nothing periodic (whispered?): no verdict on what is speech
    level = float(np.percentile(db[voiced], 90))
    out = np.zeros(n, dtype=bool)
    join = int(SPEECH_JOIN / frame_s)
    groups: list[list[int]] = []
    for a, b in _runs(mask):
        if groups and a - groups[-1][1] <= join:
            groups[-1][1] = b
        else:
            groups.append([a, b])
    for a, b in groups:
        if (voiced[a:b] & (db[a:b] >= level - SPEECH_RANGE)).any():
            out[a:b] = mask[a:b]
    return out


def trim_to_voice(times, mask: np.ndarray, hop: int, sample_rate: int) -> list[tuple[float, float]]:
    """Each word's interval cut to its first and last voiced frame (the aligner's frames are
    10 ms and it gives a word the silence next to it; where a pause splits its voice, to the
    part with the most voice: the rest is its neighbour's), then grown over voice the aligner left
    outside every word next to it, across dips shorter than :data:`SPEECH_JOIN`: up to
    :data:`EXTRA_NEAR` (a soft onset such as an "n" it started late), up to :data:`GROW` where
    a pause lies beyond that voice (the first word after a pause, which it often starts
    0.1-0.2 s into its voice; longer voice that runs on into the word before is a word of its
    own, which the transcript lacks); backwards also where a dip longer than
    :data:`SPEECH_JOIN` parts that voice from the word before (a stop's closure: the corpus's
    8 kHz espeak-ng 'church', started 0.34 s into its voice after 'old'). A word with no voiced
    frame is left as it is."""
    out = []
    for a, b in times:
        fa, fb = int(a * sample_rate) // hop, -(-int(round(b * sample_rate)) // hop)
        idx = np.flatnonzero(mask[fa:fb])
        if len(idx):  # voice apart by a pause is another word's: keep the word's most voice
            parts = np.split(idx, np.flatnonzero(np.diff(idx) * hop / sample_rate >= STRETCH_PAUSE) + 1)
            idx = max(parts, key=len)
            a2 = max(a, (fa + int(idx[0])) * hop / sample_rate)
            b2 = min(b, (fa + int(idx[-1]) + 1) * hop / sample_rate)
            if a2 < b2:
                a, b = a2, b2
        out.append((a, b))
    reach, near = int(GROW * sample_rate) // hop, int(EXTRA_NEAR * sample_rate) // hop
    bridge = int(SPEECH_JOIN * sample_rate) // hop
    pause = int(STRETCH_PAUSE * sample_rate) // hop
    for k, (a, b) in enumerate(out):
        fa, fb = int(round(a * sample_rate)) // hop, -(-int(round(b * sample_rate)) // hop)
        lo = -(-int(round(out[k - 1][1] * sample_rate)) // hop) if k else -pause
        hi = min(int(round(out[k + 1][0] * sample_rate)) // hop if k + 1 < len(out) else len(mask) + pause,
                 len(mask) + pause)
        f = fa
        while f > max(lo, 0, fa - reach):  # back over voice, across dips shorter than SPEECH_JOIN
            back = next((d for d in range(1, bridge + 2) if f - d >= max(lo, 0) and mask[f - d]), None)
            if back is None or (back > 1 and not (0 <= fa < len(mask) and mask[fa])):
                break
            f -= back
        # far only after a pause, or a dip longer than SPEECH_JOIN: voice that joins the word before is a word of its own
        dip = 0
        while f - dip > max(lo, 0) and not mask[f - dip - 1] and dip <= bridge:
            dip += 1
        if f < fa and (fa - f <= near or f - lo >= pause or dip > bridge):
            a = f * hop / sample_rate
        g = fb
        while g < min(hi, len(mask), fb + reach):
            on = next((d for d in range(0, bridge + 1) if g + d < min(hi, len(mask)) and mask[g + d]), None)
            if on is None or (on > 0 and not (0 < fb <= len(mask) and mask[fb - 1])):
                break
            g += on + 1
        if g > fb and (g - fb <= near or hi - g >= pause):
            b = min(g * hop / sample_rate, len(mask) * hop / sample_rate)
        out[k] = (a, b)
    return out


def first_mismatch(words, times, absent, mask, hop, sample_rate, poor=(), extra=()):
    """The earliest of: a word the recording does not say (``absent``), a word whose sounds fit
    the recording poorly (``poor``: (index, z, squeezed) of :func:`poor_fits`), a word the recording says
    that the transcript lacks (``extra``: :meth:`_Aligner.extra_words`), and
    :data:`EXTRA_VOICE` or more of voiced speech (``mask``) between two words (speech the
    transcript lacks).
    (word index, seconds, reason, (start, end) seconds of the stretch to listen to) or None;
    the stretch runs from the word before to the word after the place."""
    found = []
    n = len(times)

    def listen(k):  # from the word before to the word after
        return (times[k - 1][0] if k else max(0.0, times[k][0] - STRETCH_MARGIN),
                times[k + 1][1] if k + 1 < n else times[k][1] + STRETCH_MARGIN)

    if absent:
        k = absent[0]
        found.append((times[k][0], k, f"word {k + 1} ({words[k]!r}) is not in the recording: the aligner "
                                      f"finds no audio for it (it would be at {times[k][0]:.2f} s)", listen(k)))
    if poor:
        k, z, tight = poor[0]
        how = f"its sounds fit the audio {z:.1f} spreads worse than"
        if tight:
            how = f"its sounds are squeezed into {times[k][1] - times[k][0]:.2f} s and fit the audio {z:.1f} spreads worse than"
        found.append((times[k][0], k, f"word {k + 1} ({words[k]!r}) does not sound like the recording at "
                                      f"{times[k][0]:.2f} s: {how} the same sounds do in correct transcripts",
                      listen(k)))
    if extra:
        g, heard, t0, t1 = extra[0]
        where = (f"between {words[g - 1]!r} and {words[g]!r}" if 0 < g < n
                 else f"before {words[0]!r}" if g == 0 else f"after {words[-1]!r}")
        found.append((t0, min(g, n - 1), f"the recording says {heard!r} at {t0:.2f} s {where}, which the transcript "
                                          "does not have", (times[g - 1][0] if g else max(0.0, t0 - STRETCH_MARGIN),
                                                             times[g][1] if g < n else t1 + STRETCH_MARGIN)))
    n_frames = len(mask)
    bounds = [0] + [f for a, b in times for f in (int(a * sample_rate) // hop, -(-int(round(b * sample_rate)) // hop))]
    bounds.append(n_frames)
    for g in range(n + 1):  # gap g lies before word g
        lo, hi = bounds[2 * g], bounds[2 * g + 1]
        idx = np.flatnonzero(mask[lo:hi]) if hi > lo else np.zeros(0, dtype=int)
        if len(idx) * hop / sample_rate >= EXTRA_VOICE:
            t = (lo + int(idx[0])) * hop / sample_rate
            t_end = (lo + int(idx[-1]) + 1) * hop / sample_rate
            where = (f"between {words[g - 1]!r} and {words[g]!r}" if 0 < g < len(words)
                     else f"before {words[0]!r}" if g == 0 else f"after {words[-1]!r}")
            around = (times[g - 1][0] if g else max(0.0, t - STRETCH_MARGIN),
                      times[g][1] if g < n else t_end + STRETCH_MARGIN)
            found.append((t, min(g, len(words) - 1),
                          f"the recording has {len(idx) * hop / sample_rate:.2f} s of voiced speech at {t:.2f} s "
                          f"{where} that the transcript does not have", around))
            break
    if not found:
        return None
    t, k, reason, around = min(found, key=lambda f: f[:2])
    return k, t, reason, around
