"""Corpus voices besides espeak-ng: Festival's English voices, with word times from the engine.

Debian packages Festival with three English voices (``apt-get install festival
festvox-kallpc16k festvox-kdlpc16k festvox-us-slt-hts``): two diphone voices of American men
(``kal_diphone``, ``ked_diphone``) and a statistical-parametric (HTS) voice of an American woman
(``cmu_us_slt_arctic_hts``). They differ from espeak-ng's formant voices in timbre, prosody and
timing, so the corpus's audio features are not one engine's. Festival reports each word's start
and end (``word_start``/``word_end`` of the utterance's Word relation), so no alignment is needed.
(flite's voices print segment end times but no word boundaries: they would need the aligner.)

Only the corpus builder uses this; ``sgt`` itself speaks with espeak-ng (:mod:`dsl.speech`).
"""

from __future__ import annotations

import shutil
import subprocess
import zlib
from pathlib import Path

import numpy as np

#: Festival voice -> the folder its package installs.
FESTIVAL_VOICES = {
    "kal_diphone": "english/kal_diphone",
    "ked_diphone": "english/ked_diphone",
    "cmu_us_slt_arctic_hts": "us/cmu_us_slt_arctic_hts",
}
VOICE_ROOT = Path("/usr/share/festival/voices")
PREFIX = "festival:"


class VoiceError(Exception):
    """Festival failed on a sentence (its message is kept)."""


def festival_voices() -> list[str]:
    """Installed Festival voices as corpus voice names (``festival:NAME``); [] without festival."""
    if shutil.which("festival") is None:
        return []
    return [PREFIX + v for v, d in FESTIVAL_VOICES.items() if (VOICE_ROOT / d).is_dir()]


def _scheme_string(text: str) -> str:
    return '"' + text.replace("\\", " ").replace('"', '\\"') + '"'


def festival_say(text: str, voice: str, wav_path: Path, stretch: float = 1.0) -> list[tuple[str, float, float]]:
    """Speak ``text`` with Festival ``voice`` (without the prefix) into ``wav_path``; returns the
    words Festival spoke (numbers and abbreviations expanded) with start and end seconds.
    ``stretch`` scales durations (Festival's Duration_Stretch: above 1 is slower)."""
    if voice not in FESTIVAL_VOICES:
        raise VoiceError(f"unknown Festival voice {voice!r}; known: {', '.join(FESTIVAL_VOICES)}")
    script = "\n".join([
        f"(voice_{voice})",
        f"(Parameter.set 'Duration_Stretch {float(stretch):.4f})",
        f"(set! utt (Utterance Text {_scheme_string(text)}))",
        "(utt.synth utt)",
        f"(utt.save.wave utt {_scheme_string(str(wav_path))} 'riff)",
        ("(mapcar (lambda (w) (format t \"W\\t%s\\t%f\\t%f\\n\" (item.name w) (item.feat w \"word_start\")"
         " (item.feat w \"word_end\"))) (utt.relation.items utt 'Word))"),
    ])
    scm = Path(wav_path).with_suffix(".scm")
    scm.write_text(script + "\n", encoding="utf-8")
    proc = subprocess.run(["festival", "--batch", str(scm)], capture_output=True, text=True, timeout=120, check=False)
    words = []
    for line in proc.stdout.splitlines():
        parts = line.split("\t")
        if len(parts) == 4 and parts[0] == "W":
            words.append((parts[1], float(parts[2]), float(parts[3])))
    if proc.returncode != 0 or not Path(wav_path).is_file() or not words:
        raise VoiceError(f"festival failed on {text!r} with {voice}: {(proc.stderr or proc.stdout).strip()[-300:]}")
    return words


def speak(text: str, voice: str, tmp: Path, rng: np.random.Generator) -> tuple[Path, list[tuple[str, float, float]], dict]:
    """A corpus voice's take of ``text``: (wav path, timed words, what was drawn). ``voice`` is a
    ``festival:NAME`` name; the speaking rate is drawn from ``rng`` (stretch 0.8-1.3)."""
    stretch = round(float(rng.uniform(0.8, 1.3)), 3)
    wav = Path(tmp) / f"fest_{zlib.crc32(f'{voice} {stretch} {text}'.encode()):08x}.wav"
    words = festival_say(text, voice.removeprefix(PREFIX), wav, stretch)
    return wav, words, {"stretch": stretch}
