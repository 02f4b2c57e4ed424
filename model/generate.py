"""Script -> motion: compile a script, then run a generation engine on every utterance.

::

    from model.generate import generate, generate_clips
    clips = generate_clips("examples/mall_guide.sgt", engine="keyframe")
    clips[0].poses      # (T, 27) unit bone directions at 15 fps
    clips[0].positions  # (T, 10, 3) metres
    clips[0].hands      # core.hands.HandTrack: hand shapes and palms (model/hands.py's rules)
    clips = generate_clips(source="guide: Hello [pose:wave] there.")   # from text, no file
    take = generate(compile_text(text).plan)                           # from a compiled plan

:func:`generate` is the one path from a script (a file, its text, or a compiled plan) to
motion: the ``sgt`` commands and the editor's worker all call it.

Engines share one interface: ``generate(inputs: EngineInputs, *, seed) -> (T, 27)``, where
:class:`EngineInputs` carries the per-frame controls, the timed words and the speech audio.
Engines: ``neural`` (the controllable generator, default), ``matching`` (motion matching over a
database of the training takes, :mod:`model.matching`), ``flow`` (a flow-matching network that
samples takes, :mod:`model.flow`), ``keyframe`` (SGToolkit's MANUAL condition) and ``rules``
(the procedural teacher).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from core import cancel, limits
from core.controls import ControlArrays
from core.counting import no_utterance, plural
from core.fileio import OutputError
from core.motion import MotionClip, Track, save_motion
from core.reading import LIMITS
from core.seeds import SEED_MAX
from core.words import TimedWord
from dsl.compiler import compile_file
from dsl.plan import Plan
from model.engines import DEFAULT_ENGINE, ENGINES, NETWORK_ENGINES
from model.hands import motion_hands
from model.performance import Exact, perform
from model.runtime import load_runner
from model.take_posture import speaker_key
from model.weights import WeightsError


@dataclass
class EngineInputs:
    """Everything an engine may use for one utterance, on the motion timeline."""

    arrays: ControlArrays  # pose and style controls, T frames
    words: list[TimedWord]  # seconds on the motion timeline, lead-in already added
    audio_path: Path | None = None  # speech audio; it starts ``lead_in`` seconds into the motion
    lead_in: float = 0.0
    #: the take's draw key (:func:`model.take_posture.speaker_key`): one posture per speaker of a
    #: performance; None: the engine's seed draws it.
    take_key: tuple | None = None

    @property
    def n_frames(self) -> int:
        return self.arrays.n_frames

    @classmethod
    def from_plan(cls, u, base_seed: int | None = None) -> EngineInputs:
        key = None if base_seed is None else speaker_key(base_seed, u.speaker)
        return cls(u.arrays, list(u.words), u.audio_path, u.lead_in, key)


class GenerateError(Exception):
    """The script has errors (``diagnostics`` holds them, ``source`` the text) or the engine
    cannot run. ``str()`` is one line: what is wrong, and where for a script error."""

    def __init__(self, message: str, diagnostics=(), source: str = "") -> None:
        super().__init__(message)
        self.diagnostics = list(diagnostics)
        self.source = source


class NoSuchUtterance(GenerateError):
    """An utterance the script (or plan) does not have. ``str()`` counts from 0, as the API's
    ``utterances`` do; :meth:`for_people` from 1, as the command line does (:mod:`core.counting`)."""

    def __init__(self, missing: int, known, what: str = "the script") -> None:
        self.missing, self.known, self.what = missing, sorted(known), what
        super().__init__(no_utterance(missing, self.known, first=0, what=what))

    def for_people(self) -> str:
        return no_utterance(self.missing, self.known, what=self.what)


@dataclass
class Take:
    """What :func:`generate` made: the compiled plan, one clip per planned utterance, the
    speakers' tracks, the compiler's warnings and the script's text (for showing them).

    The tracks are the performance (:func:`model.performance.perform`) and each clip the
    frames of its utterance on its speaker's track. A take made with ``perform=False`` holds
    the engine's clips, each on its own (what ``sgt build`` caches); asking for its tracks
    performs it then, and its clips become the tracks' views."""

    plan: Plan
    clips: list[MotionClip]
    diagnostics: list = field(default_factory=list)
    source: str = ""
    seed: int = 0
    _tracks: list | None = field(default=None, repr=False)
    exact: Exact | None = field(default=None, repr=False)  # how the performance makes the pose controls exact
    engine: str | None = None  # the engine that made it (recorded in the motion file)

    @property
    def tracks(self) -> list[Track]:
        """One continuous track per speaker over the whole performance."""
        if self._tracks is None:
            self.clips, self._tracks = perform(self.plan, self.clips, self.seed, exact=self.exact)
        return self._tracks

    def save(self, path, format: str | None = None) -> None:
        """Write the take as a motion file (utterances, tracks, the script's path); raises
        :class:`core.fileio.OutputError` when it would be larger than a motion file may be
        (:func:`check_motion_size`)."""
        source = self.plan.source if self.plan.source and not self.plan.source.startswith("<") else None
        check_motion_size(self.clips, self.tracks)
        save_motion(path, self.clips, format, tracks=self.tracks, source=source, engine=self.engine)

    @property
    def utterances(self) -> list[int]:
        """The script's utterance numbers (0-based) of the clips, in order."""
        return [u.index for u in self.plan.utterances]

    @property
    def timing(self) -> str | None:
        """Where the word times came from (``espeak-ng``, ``textgrid``, ``estimate``, ...)."""
        return self.plan.utterances[0].speech.get("engine") if self.plan.utterances else None


