"""Recorded speech: read the audio, get word timings (TextGrid / JSON / pocketsphinx), insert pauses.

Timings files
-------------
* Praat TextGrid, long ("ooTextFile" with ``xmin = ...`` lines) or short format, UTF-8 or
  UTF-16. The tier named ``words`` (or ``word``, any case) is used, else the first interval
  tier. Empty, ``sil``, ``sp``, ``spn`` and ``<eps>`` intervals are skipped.
* JSON: a list of ``{"word": str, "start": seconds, "end": seconds}`` (or ``{"words": [...]}``).

Timed words are matched one-to-one with the transcript's word spans after normalisation
(Unicode NFKD without accents, case folded, only letters/digits kept, so curly apostrophes and
punctuation do not matter). Without a timings file the transcript is aligned to the audio
with pocketsphinx (see :mod:`dsl.speech.align`).

Pauses are inserted into the audio as digital silence at the quietest point between the
neighbouring words; the audio is then written (mono, 16-bit PCM) to the cache.
"""

from __future__ import annotations

import math
import re
import unicodedata
from pathlib import Path
from typing import Sequence

import numpy as np

from core import cancel, limits
from core.fileio import Inside, atomic_write, json_text
from core.reading import InputFileError, loads_json, read_bytes
from core.words import TimedWord

from . import align, audio, cache
from .synth import check_pauses, check_spans, pause_boundaries
from .types import Speech, SpeechError

SKIP_LABELS = {"", "sil", "sp", "spn", "<eps>", "<sil>", "sil1"}
#: Timed words may run this far past the end of the audio (rounding in aligners) before it is an error.
END_TOLERANCE = 0.05


def normalise_word(w: str) -> str:
    w = unicodedata.normalize("NFKD", w)
    w = "".join(c for c in w if not unicodedata.combining(c))
    return "".join(c for c in w.casefold() if c.isalnum())


# -- audio ----------------------------------------------------------------------------------


#: Frames decoded at a time (the channels are mixed down block by block).
_BLOCK = 1 << 16


def read_audio(path: Path) -> tuple[np.ndarray, int]:
    """Mono float32 samples and the sample rate; SpeechError naming the file if unreadable.

    A recording longer than :func:`core.limits.current`'s ``recording_seconds_at`` its sample
    rate is refused ("too-long") from its header, before it is decoded, and decoding stops at
    the limit when the header says less than the file holds; the channels are mixed down
    block by block, so memory holds the mono samples only."""
    import soundfile as sf

    try:
        with sf.SoundFile(str(path)) as f:
            sr, channels = int(f.samplerate), int(f.channels)
            longest = limits.current().recording_seconds_at(sr)
            most = int(longest * sr)
            if f.frames > most:
                raise _too_long(path, f"it lasts {limits.duration_text(f.frames / sr)}", longest, sr)
            blocks, total = [], 0
            while True:
                cancel.check()
                block = f.read(min(_BLOCK, most + 1 - total), dtype="float32", always_2d=True)
                if not len(block):
                    break
                total += len(block)
                if total > most:
                    raise _too_long(path, "it lasts longer than its header says", longest, sr)
                blocks.append(block.mean(axis=1) if channels > 1 else block[:, 0])
    except SpeechError:
        raise
    except Exception as e:  # soundfile raises LibsndfileError/RuntimeError/OSError/TypeError
        reason = re.sub(r"^Error opening .*?: ", "", str(e)).rstrip(".")  # the file is named by the caller
        raise SpeechError(f"cannot read the audio file {str(path)!r}: {e}", kind="audio", file=path, reason=reason) from None
    if total == 0:
        raise SpeechError(f"the audio file {str(path)!r} is empty", kind="audio", file=path, reason="the file holds no samples")
    mono = blocks[0] if len(blocks) == 1 else np.concatenate(blocks)
    return np.ascontiguousarray(mono, dtype=np.float32), sr


def _too_long(path, lasts: str, longest: float, sr: int) -> SpeechError:
    at = f" at {sr} Hz" if longest < limits.current().recording_seconds else ""
    reason = f"{lasts}; sgt reads at most {limits.duration_text(longest)} of a recording{at}"
    return SpeechError(f"the audio file {str(path)!r} is too long: {reason}", kind="too-long", file=path, reason=reason)


