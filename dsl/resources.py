"""What a script needs from the outside world, checked the way the compiler uses it.

The parser checks the text; this module checks the voices and recordings the text refers to,
with the very functions speech timing uses (:func:`dsl.speech.synth.check_voice`,
:func:`dsl.speech.recording.check_recording`), so that ``sgt check`` (estimated timing) and
``sgt compile``, ``say``, ``generate`` and the editor (which all go through
:func:`dsl.compiler.load_script`) accept and reject the same scripts. It also owns the one
mapping from a :class:`~dsl.speech.SpeechError` to a diagnostic at the right place: the
``@voice`` value, the audio file's name, the ``timings=`` value, or the word that does not
match (in the timings file, or in the recording itself when it is aligned automatically).
"""

from __future__ import annotations

from pathlib import Path

from core import rules
from core.diagnostics import Diagnostic, Related
from dsl.script import Script, Span, Utterance
from dsl.speech import SpeechError, list_voices, piper
from dsl.speech.recording import check_recording
from dsl.speech.synth import MAX_VOICE_NAME, check_voice, list_variants


def check_resources(script: Script) -> list[Diagnostic]:
    """Problems with the voices and recordings ``script`` uses, each reported once: every
    ``@voice`` of the header (used or not, so that the verdict does not depend on which
    utterances are compiled), the speech engine itself when an utterance needs it, and each
    ``@audio`` recording with its timings file."""
    out: list[Diagnostic] = []
    header = script.header
    for speaker, where in header.voice_where.items():
        name = header.speaker_overrides.get(speaker, {}).get("name") if speaker else header.voice.name
        if name is None:
            continue
        try:
            check_voice(name)
        except SpeechError as exc:
            if exc.kind == "voice":
                out.append(_unknown_voice(script.path, name, exc, where))
            elif exc.kind == "not-installed":
                out.append(_not_installed(script.path, name, exc, where))
    out += _pitches_ignored(script)
    engine_checked = False
    for utt in script.utterances:
        if utt.audio is not None:
            try:
                check_recording(utt.audio.path, utt.text, utt.word_spans, utt.audio.timings)
            except SpeechError as exc:
                out.append(speech_diagnostic(script, utt, exc))
        elif not engine_checked:  # the engine loads for the first synthesized utterance
            engine_checked = True
            try:
                check_voice(utt.voice.name)
            except SpeechError as exc:
                if exc.kind not in ("voice", "not-installed"):  # reported at its @voice above
                    out.append(speech_diagnostic(script, utt, exc))
    return out


def _unknown_voice(file: str, name: str, exc: SpeechError, where: Span) -> Diagnostic:
    kw: dict = {}
    base, _, variant = name.partition("+")
    variants = exc.reason == "voice variant"  # the voice is right: suggest its variants
    hint, fixes = None, ()
    if len(name) <= MAX_VOICE_NAME:
        try:
            if variants:
                hint, fixes = rules.did_you_mean(variant, list_variants(), where.line, where.col, where.length, fmt=base + "+{}")
            else:
                hint, fixes = rules.did_you_mean(name.lower(), list_voices(), where.line, where.col, where.length)
        except SpeechError:
            pass
    else:  # the message quotes the name: not a 10,000-character one
        name = name[:60] + "..."
    lists = "'sgt voices --variants' lists the variants" if variants else "'sgt voices' lists the voices"
    kw = {"hint": f"{hint} ({lists})", "fixes": fixes} if hint else {"hint": lists}
    return rules.UNKNOWN_VOICE.at(file, where.line, where.col, where.length, what=exc.reason or "voice", voice=name, **kw)


def _not_installed(file: str, name: str, exc: SpeechError, where: Span) -> Diagnostic:
    return rules.VOICE_NOT_INSTALLED.at(file, where.line, where.col, where.length, voice=name, reason=exc.reason,
                                        install=piper.INSTALL)


