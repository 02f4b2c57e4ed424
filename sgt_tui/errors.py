"""Errors shared by the ``sgt`` command and its subcommands.

In a module of its own, not in :mod:`sgt_tui.cli`: under ``python -m sgt_tui.cli`` that module
runs as ``__main__``, and a class defined there would be a different class from the one the
subcommands import, so their usage errors would escape as tracebacks.
"""


class UsageError(Exception):
    """A problem with how the command was called (exit status 2)."""


class InputError(Exception):
    """A problem in the user's input (exit status 1): ``str()`` is the one-line message, or
    ``printed`` says the diagnostics were printed already."""

    def __init__(self, message: str, printed: bool = False) -> None:
        super().__init__(message)
        self.printed = printed
