"""The build cache's key of one utterance: everything that changes its motion, and nothing else.

The key is the sha256 of a canonical JSON rendering of:

- what is spoken and marked: the spoken text and its word offsets, the text as shown, the
  speaker, every pose mark (gesture, speed, flip, hold, where it is anchored), style span
  (its values after presets are applied) and pause, each with its place *relative to the
  utterance's first line* (the motion file records where a control was written, but moving
  an utterance up or down the file must not regenerate it);
- the content of each library gesture it plays (duration, keyframe times, stroke, bone
  directions: a gesture file's comments or description do not count);
- the speech: the voice, rate and pitch and the espeak-ng build that speaks them (a piper
  voice: the rate and the versions of piper, the voice and onnxruntime), or for a
  recording the sha256 of the audio file and of its timings file (or the aligner that
  times it, when there is none);
- the generator: the engine; for ``neural`` the sha256 of the weights, for ``matching`` that of
  its database (``--database`` or the shipped one); for both the smoothing and the
  pose-control blend, and the seed its speaker's take posture is drawn with (the script's
  seed, none with ``--no-take-posture``); the seed the engine receives (``--seed`` or
  ``@seed``, plus the utterance's number, as :func:`model.generate.clips_from_plan` seeds it;
  the keyframe engine uses none);
- :data:`CODE_VERSION`, bumped whenever code changes what an utterance generates.

Not in it: the script's path or name, the utterance's line number, comments, other
utterances, file times, the machine.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from model.engines import DEFAULT_ENGINE, NETWORK_ENGINES

#: Bump when a change to the compiler, the speech timing, the engines or the post-processing
#: changes the motion of an utterance whose inputs did not change.
CODE_VERSION = 8  # 3: audio features summed without BLAS (last bits changed); 4: the speed style met (follow_speed); 5: zero-phase smoothing; 6: the take's posture; 7: the take's drift; 8: the face (motion files version 3)

#: Engines whose output does not depend on the seed.
_SEEDLESS = frozenset({"keyframe"})


@dataclass(frozen=True)
class Settings:
    """The build's generator settings (``sgt build``'s options)."""

    engine: str = DEFAULT_ENGINE
    seed: int | None = None  # None: each script's @seed
    smoothing: str = "one_euro"
    blend: bool = True
    weights: str | None = None  # None: the shipped weights
    database: str | None = None  # the matching engine's database; None: the shipped one
    take_posture: bool = True  # the neural engine draws each speaker's take posture and drift (model.take_posture)
    auto_gestures: bool = False  # gestures chosen from the words where a script has no mark (sgt_tui.suggesting)

    def options(self):
        from model.neural import Options  # lazy: numpy, the engine

        return Options(smoothing=self.smoothing, blend=self.blend, weights=self.weights, take_posture=self.take_posture,
                       database=self.database)

    def describe(self) -> dict:
        """The settings as the manifest records them."""
        out: dict = {"engine": self.engine, "seed": self.seed}
        if self.engine in NETWORK_ENGINES:
            out.update(smoothing=self.smoothing, blend=self.blend, take_posture=self.take_posture,
                       weights_sha256=weights_hash(self.weights, self.engine))
        elif self.engine == "matching":
            out.update(smoothing=self.smoothing, blend=self.blend, take_posture=self.take_posture,
                       database_sha256=database_hash(self.database))
        if self.auto_gestures:  # (only when set: builds without it keep their manifests)
            from library.words import BUILTIN_WORDS  # lazy: the library package

            out.update(auto_gestures=True, words_sha256=file_sha256(BUILTIN_WORDS))
        return out


def file_sha256(path: Path | str, what: str = "weights") -> str:
    """The sha256 of a regular file (a FIFO or a device is refused unread: InputFileError)."""
    from core.reading import open_input  # lazy: keeps this module's import light

    h = hashlib.sha256()
    with open_input(path, what) as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def weights_hash(weights: str | None, engine: str = "neural") -> str:
    """The weights file's sha256 (None: the ``engine``'s shipped file), with its ONNX export's
    when there is one (inference runs the export when it is fresh, PyTorch otherwise: their
    numbers differ in the last bits)."""
    from model.weights import default_weights  # lazy: numpy

    path = Path(weights) if weights else default_weights(engine)
    export = path.with_suffix(".onnx")
    if export.is_file():
        return _hash_once(str(path)) + "+" + _hash_once(str(export))
    return _hash_once(str(path))


def database_hash(database: str | None) -> str:
    """The matching engine's database file's sha256 (``database`` or the shipped one)."""
    from model.matching import DEFAULT_DB  # lazy: numpy

    return _hash_once(str(Path(database) if database else DEFAULT_DB))


@lru_cache(maxsize=256)
def _hash_once(path: str) -> str:
    return file_sha256(path)


def _espeak_build() -> str:
    from dsl.speech import _espeak  # lazy: ctypes look-up of the engine library

    return _espeak.engine_fingerprint()


@lru_cache(maxsize=1)
def _aligner() -> str:
    from importlib.metadata import PackageNotFoundError, version

    from dsl.speech.align import VERSION as ALIGN_VERSION  # lazy: only scripts with recordings need it

    try:
        return f"pocketsphinx {version('pocketsphinx')}, sgt alignment {ALIGN_VERSION}"
    except PackageNotFoundError:
        return f"pocketsphinx (not installed), sgt alignment {ALIGN_VERSION}"


def gesture_digest(gesture) -> str:
    """sha256 of what a library gesture contributes to motion (not its comments or description)."""
    spec = gesture.spec
    h = hashlib.sha256()
    h.update(json.dumps([spec.duration, [[k.time, k.stroke] for k in spec.keyframes]]).encode())
    import numpy as np  # lazy: numpy (already loaded by the library)

    h.update(np.ascontiguousarray(spec.key_dirs, dtype="<f8").tobytes())
    return h.hexdigest()


def _where(span, first_line: int) -> list[int]:
    return [span.line - first_line, span.col]


def _speech(utt, files) -> dict:
    if utt.audio is None:
        v = utt.voice
        from dsl.speech import piper  # lazy: the speech engines

        natural = piper.voice_of(v.name)
        if natural is not None:  # no pitch: it changes nothing
            return {"engine": "piper", "build": piper.fingerprint(natural), "voice": natural.name, "rate": v.rate}
        return {"engine": "espeak-ng", "build": _espeak_build(), "voice": v.name, "rate": v.rate, "pitch": v.pitch}
    timings = utt.audio.timings
    return {
        "recording": files(utt.audio.path),
        "timings": files(timings) if timings is not None else None,
        "aligner": None if timings is not None else _aligner(),
    }


def utterance_payload(utt, lib, base_seed: int, settings: Settings, files=None) -> dict:
    """What :func:`utterance_key` hashes (for tests and for explaining a cache miss).

    ``files`` hashes a recording or timings file (default :func:`file_sha256`, memoised by
    the caller to read each file once)."""
    files = files or file_sha256
    first = utt.line
    gestures = {}
    for m in utt.poses:
        if m.name not in gestures:
            g = lib.get(m.name)
            gestures[m.name] = gesture_digest(g) if g is not None else None
    payload = {
        "code": CODE_VERSION,
        "speaker": utt.speaker,
        "text": utt.text,
        "display": utt.display,
        "words": [[w.start, w.end] for w in utt.words],
        "poses": [[m.name, m.speed, m.flip, m.hold, m.offset, m.word_index, m.after_word, _where(m.where, first)]
                  for m in utt.poses],
        "gestures": gestures,
        "styles": [[s.name, sorted(s.values.items()), s.offset, s.end_offset, s.first_word, s.last_word,
                    _where(s.where, first)] for s in utt.styles],
        "pauses": [[p.seconds, p.offset, p.word_index, _where(p.where, first)] for p in utt.pauses],
        "speech": _speech(utt, files),
        "engine": settings.engine,
    }
    if settings.engine not in _SEEDLESS:
        payload["seed"] = (base_seed if settings.seed is None else settings.seed) + utt.index
    if settings.engine in (*NETWORK_ENGINES, "matching"):
        model = ({"weights": weights_hash(settings.weights, settings.engine)} if settings.engine in NETWORK_ENGINES
                 else {"database": database_hash(settings.database)})
        payload.update(model, smoothing=settings.smoothing, blend=settings.blend,
                       # the speaker's take posture is drawn with the script's seed, not the utterance's
                       take_posture=(base_seed if settings.seed is None else settings.seed) if settings.take_posture else None)
    return payload


def utterance_key(utt, lib, base_seed: int, settings: Settings, files=None) -> str:
    """The cache key of one utterance of an analysed script (see the module docstring)."""
    blob = json.dumps(utterance_payload(utt, lib, base_seed, settings, files), sort_keys=True,
                      ensure_ascii=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode("ascii")).hexdigest()
