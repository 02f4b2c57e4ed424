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

from core import cancel, rules
from core.diagnostics import Diagnostic, Related, sort_key
from core.reading import InputFileError
from core.skeleton import FPS, frame_count, seconds_to_frame
from dsl import realize
from dsl.limits import declared_timing, too_long
from dsl.parser import analyse, read_source
from dsl.plan import ArrayRequests, Control, Plan, UtterancePlan
from dsl.resources import check_resources, speech_diagnostic
from dsl.script import Script, Utterance
from dsl.speech import SpeechError
from dsl.timing import Timing, estimate_timing, speech_timing
from library import LibraryProblem, load_library

Progress = Callable[[int, int, str], None]


@dataclass
class CompileResult:
    script: Script
    plan: Plan | None
    diagnostics: list[Diagnostic] = field(default_factory=list)
    #: Each compiled utterance planned on its declared timing (:mod:`dsl.limits`): the
    #: performance the limits are checked on (the editor, which compiles a script in pieces,
    #: lays the pieces' out together); empty when the analysis found errors.
    declared: list[UtterancePlan] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)


def library_diagnostic(p: LibraryProblem) -> Diagnostic:
    """The warning for one problem met while loading the motion library, at its TOML line and
    column, with fixes for a misspelt key."""
    where = f"{p.field}: " if p.field and p.field not in ("toml", "file") else ""
    fixes = rules.replacements(str(p.path), p.line, p.col, p.length, p.suggestions) if p.line else ()
    kw = {"hint": "did you mean " + " or ".join(f"'{s}'" for s in p.suggestions) + "?", "fixes": fixes} if fixes else {}
    if p.kind == "folder":
        return rules.LIBRARY_FOLDER.at(str(p.path), 0, 0, folder=str(p.path), source=p.source or "the configuration", problem=p.message)
    if p.kind == "config":
        return rules.BAD_CONFIG.at(str(p.path), p.line, p.col, p.length, config=p.path.name, where=where, message=p.message, **kw)
    return rules.BAD_SPEC.at(str(p.path), p.line, p.col, p.length, spec=p.path.name, where=where, message=p.message, **kw)


def _skipped_specs(library):
    """``name -> Related`` for gesture specs that were skipped because they are malformed."""
    def skipped(name: str):
        for p in getattr(library, "problems", ()):
            if p.kind == "spec" and p.path.stem == name:
                return Related(f"{p.path.name} was skipped because it is malformed: {p.message}",
                               str(p.path), p.line, p.col, p.length)
        return None
    return skipped


