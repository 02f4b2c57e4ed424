"""The face that ships (issue 25): what `sgt generate` puts on the speakers' tracks, measured on
the tracks' numbers against the plan's phonemes and words, with measures written here (not
taken from model/face.py): lips closed on p/b/m, the mouth shut in silence and open on vowels,
blinks at a natural rate and never through a stressed vowel, a listener's eyes on the speaker,
``[look:...]`` marks, ``<face:...>`` spans and the presets' expressions, a seed's determinism,
and the motion file (version 3) keeping the face."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.face import ARKIT_INDEX as J
from core.face import LOOK_DIRECTIONS
from core.motion import load_motion_file, save_motion
from core.skeleton import BONE_INDEX, FPS, REST_DIRECTIONS
from dsl.speech import _espeak

pytestmark = pytest.mark.skipif(_espeak.find_library() is None, reason="libespeak-ng not installed")

PARTING = ["mouthFunnel", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight", "tongueOut"]
OPEN_VOWELS = set("aɑæʌɐ")
STRESSABLE = set("aeiouæɐɑɒɔəɛɜɪʊʌ")


def take_of(text: str, seed: int = 0):
    from model.generate import generate  # lazy: numpy and the engines

    return generate(source=text, engine="keyframe", seed=seed)


def lips_closed(w: np.ndarray) -> np.ndarray:
    """Frames whose lips meet: the jaw nearly shut, mouthClose taking up what it opens, nothing
    parting the lips."""
    return ((w[:, J["jawOpen"]] <= 0.15) & (w[:, J["jawOpen"]] - w[:, J["mouthClose"]] <= 0.02)
            & (w[:, [J[n] for n in PARTING]] <= 0.1).all(axis=1))


def frames_over(a: float, b: float, n: int) -> list[int]:
    return [f for f in range(int(math.floor(a * FPS)), int(math.ceil(b * FPS))) if 0 <= f < n]


def head_yaw_pitch(poses: np.ndarray) -> np.ndarray:
    """Degrees the body's nose bone is turned from its rest direction (yaw to the left, pitch up)."""
    d = poses.reshape(len(poses), -1, 3)[:, BONE_INDEX["nose"]].astype(np.float64)
    rest = np.asarray(REST_DIRECTIONS["nose"])
    return np.stack([np.degrees(np.arctan2(d[:, 0], d[:, 2]) - math.atan2(rest[0], rest[2])),
                     np.degrees(np.arcsin(np.clip(d[:, 1], -1, 1)) - math.asin(rest[1]))], axis=1)


def world_gaze(track) -> np.ndarray:
    """Where the track's eyes look from the body's front (degrees): head turn plus the eyes."""
    return head_yaw_pitch(track.poses) + track.face.gaze.astype(np.float64).mean(axis=1)


def circle_yaw(n: int, i: int, j: int) -> float:
    """Yaw from speaker i to j standing on a circle facing its centre (the geometry, written here)."""
    p = [np.array([math.cos(2 * math.pi * k / n), math.sin(2 * math.pi * k / n)]) for k in range(n)]
    forward = -p[i]
    left = np.array([forward[1], -forward[0]])
    d = p[j] - p[i]
    return math.degrees(math.atan2(d @ left, d @ forward))


@pytest.fixture(scope="module")
def mouth_take():
    return take_of("@rate 160\nguide: Bob bought a big blue boat, [pause 600ms] a mop and a pump.\n"
                   "guide: Maybe the bubble will pop, but maybe it will not.\n")


def test_bilabials_close_the_lips_on_the_track(mouth_take):
    n_bilabial = 0
    for u, c in zip(mouth_take.plan.utterances, mouth_take.clips):
        closed = lips_closed(c.face.weights)
        for p in u.phonemes:
            if p.phoneme[0] in "pbm":
                n_bilabial += 1
                mid = min(int(math.floor((p.start + p.end) / 2 * FPS)), c.n_frames - 1)
                assert closed[mid], (u.text, p.phoneme, p.start)
    assert n_bilabial >= 15
    # the track is what ships: the clips are views of its frames
    track = mouth_take.tracks[0]
    for u, c in zip(mouth_take.plan.utterances, mouth_take.clips):
        np.testing.assert_array_equal(track.face.weights[u.start_frame:u.start_frame + c.n_frames], c.face.weights)


