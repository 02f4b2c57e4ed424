"""The compiled plan: per utterance its words, controls and the per-frame control arrays,
and where it plays on the performance clock.

A script is one performance (:meth:`Plan.lay_out`): its utterances play in order on one
clock. Utterance ``i + 1``'s speech starts ``gap`` seconds (``@gap``, default
:data:`dsl.script.DEFAULT_GAP`) after the speech so far ends (utterance ``i``'s, unless an
earlier one still talks: see below), rounded up to a whole frame; its motion starts
``audio_offset`` (its lead-in) before its speech. A speaker's utterances never overlap on
its own track: a line waits until the same speaker's previous motion (its retraction) is
over. The first utterance's motion starts at 0.

Overlapping speech: a negative ``gap`` (``@gap -400ms`` before a line) starts the line's
speech that long before the speech so far ends; the speaker interrupts, and the interrupted
speaker finishes its line under it (both voices are in the mix, each on its own track). An
interruption starts at the earliest with the previous line's speech (lines start in script
order), and never before its own speaker's previous line is over; where either moves it
later than its gap asks, :attr:`Plan.moved` says so (the compiler's warnings
``self-interruption`` and ``interruption-too-long``). Without a negative gap the clock is
the one above, to the frame.

``plan.json`` is deterministic and human-readable (reviewable in a diff); ``--npz`` holds the
arrays the generator consumes (layout owned by :mod:`core.controls`). Both are written by
:mod:`core.fileio`'s rules (atomically for a regular file; a device or a link is never replaced).
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.controls import STYLE_NAMES, Control, ControlArrays
from core.fileio import atomic_write, json_text
from core.easing import smoothstep
from core.hands import SIDES, HandTrack, slerp
from core.skeleton import FPS, slerp_poses
from core.words import TimedWord

PLAN_FORMAT = "sgt-plan"
PLAN_VERSION = 2  # 2: start, audio_offset and gap per utterance, frames of the performance


@dataclass
class ArrayRequests:
    """What the control arrays must hold; they are built on first use (``sgt check`` never needs them)."""

    n_frames: int
    poses: list = field(default_factory=list)  # dsl.realize.Placed, resolved, in start order
    styles: list = field(default_factory=list)  # (start, end, {name: value}), outer spans first

    def build(self) -> ControlArrays:
        arrays = ControlArrays.empty(self.n_frames)
        for a, b, values in self.styles:
            arrays.set_style(a, b, values)
        for p in self.poses:  # a limb's frames played < the clip's: its retraction was cut there
            clip = p.clip()
            lengths = p.lengths()[0]
            taken = p.approach[1] if p.approach is not None else np.zeros(len(lengths), bool)
            own = np.asarray(clip.bones, bool) & ~taken
            for length in sorted(set(lengths[own].tolist())):  # (np.unique imports numpy.ma: 7 ms of a cold start)
                arrays.set_pose(p.start, clip.poses[:length], own & (lengths == length))
            if not taken.any():
                continue
            cut, _, frm, _, _ = p.approach  # the bones taken over approach the stroke from where they are
            n = p.stroke_frame - cut
            w = smoothstep((np.arange(n) + 1) / (n + 1))
            on_the_way = slerp_poses(np.repeat(frm[None], n, 0), np.repeat(clip.poses[p.stroke][None], n, 0), w)
            for length in sorted(set(lengths[taken].tolist())):
                arrays.set_pose(cut, np.concatenate([on_the_way, clip.poses[p.stroke : length]]), taken & (lengths == length))
        return arrays

    def build_hands(self) -> tuple[HandTrack, np.ndarray]:
        """The pose controls' hands (their gestures' hand keys; relaxed elsewhere) and a mask
        (T, 2) per side (:data:`core.hands.SIDES`), 1 on the frames a pose control sets that
        hand: a layered gesture sets only the hands it drives (``Clip.hand_sides``); a gesture
        that chains from the one before changes from that one's hands to its own on the frames
        of its approach (:mod:`dsl.realize`)."""
        track = HandTrack.rest(self.n_frames)
        mask = np.zeros((self.n_frames, 2), np.float32)
        for p in self.poses:
            clip = p.clip()
            start = p.start
            taken = p.approach[4] if p.approach is not None else np.zeros(2, bool)
            for s in np.flatnonzero(clip.hand_sides):
                end = start + int(p.lengths()[1][s])
                first = p.approach[0] if taken[s] else start
                lo, hi = max(0, first), min(self.n_frames, end)
                if hi <= lo:
                    continue
                palm, fingers = clip.hands.palm[:, s], clip.hands.fingers[:, s]
                if taken[s]:  # from the previous gesture's hand to this one's, reached at the stroke
                    n = p.stroke_frame - first
                    w = smoothstep((np.arange(n) + 1) / (n + 1))
                    from_palm, from_fingers = p.approach[3][0][s], p.approach[3][1][s]
                    way_palm = slerp(np.repeat(from_palm[None], n, 0), np.repeat(palm[p.stroke][None], n, 0), w,
                                     1.0 if SIDES[s] == "right" else -1.0)
                    way_fingers = (1 - w)[:, None, None] * from_fingers + w[:, None, None] * fingers[p.stroke]
                    palm = np.concatenate([way_palm, palm[p.stroke :]])
                    fingers = np.concatenate([way_fingers, fingers[p.stroke :]])
                    offset = first
                else:
                    offset = start
                track.palm[lo:hi, s] = palm[lo - offset : hi - offset]
                track.fingers[lo:hi, s] = fingers[lo - offset : hi - offset]
                mask[lo:hi, s] = 1.0
        return track, mask


@dataclass
class UtterancePlan:
    index: int
    speaker: str | None
    line: int
    text: str
    duration: float
    n_frames: int
    words: list[TimedWord]
    controls: list[Control]
    requests: ArrayRequests
    speech: dict = field(default_factory=dict)
    audio_path: Path | None = None
    lead_in: float = 0.0  # seconds of silence before the audio starts (words are already shifted)
    gap: float = 0.5  # seconds of silence before this line's speech (after the previous line's)
    start_frame: int = 0  # first motion frame on the performance clock (set by Plan.lay_out)
    #: The phonemes (:class:`dsl.speech.types.TimedPhoneme`) on the same clock as the words
    #: (lead-in included); none with estimated timing.
    phonemes: list = field(default_factory=list)

    _arrays: ControlArrays | None = field(default=None, repr=False)
    _hands: tuple[HandTrack, np.ndarray] | None = field(default=None, repr=False)

    @property
    def arrays(self) -> ControlArrays:
        """Per-frame control arrays (SGToolkit Eq. 1-3), layout from :mod:`core.controls`."""
        if self._arrays is None:
            self._arrays = self.requests.build()
        return self._arrays

    @property
    def hands(self) -> tuple[HandTrack, np.ndarray]:
        """The pose controls' hands and where they apply (see :meth:`ArrayRequests.build_hands`)."""
        if self._hands is None:
            self._hands = self.requests.build_hands()
        return self._hands

    @property
    def start(self) -> float:
        """Seconds on the performance clock of the first motion frame."""
        return self.start_frame / FPS

    @property
    def audio_offset(self) -> float:
        """Seconds from the first motion frame to the first audio sample (the lead-in)."""
        return self.lead_in

    @property
    def speech_duration(self) -> float:
        """Seconds of speech audio (the motion is longer by the lead-in and the tail)."""
        return self.duration - self.lead_in - self.speech.get("tail", 0.0)

    def to_dict(self) -> dict:
        return {
            "index": self.index,
            "speaker": self.speaker,
            "line": self.line,
            "text": self.text,
            "start": round(self.start, 6),
            "audio_offset": round(self.audio_offset, 6),
            "gap": round(self.gap, 6),
            "duration": round(self.duration, 3),
            "frames": self.n_frames,
            "speech": self.speech,
            "words": [w.to_dict() for w in self.words],
            "phonemes": [p.to_list() for p in self.phonemes],
            "controls": [c.to_dict() for c in self.controls],
        }


