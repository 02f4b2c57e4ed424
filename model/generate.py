"""Script -> motion: compile a script, then run a generation engine on every utterance.

::

    from model.generate import generate_clips
    clips = generate_clips("examples/mall_guide.sgt", engine="keyframe")
    clips[0].poses      # (T, 27) unit bone directions at 15 fps
    clips[0].positions  # (T, 10, 3) metres

Engines share one interface: ``generate(inputs: EngineInputs, *, seed) -> (T, 27)``, where
:class:`EngineInputs` carries the per-frame controls, the timed words and the speech audio.
Engines: ``neural`` (the controllable generator, default), ``keyframe`` (SGToolkit's MANUAL
condition) and ``rules`` (the procedural teacher).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Callable

from core.controls import ControlArrays
from core.motion import MotionClip
from core.words import TimedWord
from dsl.compiler import compile_file
from model.neural import _model
from model.weights import WeightsError

#: Engine name -> module with ``generate(inputs, *, seed, ...)``.
ENGINES = {
    "neural": "model.neural",  # the controllable generator (shipped weights)
    "keyframe": "model.keyframe",  # SGToolkit's MANUAL condition: splines through the pose controls
    "rules": "model.teacher",  # the rule-based teacher of the procedural corpus
}
DEFAULT_ENGINE = "neural"


@dataclass
class EngineInputs:
    """Everything an engine may use for one utterance, on the motion timeline."""

    arrays: ControlArrays  # pose and style controls, T frames
    words: list[TimedWord]  # seconds on the motion timeline, lead-in already added
    audio_path: Path | None = None  # speech audio; it starts ``lead_in`` seconds into the motion
    lead_in: float = 0.0

    @property
    def n_frames(self) -> int:
        return self.arrays.n_frames

    @classmethod
    def from_plan(cls, u) -> "EngineInputs":
        return cls(u.arrays, list(u.words), u.audio_path, u.lead_in)


class GenerateError(Exception):
    """The script has errors (``diagnostics`` holds them) or the engine cannot run."""

    def __init__(self, message: str, diagnostics=(), source: str = "") -> None:
        super().__init__(message)
        self.diagnostics = list(diagnostics)
        self.source = source


def engine_function(name: str, options=None) -> Callable:
    """The engine's ``generate`` function; ``options`` (neural only) set post-processing and weights."""
    if name not in ENGINES:
        raise GenerateError(f"unknown engine '{name}': choose one of {', '.join(ENGINES)}")
    fn = importlib.import_module(ENGINES[name]).generate
    if name == "neural":
        try:  # fail early, with the fix, when the weights are missing or unusable
            _model(getattr(options, "weights", None))
        except WeightsError as exc:
            raise GenerateError(str(exc)) from None
        return partial(fn, options=options)
    return fn


def clips_from_plan(plan, *, engine: str | None = None, seed: int | None = None, progress=None, options=None) -> list:
    """One :class:`~core.motion.MotionClip` per planned utterance."""
    fn = engine_function(engine or DEFAULT_ENGINE, options)
    clips = []
    base_seed = plan.seed if seed is None else seed
    for n, u in enumerate(plan.utterances):
        if progress:
            progress(n, len(plan.utterances), u.text[:40])
        poses = fn(EngineInputs.from_plan(u), seed=base_seed + u.index)
        clips.append(MotionClip(poses=poses, speaker=u.speaker, text=u.text, words=list(u.words),
                                controls=list(u.controls)))
    if progress:
        progress(len(plan.utterances), len(plan.utterances), "")
    return clips


def generate_clips(script_path, *, engine: str | None = None, utterances=None, seed: int | None = None,
                   progress=None, timing: str = "speech", options=None) -> list:
    """Compile ``script_path`` and generate motion; raises :class:`GenerateError` on script errors."""
    engine_function(engine or DEFAULT_ENGINE, options)  # fail fast on a bad engine or missing weights
    result = compile_file(Path(script_path), timing=timing, utterances=utterances)
    if result.plan is None:
        raise GenerateError(f"{script_path} has errors", result.diagnostics, result.script.source)
    return clips_from_plan(result.plan, engine=engine, seed=seed, progress=progress, options=options)
