"""The build cache: one generated utterance per entry, stored under its key (:mod:`.keys`).

An entry holds what the motion file needs of an utterance: its poses and hands (float32),
speaker, text, timed words and controls (their source lines relative to the utterance's first
line, see :mod:`.keys`); not where it plays (its place on the performance clock depends on the
lines before it and is laid out when the script's outputs are written). On disk:
``<root>/<key[:2]>/<key>``, a 4-byte little-endian length, that many bytes of JSON (the
metadata, with the key and the number of frames), then the poses (T x 27), the palms
(T x 2 x 3) and the finger angles (T x 2 x 5 x 4) as little-endian float32. Entries are written atomically (:mod:`core.fileio`); one that cannot
be read back whole, or that names another key, is a miss, never an error.

The default root is ``build`` in the sgt cache (:func:`core.paths.cache_dir`).
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from pathlib import Path

from core.controls import Control
from core.fileio import atomic_write, json_bytes
from core.hands import HandTrack
from core.motion import MotionClip
from core.paths import cache_dir
from core.words import TimedWord

_FORMAT = "sgt-build-entry-2"
#: float32 numbers per frame: the pose, the palms, the finger angles.
_PER_FRAME = 27 + 2 * 3 + 2 * 5 * 4


@dataclass
class Entry:
    """One generated utterance, independent of where it sits in its script."""

    poses: object  # (T, 27) float32
    speaker: str | None
    text: str | None
    words: list  # [word, start, end]
    controls: list  # Control.to_dict() with "line" relative to the utterance's first line
    hands: HandTrack | None = None  # relaxed when None

    @classmethod
    def from_clip(cls, clip, first_line: int) -> Entry:
        controls = []
        for c in clip.controls:
            d = c.to_dict()
            d["line"] -= first_line
            controls.append(d)
        return cls(clip.poses, clip.speaker, clip.text, [list(w) for w in clip.words], controls, clip.hands)

    def clip(self, first_line: int, index: int | None = None, start: float = 0.0, audio_offset: float | None = None):
        """The :class:`core.motion.MotionClip` of this entry for an utterance starting on
        ``first_line``, utterance ``index`` of its script, placed at ``start`` seconds."""
        controls = [Control.from_dict({**c, "line": c["line"] + first_line}) for c in self.controls]
        words = [TimedWord(str(w), float(a), float(b)) for w, a, b in self.words]
        # poses as the motion file writes them (5 decimals): workers on other machines or thread
        # counts differ in the last bits, and the speakers' tracks are made from these poses
        return MotionClip(poses=self.poses.round(5), speaker=self.speaker, text=self.text, words=words, controls=controls,
                          hands=self.hands, index=index, start=start, audio_offset=audio_offset)

    def to_bytes(self, key: str) -> bytes:
        import numpy as np  # lazy: numpy (the entries' readers have it)

        poses = np.ascontiguousarray(self.poses, dtype="<f4")
        hands = self.hands or HandTrack.rest(poses.shape[0])
        meta = {"format": _FORMAT, "key": key, "frames": int(poses.shape[0]), "speaker": self.speaker,
                "text": self.text, "words": self.words, "controls": self.controls}
        head = json_bytes(meta, sort_keys=True, separators=(",", ":"))
        body = [poses, np.ascontiguousarray(hands.palm, dtype="<f4"), np.ascontiguousarray(hands.fingers, dtype="<f4")]
        return struct.pack("<I", len(head)) + head + b"".join(a.tobytes() for a in body)

    @classmethod
    def from_bytes(cls, data: bytes, key: str) -> Entry | None:
        import numpy as np  # lazy: numpy

        try:
            (n,) = struct.unpack_from("<I", data)
            meta = json.loads(data[4 : 4 + n].decode("utf-8"))
            body = data[4 + n :]
            frames = int(meta["frames"])
            if meta.get("format") != _FORMAT or meta.get("key") != key or len(body) != frames * _PER_FRAME * 4 or frames <= 0:
                return None
            values = np.frombuffer(body, dtype="<f4").astype(np.float32)
            poses, palm, fingers = np.split(values, [frames * 27, frames * 33])
            hands = HandTrack(palm.reshape(frames, 2, 3), fingers.reshape(frames, 2, 5, 4))
            return cls(poses.reshape(frames, 27), meta["speaker"], meta["text"], meta["words"], meta["controls"], hands)
        except (struct.error, ValueError, KeyError, TypeError, UnicodeDecodeError):
            return None


class BuildCache:
    """Entries by key under ``root`` (default: ``build`` in the sgt cache)."""

    def __init__(self, root: Path | str | None = None) -> None:
        self.root = Path(root) if root is not None else cache_dir("build")

    def path(self, key: str) -> Path:
        return self.root / key[:2] / key

    def get(self, key: str) -> Entry | None:
        try:
            data = self.path(key).read_bytes()
        except OSError:
            return None
        return Entry.from_bytes(data, key)

    def put_bytes(self, key: str, data: bytes) -> None:
        """Store an entry (not fsynced: a damaged entry is a miss, :meth:`Entry.from_bytes`)."""
        atomic_write(self.path(key), data, durable=False)
