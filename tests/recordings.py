"""Recordings as users make them, for the tests and benchmarks/bench_timing.py (issue 27).

Nothing here is committed audio: every recording is made, deterministically, from

- human speech that Debian ships: the LibriVox reader of pocketsphinx-testdata (*Sense and
  Sensibility*, 5 sentences, 16 kHz), its "cards" speaker (5 phrases, 16 kHz) and the
  alsa-utils channel phrases ("Front left", 8, 48 kHz);
- synthetic voices: espeak-ng (through :func:`dsl.speech.synthesize`, several accents and
  rates) and Festival's three English voices (:mod:`model.training.voices`);

joined, 2 to 4 sentences of one speaker a recording, by gaps of 0.5 to 4 s of digital
silence or of room noise (pink noise at -60 to -40 dBFS, under the speech too), with leading
and trailing silence, sometimes a breath or a click in a gap, each sentence cut at the onset
of its first word so that the speech starts right at a gap's end, at 8 to 48 kHz, mono or
stereo, written as WAV, FLAC or MP3.

Each recording knows where its words start (``onsets``, seconds in the recording): every word
of the synthetic voices (the engines report them), the first word of every human sentence
(where the sentence was cut; None for their other words).

:func:`corpus` makes the whole set (:data:`SIZE` recordings, the first one the case of issue
27); :func:`wrong_transcripts` gives each a transcript with a word added, dropped or changed.
"""

from __future__ import annotations

import re
import shutil
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

LIBRIVOX = Path("/usr/share/pocketsphinx/test/data/librivox")
CARDS = Path("/usr/share/pocketsphinx/test/data/cards")
ALSA = Path("/usr/share/sounds/alsa")
ALSA_PHRASES = ["Front_Left", "Front_Center", "Front_Right", "Rear_Left", "Rear_Center", "Rear_Right",
                "Side_Left", "Side_Right"]

#: Sentences for the synthetic voices: many start with a soft consonant (h, w, m, n, y, f, s,
#: th, l), which is where an aligner loses a word after a silence.
TTS_SENTENCES = [
    "He was not in the house when we came back.",
    "How are you today?",
    "Where did you leave the keys?",
    "Her brother lives in a small town by the sea.",
    "Many people walked along the river that morning.",
    "Now turn left at the old church.",
    "Yes, I think that would be fine.",
    "Why did nobody tell me about it?",
    "Fine rain fell all through the night.",
    "So we waited for the last train home.",
    "Things will look better in the spring.",
    "Lunch is ready in the kitchen.",
    "She sat in the garden and read a book.",
    "Thank you for coming all this way.",
    "We should leave before it gets dark.",
    "Your table is by the window.",
    "Hold the door for the next person.",
    "My sister bought a green bicycle.",
]

#: The speakers, cycled through by the recordings.
SPEAKERS = ["librivox", "espeak:en-us", "cards", "festival:kal_diphone", "alsa", "espeak:en-gb",
            "festival:cmu_us_slt_arctic_hts", "espeak:en-us+f3", "festival:ked_diphone"]
GAPS_S = (0.5, 1.0, 1.5, 2.5, 3.0, 4.0)
NOISE_DBFS = (None, -60.0, -50.0, -45.0, -40.0)  # None: digital silence between the sentences
RATES = (8000, 16000, 22050, 44100, 48000)
FORMATS = ("wav", "flac", "mp3")
EXTRAS = (None, "breath", "click")
EDGES_S = ((0.0, 0.0), (0.3, 0.5), (1.0, 1.0), (2.0, 0.2))  # (leading, trailing) silence
SPEECH_DBFS = -20.0
SIZE = 72

#: Words put into or swapped into a transcript by :func:`wrong_transcripts` (none of them
#: sounds like a word of the corpus).
OTHER_WORDS = ["carriage", "wonderful", "yesterday", "basket", "seventy", "elephant", "pocket",
               "umbrella", "tomorrow", "kitchen", "purple", "dinosaur"]

WORD = re.compile(r"[\w'\-]+")