def test_the_mouth_is_shut_in_silence_and_opens_on_open_vowels(mouth_take):
    opened = []
    for u, c in zip(mouth_take.plan.utterances, mouth_take.clips):
        w = c.face.weights
        touched = np.zeros(c.n_frames, bool)
        for p in u.phonemes:
            touched[frames_over(p.start, p.end, c.n_frames)] = True
            if p.phoneme[0] in OPEN_VOWELS and not p.phoneme.startswith(("aɪ", "aʊ")):
                ev = int(math.floor(p.start * FPS))
                opened.append(any(w[f, J["jawOpen"]] >= 0.25 for f in range(ev - 1, ev + 2) if 0 <= f < c.n_frames))
        assert (~touched).sum() >= (8 if u.index == 0 else 2)  # the pause (first line), the lead-in, the tail
        assert lips_closed(w[~touched]).all() and w[~touched, J["jawOpen"]].max() < 0.05
    assert len(opened) >= 5 and np.mean(opened) >= 0.9


@pytest.fixture(scope="module")
def dialogue():
    lines = ["Good morning! Did you sleep well?", "Not really, the storm kept me awake all night.",
             "I heard it too. The wind was very loud.", "Shall we walk to the market before it rains again?",
             "Yes, but first I need a coffee.", "There is a small cafe near the bridge.",
             "Perfect. Let me get my coat and my umbrella.", "Take your time, I will wait here by the door."]
    text = "@rate 160\n" + "\n".join(f"{('ann', 'ben')[k % 2]}: {line}" for k, line in enumerate(lines * 2)) + "\n"
    return take_of(text, seed=3)


def test_blinks_come_at_a_natural_rate_and_never_through_a_stressed_vowel(dialogue):
    plan = dialogue.plan
    minutes = plan.n_frames / FPS / 60
    for t in dialogue.tracks:
        lid = t.face.weights[:, J["eyeBlinkLeft"]]
        shut = lid >= 0.8
        blinks = int((shut & ~np.concatenate([[False], shut[:-1]])).sum())
        assert 8 <= blinks / minutes <= 30, (t.speaker, blinks / minutes)
        down = lid >= 0.4
        for u in plan.utterances:
            if u.speaker != t.speaker:
                continue
            for p in u.phonemes:
                if p.stress == 2 and p.phoneme[0] in STRESSABLE:
                    fs = frames_over(u.start + p.start, u.start + p.end, plan.n_frames)
                    assert not down[fs].any(), (u.text, p.phoneme)


def test_a_listener_looks_at_whoever_speaks(dialogue):
    plan = dialogue.plan
    speakers = plan.speakers
    n = plan.n_frames
    who = np.full(n, -1)
    for u in plan.utterances:
        who[frames_over(u.start + u.words[0].start, u.start + u.words[-1].end, n)] = speakers.index(u.speaker)
    for t in dialogue.tracks:
        me = speakers.index(t.speaker)
        gaze = world_gaze(t)
        listening = np.flatnonzero((who >= 0) & (who != me))
        on = [abs(gaze[f, 0] - circle_yaw(2, me, int(who[f]))) <= 5 and abs(gaze[f, 1]) <= 5 for f in listening]
        assert len(on) > 100 and np.mean(on) >= 0.75, (t.speaker, np.mean(on))