def _pitches_ignored(script: Script) -> list[Diagnostic]:
    """A warning at each ``@pitch`` whose speaker (everyone's, for one without a speaker) speaks
    with a piper voice, which has no pitch."""
    out = []
    header = script.header
    for key, where in header.settings_where.items():
        kind, _, speaker = key.partition(":")
        if kind != "pitch":
            continue
        name = header.voice_for(speaker or None).name
        if piper.voice_of(name) is not None:
            out.append(rules.PITCH_NOT_SUPPORTED.at(script.path, where.line, where.col, where.length, voice=name))
    return out


def _voice_span(script: Script, utt: Utterance) -> Span | None:
    """Where the voice of ``utt`` was set: its speaker's ``@voice``, else the default one."""
    where = script.header.voice_where
    if utt.speaker is not None and "name" in script.header.speaker_overrides.get(utt.speaker, {}):
        return where.get(utt.speaker)
    return where.get("")


def shown_from(path, script_path) -> str:
    """``path`` as a directive of the script at ``script_path`` names it: relative to the
    script's folder where it lies under it, else as it is."""
    try:
        return str(Path(path).resolve().relative_to(Path(script_path).resolve().parent))
    except (ValueError, OSError):
        return str(path)


def speech_diagnostic(script: Script, utt: Utterance, exc: SpeechError) -> Diagnostic:
    """The diagnostic for a speech problem of ``utt``, at the place it is about."""
    file = script.path
    audio = utt.audio
    if exc.kind == "voice":
        where = _voice_span(script, utt) or Span(utt.line, 1, 1)
        return _unknown_voice(file, utt.voice.name, exc, where)
    if exc.kind == "not-installed":
        return _not_installed(file, utt.voice.name, exc, _voice_span(script, utt) or Span(utt.line, 1, 1))
    if exc.kind == "crash":
        return rules.SPEECH_CRASH.at(file, utt.line, 1, 1, detail=exc.message)
    if exc.kind == "audio" and audio is not None:
        w = audio.where
        return rules.UNREADABLE_AUDIO.at(file, w.line, w.col, w.length, audio=shown_from(audio.path, file), reason=exc.reason)
    if exc.kind == "too-long" and audio is not None:
        w = audio.where
        return rules.RECORDING_TOO_LONG.at(file, w.line, w.col, w.length, audio=shown_from(audio.path, file), reason=exc.reason)
    if exc.kind == "timings" and audio is not None and audio.timings_where is not None:
        w = audio.timings_where
        return rules.BAD_TIMINGS.at(file, w.line, w.col, w.length, timings=shown_from(audio.timings, file), reason=exc.reason)
    if exc.kind == "mismatch" and audio is not None and audio.timings is None:  # the automatic alignment
        idx = exc.word_index
        w = utt.words[idx].where if idx is not None and 0 <= idx < len(utt.words) else Span(utt.line, 1, 1)
        a = audio.where
        return rules.RECORDING_MISMATCH.at(
            file, w.line, w.col, w.length, detail=f"{shown_from(audio.path, file)}: {exc.reason}",
            related=(Related("the recording", file, a.line, a.col, a.length),))
    if exc.kind == "mismatch":
        related = ()
        if audio is not None and audio.timings_where is not None:
            t = audio.timings_where
            related = (Related("the timings file", file, t.line, t.col, t.length),)
        idx = exc.word_index
        if idx is not None and 0 <= idx < len(utt.words):
            w = utt.words[idx].where
            place = (w.line, w.col, w.length)
        elif audio is not None and audio.timings_where is not None:
            place, related = (audio.timings_where.line, audio.timings_where.col, audio.timings_where.length), ()
        else:
            place = (utt.line, 1, 1)
        message = exc.message
        if audio is not None and audio.timings is not None:
            message = message.replace(str(audio.timings), shown_from(audio.timings, file))
        return rules.TIMINGS_MISMATCH.at(file, *place, detail=message, related=related)
    if audio is not None:
        w = audio.where
        return rules.SPEECH.at(file, w.line, w.col, w.length, detail=exc.message)
    return rules.SPEECH.at(file, utt.line, 1, 1, detail=exc.message)
