"""Turn a span of recorded poses into a gesture spec file (used by ``sgt library add``).

Keyframes are chosen greedily: start with the first and last frames (and the stroke),
then keep adding the frame that the spec reproduces worst until every bone of every
frame is within ``tolerance_deg`` of the recording (or ``max_keyframes`` is reached).
The error is measured by actually re-parsing the written text and sampling it, so it is
the round-trip error of the file. With the recording's hands, every keyframe also names each
hand's nearest shape and palm (:func:`core.hands.nearest_shape`, :func:`core.hands.nearest_palm`)
where they differ from the previous keyframe's.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from core.hands import REST_PALM, REST_SHAPE, SIDES, HandTrack, nearest_palm, nearest_shape
from core.skeleton import (
    BONE_NAMES,
    FPS,
    JOINT_INDEX,
    N_BONES,
    frame_count,
    positions_from_pose,
    slerp_poses,
)
from library.spec import REST_DIRS, parse_spec_text, sample

#: Bones are written only when they moved more than this since the previous keyframe.
SAME_DEG = 0.3


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:.4f}" for x in v) + "]"


def _trunc(x: float) -> float:
    return math.floor(x * 1e6 + 1e-9) / 1e6


def _num(x: float) -> str:
    text = f"{x:.6f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


_TOML_ESCAPES = {"\\": "\\\\", '"': '\\"', "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _toml_str(s: str) -> str:
    """``s`` as a TOML basic string that reads back exactly: quotes, backslashes and every
    control character escaped (TOML allows none of them raw, except tab)."""
    out = []
    for ch in s:
        if ch in _TOML_ESCAPES:
            out.append(_TOML_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def render_spec(name: str, dirs: np.ndarray, frames: list[int], n: int, *, description: str,
                tags: list[str], stroke: int | None, hands: HandTrack | None = None) -> str:
    """Spec text for keyframes at ``frames`` of ``dirs`` (n, 9, 3) (and of ``hands``)."""
    # Truncated so that frame_count(duration) == n despite the decimal rounding.
    duration = _trunc(n / FPS)
    lines = [
        f"name = {_toml_str(name)}",
        f"description = {_toml_str(description)}",
        "tags = [" + ", ".join(_toml_str(t) for t in tags) + "]",
        f"duration = {_num(duration)}",
    ]
    prev = REST_DIRS
    prev_hands = {f"{side}_{k}": v for side in SIDES for k, v in (("hand", REST_SHAPE), ("palm", REST_PALM))}
    for i, f in enumerate(frames):
        t = duration if f == n - 1 else _trunc(f * duration / (n - 1))
        lines += ["", "[[keyframes]]", f"time = {_num(t)}"]
        label = "start" if i == 0 else "end" if i == len(frames) - 1 else None
        if f == stroke:
            label = "stroke"
        if label:
            lines.append(f'label = "{label}"')
        if f == stroke:
            lines.append("stroke = true")
        cur = dirs[f]
        cos = np.clip(np.sum(cur * prev, axis=-1), -1, 1)
        moved = np.degrees(np.arccos(cos)) > SAME_DEG
        for b in range(N_BONES):
            if moved[b]:
                lines.append(f"{BONE_NAMES[b]} = {_fmt(cur[b])}")
        # What the loader will hold for the next keyframe.
        prev = np.where(moved[:, None], cur, prev)
        if hands is not None:
            for s, side in enumerate(SIDES):
                named = {f"{side}_hand": nearest_shape(hands.fingers[f, s]),
                         f"{side}_palm": nearest_palm(hands.palm[f, s], side)}
                for key, value in named.items():
                    if value != prev_hands[key]:
                        lines.append(f'{key} = "{value}"')
                        prev_hands[key] = value
    return "\n".join(lines) + "\n"


def _max_errors(text: str, name: str, dirs: np.ndarray) -> np.ndarray:
    spec = parse_spec_text(text, Path(f"{name}.toml"))
    got = sample(spec, frame_count(spec.duration)).reshape(-1, N_BONES, 3).astype(np.float64)
    got /= np.linalg.norm(got, axis=-1, keepdims=True)
    cos = np.clip(np.sum(got * dirs, axis=-1), -1, 1)
    return np.degrees(np.arccos(cos)).max(axis=-1)  # per frame


#: The joints whose speed finds the stroke (:func:`find_stroke`): the wrists and the head.
STROKE_JOINTS = ("right_wrist", "left_wrist", "nose", "head_top")
#: A movement ends where its speed has fallen to this share of its peak, ...
END_SHARE = 0.2
#: ... or where it stops falling once under this share of it.
STOP_SHARE = 0.3
#: A movement that ends nearer the span's first pose than it began, within this share of the
#: span's largest excursion from that pose, brings the gesture back: a retraction.
BACK_SHARE = 1 / 3


def find_stroke(poses: np.ndarray, fps: float = FPS) -> int:
    """The stroke's frame in ``poses`` (n, 27) at ``fps``: where the span's fastest movement
    ends. Speed: the fastest of :data:`STROKE_JOINTS` on sgt's skeleton, over a 1/15 s centred
    difference. Each peak of it is a movement, which ends at the first frame after the peak
    where the speed has fallen to :data:`END_SHARE` of the peak, or stops falling under
    :data:`STOP_SHARE` of it (the hold's onset, the key pose), or at the span's end; it began at
    the last such frame before the peak. The movement with the highest peak that is not a
    retraction (:data:`BACK_SHARE`) gives the stroke; with none, the frame farthest from the
    first pose."""
    p = np.asarray(poses, dtype=np.float64)
    n = len(p)
    x = positions_from_pose(p)[:, [JOINT_INDEX[j] for j in STROKE_JOINTS]]
    h = max(1, round(fps / (2 * FPS)))
    i0 = np.clip(np.arange(n) - h, 0, n - 1)
    i1 = np.clip(np.arange(n) + h, 0, n - 1)
    speed = np.linalg.norm(x[i1] - x[i0], axis=-1).max(axis=-1) / np.maximum(i1 - i0, 1) * fps
    away = np.linalg.norm(x - x[:1], axis=-1).max(axis=-1)
    pad = np.concatenate([[np.inf], speed, [np.inf]])
    minimum = (speed <= pad[:-2]) & (speed <= pad[2:])
    pad = np.concatenate([[-np.inf], speed, [-np.inf]])
    peaks = np.flatnonzero((speed > pad[:-2]) & (speed >= pad[2:]) & (speed > 0))
    for peak in peaks[np.argsort(-speed[peaks], kind="stable")]:
        stop = (speed <= END_SHARE * speed[peak]) | (minimum & (speed <= STOP_SHARE * speed[peak]))
        after = np.flatnonzero(stop[peak + 1:])
        before = np.flatnonzero(stop[:peak])
        end = peak + 1 + int(after[0]) if len(after) else n - 1
        start = int(before[-1]) if len(before) else 0
        if not (away[end] < away[start] and away[end] <= BACK_SHARE * away.max()):
            return int(end)
    return int(np.argmax(away))


def resample_through(poses: np.ndarray, fps: float, frame: int) -> tuple[np.ndarray, int]:
    """``poses`` (n, 27) at ``fps`` resampled to :data:`core.skeleton.FPS` on the frames through
    ``frame`` (so that pose is kept exactly; the others are slerped between their neighbours):
    (the new poses, ``frame``'s index among them)."""
    p = np.asarray(poses, dtype=np.float64)
    step = fps / FPS  # source frames per frame
    before = math.floor(frame / step + 1e-6)
    after = math.floor((len(p) - 1 - frame) / step + 1e-6)
    u = frame + np.arange(-before, after + 1) * step
    i0 = np.clip(np.floor(u + 1e-9).astype(int), 0, len(p) - 1)
    i1 = np.minimum(i0 + 1, len(p) - 1)
    return slerp_poses(p[i0], p[i1], np.clip(u - i0, 0.0, 1.0)), before


def spec_text_from_poses(name: str, poses: np.ndarray, *, description: str = "",
                         tags: list[str] = (), stroke: int | None = None,
                         tolerance_deg: float = 2.0, max_keyframes: int = 40,
                         hands: HandTrack | None = None) -> tuple[str, float]:
    """Spec text reproducing ``poses`` (n, 27) and, by name, ``hands`` (the same n frames);
    returns (text, max round-trip error of the bones in degrees)."""
    p = np.asarray(poses, dtype=np.float64)
    n = len(p)
    if n < 2:
        raise ValueError("need at least 2 frames")
    dirs = p.reshape(n, N_BONES, 3)
    dirs = dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)
    if stroke is None:
        stroke = find_stroke(dirs.reshape(n, -1))
    frames = sorted({0, n - 1, stroke})
    while True:
        text = render_spec(name, dirs, frames, n, description=description, tags=list(tags),
                           stroke=stroke, hands=hands)
        err = _max_errors(text, name, dirs)
        worst = int(np.argmax(err))
        if err[worst] <= tolerance_deg or len(frames) >= max_keyframes or worst in frames:
            return text, float(err.max())
        frames = sorted(set(frames) | {worst})
