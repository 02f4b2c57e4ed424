"""The mannequin's face: parts placed by the 52 ARKit weights and the gaze (numpy only).

One face serves the preview (:mod:`renders.mannequin` draws its parts) and the glTF export
(:mod:`renders.gltf` turns each blendshape into a morph target of the same parts), so what a
``.glb`` shows in Blender or three.js is what ``sgt render`` shows.

Coordinates are the head's own (:func:`head_frames`): origin at the head's centre, x to the
character's **left**, y up, z forward (out of the face), metres. ARKit's ``Left`` is the
character's own left, so ``eyeBlinkLeft`` closes the eye on +x. Every part is a small mesh in its
own frame (:func:`part_meshes`) moved by an affine map per frame (:func:`part_transforms`):

- eyes: a white ball each, a dark pupil that turns with the gaze (yaw towards the character's
  left, pitch up, degrees; :data:`GAZE_GAIN` times for the picture) and shrinks as the eye widens;
- eyelids: an upper lid per eye, an ellipsoid that grows down over the ball as the eye closes
  (``eyeBlink``) and as the brow lowers (``browDown``: a glare), up off it with ``eyeWide``, and a
  lower lid that rises as it squints (``eyeSquint``, ``cheekSquint``: a smile's eyes);
- brows: a bar per side, level at rest as the cameras see it (its outer end lower on the head,
  where the forehead curves back), whose inner end rises with ``browInnerUp`` (a worried slant),
  outer end with ``browOuterUp``, and whose inner end drops and draws in with ``browDown`` (a V);
- mouth: a dark opening whose height follows ``jawOpen`` (and ``mouthLowerDown``,
  ``mouthUpperUp``, ``mouthFunnel``, ``mouthStretch``; ``mouthClose``, ``mouthPress`` and
  ``mouthRoll`` close it) and whose width narrows as it rounds (``mouthPucker``, ``mouthFunnel``)
  or presses and widens as it stretches or smiles; four lip bars from its middle to its corners,
  the corners up with a smile (a V), down with a frown or a stretch, a tongue that comes out with
  ``tongueOut``;
- a chin that drops with the jaw (``jawOpen``, ``jawForward``, ``jawLeft``/``Right``), cheeks that
  puff, a nose that sneers.

The parts are sized and their movements scaled to read at 320 px, where the head is about 50
pixels tall (a mouth 6 cm wide, eyes 5 cm, a smile that lifts the corners 2 cm, brows that rise
2.4 cm): a mannequin's face, not a person's. ``docs/face_expressions.png``
(:mod:`renders.face_sheet`) shows every expression at that size.
"""

from __future__ import annotations

import numpy as np

from core.face import ARKIT_INDEX, EYE_DOWN_LIMIT, EYE_UP_LIMIT, EYE_YAW_LIMIT, N_BLENDSHAPES
from core.skeleton import JOINT_INDEX as J

#: The head ellipsoid's half axes (x, y, z), metres (the mannequin's head).
HEAD_RADII = (0.092, 0.112, 0.102)
#: The preview turns the pupils this many times the gaze, so that a glance reads at 320 px.
GAZE_GAIN = 1.5

SKIN = (0.80, 0.62, 0.48)
LID = (0.68, 0.48, 0.37)
EYE_WHITE = (0.93, 0.93, 0.90)
PUPIL = (0.08, 0.09, 0.12)
BROW = (0.24, 0.16, 0.11)
MOUTH = (0.13, 0.02, 0.03)
LIP = (0.55, 0.17, 0.16)
TONGUE = (0.80, 0.36, 0.38)

