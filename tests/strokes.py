"""What a mark promises, checked on what ships: every pose control's stroke on the speaker's
track, the joints' speed, the hands' turns (issue 22).

:func:`check` takes motion as users get it (utterance clips with their controls, one track
per speaker: a :class:`model.generate.Take`, a motion file read back, a service answer) and
returns every broken promise as a line of text: a stroke more than :data:`MAX_STROKE_DEG`
degrees from its gesture's stroke pose on a bone it drives, a stroke more than
:data:`MAX_LATE` frames from its word without a warning saying why, a bone turning faster
than :data:`MAX_DEG_PER_S`, a hand turning more than :data:`MAX_HAND_TURN` degrees in a frame
relative to its forearm (:func:`hand_turns`).
:func:`scripts` makes the scripts it is run on.
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np

from core.skeleton import FPS, bone_angles

ROOT = Path(__file__).resolve().parent.parent
MAX_STROKE_DEG = 3.0
MAX_LATE = 2
MAX_DEG_PER_S = 900.0
MAX_HAND_TURN = 45.0


def check(clips, tracks, library, warned: set | None = None, hands: bool = True) -> list[str]:
    """The broken promises of a performance (see the module docstring). ``warned``: the
    (line, col) of the pose marks an SGT401 warning is about (a late stroke it explains);
    ``hands``: check the hands' turns too."""
    problems = []
    by_speaker = {t.speaker: t for t in tracks}
    for c in clips:
        track = by_speaker.get(c.speaker)
        poses = track.poses if track is not None else c.poses
        offset = c.start_frame if track is not None else 0
        for k in c.controls:
            if k.kind != "pose" or k.stroke_frame is None:
                continue
            g = library.get(k.name)
            opts = k.options or {}
            clip = g.clip(speed=opts.get("speed", 1), flip=bool(opts.get("flip")), hold=float(opts.get("hold", 0.0)))
            frame = offset + k.stroke_frame
            where = f"{c.speaker}: '{c.text[:40]}' [pose:{k.name}] (line {k.line})"
            if not 0 <= frame < len(poses):
                problems.append(f"{where}: stroke frame {frame} outside the track")
                continue
            off = bone_angles(poses[frame], clip.poses[clip.stroke_frame])[np.asarray(clip.bones, bool)]
            if off.max(initial=0.0) > MAX_STROKE_DEG:
                problems.append(f"{where}: stroke {off.max():.1f} degrees from its pose at frame {frame}")
            late = k.stroke_frame - k.word_frame
            if abs(late) > MAX_LATE and (warned is None or (k.line, k.col) not in warned):
                problems.append(f"{where}: stroke {late:+d} frames from its word, with no warning")
    for t in tracks:
        turns = bone_angles(t.poses[1:], t.poses[:-1])
        if len(turns) and turns.max() * FPS > MAX_DEG_PER_S:
            f, b = np.unravel_index(int(turns.argmax()), turns.shape)
            problems.append(f"{t.speaker}: bone {b} turns {turns.max() * FPS:.0f} deg/s at frame {f + 1}")
        hand = hand_turns(t) if hands else None
        if hand is not None and len(hand) and hand.max() > MAX_HAND_TURN:
            f = int(hand.max(axis=1).argmax())
            problems.append(f"{t.speaker}: a hand turns {hand.max():.0f} degrees at frame {f + 1}")
    return problems


