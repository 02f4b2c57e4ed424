"""Content-addressed cache of speech results: ``<hash>.wav`` + ``<hash>.json``."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from core.fileio import atomic_write, json_bytes
from core.paths import cache_dir

#: Bump when the timing algorithm changes so that old cache entries are not reused.
#: 3: espeak-ng's phoneme events (with their stress) are kept with the words.
ALGORITHM_VERSION = 3


def default_cache_dir() -> Path:
    """``speech`` in the sgt cache (:func:`core.paths.cache_dir`: ``$SGT_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/sgt``, else ``~/.cache/sgt``)."""
    return cache_dir("speech")


def content_hash(payload: dict) -> str:
    """sha256 of a canonical JSON rendering of ``payload``."""
    blob = json.dumps(payload, sort_keys=True, ensure_ascii=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode("ascii")).hexdigest()


def file_hash(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def read_json(path: Path) -> dict | None:
    """The JSON object in ``path``, or None if missing/corrupt (treated as a cache miss)."""
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def write_json(path: Path, data: dict) -> None:
    """Write a cache entry's JSON (not fsynced: :func:`read_json` takes a damaged one for a miss)."""
    atomic_write(path, json_bytes(data, indent=1), durable=False)


def write_bytes(path: Path, data: bytes) -> None:
    """Write a cache entry's data file (not fsynced: the entry's JSON records its size, which its
    reader checks)."""
    atomic_write(path, data, durable=False)
