"""Motion for a command: generated from a script, or read from a motion file.

The one place where a command turns a script into motion (through
:func:`model.generate.generate`, the path the editor's worker takes too) and reports what
went wrong: script errors as diagnostics (exit 1), an utterance the script does not have
(exit 2), an engine that cannot run (exit 1).
"""

from __future__ import annotations

from pathlib import Path

from sgt_tui.commands.common import existing_file, print_diagnostics
from sgt_tui.errors import InputError, UsageError

MOTION_SUFFIXES = (".json", ".npz")
SCRIPT_SUFFIXES = (".sgt",)


def generate_script(path: Path, *, engine: str | None = None, utterances=None, seed: int | None = None,
                    options=None, label: str = "generate"):
    """Compile and generate ``path``; returns a :class:`model.generate.Take`. Warnings are
    printed; errors raise :class:`InputError` (diagnostics printed) or :class:`UsageError`."""
    from model.generate import GenerateError, NoSuchUtterance, generate  # lazy: numpy, the engines
    from sgt_tui.progress import ProgressBar

    try:
        take = generate(path, engine=engine, utterances=utterances, seed=seed, options=options,
                        progress=ProgressBar(label))
    except NoSuchUtterance as exc:
        raise UsageError(f"{path}: {exc}") from None
    except GenerateError as exc:
        if exc.diagnostics:
            print_diagnostics(exc.diagnostics, {str(path): exc.source})
            raise InputError(str(exc), printed=True) from None
        raise InputError(str(exc)) from None
    print_diagnostics(take.diagnostics, {str(path): take.source})
    return take


def load_clips(path_text: str, utterance: int | None = None, *, engine: str | None = None,
               seed: int | None = None, options=None) -> list:
    """Clips of a motion file (.json/.npz) or a script (.sgt, generated), narrowed to
    ``utterance`` (0-based) when given."""
    path = existing_file(path_text)
    suffix = path.suffix.lower()
    if suffix in SCRIPT_SUFFIXES:
        utterances = [utterance] if utterance is not None else None
        return generate_script(path, engine=engine, utterances=utterances, seed=seed, options=options).clips
    if suffix not in MOTION_SUFFIXES:
        raise UsageError(f"{path}: unknown input type '{suffix or '(none)'}' (use .json, .npz or .sgt)")
    from core.motion import MotionFileError, load_motion  # lazy: numpy

    try:
        clips = load_motion(path)
    except MotionFileError as exc:
        raise InputError(str(exc)) from None
    if not clips:
        raise InputError(f"{path}: no utterances")
    from renders.clips import pick  # lazy: numpy

    try:
        return pick(clips, utterance)
    except IndexError as exc:
        raise UsageError(f"{path}: {exc}") from None