_EYE_R = 0.024  # eyeball radius
_LID_R = 1.14 * _EYE_R  # over the ball and the pupil (1.05 radii) even between the coarse mesh's vertices (5 % in)
_EYE_AT = (0.039, 0.018)  # x (per side), y of the eye centres
_BROW_R = 0.0075
_LIP_R = 0.0050
_MOUTH_Y = -0.054
_MOUTH_HALF_WIDTH = 0.030
_BROW_INNER, _BROW_OUTER = 0.013, 0.064  # x of the brow's ends
_BROW_Y = 0.070  # the inner end's height at rest
_BROW_DROP = 0.010  # the outer end this much lower at rest
_BROW_INNER_UP, _BROW_OUTER_UP = 0.024, 0.020  # how far browInnerUp, browOuterUp raise the ends
_BROW_DOWN, _BROW_OUTER_DOWN, _BROW_KNIT = 0.024, 0.004, 0.008  # browDown: the inner end down and in, the outer a little
_LID_REST, _LID_LIFT = 0.14, 0.008  # the upper lid's height at rest; how far eyeWide lifts it off the ball
_LID_BROW_DOWN, _LOWER_LID_SQUINT = 0.30, 0.70  # how far browDown brings the upper lid down, a squint the lower lid up
_PUPIL_WIDE = 0.25  # a wide eye's pupil this much smaller
_CORNER_REST, _CORNER_SMILE, _CORNER_FROWN = 0.001, 0.030, 0.020  # the mouth's corners above its middle
_SMILE_LIFT = 0.33  # the share of a smile's rise that lifts the whole mouth (the rest: the corners above it)

#: The parts, in draw order: (name, shape, colour, roughness). Shapes: ``sphere`` (a unit
#: ball: its transform holds the radii) or ``capsule:R:H`` (a bar of radius R and half length H
#: along x, metres: its transform carries x to the bar's half extent).
PARTS: tuple[tuple[str, str, tuple, float], ...] = (
    ("eye_l", "sphere", EYE_WHITE, 0.35), ("eye_r", "sphere", EYE_WHITE, 0.35),
    ("pupil_l", "sphere", PUPIL, 0.3), ("pupil_r", "sphere", PUPIL, 0.3),
    ("lid_l", "sphere", LID, 0.6), ("lid_r", "sphere", LID, 0.6),
    ("lower_lid_l", "sphere", LID, 0.6), ("lower_lid_r", "sphere", LID, 0.6),
    ("brow_l", f"capsule:{_BROW_R}:{(_BROW_OUTER - _BROW_INNER) / 2}", BROW, 0.8),
    ("brow_r", f"capsule:{_BROW_R}:{(_BROW_OUTER - _BROW_INNER) / 2}", BROW, 0.8),
    ("mouth", "sphere", MOUTH, 0.5),
    ("tongue", "sphere", TONGUE, 0.5),
    ("lip_upper_l", f"capsule:{_LIP_R}:{_MOUTH_HALF_WIDTH / 2}", LIP, 0.5),
    ("lip_upper_r", f"capsule:{_LIP_R}:{_MOUTH_HALF_WIDTH / 2}", LIP, 0.5),
    ("lip_lower_l", f"capsule:{_LIP_R}:{_MOUTH_HALF_WIDTH / 2}", LIP, 0.5),
    ("lip_lower_r", f"capsule:{_LIP_R}:{_MOUTH_HALF_WIDTH / 2}", LIP, 0.5),
    ("chin", "sphere", SKIN, 0.6),
    ("cheek_l", "sphere", SKIN, 0.6), ("cheek_r", "sphere", SKIN, 0.6),
    ("nose", "sphere", SKIN, 0.6),
)
PART_INDEX = {name: i for i, (name, *_) in enumerate(PARTS)}


def surface_z(x: float, y: float) -> float:
    """z of the head ellipsoid's front at (x, y)."""
    a, b, c = HEAD_RADII
    return c * float(np.sqrt(max(0.0, 1.0 - (x / a) ** 2 - (y / b) ** 2)))


def _surface_slope(x: float, y: float) -> float:
    """dz/dy of the head ellipsoid's front at (x, y), over the span the brows move (2 cm down to 2 up)."""
    return (surface_z(x, y + 0.02) - surface_z(x, y - 0.02)) / 0.04


# -- meshes --------------------------------------------------------------------------------

def uv_sphere(rings: int = 8, segments: int = 14) -> tuple[np.ndarray, np.ndarray]:
    """A unit sphere: vertices (V, 3) (also its normals) and triangles (F, 3), counter-clockwise
    seen from outside."""
    verts = [(0.0, 1.0, 0.0)]
    for i in range(1, rings):
        phi = np.pi * i / rings
        for j in range(segments):
            theta = 2 * np.pi * j / segments
            verts.append((np.sin(phi) * np.sin(theta), np.cos(phi), np.sin(phi) * np.cos(theta)))
    verts.append((0.0, -1.0, 0.0))
    v = np.array(verts)
    last = len(verts) - 1
    ring = lambda i, j: 1 + (i - 1) * segments + (j % segments)  # noqa: E731
    tris = []
    for j in range(segments):
        tris.append((0, ring(1, j), ring(1, j + 1)))
        tris.append((last, ring(rings - 1, j + 1), ring(rings - 1, j)))
    for i in range(1, rings - 1):
        for j in range(segments):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)
            tris += [(a, c, b), (b, c, d)]
    return v, np.array(tris)


