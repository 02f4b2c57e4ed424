"""Text-to-speech with exact word timings, through espeak-ng.

Timing model
------------
espeak-ng reports a *word event* (sample index + character position) whenever it starts
speaking a word; these are used as word start times. Engine words are mapped to our word
spans by character position:

* several events inside one span (``"1999"`` -> "nineteen ninety-nine") -> the span starts at
  the first of them;
* spans that got no event (the engine merges ``"in the"`` into one word, and some punctuation
  or symbols produce no event) share the interval from the previous anchored span's start to
  the end of voiced audio before the next anchored span, in proportion to their character
  counts; spans before the first event / after the last are placed the same way against the
  start / end of voiced audio;
* a word ends where its audio ends: the end of its last voiced frame (energy threshold, 5 ms
  frames) before the next word starts (the end of the voiced audio for the last word). Inside
  a phrase that is the next word's start; before a clause break or a pause, where the voice
  stops.

The whole text is synthesized in one call (so prosody is that of the whole utterance) and
pauses are inserted afterwards as exact digital silence after the previous word's audio;
every later time is shifted by the pause length. Inside a clause espeak-ng runs words
together, so a comma is added to the text after the word before such a pause: espeak-ng
then finishes that word, and the comma's silence is dropped (but for :data:`PAUSE_SETTLE`)
for the pause. Where the text already breaks there, the pause lengthens the audio by exactly
its length (to the sample).

Leading silence is trimmed or padded to exactly :data:`LEAD_IN` seconds before the first voiced
sample and trailing silence to exactly :data:`TAIL` seconds after the last one, so the first
word starts near 0.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from core.words import TimedWord

from . import _espeak, audio, cache, piper
from .types import Speech, SpeechError, TimedPhoneme

#: Silence kept before the first voiced sample, seconds.
LEAD_IN = 0.05
#: Silence kept after the last voiced sample, seconds.
TAIL = 0.10

#: Of the silence after a word that ends before a mid-clause pause, this much is kept before
#: the pause (its fade-out), seconds.
PAUSE_SETTLE = 0.01

#: Speaking rates (words per minute) and pitches espeak-ng accepts; ``@rate``/``@pitch`` check them.
RATE_RANGE = (80, 450)
PITCH_RANGE = (0, 100)
#: Longest voice name (``en-gb-scotland+Annie`` is 20): longer ones are refused before espeak-ng sees them.
MAX_VOICE_NAME = 64

# -- validation -----------------------------------------------------------------------------


def check_spans(text: str, word_spans) -> list[tuple[int, int]]:
    spans = []
    prev_end = 0
    for i, span in enumerate(word_spans):
        try:
            s, e = span
        except (TypeError, ValueError):
            raise SpeechError(f"word span {i} is not a (start, end) pair: {span!r}", word_index=i) from None
        if not (isinstance(s, int) and isinstance(e, int)) or isinstance(s, bool) or isinstance(e, bool):
            raise SpeechError(f"word span {i} must hold integer character offsets, got {span!r}", word_index=i)
        if not (0 <= s < e <= len(text)):
            raise SpeechError(f"word span {i} {span!r} is outside the text (length {len(text)}) or empty",
                              word_index=i)
        if s < prev_end:
            raise SpeechError(f"word span {i} {span!r} overlaps or precedes the previous span", word_index=i)
        spans.append((s, e))
        prev_end = e
    return spans


def check_pauses(text: str, pauses) -> list[tuple[int, float]]:
    out = []
    for i, p in enumerate(pauses):
        try:
            off, secs = p
            secs = float(secs)
        except (TypeError, ValueError):
            raise SpeechError(f"pause {i} is not an (offset, seconds) pair: {p!r}") from None
        if not isinstance(off, int) or isinstance(off, bool) or not (0 <= off <= len(text)):
            raise SpeechError(f"pause {i} offset {off!r} is outside the text (length {len(text)})")
        if not math.isfinite(secs) or secs < 0:
            raise SpeechError(f"pause {i} length must be a non-negative number of seconds, got {secs!r}")
        out.append((off, secs))
    return out


def pause_boundaries(spans: list[tuple[int, int]], pauses: list[tuple[int, float]]) -> dict[int, float]:
    """Map each pause to a word boundary ``b`` (the pause goes before word ``b``; ``b == len(spans)``
    is the end). A pause offset inside a word is moved to after that word. Seconds are summed."""
    out: dict[int, float] = {}
    for off, secs in pauses:
        b = 0
        for s, e in spans:
            if s < off:  # word starts before the pause offset: it is spoken before the pause
                b += 1
            else:
                break
        out[b] = out.get(b, 0.0) + secs
    return {b: s for b, s in out.items() if s > 0}


def pause_sample_counts(boundaries: dict[int, float], sample_rate: int) -> dict[int, int]:
    return {b: int(round(secs * sample_rate)) for b, secs in boundaries.items()}


# -- voices ---------------------------------------------------------------------------------

_voice_names: list[str] | None = None


def list_voices() -> list[str]:
    """Voice names accepted by :func:`synthesize`: the espeak-ng language codes (``en-us``,
    ``en-gb-scotland``, ``fr``...) and the piper voices (``joe``: :mod:`dsl.speech.piper`,
    listed whether installed or not), sorted. ``+variant`` suffixes (``en-us+f3``) are
    accepted after an espeak-ng voice."""
    global _voice_names
    with _espeak._LOCK:
        if _voice_names is None:
            try:
                eng = _espeak.engine()
            except _espeak.EngineError as e:
                raise SpeechError(e.message) from None
            names = set()
            for v in eng.voices():
                if v.languages:
                    names.add(v.languages[0].lower())
            _voice_names = sorted(names | set(piper.VOICES))
        return list(_voice_names)


def list_variants() -> list[str]:
    """The voice variants a voice name may add after ``+`` (``en-us+m3``): the installed
    espeak-ng's, sorted case-insensitively."""
    return [name for name, _ in variant_table()]


