"""Overlapping speech (issue 22, part 5): a negative ``@gap`` before a line makes its speaker
interrupt. The interrupted speaker finishes its line under the interruption; the clock
(:meth:`dsl.plan.Plan.lay_out`), the mix (:mod:`renders.audio_mix`) and the speakers' tracks
(:func:`model.performance.perform`) agree on where each line plays, a speaker never talks
over itself (SGT409), an interruption reaches back at most to the previous line's start
(SGT410), and a script without a negative gap is laid out exactly as before.
"""

from __future__ import annotations

import itertools
import json
import math
import random
import shutil
import subprocess

import numpy as np
import pytest

from core.motion import load_motion_file
from core.skeleton import FPS
from dsl.compiler import compile_file, compile_text
from dsl.parser import analyse
from dsl.plan import ArrayRequests, Plan, UtterancePlan
from tests.test_rules import apply_fix

DUO = """knight: Halt! Who goes there, in the dark of the night?
@gap -1.2s
merchant: [pose:open_arms] Only a humble merchant, sir.
knight: Then show your face.
"""


def _main(argv) -> int:
    from sgt_tui.cli import main

    return main([str(a) for a in argv])


# -- the language --------------------------------------------------------------------------------


def test_a_negative_gap_goes_between_two_lines_and_not_in_the_header():
    s = analyse("a: one\n@gap -400ms\nb: two\n@gap -1.5s\na: three\n")
    assert [u.gap for u in s.utterances] == [None, -0.4, -1.5] and s.diagnostics == []
    assert (s.utterances[1].gap_where.line, s.utterances[1].gap_where.col, s.utterances[1].gap_where.length) == (2, 6, 6)
    (d,) = analyse("@gap -1s\na: one\n").diagnostics
    assert (d.code, d.message) == ("SGT310", "'@gap' needs a duration from 0s to 30s in the header, not '-1s'")
    assert d.hint.endswith("; a negative gap goes just before the line that interrupts")
    (d,) = analyse("a: one\n@gap -31s\nb: two\n").diagnostics
    assert d.message == "'@gap' needs a duration from -30s to 30s (negative: the next line interrupts), not '-31s'"
    assert [d.code for d in analyse("a: one\n@gap --1s\nb: two\n").diagnostics] == ["SGT310"]


# -- the clock -----------------------------------------------------------------------------------


def _utterance(n, speaker, lead, speech, tail, gap) -> UtterancePlan:
    frames = lead + math.ceil(speech * FPS) + tail
    return UtterancePlan(index=n, speaker=speaker, line=n + 1, text="", duration=frames / FPS, n_frames=frames,
                         words=[], controls=[], requests=ArrayRequests(frames),
                         speech={"tail": frames / FPS - lead / FPS - speech}, lead_in=lead / FPS, gap=gap)


def _clock_before_interruptions(utts) -> list[int]:
    """Plan.lay_out as it was before negative gaps (commit 7442c5c), for the comparison."""
    speech_end, track_end, starts = 0.0, {}, []
    for n, u in enumerate(utts):
        lead = int(round(u.lead_in * FPS))
        audio = lead if n == 0 else math.ceil((speech_end + u.gap) * FPS - 1e-6)
        start = max(0, audio - lead, track_end.get(u.speaker, 0))
        speech_end = start / FPS + u.lead_in + u.speech_duration
        track_end[u.speaker] = start + u.n_frames
        starts.append(start)
    return starts


def test_without_a_negative_gap_the_clock_is_the_one_before_to_the_frame():
    rng = random.Random(22)
    for _ in range(400):
        utts = [_utterance(n, rng.choice(["a", "b", "c", None]), rng.randint(0, 9), rng.uniform(0.1, 4.0),
                           rng.randint(0, 12), rng.choice([0.0, 0.1, 0.5, 0.8, 2.0, 30.0]))
                for n in range(rng.randint(1, 8))]
        plan = Plan("t.sgt", FPS, 0, utts)
        assert [u.start_frame for u in plan.utterances] == _clock_before_interruptions(utts)
        assert plan.moved == []


