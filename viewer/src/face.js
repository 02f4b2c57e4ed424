// The mannequin's face, as renders/face_rig.py makes it: eyes whose pupils turn with the gaze,
// eyelids that close (eyeBlink) and squint, brows, a mouth that opens (jawOpen) and rounds
// (mouthFunnel, mouthPucker), lips whose corners smile, a tongue, a chin that drops with the jaw,
// cheeks and a nose. Each part is a small mesh (a unit ball, or a bar along x) placed in the
// head's frame (x to the character's left, y up, z out of the face; origin at the head's centre)
// by an affine map that faceMatrices() computes from the ARKit weights and the gaze, formula for
// formula as face_rig.part_transforms (tests/test_view_browser.py compares the two).

import * as THREE from 'three';

export const HEAD_RADII = [0.092, 0.112, 0.102];
const GAZE_GAIN = 1.5; // the pupils turn this many times the gaze (face_rig.GAZE_GAIN)

const SKIN = [0.80, 0.62, 0.48];
const LID = [0.68, 0.48, 0.37];
const EYE_WHITE = [0.93, 0.93, 0.90];
const PUPIL = [0.08, 0.09, 0.12];
const BROW = [0.24, 0.16, 0.11];
const MOUTH = [0.13, 0.02, 0.03];
const LIP = [0.55, 0.17, 0.16];
const TONGUE = [0.80, 0.36, 0.38];

const EYE_R = 0.024;
const LID_R = 1.14 * EYE_R;  // renders/face_rig.py's _LID_R
const EYE_AT = [0.039, 0.018];
const BROW_R = 0.0075;
const LIP_R = 0.0050;
const MOUTH_Y = -0.054;
const MOUTH_HALF_WIDTH = 0.030;
const BROW_INNER = 0.013;
const BROW_OUTER = 0.064;
const BROW_Y = 0.070; // the inner end's height at rest
const BROW_DROP = 0.010; // the outer end this much lower at rest
const BROW_INNER_UP = 0.024;
const BROW_OUTER_UP = 0.020;
const BROW_DOWN = 0.024;
const BROW_OUTER_DOWN = 0.004;
const BROW_KNIT = 0.008;
const LID_REST = 0.14;
const LID_LIFT = 0.008;
const LID_BROW_DOWN = 0.30;
const LOWER_LID_SQUINT = 0.70;
const PUPIL_WIDE = 0.25;
const CORNER_REST = 0.001;
const CORNER_SMILE = 0.030;
const CORNER_FROWN = 0.020;
const SMILE_LIFT = 0.33;
const BROW_HALF = (BROW_OUTER - BROW_INNER) / 2;
const LIP_HALF = MOUTH_HALF_WIDTH / 2;

// [name, shape, colour, roughness]: a shape is 'sphere' (a unit ball: its map holds the radii)
// or [radius, half]: a bar of that radius whose ends are `half` from its middle along x.
export const FACE_PARTS = [
  ['eye_l', 'sphere', EYE_WHITE, 0.35], ['eye_r', 'sphere', EYE_WHITE, 0.35],
  ['pupil_l', 'sphere', PUPIL, 0.3], ['pupil_r', 'sphere', PUPIL, 0.3],
  ['lid_l', 'sphere', LID, 0.6], ['lid_r', 'sphere', LID, 0.6],
  ['lower_lid_l', 'sphere', LID, 0.6], ['lower_lid_r', 'sphere', LID, 0.6],
  ['brow_l', [BROW_R, BROW_HALF], BROW, 0.8], ['brow_r', [BROW_R, BROW_HALF], BROW, 0.8],
  ['mouth', 'sphere', MOUTH, 0.5],
  ['tongue', 'sphere', TONGUE, 0.5],
  ['lip_upper_l', [LIP_R, LIP_HALF], LIP, 0.5], ['lip_upper_r', [LIP_R, LIP_HALF], LIP, 0.5],
  ['lip_lower_l', [LIP_R, LIP_HALF], LIP, 0.5], ['lip_lower_r', [LIP_R, LIP_HALF], LIP, 0.5],
  ['chin', 'sphere', SKIN, 0.6],
  ['cheek_l', 'sphere', SKIN, 0.6], ['cheek_r', 'sphere', SKIN, 0.6],
  ['nose', 'sphere', SKIN, 0.6],
];