def variant_table() -> list[tuple[str, str]]:
    """(variant, description) of every installed voice variant, e.g. ("aunty", "Auntie"):
    what ``sgt voices --variants`` prints."""
    with _espeak._LOCK:
        try:
            return list(_espeak.engine().variants().items())
        except _espeak.EngineError as e:
            raise SpeechError(e.message) from None


def voice_table() -> list[tuple[str, str]]:
    """(name, description) of every voice :func:`list_voices` gives, e.g. ("en-us", "English
    (America)"), sorted by name: what ``sgt voices`` prints (a piper voice that is not
    installed says so, with the command that installs it)."""
    names = set(list_voices())
    with _espeak._LOCK:
        voices = _espeak.engine().voices()
    table: dict[str, str] = {}
    for v in voices:
        if v.languages and v.languages[0].lower() in names:
            table.setdefault(v.languages[0].lower(), v.name)
    for name, natural in piper.VOICES.items():
        lacking = piper.missing(natural)
        table[name] = natural.description + (f" (not installed: {piper.INSTALL})" if lacking else "")
    return sorted(table.items())


_checked_voices: dict[str, str | SpeechError] = {}


def check_voice(voice: str) -> str:
    """The espeak-ng voice ``voice`` resolves to, as :func:`synthesize` resolves it; raises
    :class:`SpeechError` (kind "voice" for an unknown name, "engine" when espeak-ng cannot be
    loaded). ``sgt check`` calls this, so it accepts exactly the voices ``sgt compile`` does.
    Results are kept for the process. A piper voice (``joe``) gives its name, or kind
    "not-installed" when piper or the voice's package is missing."""
    natural = piper.voice_of(voice)
    if natural is not None:
        return piper.check(natural)
    hit = _checked_voices.get(voice)
    if hit is None:
        try:
            with _espeak._LOCK:
                hit = _resolve_voice(_espeak.engine(), voice)
        except _espeak.EngineError as e:
            hit = SpeechError(e.message)
        except SpeechError as e:
            hit = e
        _checked_voices[voice] = hit
    if isinstance(hit, SpeechError):
        raise hit
    return hit