def test_an_interruption_starts_its_gap_before_the_speech_so_far_ends():
    knight = _utterance(0, "knight", 0, 3.0, 3, 0.5)
    merchant = _utterance(1, "merchant", 4, 0.5, 2, -0.8)  # interrupts: ends before the knight does
    next_line = _utterance(2, "merchant", 0, 1.0, 0, 0.5)
    plan = Plan("t.sgt", FPS, 0, [knight, merchant, next_line])
    audio = [u.start_frame + round(u.lead_in * FPS) for u in plan.utterances]
    assert audio[1] == math.ceil((3.0 - 0.8) * FPS) and merchant.start_frame == audio[1] - 4
    # the next line follows the last voice (the knight's, still talking), not the merchant's
    assert audio[2] == math.ceil((3.0 + 0.5) * FPS) and plan.moved == []
    assert plan.n_frames == max(u.start_frame + u.n_frames for u in plan.utterances)


def test_an_interruption_reaches_back_at_most_to_the_line_it_interrupts():
    a, b = _utterance(0, "a", 0, 1.0, 0, 0.5), _utterance(1, "a", 0, 1.0, 0, 0.5)
    c = _utterance(2, "b", 2, 1.0, 0, -5.0)
    plan = Plan("t.sgt", FPS, 0, [a, b, c])
    assert c.start_frame + 2 == b.start_frame  # its speech starts with b's
    (m,) = plan.moved
    assert (m.index, m.why, m.other) == (2, "start", 1) and m.frame == b.start_frame
    assert m.asked == math.ceil((b.start + 1.0 - 5.0) * FPS) and abs(m.reach - 1.0) < 1e-9
    # a lead-in that would start before frame 0
    first, lead = _utterance(0, "a", 0, 0.5, 0, 0.5), _utterance(1, "b", 10, 1.0, 0, -0.5)
    plan = Plan("t.sgt", FPS, 0, [first, lead])
    assert lead.start_frame == 0 and [(m.why, m.frame) for m in plan.moved] == [("clock", 10)]


def test_a_speaker_never_talks_over_itself():
    a1, a2 = _utterance(0, "a", 0, 2.0, 5, 0.5), _utterance(1, "a", 0, 1.0, 0, -1.0)
    plan = Plan("t.sgt", FPS, 0, [a1, a2])
    assert a2.start_frame == a1.n_frames  # after a1's retraction
    (m,) = plan.moved
    assert (m.why, m.other, m.frame) == ("self", 0, a1.n_frames)
    # further back: a, b, a interrupting b while a's first line still plays
    a1, b, a2 = _utterance(0, "a", 0, 1.0, 10, 0.5), _utterance(1, "b", 0, 0.4, 0, 0.0), _utterance(2, "a", 0, 1.0, 0, -0.3)
    plan = Plan("t.sgt", FPS, 0, [a1, b, a2])
    assert a2.start_frame == a1.n_frames and [(m.why, m.other) for m in plan.moved] == [("self", 0)]
    for u in ([a1, a2], [a1, b, a2]):  # one speaker's frames never overlap
        spans = sorted((x.start_frame, x.start_frame + x.n_frames) for x in u if x.speaker == "a")
        assert all(e <= s for (_, e), (s, _) in itertools.pairwise(spans))


