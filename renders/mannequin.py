"""An offscreen shaded mannequin: its parts built once as one mesh, posed on the CPU per frame.

The parts are trimesh primitives (capsules along the bones, spheres at the joints, a head) and
the face of :mod:`renders.face_rig` (eyes that turn with the gaze, eyelids, brows, a mouth that
opens and rounds, lips, a chin that drops, a nose); hands are a palm (a flattened box) and the
thumb and four fingers, three capsules each, placed on the hand joints of :mod:`core.hands` (drawn a little thicker than
life so that a pointing index or a thumbs up reads at 240x240). :meth:`Mannequin.render`
computes every part's transform for a frame (batched numpy), moves the mesh's vertices and
draws it in one call (:class:`renders.gl.MeshRenderer`). A clip's face (:class:`FaceFrames`) places
the face's parts frame by frame; without one the face rests (eyes open and ahead, mouth shut).

Views (:data:`VIEWS`): the camera circles the character (who faces +z) and the lights move
with it, so every view is lit alike:

- ``three-quarter`` (the default): from the front-left, 25 degrees round, and a little above
  (10 degrees; the character's right hand is still on the left of the picture). The library's
  one-handed gestures use the right hand, and from this side a reach towards the listener (a
  point, a handshake, an offer) stands out from the body against the background, level, instead
  of crossing in front of the torso; a camera higher up made such reaches read as pointing at the
  floor (docs/library.md compares the candidates);
- ``front``: facing the character at eye height (its right hand on your left; depth is lost);
- ``side``: its right side, the character facing the right of the picture (depth is left-right);
- ``top``: from straight above, its front down the picture (its right hand on your left, as from
  the front);
- ``face``: a close-up of the head from the front, the camera following the head's centre
  frame by frame (``View.on_head``), for the face's expressions.

``tint`` colours the body (clothes) of one render, to tell speakers apart (:data:`TINTS`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.face import FaceTrack
from core.hands import DIGITS, HAND_JOINTS, SIDES, HandTrack, hand_positions, local_hand_joints
from core.interrupts import interrupts_deferred
from core.skeleton import BONE_LENGTHS, REST_POSE, positions_from_pose
from core.skeleton import JOINT_INDEX as J
from renders import face_rig, gl
from renders.rotations import frame_from, shortest_arcs, transform

BACKGROUND = (236, 239, 243)
BODY = (0.25, 0.36, 0.55)
SKIN = face_rig.SKIN
JOINT_COLOR = (0.17, 0.24, 0.37)

#: Body colours (linear RGB) that tell speakers apart, in speaker order: blue (the one
#: speaker's colour), green, plum, teal, dark red, slate; none of them near the skin's hue.
#: The joints are a darker shade.
TINTS = ((0.25, 0.36, 0.55), (0.20, 0.42, 0.20), (0.40, 0.20, 0.48), (0.10, 0.40, 0.42),
         (0.50, 0.12, 0.10), (0.30, 0.30, 0.32))
_JOINT_SHADE = np.array(JOINT_COLOR) / np.array(BODY)

#: Camera: looks at TARGET from DISTANCE, with a vertical field of view of YFOV degrees.
TARGET = np.array([0.0, 1.39, 0.0])
DISTANCE = 2.95
YFOV = 30.0
#: The head's centre (:func:`renders.face_rig.head_frames`) in the rest pose: where a view
#: ``on_head`` looks when no frame gives the head.
HEAD_CENTRE = face_rig.head_frames(positions_from_pose(REST_POSE[None]))[1][0]


@dataclass(frozen=True)
class View:
    """A camera position: ``azimuth`` degrees round from the character's front towards its
    right (-x; negative: towards its left), ``elevation`` degrees above the horizontal, ``distance``
    metres from what it looks at: :data:`TARGET`, or with ``on_head`` the head's centre in each frame
    (a close-up that follows the head; :data:`HEAD_CENTRE` where no frame says)."""

    azimuth: float
    elevation: float
    distance: float = DISTANCE
    on_head: bool = False


VIEWS = {
    "three-quarter": View(-25.0, 10.0),
    "front": View(0.0, 6.0),
    "side": View(90.0, 6.0),
    "top": View(0.0, 90.0),
}
DEFAULT_VIEW = "three-quarter"
#: ``face``: a close-up of the head from the front, a little above, that follows the head; the
#: head and chin fill about two thirds of the picture's height (0.40 m seen at 0.75 m).
VIEWS["face"] = View(0.0, 6.0, distance=0.75, on_head=True)

#: Lights (direction towards the light, colour, intensity) as seen from the camera of
#: LIGHTS_VIEW; other views turn them with the camera.
_LIGHTS = (((-0.6, 0.9, 0.9), (1.0, 0.97, 0.92), 2.4),
           ((0.9, 0.2, 0.7), (0.85, 0.9, 1.0), 0.9),
           ((0.2, 0.6, -1.0), (1.0, 1.0, 1.0), 0.8))
_LIGHTS_VIEW = View(30.0, 6.0)
AMBIENT = (0.18, 0.18, 0.2)

# (name, parent joint, child joint, radius): capsules drawn along bones.
_LIMBS = (
    ("l_clav", "neck", "left_shoulder", 0.045),
    ("l_upper", "left_shoulder", "left_elbow", 0.045),
    ("l_fore", "left_elbow", "left_wrist", 0.037),
    ("r_clav", "neck", "right_shoulder", 0.045),
    ("r_upper", "right_shoulder", "right_elbow", 0.045),
    ("r_fore", "right_elbow", "right_wrist", 0.037),
)
#: How far the torso reaches from its middle across (x) and in depth (z), metres: a capsule of
#: radius _TORSO_RADIUS widened to these (what a camera sees of its width).
TORSO_HALF_WIDTH = (0.155, 0.095)
_TORSO_RADIUS = 0.1
_BALLS = (("left_shoulder", 0.058), ("right_shoulder", 0.058), ("left_elbow", 0.047),
          ("right_elbow", 0.047))
#: Finger capsule radius (metres) per digit; the palm's half thickness.
_FINGER_RADIUS = {"thumb": 0.0125, "index": 0.0115, "middle": 0.0115, "ring": 0.011, "little": 0.010}
_PALM_HALF_THICKNESS = 0.015


#: The hand joints of a relaxed hand at the origin (segment lengths of the finger capsules).
_REST_HAND = local_hand_joints(HandTrack.rest(1).fingers[0, 0])


class _Mesh:
    """A part's mesh as the trimesh primitives give theirs (vertices, vertex_normals, faces)."""

    def __init__(self, vertices: np.ndarray, normals: np.ndarray, faces: np.ndarray) -> None:
        self.vertices, self.vertex_normals, self.faces = vertices, normals, faces