// A part's mesh in its own frame: the shapes of face_rig.part_meshes, finer (sgt's software
// rasteriser draws balls of 10 x 6 faces, whose flat faces let a pupil show through a shut lid;
// a GPU can afford round ones).
export function faceGeometry(shape) {
  if (shape === 'sphere') return new THREE.SphereGeometry(1, 24, 16);
  const [radius, half] = shape;
  const g = new THREE.CapsuleGeometry(radius, 2 * half, 6, 12);
  g.rotateZ(-Math.PI / 2); // along x
  return g;
}

// z of the head ellipsoid's front at (x, y).
function surfaceZ(x, y) {
  const [a, b, c] = HEAD_RADII;
  return c * Math.sqrt(Math.max(0, 1 - (x / a) ** 2 - (y / b) ** 2));
}

// dz/dy of the head ellipsoid's front at (x, y), over the span the brows move (face_rig._surface_slope).
const surfaceSlope = (x, y) => (surfaceZ(x, y + 0.02) - surfaceZ(x, y - 0.02)) / 0.04;

const clip01 = (v) => Math.min(1, Math.max(0, v));

// An ellipsoid: radii on the diagonal, at `c`.
function ellipsoid(m, c, r) {
  m.set(r[0], 0, 0, c[0], 0, r[1], 0, c[1], 0, 0, r[2], c[2], 0, 0, 0, 1);
}

// A bar from `a` to `b` (taken left to right): x carried onto the bar's half extent, y and z kept.
function bar(m, a, b, half) {
  if (b[0] < a[0]) [a, b] = [b, a];
  const s = 1 / (2 * half);
  m.set((b[0] - a[0]) * s, 0, 0, (a[0] + b[0]) / 2,
    (b[1] - a[1]) * s, 1, 0, (a[1] + b[1]) / 2,
    (b[2] - a[2]) * s, 0, 1, (a[2] + b[2]) / 2, 0, 0, 0, 1);
}

const add = (p, q) => [p[0] + q[0], p[1] + q[1], p[2] + q[2]];

