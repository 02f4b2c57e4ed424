"""Speech timing: synthesized (espeak-ng) or recorded speech with per-word start/end times.

Importing this package is cheap: the espeak-ng library, soundfile and pocketsphinx are only
loaded when a function needs them.
"""

from __future__ import annotations

from .cache import default_cache_dir
from .types import Speech, SpeechError


def synthesize(text, word_spans, pauses=(), *, voice="en-us", rate=175, pitch=50, cache_dir=None):
    """Speak ``text`` with espeak-ng and time each word span; see :mod:`dsl.speech.synth`."""
    from .synth import synthesize as _synthesize

    return _synthesize(text, word_spans, pauses, voice=voice, rate=rate, pitch=pitch, cache_dir=cache_dir)


def load_recording(audio_path, text, word_spans, pauses=(), *, timings_path=None, cache_dir=None):
    """Time the word spans of a recorded utterance; see :mod:`dsl.speech.recording`."""
    from .recording import load_recording as _load_recording

    return _load_recording(audio_path, text, word_spans, pauses, timings_path=timings_path, cache_dir=cache_dir)


def list_voices():
    """Voice names accepted by :func:`synthesize`."""
    from .synth import list_voices as _list_voices

    return _list_voices()


__all__ = ["Speech", "SpeechError", "synthesize", "load_recording", "default_cache_dir", "list_voices"]
