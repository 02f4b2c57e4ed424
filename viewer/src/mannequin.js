// sgt's mannequin in three.js, drawn from a frame's joint positions and hand joint positions,
// part for part as renders/mannequin.py builds and poses it (the same shapes, sizes, colours and
// transforms), so that the page shows what `sgt render` draws: a torso and hips, a neck, a head
// with the face of face.js (eyes that look, eyelids that blink, brows, a mouth that opens and
// rounds, a nose), capsules along the arm bones, balls at the shoulders and elbows, and per hand a
// palm (a flattened box), a wrist ball and three capsules for each digit.

import * as THREE from 'three';
import { FACE_PARTS, HEAD_RADII, NEUTRAL, faceGeometry, faceMatrices } from './face.js';

// joint order of core/skeleton.py
export const J = {
  spine: 0, neck: 1, nose: 2, head_top: 3, left_shoulder: 4, left_elbow: 5, left_wrist: 6,
  right_shoulder: 7, right_elbow: 8, right_wrist: 9,
};
const SKIN = [0.80, 0.62, 0.48];
const BODY = [0.25, 0.36, 0.55];
const JOINT_COLOR = [0.17, 0.24, 0.37];
const BONE = { left_shoulder: 0.18, left_elbow: 0.29, left_wrist: 0.26, right_shoulder: 0.18, right_elbow: 0.29, right_wrist: 0.26 };
const LIMBS = [
  ['neck', 'left_shoulder', 0.045], ['left_shoulder', 'left_elbow', 0.045], ['left_elbow', 'left_wrist', 0.037],
  ['neck', 'right_shoulder', 0.045], ['right_shoulder', 'right_elbow', 0.045], ['right_elbow', 'right_wrist', 0.037],
];
const BALLS = [['left_shoulder', 0.058], ['right_shoulder', 0.058], ['left_elbow', 0.047], ['right_elbow', 0.047]];
const FINGER_RADIUS = [0.0125, 0.0115, 0.0115, 0.011, 0.010]; // thumb, index, middle, ring, little
const PALM_HALF_THICKNESS = 0.015;
const INDEX_MCP = 4;
const LITTLE_MCP = 16;
const Z = new THREE.Vector3(0, 0, 1);

function color(rgb) {
  return new THREE.Color().setRGB(rgb[0], rgb[1], rgb[2], THREE.LinearSRGBColorSpace);
}

function material(rgb, roughness) {
  return new THREE.MeshStandardMaterial({ color: color(rgb), roughness, metalness: 0 });
}

// A capsule of `length` between its two sphere centres and `radius`, along +z (trimesh's capsule).
function capsuleZ(radius, length, segments = 12) {
  const g = new THREE.CapsuleGeometry(radius, length, Math.max(4, segments / 2), segments);
  g.rotateX(Math.PI / 2);
  return g;
}

// The rotation whose columns are (x, y, z): y along `up`, z towards `forward` (renders/rotations.frame_from).
const _y = new THREE.Vector3();
const _z = new THREE.Vector3();
const _x = new THREE.Vector3();
function frameFrom(up, forward, out) {
  _y.copy(up).normalize();
  _z.copy(forward).addScaledVector(_y, -forward.dot(_y));
  if (_z.length() < 1e-6) {
    _z.set(Math.abs(_y.x) < 0.9 ? 1 : 0, 0, Math.abs(_y.x) < 0.9 ? 0 : 1).cross(_y).negate();
  }
  _z.normalize();
  _x.crossVectors(_y, _z);
  return out.makeBasis(_x, _y, _z);
}

export class Mannequin {
  // `hands0`: the hand joints (120 numbers) of one frame, for the finger segments' lengths.
  constructor(tint, hands0) {
    this.group = new THREE.Group();
    this.parts = {};
    const body = material(tint, 0.75);
    const joint = material(tint.map((c, i) => c * JOINT_COLOR[i] / BODY[i]), 0.75);
    const skin = material(SKIN, 0.6);
    this.materials = [body, joint, skin];
    const add = (name, geometry, mat) => {
      const mesh = new THREE.Mesh(geometry, mat);
      mesh.matrixAutoUpdate = false;
      this.group.add(mesh);
      this.parts[name] = mesh;
      return mesh;
    };
    const torso = new THREE.CapsuleGeometry(0.1, 0.30, 8, 16);
    torso.scale(1.55, 1.0, 0.95);
    add('torso', torso, body);
    const hips = new THREE.CapsuleGeometry(0.1, 0.06, 8, 16);
    hips.scale(1.45, 1.0, 0.95);
    add('hips', hips, joint);
    add('neckpiece', capsuleZ(0.042, 0.07), skin);
    const head = new THREE.SphereGeometry(1, 32, 20);
    head.scale(...HEAD_RADII);
    add('head', head, skin);
    // the face: its parts' maps in the head's frame (this.face), moved with the head
    this.face = {};
    for (const [name, shape, rgb, roughness] of FACE_PARTS) {
      const mat = material(rgb, roughness);
      this.materials.push(mat);
      add(`face_${name}`, faceGeometry(shape), mat);
      this.face[name] = new THREE.Matrix4();
    }
    LIMBS.forEach(([a, b, r]) => add(`limb_${a}_${b}`, capsuleZ(r, BONE[b]), body));
    BALLS.forEach(([j, r]) => add(`ball_${j}`, new THREE.SphereGeometry(r, 16, 12), joint));
    this.segments = [];
    for (let s = 0; s < 2; s++) {
      add(`palm_${s}`, new THREE.BoxGeometry(1, 1, 1), skin);
      add(`wristball_${s}`, new THREE.SphereGeometry(0.026, 12, 10), skin);
    }
    for (let s = 0; s < 2; s++) {
      for (let d = 0; d < 5; d++) {
        for (let k = 0; k < 3; k++) {
          const a = 4 * d + k;
          const b = a + 1;
          const length = handJoint(hands0, s, a).distanceTo(handJoint(hands0, s, b));
          this.segments.push([s, a, b, add(`finger_${s}_${b}`, capsuleZ(FINGER_RADIUS[d], length, 8), skin)]);
        }
      }
    }
    this._m = new THREE.Matrix4();
    this._q = new THREE.Quaternion();
    this._v = [0, 1, 2, 3, 4, 5, 6, 7].map(() => new THREE.Vector3());
    this._scale = new THREE.Vector3();
  }