def load_script(path: Path | str, *, library=None, source: str | None = None, resources: bool = True):
    """Read and analyse a script file: the text (:func:`dsl.parser.analyse`), the motion
    library's problems, and the voices and recordings it uses (:mod:`dsl.resources`).

    This is the one analysis ``sgt check``, ``compile``, ``say``, ``generate`` and the editor
    share. Returns (script, library, diagnostics); an unreadable file is a diagnostic.
    ``resources=False`` leaves the voices and recordings unchecked (``sgt align`` times the
    recordings itself)."""
    path = Path(path)
    diags: list[Diagnostic] = []
    if source is None:
        try:
            source, diags = read_source(path)
        except OSError as exc:
            if isinstance(exc, InputFileError):
                reason = exc.reason
            elif isinstance(exc, IsADirectoryError):
                reason = "it is a folder"
            else:
                reason = (exc.strerror or str(exc)).lower()
            d = rules.IO.at(str(path), 0, 0, reason=reason)
            return Script(str(path), "", None, [], [d]), None, [d]  # type: ignore[arg-type]
    holder = {}

    def get_library(header):
        if "lib" not in holder:
            holder["lib"] = library if library is not None else load_library(extra_dirs=header.library_dirs)
        return holder["lib"]

    def skipped(name):
        return _skipped_specs(holder.get("lib"))(name)

    script = analyse(source, str(path), gesture_names=lambda header: get_library(header).names(),
                     base_dir=path.parent, skipped_gesture=skipped)
    lib = get_library(script.header)  # also with no utterance: its problems are reported
    diags = diags + script.diagnostics + [library_diagnostic(p) for p in lib.problems]
    if resources:
        diags += check_resources(script)
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

    The verdict (errors or not) does not depend on ``timing``: overlapping pose controls are
    warnings resolved the same way under both (:func:`dsl.realize.resolve`); only a failing speech
    engine or aligner is found by "speech" alone.
    """
    script, lib, diags = load_script(path, library=library, source=source)
    if script.header is None or any(d.is_error for d in diags):
        return CompileResult(script, None, sorted(diags, key=sort_key))
    plans: list[UtterancePlan] = []
    selected = [u for u in script.utterances if utterances is None or u.index in utterances]
    # The performance as the script declares it, held to the limits before any speech is made
    # (dsl/limits.py); with estimated timing these are the plans, but for recordings.
    declared: list[tuple[UtterancePlan, list[Diagnostic]]] = []
    for utt in selected:
        cancel.check()
        own: list[Diagnostic] = []
        declared.append((_utterance_plan(script, utt, declared_timing(utt), lib, True, own), own))
    declared_plans = [p for p, _ in declared]
    over = too_long(script, Plan(source=str(path), fps=FPS, seed=script.header.seed, utterances=declared_plans))
    if over is not None:
        return CompileResult(script, None, sorted(diags + [over], key=sort_key), declared_plans)
    for n, (utt, (plan, own)) in enumerate(zip(selected, declared)):
        cancel.check()
        if progress:
            progress(n, len(selected), utt.display[:40])
        if timing == "estimate" and utt.audio is None:  # planned on the estimate already
            plans.append(plan)
            diags += own
            continue
        t = _timing(script, utt, timing, cache_dir, diags)
        if t is None:
            continue
        plans.append(_utterance_plan(script, utt, t, lib, timing == "estimate", diags))
    if progress:
        progress(len(selected), len(selected), "")
    plan = Plan(source=str(path), fps=FPS, seed=script.header.seed, utterances=plans)
    if utterances is None and plan.moved:  # the whole performance: interruptions not started as asked
        by_index = {u.index: u for u in script.utterances}
        diags += interruption_diagnostics(script.path, plan, [(by_index[u.index], 0) for u in plan.utterances],
                                          script.source.replace("\r\n", "\n").replace("\r", "\n").split("\n"),
                                          timing == "estimate")
    diags = sorted(diags, key=sort_key)
    return CompileResult(script, plan if not any(d.is_error for d in diags) else None, diags, declared_plans)


def compile_text(text: str, path: Path | str = "<text>", **options) -> CompileResult:
    """Compile a script given as text; no file is read or written.

    ``path`` names the script in diagnostics and in the plan; relative ``@audio`` and
    ``@library`` paths resolve against its folder (the current folder for the default).
    ``options`` are :func:`compile_file`'s (``timing``, ``utterances``, ``library``, ...).
    """
    return compile_file(path, source=text, **options)


#: The codes :func:`interruption_diagnostics` reports (they depend on the whole performance).
INTERRUPTION_CODES = frozenset({rules.SELF_INTERRUPTION.code, rules.INTERRUPTION_TOO_LONG.code})


def interruption_diagnostics(file: str, plan: Plan, utterances, source_lines: list[str], estimated: bool) -> list[Diagnostic]:
    """Warnings for the interruptions (negative ``@gap``) that ``plan``'s clock started later
    than asked (:attr:`dsl.plan.Plan.moved`), at their ``@gap``. ``utterances``: for each of
    the plan's utterances, its :class:`~dsl.script.Utterance` and the lines to add to its
    places (the editor analyses a script in pieces; 0 otherwise); ``source_lines``: the text."""
    out: list[Diagnostic] = []
    how = " (with estimated timing; real speech may differ)" if estimated else ""
    for m in plan.moved:
        utt, shift = utterances[m.index]
        g = utt.gap_where
        if g is None:
            continue
        line = g.line + shift
        text = source_lines[line - 1][g.col - 1 : g.col - 1 + g.length] if line <= len(source_lines) else f"{utt.gap:g}s"
        late = f"{m.late:.2f}"
        other, oshift = utterances[m.other]
        ow = other.words[0].where if other.words else None
        oplace = (ow.line + oshift, ow.col, ow.length) if ow else (other.line + oshift, 1, 1)
        if m.why == "self":
            who, over = ((f"'{utt.speaker}'", "its own previous line") if utt.speaker is not None else
                         ("this line", "the previous line without a speaker (lines without one are one speaker)"))
            fixes = (rules.delete(line, 1, g.col + g.length - 1, "remove the '@gap'"),) if m.other == m.index - 1 else ()
            out.append(rules.SELF_INTERRUPTION.at(
                file, line, g.col, g.length, gap=text, who=who, over=over, late=late, how=how, fixes=fixes,
                related=(Related("that line: a speaker's own lines never overlap", file, *oplace),)))
            continue
        if m.why == "start":
            limit, reach = "the start of the previous line's speech", math.floor(m.reach * 1000 + 1e-6)
            fixes = (rules.replacements(file, line, g.col, g.length, [f"-{reach}ms"],
                                        "start with the previous line: '@gap {}'") if reach > 0 else ())
            related = (Related("the previous line, interrupted from its start", file, *oplace),)
        else:
            limit, fixes, related = "the performance's first frame (this line's gestures start before its speech)", (), ()
        out.append(rules.INTERRUPTION_TOO_LONG.at(file, line, g.col, g.length, gap=text, limit=limit, late=late,
                                                  how=how, fixes=fixes, related=related))
    return out


def _timing(script: Script, utt: Utterance, mode: str, cache_dir, diags: list[Diagnostic]) -> Timing | None:
    if mode == "estimate":
        return estimate_timing(utt)
    try:
        t = speech_timing(utt, cache_dir)
    except SpeechError as exc:
        diags.append(speech_diagnostic(script, utt, exc))
        return None
    if len(t.words) != len(utt.words):  # a broken engine must not shift every control silently
        diags.append(rules.TIMING.at(script.path, utt.line, 1, 1, got=len(t.words), expected=len(utt.words)))
        return None
    return t


def _utterance_plan(script: Script, utt: Utterance, t: Timing, lib, estimated: bool, diags: list[Diagnostic]) -> UtterancePlan:
    # People start preparing a gesture before they speak and finish it after: the motion gets
    # a lead-in before the speech (whole frames, so onsets keep their frame phase) and a tail
    # after it, so that no gesture loses its preparation or its retraction.
    poses = realize.place(utt, t.words, lib)
    lead_frames = max([0] + [-p.start for p in poses])
    lead = lead_frames / FPS
    if lead_frames:
        t = t.shifted(lead)
        for p in poses:
            p.start += lead_frames
            p.word_frame += lead_frames
    realize.resolve(poses)
    n_frames = max([frame_count(t.duration)] + [p.end for p in poses])
    requests = ArrayRequests(n_frames)
    controls: list[Control] = []

    # Style spans in opening order: an inner span opens later, so it wins where they overlap.
    # A span's facial expression (its own) is a face control on the same frames.
    for span in utt.styles:
        if span.first_word is None:
            continue
        a = seconds_to_frame(t.words[span.first_word].start)
        b = max(a + 1, min(n_frames, int(math.ceil(t.words[span.last_word].end * FPS - 1e-6))))
        if span.styled:
            requests.styles.append((a, b, span.values))
            controls.append(Control("style", span.name, a, b, span.where.line, span.where.col,
                                    dict(sorted(span.values.items()))))
        if span.face is not None:
            controls.append(Control("face", span.face, a, b, span.where.line, span.where.col, {}))

    for look in utt.looks:
        a, b = _look_frames(utt, t, look, n_frames)
        controls.append(Control("look", look.target, a, b, look.where.line, look.where.col,
                                {"hold": look.hold} if look.hold else {}))

    for p in utt.pauses:
        end = t.words[p.word_index].start if p.word_index < len(t.words) else t.duration
        a = seconds_to_frame(max(0.0, end - p.seconds))
        b = max(a + 1, min(n_frames, seconds_to_frame(end)))
        controls.append(Control("pause", "pause", a, b, p.where.line, p.where.col, {"seconds": p.seconds}))

    for p in poses:
        w = p.mark.where
        if p.late >= realize.LATE_WARN:
            o = p.after.mark.where
            diags.append(rules.OVERLAP.at(
                script.path, w.line, w.col, w.length, name=p.mark.name, other=p.after.mark.name, late=p.late,
                secs=f"{p.late / FPS:.2f}", word=_word_text(utt, t, p.mark),
                why=p.why,
                how=" (with estimated timing; real speech may differ)" if estimated else "",
                hint=realize.hint(p, t.words) or None,
                related=(Related(f"'{p.after.mark.name}' is here", script.path, o.line, o.col, o.length),),
            ))
        stroke = {} if p.stroke is None else {"stroke_frame": p.stroke_frame, "word_frame": p.word_frame}
        controls.append(Control("pose", p.mark.name, p.first, p.end, w.line, w.col, p.mark.options, **stroke))
    requests.poses.extend(sorted(poses, key=lambda p: p.start))
    tail = max(0.0, n_frames / FPS - t.duration)

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
        lead_in=lead, gap=script.header.gap if utt.gap is None else utt.gap, phonemes=list(t.phonemes),
    )


#: What ends a look mark's clause in the text between two words.
_CLAUSE_END = ",.;:!?"


def _look_frames(utt: Utterance, t: Timing, look, n_frames: int) -> tuple[int, int]:
    """Frames [a, b) of a look mark: from its word's onset (the end of the last word when no
    word follows) for ``hold`` seconds, or to the end of the last word of its clause (before
    the next clause mark or pause, else the utterance's last word)."""
    words = t.words
    if look.word_index is not None:
        first = look.word_index
        a = seconds_to_frame(words[first].start)
    else:
        first = look.after_word
        a = min(n_frames - 1, seconds_to_frame(words[first].end))
    if look.hold:
        return a, min(n_frames, a + max(1, int(round(look.hold * FPS))))
    paused = {p.word_index for p in utt.pauses}
    last = first
    while last + 1 < len(words):
        between = utt.text[utt.words[last].end : utt.words[last + 1].start]
        if last + 1 in paused or any(c in _CLAUSE_END for c in between):
            break
        last += 1
    b = int(math.ceil(words[last].end * FPS - 1e-6))
    return a, max(a + 1, min(n_frames, b))


def _word_text(utt: Utterance, t: Timing, mark) -> str:
    """The word a pose mark puts its stroke on, for messages."""
    if mark.word_index is not None:
        return t.words[mark.word_index].word
    return t.words[mark.after_word].word if mark.after_word is not None else ""


def _rel(path: Path, script_path: str) -> str:
    try:
        return str(Path(path).resolve().relative_to(Path(script_path).resolve().parent))
    except ValueError:
        return str(path)
