"""What a script's analysis read, fingerprinted cheaply, so a rebuild can skip the analysis.

Keying a script's utterances means parsing it, loading its gesture library and describing
every utterance: about 35 ms for a script of 100 lines, 3.5 s for 10,000 lines, which a
rebuild with one line changed would pay for every unchanged script. Instead the build's state
file (beside the manifest) records, per built script, a fingerprint of everything its keys
were computed from:

- the script's bytes (sha256);
- the build's token: the code's format version, the settings (with the weights' hashes), the
  espeak-ng build, the aligner's version, the library config files (size and time) and
  ``SGT_LIBRARY_PATH``;
- the files and folders the analysis read besides the script: every gesture folder loaded
  (each ``*.toml`` in it by name, size and modification time, so an added, removed or edited
  gesture counts) and every recording and timings file (size, modification time, inode).

When the fingerprint of a script equals its record's and the outputs are intact, the build
takes the record as it is; anything else (a changed byte, a touched gesture file, another
option) analyses the script as before. Recordings are compared by size, time and inode here,
not by content: the utterance keys themselves hash them, so a file changed without changing
those three (a rare, deliberate act) is only seen once the script itself is analysed again.

The same files (and each script itself) make the build's :class:`Guard`: no output of a
build may be one of its inputs.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
from pathlib import Path

from core.paths import LIBRARY_PATH_VAR, config_files
from sgt_tui.build import keys


def build_token(settings) -> str:
    """The part of every fingerprint that does not depend on the script."""
    doc = {
        "code": keys.CODE_VERSION,
        "settings": settings.describe(),
        "espeak": keys._espeak_build(),
        "aligner": keys._aligner(),
        "config": [[str(p), _stat(p)] for p in config_files()],
        "library_env": os.environ.get(LIBRARY_PATH_VAR, ""),
    }
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode("utf-8")).hexdigest()


def dependencies(script, library) -> list[str]:
    """The files and folders the analysis of ``script`` read besides the script itself."""
    deps = [os.path.abspath(folder) for _, folder in getattr(library, "folders", ())]
    for utt in script.utterances:
        if utt.audio is not None:
            deps.append(os.path.abspath(utt.audio.path))
            if utt.audio.timings is not None:
                deps.append(os.path.abspath(utt.audio.timings))
    return sorted(set(deps))


def fingerprint(source: bytes, deps: list[str], token: str, seen: dict | None = None) -> str:
    """``seen`` keeps the look at each dependency for the build (scripts share gesture folders)."""
    seen = {} if seen is None else seen
    for d in deps:
        if d not in seen:
            seen[d] = _stat(Path(d))
    h = hashlib.sha256()
    h.update(token.encode("ascii"))
    h.update(hashlib.sha256(source).digest())
    h.update(json.dumps([[d, seen[d]] for d in deps]).encode("utf-8"))
    return h.hexdigest()


def _stat(path: Path):
    """A folder: its gesture files by (name, size, time); a file: (size, time, inode); None if missing."""
    try:
        st = path.stat()
    except OSError:
        return None
    if not path.is_dir():
        return [st.st_size, st.st_mtime_ns, st.st_ino]
    try:
        with os.scandir(path) as entries:
            gestures = [e for e in entries if e.name.endswith(".toml") and not e.name.startswith(".")]
            return sorted([e.name, e.stat().st_size, e.stat().st_mtime_ns] for e in gestures)
    except OSError:
        return None


class Guard:
    """The files a build reads (scripts, recordings, timings files), by device and inode, so
    that no output of the build is one of them: the same file through a symbolic or a hard
    link counts (:func:`core.fileio.same_file`'s rule, with one look at each file however many
    outputs are checked). Folders are not kept (gesture folders: no output is a ``.toml``
    file), nor what is not there."""

    def __init__(self) -> None:
        self._files: dict[tuple[int, int], tuple[str, str, str]] = {}

    def add(self, path, reader: str, kind: str = "file") -> None:
        """``path`` is read by the script ``reader`` (as the build names it) as its ``kind``
        (``script``, ``recording``, ``timings file``, or just ``file``)."""
        try:
            st = os.stat(path)
        except (OSError, ValueError):
            return
        if not stat.S_ISREG(st.st_mode):
            return
        key = (st.st_dev, st.st_ino)
        if key not in self._files or self._files[key][2] == "file":
            self._files[key] = (os.fspath(path), reader, kind)

    def reader(self, output) -> tuple[str, str, str] | None:
        """(the input, the script that reads it, its kind) when ``output`` is an input, else None."""
        try:
            st = os.stat(output)
        except (OSError, ValueError):
            return None
        return self._files.get((st.st_dev, st.st_ino))

    def clash(self, output, script) -> str | None:
        """Why writing ``output`` for ``script`` would destroy an input (the end of a sentence
        that starts with the output), or None."""
        found = self.reader(output)
        if found is None:
            return None
        what, reader, kind = found
        same = os.path.abspath(what) == os.path.abspath(output)
        if kind == "script":
            return "is the script itself" if same and _same(reader, script) else f"is the script {what}"
        return f"is the {kind}{'' if same else ' ' + what} that {'it' if _same(reader, script) else reader} reads"


def _same(a, b) -> bool:
    return os.path.abspath(a) == os.path.abspath(b)


def named_files(script) -> list[tuple[str, str]]:
    """(path, kind) of the recordings and timings files an analysed script reads."""
    found = []
    for utt in script.utterances:
        if utt.audio is not None:
            found.append((os.path.abspath(utt.audio.path), "recording"))
            if utt.audio.timings is not None:
                found.append((os.path.abspath(utt.audio.timings), "timings file"))
    return found