def words_of(text: str) -> list[str]:
    return WORD.findall(text)


def spans_of(text: str) -> list[tuple[int, int]]:
    return [m.span() for m in WORD.finditer(text)]


@dataclass
class Sentence:
    text: str
    samples: np.ndarray  # mono float64, starting at its first word's onset
    rate: int
    onsets: list  # per word: seconds from samples[0], or None where not known
    speaker: str


@dataclass
class Recording:
    name: str
    path: Path
    text: str
    onsets: list  # per word: seconds in the recording, or None where not known
    spec: dict = field(default_factory=dict)

    @property
    def words(self) -> list[str]:
        return words_of(self.text)


# -- what is installed -----------------------------------------------------------------------


def human_speech_installed() -> bool:
    return (LIBRIVOX / "transcription").is_file() and (CARDS / "cards.transcription").is_file() \
        and (ALSA / "Front_Left.wav").is_file()


def voices_installed() -> bool:
    from dsl.speech import _espeak  # lazy: only to tell whether the voices are installed
    from model.training.voices import festival_voices  # lazy: the model layer, for Festival's voices only

    want = {s.removeprefix("festival:") for s in SPEAKERS if s.startswith("festival:")}
    return _espeak.find_library() is not None and want <= {v.removeprefix("festival:") for v in festival_voices()}


def available() -> str | None:
    """Why the corpus cannot be made here (None when it can)."""
    if not human_speech_installed():
        return "pocketsphinx-testdata or alsa-utils not installed (scripts/install.sh)"
    if not voices_installed():
        return "espeak-ng or Festival's voices not installed (scripts/install.sh)"
    if shutil.which("festival") is None:
        return "festival not installed"
    return None


# -- signals -----------------------------------------------------------------------------------


def _read(path: Path) -> tuple[np.ndarray, int]:
    import soundfile as sf

    x, sr = sf.read(str(path), dtype="float64", always_2d=True)
    return x.mean(axis=1), int(sr)