def hand_turns(track) -> np.ndarray | None:
    """Degrees each hand turns between frames relative to its forearm, (T-1, 2): the hand as
    renders and exports draw it (:func:`core.hands.hand_positions`: its frame from the wrist,
    the middle finger's knuckle and the knuckles' line), less what the forearm's own swing
    carries (the previous frame's hand turned by the least rotation from the previous forearm
    direction to this one). A hand that flips about its forearm, or a wrist that snaps from
    one bend to the other, turns by that much; an arm swinging fast carries its hand along."""
    from core.hands import HAND_JOINTS, SIDES, hand_positions
    from core.skeleton import JOINT_INDEX, positions_from_pose

    if track.hands is None:
        return None
    pos = positions_from_pose(track.poses)
    joints = hand_positions(pos, track.hands)  # (T, 2, 20, 3)
    k = {name: i for i, name in enumerate(HAND_JOINTS)}
    out = []
    for s, side in enumerate(SIDES):
        wrist = pos[:, JOINT_INDEX[f"{side}_wrist"]]
        along = _unit(joints[:, s, k["middle_mcp"]] - wrist)
        across = joints[:, s, k["index_mcp"]] - joints[:, s, k["little_mcp"]]
        across = _unit(across - np.sum(across * along, -1, keepdims=True) * along)
        r = np.stack([across, along, np.cross(across, along)], axis=-1)  # (T, 3, 3)
        forearm = _unit(wrist - pos[:, JOINT_INDEX[f"{side}_elbow"]])
        carried = _least_rotation(forearm[:-1], forearm[1:]) @ r[:-1]
        rel = np.einsum("tji,tjk->tik", carried, r[1:])
        cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)
        out.append(np.degrees(np.arccos(cos)))
    return np.stack(out, axis=1)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _least_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotations (n, 3, 3) of least angle taking unit vectors ``a`` to ``b`` (n, 3) (Rodrigues)."""
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)
    k = np.zeros(a.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    k[..., 1, 0], k[..., 2, 0], k[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return np.eye(3) + k + (k @ k) / (1.0 + np.maximum(c, -1.0 + 1e-9))[..., None, None]


# -- the scripts ---------------------------------------------------------------------------------

#: Written by hand: the cases of issue 22 and a few scenes.
HAND_WRITTEN = [
    # the fitness coach: lines opening with gestures, fast styles, back-to-back strokes
    "coach: Good morning everyone, let us start. [pose:wave] Hello!\n"
    "coach: [pose:rise x2] Now raise your arms up high.\n"
    "coach: <speed:+3 space:+2>[pose:clap x2] Alright team!</speed> [pose:point_front] You can do it.\n"
    "coach: [pose:count_one x2] One, [pose:count_two x2] two, [pose:count_three x2] three, [pose:count_four x2] four!\n"
    "coach: [pose:stop] Stop. [pose:calm_down] Breathe slowly. [pose:open_arms] And relax.\n"
    "coach: <speed:+3>[pose:fist_pump x3] Yes! [pose:celebrate x2] Great work!</speed>\n",
    "guide: Today we cover [pose:count_one x2] one, [pose:count_two x2] two, [pose:count_three x2] three topics.\n",
    "guide: Look [pose:point_left x3] [pose:point_right x3] there.\n",
    "guide: Welcome! [pose:open_arms] Look at the shelf [pose:point_right x2] <speed:-1>over there</speed>.\n"
    "visitor: [pose:nod] Thanks! [pose:thumbs_up] Great.\n"
    "guide: [pose:wave] Goodbye, and [pose:bow] come back soon.\n",
    "a: [pose:stop] No. [pose:head_shake] No, no. [pose:dismiss x2] Go away.\nb: [pose:shrug x2] Fine.\n"
    "a: [pose:point_self] Me? [pose:point_front] You!\n",
    "host: [pose:welcome] Welcome to the show. [pose:hands_together x2] Tonight [pose:timeline] we travel through time.\n"
    "guest: [pose:hand_on_heart] I am honoured. [pose:weigh] It is a big question, [pose:think] let me think.\n",
]

SENTENCES = ("the market opens early", "we walk along the river", "this is the old tower", "look at the bright lanterns",
             "our friends are waiting near the gate", "bread and coins and a sword", "the road goes north", "slowly now",
             "every morning the bells ring", "quickly, before the rain comes", "thank you so much", "here and there")
STYLES = ("<speed:+3 space:+2>", "<speed:+2>", "<speed:-2>", "<space:+2>", "<handedness:-1>", "<happy>", "<calm>", "<angry>")


def generated(n: int, seed: int = 22) -> list[str]:
    """``n`` scripts made by a seeded generator: back-to-back gestures, lines that open with a
    gesture, fast style spans, counted lists, two or three speakers."""
    from library import load_library

    names = sorted(load_library(use_config=False).names())
    counts = ["count_one", "count_two", "count_three", "count_four", "count_five"]
    rng = random.Random(seed)
    out = []
    for _ in range(n):
        speakers = rng.sample(["guide", "visitor", "knight", "merchant", "coach"], rng.randint(1, 3))
        lines = []
        for _ in range(rng.randint(2, 5)):
            words = rng.choice(SENTENCES).split()
            kind = rng.random()
            parts = []
            if kind < 0.25:  # a counted list
                k = rng.randint(2, 5)
                speed = rng.choice(["", " x2", " x3"])
                parts = [f"[pose:{counts[i]}{speed}] {w}," for i, w in enumerate(["one", "two", "three", "four", "five"][:k])]
                parts.append(rng.choice(SENTENCES))
            else:
                for i, w in enumerate(words):
                    if rng.random() < (0.45 if kind < 0.7 else 0.25) or (i == 0 and rng.random() < 0.5):
                        opts = rng.choice(["", " x2", " x3", " flip", " x2 flip", " hold=300ms"])
                        parts.append(f"[pose:{rng.choice(names)}{opts}]")
                    parts.append(w)
                if rng.random() < 0.3:
                    style = rng.choice(STYLES)
                    at = rng.randrange(len(parts))
                    parts.insert(at, style)
            lines.append(f"{rng.choice(speakers)}: {' '.join(parts)}.")
        out.append("\n".join(lines) + "\n")
    return out


def scripts(n_generated: int = 200) -> list[tuple[str, str]]:
    """(name, text) of the scripts the stroke test runs: the examples, the hand-written ones,
    ``n_generated`` generated ones."""
    out = [(p.name, p.read_text(encoding="utf-8")) for p in sorted((ROOT / "examples").glob("*.sgt"))]
    out += [(f"hand-{i}", text) for i, text in enumerate(HAND_WRITTEN)]
    out += [(f"gen-{i}", text) for i, text in enumerate(generated(n_generated))]
    return out


def warned_marks(diagnostics) -> set:
    """(line, col) of the pose marks the SGT401 warnings are about."""
    return {(d.line, d.col) for d in diagnostics if d.code == "SGT401"}