def check_motion_size(clips, tracks) -> None:
    """Raise :class:`core.fileio.OutputError` when a motion file of ``clips`` and ``tracks`` could
    be larger than sgt reads one (:data:`core.reading.LIMITS`), before it is encoded."""
    frames = sum(c.n_frames for c in clips) + sum(t.n_frames for t in tracks)
    if not limits.motion_file_fits(frames):
        most = LIMITS["motion file"] // limits.MAX_FRAME_BYTES
        raise OutputError(f"the motion is {frames} frames over its utterances and speakers' tracks, more than a motion "
                          f"file holds (at most {most} frames, {LIMITS['motion file'] >> 20} MiB): generate fewer "
                          f"utterances at a time (--utterance) or split the script")


def engine_function(name: str, options=None) -> Callable:
    """The engine's ``generate`` function; ``options`` (a :class:`model.neural.Options`; neural and
    matching) set post-processing, weights and the take's posture."""
    if name not in ENGINES:
        raise GenerateError(f"unknown engine '{name}': choose one of {', '.join(ENGINES)}")
    fn = importlib.import_module(ENGINES[name]).generate
    if name in NETWORK_ENGINES:
        try:  # fail early, with the fix, when the weights are missing, unusable or of the other network
            load_runner(getattr(options, "weights", None), name)
        except WeightsError as exc:
            raise GenerateError(str(exc)) from None
        return partial(fn, options=options)
    if name == "matching":
        from model import matching  # lazy: only this engine reads the database

        opts = matching.options_from(options)
        try:  # fail early, with the fix, when the database is missing or unusable
            matching.load(opts.database)
        except matching.DatabaseError as exc:
            raise GenerateError(str(exc)) from None
        return partial(fn, options=opts)
    return fn


def clips_from_plan(plan: Plan, *, engine: str | None = None, seed: int | None = None, progress=None,
                    options=None) -> list[MotionClip]:
    """One :class:`~core.motion.MotionClip` per planned utterance, each generated from its own
    inputs alone (its words, speech and controls; the seed ``seed + index``): nothing of the
    lines around it, so ``sgt build`` caches exactly what ``sgt generate`` makes. The
    performance (:func:`model.performance.perform`) then eases each speaker's track into and
    out of its utterances."""
    fn = engine_function(engine or DEFAULT_ENGINE, options)
    base_seed = plan.seed if seed is None else seed
    _check_seed(base_seed)
    clips = []
    for n, u in enumerate(plan.utterances):
        cancel.check()
        if progress:
            progress(n, len(plan.utterances), u.text[:40])
        layers: list = []  # an engine's own gesture hands (the rules engine's), then the pose controls'
        extra = {"hands_out": layers} if "hands_out" in inspect.signature(fn).parameters else {}
        poses = fn(EngineInputs.from_plan(u, base_seed), seed=base_seed + u.index, **extra)
        hands = motion_hands(poses, [*layers, u.hands])
        clips.append(MotionClip(poses=poses, speaker=u.speaker, text=u.text, words=list(u.words),
                                controls=list(u.controls), hands=hands, index=u.index, start=u.start,
                                audio_offset=u.audio_offset))
    if progress:
        progress(len(plan.utterances), len(plan.utterances), "")
    return clips


