"""Errors shared by the ``sgt`` command and its subcommands.

In a module of its own, not in :mod:`sgt_tui.cli`: under ``python -m sgt_tui.cli`` that module
runs as ``__main__``, and a class defined there would be a different class from the one the
subcommands import, so their usage errors would escape as tracebacks.
"""


class UsageError(Exception):
    """A problem with how the command was called (exit status 2)."""