def _resolve_voice(eng, voice: str) -> str:
    """An espeak voice name for ``voice`` or SpeechError (kind "voice"). Only names the engine
    lists get through (:meth:`dsl.speech._espeak._Engine.set_voice` refuses the rest too)."""
    if not isinstance(voice, str) or not voice.strip():
        raise SpeechError("the voice name is empty", kind="voice", reason="")
    voice = voice.strip()
    if len(voice) > MAX_VOICE_NAME:
        raise SpeechError(f"the voice name is {len(voice)} characters long; voice names are at most {MAX_VOICE_NAME} "
                          "('sgt voices' lists them)", kind="voice", reason="voice")
    base, plus, variant = voice.partition("+")
    key = base.lower()
    chosen = None
    for v in eng.voices():
        if key in (v.name.lower(), v.identifier.lower()) or (v.languages and v.languages[0].lower() == key):
            chosen = v.identifier
            break
    if chosen is None:
        for v in eng.voices():
            if key in (lang.lower() for lang in v.languages):
                chosen = v.identifier
                break
    if chosen is None:
        raise SpeechError(f"unknown voice {voice!r}{_close(key, list_voices())} ('sgt voices' lists the voices)",
                          kind="voice", reason="voice")
    candidate = chosen
    if plus:
        canonical = {name.lower(): name for name in eng.variants()}.get(variant.lower())
        if canonical is None:
            raise SpeechError(f"unknown voice variant {variant!r} in {voice!r}{_close(variant.lower(), eng.variants())} "
                              "('sgt voices --variants' lists them)", kind="voice", reason="voice variant")
        candidate = f"{chosen}+{canonical}"
    if eng.set_voice(candidate):
        return candidate
    raise SpeechError(f"espeak-ng could not load the voice {voice!r}", kind="voice", reason="voice")


def _close(word: str, choices) -> str:
    import difflib

    close = difflib.get_close_matches(word, [c.lower() for c in choices], n=3, cutoff=0.5)
    return f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""


# -- phonemes of words ----------------------------------------------------------------------

#: First characters of IPA vowels (a phoneme is a vowel when its name starts with one).
IPA_VOWELS = frozenset("aeiouyæɐɑɒɔəɘɚɛɜɝɞɤɨɪʉʊʌʏøœɶɵᵻ")
#: How much longer than a consonant a vowel is taken to last when phonemes are spread over a
#: word's time (a recording's words), and a stressed vowel longer still.
VOWEL_SHARE, STRESSED_SHARE = 2.0, 3.0


def is_vowel(phoneme: str) -> bool:
    return bool(phoneme) and phoneme[0] in IPA_VOWELS


def phonemes_of_words(words: Sequence[TimedWord], voice: str = "en-us") -> list[TimedPhoneme]:
    """Phonemes for timed words whose audio espeak-ng did not make (a recording): each word's
    phonemes as espeak-ng's dictionary and rules give them for ``voice``'s language
    (``espeak_TextToPhonemes``, the word on its own, in a worker process as synthesis is),
    spread over the word's time, a vowel :data:`VOWEL_SHARE` times as long as a consonant
    (:data:`STRESSED_SHARE` when stressed).
    An empty list when espeak-ng or the voice is missing (the face then moves the mouth with
    the words alone)."""
    natural = piper.voice_of(voice)
    if natural is not None:  # a piper voice's phonemes are espeak-ng's of its language
        voice = natural.language
    try:
        with _espeak._LOCK:
            resolved = _resolve_voice(_espeak.engine(), voice)
        per_word = _espeak.run_text_to_phonemes([w.word for w in words], resolved) if words else []
    except (_espeak.EngineError, SpeechError):
        return []
    out: list[TimedPhoneme] = []
    for w, names in zip(words, per_word):
        marked = [_espeak.split_stress(n) for n in names if n]
        if not marked or w.end <= w.start:
            continue
        shares = [(STRESSED_SHARE if k == 2 else VOWEL_SHARE) if is_vowel(n) else 1.0 for n, k in marked]
        total, at = sum(shares), 0.0
        for (name, stress), share in zip(marked, shares):
            a = w.start + (w.end - w.start) * at / total
            at += share
            out.append(TimedPhoneme(name, a, w.start + (w.end - w.start) * at / total, stress))
    return out


# -- timing ---------------------------------------------------------------------------------