def exact_for(engine: str, options=None) -> Exact:
    """How the performance makes an engine's pose controls exact (its own blend's settings;
    none for the neural engine with ``blend=False``, ``--no-blend``)."""
    if engine == "rules":
        from model.teacher import CONTROL_RAMP, CONTROL_RAMP_STEP_DEG  # lazy: the teacher loads the library

        return Exact(ramp=CONTROL_RAMP, max_step_deg=CONTROL_RAMP_STEP_DEG)
    if engine in (*NETWORK_ENGINES, "matching") and options is not None:
        return Exact(ramp=options.ramp, blend=options.blend)
    return Exact()


def generate(script: Path | str | Plan | None = None, *, source: str | None = None, engine: str | None = None,
             utterances=None, seed: int | None = None, timing: str = "speech", options=None, progress=None,
             speech_progress=None, library=None, perform: bool = True) -> Take:
    """Compile a script and generate its motion: the one way from a script to motion.

    ``script`` is a script file's path, or a compiled :class:`~dsl.plan.Plan` (generated as it
    is). ``source`` is the script's text: alone, it is compiled as the script ``<text>`` in the
    current folder; with a path, it replaces that file's contents (the file need not exist,
    and relative ``@audio``/``@library`` paths resolve against its folder). No file is
    written. ``utterances`` picks utterance numbers (0-based; all by default), ``seed``
    overrides the script's ``@seed``, ``timing`` is "speech" or "estimate".
    ``speech_progress`` and ``progress`` are called ``(done, total, what)`` while compiling and
    while generating. ``library`` is a loaded :class:`~library.Library` to compile with (default:
    the built-in and user gestures plus the script's ``@library`` folders, loaded per call).
    ``perform``: the tracks and the clips as their
    views (:func:`model.performance.perform`); False keeps the engine's clips (see :class:`Take`).

    Raises :class:`GenerateError` (script errors, with their diagnostics; an unknown engine;
    missing weights) or :class:`NoSuchUtterance`.
    """
    engine = engine or DEFAULT_ENGINE
    engine_function(engine, options)  # fail fast on a bad engine or missing weights
    if seed is not None:
        _check_seed(seed)
    diagnostics: list = []
    text = ""
    if isinstance(script, Plan):
        if source is not None:
            raise TypeError("generate() takes a plan or a source text, not both")
        plan = script
        if utterances is not None:
            known = {u.index for u in plan.utterances}
            missing = [n for n in utterances if n not in known]
            if missing:
                raise NoSuchUtterance(missing[0], known, "the plan")
            plan = dataclasses.replace(plan, utterances=[dataclasses.replace(u) for u in plan.utterances if u.index in utterances])
    else:
        if script is None and source is None:
            raise TypeError("generate() needs a script path, a plan or a source text")
        path = Path(script) if script is not None else Path("<text>")
        result = compile_file(path, timing=timing, source=source, utterances=utterances, progress=speech_progress,
                              library=library)
        missing = result.script.missing_utterance(utterances) if result.script.header is not None else None
        if result.plan is None:
            raise GenerateError(_errors_message(path, result.diagnostics), result.diagnostics, result.script.source)
        if missing is not None:
            raise NoSuchUtterance(missing, [u.index for u in result.script.utterances])
        plan, diagnostics, text = result.plan, result.diagnostics, result.script.source
    base_seed = plan.seed if seed is None else seed
    # once, for the seed poses and the tracks (the other engines' tracks compute it when asked)
    clips = clips_from_plan(plan, engine=engine, seed=seed, progress=progress, options=options)
    take = Take(plan, clips, diagnostics, text, base_seed, exact=exact_for(engine, options), engine=engine)
    if perform:
        take.tracks  # noqa: B018  (performs the take: its clips become the tracks' views)
    return take


def generate_clips(script: Path | str | Plan | None = None, **options) -> list[MotionClip]:
    """:func:`generate`'s clips, one :class:`~core.motion.MotionClip` per utterance."""
    return generate(script, **options).clips


def _check_seed(seed: int) -> None:
    if not 0 <= seed <= SEED_MAX:
        raise GenerateError(f"seed {seed} is out of range: use 0 to {SEED_MAX}")


def _errors_message(path: Path, diagnostics) -> str:
    errors = [d for d in diagnostics if d.is_error]
    first = f" (line {errors[0].line}: {errors[0].message})" if errors else ""
    return f"{path.name} has {plural(len(errors), 'error')}{first}"