def recording_length(path) -> float | None:
    """Seconds of a recording as its header says (None when it cannot be read: that is
    reported where it is decoded, :func:`read_audio`)."""
    info = _info(path)
    return info.frames / info.samplerate if info is not None and info.samplerate > 0 else None


# -- timings files --------------------------------------------------------------------------

_TOKEN = re.compile(r'"((?:[^"]|"")*)"|(\S+)', re.S)


def _textgrid_tokens(text: str) -> list[tuple[str, object]]:
    """Praat's reading rule: only string literals, numbers and <flags> count; labels are skipped."""
    out: list[tuple[str, object]] = []
    for m in _TOKEN.finditer(text):
        if m.group(1) is not None:
            out.append(("str", m.group(1).replace('""', '"')))
            continue
        tok = m.group(2)
        if tok.startswith("<") and tok.endswith(">"):
            out.append(("flag", tok))
            continue
        try:
            val = float(tok)
        except ValueError:
            continue
        if math.isfinite(val):
            out.append(("num", val))
    return out


def _decode_text(raw: bytes) -> str:
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        return raw.decode("utf-16")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def parse_textgrid(path: Path) -> list[tuple[str, float, float]]:
    """Timed words (label, start, end) from a TextGrid's word tier (see module docstring)."""
    name = str(path)
    try:
        text = _decode_text(read_bytes(path, "timings"))
    except InputFileError as e:
        raise SpeechError(f"cannot read the timings file {name!r}: {e.reason}", kind="timings", reason=e.reason) from None
    except OSError as e:
        raise SpeechError(f"cannot read the timings file {name!r}: {e}") from None
    toks = _textgrid_tokens(text)
    pos = 0

    def take(kind: str, what: str):
        nonlocal pos
        if pos >= len(toks):
            raise SpeechError(f"{name}: the TextGrid ends early (expected {what})")
        k, v = toks[pos]
        if k != kind:
            raise SpeechError(f"{name}: malformed TextGrid (expected {what}, found {v!r})")
        pos += 1
        return v

    if len(toks) < 2 or toks[0] != ("str", "ooTextFile") or toks[1] != ("str", "TextGrid"):
        raise SpeechError(f"{name}: not a Praat TextGrid (it must start with File type = \"ooTextFile\" "
                          "and Object class = \"TextGrid\")")
    pos = 2
    take("num", "xmin")
    take("num", "xmax")
    if pos < len(toks) and toks[pos][0] == "flag":
        if toks[pos][1] != "<exists>":
            return []
        pos += 1
    n_tiers = int(take("num", "the number of tiers"))
    tiers = []
    for t in range(n_tiers):
        cls = take("str", f"the class of tier {t + 1}")
        tier_name = take("str", f"the name of tier {t + 1}")
        take("num", "tier xmin")
        take("num", "tier xmax")
        count = int(take("num", f"the size of tier {tier_name!r}"))
        items = []
        for i in range(count):
            where = f"tier {tier_name!r} {'interval' if cls == 'IntervalTier' else 'point'} {i + 1}"
            if cls == "IntervalTier":
                a = take("num", f"xmin of {where}")
                b = take("num", f"xmax of {where}")
                label = take("str", f"the text of {where}")
                items.append((label, a, b, where))
            else:
                take("num", f"time of {where}")
                take("str", f"the mark of {where}")
        tiers.append((cls, tier_name, items))
    intervals = [t for t in tiers if t[0] == "IntervalTier"]
    if not intervals:
        raise SpeechError(f"{name}: the TextGrid has no interval tier with words")
    chosen = next((t for t in intervals if t[1].strip().lower() in ("words", "word")), intervals[0])
    out = []
    for label, a, b, where in chosen[2]:
        if label.strip().lower() in SKIP_LABELS:
            continue
        out.append((label.strip(), a, b, f"{name}: {where}"))
    return _validate(out)