def _event_starts(spans, events, n_samples, mask, hop) -> list[float]:
    """Start sample (float) per span from engine word events; see the module docstring."""
    n = len(spans)
    anchor: list[int | None] = [None] * n
    starts_sorted = [s for s, _ in spans]
    import bisect

    for ev in events:
        pos = ev.char_index
        j = bisect.bisect_right(starts_sorted, pos) - 1
        if j >= 0 and spans[j][0] <= pos < spans[j][1]:
            k = j
        else:  # event starts in a gap (space/punctuation): give it to the span it runs into
            k = j + 1
            if not (k < n and spans[k][0] < pos + max(ev.length, 1)):
                continue
        if anchor[k] is None or ev.sample < anchor[k]:
            anchor[k] = ev.sample
    # keep anchors monotonic in word order
    last = -1
    for k in range(n):
        if anchor[k] is not None:
            if anchor[k] < last:
                anchor[k] = None
            else:
                last = anchor[k]
    bounds = audio.voiced_bounds(mask, hop, n_samples)
    v0, v1 = bounds if bounds else (0, n_samples)
    starts: list[float] = [0.0] * n
    anchored = [k for k in range(n) if anchor[k] is not None]
    for k in anchored:
        starts[k] = float(anchor[k])

    def spread(ks: list[int], t0: float, t1: float) -> None:
        lens = [spans[k][1] - spans[k][0] for k in ks]
        total = float(sum(lens))
        acc = 0
        for k, ln in zip(ks, lens):
            starts[k] = t0 + (t1 - t0) * acc / total
            acc += ln

    if not anchored:
        spread(list(range(n)), float(v0), float(v1))
        return starts
    first = anchored[0]
    if first > 0:
        t1 = float(anchor[first])
        spread(list(range(first)), min(float(v0), t1), t1)
    for a, b in zip(anchored, anchored[1:] + [n]):
        if b - a <= 1:
            continue
        ta = float(anchor[a])
        hi = int(anchor[b]) if b < n else n_samples
        tb = float(audio.voiced_end_in(mask, hop, int(ta), hi))
        tb = max(tb, ta)
        spread(list(range(a, b)), ta, tb)
    return starts


def _word_ends(spans, starts: list[float], mask, hop, n_samples: int, v1: int) -> list[float]:
    """End sample per span: the end of the last voiced frame between its start and the next
    span's start (the end of the voiced audio for the last span), never before its start."""
    n = len(spans)
    ends = [0.0] * n
    for k in range(n):
        hi = int(starts[k + 1]) if k + 1 < n else v1
        hi = max(hi, int(math.ceil(starts[k])))
        ends[k] = float(max(audio.voiced_end_in(mask, hop, int(starts[k]), hi), starts[k]))
    return ends


def _timeline(samples: np.ndarray, sample_rate: int, spans, starts: list[float], pause_n: dict[int, int],
              joined: set[int], lead: float, tail: float, points: Sequence[float] = (),
              ends: list[float] | None = None):
    """Word ends (unless given: piper's alignments), pauses, trimmed/padded ends. Returns (samples, starts, ends, places) in
    samples: ``places`` maps each of ``points`` (positions in the engine's audio: phoneme
    events) to where that audio is in the result, as (start, end): a point where an inserted
    pause begins is the start of what comes after it and the end of what comes before it.

    A pause at boundary ``b`` goes after the previous word's audio (its end), never inside it:
    where the text already had a clause break there, at the quietest point of the silence
    espeak-ng left before the next word; where ``b`` is in ``joined`` (a comma was added to the
    text so that espeak-ng finishes the word, see :func:`_clause_breaks`), that comma's own
    silence is removed but for :data:`PAUSE_SETTLE` and the pause takes its place."""
    n = len(spans)
    mask, hop = audio.voiced_mask(samples, sample_rate)
    bounds = audio.voiced_bounds(mask, hop, len(samples))
    v0, v1 = bounds if bounds else (0, len(samples))
    lead_n, tail_n = int(round(lead * sample_rate)), int(round(tail * sample_rate))
    if ends is None:
        ends = _word_ends(spans, starts, mask, hop, len(samples), v1)
    cuts: dict[int, int] = {}
    removed: list[tuple[int, int]] = []
    settle = int(round(PAUSE_SETTLE * sample_rate))
    for b in sorted(pause_n):
        if 0 < b < n:
            lo, hi = int(math.ceil(ends[b - 1])), int(starts[b])
            if hi <= lo:
                cuts[b] = int(starts[b])
            elif b in joined:
                cuts[b] = lo + min(settle, hi - lo)
                removed.append((cuts[b], hi))
            else:
                cuts[b] = audio.quiet_cut(samples, sample_rate, lo, hi)
    if removed:  # drop the added commas' silences; every position after one moves back
        keep = np.ones(len(samples), dtype=bool)
        for a, b in removed:
            keep[a:b] = False
        samples = samples[keep]

        def moved(p: float) -> float:
            return p - sum(min(max(p - a, 0), b - a) for a, b in removed)

        starts, ends = [moved(x) for x in starts], [moved(x) for x in ends]
        points = [moved(x) for x in points]
        cuts = {b: int(moved(c)) for b, c in cuts.items()}
        v0, v1 = int(moved(v0)), int(moved(v1))
    # trim/pad ends: keep exactly lead_n before v0 and tail_n after v1
    shift = lead_n - v0
    body = samples[v0:v1]
    out = np.concatenate([np.zeros(lead_n, samples.dtype), body, np.zeros(tail_n, samples.dtype)])
    total = len(out)
    starts = [min(max(s + shift, 0.0), float(total)) for s in starts]
    ends = [min(max(e + shift, 0.0), float(total)) for e in ends]
    cut_pos = {b: min(max(c + shift, 0), total) for b, c in cuts.items()}
    # pauses: at boundary 0 -> at time 0; at n -> appended; else at the cut
    inserts = []
    if pause_n.get(0):
        inserts.append((0, pause_n[0]))
    for b, c in cut_pos.items():
        inserts.append((int(c), pause_n[b]))
    if pause_n.get(n) and n > 0:
        inserts.append((total, pause_n[n]))
    out = audio.insert_silences(out, inserts)
    placed = [min(max(p + shift, 0.0), float(total)) for p in points]
    places = [(p + sum(k for at, k in inserts if at <= p), p + sum(k for at, k in inserts if at < p)) for p in placed]
    offs = [0] * n
    for b, cnt in pause_n.items():
        for k in range(b, n):
            offs[k] += cnt
    starts = [s + o for s, o in zip(starts, offs)]
    ends = [e + o for e, o in zip(ends, offs)]
    return out, starts, ends, places


