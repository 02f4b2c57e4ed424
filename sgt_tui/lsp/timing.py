"""Word and utterance times for hover and inlay hints: the estimate every analysis has, or the
real speech timing once it is in the speech cache.

The server never synthesizes speech for a hover: it learns that an utterance's speech is
cached when a preview (``sgt.preview``) has spoken it, then compiles that utterance with
``timing="speech"`` (a cache hit) and keeps its plan by the utterance's key (its text and the
header it depends on). Everything else shows the estimate, and says so.
"""

from __future__ import annotations

import dataclasses

from core.skeleton import FPS
from dsl.compiler import compile_file
from dsl.plan import Plan


class SpeechTimes:
    def __init__(self) -> None:
        self._real: dict[str, object] = {}  # utterance key -> dsl.plan.UtterancePlan with speech timing

    def learn(self, doc, info) -> None:
        """Compile utterance ``info`` of ``doc`` with its (cached) speech timing and keep it."""
        result = compile_file(doc.path, source=doc.text, timing="speech", utterances=[info.index],
                              library=doc.analysis().library)
        if result.plan is not None and result.plan.utterances:
            self._real[info.key] = result.plan.utterances[0]

    def plan_of(self, doc, info) -> tuple[object | None, bool]:
        """The utterance's plan and whether its times are real speech (else the estimate)."""
        if info is None:
            return None, False
        real = self._real.get(info.key)
        return (real, True) if real is not None else (info.plan, False)

    def performance(self, doc) -> list[tuple[object, float, float, bool]]:
        """(utterance info, start on the performance clock, length, real) for each utterance with
        a plan, laid out together as the performance plays them (``@gap``, interruptions)."""
        chosen = [(info, *self.plan_of(doc, info)) for info in doc.analysis().utterances]
        chosen = [(info, plan, real) for info, plan, real in chosen if plan is not None]
        if not chosen:
            return []
        plan = Plan(str(doc.path), FPS, 0, [dataclasses.replace(p) for _, p, _ in chosen])
        return [(info, u.start, u.duration, real) for (info, _, real), u in zip(chosen, plan.utterances)]