@dataclass(frozen=True)
class Moved:
    """An interruption (a negative gap) :meth:`Plan.lay_out` started later than it asked:
    utterance ``index`` (its place in :attr:`Plan.utterances`) asked for its speech at frame
    ``asked`` and got ``frame``, because of ``why``: "self" (its own speaker's utterance
    ``other`` was still playing), "start" (it would have started before utterance ``other``,
    the one it interrupts: ``reach`` is the most it may reach back, seconds) or "clock" (its
    lead-in would have started before frame 0)."""

    index: int
    why: str
    asked: int
    frame: int
    other: int | None
    reach: float

    @property
    def late(self) -> float:
        """Seconds later than asked."""
        return (self.frame - self.asked) / FPS


@dataclass
class Plan:
    source: str
    fps: int
    seed: int
    utterances: list[UtterancePlan]
    #: Interruptions the clock started later than their gap asks (set by :meth:`lay_out`).
    moved: list[Moved] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        self.lay_out()

    @property
    def n_frames(self) -> int:
        """Frames of the whole performance (every utterance's motion ends by then)."""
        return max((u.start_frame + u.n_frames for u in self.utterances), default=0)

    @property
    def speakers(self) -> list[str | None]:
        """The speakers in order of their first line."""
        return list(dict.fromkeys(u.speaker for u in self.utterances))

    def lay_out(self) -> None:
        """Place the utterances on the performance clock (see the module's docstring), and
        record in :attr:`moved` the interruptions (negative gaps) it had to start later."""
        speech_end = 0.0  # the latest end of speech so far (seconds)
        track_end: dict = {}  # speaker -> (first frame its track is free, its last utterance's number)
        audio_prev = 0  # the previous utterance's first audio frame
        self.moved = []
        for n, u in enumerate(self.utterances):
            lead = int(round(u.lead_in * FPS))
            asked = audio = lead if n == 0 else int(math.ceil((speech_end + u.gap) * FPS - 1e-6))
            free, mine = track_end.get(u.speaker, (0, None))
            if n and u.gap < 0:  # an interruption: not before the line it interrupts starts
                audio = max(audio, audio_prev)
            u.start_frame = max(0, audio - lead, free)
            if n and u.gap < 0 and u.start_frame + lead > asked:
                if u.start_frame == free and free > max(0, audio - lead):
                    self.moved.append(Moved(n, "self", asked, u.start_frame + lead, mine, 0.0))
                else:
                    limit = "start" if audio > asked and audio - lead >= 0 else "clock"
                    self.moved.append(Moved(n, limit, asked, u.start_frame + lead, n - 1, speech_end - audio_prev / FPS))
            audio_prev = u.start_frame + lead
            speech_end = max(speech_end, u.start + u.lead_in + u.speech_duration)
            track_end[u.speaker] = (u.start_frame + u.n_frames, n)

    def to_dict(self) -> dict:
        return {
            "format": PLAN_FORMAT,
            "version": PLAN_VERSION,
            "source": self.source,
            "fps": self.fps,
            "seed": self.seed,
            "frames": self.n_frames,
            "style_names": list(STYLE_NAMES),
            "utterances": [u.to_dict() for u in self.utterances],
        }

    def to_json(self) -> str:
        return json_text(self.to_dict(), indent=2) + "\n"

    def save_json(self, path) -> None:
        """Write :meth:`to_json` to ``path`` (or a binary stream) by :mod:`core.fileio`'s rules."""
        atomic_write(path, self.to_json().encode("utf-8"))

    def save_npz(self, path) -> None:
        """Arrays ``pose_I``, ``pose_mask_I``, ``style_I``, ``style_mask_I``, ``bone_mask_I`` per utterance I, plus ``plan`` (JSON);
        to ``path`` (or a binary stream) by :mod:`core.fileio`'s rules."""
        arrays: dict[str, np.ndarray] = {"plan": np.array(self.to_json())}
        for i, u in enumerate(self.utterances):
            for key, value in u.arrays.as_dict().items():
                arrays[f"{key}_{i}"] = value
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        atomic_write(path, buf.getvalue())