def _timed_phonemes(phonemes, places, sample_rate: int, n_samples: int) -> list[TimedPhoneme]:
    """The phonemes of the result (pauses, which espeak-ng reports as phonemes without a
    name, left out): each from where its audio starts to where the next phoneme's (a pause's
    included) starts, the last to the end of the voice (:data:`TAIL` before the end)."""
    out: list[TimedPhoneme] = []
    voice_end = max(0.0, n_samples / sample_rate - TAIL)
    for k, p in enumerate(phonemes):
        if not p.name:
            continue
        start = places[k][0] / sample_rate
        end = places[k + 1][1] / sample_rate if k + 1 < len(places) else max(voice_end, start)
        out.append(TimedPhoneme(p.name, start, max(end, start), p.stress))
    return out


#: Characters after which espeak-ng ends a clause (and so a word's audio) before going on.
_CLAUSE_MARKS = ",.;:!?"


def _clause_breaks(text: str, spans, boundaries: dict[int, float]) -> tuple[str, list[int], set[int]]:
    """The text espeak-ng speaks, with a comma after the word before each pause that is not
    already at a clause break (inside a clause, espeak-ng runs the words together: a cut there
    would split a word); the original character index of every character of that text (an
    added comma maps to where it was added), and the boundaries that got a comma."""
    joined = {b for b in boundaries if 0 < b < len(spans)
              and not any(c in _CLAUSE_MARKS for c in text[spans[b - 1][1]:spans[b][0]])}
    at = sorted(spans[b - 1][1] for b in joined)
    pieces, origin, prev = [], [], 0
    for pos in at:
        pieces += [text[prev:pos], ","]
        origin += list(range(prev, pos)) + [pos]
        prev = pos
    pieces.append(text[prev:])
    origin += list(range(prev, len(text) + 1))
    return "".join(pieces), origin, joined


def _build_words(text, spans, starts, ends, sample_rate, n_samples) -> list[TimedWord]:
    dur = n_samples / sample_rate
    words = []
    prev = 0.0
    for (s, e), a, b in zip(spans, starts, ends):
        st = min(max(a / sample_rate, prev), dur)
        en = min(max(b / sample_rate, st), dur)
        words.append(TimedWord(text[s:e], st, en))
        prev = st
    return words


# -- public entry point ---------------------------------------------------------------------


