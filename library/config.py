"""Where user gesture folders come from.

Sources, in order (a later folder overrides gestures of an earlier one):

1. ``config.toml`` in the user config folder (:func:`core.paths.config_dir`),
2. ``./sgt.toml`` in the current directory,
3. the environment variable ``SGT_LIBRARY_PATH`` (folders separated by ``os.pathsep``).

In the TOML files the key is ``[library] paths = ["folder", ...]``; relative paths are
resolved against the folder of the config file, ``~`` is expanded. Folders passed by a
script header (``extra_dirs`` of :func:`library.load_library`) come after all of these.
Problems (unreadable file, wrong types) are reported, never raised.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from core.paths import LIBRARY_PATH_VAR, config_files
from core.reading import InputFileError, read_bytes
from library.spec import LibraryProblem, locate, toml_error

ENV_VAR = LIBRARY_PATH_VAR


def _problem(path: Path, text: str, field: str, message: str) -> LibraryProblem:
    line, col, length = locate(text, field)
    return LibraryProblem(path, field, message, line, col, length, kind="config")


def _paths_from_file(path: Path) -> tuple[list[Path], list[LibraryProblem]]:
    try:
        raw = read_bytes(path, "configuration")
    except FileNotFoundError:
        return [], []
    except InputFileError as exc:
        return [], [LibraryProblem(path, "file", f"cannot read: {exc.reason}", kind="config")]
    except OSError as exc:
        return [], [LibraryProblem(path, "file", f"cannot read: {exc.strerror or exc}", kind="config")]
    text = raw.decode("utf-8", errors="replace")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message, line, col = toml_error(exc)
        return [], [LibraryProblem(path, "toml", f"TOML syntax error: {message}", line, col, kind="config")]
    section = data.get("library")
    if section is None:
        return [], []
    if not isinstance(section, dict):
        return [], [_problem(path, text, "library", "[library] must be a table")]
    paths = section.get("paths", [])
    if not isinstance(paths, list) or not all(isinstance(p, str) for p in paths):
        return [], [_problem(path, text, "library.paths", "must be a list of folder names")]
    out = []
    for p in paths:
        folder = Path(os.path.expanduser(p))
        if not folder.is_absolute():
            folder = path.parent / folder
        out.append(folder)
    return out, []


def configured_sources() -> tuple[list[tuple[Path, str]], list[LibraryProblem]]:
    """User gesture folders from the config files and ``SGT_LIBRARY_PATH``, in order, each with
    where it was named (the config file's path, or ``SGT_LIBRARY_PATH``)."""
    folders: list[tuple[Path, str]] = []
    problems: list[LibraryProblem] = []
    for cfg in config_files():
        found, probs = _paths_from_file(cfg)
        folders += [(f, str(cfg)) for f in found]
        problems += probs
    env = os.environ.get(ENV_VAR, "")
    for part in env.split(os.pathsep):
        if part.strip():
            folders.append((Path(os.path.expanduser(part.strip())), ENV_VAR))
    # Keep the first mention of a folder only.
    seen: set[Path] = set()
    unique = []
    for f, source in folders:
        key = Path(os.path.abspath(f))
        if key not in seen:
            seen.add(key)
            unique.append((f, source))
    return unique, problems


def configured_paths() -> tuple[list[Path], list[LibraryProblem]]:
    """User gesture folders from the config files and ``SGT_LIBRARY_PATH``, in order."""
    found, problems = configured_sources()
    return [f for f, _ in found], problems
