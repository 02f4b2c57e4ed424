"""A build's outputs: where each goes, writing them, and ``OUT/manifest.json``.

Layout: the outputs of a script sit at its path relative to the deepest folder that holds
every PATH of the build (a folder PATH holds itself; a file PATH is held by its folder), with
its extension replaced: ``sgt build game -o out`` writes ``game/act1/intro.sgt``'s motion to
``out/act1/intro.json``, its ``--bvh`` to ``out/act1/intro.bvh``, its ``--glb`` to
``out/act1/intro.glb`` and its ``--wav`` speech to ``out/act1/intro_000.wav``,
``intro_001.wav``, ... (one per utterance, named as ``sgt say`` names them).

Every file is written by :mod:`core.fileio` (atomically), the manifest last. The manifest is
deterministic (sorted, no times, no absolute paths): two builds of the same inputs differ
only in the ``cached`` flags.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from core.fileio import atomic_write

MANIFEST = "manifest.json"
#: Size and modification time of each output when this build last wrote or checked it: a
#: rebuild trusts an output whose size and time are unchanged instead of reading it again
#: (as git and make do). Not part of the manifest, which must not depend on when it was built.
STATE = ".sgt-build-state.json"
MANIFEST_FORMAT = "sgt-build"
MANIFEST_VERSION = 1

#: The temporary files :func:`core.fileio.atomic_write` makes next to an output (``.NAME.XXXXXXXX.tmp``).
_TEMP = re.compile(r"^\.(?P<name>.+)\.[a-z0-9_]{8}\.tmp$")


def output_base(paths: list[Path]) -> Path:
    """The deepest folder that holds every PATH of the build."""
    folders = [os.path.abspath(p) if os.path.isdir(p) else os.path.dirname(os.path.abspath(p)) for p in paths]
    return Path(os.path.commonpath(folders))


def stem(rel: str) -> str:
    """``act1/intro.sgt`` -> ``act1/intro``."""
    return rel[: -len(Path(rel).suffix)] if Path(rel).suffix else rel


def wav_name(rel: str, index: int) -> str:
    return f"{stem(rel)}_{index:03d}.wav"


def sha256(data: bytes) -> str:
    import hashlib

    return hashlib.sha256(data).hexdigest()


def file_record(out: Path, rel: str) -> dict:
    """``{"path", "sha256", "bytes"}`` of a written output."""
    data = (out / rel).read_bytes()
    return {"path": rel, "sha256": sha256(data), "bytes": len(data)}


def intact(out: Path, record: dict, state: dict | None = None) -> bool:
    """Whether the output a manifest lists is still there with the same content: the same size
    and time as ``state`` recorded for that content, or else the same sha256."""
    try:
        path = out / record["path"]
        st = os.stat(path)
    except (OSError, KeyError, TypeError, ValueError):
        return False
    seen = (state or {}).get(record["path"])
    if seen == [st.st_size, st.st_mtime_ns, record.get("sha256")]:
        return True
    try:
        data = path.read_bytes()
    except OSError:
        return False
    ok = len(data) == record.get("bytes") and sha256(data) == record.get("sha256")
    if ok and state is not None:
        state[record["path"]] = [st.st_size, st.st_mtime_ns, record["sha256"]]
    return ok


def read_state(out: Path) -> tuple[dict, dict]:
    """What the last build recorded beside the manifest (not part of the result): each output's
    size, time and sha256, and each script's inputs fingerprint (see :mod:`.inputs`)."""
    try:
        state = json.loads((out / STATE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}, {}
    if not isinstance(state, dict):
        return {}, {}
    if not isinstance(state.get("outputs"), dict):  # the first format: outputs only
        return state, {}
    inputs = state.get("inputs")
    return state["outputs"], inputs if isinstance(inputs, dict) else {}


def write_state(out: Path, records: list[dict], inputs: dict[str, dict]) -> None:
    """Size and time of every output listed in ``records`` (the manifest's scripts), and the
    ``inputs`` fingerprint of each script built (by source path)."""
    sizes = {}
    for script in records:
        for r in script.get("outputs") or ():
            try:
                st = os.stat(out / r["path"])
            except OSError:
                continue
            sizes[r["path"]] = [st.st_size, st.st_mtime_ns, r["sha256"]]
    state = {"outputs": sizes, "inputs": inputs}
    atomic_write(out / STATE, json.dumps(state, separators=(",", ":"), ensure_ascii=True).encode("ascii"))


def write_motion_outputs(out: Path, rel: str, clips: list, exports: tuple[str, ...], tracks=()) -> list[dict]:
    """The motion file (utterances on the performance clock and the speakers' ``tracks``) and
    the ``exports`` (``bvh``, ``glb``) of one script: one file per speaker's track as ``sgt
    export`` writes them (``NAME.bvh`` for one speaker, ``NAME.SPEAKER.bvh`` for several; the
    utterances joined when there are no tracks); their records."""
    from core.motion import save_motion  # lazy: numpy

    written = [f"{stem(rel)}.json"]
    save_motion(out / written[0], clips, format="json", tracks=list(tracks))
    if clips and exports:
        from renders.clips import concat_clips, speaker_name, track_clip  # lazy: numpy, the exporters

        if tracks:
            many = len(tracks) > 1
            parts = [(f".{speaker_name(t.speaker)}" if many else "", track_clip(t, clips)) for t in tracks]
        else:
            parts = [("", concat_clips(clips))]
        for suffix, clip in parts:
            if "bvh" in exports:
                from renders.export import bvh_text  # lazy: numpy

                written.append(f"{stem(rel)}{suffix}.bvh")
                atomic_write(out / written[-1], bvh_text(clip).encode("utf-8"))
            if "glb" in exports:
                from renders.gltf import glb_bytes  # lazy: numpy
                from renders.rigs import get_rig  # lazy: numpy

                written.append(f"{stem(rel)}{suffix}.glb")
                atomic_write(out / written[-1], glb_bytes(clip, get_rig("sgt")))
    return [file_record(out, name) for name in written]


def write_wav(out: Path, rel: str, index: int, audio_path: Path) -> dict:
    name = wav_name(rel, index)
    atomic_write(out / name, Path(audio_path).read_bytes())
    return file_record(out, name)


def read_manifest(out: Path) -> dict:
    """The previous build's manifest, or an empty one (missing, damaged, another format)."""
    try:
        doc = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    if not isinstance(doc, dict) or doc.get("format") != MANIFEST_FORMAT or doc.get("version") != MANIFEST_VERSION:
        return {}
    return doc


class _OnePerLine(list):
    """A list the manifest writes one item per line (a script's utterances)."""


def write_manifest(out: Path, settings: dict, scripts: list[dict]) -> None:
    from core.frames_text import json_with_lines  # lazy: numpy

    doc = {"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION, "settings": settings,
           "scripts": [{**s, "utterances": _OnePerLine(s["utterances"])} if "utterances" in s else s
                       for s in sorted(scripts, key=lambda s: s["source"])]}

    def items(x, ascii_only: bool):
        if not isinstance(x, _OnePerLine):
            return None
        return [json.dumps(u, ensure_ascii=ascii_only, separators=(", ", ": ")) for u in x]

    try:
        data = json_with_lines(doc, lambda x: items(x, False), ensure_ascii=False).encode("utf-8")
    except UnicodeEncodeError:  # a file name that is not UTF-8 (Python keeps its bytes as lone surrogates)
        data = json_with_lines(doc, lambda x: items(x, True)).encode("ascii")
    atomic_write(out / MANIFEST, data + b"\n")


def remove_stale(out: Path, old: dict, keep: set[str]) -> list[str]:
    """Remove outputs the previous manifest lists that this build no longer makes (their script
    is gone or failed), when they are unchanged since (a file edited by hand stays)."""
    removed = []
    for script in old.get("scripts") or ():
        for record in script.get("outputs") or ():
            rel = record.get("path") if isinstance(record, dict) else None
            if not isinstance(rel, str) or rel in keep or not _inside(out, rel):
                continue
            if intact(out, record):
                os.unlink(out / rel)
                removed.append(rel)
    return removed


def remove_temporaries(out: Path, folders: set[Path]) -> None:
    """Delete the temporary files that a killed build left next to its outputs (``kill -9``
    stops :func:`core.fileio.atomic_write` before it can clean up)."""
    for folder in folders:
        try:
            entries = list(os.scandir(out / folder))
        except OSError:
            continue
        for e in entries:
            if _TEMP.match(e.name) and e.is_file(follow_symlinks=False):
                try:
                    os.unlink(e.path)
                except OSError:
                    pass


def _inside(out: Path, rel: str) -> bool:
    if os.path.isabs(rel):
        return False
    full = os.path.normpath(os.path.join(out, rel))
    return full.startswith(os.path.normpath(out) + os.sep)
