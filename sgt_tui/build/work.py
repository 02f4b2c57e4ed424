"""The unit of work of a build: generate some utterances of one script, in any process.

A :class:`Task` carries the script's text as the build read it (so every worker generates
exactly what was keyed, even if the file changes meanwhile), the utterance numbers, their
cache keys and the settings. :func:`run_task` runs it through :func:`model.generate.generate`
(the one path from a script to motion) with one torch thread, and returns each utterance's
cache entry as bytes, or the diagnostics that stopped it. It never raises for a problem in
the script; anything else is a bug and is reported as ``error``.
"""

from __future__ import annotations

import os
import sys

from dataclasses import dataclass, field

from sgt_tui.build.cache import Entry
from sgt_tui.build.keys import Settings


@dataclass
class Task:
    number: int
    path: str  # the script, as named in diagnostics; @audio and @library resolve against its folder
    source: str
    keys: dict[int, str]  # utterance number -> cache key
    settings: Settings


@dataclass
class TaskResult:
    number: int
    entries: dict[int, bytes] = field(default_factory=dict)  # utterance number -> Entry.to_bytes()
    diagnostics: list[dict] = field(default_factory=list)  # Diagnostic.to_dict() of a script problem
    error: str = ""  # one line: why these utterances failed (empty: they did not)


def one_thread() -> None:
    """One thread for torch and for numpy's BLAS in this process.

    Parallelism comes from worker processes, and the thread count must be the same on every
    machine: OpenBLAS sums in another order with another thread count (measured: a build with
    ``OMP_NUM_THREADS=1``, as Ray sets it, differed in the 5th decimal from one with the
    default two threads), so without this two machines would not write the same bytes."""
    from threadpoolctl import threadpool_limits  # lazy: only workers need it

    torch = sys.modules.get("torch")  # loaded only when the weights have no fresh ONNX export
    if torch is not None and torch.get_num_threads() != 1:  # (model.neural.use_threads sets 1 then too)
        torch.set_num_threads(1)
    global _LIMITS
    if _LIMITS is None:
        _LIMITS = threadpool_limits(limits=1)


_LIMITS = None  # kept alive: the limits hold while it exists


def _die_with_parent() -> None:
    """Ask Linux to send this process SIGTERM when its parent dies (prctl PR_SET_PDEATHSIG), so
    that a killed build leaves no idle workers behind; elsewhere nothing is done."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # 1 = PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:  # the parent died before the request was made
        os._exit(1)


def warm_up(settings: Settings) -> None:
    """Everything a worker loads before its first utterance (torch, the resampler, the
    engine and its weights), so that it can load them while the build reads the scripts.
    A worker also ends when the build that started it dies (kill -9 included)."""
    _die_with_parent()
    one_thread()
    from model.generate import GenerateError, engine_function  # lazy: numpy, the engines

    try:
        engine_function(settings.engine, settings.options())
    except GenerateError:
        pass  # reported by the first task, with the script it concerns


def run_task(task: Task, weights: str | None = None, database: str | None = None) -> TaskResult:
    """Generate the task's utterances; ``weights`` and ``database`` override the settings' weights
    and matching database paths (a Ray worker's local copies of the same files)."""
    from pathlib import Path

    from model.generate import GenerateError, generate  # lazy: numpy, the engines

    one_thread()
    settings = task.settings
    options = settings.options()
    if weights is not None or database is not None:
        import dataclasses

        options = dataclasses.replace(options, weights=weights or options.weights, database=database or options.database)
    try:
        take = generate(Path(task.path), source=task.source, engine=settings.engine, utterances=sorted(task.keys),
                        seed=settings.seed, options=options, perform=False)
    except GenerateError as exc:
        return TaskResult(task.number, diagnostics=[d.to_dict() for d in exc.diagnostics], error=str(exc))
    entries = {}
    for u, clip in zip(take.plan.utterances, take.clips):
        entries[u.index] = Entry.from_clip(clip, u.line).to_bytes(task.keys[u.index])
    missing = sorted(set(task.keys) - set(entries))
    if missing:  # compile_file skips an utterance whose speech failed and reports it
        errors = [d.to_dict() for d in take.diagnostics if d.is_error]
        return TaskResult(task.number, entries, errors, f"no motion for utterance {missing[0]}")
    return TaskResult(task.number, entries)
