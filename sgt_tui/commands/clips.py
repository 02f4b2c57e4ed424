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
                    options=None, label: str = "generate", auto_gestures: bool = False):
    """Compile and generate ``path``; returns a :class:`model.generate.Take`. Warnings are
    printed; errors raise :class:`InputError` (diagnostics printed) or :class:`UsageError`.
    ``auto_gestures``: with the gestures its words call for where it has no mark
    (:mod:`sgt_tui.suggesting`; the take's source is the script with them)."""
    import sys

    from model.generate import GenerateError, NoSuchUtterance, generate  # lazy: numpy, the engines
    from sgt_tui.progress import ProgressBar

    source = None
    if auto_gestures:
        from sgt_tui.suggesting import SuggestError, suggestions_for

        try:
            _, found, source = suggestions_for(path)
        except SuggestError as exc:
            if exc.diagnostics:
                print_diagnostics(exc.diagnostics, exc.sources)
                raise InputError(str(exc), printed=True) from None
            raise InputError(str(exc)) from None
        print(f"{len(found)} gesture{'s' if len(found) != 1 else ''} chosen from the words "
              f"({', '.join(sorted({s.gesture for s in found})) or 'none'})", file=sys.stderr)
    try:
        take = generate(path, source=source, engine=engine, utterances=utterances, seed=seed, options=options,
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


def load_performance(path_text: str, utterance: int | None = None, *, engine: str | None = None,
                     seed: int | None = None, options=None, tracks: bool = True):
    """A :class:`core.motion.MotionFile` of a motion file or a script (generated): its
    utterances, its speakers' tracks and the script. With ``utterance`` only that one, and
    no tracks; ``tracks=False`` does not build a script's tracks."""
    path = existing_file(path_text)
    suffix = path.suffix.lower()
    if suffix in SCRIPT_SUFFIXES:
        from core.motion import MotionFile  # lazy: numpy

        take = generate_script(path, engine=engine, utterances=None if utterance is None else [utterance],
                               seed=seed, options=options)
        if not take.clips:
            raise InputError(f"{path}: no utterances (a script with only a header makes no motion)")
        return MotionFile(take.clips, take.tracks if tracks and utterance is None else [], str(path), engine=take.engine)
    if suffix not in MOTION_SUFFIXES:
        raise UsageError(f"{path}: unknown input type '{suffix or '(none)'}' (use .json, .npz or .sgt)")
    from core.motion import MotionFile, MotionFileError, load_motion_file  # lazy: numpy
    from renders.clips import pick  # lazy: numpy

    try:
        whole = load_motion_file(path)
    except MotionFileError as exc:
        raise InputError(str(exc)) from None
    if not whole.clips:
        raise InputError(f"{path}: no utterances")
    if utterance is None:
        return whole
    try:
        return MotionFile(pick(whole.clips, utterance), [], whole.source, whole.version, whole.engine)
    except IndexError as exc:
        raise UsageError(f"{path}: {exc}") from None
