"""A build's outputs: where each goes, writing them, and ``OUT/manifest.json``.

Layout: the outputs of a script sit at its path relative to the deepest folder that holds
every PATH of the build (a folder PATH holds itself; a file PATH is held by its folder), with
its extension replaced: ``sgt build game -o out`` writes ``game/act1/intro.sgt``'s motion to
``out/act1/intro.json``, its ``--bvh`` to ``out/act1/intro.bvh``, its ``--glb`` to
``out/act1/intro.glb`` and its ``--wav`` speech to ``out/act1/intro_000.wav``,
``intro_001.wav``, ... (one per utterance, named as ``sgt say`` names them).

Every file is written, read back and removed under ``OUT`` by :class:`core.fileio.Inside`:
atomically, and never through a symbolic link (a link in ``OUT`` where an output goes, or on
the way to it, is refused with one line and left alone, so nothing outside ``OUT`` is ever
written, read as an output or deleted); the manifest is written last. The manifest is
deterministic (sorted, no times, no absolute paths): two builds of the same inputs differ
only in the ``cached`` flags.

A build checks the outputs the previous manifest lists before it trusts them (:func:`intact`):
by the size, modification and change times and inode that :data:`STATE` recorded with each
output's sha256, when they vouch for it (:func:`trusted`), else by reading and hashing it. An
output that is an input of the build (:class:`.inputs.Guard`) is never written
(:class:`Overwrite`) nor removed.
"""

from __future__ import annotations

import io
import json
import os
import re
import stat
import time
from pathlib import Path

from core.fileio import Inside, OutputError
from core.reading import loads_json

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

#: The largest manifest or state file read (a build of 100,000 utterances writes about 15 MiB).
MAX_RECORD_BYTES = 256 << 20

#: The temporary files :class:`core.fileio.Inside` makes next to an output (``.NAME.XXXXXXXX.tmp``).
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


def _read(out: Path, rel: str) -> tuple[bytes, list[int] | None, int]:
    """The bytes of the output ``rel`` (never through a link: :class:`core.fileio.Inside`),
    its :func:`_seen` (None if it changed while it was read) and the time just before it was
    looked at. OSError when it is not there or cannot be read."""
    now = time.time_ns()
    with Inside(out) as d:
        f = d.open(rel)
    if f is None:
        raise FileNotFoundError(f"{Path(out) / rel} is not there")
    with f:
        before = os.fstat(f.fileno())
        data = f.read()
        after = os.fstat(f.fileno())
    return data, _seen(before) if _seen(before) == _seen(after) else None, now


def file_record(out: Path, rel: str, state: dict | None = None) -> dict:
    """``{"path", "sha256", "bytes"}`` of a written output, from the file as it is now (read
    back); what was seen of it goes into ``state``."""
    data, seen, now = _read(out, rel)
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
    else read and hashed, and what was seen recorded in ``state``. A file reached through a
    link is not intact (:class:`core.fileio.Inside`)."""
    try:
        rel = record["path"]
        with Inside(out) as d:
            st = d.lstat(rel)
    except (OSError, KeyError, TypeError, ValueError):
        return False
    if st is None or not stat.S_ISREG(st.st_mode):
        return False
    if state is not None and trusted(state.get(rel), st, record.get("sha256")):
        return True
    try:
        data, seen, now = _read(out, rel)
    except OSError:
        return False
    ok = len(data) == record.get("bytes") and sha256(data) == record.get("sha256")
    if state is not None:
        state[rel] = seen + [record["sha256"], now] if ok and seen else None
    return ok


def _read_json(out: Path, name: str):
    """The JSON document ``OUT/name`` (the manifest, the state), None when it is not there, is
    not JSON or is reached through a link (the build then refuses to write it)."""
    try:
        with Inside(out) as d:
            data = d.read(name, MAX_RECORD_BYTES)
        return loads_json(data) if data is not None else None
    except (OSError, ValueError):
        return None


def read_state(out: Path) -> tuple[dict, dict]:
    """What the last build recorded beside the manifest (not part of the result): what it saw
    of each output (see :data:`STATE`), and each script's inputs fingerprint (see :mod:`.inputs`)."""
    state = _read_json(out, STATE)
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
                    with Inside(out) as d:
                        st = d.lstat(r["path"])
                except OSError:
                    continue
                if st is None:
                    continue
                if _seen(st) == seen[:4]:
                    seen = seen[:5] + [now]
            kept[r["path"]] = seen
    doc = {"outputs": kept, "inputs": inputs}
    write(out, STATE, json.dumps(doc, separators=(",", ":"), ensure_ascii=True).encode("ascii"))