// The parts' maps in the head's frame, into `out` ({name: Matrix4}), for a face: `weight(name)`
// an ARKit weight (0 for any the take leaves out), `gaze` [left yaw, left pitch, right yaw, right
// pitch] in degrees (yaw to the character's left, pitch up).
export function faceMatrices(weight, gaze, out) {
  const w = (...names) => names.reduce((s, n) => s + clip01(weight(n)), 0) / names.length;
  const sides = [['l', 1, 'Left'], ['r', -1, 'Right']];
  sides.forEach(([s, sx, side], k) => {
    const eye = [sx * EYE_AT[0], EYE_AT[1], surfaceZ(EYE_AT[0], EYE_AT[1]) - 0.55 * EYE_R];
    ellipsoid(out[`eye_${s}`], eye, [EYE_R, EYE_R, EYE_R]);
    // the pupil: a flattened ball on the eye's front, turned by the gaze (yaw about y, pitch about x)
    const yaw = (gaze[2 * k] * GAZE_GAIN * Math.PI) / 180;
    const pitch = (gaze[2 * k + 1] * GAZE_GAIN * Math.PI) / 180;
    const fwd = new THREE.Vector3(Math.sin(yaw) * Math.cos(pitch), Math.sin(pitch), Math.cos(yaw) * Math.cos(pitch));
    const right = new THREE.Vector3(Math.cos(yaw), 0, -Math.sin(yaw));
    const up = new THREE.Vector3().crossVectors(fwd, right);
    const blink = w(`eyeBlink${side}`);
    const wide = w(`eyeWide${side}`);
    const squint = clip01(w(`eyeSquint${side}`) + w(`cheekSquint${side}`));
    const size = 1 - PUPIL_WIDE * wide; // smaller in a wide eye
    const pupil = out[`pupil_${s}`].makeBasis(right.multiplyScalar(0.52 * EYE_R * size), up.multiplyScalar(0.52 * EYE_R * size),
      fwd.clone().multiplyScalar(0.2 * EYE_R * size));
    pupil.setPosition(eye[0] + 0.84 * EYE_R * fwd.x, eye[1] + 0.84 * EYE_R * fwd.y, eye[2] + 0.84 * EYE_R * fwd.z);
    // the upper lid covers the ball from the top down: its height runs LID_REST (open) .. 1 (shut), up
    // off the ball as the eye widens, down as the brow lowers; a squint raises the lower lid
    const down = w(`browDown${side}`);
    const h = Math.min(1, Math.max(0.02, LID_REST + (1 - LID_REST) * blink - LID_REST * wide + 0.08 * squint + LID_BROW_DOWN * down));
    ellipsoid(out[`lid_${s}`], add(eye, [0, LID_R * (1 - h) + LID_LIFT * wide, 0]), [LID_R, LID_R * h, LID_R]);
    const lo = Math.min(1, Math.max(0.02, 0.10 + LOWER_LID_SQUINT * squint - 0.06 * wide));
    ellipsoid(out[`lower_lid_${s}`], add(eye, [0, -LID_R * (1 - lo), 0]), [LID_R, LID_R * lo, LID_R]);
    // brows: inner and outer ends, each keeping to the forehead as it moves
    const innerUp = w('browInnerUp');
    const outerUp = w(`browOuterUp${side}`);
    const dyi = BROW_INNER_UP * innerUp - BROW_DOWN * down;
    const dyo = BROW_OUTER_UP * outerUp - BROW_OUTER_DOWN * down;
    const yo = BROW_Y - BROW_DROP;
    bar(out[`brow_${s}`], [sx * (BROW_INNER - BROW_KNIT * down), BROW_Y + dyi,
      surfaceZ(BROW_INNER, BROW_Y) + 0.003 + surfaceSlope(BROW_INNER, BROW_Y) * dyi + 0.003 * down],
    [sx * BROW_OUTER, yo + dyo, surfaceZ(BROW_OUTER, yo) + 0.002 + surfaceSlope(BROW_OUTER, yo) * dyo], BROW_HALF);
  });
  // the mouth: width, opening, where its middle is, its corners
  const jaw = w('jawOpen');
  const funnel = w('mouthFunnel');
  const pucker = w('mouthPucker');
  const stretch = w('mouthStretchLeft', 'mouthStretchRight');
  const smile = w('mouthSmileLeft', 'mouthSmileRight');
  const closing = clip01(w('mouthClose') + 0.5 * w('mouthPressLeft', 'mouthPressRight') + 0.5 * w('mouthRollLower', 'mouthRollUpper'));
  const upperUp = w('mouthUpperUpLeft', 'mouthUpperUpRight');
  const lowerDown = w('mouthLowerDownLeft', 'mouthLowerDownRight');
  const press = w('mouthPressLeft', 'mouthPressRight');
  const halfW = MOUTH_HALF_WIDTH * (1 + 0.40 * stretch + 0.30 * smile + 0.12 * w('mouthDimpleLeft', 'mouthDimpleRight') -
    0.45 * pucker - 0.28 * funnel - 0.15 * press);
  const opening = 0.022 * jaw + 0.006 * lowerDown + 0.008 * upperUp + 0.008 * funnel + 0.010 * stretch;
  const halfH = Math.max(0.0012, 0.0022 + opening * (1 - 0.85 * closing) - 0.0012 * closing);
  const centre = [
    0.008 * (w('mouthLeft') - w('mouthRight')) + 0.006 * (w('jawLeft') - w('jawRight')),
    MOUTH_Y - 0.008 * jaw + 0.008 * upperUp - 0.002 * lowerDown + 0.003 * w('mouthShrugUpper') + SMILE_LIFT * CORNER_SMILE * smile,
    surfaceZ(0, MOUTH_Y) - 0.004 + 0.007 * pucker + 0.004 * funnel + 0.006 * w('jawForward'),
  ];
  ellipsoid(out.mouth, centre, [halfW * (1 - 0.5 * smile), halfH, 0.009]); // narrower as the corners rise
  ellipsoid(out.tongue, add(centre, [0, -0.5 * halfH, -0.012 + 0.028 * w('tongueOut')]), [0.012, 0.005, 0.013]);
  for (const [s, sx, side] of sides) {
    const corner = add(centre, [sx * halfW, CORNER_REST + (1 - SMILE_LIFT) * CORNER_SMILE * w(`mouthSmile${side}`) -
      CORNER_FROWN * w(`mouthFrown${side}`) - 0.005 * w(`mouthStretch${side}`), -0.004 * w(`mouthDimple${side}`)]);
    for (const [lip, sign, part] of [['upper', 1, 'Upper'], ['lower', -1, 'Lower']]) {
      const middle = add(centre, [0, sign * (halfH + 0.6 * LIP_R) + 0.005 * w(`mouthShrug${part}`), 0.004 - 0.004 * w(`mouthRoll${part}`)]);
      bar(out[`lip_${lip}_${s}`], middle, corner, LIP_HALF);
    }
  }
  // chin, cheeks, nose
  ellipsoid(out.chin, [0.010 * (w('jawLeft') - w('jawRight')), -0.075 - 0.022 * jaw, 0.045 + 0.010 * w('jawForward')],
    [0.036, 0.024, 0.034]);
  const puff = 0.028 * (1 + 0.5 * w('cheekPuff'));
  for (const [s, sx, side] of sides) {
    ellipsoid(out[`cheek_${s}`], [sx * 0.045, -0.028 + 0.006 * w(`cheekSquint${side}`), 0.045], [puff, puff, puff]);
  }
  const sneer = w('noseSneerLeft', 'noseSneerRight');
  ellipsoid(out.nose, [0, -0.012 + 0.008 * sneer, surfaceZ(0, -0.012) - 0.004], [0.016 * (1 + 0.30 * sneer), 0.019, 0.026]);
  return out;
}

