"""The face's files: a Live Link Face CSV, ARKit weights (CSV, NPZ, JSON), and the face as VRM
expressions (one place for the ARKit -> VRM mapping, which the ``.vrma`` writer uses).

Every file holds one clip's face (a speaker's track, or an utterance) at 15 fps from the clip's
frame 0 (numpy only; see docs/formats.md, *The face*).

**Live Link Face CSV** (:func:`livelink_csv`), the recording format of Epic's Live Link Face app
that Unreal's LiveLinkFaceImporter turns into a Level Sequence: a header ``Timecode,
BlendShapeCount``, the 52 blendshapes with capitalised first letters in the app's column order
(:data:`LIVE_LINK_ORDER`: ARKit's, except ``JawRight`` before ``JawLeft`` and ``MouthRight`` before
``MouthLeft``, as the app writes them), then ``HeadYaw, HeadPitch, HeadRoll, LeftEyeYaw,
LeftEyePitch, LeftEyeRoll, RightEyeYaw, RightEyePitch, RightEyeRoll``; one row per frame: the
timecode ``HH:MM:SS:FF.mmm``, 61, the values. The importer reads the timecode's frame field in
60ths of a second (the app records at 60 fps), so frame i (at i / 15 s) is written with its
whole seconds and ``FF = 4 * (i % 15)``, ``.000``. Angles in radians (:func:`head_angles`).

**VRM expressions** (:func:`vrm_expressions`): the 17 preset expressions of VRM 1.0 that a face
drives, each a weight 0..1 per frame:

- ``aa, ih, ou, ee, oh`` (visemes) and ``happy, angry, sad, relaxed, surprised`` (emotions) are
  fitted together: per frame, the weights (each 0..1) whose ARKit pictures best rebuild the
  frame's blendshapes, blinks and eye turns left out (least squares, :func:`_fit`). The pictures
  are the face's own: the vowels of :data:`model.face.VISEMES` (``aa``, ``I``, ``U``, ``E``, ``O``;
  :data:`VRM_VISEMES`) and the expressions of :data:`core.face.EXPRESSIONS` (``happy``,
  ``angry``, ``sad``, ``calm`` for relaxed, ``surprised``; :data:`VRM_EMOTIONS`);
- ``blink`` both eyes' common closure (the lesser ``eyeBlink``), ``blinkLeft``/``blinkRight`` what
  one eye closes beyond it;
- ``lookLeft/Right/Up/Down`` the gaze of both eyes (their mean) over the eyes' reach
  (:data:`core.face.EYE_YAW_LIMIT`, ``EYE_UP_LIMIT``, ``EYE_DOWN_LIMIT``).
"""

from __future__ import annotations

import io
import json

import numpy as np

from core.face import (ARKIT_INDEX, ARKIT_NAMES, EYE_DOWN_LIMIT, EYE_UP_LIMIT, EYE_YAW_LIMIT, EYES, N_BLENDSHAPES,
                       FaceTrack, blendshapes, expression_weights)
from core.motion import MotionClip
from core.skeleton import FPS, REST_POSE, positions_from_pose
from model.face import VISEMES
from renders.face_rig import head_frames

#: What ``sgt export --face`` writes, and the types of file each comes in.
FACE_KINDS = {"livelink": ("csv",), "arkit": ("csv", "npz", "json")}

#: The 52 blendshapes in the order the Live Link Face app writes its columns.
LIVE_LINK_ORDER: tuple[str, ...] = tuple(
    {"jawLeft": "jawRight", "jawRight": "jawLeft", "mouthLeft": "mouthRight", "mouthRight": "mouthLeft"}.get(n, n)
    for n in ARKIT_NAMES)
#: The head's and eyes' angles after the blendshapes (radians).
LIVE_LINK_ANGLES = ("HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll",
                    "RightEyeYaw", "RightEyePitch", "RightEyeRoll")
LIVE_LINK_HEADER: tuple[str, ...] = ("Timecode", "BlendShapeCount",
                                     *(n[0].upper() + n[1:] for n in LIVE_LINK_ORDER), *LIVE_LINK_ANGLES)
#: The BlendShapeCount column: the 52 blendshapes and the 9 angles.
BLENDSHAPE_COUNT = N_BLENDSHAPES + len(LIVE_LINK_ANGLES)
#: The timecode's frame field counts 60ths of a second (the app's rate; Unreal's importer divides by 60).
TIMECODE_RATE = 60

#: The VRM 1.0 preset expressions a face drives, in the order the ``.vrma`` lists them.
VRM_EXPRESSIONS = ("aa", "ih", "ou", "ee", "oh", "blink", "blinkLeft", "blinkRight", "happy", "angry", "sad",
                   "relaxed", "surprised", "lookUp", "lookDown", "lookLeft", "lookRight")
