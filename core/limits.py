"""How much work one script may ask for: limits checked before the work, from what the input
declares (its text, the headers of its recordings), never from what the work has made.

- **The performance's length** (:attr:`Limits.seconds`): the whole clock of a script, its
  speech (estimated from the text, as ``sgt check`` estimates it; a recording's own length),
  its pauses, gaps, holds and the gestures that run past the speech. A single ``[pause 10s]``
  or ``@gap 30s`` is fine; the total is what is bounded. At most 1 hour
  (:data:`MAX_SECONDS`; the environment variable ``SGT_MAX_SECONDS`` sets another limit,
  ``sgt serve --max-seconds`` its own, 10 minutes by default).
- **The motion it makes**: every speaker's track is as long as the whole performance, and a
  motion file holds the utterances' own frames too: about ``speakers + 1`` times the
  performance's frames. A performance of several speakers is held to ``2 / (speakers + 1)``
  of that length (:meth:`Limits.seconds_for`; two speakers 40 minutes, three 30), so its
  motion stays that of one speaker over the whole limit (generating it, and writing its
  motion file, peaks at about 800 MB for an hour).
- **A recording's length** (:attr:`Limits.recording_seconds`), read from its header before it
  is decoded (and decoding stops there if the header says less than the file holds): at
  most 10 minutes at up to 48 kHz (:data:`MAX_RECORDING_SECONDS`, ``SGT_MAX_RECORDING_SECONDS``),
  less at higher sample rates (:meth:`Limits.recording_seconds_at`): the samples decoded are
  what costs memory.
- **A motion file written**: at most what :data:`core.reading.LIMITS` lets a reader open
  (:func:`motion_file_fits`), checked from its frames before it is encoded.

A script over a limit gets an error at the mark where it crosses it (``dsl/limits.py``; rules
SGT411 and SGT613), from ``sgt check`` as from ``generate`` and ``sgt serve``. The limits in
force are context-local (:func:`using`): the service runs each request under its own.

Standard library only.
"""

from __future__ import annotations

import math
import os
from contextvars import ContextVar
from dataclasses import dataclass

from core.cancel import set_for_block
from core.reading import LIMITS

#: The longest performance, seconds.
MAX_SECONDS = 3600.0
#: The longest recording, seconds (at up to :data:`RECORDING_RATE`).
MAX_RECORDING_SECONDS = 600.0
#: The sample rate :data:`MAX_RECORDING_SECONDS` is counted at: a recording sampled faster may
#: last proportionally less (the same number of samples).
RECORDING_RATE = 48_000
#: The most bytes one frame of one utterance or track takes in a JSON motion file (poses,
#: positions, hands, face; measured about 1.4 KB, the longest numbers under 1.7 KB).
MAX_FRAME_BYTES = 4096

#: The environment variables that set other limits (a positive number of seconds; anything else is ignored).
ENV_SECONDS = "SGT_MAX_SECONDS"
ENV_RECORDING_SECONDS = "SGT_MAX_RECORDING_SECONDS"


@dataclass(frozen=True)
class Limits:
    seconds: float = MAX_SECONDS
    recording_seconds: float = MAX_RECORDING_SECONDS
    #: where the limit is set, for the hint ("SGT_MAX_SECONDS", "the service's --max-seconds")
    setting: str = ENV_SECONDS

    def seconds_for(self, speakers: int) -> float:
        """The longest performance of ``speakers`` speakers: :attr:`seconds` for one, ``2 /
        (speakers + 1)`` of it for more (see the module's docstring)."""
        return self.seconds * 2 / (max(1, speakers) + 1)

    def recording_seconds_at(self, rate: float) -> float:
        """The longest recording sampled at ``rate`` Hz."""
        return self.recording_seconds * min(1.0, RECORDING_RATE / rate) if rate > 0 else self.recording_seconds


def _seconds(name: str, default: float) -> float:
    try:
        value = float(os.environ.get(name, ""))
    except ValueError:
        return default
    return value if math.isfinite(value) and value > 0 else default


_current: ContextVar[Limits | None] = ContextVar("sgt_limits", default=None)


def current() -> Limits:
    """The limits in force here: those of :func:`using`, else the defaults and the environment."""
    limits = _current.get()
    if limits is not None:
        return limits
    return Limits(_seconds(ENV_SECONDS, MAX_SECONDS), _seconds(ENV_RECORDING_SECONDS, MAX_RECORDING_SECONDS))


def using(limits: Limits):
    """Run the block (in this thread or task) under ``limits``."""
    return set_for_block(_current, limits)


def motion_file_fits(frames: int) -> bool:
    """Whether a JSON motion file of ``frames`` frames (over all its utterances and tracks)
    stays within what a reader opens (:data:`core.reading.LIMITS`)."""
    return frames * MAX_FRAME_BYTES <= LIMITS["motion file"]


def duration_text(seconds: float) -> str:
    """``seconds`` for a message: "45 s", "10 min", "1 h 5 min", "1 h 0 min 8 s", "6 h"."""
    s = round(seconds)
    if s < 60:
        return f"{seconds:.3g} s" if seconds < 10 else f"{s} s"
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    parts = [f"{h} h"] * bool(h) + [f"{m} min"] * bool(m or (h and s)) + [f"{s} s"] * bool(s)
    return " ".join(parts)