def check_writable(out: Path, rel: str) -> None:
    """Raise :class:`core.fileio.LinkRefused` (one line) when ``OUT/rel`` is, or is reached
    through, a symbolic link: the build would refuse to write it (checked before any work)."""
    with Inside(out) as d:
        d.check(rel)


def write(out: Path, rel: str, data: bytes) -> None:
    """Write the file ``OUT/rel`` by :class:`core.fileio.Inside`'s rule (never through a link)."""
    with Inside(out, create=True) as d:
        d.write(rel, data)


def write_motion_outputs(out: Path, rel: str, clips: list, exports: tuple[str, ...], tracks=(), *,
                         state: dict | None = None, guard=None, source=None, engine: str | None = None) -> list[dict]:
    """The motion file (utterances on the performance clock and the speakers' ``tracks``, the
    script it was made from, ``source``, and the ``engine``: the file ``sgt generate`` writes) and
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
    motion = io.BytesIO()
    save_motion(motion, clips, format="json", tracks=list(tracks), source=source, engine=engine, at=out / names[0])
    write(out, names[0], motion.getvalue())
    for suffix, make in parts:
        clip = make()
        if "bvh" in exports:
            from renders.export import bvh_text  # lazy: numpy

            write(out, f"{stem(rel)}{suffix}.bvh", bvh_text(clip).encode("utf-8"))
        if "glb" in exports:
            from renders.gltf import glb_bytes  # lazy: numpy
            from renders.rigs import get_rig  # lazy: numpy

            write(out, f"{stem(rel)}{suffix}.glb", glb_bytes(clip, get_rig("sgt")))
    return [file_record(out, name, state) for name in names]


def write_wav(out: Path, rel: str, index: int, audio_path: Path, *, state: dict | None = None, guard=None) -> dict:
    name = wav_name(rel, index)
    _not_an_input(out, name, guard)
    write(out, name, Path(audio_path).read_bytes())
    return file_record(out, name, state)


def _not_an_input(out: Path, name: str, guard) -> None:
    found = guard.reader(out / name) if guard is not None else None
    if found is not None:
        raise Overwrite(f"not written: its output {out / name} is the {found[2]} {found[0]} that {found[1]} reads")


def read_manifest(out: Path) -> dict:
    """The previous build's manifest, or an empty one (missing, damaged, another format)."""
    doc = _read_json(out, MANIFEST)
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
    write(out, MANIFEST, data + b"\n")


def remove_stale(out: Path, old: dict, keep: set[str], guard=None, warn=None) -> list[str]:
    """Remove outputs the previous manifest lists that this build no longer makes (their script
    is gone or failed), when they are unchanged since (a file edited by hand stays), unless
    they are inputs of this build (``guard``). Only files inside ``OUT`` are removed, never
    through a link: a path that leads out or through a link is left, and ``warn(line)`` told."""
    removed = []
    with Inside(out) as d:
        for script in old.get("scripts") or ():
            if not isinstance(script, dict):
                continue
            for record in script.get("outputs") or ():
                rel = record.get("path") if isinstance(record, dict) else None
                if not isinstance(rel, str) or rel in keep:
                    continue
                if guard is not None and guard.reader(out / rel) is not None:
                    continue
                try:
                    if d.remove(rel, check=lambda f, record=record: _holds(f, record)):
                        removed.append(rel)
                except OutputError as exc:
                    if warn is not None:
                        warn(f"{exc} (a stale output the manifest lists)")
    return removed


def _holds(f, record: dict) -> bool:
    """Whether the open file ``f`` has the size and sha256 the manifest ``record`` gives it."""
    data = f.read()
    return len(data) == record.get("bytes") and sha256(data) == record.get("sha256")


def remove_temporaries(out: Path, folders: set[Path], guard=None) -> None:
    """Delete the temporary files that a killed build left next to its outputs (``kill -9``
    stops :class:`core.fileio.Inside` before it can clean up); never an input of the build,
    never through a link."""
    with Inside(out) as d:
        for folder in folders:
            try:
                entries = d.entries(str(folder))
            except OSError:
                continue  # a link on the way: the outputs there are refused when written
            for name, regular in entries:
                rel = os.path.join(folder, name)
                if regular and _TEMP.match(name) and (guard is None or guard.reader(out / rel) is None):
                    try:
                        d.remove(rel)
                    except OSError:
                        pass
