"""A target rig as data: bones, parents, rest pose, rest orientations, and what drives each bone.

A :class:`Rig` lists its bones parents first. Every bone has a *head* (its joint's position in
the rig's rest pose, world coordinates: y up, metres, the character facing +z, its left hand on
+x) and a *rest rotation* (its world orientation in the rest pose; identity unless given). What
moves it is one :class:`Aim`, one :class:`Orient`, or nothing (it keeps its rest rotation
relative to its parent). Drives name *source joints*: sgt's skeleton joints
(:data:`core.skeleton.JOINTS`) or any joint a later layer adds to the positions handed to
:func:`renders.rigs.retarget.retarget` (finger joints, for instance), so a new joint on either
side is a table change.

- :class:`Aim` (limbs): the bone's aim segment (its head to the head of ``to``, or to its own
  ``tail``) points exactly where the source segment ``source[0] -> source[1]`` points.
- :class:`Orient` (torso, head): the bone turns, relative to its rest, the way the source frame
  (``primary`` segment, ``secondary`` segment for the roll) turns relative to the source's rest.
- :class:`AimRoll` (hands, fingers): aimed like :class:`Aim`, and rolled about its aim so that
  a direction across it (``roll``) lies where the source's does: the rig's frame (aim, its rest
  ``rig_roll``) is carried onto the source's (aim, ``roll``) in every frame. It does not depend
  on the source's rest pose, so a hanging relaxed hand and a T-pose flat hand agree.

Twist convention (documented in docs/formats.md): an aimed bone is first carried from its rest
aim to the source's rest direction keeping its front in front
(:func:`renders.rigs.retarget.rest_alignment`), then by the shortest arc from the source's rest
direction to the direction in the frame, so a T-pose rig and an A-pose rig get the same world
orientation for the same motion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from renders.rotations import quat_to_matrix

Vec = tuple[float, float, float]


@dataclass(frozen=True)
class Aim:
    source: tuple[str, str]
    to: str | None = None  # the bone whose head ends the aim segment; None: this bone's tail


@dataclass(frozen=True)
class Orient:
    primary: tuple[str, str]
    secondary: tuple[str, str]


@dataclass(frozen=True)
class AimRoll:
    """Aim along ``source`` (to the head of ``to``, or the bone's tail) with the roll of ``roll``:
    two source joints (a segment) or four (the normal ``a->b x c->d`` of two segments);
    ``rig_roll`` names the rig's bones whose rest heads give the same direction in the rig."""

    source: tuple[str, str]
    roll: tuple[str, ...]
    rig_roll: tuple[str, ...]
    to: str | None = None


@dataclass(frozen=True)
class Bone:
    name: str
    parent: str | None
    head: Vec
    drive: Aim | AimRoll | Orient | None = None
    tail: Vec | None = None  # where a leaf ends (BVH End Site, the mesh, aims without ``to``)
    rest_rotation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # world, (x, y, z, w)
    humanoid: str | None = None  # the VRM humanoid bone it is, when the rig declares one


@dataclass(frozen=True)
class Rig:
    name: str
    title: str
    bones: tuple[Bone, ...]
    #: The source joint whose movement moves the root, and the factor applied to it.
    root_source: str = "spine"
    translation_scale: float = 1.0
    #: VRM Animation humanoid mapping is written into glTF files (VRMC_vrm_animation).
    vrm_animation: bool = False

    def __post_init__(self) -> None:
        seen: set[str] = set()
        for b in self.bones:
            if b.name in seen:
                raise ValueError(f"rig {self.name}: bone {b.name} twice")
            if (b.parent is None) != (b is self.bones[0]):
                raise ValueError(f"rig {self.name}: only the first bone is the root ({b.name})")
            if b.parent is not None and b.parent not in seen:
                raise ValueError(f"rig {self.name}: {b.name}'s parent {b.parent} must come before it")
            if isinstance(b.drive, (Aim, AimRoll)) and b.drive.to is None and b.tail is None:
                raise ValueError(f"rig {self.name}: {b.name} aims at its tail but has none")
            seen.add(b.name)
        for b in self.bones:
            if isinstance(b.drive, (Aim, AimRoll)) and b.drive.to is not None and b.drive.to not in seen:
                raise ValueError(f"rig {self.name}: {b.name} aims at unknown bone {b.drive.to}")
            if isinstance(b.drive, AimRoll):
                unknown = [n for n in b.drive.rig_roll if n not in seen]
                if unknown or len(b.drive.roll) not in (2, 4) or len(b.drive.rig_roll) != len(b.drive.roll):
                    raise ValueError(f"rig {self.name}: {b.name}'s roll must name 2 or 4 source joints and as many "
                                     f"rig bones{' (unknown: ' + ', '.join(unknown) + ')' if unknown else ''}")
            if not self.children(b.name) and b.tail is None:
                raise ValueError(f"rig {self.name}: leaf {b.name} needs a tail")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(b.name for b in self.bones)

    @property
    def index(self) -> dict[str, int]:
        return {b.name: i for i, b in enumerate(self.bones)}

    def parent_indices(self) -> np.ndarray:
        idx = self.index
        return np.array([-1 if b.parent is None else idx[b.parent] for b in self.bones])

    def children(self, name: str) -> list[str]:
        return [b.name for b in self.bones if b.parent == name]

    def heads(self) -> np.ndarray:
        return np.array([b.head for b in self.bones], dtype=np.float64)

    def rest_rotations(self) -> np.ndarray:
        return quat_to_matrix(np.array([b.rest_rotation for b in self.bones], dtype=np.float64))

    def rest_offsets(self) -> np.ndarray:
        """Each bone's head relative to its parent's head, world axes (rest pose)."""
        h = self.heads()
        p = self.parent_indices()
        return np.where(p[:, None] >= 0, h - h[np.maximum(p, 0)], 0.0)

    def aim_end(self, bone: Bone) -> np.ndarray:
        """Rest position where ``bone``'s aim segment ends."""
        if isinstance(bone.drive, (Aim, AimRoll)) and bone.drive.to is not None:
            return np.asarray(self.bones[self.index[bone.drive.to]].head, dtype=np.float64)
        return np.asarray(bone.tail, dtype=np.float64)

    def rest_roll(self, bone: Bone) -> np.ndarray:
        """The rest direction of an :class:`AimRoll` bone's ``rig_roll`` (from the rig's heads)."""
        heads = {n: np.asarray(self.bones[self.index[n]].head, dtype=np.float64) for n in bone.drive.rig_roll}
        return roll_direction(heads, bone.drive.rig_roll)

    def source_joints(self) -> set[str]:
        out = {self.root_source}
        for b in self.bones:
            if isinstance(b.drive, Aim):
                out.update(b.drive.source)
            elif isinstance(b.drive, AimRoll):
                out.update(b.drive.source + b.drive.roll)
            elif isinstance(b.drive, Orient):
                out.update(b.drive.primary + b.drive.secondary)
        return out


def roll_direction(points: dict[str, np.ndarray], names: tuple[str, ...]) -> np.ndarray:
    """A roll reference from named points (arrays (..., 3)): the segment ``a -> b``, or for four
    names the normal ``(a -> b) x (c -> d)``."""
    first = points[names[1]] - points[names[0]]
    if len(names) == 2:
        return first
    return np.cross(first, points[names[3]] - points[names[2]])
