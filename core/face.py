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


def concat(tracks) -> FaceTrack:
    tracks = list(tracks)
    return FaceTrack(np.concatenate([t.weights for t in tracks]), np.concatenate([t.gaze for t in tracks]))