def synthesize(text: str, word_spans: list[tuple[int, int]], pauses: Sequence[tuple[int, float]] = (), *,
               voice: str = "en-us", rate: int = 175, pitch: int = 50, cache_dir: Path | None = None) -> Speech:
    """Speak ``text`` with espeak-ng and time each word span (see the module docstring).

    ``word_spans`` are (start, end) character offsets of the word tokens in ``text``; ``pauses``
    are (character offset, seconds) of silences to insert. ``rate`` is words per minute
    (80..450), ``pitch`` 0..100. Results are cached by content hash in ``cache_dir``
    (default :func:`default_cache_dir`); a cache hit does not touch the engine.
    """
    if not isinstance(text, str):
        raise SpeechError("the text to speak must be a string")
    spans = check_spans(text, word_spans)
    pause_list = check_pauses(text, pauses)
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not (RATE_RANGE[0] <= rate <= RATE_RANGE[1]):
        raise SpeechError(f"speech rate must be {RATE_RANGE[0]}..{RATE_RANGE[1]} words per minute, got {rate!r}")
    if isinstance(pitch, bool) or not isinstance(pitch, (int, float)) or not (PITCH_RANGE[0] <= pitch <= PITCH_RANGE[1]):
        raise SpeechError(f"pitch must be {PITCH_RANGE[0]}..{PITCH_RANGE[1]}, got {pitch!r}")
    if not isinstance(voice, str) or not voice.strip():
        raise SpeechError("the voice name is empty")
    rate, pitch = int(round(rate)), int(round(pitch))
    clean = text.replace("\0", " ")
    boundaries = pause_boundaries(spans, pause_list)
    natural = piper.voice_of(voice)
    if natural is not None:  # a piper voice: no pitch (sgt check warns where @pitch is set)
        return piper.synthesize(clean, spans, boundaries, natural, rate, cache_dir)
    spoken, origin, joined = _clause_breaks(clean, spans, boundaries)

    key = cache.content_hash({
        "kind": "espeak-ng", "algorithm": cache.ALGORITHM_VERSION, "engine": _espeak.engine_fingerprint(),
        "voice": voice.strip(), "rate": rate, "pitch": pitch, "text": clean,
        "spans": [list(s) for s in spans], "pauses": sorted([b, s] for b, s in boundaries.items()),
        "lead": LEAD_IN, "tail": TAIL,
    })
    cdir = Path(cache_dir) if cache_dir is not None else cache.default_cache_dir()
    wav_path, meta_path = cdir / f"{key}.wav", cdir / f"{key}.json"
    hit = _load_cached(wav_path, meta_path, key, len(spans))
    if hit is not None:
        return hit

    try:
        with _espeak._LOCK:
            eng = _espeak.engine()
            resolved = _resolve_voice(eng, voice)
            sr = eng.sample_rate
        if spans:
            sr, raw, events, phonemes = _espeak.run_synth(spoken, resolved, rate, pitch)
            events = [_espeak.WordEvent(origin[min(e.char_index, len(origin) - 1)], e.length, e.sample)
                      for e in events]
        else:
            raw, events, phonemes = b"", [], []
    except _espeak.EngineError as e:
        raise SpeechError(e.message, kind="crash" if e.kind == "crash" else "engine") from None
    samples = np.frombuffer(raw, dtype="<i2").astype(np.int16)
    mask, hop = audio.voiced_mask(samples, sr)
    starts = _event_starts(spans, events, len(samples), mask, hop) if spans else []
    out, starts, ends, places = _timeline(samples, sr, spans, starts, pause_sample_counts(boundaries, sr), joined,
                                          LEAD_IN, TAIL, [float(p.sample) for p in phonemes])
    words = _build_words(clean, spans, starts, ends, sr, len(out))
    timed = _timed_phonemes(phonemes, places, sr, len(out))
    cdir.mkdir(parents=True, exist_ok=True)
    wav = audio.wav_bytes(out, sr)
    cache.write_bytes(wav_path, wav)
    meta = {"key": key, "source": "espeak-ng", "sample_rate": sr, "duration": len(out) / sr,
            "words": [[w.word, w.start, w.end] for w in words], "wav_bytes": len(wav),
            "phonemes": [list(p) for p in timed]}
    cache.write_json(meta_path, meta)
    return Speech(wav_path, sr, len(out) / sr, words, "espeak-ng", timed)


def _load_cached(wav_path: Path, meta_path: Path, key: str, n_words: int) -> Speech | None:
    if not (wav_path.is_file() and meta_path.is_file()):
        return None
    meta = cache.read_json(meta_path)
    try:
        if meta is None or meta.get("key") != key or len(meta["words"]) != n_words:
            return None
        if "wav_bytes" in meta and wav_path.stat().st_size != int(meta["wav_bytes"]):
            return None  # a short WAV (the entry is written without fsync): made again
        words = [TimedWord(str(t), float(a), float(b)) for t, a, b in meta["words"]]
        phonemes = [TimedPhoneme(str(p), float(a), float(b), int(k)) for p, a, b, k in meta.get("phonemes", [])]
        return Speech(wav_path, int(meta["sample_rate"]), float(meta["duration"]), words, str(meta["source"]), phonemes)
    except (KeyError, TypeError, ValueError, OSError):
        return None