def parse_json_timings(path: Path) -> list[tuple[str, float, float]]:
    name = str(path)
    try:
        data = loads_json(_decode_text(read_bytes(path, "timings")))
    except InputFileError as e:
        raise SpeechError(f"cannot read the timings file {name!r}: {e.reason}", kind="timings", reason=e.reason) from None
    except OSError as e:
        raise SpeechError(f"cannot read the timings file {name!r}: {e}") from None
    except ValueError as e:
        raise SpeechError(f"{name}: not valid JSON ({e})") from None
    if isinstance(data, dict) and isinstance(data.get("words"), list):
        data = data["words"]
    if not isinstance(data, list):
        raise SpeechError(f"{name}: expected a JSON list of {{\"word\", \"start\", \"end\"}} objects")
    out = []
    for i, entry in enumerate(data):
        where = f"{name}: entry {i + 1}"
        if not isinstance(entry, dict):
            raise SpeechError(f"{where} is not an object with \"word\", \"start\" and \"end\"")
        for field in ("word", "start", "end"):
            if field not in entry:
                raise SpeechError(f"{where} has no {field!r}")
        word, a, b = entry["word"], entry["start"], entry["end"]
        if not isinstance(word, str):
            raise SpeechError(f"{where}: \"word\" must be a string, got {word!r}")
        for field, v in (("start", a), ("end", b)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise SpeechError(f"{where} ({word!r}): {field!r} must be a number of seconds, got {v!r}")
        if word.strip().lower() in SKIP_LABELS:
            continue
        out.append((word.strip(), float(a), float(b), where))
    return _validate(out)


def _validate(items) -> list[tuple[str, float, float]]:
    prev_start = -math.inf
    out = []
    for label, a, b, where in items:
        if a < 0:
            raise SpeechError(f"{where} ({label!r}): start {a} is negative", time=a)
        if b < a:
            raise SpeechError(f"{where} ({label!r}): end {b} is before start {a}", time=a)
        if a < prev_start:
            raise SpeechError(f"{where} ({label!r}): start {a} is before the previous word's start {prev_start}",
                              time=a)
        prev_start = a
        out.append((label, a, b))
    return out


def read_timings(path: Path) -> tuple[list[tuple[str, float, float]], str]:
    """(timed words, source) from a TextGrid or JSON file, chosen by suffix or content.

    Raises :class:`SpeechError` of kind "timings" naming the file."""
    p = Path(path)
    try:
        return _read_timings(p)
    except SpeechError as e:
        reason = e.message.removeprefix(f"{p}: ")
        raise SpeechError(e.message, e.word_index, e.time, kind="timings", file=p, reason=reason) from None
    except (ValueError, OverflowError) as e:  # a number no interval can have (inf, nan)
        raise SpeechError(f"{p}: {e}", kind="timings", file=p, reason=str(e)) from None


def _read_timings(p: Path) -> tuple[list[tuple[str, float, float]], str]:
    suffix = p.suffix.lower()
    if suffix == ".json":
        return parse_json_timings(p), "json"
    if suffix == ".textgrid":
        return parse_textgrid(p), "textgrid"
    try:
        head = _decode_text(read_bytes(p, "timings")[:200]).lstrip()
    except InputFileError as e:
        raise SpeechError(f"cannot read the timings file {str(p)!r}: {e.reason}", kind="timings", reason=e.reason) from None
    except OSError as e:
        raise SpeechError(f"cannot read the timings file {str(p)!r}: {e}") from None
    except UnicodeDecodeError:
        head = ""
    if head.startswith(("[", "{")):
        return parse_json_timings(p), "json"
    return parse_textgrid(p), "textgrid"


def match_words(text: str, spans, timed, source_name: str) -> list[tuple[float, float]]:
    """Check the timed words against the transcript; (start, end) per span."""
    for i, ((s, e), (label, a, _b)) in enumerate(zip(spans, timed)):
        if normalise_word(text[s:e]) != normalise_word(label):
            raise SpeechError(
                f"{source_name}: word {i + 1} does not match the script: expected {text[s:e]!r}, "
                f"found {label!r} at {a:.2f} s", word_index=i, time=a, kind="mismatch", file=source_name)
    if len(timed) != len(spans):
        if len(timed) > len(spans):
            label, a, _ = timed[len(spans)]
            raise SpeechError(
                f"{source_name} has {len(timed)} words but the script has {len(spans)}; the first extra "
                f"word is {label!r} at {a:.2f} s", word_index=len(spans), time=a, kind="mismatch", file=source_name)
        s, e = spans[len(timed)]
        last = timed[-1][2] if timed else None
        raise SpeechError(
            f"{source_name} has {len(timed)} words but the script has {len(spans)}; no timing for "
            f"{text[s:e]!r} (word {len(timed) + 1})", word_index=len(timed), time=last, kind="mismatch", file=source_name)
    return [(a, b) for _, a, b in timed]


def check_timings(text: str, spans, timings_path: Path, duration: float) -> tuple[list[tuple[float, float]], str]:
    """Read a timings file and check it against the transcript and the recording's length:
    ((start, end) per span, source). Raises :class:`SpeechError` ("timings" or "mismatch")."""
    timed, source = read_timings(Path(timings_path))
    times = match_words(text, spans, timed, str(timings_path))
    for i, (a, _b) in enumerate(times):
        if a > duration + END_TOLERANCE:
            raise SpeechError(f"{timings_path}: word {i + 1} ({timed[i][0]!r}) starts at {a:.2f} s, after the "
                              f"end of the audio ({duration:.2f} s) - is it the right recording?",
                              word_index=i, time=a, kind="mismatch", file=timings_path)
    return times, source


def check_recording(audio_path: Path, text: str, word_spans, timings_path: Path | None = None,
                    cache_dir: Path | None = None) -> None:
    """Everything :func:`load_recording` checks before it times the words: the audio can be read
    and is not empty, the timings file (if any) is well-formed and fits the transcript and the
    recording, and without one, the recording says the transcript's words (the automatic
    alignment, cached in ``cache_dir`` as :func:`load_recording` caches it). ``sgt check``
    runs this, so it accepts exactly the recordings that ``sgt compile`` accepts. Raises
    :class:`SpeechError`."""
    spans = check_spans(text, word_spans)
    audio_path = Path(audio_path)
    samples, sr = read_audio(audio_path)
    if timings_path is not None:
        check_timings(text, spans, Path(timings_path), len(samples) / sr)
    else:
        cdir = Path(cache_dir) if cache_dir is not None else cache.default_cache_dir()
        _cached_alignment(audio_path, text, spans, samples, sr, cdir)


# -- public entry point ---------------------------------------------------------------------


def load_recording(audio_path: Path, text: str, word_spans: list[tuple[int, int]],
                   pauses: Sequence[tuple[int, float]] = (), *, timings_path: Path | None = None,
                   cache_dir: Path | None = None) -> Speech:
    """Time the word spans of ``text`` in a recording (WAV/FLAC/MP3...; stereo is mixed to mono).

    With ``timings_path`` (TextGrid or JSON) the timings are read and checked against the
    transcript; without it the transcript is aligned with pocketsphinx (en-us), with built
    pronunciations for words missing from its dictionary (see :mod:`dsl.speech.align`).
    Pauses (character offset, seconds) are inserted as silence. The returned ``audio_path`` is
    the original file when it is a mono WAV and no pause was inserted, else a mono 16-bit WAV
    in the cache.
    """
    audio_path = Path(audio_path)
    if not isinstance(text, str):
        raise SpeechError("the transcript must be a string")
    spans = check_spans(text, word_spans)
    pause_list = check_pauses(text, pauses)
    samples, sr = read_audio(audio_path)
    duration = len(samples) / sr
    cdir = Path(cache_dir) if cache_dir is not None else cache.default_cache_dir()

    if timings_path is not None:
        times, source = check_timings(text, spans, Path(timings_path), duration)
    else:
        source = "pocketsphinx"
        times = _cached_alignment(audio_path, text, spans, samples, sr, cdir)

    starts = [min(a, duration) for a, _ in times]
    ends = [min(max(b, a), duration) for (a, _), b in zip(times, [t[1] for t in times])]
    for k in range(1, len(starts)):  # keep starts non-decreasing after clamping
        starts[k] = max(starts[k], starts[k - 1])
        ends[k] = max(ends[k], starts[k])

    boundaries = pause_boundaries(spans, pause_list)
    needs_copy = bool(boundaries) or audio_path.suffix.lower() != ".wav" or _channels(audio_path) != 1
    out_path = audio_path
    if boundaries:
        samples, starts, ends = _insert_pauses(samples, sr, starts, ends, boundaries)
        duration = len(samples) / sr
    if needs_copy:
        key = cache.content_hash({"kind": "recording", "algorithm": cache.ALGORITHM_VERSION,
                                  "audio": cache.file_hash(audio_path),
                                  "pauses": sorted([[b, s] for b, s in boundaries.items()]),
                                  "spans": [list(s) for s in spans]})
        out_path = cdir / f"{key}.wav"
        if not out_path.is_file():
            atomic_write(out_path, audio.wav_bytes(samples, sr))
    words = []
    for (s, e), a, b in zip(spans, starts, ends):
        a = min(max(a, 0.0), duration)
        words.append(TimedWord(text[s:e], a, min(max(b, a), duration)))
    return Speech(out_path, sr, duration, words, source)


def _channels(path: Path) -> int:
    info = _info(path)
    return info.channels if info is not None else 0


def _info(path):
    """soundfile's header of a recording, None when it cannot be read."""
    import soundfile as sf

    try:
        return sf.info(str(path))
    except Exception:  # soundfile raises LibsndfileError/RuntimeError/OSError/TypeError
        return None


def _insert_pauses(samples, sr, starts, ends, boundaries: dict[int, float]):
    n = len(starts)
    inserts = []
    offsets = [0] * n
    for b, secs in sorted(boundaries.items()):
        cnt = int(round(secs * sr))
        if b == 0:
            pos = 0
        elif b >= n:
            pos = len(samples)
        else:
            lo = int(round(min(ends[b - 1], starts[b]) * sr))
            lo = max(lo, int(round(starts[b - 1] * sr)))
            hi = int(round(starts[b] * sr))
            pos = audio.quiet_cut(samples, sr, lo, hi) if hi > lo else hi
            ends[b - 1] = min(ends[b - 1], pos / sr)
        inserts.append((pos, cnt))
        for k in range(b, n):
            offsets[k] += cnt
    out = audio.insert_silences(samples, inserts)
    starts = [a + o / sr for a, o in zip(starts, offsets)]
    ends = [e + o / sr for e, o in zip(ends, offsets)]
    return out, starts, ends


def _cached_alignment(audio_path: Path, text: str, spans, samples, sr, cdir: Path) -> list[tuple[float, float]]:
    """Word times from pocketsphinx (cached by the audio's and the words' content); a
    recording that does not say the transcript's words raises SpeechError ("mismatch") naming
    the first word that differs and its time, cached too."""
    times, mismatch = _alignment(audio_path, text, spans, samples, sr, cdir)
    if mismatch:
        k, t, reason = int(mismatch[0]), float(mismatch[1]), str(mismatch[2])
        raise SpeechError(f"{audio_path}: {reason}", word_index=k, time=t, kind="mismatch", file=audio_path,
                          reason=reason)
    return times


def _alignment(audio_path: Path, text: str, spans, samples, sr, cdir: Path):
    """(times, mismatch) of :func:`_cached_alignment`, the verdict returned instead of raised:
    mismatch is None or [word index, seconds, reason]."""
    words = [text[s:e] for s, e in spans]
    key = cache.content_hash({"kind": "pocketsphinx-align", "algorithm": cache.ALGORITHM_VERSION,
                              "aligner": align.VERSION, "audio": cache.file_hash(audio_path), "words": words})
    meta_path = cdir / f"{key}.json"
    meta = cache.read_json(meta_path)
    if meta is not None and meta.get("key") == key and len(meta.get("times", [])) == len(words):
        times, mismatch = [(float(a), float(b)) for a, b in meta["times"]], meta.get("mismatch")
    elif not words:
        return [], None
    else:
        times, mismatch = align.align_words(samples, sr, words)
        cdir.mkdir(parents=True, exist_ok=True)
        cache.write_json(meta_path, {"key": key, "source": "pocketsphinx", "times": [list(t) for t in times],
                                     "mismatch": list(mismatch) if mismatch else None})
    return times, mismatch


#: The file name ``sgt align`` gives a recording's timings, by format: the recording's stem and this.
TIMINGS_SUFFIX = {"json": ".timings.json", "textgrid": ".TextGrid"}


def timings_path(audio_path, fmt: str = "json", folder: Path | None = None) -> Path:
    """Where ``sgt align`` writes a recording's timings in ``fmt``: the recording's stem and
    :data:`TIMINGS_SUFFIX`, in ``folder`` (default: the recording's own)."""
    audio_path = Path(audio_path)
    return (audio_path.parent if folder is None else Path(folder)) / (audio_path.stem + TIMINGS_SUFFIX[fmt])


def write_timings_file(target: Path, text: str, *, replace: bool = False) -> None:
    """Write the timings file ``target`` that ``sgt align`` (or the language server) derived from
    a recording: in ``target``'s folder by :class:`core.fileio.Inside`'s rule, so a symbolic link
    at ``target`` (dangling or not) is refused (:class:`core.fileio.LinkRefused`), with or without
    ``replace``, never written through; without ``replace`` the file is created only where
    nothing is, atomically (:class:`core.fileio.OutputExists` otherwise, even if it appeared a
    moment ago); with it, a regular file there is replaced atomically."""
    target = Path(target)
    with Inside(target.parent, create=True) as d:
        d.write(target.name, text.encode("utf-8"), exclusive=not replace)


def check_timings_target(target: Path) -> None:
    """Raise :class:`core.fileio.LinkRefused` (or another :class:`core.fileio.OutputError`) when
    :func:`write_timings_file` would refuse ``target`` whatever is in it: a link there or on the way,
    a folder or a device; writes nothing (a folder that is not there yet is fine)."""
    target = Path(target)
    if not target.parent.is_dir():
        return
    with Inside(target.parent) as d:
        d.check(target.name)


def aligner_timings(audio_path: Path, text: str, word_spans, fmt: str = "json", cache_dir: Path | None = None):
    """The automatic alignment of a recording whatever its verdict, as ``sgt align`` writes it
    (cached as :func:`load_recording` caches it): (the timings file's text in ``fmt``
    (:func:`timings_text`), the words' (start, end) times, None or the reason
    :func:`check_recording` would reject the transcript for). Raises :class:`SpeechError` when
    the audio cannot be read or aligned at all."""
    spans = check_spans(text, word_spans)
    audio_path = Path(audio_path)
    samples, sr = read_audio(audio_path)
    cdir = Path(cache_dir) if cache_dir is not None else cache.default_cache_dir()
    times, mismatch = _alignment(audio_path, text, spans, samples, sr, cdir)
    words = [text[a:b] for a, b in spans]
    return timings_text(words, times, fmt, len(samples) / sr), times, (str(mismatch[2]) if mismatch else None)


def timings_text(words: Sequence[str], times: Sequence[tuple[float, float]], fmt: str, duration: float) -> str:
    """A timings file that :func:`read_timings` reads back: ``fmt`` "json" (a list of
    {"word", "start", "end"}, the times rounded to 0.1 ms) or "textgrid" (a Praat long-format
    TextGrid with one interval tier "words", empty intervals between the words, so Praat opens
    it beside the recording to correct by hand); ``duration``: the recording's length (s)."""
    rows = [(w, round(float(a), 4), round(float(max(b, a)), 4)) for w, (a, b) in zip(words, times)]
    if fmt == "json":
        lines = [json_text({"word": w, "start": a, "end": b}) for w, a, b in rows]  # a word a line: diffs read well
        return "[\n" + ",\n".join(lines) + "\n]\n" if lines else "[]\n"
    if fmt != "textgrid":
        raise ValueError(f"unknown timings format {fmt!r}")
    end = max([duration] + [b for _, _, b in rows])
    cells: list[tuple[float, float, str]] = []
    at = 0.0
    for w, a, b in rows:
        a = max(a, at)
        if a > at:
            cells.append((at, a, ""))
        b = max(b, a + 0.0001)  # (Praat refuses an interval of no length)
        cells.append((a, b, w))
        at = b
    if end > at:
        cells.append((at, end, ""))

    def q(label: str) -> str:
        return '"' + label.replace('"', '""') + '"'

    out = ['File type = "ooTextFile"', 'Object class = "TextGrid"', "", "xmin = 0", f"xmax = {end:.4f}",
           "tiers? <exists>", "size = 1", "item []:", "    item [1]:", '        class = "IntervalTier"',
           '        name = "words"', "        xmin = 0", f"        xmax = {end:.4f}",
           f"        intervals: size = {len(cells)}"]
    for i, (a, b, label) in enumerate(cells, 1):
        out += [f"        intervals [{i}]:", f"            xmin = {a:.4f}", f"            xmax = {b:.4f}",
                f"            text = {q(label)}"]
    return "\n".join(out) + "\n"
