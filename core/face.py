"""The face: a layer beside the body and the hands (numpy only).

The body stays the 27 numbers of :mod:`core.skeleton` (the head's turn is in it) and the hands
are :mod:`core.hands`. A *face track* holds, per frame:

- ``weights`` (T, 52): the ARKit blendshape weights in [0, 1], in :data:`ARKIT_NAMES` order
  (Apple's ARFaceAnchor.BlendShapeLocation, the order Unreal's Live Link Face records);
- ``gaze`` (T, 2, 2): per eye (:data:`EYES`: left, right) its yaw and pitch in degrees relative
  to the head (yaw positive to the character's left, pitch positive up). The ``eyeLook*``
  weights say the same thing as blendshapes; both are kept in step by whoever makes the track.

:meth:`FaceTrack.neutral` is a resting face (everything 0, eyes ahead).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The 52 ARKit blendshapes, in ARKit's (and Live Link Face's) order.
ARKIT_NAMES: tuple[str, ...] = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft", "eyeSquintLeft",
    "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight", "eyeLookOutRight", "eyeLookUpRight",
    "eyeSquintRight", "eyeWideRight", "jawForward", "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel",
    "mouthPucker", "mouthLeft", "mouthRight", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft", "mouthFrownRight",
    "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft", "mouthStretchRight", "mouthRollLower", "mouthRollUpper",
    "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft", "mouthPressRight", "mouthLowerDownLeft",
    "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp",
    "browOuterUpLeft", "browOuterUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft",
    "noseSneerRight", "tongueOut",
)
ARKIT_INDEX = {name: i for i, name in enumerate(ARKIT_NAMES)}
N_BLENDSHAPES = len(ARKIT_NAMES)
EYES: tuple[str, ...] = ("left", "right")


@dataclass
class FaceTrack:
    """Blendshape weights (T, 52) and gaze (T, 2, 2): see the module's docstring."""

    weights: np.ndarray
    gaze: np.ndarray

    def __post_init__(self) -> None:
        self.weights = np.asarray(self.weights, dtype=np.float32)
        self.gaze = np.asarray(self.gaze, dtype=np.float32)
        if self.weights.ndim != 2 or self.weights.shape[1] != N_BLENDSHAPES:
            raise ValueError(f"face weights must be (frames, {N_BLENDSHAPES}), got {self.weights.shape}")
        if self.gaze.shape != (self.weights.shape[0], 2, 2):
            raise ValueError(f"face gaze must be (frames, 2, 2), got {self.gaze.shape}")

    @property
    def n_frames(self) -> int:
        return int(self.weights.shape[0])

    @classmethod
    def neutral(cls, n_frames: int) -> FaceTrack:
        return cls(np.zeros((n_frames, N_BLENDSHAPES), np.float32), np.zeros((n_frames, 2, 2), np.float32))

    def weight(self, name: str) -> np.ndarray:
        """The weights (T,) of one blendshape by its ARKit name."""
        return self.weights[:, ARKIT_INDEX[name]]

    def take(self, index) -> FaceTrack:
        """The frames ``index`` (a slice or an integer array)."""
        return FaceTrack(self.weights[index], self.gaze[index])

    #: Decimals kept in files: weights to 1e-3, gaze to 0.01 degree.
    DECIMALS = {"weights": 3, "gaze": 2}

    def to_dict(self) -> dict:
        return {"names": list(ARKIT_NAMES),
                **{key: np.round(getattr(self, key).astype(np.float64), d).tolist() for key, d in self.DECIMALS.items()}}

    @classmethod
    def from_dict(cls, d) -> FaceTrack:
        if not isinstance(d, dict) or "weights" not in d or "gaze" not in d:
            raise ValueError("face must be an object with 'weights' and 'gaze'")
        names = d.get("names", list(ARKIT_NAMES))
        weights = np.asarray(d["weights"], dtype=np.float32)
        if list(names) != list(ARKIT_NAMES):  # another order (or a subset): put them in ARKit's
            full = np.zeros((len(weights), N_BLENDSHAPES), np.float32)
            for j, name in enumerate(names):
                if name in ARKIT_INDEX:
                    full[:, ARKIT_INDEX[name]] = weights[:, j]
            weights = full
        return cls(weights, np.asarray(d["gaze"], dtype=np.float32))


