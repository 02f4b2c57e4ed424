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

A build checks the outputs the previous manifest lists before it trusts them (:func:`intact`):
by the size, modification and change times and inode that :data:`STATE` recorded with each
output's sha256, when they vouch for it (:func:`trusted`), else by reading and hashing it. An
output that is an input of the build (:class:`.inputs.Guard`) is never written
(:class:`Overwrite`) nor removed.
"""

from __future__ import annotations

import json
import os
import re
import time
from pathlib import Path

from core.fileio import atomic_write

MANIFEST = "manifest.json"
#: What this build saw of each output, so that a rebuild trusts an output without reading it
#: again (as git and make do): its size, modification and change times and inode when its
#: sha256 was computed (from the file as read back, never from what was meant to be there),
#: and when that was. Not part of the manifest, which must not depend on when it was built.
STATE = ".sgt-build-state.json"
MANIFEST_FORMAT = "sgt-build"
MANIFEST_VERSION = 1

#: An output whose change time is less than this before the moment its state was recorded
#: is hashed again by the next build, however its times look: a file changed in place in the
#: same clock tick as that look (the file system's clock has ticks of milliseconds, seconds
#: on old ones) keeps its size and times ("racy git").
RACY_NS = 2_000_000_000

#: The temporary files :func:`core.fileio.atomic_write` makes next to an output (``.NAME.XXXXXXXX.tmp``).
_TEMP = re.compile(r"^\.(?P<name>.+)\.[a-z0-9_]{8}\.tmp$")


class Overwrite(Exception):
    """An output of the build is one of its inputs (one line for users, the script's error)."""


def output_base(paths: list[Path]) -> Path:
    """The deepest folder that holds every PATH of the build."""
    folders = [os.path.abspath(p) if os.path.isdir(p) else os.path.dirname(os.path.abspath(p)) for p in paths]
    return Path(os.path.commonpath(folders))


def stem(rel: str) -> str:
    """``act1/intro.sgt`` -> ``act1/intro``."""
    return rel[: -len(Path(rel).suffix)] if Path(rel).suffix else rel


def wav_name(rel: str, index: int) -> str:
    return f"{stem(rel)}_{index:03d}.wav"


def planned(rel: str, speakers: list, indices: list[int], exports: tuple[str, ...]) -> list[str]:
    """The outputs a script with these speakers (in order of their first line, as the tracks
    are) and utterance numbers will have, as :func:`write_motion_outputs` and :func:`write_wav`
    name them."""
    from renders.clips import speaker_name  # lazy: numpy, the exporters

    names = [f"{stem(rel)}.json"]
    if indices:
        suffixes = [f".{speaker_name(sp)}" for sp in speakers] if len(speakers) > 1 else [""]
        for suffix in suffixes:
            names += [f"{stem(rel)}{suffix}.{kind}" for kind in ("bvh", "glb") if kind in exports]
    if "wav" in exports:
        names += [wav_name(rel, i) for i in indices]
    return names


def sha256(data: bytes) -> str:
    import hashlib

    return hashlib.sha256(data).hexdigest()


def _seen(st: os.stat_result) -> list[int]:
    return [st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino]


def _read(path: Path) -> tuple[bytes, list[int] | None, int]:
    """The file's bytes, its :func:`_seen` (None if it changed while it was read) and the time
    just before it was looked at."""
    now = time.time_ns()
    with open(path, "rb") as f:
        before = os.fstat(f.fileno())
        data = f.read()
        after = os.fstat(f.fileno())
    return data, _seen(before) if _seen(before) == _seen(after) else None, now


def file_record(out: Path, rel: str, state: dict | None = None) -> dict:
    """``{"path", "sha256", "bytes"}`` of a written output, from the file as it is now (read
    back); what was seen of it goes into ``state``."""
    data, seen, now = _read(out / rel)
    record = {"path": rel, "sha256": sha256(data), "bytes": len(data)}
    if state is not None:
        state[rel] = seen + [record["sha256"], now] if seen else None
    return record


def trusted(seen, st: os.stat_result, digest) -> bool:
    """Whether ``seen`` (a state entry) vouches for the file with status ``st`` having the
    sha256 ``digest``: the same size, times and inode, recorded when no change in the same
    clock tick could hide (:data:`RACY_NS`)."""
    return (isinstance(seen, list) and len(seen) == 6 and seen[:4] == _seen(st) and seen[4] == digest
            and isinstance(seen[5], int) and max(st.st_mtime_ns, st.st_ctime_ns) + RACY_NS < seen[5])


def intact(out: Path, record: dict, state: dict | None = None) -> bool:
    """Whether the output a manifest lists is there with the content the manifest gives it
    (size and sha256): trusted from ``state`` when it vouches for the file (:func:`trusted`),
    else read and hashed, and what was seen recorded in ``state``."""
    try:
        path = out / record["path"]
        st = os.stat(path)
    except (OSError, KeyError, TypeError, ValueError):
        return False
    if state is not None and trusted(state.get(record["path"]), st, record.get("sha256")):
        return True
    try:
        data, seen, now = _read(path)
    except OSError:
        return False
    ok = len(data) == record.get("bytes") and sha256(data) == record.get("sha256")
    if state is not None:
        state[record["path"]] = seen + [record["sha256"], now] if ok and seen else None
    return ok


def read_state(out: Path) -> tuple[dict, dict]:
    """What the last build recorded beside the manifest (not part of the result): what it saw
    of each output (see :data:`STATE`), and each script's inputs fingerprint (see :mod:`.inputs`)."""
    try:
        state = json.loads((out / STATE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}, {}
    if not isinstance(state, dict) or not isinstance(state.get("outputs"), dict):
        return {}, {}
    inputs = state.get("inputs")
    return state["outputs"], inputs if isinstance(inputs, dict) else {}


def write_state(out: Path, records: list[dict], inputs: dict[str, dict], state: dict, written: set[str]) -> None:
    """What was seen of every output listed in ``records`` (the manifest's scripts), from
    ``state``, and the ``inputs`` fingerprint of each script built (by source path).

    The outputs this build ``written`` were seen just after they were written; those still
    the same now are recorded as seen now, so that the next build trusts them (only the last
    :data:`RACY_NS` of them are read again)."""
    now = time.time_ns()
    kept = {}
    for script in records:
        for r in script.get("outputs") or ():
            seen = state.get(r["path"])
            if not isinstance(seen, list) or len(seen) != 6 or seen[4] != r["sha256"]:
                continue
            if r["path"] in written:
                try:
                    if _seen(os.stat(out / r["path"])) == seen[:4]:
                        seen = seen[:5] + [now]
                except OSError:
                    continue
            kept[r["path"]] = seen
    doc = {"outputs": kept, "inputs": inputs}
    atomic_write(out / STATE, json.dumps(doc, separators=(",", ":"), ensure_ascii=True).encode("ascii"))


def write_motion_outputs(out: Path, rel: str, clips: list, exports: tuple[str, ...], tracks=(), *,
                         state: dict | None = None, guard=None) -> list[dict]:
    """The motion file (utterances on the performance clock and the speakers' ``tracks``) and
    the ``exports`` (``bvh``, ``glb``) of one script: one file per speaker's track as ``sgt
    export`` writes them (``NAME.bvh`` for one speaker, ``NAME.SPEAKER.bvh`` for several; the
    utterances joined when there are no tracks); their records. Nothing is written when one
    of them is an input of the build (``guard``, :class:`.inputs.Guard`): :class:`Overwrite`."""
    from core.motion import save_motion  # lazy: numpy

    parts = []
    if clips and exports:
        from renders.clips import concat_clips, speaker_name, track_clip  # lazy: numpy, the exporters

        if tracks:
            many = len(tracks) > 1
            parts = [(f".{speaker_name(t.speaker)}" if many else "", lambda t=t: track_clip(t, clips)) for t in tracks]
        else:
            parts = [("", lambda: concat_clips(clips))]
    names = [f"{stem(rel)}.json"] + [f"{stem(rel)}{suffix}.{kind}" for suffix, _ in parts
                                     for kind in ("bvh", "glb") if kind in exports]
    for name in names:
        _not_an_input(out, name, guard)
    save_motion(out / names[0], clips, format="json", tracks=list(tracks))
    for suffix, make in parts:
        clip = make()
        if "bvh" in exports:
            from renders.export import bvh_text  # lazy: numpy

            atomic_write(out / f"{stem(rel)}{suffix}.bvh", bvh_text(clip).encode("utf-8"))
        if "glb" in exports:
            from renders.gltf import glb_bytes  # lazy: numpy
            from renders.rigs import get_rig  # lazy: numpy

            atomic_write(out / f"{stem(rel)}{suffix}.glb", glb_bytes(clip, get_rig("sgt")))
    return [file_record(out, name, state) for name in names]


def write_wav(out: Path, rel: str, index: int, audio_path: Path, *, state: dict | None = None, guard=None) -> dict:
    name = wav_name(rel, index)
    _not_an_input(out, name, guard)
    atomic_write(out / name, Path(audio_path).read_bytes())
    return file_record(out, name, state)


def _not_an_input(out: Path, name: str, guard) -> None:
    found = guard.reader(out / name) if guard is not None else None
    if found is not None:
        raise Overwrite(f"not written: its output {out / name} is the {found[2]} {found[0]} that {found[1]} reads")


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


def remove_stale(out: Path, old: dict, keep: set[str], guard=None) -> list[str]:
    """Remove outputs the previous manifest lists that this build no longer makes (their script
    is gone or failed), when they are unchanged since (a file edited by hand stays), unless
    they are inputs of this build (``guard``)."""
    removed = []
    for script in old.get("scripts") or ():
        if not isinstance(script, dict):
            continue
        for record in script.get("outputs") or ():
            rel = record.get("path") if isinstance(record, dict) else None
            if not isinstance(rel, str) or rel in keep or not _inside(out, rel):
                continue
            if guard is not None and guard.reader(out / rel) is not None:
                continue
            if intact(out, record):
                os.unlink(out / rel)
                removed.append(rel)
    return removed


def remove_temporaries(out: Path, folders: set[Path], guard=None) -> None:
    """Delete the temporary files that a killed build left next to its outputs (``kill -9``
    stops :func:`core.fileio.atomic_write` before it can clean up); never an input of the build."""
    for folder in folders:
        try:
            entries = list(os.scandir(out / folder))
        except OSError:
            continue
        for e in entries:
            if _TEMP.match(e.name) and e.is_file(follow_symlinks=False) and (guard is None or guard.reader(e.path) is None):
                try:
                    os.unlink(e.path)
                except OSError:
                    pass


def _inside(out: Path, rel: str) -> bool:
    if os.path.isabs(rel):
        return False
    full = os.path.normpath(os.path.join(out, rel))
    return full.startswith(os.path.normpath(out) + os.sep)
