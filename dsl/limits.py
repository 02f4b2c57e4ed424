"""A script's performance as it declares itself, held to :mod:`core.limits` before any speech
or motion is made.

:func:`declared_timing` times an utterance the way ``sgt check`` does (the estimate from its
text, pauses included), and a recording by its header's length; the compiler plans every
utterance on it, lays them out on the performance clock (:class:`dsl.plan.Plan`) and asks
:func:`too_long` whether the performance is longer than the limits allow: the same verdict
whatever the timing asked for, so ``sgt check``, ``generate`` and ``sgt serve`` agree.
"""

from __future__ import annotations

import math
from dataclasses import replace

from core import limits, rules
from core.diagnostics import Diagnostic
from core.skeleton import FPS
from dsl.plan import Plan
from dsl.script import Script, Span, Utterance
from dsl.speech.recording import recording_length
from dsl.timing import Timing, estimate_timing


def declared_timing(utt: Utterance) -> Timing:
    """The estimate of ``utt``'s timing (:func:`dsl.timing.estimate_timing`), lasting at least
    its recording's length as the file's header says (and the pauses inserted into it)."""
    t = estimate_timing(utt)
    if utt.audio is not None:
        seconds = recording_length(utt.audio.path)
        if seconds is not None:
            t = replace(t, duration=max(t.duration, seconds + sum(p.seconds for p in utt.pauses)))
    return t


def passing(plan: Plan) -> int | None:
    """The number (in ``plan``) of the first utterance whose motion passes the longest
    performance :func:`core.limits.current` allows for ``plan``'s speakers; None when it fits.
    (The editor, which plans a script in pieces, places :func:`too_long`'s error by it.)"""
    frames = math.floor(limits.current().seconds_for(len(plan.speakers)) * FPS + 1e-9)
    if plan.n_frames <= frames:
        return None
    return next(n for n, u in enumerate(plan.utterances) if u.start_frame + u.n_frames > frames)


def too_long(script: Script, plan: Plan) -> Diagnostic | None:
    """The error for a performance (``plan``, laid out on :func:`declared_timing`) longer than
    :func:`core.limits.current` allows for its speakers, at the place where it passes the
    limit; None when it fits."""
    n = passing(plan)
    if n is None:
        return None
    lim = limits.current()
    speakers = len(plan.speakers)
    longest = lim.seconds_for(speakers)
    frames = math.floor(longest * FPS + 1e-9)
    u = plan.utterances[n]
    utt = next(x for x in script.utterances if x.index == u.index)
    where = _crossing(script, utt, u, (frames - u.start_frame) / FPS)
    per = "" if speakers <= 1 else f" for {speakers} speakers (each speaker's track lasts the whole performance)"
    return rules.PERFORMANCE_TOO_LONG.at(
        script.path, where.line, where.col, where.length, total=limits.duration_text(plan.n_frames / FPS),
        limit=limits.duration_text(longest), per=per, setting=lim.setting)


def _crossing(script: Script, utt: Utterance, u, t: float) -> Span:
    """The mark of ``utt`` (planned as ``u``) playing ``t`` seconds into its motion: a pause, a
    word, its recording, a pose mark (its hold, a late stroke); before its speech, its
    ``@gap``. What plays then is what makes the performance that long; where nothing does
    (the silence after a sentence), the last thing that started before."""
    gap = utt.gap_where or script.header.settings_where.get("gap")
    spans: list[tuple[float, float, int, Span]] = []  # (start, end, rank: the first rank wins, place)
    words = u.words
    for p in utt.pauses:
        end = words[p.word_index].start if p.word_index < len(words) else (words[-1].end if words else u.lead_in)
        spans.append((end - p.seconds, end, 0, p.where))
    spans += [(w.start, w.end, 1, tok.where) for w, tok in zip(words, utt.words)]
    if utt.audio is not None:
        spans.append((u.lead_in, u.lead_in + u.speech_duration, 2, utt.audio.where))
    spans += [(p.first / FPS, p.end / FPS, 3, p.mark.where) for p in u.requests.poses]
    if gap is not None:
        spans.append((-math.inf, 0.0, 4, gap))
    playing = [s for s in spans if s[0] <= t < s[1]]
    if playing:
        return min(playing, key=lambda s: (s[2], -s[0]))[3]
    started = [s for s in spans if s[0] <= t]
    if started:
        return max(started, key=lambda s: (s[0], -s[2]))[3]
    return Span(utt.line, 1, 1)