class FaceFrames:
    """A face track's parts, frame by frame: ``frames[i]`` is frame i's maps (P, 4, 4) for
    :meth:`Mannequin.render`. They are made :data:`CHUNK` frames at a time (one batched call
    instead of one per frame) and only the current chunk is kept, so memory does not grow with
    the clip. The pupils turn :data:`renders.face_rig.GAZE_GAIN` times the gaze."""

    CHUNK = 128

    def __init__(self, face: FaceTrack) -> None:
        self.face = face
        self._start, self._maps = -self.CHUNK - 1, None

    def __getitem__(self, frame: int) -> np.ndarray:
        frame = min(max(int(frame), 0), self.face.n_frames - 1)
        if not self._start <= frame < self._start + self.CHUNK:
            self._start = frame - frame % self.CHUNK
            part = self.face.take(slice(self._start, self._start + self.CHUNK))
            self._maps = face_rig.part_transforms(part.weights, part.gaze, face_rig.GAZE_GAIN)
        return self._maps[frame - self._start]


def speaker_tint(index: int) -> tuple[float, float, float]:
    """The body colour of the ``index``-th speaker of a take (:data:`TINTS`, round again after six)."""
    return TINTS[index % len(TINTS)]


def camera_pose(view: str = DEFAULT_VIEW, head=None) -> np.ndarray:
    """The camera's pose (4, 4) for ``view`` (a name of :data:`VIEWS`): it looks along its own -z.
    A view ``on_head`` looks at ``head`` (the head's centre, (3,); :data:`HEAD_CENTRE` when None)."""
    return _camera(VIEWS[view], head)


