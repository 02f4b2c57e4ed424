"""Turn a span of recorded poses into a gesture spec file (used by ``sgt library add``).

Keyframes are chosen greedily: start with the first and last frames (and the stroke),
then keep adding the frame that the spec reproduces worst until every bone of every
frame is within ``tolerance_deg`` of the recording (or ``max_keyframes`` is reached).
The error is measured by actually re-parsing the written text and sampling it, so it is
the round-trip error of the file.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from core.skeleton import (
    BONE_NAMES,
    FPS,
    JOINT_INDEX,
    N_BONES,
    frame_count,
    positions_from_pose,
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
                tags: list[str], stroke: int | None) -> str:
    """Spec text for keyframes at ``frames`` of ``dirs`` (n, 9, 3)."""
    # Truncated so that frame_count(duration) == n despite the decimal rounding.
    duration = _trunc(n / FPS)
    lines = [
        f"name = {_toml_str(name)}",
        f"description = {_toml_str(description)}",
        "tags = [" + ", ".join(_toml_str(t) for t in tags) + "]",
        f"duration = {_num(duration)}",
    ]
    prev = REST_DIRS
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
    return "\n".join(lines) + "\n"


def _max_errors(text: str, name: str, dirs: np.ndarray) -> np.ndarray:
    spec = parse_spec_text(text, Path(f"{name}.toml"))
    got = sample(spec, frame_count(spec.duration)).reshape(-1, N_BONES, 3).astype(np.float64)
    got /= np.linalg.norm(got, axis=-1, keepdims=True)
    cos = np.clip(np.sum(got * dirs, axis=-1), -1, 1)
    return np.degrees(np.arccos(cos)).max(axis=-1)  # per frame


def default_stroke(dirs: np.ndarray) -> int:
    """The frame where the wrists are farthest from where they start."""
    pos = positions_from_pose(dirs.reshape(len(dirs), -1))
    w = pos[:, [JOINT_INDEX["right_wrist"], JOINT_INDEX["left_wrist"]]]
    d = np.linalg.norm(w - w[:1], axis=-1).max(axis=-1)
    return int(np.argmax(d))


def spec_text_from_poses(name: str, poses: np.ndarray, *, description: str = "",
                         tags: list[str] = (), stroke: int | None = None,
                         tolerance_deg: float = 2.0, max_keyframes: int = 40) -> tuple[str, float]:
    """Spec text reproducing ``poses`` (n, 27); returns (text, max round-trip error in degrees)."""
    p = np.asarray(poses, dtype=np.float64)
    n = len(p)
    if n < 2:
        raise ValueError("need at least 2 frames")
    dirs = p.reshape(n, N_BONES, 3)
    dirs = dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)
    if stroke is None:
        stroke = default_stroke(dirs)
    frames = sorted({0, n - 1, stroke})
    while True:
        text = render_spec(name, dirs, frames, n, description=description, tags=list(tags),
                           stroke=stroke)
        err = _max_errors(text, name, dirs)
        worst = int(np.argmax(err))
        if err[worst] <= tolerance_deg or len(frames) >= max_keyframes or worst in frames:
            return text, float(err.max())
        frames = sorted(set(frames) | {worst})