def test_check_warns_where_an_interruption_cannot_start_as_asked_with_fixes():
    text = ("knight: Halt, who goes there?\n@gap -400ms\nknight: Answer me.\n"
            "merchant: Yes.\n@gap -5s\nknight: Good.\n")
    result = compile_text(text, "t.sgt", timing="estimate")
    assert result.ok
    d = {x.code: x for x in result.diagnostics}
    assert sorted(d) == ["SGT409", "SGT410"]
    me = d["SGT409"]
    assert (me.line, me.col, me.length) == (2, 6, 6)
    assert me.message.startswith("'@gap -400ms' would make 'knight' talk over its own previous line: this line starts ")
    assert "(with estimated timing; real speech may differ), when that line is over" in me.message
    assert [(r.line, r.col) for r in me.related] == [(1, 9)]
    assert me.fixes[0].title == "remove the '@gap'" and apply_fix(text, me.fixes[0]).split("\n")[1] == ""
    far = d["SGT410"]
    assert (far.line, far.col) == (5, 6) and far.message.startswith(
        "'@gap -5s' reaches back before the start of the previous line's speech: this line starts ")
    fixed = apply_fix(text, far.fixes[0])
    assert fixed.split("\n")[4].startswith("@gap -") and fixed.split("\n")[4].endswith("ms")
    assert [x.code for x in compile_text(fixed, "t.sgt", timing="estimate").diagnostics] == ["SGT409"]
    # the same, with the real speech (no "estimated"), and not for a part of the script
    real = compile_text(text, "t.sgt")
    assert sorted(x.code for x in real.diagnostics) == ["SGT409", "SGT410"]
    assert not any("estimated" in x.message for x in real.diagnostics)
    assert compile_text(text, "t.sgt", timing="estimate", utterances=[2, 3]).diagnostics == []


# -- the performance: plan, mix, tracks, video --------------------------------------------------


@pytest.fixture(scope="module")
def duo(tmp_path_factory):
    """The two-speaker script with an interruption: its plan (real speech), its mix and its take."""
    d = tmp_path_factory.mktemp("duo")
    script = d / "duo.sgt"
    script.write_text(DUO)
    result = compile_file(script)
    assert result.ok and result.diagnostics == []
    mix = d / "mix.wav"
    assert _main(["say", script, "-o", d / "speech", "--mix", mix, "--json"]) == 0
    take = d / "take.json"
    assert _main(["generate", script, "-o", take, "--engine", "rules"]) == 0
    return script, result.plan, mix, take


def test_the_plan_places_the_interruption(duo):
    _, plan, _, _ = duo
    knight, merchant, last = plan.utterances
    knight_end = knight.start + knight.audio_offset + knight.speech_duration
    merchant_audio = merchant.start + merchant.audio_offset
    assert merchant.gap == -1.2 and merchant.audio_offset > 0  # its gesture's lead-in comes before its speech
    assert round(merchant_audio * FPS) == math.ceil((knight_end - 1.2) * FPS - 1e-6)
    assert merchant_audio < knight_end - 1.1  # they overlap by 1.2 s, to a frame
    merchant_end = merchant_audio + merchant.speech_duration
    last_audio = last.start + last.audio_offset
    assert round(last_audio * FPS) == math.ceil((max(knight_end, merchant_end) + 0.5) * FPS - 1e-6)
    assert last.start_frame >= knight.start_frame + knight.n_frames  # the knight's own lines never overlap


def test_the_mix_holds_both_voices_where_they_overlap(duo):
    import soundfile as sf

    _, plan, mix_path, _ = duo
    mix, rate = sf.read(str(mix_path), dtype="float32")
    assert len(mix) == round(plan.n_frames / FPS * rate)  # the performance's length
    sources = [sf.read(str(u.audio_path), dtype="float32") for u in plan.utterances]
    assert all(r == rate for _, r in sources)
    at = [round((u.start + u.audio_offset) * rate) for u in plan.utterances]
    expect = np.zeros(len(mix), np.float64)
    for (audio, _), a in zip(sources, at):
        expect[a : a + len(audio)] += audio
    scale = 1.0 / max(1.0, float(np.abs(expect).max()))  # overlapping voices are scaled, never clipped
    tol = 2.0 / 32768  # the WAV's 16 bits
    assert np.abs(mix - scale * expect).max() <= tol
    # sample 0 is frame 0: before the merchant speaks, the mix is the knight's line alone
    knight = sources[0][0]
    assert at[0] == 0 and np.abs(mix[: at[1]] - scale * knight[: at[1]]).max() <= tol
    # in the overlap both voices speak (each loud on its own there), and both are in the mix
    lo, hi = at[1], at[0] + len(knight)
    assert hi - lo > rate  # more than a second
    alone_knight = knight[lo - at[0] : hi - at[0]]
    alone_merchant = sources[1][0][: hi - lo]
    for voice in (alone_knight, alone_merchant):
        assert np.sqrt(np.mean(voice ** 2)) > 0.02
        part = mix[lo:hi] - scale * (alone_knight + alone_merchant - voice)  # the mix less the other voice
        assert np.corrcoef(part, voice)[0, 1] > 0.99


