"""Speech timing: synthesized (espeak-ng) or recorded speech with per-word start/end times.

Importing this package is cheap: the espeak-ng library is loaded (ctypes) on the first
synthesis, pocketsphinx on the first alignment.
"""

from __future__ import annotations

from .cache import default_cache_dir
from .recording import load_recording
from .synth import list_voices, synthesize
from .types import Speech, SpeechError

__all__ = ["Speech", "SpeechError", "synthesize", "load_recording", "default_cache_dir", "list_voices"]
