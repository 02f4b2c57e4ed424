"""Do listeners move? Head, wrists, spine and hands of each speaker while the other one talks.

Generates a two-speaker dialogue (by default the one below; or a script file) ``--seeds`` times
with an engine (default: the default engine) and measures, over every speaker's **listening**
frames (its track's frames farther than one second from its own lines), against its own
**speaking** frames (inside its lines' words) and against :func:`model.performance.idle`
**alone** on the same frames (the teacher's idle layer with nods after accented words, with
relaxed hands that do not move; the ground the listening motion is made on):

- head: angular speed of the head (the nose bone, degrees/s), mean and 95th percentile;
- wrists: speed (mean of both, m/s), mean and p95;
- spine: angular speed of the spine bone (degrees/s), mean and p95;
- shoulders: the range of their height (mm; breathing), median over 4-s windows;
- fingers: angular speed of the finger joints (degrees/s), mean;
- nods and tilts per minute (:func:`head_events`), and the share of them that start within
  1.5 s after a phrase end of the other speaker (:func:`model.performance.phrase_ends`).

    python scripts/listening_check.py [FILE.sgt] [--engine NAME] [--seeds N] [--json FILE]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

SCRIPT = """\
guide: Welcome to the museum. This morning we start in the great hall, where the old ships are kept,
  and then we walk up to the gallery on the second floor, the one with the maps.
visitor: That sounds wonderful. How long does the whole tour take, more or less?
guide: About an hour and a half, if nobody gets lost. There is a cafe by the entrance, and the
  shop is open until six, so you will have time for both after we finish.
visitor: Perfect. And can we take photographs inside, or is that not allowed?
guide: You can take photographs everywhere except in the map room. The light damages the paper,
  so please keep your flash off, and enjoy the tour.
visitor: Thank you, we will. Let us go and see the ships first.
"""
#: Frames of a track nearer its own lines than this are neither listening nor speaking.
MARGIN_S = 1.0
#: A nod: the head's pitch at least NOD_MIN degrees below its centred 1.2-s mean (a local minimum);
#: a tilt: its roll at least TILT_MIN degrees off its centred 4-s mean (a local extremum).
NOD_MIN = 3.0
TILT_MIN = 3.0
#: A nod or tilt "answers" a phrase end that ended at most this long before it started.
ANSWER_WINDOW_S = 1.5


def head_angles(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(pitch, roll) degrees per frame: the nose bone's pitch (:func:`model.face.head_angles`)
    and the head_top bone's sideways lean."""
    from core.skeleton import BONE_INDEX
    from model.face import head_angles as yaw_pitch

    d = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)[:, BONE_INDEX["head_top"]]
    return yaw_pitch(poses)[:, 1], np.degrees(np.arctan2(d[:, 0], d[:, 1]))


def _extrema(x: np.ndarray, order: int) -> np.ndarray:
    pad = np.concatenate([np.full(order, np.inf), x, np.full(order, np.inf)])
    window = np.lib.stride_tricks.sliding_window_view(pad, 2 * order + 1)
    return np.flatnonzero(window.argmin(1) == order)


def head_events(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frames of nods and of tilts of ``poses`` (see :data:`NOD_MIN`, :data:`TILT_MIN`)."""
    from core.skeleton import FPS
    from model.postprocess import gauss_smooth

    pitch, roll = head_angles(poses)
    dip = pitch - gauss_smooth(pitch, 0.6 * FPS)
    nods = [t for t in _extrema(dip, 3) if dip[t] <= -NOD_MIN]
    lean = np.abs(roll - gauss_smooth(roll, 2.0 * FPS))
    tilts = [t for t in _extrema(-lean, 7) if lean[t] >= TILT_MIN]
    return np.asarray(nods, np.int64), np.asarray(tilts, np.int64)


def bone_speed(poses: np.ndarray, bone: str) -> np.ndarray:
    """(T,) degrees per second of one bone's direction (frame t: the turn into it; frame 0 reads 0)."""
    from core.skeleton import BONE_INDEX, FPS

    d = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)[:, BONE_INDEX[bone]]
    cos = np.clip((d[1:] * d[:-1]).sum(-1), -1.0, 1.0)
    return np.r_[0.0, np.degrees(np.arccos(cos)) * FPS]


def frame_masks(plan, speaker) -> tuple[np.ndarray, np.ndarray]:
    """(listening, speaking) frame masks of ``speaker``'s track (see the module's docstring)."""
    from core.skeleton import FPS

    n = plan.n_frames
    near, speaking = np.zeros(n, bool), np.zeros(n, bool)
    margin = int(MARGIN_S * FPS)
    t = np.arange(n) / FPS
    for u in plan.utterances:
        if u.speaker != speaker:
            continue
        near[max(0, u.start_frame - margin): u.start_frame + u.n_frames + margin] = True
        for w in u.words:
            speaking |= (t >= u.start + w.start) & (t < u.start + w.end)
    return ~near, speaking