#: VRM's visemes and the vowel classes of :data:`model.face.VISEMES` that picture them.
VRM_VISEMES = {"aa": "aa", "ih": "I", "ou": "U", "ee": "E", "oh": "O"}
#: VRM's emotions and the expressions of :data:`core.face.EXPRESSIONS` that picture them.
VRM_EMOTIONS = {"happy": "happy", "angry": "angry", "sad": "sad", "relaxed": "calm", "surprised": "surprised"}


# -- VRM expressions -----------------------------------------------------------------------------

def _fitted_channels() -> np.ndarray:
    """The blendshapes the fit rebuilds: all but the blinks and the eyes' turns."""
    return np.array([i for i, n in enumerate(ARKIT_NAMES) if not n.startswith(("eyeBlink", "eyeLook"))])


def _fit(weights: np.ndarray, shapes: np.ndarray, iterations: int = 300) -> np.ndarray:
    """Per frame the x in [0, 1]^K that minimises |x @ shapes - weights|^2 (weights (T, C),
    shapes (K, C)): accelerated projected gradient on the K x K normal equations."""
    gram = shapes @ shapes.T
    target = weights @ shapes.T  # (T, K)
    step = 1.0 / max(float(np.linalg.eigvalsh(gram).max()), 1e-9)
    x = y = np.zeros_like(target)
    t = 1.0
    for _ in range(iterations):
        x_next = np.clip(y - step * (y @ gram - target), 0.0, 1.0)
        t_next = (1 + np.sqrt(1 + 4 * t * t)) / 2
        y = x_next + ((t - 1) / t_next) * (x_next - x)
        x, t = x_next, t_next
    return x


def vrm_expressions(face: FaceTrack) -> dict[str, np.ndarray]:
    """The face as VRM 1.0 preset expressions: name -> weights (T,) in [0, 1] (the module's
    docstring says how)."""
    w = np.clip(np.asarray(face.weights, np.float64), 0.0, 1.0)
    names = list(VRM_VISEMES) + list(VRM_EMOTIONS)
    shapes = np.stack([blendshapes(VISEMES[v]) for v in VRM_VISEMES.values()]
                      + [expression_weights(e) for e in VRM_EMOTIONS.values()]).astype(np.float64)
    cols = _fitted_channels()
    fitted = _fit(w[:, cols], shapes[:, cols])
    out = {name: fitted[:, k] for k, name in enumerate(names)}
    left, right = w[:, ARKIT_INDEX["eyeBlinkLeft"]], w[:, ARKIT_INDEX["eyeBlinkRight"]]
    both = np.minimum(left, right)
    out.update(blink=both, blinkLeft=left - both, blinkRight=right - both)
    yaw, pitch = np.mean(face.gaze[:, :, 0], axis=1), np.mean(face.gaze[:, :, 1], axis=1)
    out.update(lookLeft=np.clip(yaw / EYE_YAW_LIMIT, 0, 1), lookRight=np.clip(-yaw / EYE_YAW_LIMIT, 0, 1),
               lookUp=np.clip(pitch / EYE_UP_LIMIT, 0, 1), lookDown=np.clip(-pitch / EYE_DOWN_LIMIT, 0, 1))
    return {name: np.round(out[name], 4).astype(np.float32) for name in VRM_EXPRESSIONS}


# -- the head's angles ---------------------------------------------------------------------------

def head_angles(positions) -> np.ndarray:
    """The head's turn from its rest (T, 3): yaw, pitch, roll in radians, in the character's
    frame (it stands facing +z). The turn is taken as yaw about the vertical, then pitch about the
    turned left-right axis, then roll about the face's forward axis. Yaw is positive to the
    character's left, pitch positive up (sgt's gaze convention), roll positive with the head
    tilted towards its right shoulder."""
    rot, _ = head_frames(positions)
    rest, _ = head_frames(positions_from_pose(REST_POSE[None]))
    r = rot @ rest[0].T  # world turn from the rest head to this frame's
    yaw = np.arctan2(r[:, 0, 2], r[:, 2, 2])
    pitch_down = np.arcsin(np.clip(-r[:, 1, 2], -1.0, 1.0))
    roll = np.arctan2(r[:, 1, 0], r[:, 1, 1])
    return np.stack([yaw, -pitch_down, roll], axis=-1)


# -- files ---------------------------------------------------------------------------------------

def _face_of(clip: MotionClip) -> FaceTrack:
    if clip.face is None:
        raise ValueError("the clip has no face")
    return clip.face


def livelink_timecode(frame: int) -> str:
    """``HH:MM:SS:FF.mmm`` of 15 fps ``frame`` with FF in 60ths of a second (:data:`TIMECODE_RATE`)."""
    seconds, sub = divmod(int(frame), FPS)
    minutes, s = divmod(seconds, 60)
    h, m = divmod(minutes, 60)
    return f"{h:02d}:{m:02d}:{s:02d}:{sub * TIMECODE_RATE // FPS:02d}.000"