def _camera(v: View, head=None) -> np.ndarray:
    az, el = np.radians(v.azimuth), np.radians(v.elevation)
    # Front is +z; the character's right is -x.
    back = np.array([-np.sin(az) * np.cos(el), np.sin(el), np.cos(az) * np.cos(el)])
    # Straight above, "up" in the picture is the character's back (its front is down the picture).
    up = np.array([0.0, 1.0, 0.0]) if abs(back[1]) < 0.999 else np.array([np.sin(az), 0.0, -np.cos(az)])
    target = (HEAD_CENTRE if head is None else np.asarray(head, np.float64)) if v.on_head else TARGET
    return transform(_look_frame(back, up), target + v.distance * back)


def _look_frame(back: np.ndarray, up=np.array([0.0, 1.0, 0.0])) -> np.ndarray:
    """Rotation whose -z looks against ``back`` with +y as close to ``up`` as possible."""
    z = back / np.linalg.norm(back)
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


def projection(width: int, height: int) -> np.ndarray:
    """The perspective projection (4, 4) of a ``width`` x ``height`` picture (near 0.5 m, far 10 m)."""
    t = np.tan(np.radians(YFOV) / 2)
    n, f = 0.5, 10.0
    p = np.zeros((4, 4))
    p[0, 0] = 1.0 / (width / height * t)
    p[1, 1] = 1.0 / t
    p[2, 2] = (f + n) / (n - f)
    p[2, 3] = 2 * f * n / (n - f)
    p[3, 2] = -1.0
    return p


def project(points: np.ndarray, width: int, height: int, view: str = DEFAULT_VIEW, head=None) -> np.ndarray:
    """Pixel coordinates (..., 2) (x right, y down) of world ``points`` (..., 3) in a
    ``width`` x ``height`` render from ``view`` (a view on the head: looking at ``head``, see
    :func:`camera_pose`)."""
    cam = camera_pose(view, head)
    p = np.asarray(points, np.float64)
    clip = np.concatenate([p, np.ones(p.shape[:-1] + (1,))], axis=-1) @ (projection(width, height) @ np.linalg.inv(cam)).T
    ndc = clip[..., :2] / clip[..., 3:4]
    return np.stack([(ndc[..., 0] + 1) * width / 2, (1 - ndc[..., 1]) * height / 2], axis=-1)


def _lights(v: View) -> list[tuple[np.ndarray, np.ndarray]]:
    """(direction the light shines along, linear radiance) in world coordinates for ``v``."""
    turn = _camera(v)[:3, :3] @ _camera(_LIGHTS_VIEW)[:3, :3].T
    out = []
    for towards, color, intensity in _LIGHTS:
        d = turn @ np.asarray(towards, np.float64)
        out.append((-d / np.linalg.norm(d), np.asarray(color) * intensity))
    return out