#: Facial expressions (``<face:NAME>``; the built-in presets' in :data:`PRESET_EXPRESSIONS`):
#: blendshape weights added to the face while they last ("neutral" adds nothing: it ends an
#: outer span's expression). A name without a side stands for both (``mouthSmile``).
EXPRESSIONS: dict[str, dict[str, float]] = {
    "neutral": {},
    "smile": {"mouthSmile": 0.6, "cheekSquint": 0.5},
    "happy": {"mouthSmile": 0.8, "cheekSquint": 0.5, "eyeSquint": 0.3, "mouthDimple": 0.2, "browOuterUp": 0.15,
              "jawOpen": 0.2},
    "sad": {"mouthFrown": 0.5, "browInnerUp": 0.65, "mouthShrugLower": 0.3, "mouthPress": 0.1, "eyeBlink": 0.25},
    "angry": {"browDown": 0.75, "noseSneer": 0.3, "eyeSquint": 0.45, "mouthPress": 0.4, "mouthFrown": 0.25},
    "surprised": {"browInnerUp": 0.8, "browOuterUp": 0.8, "eyeWide": 0.7, "jawOpen": 0.35, "mouthFunnel": 0.15},
    "afraid": {"browInnerUp": 0.8, "browOuterUp": 0.2, "eyeWide": 0.6, "mouthStretch": 0.55, "jawOpen": 0.12},
    "disgusted": {"noseSneer": 0.7, "mouthUpperUp": 0.45, "browDown": 0.35, "cheekSquint": 0.45, "mouthFrown": 0.3},
    "calm": {"mouthSmile": 0.3, "eyeBlink": 0.55},
}
#: The expression a built-in style preset (``<happy>``) shows.
PRESET_EXPRESSIONS: dict[str, str] = {"happy": "happy", "sad": "sad", "angry": "angry", "calm": "calm"}

#: ``[look:NAME]`` directions: (yaw, pitch) in degrees from where the body faces (yaw positive
#: to the character's left, pitch positive up). Any other name is a speaker to look at.
LOOK_DIRECTIONS: dict[str, tuple[float, float]] = {
    "left": (25.0, 0.0), "right": (-25.0, 0.0), "up": (0.0, 15.0), "down": (0.0, -20.0), "ahead": (0.0, 0.0),
}

#: The eyes' reach from the head (degrees): sideways, up, down. An ``eyeLook*`` weight of 1 is
#: an eye turned that far; :func:`set_eye_looks` keeps the weights in step with the gaze.
EYE_YAW_LIMIT, EYE_UP_LIMIT, EYE_DOWN_LIMIT = 35.0, 20.0, 25.0


def blendshapes(values: dict[str, float]) -> np.ndarray:
    """(52,) weights from ``{name: weight}``, where a name without its side (``mouthSmile``)
    sets both (``mouthSmileLeft``, ``mouthSmileRight``)."""
    out = np.zeros(N_BLENDSHAPES, np.float32)
    for key, value in values.items():
        for full in ((key,) if key in ARKIT_INDEX else (key + "Left", key + "Right")):
            out[ARKIT_INDEX[full]] = value
    return out


def expression_weights(name: str) -> np.ndarray:
    """The (52,) weights :data:`EXPRESSIONS` gives ``name``."""
    return blendshapes(EXPRESSIONS[name])


def set_eye_looks(weights: np.ndarray, gaze: np.ndarray) -> None:
    """Set the eight ``eyeLook*`` weights of ``weights`` (T, 52) from ``gaze`` (T, 2, 2), in
    place: a left eye turned to the character's left looks *out*, a right eye *in*; up and
    down alike; a weight of 1 at :data:`EYE_YAW_LIMIT`, :data:`EYE_UP_LIMIT`, :data:`EYE_DOWN_LIMIT`."""
    gaze = np.asarray(gaze, np.float32)
    for e, eye in enumerate(("Left", "Right")):
        yaw, pitch = gaze[:, e, 0], gaze[:, e, 1]
        toward_left = np.clip(yaw / EYE_YAW_LIMIT, 0.0, 1.0)
        toward_right = np.clip(-yaw / EYE_YAW_LIMIT, 0.0, 1.0)
        weights[:, ARKIT_INDEX[f"eyeLookOut{eye}"]] = toward_left if eye == "Left" else toward_right
        weights[:, ARKIT_INDEX[f"eyeLookIn{eye}"]] = toward_right if eye == "Left" else toward_left
        weights[:, ARKIT_INDEX[f"eyeLookUp{eye}"]] = np.clip(pitch / EYE_UP_LIMIT, 0.0, 1.0)
        weights[:, ARKIT_INDEX[f"eyeLookDown{eye}"]] = np.clip(-pitch / EYE_DOWN_LIMIT, 0.0, 1.0)


def concat(tracks) -> FaceTrack:
    tracks = list(tracks)
    return FaceTrack(np.concatenate([t.weights for t in tracks]), np.concatenate([t.gaze for t in tracks]))