def livelink_csv(clip: MotionClip) -> str:
    """The Live Link Face CSV of ``clip``'s face and head (see the module's docstring)."""
    face = _face_of(clip)
    order = [ARKIT_INDEX[n] for n in LIVE_LINK_ORDER]
    head = head_angles(clip.positions)
    eyes = np.radians(face.gaze.astype(np.float64))
    lines = [",".join(LIVE_LINK_HEADER)]
    for i in range(face.n_frames):
        values = [*face.weights[i, order], *head[i], eyes[i, 0, 0], eyes[i, 0, 1], 0.0, eyes[i, 1, 0], eyes[i, 1, 1], 0.0]
        lines.append(f"{livelink_timecode(i)},{BLENDSHAPE_COUNT}," + ",".join(f"{v:.6f}" for v in values))
    return "\n".join(lines) + "\n"


#: The gaze columns of the ARKit files (degrees; yaw positive to the character's left, pitch up).
GAZE_COLUMNS = tuple(f"{eye}Eye{a}" for eye in EYES for a in ("Yaw", "Pitch"))


def arkit_csv(clip: MotionClip, utterances) -> str:
    """``frame,time,utterance``, the 52 weights under their ARKit names, then ``leftEyeYaw,
    leftEyePitch, rightEyeYaw, rightEyePitch`` in degrees; one row per frame (``utterance`` empty
    between a speaker's lines)."""
    face = _face_of(clip)
    lines = [",".join(("frame", "time", "utterance", *ARKIT_NAMES, *GAZE_COLUMNS))]
    for i in range(face.n_frames):
        u = utterances[i] if i < len(utterances) else None
        lines.append(f"{i},{i / FPS:.6f},{'' if u is None else u},"
                     + ",".join(f"{v:.3f}" for v in face.weights[i])
                     + "," + ",".join(f"{v:.2f}" for v in face.gaze[i].reshape(-1)))
    return "\n".join(lines) + "\n"


def _utterance_array(utterances, n: int) -> np.ndarray:
    return np.array([-1 if i >= len(utterances) or utterances[i] is None else utterances[i] for i in range(n)], np.int32)


def arkit_npz_bytes(clip: MotionClip, utterances) -> bytes:
    """A compressed NumPy archive: ``weights`` (T, 52), ``names`` (52,), ``gaze`` (T, 2, 2) degrees,
    ``eyes``, ``fps``, ``time`` (T,) and ``utterance`` (T,; -1 between lines)."""
    face = _face_of(clip)
    buf = io.BytesIO()
    np.savez_compressed(buf, weights=face.weights.astype(np.float32), names=np.array(ARKIT_NAMES),
                        gaze=face.gaze.astype(np.float32), eyes=np.array(EYES), fps=np.int32(FPS),
                        time=(np.arange(face.n_frames) / FPS).astype(np.float32),
                        utterance=_utterance_array(utterances, face.n_frames))
    return buf.getvalue()


def arkit_json_bytes(clip: MotionClip, utterances) -> bytes:
    """``{"format": "sgt-arkit", "version": 1, "fps", "frames", "speaker", "names", "eyes",
    "utterance", "weights", "gaze"}``, one frame per line of ``weights`` and ``gaze``."""
    face = _face_of(clip)
    n = face.n_frames
    head = {"format": "sgt-arkit", "version": 1, "fps": FPS, "frames": n, "speaker": clip.speaker,
            "names": list(ARKIT_NAMES), "eyes": list(EYES), "gaze_units": "degrees (yaw to the character's left, pitch up)",
            "utterance": [None if i >= len(utterances) else utterances[i] for i in range(n)]}
    text = json.dumps(head, indent=1)[:-2]  # reopen the object for the per-frame arrays
    rows = lambda a, d: ",\n".join("  " + json.dumps(np.round(r.astype(np.float64), d).tolist()) for r in a)  # noqa: E731
    text += ',\n "weights": [\n' + rows(face.weights, 3) + '\n ],\n "gaze": [\n' + rows(face.gaze, 2) + "\n ]\n}\n"
    return text.encode("utf-8")


def face_bytes(clip: MotionClip, kind: str, fmt: str, utterances) -> bytes:
    """The face file ``kind`` (:data:`FACE_KINDS`) as ``fmt`` for ``clip``."""
    if fmt not in FACE_KINDS[kind]:
        raise ValueError(f"--face {kind} writes {', '.join(FACE_KINDS[kind])}, not {fmt}")
    if kind == "livelink":
        return livelink_csv(clip).encode("utf-8")
    if fmt == "csv":
        return arkit_csv(clip, utterances).encode("utf-8")
    if fmt == "npz":
        return arkit_npz_bytes(clip, utterances)
    return arkit_json_bytes(clip, utterances)
