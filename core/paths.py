"""User locations: where sgt reads configuration and keeps caches. The one place that knows.

Follows the XDG base directory specification (the variables are read on every call, so a
test or a user can change them at run time):

- configuration: ``$XDG_CONFIG_HOME/sgt`` (default ``~/.config/sgt``), holding ``config.toml``;
  a project may add ``./sgt.toml`` in the current directory;
- caches: ``$SGT_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/sgt`` (default ``~/.cache/sgt``),
  with one folder per user of the cache (:func:`cache_dir`): ``speech`` (synthesized and
  aligned speech), ``editor`` (the editor's motion cache, worker log, recovery files).

Every directory is created by whoever writes into it, never here.
"""

from __future__ import annotations

import os
from pathlib import Path

#: Environment variable: gesture folders, separated by ``os.pathsep`` (see :mod:`library.config`).
LIBRARY_PATH_VAR = "SGT_LIBRARY_PATH"
#: Environment variable: the root of every sgt cache (overrides ``XDG_CACHE_HOME``).
CACHE_VAR = "SGT_CACHE_DIR"


def _xdg(variable: str, default: str) -> Path:
    value = os.environ.get(variable)
    # The spec: a relative path in an XDG variable is invalid and must be ignored.
    if value and os.path.isabs(os.path.expanduser(value)):
        return Path(os.path.expanduser(value))
    return Path.home() / default


def config_dir() -> Path:
    """``$XDG_CONFIG_HOME/sgt`` (default ``~/.config/sgt``)."""
    return _xdg("XDG_CONFIG_HOME", ".config") / "sgt"


def config_files() -> list[Path]:
    """The config files consulted, in order (whether they exist or not): the user's, then the project's."""
    return [config_dir() / "config.toml", Path.cwd() / "sgt.toml"]


def cache_root() -> Path:
    """``$SGT_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/sgt`` (default ``~/.cache/sgt``)."""
    env = os.environ.get(CACHE_VAR)
    if env:
        return Path(os.path.expanduser(env))
    return _xdg("XDG_CACHE_HOME", ".cache") / "sgt"


def cache_dir(kind: str) -> Path:
    """The cache folder of one kind of data (``speech``, ``editor``, ...)."""
    return cache_root() / kind
