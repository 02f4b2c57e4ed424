"""Compile a script: parse -> timing -> controls -> :class:`~dsl.plan.Plan`.

::

    from dsl import compile_file, compile_text
    result = compile_file("examples/mall_guide.sgt")
    if result.ok:
        arrays = result.plan.utterances[0].arrays   # pose (T,27), pose_mask (T,), style (T,3), style_mask (T,3)
    result = compile_text("guide: Hello [pose:wave] there.")   # a script given as text, no file

Every problem is a :class:`~core.diagnostics.Diagnostic` in ``result.diagnostics``; nothing a
user writes raises.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from core.diagnostics import ERROR, WARNING, Diagnostic, did_you_mean, sort_key
from core.skeleton import FPS, frame_count, seconds_to_frame
from dsl.parser import analyse, read_source
from dsl.plan import ArrayRequests, Control, Plan, UtterancePlan
from dsl.script import Script, Utterance
from dsl.speech import SpeechError, list_voices
from dsl.timing import Timing, estimate_timing, speech_timing
from library import load_library

Progress = Callable[[int, int, str], None]


@dataclass
class CompileResult:
    script: Script
    plan: Plan | None
    diagnostics: list[Diagnostic] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)


def _library_problems(library, file: str) -> list[Diagnostic]:
    out = []
    for p in getattr(library, "problems", []):
        line = getattr(p, "line", None) or 0
        out.append(
            Diagnostic(WARNING, f"gesture spec skipped: {p.field}: {p.message}", str(p.path), line, 1 if line else 0, 1,
                       "fix the file; the other gestures still load", "bad-spec")
        )
    return out


def load_script(path: Path | str, *, library=None, source: str | None = None):
    """Read and statically analyse a script file; returns (script, library, diagnostics)."""
    path = Path(path)
    diags: list[Diagnostic] = []
    if source is None:
        try:
            source, diags = read_source(path)
        except OSError as exc:
            d = Diagnostic(ERROR, f"cannot read the script: {exc.strerror or exc}", str(path), 0, 0, 1, None, "io")
            return Script(str(path), "", None, [], [d]), None, [d]  # type: ignore[arg-type]
    holder = {}

    def names(header):
        lib = library if library is not None else load_library(extra_dirs=header.library_dirs)
        holder["lib"] = lib
        return lib.names()

    script = analyse(source, str(path), gesture_names=names, base_dir=path.parent)
    lib = holder.get("lib")
    if lib is None:  # no utterance: still load the library so its problems are reported
        lib = library if library is not None else load_library(extra_dirs=script.header.library_dirs)
    diags = diags + script.diagnostics + _library_problems(lib, str(path))
    return script, lib, diags


def compile_file(
    path: Path | str,
    *,
    timing: str = "speech",
    library=None,
    cache_dir: Path | None = None,
    progress: Progress | None = None,
    source: str | None = None,
    utterances: list[int] | None = None,
) -> CompileResult:
    """Compile a script file. ``timing`` is "speech" (real word times) or "estimate" (fast).

    With ``source`` the text is compiled instead of the file's contents (the file need not
    exist: see :func:`compile_text`); ``utterances`` (0-based numbers) compiles only those.

    With "estimate", timing-dependent problems (overlapping pose controls) are warnings, since
    real speech may differ; with "speech" they are errors.
    """
    script, lib, diags = load_script(path, library=library, source=source)
    if script.header is None or any(d.is_error for d in diags):
        return CompileResult(script, None, sorted(diags, key=sort_key))
    plans: list[UtterancePlan] = []
    selected = [u for u in script.utterances if utterances is None or u.index in utterances]
    for n, utt in enumerate(selected):
        if progress:
            progress(n, len(selected), utt.display[:40])
        t = _timing(script, utt, timing, cache_dir, diags)
        if t is None:
            continue
        plans.append(_utterance_plan(script, utt, t, lib, timing == "estimate", diags))
    if progress:
        progress(len(selected), len(selected), "")
    diags = sorted(diags, key=sort_key)
    plan = Plan(source=str(path), fps=FPS, seed=script.header.seed, utterances=plans)
    return CompileResult(script, plan if not any(d.is_error for d in diags) else None, diags)


def compile_text(text: str, path: Path | str = "<text>", **options) -> CompileResult:
    """Compile a script given as text; no file is read or written.

    ``path`` names the script in diagnostics and in the plan; relative ``@audio`` and
    ``@library`` paths resolve against its folder (the current folder for the default).
    ``options`` are :func:`compile_file`'s (``timing``, ``utterances``, ``library``, ...).
    """
    return compile_file(path, source=text, **options)


def _timing(script: Script, utt: Utterance, mode: str, cache_dir, diags: list[Diagnostic]) -> Timing | None:
    if mode == "estimate":
        return estimate_timing(utt)
    try:
        t = speech_timing(utt, cache_dir)
    except SpeechError as exc:
        diags.append(_speech_diagnostic(script, utt, exc))
        return None
    if len(t.words) != len(utt.words):  # a broken engine must not shift every control silently
        diags.append(Diagnostic(ERROR, f"speech timing returned {len(t.words)} words for {len(utt.words)}", script.path, utt.line, 1, 1, None, "timing"))
        return None
    return t


def _speech_diagnostic(script: Script, utt: Utterance, exc) -> Diagnostic:
    message = getattr(exc, "message", None) or str(exc)
    line, col, length, hint, sugg = utt.line, 1, 1, None, ()
    idx = getattr(exc, "word_index", None)
    if idx is not None and 0 <= idx < len(utt.words):
        w = utt.words[idx].where
        line, col, length = w.line, w.col, w.length
    elif utt.audio is not None:
        line, col, length = utt.audio.where.line, utt.audio.where.col, utt.audio.where.length
    elif "voice" in message.lower():
        where = script.header.voice_where.get(utt.speaker or "") or script.header.voice_where.get("")
        if where is not None:
            line, col, length = where.line, where.col, where.length
        try:
            hint, sugg = did_you_mean(utt.voice.name, list_voices())
        except Exception:  # the engine itself is missing: the message already says so
            pass
    return Diagnostic(ERROR, message, script.path, line, col, length, hint, "speech", tuple(sugg))


def _place_poses(utt: Utterance, t: Timing, lib) -> list[tuple[object, object, int, int]]:
    """(mark, gesture, start frame, frames) per pose control: its stroke lands on its anchor frame.

    The clip itself is built only when the control arrays are (``sgt check`` never needs them)."""
    out = []
    for mark in utt.poses:
        gesture = lib.get(mark.name)
        if gesture is None:  # already reported by the analyser
            continue
        at = t.words[mark.word_index].start if mark.word_index is not None else t.words[mark.after_word].end
        start = seconds_to_frame(at) - (gesture.stroke_frame(mark.speed) or 0)
        out.append((mark, gesture, start, gesture.clip_length(speed=mark.speed, hold=mark.hold)))
    return out


def _utterance_plan(script: Script, utt: Utterance, t: Timing, lib, estimated: bool, diags: list[Diagnostic]) -> UtterancePlan:
    # People start preparing a gesture before they speak and finish it after: the motion gets
    # a lead-in before the speech (whole frames, so onsets keep their frame phase) and a tail
    # after it, so that no gesture loses its preparation or its retraction.
    poses = _place_poses(utt, t, lib)
    lead_frames = max([0] + [-start for _, _, start, _ in poses])
    lead = lead_frames / FPS
    if lead_frames:
        t = t.shifted(lead)
        poses = [(m, g, start + lead_frames, n) for m, g, start, n in poses]
    n_frames = max([frame_count(t.duration)] + [start + n for _, _, start, n in poses])
    tail = max(0.0, n_frames / FPS - t.duration)
    requests = ArrayRequests(n_frames)
    controls: list[Control] = []

    # Style spans in opening order: an inner span opens later, so it wins where they overlap.
    for span in utt.styles:
        if span.first_word is None:
            continue
        a = seconds_to_frame(t.words[span.first_word].start)
        b = max(a + 1, min(n_frames, int(math.ceil(t.words[span.last_word].end * FPS - 1e-6))))
        requests.styles.append((a, b, span.values))
        controls.append(Control("style", span.name, a, b, span.where.line, span.where.col, dict(sorted(span.values.items()))))

    for p in utt.pauses:
        end = t.words[p.word_index].start if p.word_index < len(t.words) else t.duration
        a = seconds_to_frame(max(0.0, end - p.seconds))
        b = max(a + 1, min(n_frames, seconds_to_frame(end)))
        controls.append(Control("pause", "pause", a, b, p.where.line, p.where.col, {"seconds": p.seconds}))

    placed: list[tuple[int, int, object]] = []
    for mark, gesture, start, length in poses:
        lo, hi = start, start + length
        w = mark.where
        for plo, phi, other in placed:
            if lo < phi and plo < hi:
                how = " (with estimated timing; real speech may differ)" if estimated else ""
                diags.append(Diagnostic(
                    WARNING if estimated else ERROR,
                    f"pose control '{mark.name}' overlaps '{other.name}' (line {other.where.line}, col {other.where.col}) in frames {max(lo, plo)}-{min(hi, phi)}{how}",
                    script.path, w.line, w.col, w.length,
                    "use x2 or x3 for a shorter gesture, anchor it to a later word, or add a [pause] between them",
                    "overlap",
                ))
                break
        else:
            requests.poses.append((start, gesture, mark))
        placed.append((lo, hi, mark))
        controls.append(Control("pose", mark.name, lo, hi, w.line, w.col, mark.options))

    controls.sort(key=lambda c: (c.start_frame, c.kind, c.line, c.col))
    speech = {"engine": t.source, "lead_in": round(lead, 6), "tail": round(tail, 6)}
    if utt.audio is not None:
        speech["audio"] = _rel(utt.audio.path, script.path)
        if utt.audio.timings is not None:
            speech["timings"] = _rel(utt.audio.timings, script.path)
    elif t.source != "estimate":
        speech.update(voice=utt.voice.name, rate=utt.voice.rate, pitch=utt.voice.pitch)
    return UtterancePlan(
        index=utt.index, speaker=utt.speaker, line=utt.line, text=utt.display, duration=n_frames / FPS,
        n_frames=n_frames, words=t.words, controls=controls, requests=requests, speech=speech, audio_path=t.audio_path,
        lead_in=lead,
    )


def _rel(path: Path, script_path: str) -> str:
    try:
        return str(Path(path).resolve().relative_to(Path(script_path).resolve().parent))
    except ValueError:
        return str(path)