  // Move the parts to joint positions `p` (30 numbers), hand joints `h` (120 numbers) and the face
  // to `face` (a FaceTrack sampled at the frame; a resting face without one).
  pose(p, h, face = NEUTRAL) {
    const P = (j, out) => out.set(p[3 * j], p[3 * j + 1], p[3 * j + 2]);
    const [spine, neck, nose, top, ls, rs, a, b] = this._v;
    P(J.spine, spine); P(J.neck, neck); P(J.nose, nose); P(J.head_top, top);
    P(J.left_shoulder, ls); P(J.right_shoulder, rs);
    const m = this._m;
    const across = new THREE.Vector3().subVectors(ls, rs);
    const up = new THREE.Vector3().subVectors(neck, spine);
    const fwd = new THREE.Vector3().crossVectors(across, up);
    const set = (name, matrix) => this.parts[name].matrix.copy(matrix);
    // torso: y along the spine, placed at 0.48 of the way up
    frameFrom(up, fwd, m).setPosition(spine.clone().addScaledVector(up, 0.48));
    set('torso', m);
    // hips: upright, turned only with the torso's heading
    frameFrom(new THREE.Vector3(0, 1, 0), fwd, m).setPosition(spine.x, spine.y - 0.02, spine.z);
    set('hips', m);
    // head: y from the neck to the head top, z towards the nose
    const head = frameFrom(a.subVectors(top, neck), b.subVectors(nose, neck), new THREE.Matrix4());
    const hx = new THREE.Vector3();
    const hu = new THREE.Vector3();
    const hz = new THREE.Vector3();
    head.extractBasis(hx, hu, hz);
    const center = top.clone().addScaledVector(hu, -0.105).addScaledVector(hz, -0.01);
    set('head', head.clone().setPosition(center));
    const neckDir = center.clone().sub(neck);
    this._q.setFromUnitVectors(Z, neckDir.clone().normalize());
    set('neckpiece', m.makeRotationFromQuaternion(this._q).setPosition(neck.clone().addScaledVector(neckDir, 0.45)));
    const headToWorld = head.clone().setPosition(center);
    faceMatrices(face.weight, face.g, this.face);
    for (const [name] of FACE_PARTS) this.parts[`face_${name}`].matrix.multiplyMatrices(headToWorld, this.face[name]);
    // capsules between two joints
    const between = (mesh, from, to) => {
      const d = b.subVectors(to, from);
      this._q.setFromUnitVectors(Z, d.normalize());
      mesh.matrix.makeRotationFromQuaternion(this._q).setPosition(a.addVectors(from, to).multiplyScalar(0.5));
    };
    const pa = new THREE.Vector3();
    const pb = new THREE.Vector3();
    for (const [ja, jb] of LIMBS) between(this.parts[`limb_${ja}_${jb}`], P(J[ja], pa), P(J[jb], pb));
    for (const [j] of BALLS) this.parts[`ball_${j}`].matrix.makeTranslation(P(J[j], pa));
    for (const [s, ia, ib, mesh] of this.segments) between(mesh, handJoint(h, s, ia, pa), handJoint(h, s, ib, pb));
    // palms: y from the wrist to the knuckles, z out of one face
    for (let s = 0; s < 2; s++) {
      const wrist = P(s === 0 ? J.left_wrist : J.right_wrist, new THREE.Vector3());
      const index = handJoint(h, s, INDEX_MCP);
      const little = handJoint(h, s, LITTLE_MCP);
      const knuckles = index.clone().add(little).multiplyScalar(0.5);
      const along = knuckles.clone().sub(wrist);
      const side = index.clone().sub(little);
      const frame = frameFrom(along, side.clone().cross(along), new THREE.Matrix4());
      this._scale.set(side.length() + 0.022, along.length(), 2 * PALM_HALF_THICKNESS);
      frame.scale(this._scale).setPosition(wrist.clone().addScaledVector(along, 0.5));
      set(`palm_${s}`, frame);
      this.parts[`wristball_${s}`].matrix.makeTranslation(wrist);
    }
    this.group.updateMatrixWorld(true);
  }

  dispose() {
    this.group.traverse((o) => o.geometry && o.geometry.dispose());
    this.materials.forEach((m) => m.dispose());
  }
}

function handJoint(h, side, k, out = new THREE.Vector3()) {
  const i = (side * 20 + k) * 3;
  return out.set(h[i], h[i + 1], h[i + 2]);
}