def test_a_look_mark_aims_the_eyes_over_its_clause():
    base = "guide: Welcome to the shop. {mark}Over on that side are the shoes, and here the hats.\nvisitor: Thanks.\n"
    marked, plain = take_of(base.format(mark="[look:left] ")), take_of(base.format(mark=""))
    u = marked.plan.utterances[0]
    over = next(i for i, w in enumerate(u.words) if w.word == "Over")
    shoes = next(i for i, w in enumerate(u.words) if w.word == "shoes")
    frames = frames_over(u.start + u.words[over].start + 0.15, u.start + u.words[shoes].end, marked.plan.n_frames)
    gaze, before = world_gaze(marked.tracks[0]), world_gaze(plain.tracks[0])
    yaw, pitch = LOOK_DIRECTIONS["left"]
    assert np.abs(gaze[frames, 0] - yaw).max() <= 3 and np.abs(gaze[frames, 1] - pitch).max() <= 3
    assert np.abs(before[frames, 0] - yaw).mean() > 10  # without the mark the eyes are elsewhere
    # the look ends with its clause: by the end of "hats" the eyes are off the left again
    hats = frames_over(u.start + u.words[-1].start, u.start + u.words[-1].end, marked.plan.n_frames)
    assert np.abs(gaze[hats, 0] - yaw).min() > 5


def test_a_look_at_a_speaker_turns_the_eyes_to_their_seat():
    take = take_of("ann: Hello. [look:cara] Have you met my friend here?\nben: Hi.\ncara: Hello to you both.\n")
    u = take.plan.utterances[0]
    frames = frames_over(u.start + u.words[1].start + 0.15, u.start + u.words[-1].end, take.plan.n_frames)
    gaze = world_gaze(take.tracks[0])
    assert np.abs(gaze[frames, 0] - circle_yaw(3, 0, 2)).max() <= 3


def test_face_spans_and_presets_show_their_expressions():
    take = take_of("guide: <face:smile>Hello there, my friend,</face> and welcome to the old museum of the town.\n"
                   "guide: <sad>I am afraid it closes early today.</sad>\n")
    (a, b), clips = take.plan.utterances, take.clips
    smile = clips[0].face.weights[:, J["mouthSmileLeft"]]
    friend = next(w for w in a.words if w.word == "friend")
    town = a.words[-1]
    assert smile[frames_over(friend.start, friend.end, clips[0].n_frames)].min() >= 0.3
    assert smile[frames_over(town.start, town.end, clips[0].n_frames)].max() <= 0.1  # the span is over
    sad = clips[1].face.weights
    mid = frames_over(b.words[2].start, b.words[-2].end, clips[1].n_frames)
    assert sad[mid, J["mouthFrownLeft"]].min() >= 0.3 and sad[mid, J["mouthSmileLeft"]].max() <= 0.1
    assert clips[0].face.weights[:, J["mouthFrownLeft"]].max() <= 0.1


def test_the_face_is_the_seeds():
    text = "guide: Take your time, and enjoy your visit. We close at six.\n"
    one, again, other = take_of(text, 1), take_of(text, 1), take_of(text, 2)
    np.testing.assert_array_equal(one.tracks[0].face.weights, again.tracks[0].face.weights)
    np.testing.assert_array_equal(one.tracks[0].face.gaze, again.tracks[0].face.gaze)
    assert not np.array_equal(one.tracks[0].face.weights, other.tracks[0].face.weights)
    # the mouth is the speech's, not the seed's
    mouth = [J[n] for n in ("jawOpen", "mouthClose", "mouthFunnel", "mouthPucker")]
    np.testing.assert_array_equal(one.tracks[0].face.weights[:, mouth], other.tracks[0].face.weights[:, mouth])


@pytest.mark.parametrize("fmt", ["json", "npz"])
def test_the_motion_file_keeps_the_face(mouth_take, tmp_path, fmt):
    path = tmp_path / f"take.{fmt}"
    save_motion(path, mouth_take.clips, format=fmt, tracks=mouth_take.tracks)
    back = load_motion_file(path)
    assert back.version == 3
    for got, want in zip(back.tracks + back.clips, mouth_take.tracks + mouth_take.clips):
        np.testing.assert_allclose(got.face.weights, want.face.weights, atol=5e-4)
        np.testing.assert_allclose(got.face.gaze, want.face.gaze, atol=5e-3)
