"""Pose controls on an utterance's frames: each gesture's stroke on its word, and gestures that
chain.

A ``[pose:NAME]`` mark plays a library gesture (:meth:`library.Gesture.clip`: preparation,
stroke, hold, retraction) with its stroke keyframe on the onset of the word after the mark
(:func:`place`). When gestures that drive a common limb follow each other closely, they are
resolved the way gesture units are realised in Kipp's and McNeill's accounts and in BML
realisers (:func:`resolve`), the same way under any timing:

- **co-articulation**: a gesture that starts before the previous one's retraction is over
  does not start from rest. The previous gesture keeps its key frames (up to the end of its
  stroke and its ``hold=``) and its retraction is cut; the later one *approaches* its stroke
  pose from where the limb is at the cut (the previous gesture's stroke or hold pose, or a
  part of its retraction), on the bones they share, over as many frames as its own
  preparation has (fewer when its word comes sooner), never turning a bone faster than
  :data:`APPROACH_MAX_DEG_PER_S`. Its hands change from the previous gesture's hands to its
  own on the same frames: counting gestures in a row add a finger instead of dropping the
  arm to rest and raising it again;
- **a stroke that cannot make its word** (the previous key frames end too close to it for
  the approach within the speed limit, or a gesture without a stroke is in the way) lands
  as early as it can, and :class:`Placed` says how late and what would make it
  (:func:`hint`): the compiler warns with that (rule SGT401).

After :func:`resolve` no two gestures that share a limb are requested on the same frame.
The approach itself is drawn by :meth:`dsl.plan.ArrayRequests.build` (poses) and
:meth:`~dsl.plan.ArrayRequests.build_hands` (hands) from :attr:`Placed.approach`.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from core import cancel
from core.counting import plural
from core.hands import HandTrack
from core.skeleton import FPS, N_BONES, bone_angles, frame_count, mirror_name, seconds_to_frame

#: The fastest an approach turns a bone: the library's own bound on played gestures
#: (docs/library.md, "Speed"; ballistic elbow movements peak near 1000 deg/s).
APPROACH_MAX_DEG_PER_S = 900.0
#: A smoothstep approach over L frames turns at most this share of its angle per frame (1.5/(L+1)).
_SMOOTHSTEP_PEAK = 1.5


@dataclass
class Placed:
    """One pose control placed on the utterance's frames.

    ``start`` is where the gesture's clip frame 0 plays and ``length`` how many of its frames
    play (fewer than the clip's when its retraction is cut by a later gesture); ``keep`` is how
    many frames no later gesture may cut (to the end of the stroke and ``hold=``; the whole clip
    when it has no stroke); ``stroke`` the stroke keyframe's frame in the clip (None without
    one); ``word_frame`` the frame its stroke is meant for (the word's onset).
    ``approach`` (first frame, (9,) bones, (27,) pose, hands, sides) when the gesture chains
    from the gesture(s) before it: from that frame to its stroke, the bones given move from the
    pose given (where the previous gesture left them) to the stroke pose, and the hands given
    from the previous hands to its own. ``late``: frames its stroke lands after ``word_frame``;
    ``after``: the gesture that made it late, or that it chains from."""

    mark: object
    gesture: object
    start: int
    length: int
    keep: int
    stroke: int | None
    word_frame: int
    approach: tuple | None = None
    late: int = 0
    after: Placed | None = None
    why: str = ""
    #: frames played per bone (9,) and per hand (2,): a later gesture that takes some of its
    #: limbs over cuts those only; None = ``length`` everywhere
    bone_lengths: np.ndarray | None = None
    side_lengths: np.ndarray | None = None
    #: where :func:`resolve` took this gesture (for :func:`hint`'s trials)
    turn: _Turn | None = field(default=None, repr=False, compare=False)

    @property
    def stroke_frame(self) -> int | None:
        return None if self.stroke is None else self.start + self.stroke

    @property
    def end(self) -> int:
        """Where the gesture stops playing on the last limb it still plays."""
        return self.start + int(self.lengths()[0][_bones(self.clip())].max(initial=0))

    def lengths(self) -> tuple[np.ndarray, np.ndarray]:
        """(frames played per bone (9,), per hand (2,))."""
        bones = np.full(N_BONES, self.length) if self.bone_lengths is None else self.bone_lengths
        sides = np.full(2, self.length) if self.side_lengths is None else self.side_lengths
        return bones, sides

    def end_on(self, bones: np.ndarray) -> int:
        """Where the gesture stops playing on ``bones`` (9,) bool (its start when it drives none of them)."""
        mine = _bones(self.clip()) & bones
        return self.start + int(self.lengths()[0][mine].max(initial=0))

    def cut(self, bones: np.ndarray, sides: np.ndarray, frame: int) -> None:
        """Stop playing ``bones`` and the hands ``sides`` at ``frame`` (a later gesture takes them over)."""
        lb, ls = (a.copy() for a in self.lengths())
        lb[bones] = np.minimum(lb[bones], frame - self.start)
        ls[sides] = np.minimum(ls[sides], frame - self.start)
        self.bone_lengths, self.side_lengths = lb, ls

    @property
    def first(self) -> int:
        """The first frame the gesture drives anything: where its approach starts when it takes
        over every bone it drives, else its clip's start."""
        if self.approach is not None and not (_bones(self.clip()) & ~self.approach[1]).any():
            return self.approach[0]
        return self.start

    def clip(self):
        """The gesture's clip as the mark plays it (shared and read-only: :meth:`library.Gesture.clip`)."""
        return self.gesture.clip(speed=self.mark.speed, flip=self.mark.flip, hold=self.mark.hold)

    @property
    def limbs(self) -> frozenset[str]:
        """The limbs the placed gesture drives (mirrored when it is flipped)."""
        limbs = self.gesture.spec.limbs
        return frozenset(mirror_name(limb) for limb in limbs) if self.mark.flip else frozenset(limbs)


def place(utt, words, lib) -> list[Placed]:
    """Each pose mark of ``utt`` whose gesture exists, in source order, with its stroke on the
    onset of the word after the mark (the end of the previous word when none follows); ``words``
    are the utterance's timed words on its motion frames."""
    out: list[Placed] = []
    for mark in utt.poses:
        gesture = lib.get(mark.name)
        if gesture is None:  # already reported by the analyser
            continue
        at = words[mark.word_index].start if mark.word_index is not None else words[mark.after_word].end
        out.append(_natural(mark, gesture, seconds_to_frame(at)))
    return out


def _natural(mark, gesture, word: int) -> Placed:
    """``gesture`` played by ``mark`` whole, its stroke on frame ``word``."""
    stroke = gesture.stroke_frame(mark.speed)
    length = gesture.clip_length(speed=mark.speed, hold=mark.hold)
    keep = length if stroke is None else stroke + 1 + (frame_count(mark.hold) if mark.hold > 0 else 0)
    return Placed(mark, gesture, word - (stroke or 0), length, keep, stroke, word)


def approach_frames(angle_deg: float) -> int:
    """The fewest frames a smoothstep approach needs to turn ``angle_deg`` degrees within
    :data:`APPROACH_MAX_DEG_PER_S`."""
    per_frame = APPROACH_MAX_DEG_PER_S / FPS
    return max(1, math.ceil(_SMOOTHSTEP_PEAK * angle_deg / per_frame) - 1)


def resolve(placed: list[Placed]) -> list[Placed]:
    """Co-articulate and order ``placed`` (source order, from :func:`place`; changed in place
    and returned): see the module's docstring. Gestures are taken in the order their clips
    start (source order on ties); each is compared with the last gesture placed on each limb it
    drives."""
    keys = sorted((p.start, i) for i, p in enumerate(placed))
    order = [placed[i] for _, i in keys]
    last_on: dict[str, Placed] = {}
    for rank, (g, key) in enumerate(zip(order, keys)):
        g.turn = _Turn(order, keys, rank, key, tuple((limb, p, p.bone_lengths, p.side_lengths) for limb, p in last_on.items()))
        _take(g, last_on)
    return placed


@dataclass(frozen=True)
class _Turn:
    """Where :func:`resolve` took a gesture: ``order`` (every gesture of the utterance in the
    order taken, shared) and their sort ``keys`` (natural start, source index), its ``rank``
    there and its ``key``, and ``last_on``: the last gesture on each limb when it was taken,
    with their frames played per bone and per hand then ((limb, Placed, bone_lengths,
    side_lengths), ...). What :func:`resolve` did before a rank depends on nothing taken
    after it, so a trial with one gesture changed starts from the turn where the two orders
    part (:func:`_makes_it`)."""

    order: list
    keys: list
    rank: int
    key: tuple
    last_on: tuple


def _take(g: Placed, last_on: dict[str, Placed]) -> None:
    """One step of :func:`resolve`: place ``g`` after the last gestures on its limbs
    (``last_on``, updated) that still play on them where it would start."""
    cancel.check()
    # the limbs in name order: a frozenset's order would depend on PYTHONHASHSEED, and ties below on it
    before = list({id(p): p for limb in sorted(g.limbs) if (p := last_on.get(limb)) is not None}.values())
    mine = _bones(g.clip())
    before = [p for p in before if g.start < p.end_on(mine)]  # still playing on g's limbs when g would start
    if before:
        _follow(g, before)
    for limb in g.limbs:
        last_on[limb] = g


def _follow(g: Placed, before: list[Placed]) -> None:
    """Place ``g`` after the gestures ``before`` (sharing a limb with it, still playing at its
    natural start): cut their retractions and approach, or wait."""
    key_end = max(p.start + p.keep for p in before)
    last = max(before, key=lambda p: p.start + p.keep)
    if g.stroke is None or any(p.stroke is None for p in before):
        # nothing to approach (a gesture without a stroke plays whole): the later one waits for
        # the earlier one's key frames, which end where it starts
        wait = max(0, key_end - g.start)
        g.start += wait
        g.late, g.after = wait, last
        g.why = f"'{last.mark.name}' has no stroke and plays whole" if last.stroke is None else \
            f"'{g.mark.name}' has no stroke and waits for '{last.mark.name}'"
        for p in before:
            p.cut(_bones(p.clip()) & _bones(g.clip()), _sides(p.clip()) & _sides(g.clip()), g.start)
        return
    clip = g.clip()
    bones = np.zeros(N_BONES, bool)  # the bones and hands g takes over from the gestures before it
    sides = np.zeros(2, bool)
    for p in before:
        bones |= _bones(p.clip()) & _bones(clip)
        sides |= _sides(p.clip()) & _sides(clip)
    target = clip.poses[g.stroke]
    # the farthest the limb can be from the stroke pose at the cut: where the key frames end
    held = _pose_at(before, key_end - 1, target)
    angle = float(bone_angles(held, target)[bones].max(initial=0.0))
    need = approach_frames(angle)
    word = g.word_frame
    cut = max(key_end, word - g.stroke)  # the approach as long as its own preparation, if there is room
    if word - cut < need:
        cut = max(key_end, word - need)
    stroke_at = max(word, cut + need)
    g.start = stroke_at - g.stroke
    g.late = stroke_at - word
    g.after = last
    room = max(0, word - key_end)
    until = "then" if room == 0 else f"{plural(room, 'frame')} before"
    g.why = (f"the arm needs {need} frames to turn {angle:.0f} degrees from '{last.mark.name}', which keeps its stroke "
             f"until {until}" if g.late else "")
    for p in before:
        p.cut(_bones(p.clip()) & _bones(clip), _sides(p.clip()) & _sides(clip), cut)
    frm = _pose_at(before, cut - 1, target)
    hands = _hands_at(before, cut - 1)
    g.approach = (cut, bones, frm, hands, sides)


def _pose_at(before: list[Placed], frame: int, default: np.ndarray) -> np.ndarray:
    """The pose (27,) the gestures ``before`` request at ``frame`` on the bones they drive
    (``default`` elsewhere): the limb's pose where a chained gesture takes it over."""
    out = np.array(default, np.float32).reshape(N_BONES, 3)
    for p in sorted(before, key=lambda p: p.start):
        clip = p.clip()
        k = min(max(frame - p.start, 0), clip.n_frames - 1)
        mask = _bones(clip)
        out[mask] = clip.poses[k].reshape(N_BONES, 3)[mask]
    return out.reshape(-1)


def _hands_at(before: list[Placed], frame: int):
    """(palm (2, 3), fingers (2, 5, 4)) the gestures ``before`` set at ``frame`` on their sides."""
    palm, fingers = (a.copy() for a in _rest_hand())
    for p in sorted(before, key=lambda p: p.start):
        clip = p.clip()
        k = min(max(frame - p.start, 0), clip.n_frames - 1)
        for s in np.flatnonzero(_sides(clip)):
            palm[s], fingers[s] = clip.hands.palm[k, s], clip.hands.fingers[k, s]
    return palm, fingers


@lru_cache(maxsize=1)
def _rest_hand() -> tuple[np.ndarray, np.ndarray]:
    """(palm (2, 3), fingers (2, 5, 4)) of relaxed hands (read only: copied by the caller)."""
    rest = HandTrack.rest(1)
    return rest.palm[0], rest.fingers[0]


def _bones(clip) -> np.ndarray:
    """(9,) bool: the bones a clip drives (all of them when it does not say)."""
    return np.ones(N_BONES, bool) if clip.bones is None else np.asarray(clip.bones, bool)


def _sides(clip) -> np.ndarray:
    """(2,) bool: the hands a clip sets (both when it does not say)."""
    return np.ones(2, bool) if clip.hand_sides is None else np.asarray(clip.hand_sides, bool)


def hint(g: Placed, words) -> str:
    """What would put a late stroke on its word, tried in this order: the earlier gesture
    faster (x2, x3: when its key frames are what is in the way), without its ``hold=``, or this
    mark one word later. ``words``: the utterance's timed words on its frames; ``g`` was placed
    by :func:`resolve`."""
    p = g.after
    if p is None:
        return ""
    if g.approach is None and p.mark.speed < 3:  # it waited for a gesture that plays whole
        for speed in (2, 3):
            if speed > p.mark.speed and _makes_it(g, p, replace(p.mark, speed=speed)):
                return f"use x{speed} on '{p.mark.name}'"
    if p.mark.hold > 0 and _makes_it(g, p, replace(p.mark, hold=0.0)):
        return f"drop hold= from '{p.mark.name}'"
    later = _next_word(g, words)
    if later is not None:
        return f"move [pose:{g.mark.name}] one word later (before '{later}')"
    return f"give '{g.mark.name}' a word of its own, later in the line"


def _makes_it(g: Placed, p: Placed, mark) -> bool:
    """Whether ``g`` would land on its word with ``p`` played by ``mark`` instead: what
    :func:`resolve` would make of the utterance with that change, replayed only from the first
    turn where the two orders differ up to ``g`` (the turns before are the same, and ``g``'s
    place depends on nothing taken after it), so a hint costs the gestures between ``p`` and
    ``g``, not the utterance's.
    """
    turn = p.turn
    changed = _natural(mark, p.gesture, p.word_frame)
    key = (changed.start, turn.key[1])
    rank = bisect_left(turn.keys, key)  # p's rank in the trial's order
    if rank > turn.rank:
        rank -= 1
    first = min(rank, turn.rank)
    seq = [q for q in turn.order[first : max(turn.rank, rank, g.turn.rank) + 1] if q is not p]
    seq.insert(rank - first, p)
    copies: dict[int, Placed] = {}  # the gestures taken before, as they were at that turn
    last_on: dict[str, Placed] = {}
    for limb, q, bone_lengths, side_lengths in turn.order[first].turn.last_on:
        if id(q) not in copies:
            copies[id(q)] = replace(q, bone_lengths=bone_lengths, side_lengths=side_lengths)
        last_on[limb] = copies[id(q)]
    for q in seq:
        trial = changed if q is p else _natural(q.mark, q.gesture, q.word_frame)
        _take(trial, last_on)
        if q is g:
            return trial.late < LATE_WARN
    raise AssertionError("the trial's order holds g")


def _next_word(g: Placed, words) -> str | None:
    i = g.mark.word_index
    if i is None or i + 1 >= len(words):
        return None
    return words[i + 1].word


#: A stroke this many frames or more after its word is reported (a frame or two is not seen).
LATE_WARN = 2