// A speaker's face on the page: its weights and gaze per frame (page.py face_of), sampled at
// a time between two frames as the joints are (in a straight line).
export class FaceTrack {
  constructor(face) {
    this.channels = face.channels;
    this.index = Object.fromEntries(face.channels.map((n, i) => [n, i]));
    this.weights = Float32Array.from(face.weights);
    this.gaze = Float32Array.from(face.gaze);
    this.w = new Float32Array(face.channels.length);
    this.g = new Float32Array(4);
    this.weight = (name) => { const i = this.index[name]; return i === undefined ? 0 : this.w[i]; };
  }

  // frame `i`, `a` of the way to the next one
  at(i, a) {
    const c = this.channels.length;
    const n = this.gaze.length / 4;
    const j = Math.min(i + 1, n - 1);
    for (let k = 0; k < c; k++) this.w[k] = this.weights[c * i + k] + a * (this.weights[c * j + k] - this.weights[c * i + k]);
    for (let k = 0; k < 4; k++) this.g[k] = this.gaze[4 * i + k] + a * (this.gaze[4 * j + k] - this.gaze[4 * i + k]);
    return this;
  }
}

// A resting face: weights 0, eyes ahead.
export const NEUTRAL = { weight: () => 0, g: [0, 0, 0, 0] };