def figures(poses: np.ndarray, fingers: np.ndarray, mask: np.ndarray, answers: np.ndarray) -> dict:
    """The figures of one track's frames ``mask`` (see the module's docstring)."""
    from core.skeleton import FPS, JOINT_INDEX, positions_from_pose

    pos = positions_from_pose(poses)
    wrists = pos[:, [JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"]]]
    wrist = np.r_[0.0, np.linalg.norm(np.diff(wrists, axis=0), axis=-1).mean(-1) * FPS]
    finger = np.r_[0.0, np.abs(np.diff(fingers.reshape(len(fingers), -1), axis=0)).mean(-1) * FPS]
    shoulders = pos[:, [JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]], 1].mean(-1)
    window = 4 * FPS
    ranges = [np.ptp(shoulders[a: a + window]) for a in range(0, len(poses) - window + 1, window)
              if mask[a: a + window].all()]
    nods, tilts = head_events(poses)
    nods, tilts = nods[mask[nods]], tilts[mask[tilts]]
    events = np.concatenate([nods, tilts])
    answered = sum(1 for f in events if ((f / FPS - answers >= 0) & (f / FPS - answers <= ANSWER_WINDOW_S)).any())
    head, spine = bone_speed(poses, "nose")[mask], bone_speed(poses, "neck")[mask]
    w = wrist[mask]
    minutes = mask.sum() / FPS / 60
    return {"head_mean": float(head.mean()), "head_p95": float(np.percentile(head, 95)),
            "wrist_mean": float(w.mean()), "wrist_p95": float(np.percentile(w, 95)),
            "spine_mean": float(spine.mean()), "spine_p95": float(np.percentile(spine, 95)),
            "shoulders_mm": float(1000 * np.median(ranges)) if ranges else float("nan"),
            "fingers_mean": float(finger[mask].mean()),
            "nods_per_min": len(nods) / minutes, "tilts_per_min": len(tilts) / minutes,
            "answering": answered / len(events) if len(events) else float("nan"), "frames": int(mask.sum())}


def measure(path: Path, *, engine: str | None = None, seeds: int = 3) -> dict:
    """Listening, ``idle`` alone and speaking figures, pooled per kind over speakers and seeds
    (the mean of each figure over the tracks, weighted by their frames)."""
    from model.generate import DEFAULT_ENGINE, generate
    from model.performance import accents, idle, phrase_ends

    engine = engine or DEFAULT_ENGINE
    rows: dict[str, list] = {"listening": [], "idle": [], "speaking": []}
    for seed in range(seeds):
        take = generate(path, engine=engine, seed=seed)
        plan = take.plan
        for k, track in enumerate(take.tracks):
            listen, speak = frame_masks(plan, track.speaker)
            answers = np.asarray(phrase_ends(plan, track.speaker))
            rows["listening"].append(figures(track.poses, track.hands.fingers, listen, answers))
            rows["speaking"].append(figures(track.poses, track.hands.fingers, speak, answers))
            before = idle(plan.n_frames, accents(plan, track.speaker), np.random.default_rng([seed, k]))
            rest = np.repeat(track.hands.fingers[:1] * 0, plan.n_frames, axis=0)  # relaxed, still
            rows["idle"].append(figures(before, rest, listen, answers))
    out = {}
    for kind, figs in rows.items():
        out[kind] = {key: _pooled([f[key] for f in figs], [f["frames"] for f in figs]) for key in figs[0] if key != "frames"}
        out[kind]["frames"] = int(sum(f["frames"] for f in figs))
    out.update(engine=engine, seeds=seeds)
    return out


def _pooled(values, weights) -> float:
    """The mean of ``values`` weighted by ``weights``, leaving out the ones that are NaN."""
    v, w = np.asarray(values, np.float64), np.asarray(weights, np.float64)
    ok = np.isfinite(v) & (w > 0)
    return float((v[ok] * w[ok]).sum() / w[ok].sum()) if ok.any() else float("nan")


COLUMNS = (("head_mean", "head deg/s", 1), ("head_p95", "p95", 1), ("wrist_mean", "wrist m/s", 3),
           ("wrist_p95", "p95", 3), ("spine_mean", "spine deg/s", 2), ("spine_p95", "p95", 2),
           ("shoulders_mm", "breath mm", 1), ("fingers_mean", "fingers deg/s", 1),
           ("nods_per_min", "nods/min", 1), ("tilts_per_min", "tilts/min", 1), ("answering", "at phrase ends", 2))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("script", nargs="?", help="a .sgt script with two or more speakers (default: the one above)")
    ap.add_argument("--engine", help="the engine (default: the default engine)")
    ap.add_argument("--seeds", type=int, default=3, help="takes (default 3)")
    ap.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(args.script) if args.script else Path(tmp) / "dialogue.sgt"
        if not args.script:
            path.write_text(SCRIPT, encoding="utf-8")
        result = measure(path, engine=args.engine, seeds=args.seeds)
    widths = [max(7, len(title)) for _, title, _ in COLUMNS]
    print(f"{'':10}" + " ".join(f"{title:>{w}}" for (_, title, _), w in zip(COLUMNS, widths)))
    for kind in ("listening", "idle", "speaking"):
        r = result[kind]
        print(f"{kind:10}" + " ".join(f"{r[key]:{w}.{d}f}" for (key, _, d), w in zip(COLUMNS, widths)))
    print(f"({args.seeds} takes, {result['engine']}; listening {result['listening']['frames']} frames, "
          f"speaking {result['speaking']['frames']})")
    if args.json:
        import json

        from core.fileio import atomic_write_text

        atomic_write_text(Path(args.json), json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