def _resample(x: np.ndarray, rate_in: int, rate_out: int) -> np.ndarray:
    from scipy.signal import resample_poly

    if rate_in == rate_out:
        return np.asarray(x, np.float64)
    g = np.gcd(int(rate_in), int(rate_out))
    return resample_poly(x, rate_out // g, rate_in // g)


def _envelope_db(x: np.ndarray, sr: int) -> np.ndarray:
    """dBFS of 10 ms Hann windows every 1 ms (window k covers samples k ms .. k ms + 10 ms)."""
    win, hop = int(round(0.010 * sr)), int(round(0.001 * sr))
    if len(x) < win:
        return np.full(1, -200.0)
    frames = np.lib.stride_tricks.sliding_window_view(x, win)[::hop]
    w = np.hanning(win)
    return 10 * np.log10(np.maximum((frames * frames * w).sum(axis=1) / w.sum(), 1e-20))


def high_pass(x: np.ndarray, sr: int, cutoff: float = 100.0) -> np.ndarray:
    """``x`` without what lies under ``cutoff`` Hz (a microphone's thumps and hum are no voice)."""
    spec = np.fft.rfft(x)
    spec[np.fft.rfftfreq(len(x), 1 / sr) < cutoff] = 0
    return np.fft.irfft(spec, len(x))


def voice_span(x: np.ndarray, sr: int) -> tuple[int, int]:
    """(onset, end) samples of the voice in a clip, on its envelope above 100 Hz: from the first
    10 ms window 25 dB under the loudest, walked back while the windows stay 10 dB above the
    clip's quietest tenth (so a soft first consonant is kept, a breath separated from the word
    by a dip is not), to the last window 35 dB under the loudest, walked on the same way, plus
    30 ms."""
    db = _envelope_db(high_pass(x, sr), sr)
    peak, floor = float(db.max()), float(np.percentile(db, 10))
    hop, win = int(round(0.001 * sr)), int(round(0.010 * sr))
    first = int(np.flatnonzero(db > peak - 25)[0])
    on_level = max(floor + 10, peak - 45)
    while first > 0 and db[first - 1] > on_level:
        first -= 1
    last = int(np.flatnonzero(db > peak - 35)[-1])
    while last + 1 < len(db) and db[last + 1] > on_level:
        last += 1
    # the window's centre is where its energy is: 5 ms in
    return max(0, first * hop + win // 2), min(len(x), last * hop + win + int(0.03 * sr))


def active_rms(x: np.ndarray, sr: int) -> float:
    """RMS of the clip's loud part (10 ms windows within 30 dB of the loudest)."""
    db = _envelope_db(x, sr)
    loud = db[db > db.max() - 30]
    return float(np.sqrt(np.mean(10 ** (loud / 10))))


def pink_noise(n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` samples of noise with a 1/f spectrum (room noise is mostly low), RMS 1."""
    spec = np.fft.rfft(rng.normal(size=n))
    f = np.arange(len(spec), dtype=np.float64)
    spec[1:] /= np.sqrt(f[1:])
    spec[0] = 0
    y = np.fft.irfft(spec, n)
    return y / max(float(np.sqrt(np.mean(y * y))), 1e-12)


def breath(sr: int, rng: np.random.Generator, seconds: float = 0.35, dbfs: float = -34.0) -> np.ndarray:
    """An in-breath: noise between 300 and 2500 Hz under a rise-and-fall envelope."""
    n = int(seconds * sr)
    spec = np.fft.rfft(rng.normal(size=n))
    f = np.fft.rfftfreq(n, 1 / sr)
    spec[(f < 300) | (f > 2500)] = 0
    y = np.fft.irfft(spec, n)
    y *= np.sin(np.linspace(0, np.pi, n)) ** 2
    return y / np.sqrt(np.mean(y * y)) * 10 ** (dbfs / 20)


def click(sr: int, dbfs_peak: float = -12.0) -> np.ndarray:
    """A lip smack or a mouse click: 4 ms of a damped 2 kHz ring."""
    t = np.arange(int(0.004 * sr)) / sr
    return 10 ** (dbfs_peak / 20) * np.sin(2 * np.pi * 2000 * t) * np.exp(-t / 0.001)


# -- sentences -------------------------------------------------------------------------------


def _sphinx_transcripts(path: Path) -> dict[str, str]:
    out = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        m = re.match(r"<s>(.*)</s>\s*\((.*)\)", line.strip())
        if m:
            out[m.group(2).strip()] = " ".join(m.group(1).split())
    return out


def _as_written(words: str) -> str:
    """A transcription's lower-case words as a user writes them: capitalised, with a full stop."""
    return words[:1].upper() + words[1:] + "."


def _human(speaker: str, path: Path, words: str) -> Sentence:
    x, sr = _read(path)
    a, b = voice_span(x, sr)
    text = _as_written(words)
    return Sentence(text, x[a:b], sr, [0.0] + [None] * (len(words_of(text)) - 1), speaker)


def human_sentences(speaker: str) -> list[Sentence]:
    if speaker == "librivox":
        texts = _sphinx_transcripts(LIBRIVOX / "transcription")
        return [_human(speaker, LIBRIVOX / f"{k}.wav", t) for k, t in sorted(texts.items())]
    if speaker == "cards":
        texts = _sphinx_transcripts(CARDS / "cards.transcription")
        return [_human(speaker, CARDS / f"{k}.wav", t) for k, t in sorted(texts.items())]
    if speaker == "alsa":
        return [_human(speaker, ALSA / f"{p}.wav", p.replace("_", " ").lower()) for p in ALSA_PHRASES]
    raise ValueError(speaker)


def _tts_cut(x: np.ndarray, sr: int, starts: list[float], text: str, speaker: str) -> Sentence:
    """Cut a synthesized sentence at its first word's onset (the engine's start or the first
    sound, the earlier) and at the end of its voice."""
    loud = np.flatnonzero(np.abs(x) > 10 ** (-60 / 20))
    a = min(int(round(starts[0] * sr)), int(loud[0]))
    _, b = voice_span(x, sr)
    return Sentence(text, x[a:b], sr, [s - a / sr for s in starts], speaker)


def espeak_sentence(text: str, voice: str, rate: int, cache: Path) -> Sentence:
    from dsl.speech import synthesize  # lazy: the speech engine, only for espeak-ng sentences

    s = synthesize(text, spans_of(text), voice=voice, rate=rate, cache_dir=cache)
    x, sr = _read(s.audio_path)
    return _tts_cut(x, sr, [w.start for w in s.words], text, f"espeak:{voice}")


def festival_sentence(text: str, voice: str, folder: Path, stretch: float = 1.0) -> Sentence:
    from model.training.voices import festival_say  # lazy: the model layer, for Festival's sentences only

    wav = folder / f"festival-{voice}-{zlib.crc32(f'{text} {stretch}'.encode()):08x}.wav"
    timed = festival_say(text, voice, wav, stretch)
    if [normal(w) for w, _, _ in timed] != [normal(w) for w in words_of(text)]:
        raise ValueError(f"Festival spoke other words: {timed}")
    x, sr = _read(wav)
    return _tts_cut(x, sr, [a for _, a, _ in timed], text, f"festival:{voice}")


def normal(word: str) -> str:
    return "".join(c for c in word.casefold() if c.isalnum())


# -- recordings ------------------------------------------------------------------------------


def spec_of(i: int, sentences: list[str] = TTS_SENTENCES) -> dict:
    """Recording ``i``'s recipe (recording 0 is issue 27's); the synthetic voices say some of
    ``sentences``."""
    if i == 0:  # three sentences of an audiobook reader, 2.5 s of room noise at -45 dBFS between them
        return {"speaker": "librivox", "sentences": [1, 4, 2], "gaps": [2.5, 2.5], "noise": -45.0,
                "extra": None, "edges": (1.5, 1.5), "rate": 16000, "channels": 1, "format": "wav",
                "levels": [0.0, 0.0, 0.0], "seed": 0}
    rng = np.random.default_rng(1000 + i)
    speaker = SPEAKERS[i % len(SPEAKERS)]
    pool = {"librivox": 5, "cards": 5, "alsa": 8}.get(speaker, len(sentences))
    n = int(rng.integers(2, 5)) if pool > 5 else int(rng.integers(2, 4))
    return {
        "speaker": speaker,
        "sentences": [int(k) for k in rng.choice(pool, size=n, replace=False)],
        "gaps": [float(GAPS_S[(i + 2 * j) % len(GAPS_S)]) for j in range(n - 1)],
        "noise": NOISE_DBFS[i % len(NOISE_DBFS)],
        "extra": EXTRAS[(i // 2) % len(EXTRAS)],
        "edges": EDGES_S[(i // 3) % len(EDGES_S)],
        "rate": RATES[(i // 5) % len(RATES)],
        "channels": 1 + (i // 4) % 2,
        "format": FORMATS[(i // 7) % len(FORMATS)],
        "levels": [float(v) for v in rng.uniform(-4, 4, n)],
        "tts_rate": int(rng.integers(140, 200)),
        "stretch": round(float(rng.uniform(0.9, 1.2)), 2),
        "seed": i,
    }


class Sources:
    """The sentences of every speaker, made once (synthesized into ``folder``)."""

    def __init__(self, folder: Path, sentences: list[str] = TTS_SENTENCES) -> None:
        self.folder = Path(folder)
        self.sentences = sentences  # what the synthetic voices say
        self.folder.mkdir(parents=True, exist_ok=True)
        self._human: dict[str, list[Sentence]] = {}
        self._tts: dict[tuple, Sentence] = {}

    def sentence(self, spec: dict, k: int) -> Sentence:
        speaker = spec["speaker"]
        if speaker in ("librivox", "cards", "alsa"):
            if speaker not in self._human:
                self._human[speaker] = human_sentences(speaker)
            return self._human[speaker][k]
        kind, voice = speaker.split(":", 1)
        key = (speaker, k, spec.get("tts_rate"), spec.get("stretch"))
        if key not in self._tts:
            text = self.sentences[k]
            if kind == "espeak":
                self._tts[key] = espeak_sentence(text, voice, spec["tts_rate"], self.folder / "espeak")
            else:
                self._tts[key] = festival_sentence(text, voice, self.folder, spec["stretch"])
        return self._tts[key]


def make_recording(i: int, folder: Path, sources: Sources, spec: dict | None = None) -> Recording:
    """Recording ``i`` (see :func:`spec_of`; or made by ``spec``), written into ``folder``."""
    import soundfile as sf

    spec = spec or spec_of(i)
    sr = spec["rate"]
    rng = np.random.default_rng(spec["seed"])
    sentences = [sources.sentence(spec, k) for k in spec["sentences"]]
    lead, trail = spec["edges"]
    pieces, onsets, texts = [np.zeros(int(round(lead * sr)))], [], []
    t = len(pieces[0])
    gap_spans = []
    for j, s in enumerate(sentences):
        x = _resample(s.samples, s.rate, sr)
        x = x / active_rms(x, sr) * 10 ** ((SPEECH_DBFS + spec["levels"][j]) / 20)
        onsets += [None if o is None else t / sr + o for o in s.onsets]
        texts.append(s.text)
        pieces.append(x)
        t += len(x)
        gap = spec["gaps"][j] if j < len(spec["gaps"]) else trail
        if j < len(spec["gaps"]):
            gap_spans.append((t, t + int(round(gap * sr))))
        pieces.append(np.zeros(int(round(gap * sr))))
        t += len(pieces[-1])
    y = np.concatenate(pieces)
    if spec["extra"] and gap_spans:
        a, b = max(gap_spans, key=lambda g: g[1] - g[0])
        sound = breath(sr, rng) if spec["extra"] == "breath" else click(sr)
        at = b - len(sound) - int(0.25 * sr) if spec["extra"] == "breath" else (a + b) // 2
        at = max(a + int(0.1 * sr), at)
        y[at: at + len(sound)] += sound[: len(y) - at]
    channels = [y]
    if spec["channels"] == 2:
        channels.append(0.7 * y)
    if spec["noise"] is not None:
        channels = [c + pink_noise(len(c), rng) * 10 ** (spec["noise"] / 20) for c in channels]
    data = np.stack(channels, axis=1) if len(channels) > 1 else channels[0]
    data = np.clip(data, -0.99, 0.99)
    path = Path(folder) / f"rec{i:02d}-{spec['speaker'].replace(':', '-').replace('+', '-')}.{spec['format']}"
    kw = {"format": "MP3"} if spec["format"] == "mp3" else {"subtype": "PCM_16"}
    sf.write(str(path), data, sr, **kw)
    return Recording(path.stem, path, " ".join(texts), onsets, spec)


def corpus(folder: Path, which=None) -> list[Recording]:
    """The recordings ``which`` (indices; default all :data:`SIZE`), made into ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    sources = Sources(folder / "sources")
    return [make_recording(i, folder, sources) for i in (range(SIZE) if which is None else which)]


def wrong_transcripts(rec: Recording, i: int) -> list[tuple[str, str, int]]:
    """(kind, transcript, index of the word changed) for a word added, dropped and changed
    (away from the first and last word, chosen from ``i``)."""
    text = rec.text
    spans = spans_of(text)
    n = len(spans)
    rng = np.random.default_rng(5000 + i)
    other = OTHER_WORDS[i % len(OTHER_WORDS)]
    k = int(rng.integers(1, n - 1)) if n > 2 else n - 1
    a, b = spans[k]
    added = text[:a] + other + " " + text[a:]
    dropped = text[:a] + text[b:].lstrip(" ")
    said = normal(text[a:b])
    swap = next(w for w in OTHER_WORDS[i % len(OTHER_WORDS):] + OTHER_WORDS if normal(w) != said)
    changed = text[:a] + swap + text[b:]
    return [("added", added, k), ("dropped", dropped, k), ("changed", changed, k)]