def test_each_speaker_plays_its_whole_line_on_its_own_track(duo):
    _, plan, _, take = duo
    whole = load_motion_file(take)
    assert [t.speaker for t in whole.tracks] == ["knight", "merchant"]
    assert all(t.n_frames == plan.n_frames for t in whole.tracks)
    assert [(c.start_frame, c.n_frames, round(c.audio_offset, 6)) for c in whole.clips] == [
        (u.start_frame, u.n_frames, round(u.audio_offset, 6)) for u in plan.utterances]
    knight, merchant = whole.clips[0], whole.clips[1]
    assert merchant.start_frame < knight.start_frame + knight.n_frames  # on the clock, together
    for clip in whole.clips:  # each clip is its track's frames at its place, overlap or not
        track = next(t for t in whole.tracks if t.speaker == clip.speaker)
        assert np.array_equal(track.poses[clip.start_frame : clip.start_frame + clip.n_frames], clip.poses)


@pytest.mark.skipif(shutil.which("ffprobe") is None, reason="ffprobe (Debian's ffmpeg) is not installed")
def test_a_video_of_the_interruption_has_the_performances_sound(duo, tmp_path):
    _, plan, _, take = duo
    path = tmp_path / "duo.mp4"
    code = _main(["render", take, "-o", path, "--size", "96x96"])
    if code and not path.exists():  # pragma: no cover - machines without offscreen GL
        pytest.skip("no offscreen GL")
    assert code == 0
    out = subprocess.run(["ffprobe", "-v", "error", "-show_streams", "-of", "json", str(path)],
                         capture_output=True, text=True, check=True).stdout
    streams = {s["codec_type"]: s for s in json.loads(out)["streams"]}
    assert int(streams["video"]["nb_frames"]) == plan.n_frames
    assert abs(float(streams["audio"]["duration"]) - plan.n_frames / FPS) <= 1 / FPS


def test_voices_that_add_up_past_full_scale_are_scaled_not_clipped(tmp_path):
    import soundfile as sf

    from renders.audio_mix import mix

    rate = 16000
    t = np.arange(rate) / rate
    a, b = 0.8 * np.sin(2 * np.pi * 200 * t), 0.7 * np.sin(2 * np.pi * 200 * t + 0.3)
    for name, x in (("a.wav", a), ("b.wav", b)):
        sf.write(str(tmp_path / name), x, rate, subtype="PCM_16")
    a, b = (sf.read(str(tmp_path / n), dtype="float32")[0] for n in ("a.wav", "b.wav"))
    # one after the other: each voice as it is (no scaling), silence between, on the clock
    alone, r = mix([(tmp_path / "a.wav", 0.0), (tmp_path / "b.wav", 1.2)], 45)
    assert r == rate and len(alone) == 3 * rate
    assert np.array_equal(alone[:rate], a) and np.array_equal(alone[int(1.2 * rate) : int(2.2 * rate)], b)
    assert not alone[rate : int(1.2 * rate)].any()
    # together for half a second: the sum, scaled to full scale, never clipped
    both, _ = mix([(tmp_path / "a.wav", 0.0), (tmp_path / "b.wav", 0.5)], 45)
    expect = np.zeros(3 * rate)
    expect[:rate] += a
    expect[rate // 2 : rate // 2 + rate] += b
    peak = np.abs(expect).max()
    assert peak > 1.2 and np.abs(both).max() == pytest.approx(1.0, abs=1e-6)
    assert np.abs(both - expect / peak).max() < 1e-6