class Mannequin:
    """Offscreen renderer of skeleton positions (10, 3) to RGB images (H, W, 3) uint8."""

    def __init__(self, width: int = 320, height: int = 320) -> None:
        self.width, self.height = int(width), int(height)
        # trimesh computes the meshes' vertex normals inside ``except BaseException`` (it falls
        # back from scipy.sparse on any error): a Ctrl-C landing there was logged as a warning and
        # the render ran on to the end (seen in CI). Hold it while the mesh is built.
        with interrupts_deferred():
            indices = self._build_mesh()
        self.renderer = gl.MeshRenderer(self.width, self.height, vertices=self._local, normals=self._local_normals,
                                        part=self._part_of_vertex, indices=indices, n_lights=len(_LIGHTS))
        self.platform = self.renderer.platform
        self._projection = projection(self.width, self.height)
        self._cameras: dict[str, tuple] = {}
        self.scene: gl.Frame | None = None  # the last frame drawn

    # -- the mesh --------------------------------------------------------------------------

    def _build_mesh(self):
        import trimesh

        parts: list[tuple[str, object, tuple, float]] = []  # (name, mesh, colour, roughness)

        def add(name, tm, rgb, rough=0.75):
            parts.append((name, tm, rgb, rough))

        # Torso: a capsule widened across the shoulders, built along +y, about 0.42 m tall.
        z_to_y = transform(np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]), [0, 0, 0])
        torso = trimesh.creation.capsule(height=0.30, radius=_TORSO_RADIUS, count=[16, 16])
        torso.apply_transform(z_to_y)
        torso.apply_scale([TORSO_HALF_WIDTH[0] / _TORSO_RADIUS, 1.0, TORSO_HALF_WIDTH[1] / _TORSO_RADIUS])
        add("torso", torso, "body")
        hips = trimesh.creation.capsule(height=0.06, radius=0.1, count=[16, 16])
        hips.apply_transform(z_to_y)
        hips.apply_scale([1.45, 1.0, 0.95])
        add("hips", hips, "joint")
        add("neckpiece", trimesh.creation.capsule(height=0.07, radius=0.042, count=[12, 12]), SKIN)
        head = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
        head.apply_scale(face_rig.HEAD_RADII)
        add("head", head, SKIN, 0.6)
        for (name, _, rgb, rough), (v, normals, f) in zip(face_rig.PARTS, face_rig.part_meshes()):
            add("face_" + name, _Mesh(v, normals, f), rgb, rough)
        for name, a, b, r in _LIMBS:
            add(name, trimesh.creation.capsule(height=BONE_LENGTHS[b], radius=r, count=[12, 12]), "body")
        for j, r in _BALLS:
            add("ball_" + j, trimesh.creation.icosphere(subdivisions=2, radius=r), "joint")
        self._segments = []  # (side index, parent hand joint, child hand joint), in part order
        for side in SIDES:
            add(side + "_palm", trimesh.creation.box(extents=[1.0, 1.0, 1.0]), SKIN, 0.6)
            add(side + "_wristball", trimesh.creation.icosphere(subdivisions=2, radius=0.026), SKIN, 0.6)
        for side in SIDES:
            for d, digit in enumerate(DIGITS):
                for k in range(3):
                    a, b = 4 * d + k, 4 * d + k + 1
                    length = float(np.linalg.norm(_REST_HAND[b] - _REST_HAND[a]))
                    cap = trimesh.creation.capsule(height=length, radius=_FINGER_RADIUS[digit], count=[8, 8])
                    add(f"{side}_{HAND_JOINTS[b]}", cap, SKIN, 0.6)
                    self._segments.append((SIDES.index(side), a, b))

        self._names = [p[0] for p in parts]
        self._index = {name: i for i, name in enumerate(self._names)}
        counts = [len(tm.vertices) for _, tm, _, _ in parts]
        self._part_of_vertex = np.repeat(np.arange(len(parts)), counts)
        self._local = np.concatenate([np.asarray(tm.vertices, np.float64) for _, tm, _, _ in parts])
        self._local_normals = np.concatenate([np.asarray(tm.vertex_normals, np.float64) for _, tm, _, _ in parts])
        offsets = np.cumsum([0] + counts[:-1])
        indices = np.concatenate([np.asarray(tm.faces, np.int64) + o for (_, tm, _, _), o in zip(parts, offsets)])
        self._kinds = np.array([{"body": 1, "joint": 2}.get(c, 0) if isinstance(c, str) else 0
                                for _, _, c, _ in parts])[self._part_of_vertex]
        self._fixed_colors = np.array([(0, 0, 0) if isinstance(c, str) else c for _, _, c, _ in parts])[self._part_of_vertex]
        self._roughness = np.array([r for *_, r in parts])[self._part_of_vertex]
        self._materials: dict[tuple, np.ndarray] = {}
        self._matrices = np.tile(np.eye(4), (len(parts), 1, 1))
        # Batched parts: limbs and finger segments are capsules along +z between two points.
        self._limb_rows = np.array([self._index[n] for n, *_ in _LIMBS])
        self._limb_joints = np.array([(J[a], J[b]) for _, a, b, _ in _LIMBS])
        self._ball_rows = np.array([self._index["ball_" + j] for j, _ in _BALLS])
        self._ball_joints = np.array([J[j] for j, _ in _BALLS])
        first = self._index[SIDES[0] + "_" + HAND_JOINTS[1]]
        self._segment_rows = np.arange(first, first + len(self._segments))
        self._segment_index = np.array(self._segments)
        first = self._index["face_" + face_rig.PARTS[0][0]]
        self._face_rows = np.arange(first, first + len(face_rig.PARTS))
        self._neutral_face = face_rig.neutral_transforms()
        return indices

    def materials(self, tint=BODY) -> np.ndarray:
        """Per-vertex material (V, 4: linear RGB, roughness) with the body in ``tint``."""
        key = tuple(float(c) for c in tint)
        if key not in self._materials:
            body = np.asarray(key)
            colors = np.where(self._kinds[:, None] == 1, body,
                              np.where(self._kinds[:, None] == 2, body * _JOINT_SHADE, self._fixed_colors))
            self._materials[key] = np.concatenate([colors, self._roughness[:, None]], axis=1).astype(np.float32)
        return self._materials[key]

    # -- per frame ---------------------------------------------------------------------

    def _set(self, name: str, matrix: np.ndarray) -> None:
        self._matrices[self._index[name]] = matrix

    def pose(self, positions: np.ndarray, hands: np.ndarray | None = None, face: np.ndarray | None = None) -> None:
        """Move the parts to joint ``positions`` (10, 3) in metres, the hands to hand joints
        ``hands`` (2, 20, 3) (:func:`core.hands.hand_positions`; relaxed when None) and the face's
        parts by ``face`` (their maps in the head, (P, 4, 4): a frame of :class:`FaceFrames`;
        resting when None)."""
        p = np.asarray(positions, dtype=np.float64)
        if hands is None:
            hands = hand_positions(p[None], HandTrack.rest(1))[0]
        hands = np.asarray(hands, dtype=np.float64)
        spine, neck = p[J["spine"]], p[J["neck"]]
        ls, rs = p[J["left_shoulder"]], p[J["right_shoulder"]]
        # Torso frame: y along the spine, x across the shoulders (to the character's left).
        across = ls - rs
        up = neck - spine
        fwd = np.cross(across, up)
        torso = frame_from(up, fwd)
        self._set("torso", transform(torso, spine + 0.48 * up))
        # The hips stay upright, turning only with the torso's heading: the skeleton's root (the
        # spine joint) is the waist, so a lean (a bow, lean_forward) bends there and the hips do
        # not swing the other way. Turned with the whole torso, the hips' bottom went back as
        # the chest went forward, and the lean seemed to pivot at the chest.
        self._set("hips", transform(frame_from(np.array([0.0, 1.0, 0.0]), fwd), spine - np.array([0.0, 0.02, 0.0])))
        # Head frame: y from the neck to the head top, z towards the nose (face_rig.head_frames).
        head, center = (a[0] for a in face_rig.head_frames(p[None]))
        head_to_world = transform(head, center)
        self._set("head", head_to_world)
        neck_dir = center - neck
        self._set("neckpiece", transform(shortest_arcs(np.array([0.0, 0.0, 1.0]), neck_dir), neck + 0.45 * neck_dir))
        m = self._matrices
        m[self._face_rows] = head_to_world @ (self._neutral_face if face is None else face)
        # Capsules between two points: the limbs, then the finger segments.
        pa, pb = p[self._limb_joints[:, 0]], p[self._limb_joints[:, 1]]
        s, a, b = self._segment_index[:, 0], self._segment_index[:, 1], self._segment_index[:, 2]
        pa = np.concatenate([pa, hands[s, a]])
        pb = np.concatenate([pb, hands[s, b]])
        rows = np.concatenate([self._limb_rows, self._segment_rows])
        m[rows, :3, :3] = shortest_arcs(np.array([0.0, 0.0, 1.0]), pb - pa)
        m[rows, :3, 3] = 0.5 * (pa + pb)
        m[self._ball_rows, :3, :3] = np.eye(3)
        m[self._ball_rows, :3, 3] = p[self._ball_joints]
        self._pose_palms(p, hands)

    def _pose_palms(self, p: np.ndarray, hands: np.ndarray) -> None:
        index, little = HAND_JOINTS.index("index_mcp"), HAND_JOINTS.index("little_mcp")
        for s, side in enumerate(SIDES):
            wrist = p[J[side + "_wrist"]]
            h = hands[s]
            knuckles = 0.5 * (h[index] + h[little])
            along = knuckles - wrist
            across = h[index] - h[little]
            frame = frame_from(along, np.cross(across, along))  # y to the knuckles, z out of one face
            width = float(np.linalg.norm(across)) + 0.022
            length = float(np.linalg.norm(along))
            self._set(side + "_palm", transform(frame @ np.diag([width, length, 2 * _PALM_HALF_THICKNESS]),
                                                wrist + 0.5 * along))
            self._set(side + "_wristball", transform(np.eye(3), wrist))

    def render(self, positions: np.ndarray, hands: np.ndarray | None = None, *, view: str = DEFAULT_VIEW,
               tint=BODY, face: np.ndarray | None = None, region: tuple[int, int, int, int] | None = None) -> np.ndarray:
        """An image of joint ``positions`` (10, 3), hand joints ``hands`` (2, 20, 3) and the
        face's parts ``face`` (a frame of :class:`FaceFrames`; None: a resting face), seen from
        ``view`` (:data:`VIEWS`), the body in ``tint`` (linear RGB); only the pixel box
        ``region`` (x0, y0, x1, y1, inside the picture) when given."""
        if view not in VIEWS:
            raise ValueError(f"unknown view '{view}': use {', '.join(VIEWS)}")
        self.pose(positions, hands, face)
        if VIEWS[view].on_head:  # the camera follows the head's centre
            cam = camera_pose(view, self._matrices[self._index["head"], :3, 3])
            vp, eye, lights = self._projection @ np.linalg.inv(cam), cam[:3, 3], _lights(VIEWS[view])
        else:
            if view not in self._cameras:
                cam = camera_pose(view)
                self._cameras[view] = (self._projection @ np.linalg.inv(cam), cam[:3, 3], _lights(VIEWS[view]))
            vp, eye, lights = self._cameras[view]
        self.scene = gl.Frame(self._matrices, self.materials(tint), vp, eye, lights, AMBIENT, BACKGROUND)
        # PyOpenGL drops exceptions raised inside its argument conversion, KeyboardInterrupt
        # included (a Ctrl-C landing there was lost and the render ran on): hold it for the frame.
        with interrupts_deferred():
            color = self.renderer.render(self.scene, region)
        return color

    def close(self) -> None:
        self.renderer.delete()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