def _capsule(radius: float, half: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A bar along x: a sphere of ``radius`` cut at x = 0, its halves ``half`` apart each way."""
    v, f = uv_sphere(6, 8)
    v = v[:, [1, 2, 0]]  # the poles on +-x, keeping the winding (a cyclic swap of the axes)
    shift = np.where(v[:, :1] >= 0, half, -half) * np.array([1.0, 0.0, 0.0])
    return v * radius + shift, v, f


def part_meshes() -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per part of :data:`PARTS`: vertices, normals (in its own frame) and triangles. Coarse
    (100 triangles a ball, 80 a bar): a part is a few pixels across, and every triangle costs
    the software rasteriser time."""
    sphere, tris = uv_sphere(6, 10)
    out = []
    for _, shape, _, _ in PARTS:
        if shape == "sphere":
            out.append((sphere, sphere, tris))
        else:
            _, r, h = shape.split(":")
            out.append(_capsule(float(r), float(h)))
    return out


# -- placing the parts -----------------------------------------------------------------------

def _w(weights: np.ndarray, *names: str) -> np.ndarray:
    """The mean of the named weights (N,)."""
    return np.mean([weights[:, ARKIT_INDEX[n]] for n in names], axis=0)


def gaze_from_weights(weights) -> np.ndarray:
    """The gaze (N, 2, 2) in degrees that the eyeLook* weights say (a weight of 1: the eye's reach,
    :data:`core.face.EYE_YAW_LIMIT` and the others; the inverse of :func:`core.face.set_eye_looks`)."""
    w = np.atleast_2d(np.asarray(weights, np.float64))
    g = np.zeros((len(w), 2, 2))
    g[:, 0, 0] = (_w(w, "eyeLookOutLeft") - _w(w, "eyeLookInLeft")) * EYE_YAW_LIMIT
    g[:, 1, 0] = (_w(w, "eyeLookInRight") - _w(w, "eyeLookOutRight")) * EYE_YAW_LIMIT
    for e, side in enumerate(("Left", "Right")):
        g[:, e, 1] = _w(w, "eyeLookUp" + side) * EYE_UP_LIMIT - _w(w, "eyeLookDown" + side) * EYE_DOWN_LIMIT
    return g


def _ellipsoids(m: np.ndarray, rows, centre: np.ndarray, radii: np.ndarray) -> None:
    m[:, rows, :3, :3] = 0.0
    for k in range(3):
        m[:, rows, k, k] = radii[..., k]
    m[:, rows, :3, 3] = centre


def _bars(m: np.ndarray, rows, a: np.ndarray, b: np.ndarray, half: float) -> None:
    """Bars between ``a`` and ``b`` (N, 3): x carried onto the bar's half extent, y and z kept.
    The ends are taken left to right (x growing), so the map keeps its handedness and the
    bar's faces their winding."""
    swap = (b[:, 0] < a[:, 0])[:, None]
    a, b = np.where(swap, b, a), np.where(swap, a, b)
    m[:, rows, :3, :3] = np.eye(3)
    m[:, rows, :3, 0] = (b - a) / (2 * half)
    m[:, rows, :3, 3] = 0.5 * (a + b)


def part_transforms(weights, gaze, gaze_gain: float = 1.0) -> np.ndarray:
    """The parts' affine maps (N, P, 4, 4) into the head's frame for weights (N, 52) and gaze
    (N, 2, 2) (degrees; turned ``gaze_gain`` times)."""
    w = np.clip(np.atleast_2d(np.asarray(weights, np.float64)), 0.0, 1.0)
    g = np.radians(np.asarray(gaze, np.float64).reshape(len(w), 2, 2) * gaze_gain)
    n = len(w)
    m = np.zeros((n, len(PARTS), 4, 4))
    m[:, :, 3, 3] = 1.0
    sides = (("l", 1.0, "Left"), ("r", -1.0, "Right"))
    for k, (s, sx, side) in enumerate(sides):
        eye = np.array([sx * _EYE_AT[0], _EYE_AT[1], surface_z(_EYE_AT[0], _EYE_AT[1]) - 0.55 * _EYE_R])
        _ellipsoids(m, PART_INDEX["eye_" + s], eye, np.full((n, 3), _EYE_R))
        # The pupil: a flattened ball on the eye's front, turned by the gaze (yaw about y, pitch about x).
        yaw, pitch = g[:, k, 0], g[:, k, 1]
        fwd = np.stack([np.sin(yaw) * np.cos(pitch), np.sin(pitch), np.cos(yaw) * np.cos(pitch)], axis=-1)
        right = np.stack([np.cos(yaw), np.zeros(n), -np.sin(yaw)], axis=-1)
        up = np.cross(fwd, right)
        rot = np.stack([right, up, fwd], axis=-1)
        blink, wide = _w(w, "eyeBlink" + side), _w(w, "eyeWide" + side)
        squint = np.clip(_w(w, "eyeSquint" + side) + _w(w, "cheekSquint" + side), 0.0, 1.0)
        p = PART_INDEX["pupil_" + s]  # smaller in a wide eye: more white round it
        m[:, p, :3, :3] = rot * (np.array([0.52, 0.52, 0.2]) * _EYE_R) * (1 - _PUPIL_WIDE * wide)[:, None, None]
        m[:, p, :3, 3] = eye + 0.84 * _EYE_R * fwd
        # The upper lid covers the ball from the top down: its height h runs from _LID_REST (open)
        # to 1 (shut), up off the ball as the eye widens, down over the pupil's top as the brow
        # lowers (a glare); a squint raises the lower lid (a smile's eyes, and a frown's).
        down = _w(w, "browDown" + side)
        h = np.clip(_LID_REST + (1 - _LID_REST) * blink - _LID_REST * wide + 0.08 * squint + _LID_BROW_DOWN * down,
                    0.02, 1.0)
        lift = _LID_LIFT * wide
        centre = eye + np.stack([np.zeros(n), _LID_R * (1 - h) + lift, np.zeros(n)], axis=-1)
        _ellipsoids(m, PART_INDEX["lid_" + s], centre, np.stack([np.full(n, _LID_R), _LID_R * h, np.full(n, _LID_R)], -1))
        lo = np.clip(0.10 + _LOWER_LID_SQUINT * squint - 0.06 * wide, 0.02, 1.0)
        centre = eye - np.stack([np.zeros(n), _LID_R * (1 - lo), np.zeros(n)], axis=-1)
        _ellipsoids(m, PART_INDEX["lower_lid_" + s], centre,
                    np.stack([np.full(n, _LID_R), _LID_R * lo, np.full(n, _LID_R)], -1))
        # Brows: inner and outer ends. Level at rest (the outer end a little lower, as a brow's
        # arch falls; seen from above it rises back); the inner end rises and falls the most, so
        # a raise, a worried slant (inner up) and a frown (inner down and in: a V) differ by the
        # bar's angle as well as its height.
        inner_up, outer_up = _w(w, "browInnerUp"), _w(w, "browOuterUp" + side)
        # Each end keeps to the forehead as it moves (z along the surface's slope there: linear in the weights).
        dyi = _BROW_INNER_UP * inner_up - _BROW_DOWN * down
        dyo = _BROW_OUTER_UP * outer_up - _BROW_OUTER_DOWN * down
        a = np.stack([sx * (_BROW_INNER - _BROW_KNIT * down), _BROW_Y + dyi,
                      surface_z(_BROW_INNER, _BROW_Y) + 0.003 + _surface_slope(_BROW_INNER, _BROW_Y) * dyi + 0.003 * down],
                     axis=-1)
        yo = _BROW_Y - _BROW_DROP
        b = np.stack([np.full(n, sx * _BROW_OUTER), yo + dyo,
                      surface_z(_BROW_OUTER, yo) + 0.002 + _surface_slope(_BROW_OUTER, yo) * dyo], axis=-1)
        _bars(m, PART_INDEX["brow_" + s], a, b, (_BROW_OUTER - _BROW_INNER) / 2)
    # The mouth: width, opening, where its middle is, its corners.
    jaw = _w(w, "jawOpen")
    funnel, pucker = _w(w, "mouthFunnel"), _w(w, "mouthPucker")
    stretch = _w(w, "mouthStretchLeft", "mouthStretchRight")
    smile = _w(w, "mouthSmileLeft", "mouthSmileRight")
    closing = np.clip(_w(w, "mouthClose") + 0.5 * _w(w, "mouthPressLeft", "mouthPressRight")
                      + 0.5 * _w(w, "mouthRollLower", "mouthRollUpper"), 0.0, 1.0)
    upper_up, lower_down = _w(w, "mouthUpperUpLeft", "mouthUpperUpRight"), _w(w, "mouthLowerDownLeft", "mouthLowerDownRight")
    press = _w(w, "mouthPressLeft", "mouthPressRight")
    half_w = _MOUTH_HALF_WIDTH * (1 + 0.40 * stretch + 0.30 * smile + 0.12 * _w(w, "mouthDimpleLeft", "mouthDimpleRight")
                                  - 0.45 * pucker - 0.28 * funnel - 0.15 * press)
    opening = 0.022 * jaw + 0.006 * lower_down + 0.008 * upper_up + 0.008 * funnel + 0.010 * stretch
    half_h = np.maximum(0.0012, 0.0022 + opening * (1 - 0.85 * closing) - 0.0012 * closing)
    cx = 0.008 * (_w(w, "mouthLeft") - _w(w, "mouthRight")) + 0.006 * (_w(w, "jawLeft") - _w(w, "jawRight"))
    # (a smile lifts the middle a third as far as the corners: a shallower V)
    cy = (_MOUTH_Y - 0.008 * jaw + 0.008 * upper_up - 0.002 * lower_down + 0.003 * _w(w, "mouthShrugUpper")
          + _SMILE_LIFT * _CORNER_SMILE * smile)
    cz = surface_z(0.0, _MOUTH_Y) - 0.004 + 0.007 * pucker + 0.004 * funnel + 0.006 * _w(w, "jawForward")
    centre = np.stack([cx, cy, cz], axis=-1)
    # The opening narrows as the corners rise (a smile), keeping inside the lips' V.
    _ellipsoids(m, PART_INDEX["mouth"], centre, np.stack([half_w * (1 - 0.5 * smile), half_h, np.full(n, 0.009)], -1))
    tongue = _w(w, "tongueOut")
    _ellipsoids(m, PART_INDEX["tongue"], centre + np.stack([np.zeros(n), -0.5 * half_h, -0.012 + 0.028 * tongue], -1),
                np.stack([np.full(n, 0.012), np.full(n, 0.005), np.full(n, 0.013)], -1))
    roll = _w(w, "mouthRollUpper"), _w(w, "mouthRollLower")
    shrug = _w(w, "mouthShrugUpper"), _w(w, "mouthShrugLower")
    for s, sx, side in sides:
        corner_up = (_CORNER_REST + (1 - _SMILE_LIFT) * _CORNER_SMILE * _w(w, "mouthSmile" + side)
                     - _CORNER_FROWN * _w(w, "mouthFrown" + side)
                     - 0.005 * _w(w, "mouthStretch" + side))
        corner = centre + np.stack([sx * half_w, corner_up, -0.004 * _w(w, "mouthDimple" + side)], axis=-1)
        for lip, sign, rolled, shrugged in (("upper", 1.0, roll[0], shrug[0]), ("lower", -1.0, roll[1], shrug[1])):
            middle = centre + np.stack([np.zeros(n), sign * (half_h + 0.6 * _LIP_R) + 0.005 * shrugged,
                                        0.004 - 0.004 * rolled], axis=-1)
            _bars(m, PART_INDEX[f"lip_{lip}_{s}"], middle, corner, _MOUTH_HALF_WIDTH / 2)
    # Chin, cheeks, nose.
    chin = np.stack([0.010 * (_w(w, "jawLeft") - _w(w, "jawRight")), -0.075 - 0.022 * jaw,
                     0.045 + 0.010 * _w(w, "jawForward")], axis=-1)
    _ellipsoids(m, PART_INDEX["chin"], chin, np.tile([0.036, 0.024, 0.034], (n, 1)))
    for s, sx, side in sides:
        puff = _w(w, "cheekPuff")
        centre = np.stack([np.full(n, sx * 0.045), -0.028 + 0.006 * _w(w, "cheekSquint" + side), np.full(n, 0.045)], -1)
        _ellipsoids(m, PART_INDEX["cheek_" + s], centre, np.tile(0.028, (n, 3)) * (1 + 0.5 * puff)[:, None])
    sneer = _w(w, "noseSneerLeft", "noseSneerRight")
    nose = np.stack([np.zeros(n), -0.012 + 0.008 * sneer, np.full(n, surface_z(0, -0.012) - 0.004)], -1)
    _ellipsoids(m, PART_INDEX["nose"], nose, np.tile([0.016, 0.019, 0.026], (n, 1)) * (1 + [0.30, 0, 0] * sneer[:, None]))
    return m


def neutral_transforms() -> np.ndarray:
    """The parts' maps (P, 4, 4) of a resting face (weights 0, eyes ahead)."""
    return part_transforms(np.zeros((1, N_BLENDSHAPES)), np.zeros((1, 2, 2)))[0]


# -- the head's frame ----------------------------------------------------------------------------

def head_frames(positions) -> tuple[np.ndarray, np.ndarray]:
    """The head's rotation (T, 3, 3) (columns: its x to the character's left, y up through the
    head top, z out of the face) and centre (T, 3) for joint positions (T, 10, 3): y from the neck
    to the head top, z towards the nose (the mannequin's head)."""
    p = np.asarray(positions, np.float64)
    neck, nose, top = p[:, J["neck"]], p[:, J["nose"]], p[:, J["head_top"]]
    y = top - neck
    y /= np.maximum(np.linalg.norm(y, axis=-1, keepdims=True), 1e-12)
    f = nose - neck
    z = f - np.sum(f * y, axis=-1, keepdims=True) * y
    z /= np.maximum(np.linalg.norm(z, axis=-1, keepdims=True), 1e-12)
    x = np.cross(y, z)
    rot = np.stack([x, y, z], axis=-1)
    centre = top - 0.105 * y - 0.01 * z
    return rot, centre


def _placed(maps: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vertices ``v`` (V, 3) under affine ``maps`` (..., 4, 4) -> (..., V, 3)."""
    return np.einsum("...ij,vj->...vi", maps[..., :3, :3], v) + maps[..., None, :3, 3]


def morph_mesh() -> list[dict]:
    """The head and the resting face as meshes in the head's frame (the head, then one per colour), each with a
    morph target per blendshape (ARKit order): the displacement of its vertices when that weight
    alone is 1 (the eyeLook* ones turn the pupils by :func:`gaze_from_weights`). A face's weights
    blend these linearly, which the parts' maps are, but for the pupils' turn and the clamps.

    Returns, per colour: ``color``, ``roughness``, ``positions`` (V, 3), ``normals`` (V, 3),
    ``indices`` (F, 3) and ``targets`` (52, V, 3)."""
    meshes = part_meshes()
    rest = neutral_transforms()
    unit = np.eye(N_BLENDSHAPES)
    shaped = part_transforms(unit, gaze_from_weights(unit))  # (52, P, 4, 4)
    head_v, head_f = uv_sphere(16, 24)
    groups: dict[tuple, dict] = {}

    def add(color, rough, v, n, f, targets, own=False):
        g = groups.setdefault((color, rough, own), {"color": color, "roughness": rough, "positions": [], "normals": [],
                                               "indices": [], "targets": [], "count": 0})
        g["indices"].append(f + g["count"])
        g["count"] += len(v)
        g["positions"].append(v)
        g["normals"].append(n)
        g["targets"].append(targets)

    radii = np.diag(HEAD_RADII)
    add(SKIN, 0.6, head_v @ radii, _unit_rows(head_v @ np.linalg.inv(radii)), head_f,
        np.zeros((N_BLENDSHAPES, len(head_v), 3)), own=True)  # a mesh of its own: no target moves it
    for k, ((_, _, color, rough), (v, n, f)) in enumerate(zip(PARTS, meshes)):
        at_rest = _placed(rest[k], v)
        normals = _unit_rows(n @ np.linalg.inv(rest[k, :3, :3]))
        add(color, rough, at_rest, normals, f, _placed(shaped[:, k], v) - at_rest)
    out = []
    for g in groups.values():
        out.append({"color": g["color"], "roughness": g["roughness"], "positions": np.concatenate(g["positions"]),
                    "normals": np.concatenate(g["normals"]), "indices": np.concatenate(g["indices"]),
                    "targets": np.concatenate(g["targets"], axis=1)})
    return out


def _unit_rows(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)
