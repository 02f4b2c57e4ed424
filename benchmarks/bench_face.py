"""Check: does the face follow the speech? (issue 25, the face layer)

    python benchmarks/bench_face.py [--rates 80 160 300] [--seeds 3] [--voice joe]

``--voice NAME`` speaks parts 2-4 with that voice (``joe``: piper, whose phoneme times are
the model's own alignments, so part 1, espeak-ng's events, is left out for it) and leaves
out part 5.

Everything is measured on the motion files' numbers (the tracks' faces, what `sgt generate`
writes; keyframe engine for the body), with measures written here, not taken from
model/face.py:

1. The phonemes carried to the plan against espeak-ng's own phoneme events: the sentences
   of part 2 synthesized by the engine directly (``_espeak.run_synth``); each event's time
   from the first phoneme's event against the plan's phoneme time from its first one (ms).
2. Viseme onsets, per @rate: for every phoneme whose viseme is visible on its own
   (bilabials p b m: lips closed; labiodentals f v: ``mouthRollLower`` >= 0.3; rounded
   vowels and w: ``mouthPucker`` + ``mouthFunnel`` >= 0.3; open vowels: ``jawOpen`` >= 0.25,
   more than any consonant's viseme opens it),
   the distance in frames from the frame holding its espeak-ng event to the nearest frame
   showing that viseme (searched within 3 frames; none there counts as 4).
3. Bilabials: the share of p, b and m whose frames show closed lips, per @rate. Lips are
   closed when ``jawOpen`` <= 0.15, ``jawOpen - mouthClose`` <= 0.02 (ARKit's mouthClose
   brings the lips together as far as the jaw opens) and nothing parts them (``mouthFunnel``,
   ``mouthLowerDown*``, ``mouthUpperUp*``, ``tongueOut`` <= 0.1). Counted two ways: a closed
   frame among the frames it overlaps, and the frame that holds its middle closed.
4. The mouth in silence: frames no phoneme overlaps, inside lines (pauses, phrase breaks) and
   while listening: the share with closed lips and the largest ``jawOpen``.
5. Dialogues of 2 and 3 speakers (24 lines, @rate 160, several seeds): blinks per minute per
   speaker (a blink is a run of frames with ``eyeBlink*`` >= 0.8), blinks whose lids are down
   (>= 0.4) through a stressed vowel of the speaker's own, and the share of listening frames
   (another speaker's speech between its first and last word, the listener not speaking)
   on which the listener's gaze (head turn from the body's nose bone + the eyes) is within
   5 degrees of the speaker's seat on the circle (see docs/face.md), plus the speakers' share
   on their addressee.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from core.face import ARKIT_INDEX as J  # noqa: E402
from core.skeleton import BONE_INDEX, FPS, REST_DIRECTIONS  # noqa: E402

SENTENCES = [
    "Well, hello there my friend. How are you today?",
    "The quick brown fox jumps over the lazy dog.",
    "Take your time. Enjoy your visit, and come back soon!",
    "Maybe the bubble will pop, but maybe it will not.",
    "Please put the map back in my bag before the bus leaves.",
    "Five vivid valleys of fine vines, very far from here.",
    "I think that we should go now, before the rain starts.",
    "Bob bought a big blue boat, a mop and a pump.",
]
BILABIAL, LABIODENTAL = set("pbm"), set("fv")
ROUNDED, OPEN = set("uʊwoɔɒ"), set("aɑæʌɐ")
PARTING = ["mouthFunnel", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight", "tongueOut"]


def closed(w: np.ndarray) -> np.ndarray:
    return ((w[:, J["jawOpen"]] <= 0.15) & (w[:, J["jawOpen"]] - w[:, J["mouthClose"]] <= 0.02)
            & (w[:, [J[n] for n in PARTING]] <= 0.1).all(axis=1))


def shows(kind: str, w: np.ndarray) -> np.ndarray:
    if kind == "bilabial":
        return closed(w)
    if kind == "labiodental":
        return w[:, J["mouthRollLower"]] >= 0.3
    if kind == "rounded":
        return w[:, J["mouthPucker"]] + w[:, J["mouthFunnel"]] >= 0.3
    return w[:, J["jawOpen"]] >= 0.25


def kind_of(phoneme: str) -> str | None:
    first = phoneme[0]
    if phoneme in ("tʃ", "dʒ"):
        return None
    if first in BILABIAL:
        return "bilabial"
    if first in LABIODENTAL:
        return "labiodental"
    if first in ROUNDED or phoneme.startswith(("uː", "oʊ")):
        return "rounded"
    if first in OPEN and not phoneme.startswith(("aɪ", "aʊ")) or phoneme in ("aɪ", "aʊ"):
        return "open"
    return None


def take_of(text: str, seed: int = 0):
    from model.generate import generate

    return generate(source=text, engine="keyframe", seed=seed)


def frames_over(a: float, b: float) -> range:
    return range(int(math.floor(a * FPS)), int(math.ceil(b * FPS)))


def part_events(rates) -> None:
    from dsl.compiler import compile_text
    from dsl.speech import _espeak

    print("1. plan phonemes against espeak-ng's phoneme events (ms, time from the first phoneme)")
    for rate in rates:
        diffs = []
        for sentence in SENTENCES:
            plan = compile_text(f"@rate {rate}\n{sentence}\n").plan
            u = plan.utterances[0]
            sr, _, _, events = _espeak.run_synth(sentence, "gmw/en-US", rate, 50)
            named = [e for e in events if e.name]
            if len(named) != len(u.phonemes):
                print(f"   @rate {rate}: {len(named)} events, {len(u.phonemes)} planned phonemes for {sentence!r}")
                continue
            zero_e, zero_p = named[0].sample / sr, u.phonemes[0].start
            diffs += [abs((e.sample / sr - zero_e) - (p.start - zero_p)) * 1000 for e, p in zip(named, u.phonemes)]
        print(f"   @rate {rate}: {len(diffs)} phonemes, median {statistics.median(diffs):.3f} ms, max {max(diffs):.3f} ms")


def part_visemes(rates, voice: str | None = None) -> None:
    print("2./3./4. visemes against the phoneme events, bilabials, the mouth in silence"
          + (f" (@voice {voice})" if voice else ""))
    text = "\n".join(f"guide: {s}" for s in SENTENCES)
    header = f"@voice {voice}\n" if voice else ""
    for rate in rates:
        take = take_of(f"{header}@rate {rate}\n{text}\n")
        errors: dict[str, list[int]] = {}
        touched_any = touched_mid = n_bilabial = 0
        silent_in, silent_jaw = [], 0.0
        for u, c in zip(take.plan.utterances, take.clips):
            w = c.face.weights
            show = {k: shows(k, w) for k in ("bilabial", "labiodental", "rounded", "open")}
            overlap = np.zeros(c.n_frames, bool)
            for p in u.phonemes:
                for f in frames_over(p.start, p.end):
                    if 0 <= f < c.n_frames:
                        overlap[f] = True
                kind = kind_of(p.phoneme)
                if kind is None:
                    continue
                ev = int(math.floor(p.start * FPS))
                near = [abs(f - ev) for f in range(ev - 3, ev + 4) if 0 <= f < c.n_frames and show[kind][f]]
                errors.setdefault(kind, []).append(min(near) if near else 4)
                if kind == "bilabial":
                    n_bilabial += 1
                    touched_any += any(show[kind][f] for f in frames_over(p.start, p.end) if 0 <= f < c.n_frames)
                    mid = int(math.floor((p.start + p.end) / 2 * FPS))
                    touched_mid += bool(show[kind][min(mid, c.n_frames - 1)])
            quiet = ~overlap
            silent_in += closed(w[quiet]).tolist()
            silent_jaw = max(silent_jaw, float(w[quiet, J["jawOpen"]].max(initial=0.0)))
        print(f"   @rate {rate}:")
        for kind, errs in errors.items():
            within = sum(e <= 1 for e in errs) / len(errs)
            print(f"     {kind:12s} {len(errs):4d} phonemes: onset error median {statistics.median(errs):.0f} frames, "
                  f"max {max(errs)}, within 1 frame {100 * within:.1f} %")
        print(f"     bilabials: lips closed on a frame they overlap {100 * touched_any / n_bilabial:.1f} % "
              f"({touched_any}/{n_bilabial}), on the frame of their middle {100 * touched_mid / n_bilabial:.1f} %")
        print(f"     silence inside lines: {len(silent_in)} frames, lips closed on {100 * np.mean(silent_in):.1f} %, "
              f"largest jawOpen {silent_jaw:.3f}")


def _head_yaw_pitch(poses: np.ndarray) -> np.ndarray:
    d = poses.reshape(len(poses), -1, 3)[:, BONE_INDEX["nose"]].astype(np.float64)
    rest = np.asarray(REST_DIRECTIONS["nose"])
    return np.stack([np.degrees(np.arctan2(d[:, 0], d[:, 2]) - math.atan2(rest[0], rest[2])),
                     np.degrees(np.arcsin(np.clip(d[:, 1], -1, 1)) - math.asin(rest[1]))], axis=1)


def _seat(n: int, i: int, j: int) -> float:
    """Yaw from speaker i to j on a circle facing its centre (written here from the geometry)."""
    a = [2 * math.pi * k / n for k in range(n)]
    p = [np.array([math.cos(x), math.sin(x)]) for x in a]
    fwd = -p[i]
    left = np.array([fwd[1], -fwd[0]])
    d = p[j] - p[i]
    return math.degrees(math.atan2(d @ left, d @ fwd))


DIALOGUE = [
    "Good morning! Did you sleep well?", "Not really, the storm kept me awake all night.",
    "I heard it too. The wind was very loud.", "Shall we walk to the market before it rains again?",
    "Yes, but first I need a coffee.", "There is a small cafe near the bridge.",
    "Perfect. Let me get my coat and my umbrella.", "Take your time, I will wait here by the door.",
]


def part_dialogues(seeds: int) -> None:
    print("5. dialogues: blinks, gaze on the speaker while listening")
    for count in (2, 3):
        names = ["ann", "ben", "cara"][:count]
        lines = [f"{names[k % count]}: {DIALOGUE[k % len(DIALOGUE)]}" for k in range(24)]
        rates, over_stress, listening, speaking = [], 0, [], []
        quiet_closed, quiet_jaw = [], 0.0
        in_pause = [0, 0.0]  # blinks starting in the first 0.5 s of a pause (or after a line), seconds of those
        elsewhere = [0, 0.0]
        for seed in range(seeds):
            take = take_of("@rate 160\n" + "\n".join(lines) + "\n", seed)
            plan = take.plan
            spk = plan.speakers
            n = plan.n_frames
            speech = {s: np.zeros(n, bool) for s in spk}
            who = np.full(n, -1)
            for u in plan.utterances:
                if u.words:
                    f0, f1 = int(math.floor((u.start + u.words[0].start) * FPS)), int(math.ceil((u.start + u.words[-1].end) * FPS))
                    speech[u.speaker][f0:f1] = True
                    who[f0:f1] = spk.index(u.speaker)
            for t in take.tracks:
                lid = t.face.weights[:, J["eyeBlinkLeft"]]
                up = lid >= 0.8
                starts = np.flatnonzero(up & ~np.concatenate([[False], up[:-1]]))
                rates.append(len(starts) / (n / FPS / 60))
                pause = np.zeros(n, bool)
                for u in plan.utterances:
                    if u.speaker != t.speaker:
                        continue
                    ends = [w0.end for w0, w1 in zip(u.words, u.words[1:]) if w1.start - w0.end >= 0.25] + [u.words[-1].end]
                    for e in ends:
                        pause[int(math.floor((u.start + e) * FPS)) : int(math.ceil((u.start + e + 0.5) * FPS))] = True
                pause = pause[:n]
                # (a blink's lid is down from the frame before its full closure)
                in_pause[0] += int(pause[np.maximum(starts - 1, 0)].sum())
                in_pause[1] += pause.sum() / FPS
                elsewhere[0] += len(starts) - int(pause[np.maximum(starts - 1, 0)].sum())
                elsewhere[1] += (~pause).sum() / FPS
                mouth_quiet = ~speech[t.speaker]
                for u in plan.utterances:  # the frames of its own lines (lead-in and tail too) are not listening
                    if u.speaker == t.speaker:
                        mouth_quiet[u.start_frame : u.start_frame + u.n_frames] = False
                quiet_closed += closed(t.face.weights[mouth_quiet]).tolist()
                quiet_jaw = max(quiet_jaw, float(t.face.weights[mouth_quiet, J["jawOpen"]].max(initial=0.0)))
                down = lid >= 0.4
                for u in plan.utterances:
                    if u.speaker != t.speaker:
                        continue
                    for p in u.phonemes:
                        if p.stress == 2 and p.phoneme[0] in "aeiouæɐɑɒɔəɛɜɪʊʌ":
                            fs = [f for f in frames_over(u.start + p.start, u.start + p.end) if 0 <= f < n]
                            over_stress += bool(down[fs].any()) if fs else 0
                world = _head_yaw_pitch(t.poses) + t.face.gaze.mean(axis=1)
                me = spk.index(t.speaker)
                for f in np.flatnonzero((who >= 0) & (who != me) & ~speech[t.speaker]):
                    aim = _seat(count, me, int(who[f]))
                    listening.append(abs(world[f, 0] - aim) <= 5 and abs(world[f, 1]) <= 5)
                for i, u in enumerate(plan.utterances):
                    if u.speaker != t.speaker or not u.words:
                        continue
                    nxt = next((v.speaker for v in plan.utterances[i + 1 :] if v.speaker != u.speaker), None)
                    nxt = nxt or next((v.speaker for v in reversed(plan.utterances[:i]) if v.speaker != u.speaker), None)
                    aim = _seat(count, me, spk.index(nxt))
                    for f in frames_over(u.start + u.words[0].start, u.start + u.words[-1].end):
                        if 0 <= f < n:
                            speaking.append(abs(world[f, 0] - aim) <= 5 and abs(world[f, 1]) <= 5)
        print(f"   {count} speakers, {seeds} seeds: blinks per minute median {statistics.median(rates):.1f} "
              f"(min {min(rates):.1f}, max {max(rates):.1f}); lids down through a stressed vowel: {over_stress}; "
              f"listening on the speaker {100 * np.mean(listening):.1f} % of {len(listening)} frames; "
              f"speaking on the addressee {100 * np.mean(speaking):.1f} %")
        print(f"     blinks per minute in the first 0.5 s after a phrase or line {60 * in_pause[0] / in_pause[1]:.1f}, "
              f"elsewhere {60 * elsewhere[0] / elsewhere[1]:.1f}; listening mouth: lips closed on "
              f"{100 * np.mean(quiet_closed):.1f} % of {len(quiet_closed)} frames, largest jawOpen {quiet_jaw:.3f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rates", type=int, nargs="+", default=[80, 160, 300])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--cache", type=Path, default=None, help="speech cache folder (default: a fresh one)")
    ap.add_argument("--voice", default=None, help="the voice of parts 2-4 (joe: piper); parts 1 and 5 are left out")
    args = ap.parse_args()
    import os

    from dsl.speech import piper

    os.environ["SGT_CACHE_DIR"] = str(args.cache or tempfile.mkdtemp(prefix="sgt-face-"))
    if piper.voice_of(args.voice) is None:
        part_events(args.rates)
    part_visemes(args.rates, args.voice)
    if args.voice is None:
        part_dialogues(args.seeds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
