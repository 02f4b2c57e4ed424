// Posing the skeleton by hand, for the page's pose editor: core/ik.py, function for function
// (tests/test_pose_ik.py runs both on the same poses and targets and compares them within 1e-6).
// A pose is 27 numbers: the unit directions of the skeleton's 9 bones (core/skeleton.py); every
// function returns a new pose and leaves its input alone. No three.js here: plain arrays.

export const BONES = ['neck', 'nose', 'head_top', 'left_shoulder', 'left_elbow', 'left_wrist', 'right_shoulder', 'right_elbow', 'right_wrist'];
export const JOINTS = ['spine', 'neck', 'nose', 'head_top', 'left_shoulder', 'left_elbow', 'left_wrist', 'right_shoulder', 'right_elbow', 'right_wrist'];
const PARENT = {
  neck: 'spine', nose: 'neck', head_top: 'nose', left_shoulder: 'neck', left_elbow: 'left_shoulder', left_wrist: 'left_elbow',
  right_shoulder: 'neck', right_elbow: 'right_shoulder', right_wrist: 'right_elbow',
};
export const LENGTHS = {
  neck: 0.42, nose: 0.20, head_top: 0.14, left_shoulder: 0.18, left_elbow: 0.29, left_wrist: 0.26,
  right_shoulder: 0.18, right_elbow: 0.29, right_wrist: 0.26,
};
export const ROOT = [0, 1, 0];
export const SIDES = ['left', 'right'];
export const ELBOW_FLEXION = [0, 155];
export const HEAD_LIMITS = { yaw: [-80, 80], pitch: [-50, 60], roll: [-40, 40] };
export const TORSO_LEAN = 45;
export const SHOULDER_ELEVATION = [-20, 40];
export const SHOULDER_PROTRACTION = [-30, 30];
export const PALMS = ['down', 'up', 'in', 'out', 'forward', 'back'];
const SWIVEL_REFERENCE = [0, -1 / Math.SQRT2, -1 / Math.SQRT2];
const UP = [0, 1, 0];
const RAD = Math.PI / 180;

// -- vectors -------------------------------------------------------------------------------------

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const scale = (a, k) => [a[0] * k, a[1] * k, a[2] * k];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => Math.sqrt(dot(a, a));
const clamp = (x, lo, hi) => Math.min(Math.max(x, lo), hi);
function unit(a) {
  const n = norm(a);
  return n > 0 ? scale(a, 1 / n) : a;
}
const reject = (v, axis) => sub(v, scale(axis, dot(v, axis)));

function checked(pose) {
  if (!pose || pose.length !== 27 || ![...pose].every(Number.isFinite)) throw new Error('a pose is 27 finite numbers');
  return Array.from(pose, Number);
}
const get = (p, bone) => { const i = 3 * BONES.indexOf(bone); return [p[i], p[i + 1], p[i + 2]]; };
function set(p, bone, d) {
  const i = 3 * BONES.indexOf(bone);
  const u = unit(d);
  p[i] = u[0]; p[i + 1] = u[1]; p[i + 2] = u[2];
}
function side(s) {
  if (s !== 'left' && s !== 'right') throw new Error(`side must be 'left' or 'right', got ${s}`);
  return s;
}

// The joints' positions (10 x [x, y, z], JOINTS order) of a pose: core.skeleton.positions_from_pose.
export function positions(pose) {
  const p = checked(pose);
  const at = { spine: ROOT.slice() };
  for (const bone of BONES) at[bone] = add(at[PARENT[bone]], scale(get(p, bone), LENGTHS[bone]));
  return JOINTS.map((j) => at[j]);
}
const joint = (x, name) => x[JOINTS.indexOf(name)];

// -- arms ------------------------------------------------------------------------------------------

export function reach(s = 'right') {
  const a = LENGTHS[`${side(s)}_elbow`];
  const b = LENGTHS[`${s}_wrist`];
  const [lo, hi] = ELBOW_FLEXION.map((x) => x * RAD);
  return [Math.sqrt(a * a + b * b + 2 * a * b * Math.cos(hi)), Math.sqrt(a * a + b * b + 2 * a * b * Math.cos(lo))];
}

export function elbowFlexion(pose, s) {
  const p = checked(pose);
  const u = unit(get(p, `${side(s)}_elbow`));
  const f = unit(get(p, `${s}_wrist`));
  return Math.acos(clamp(dot(u, f), -1, 1)) / RAD;
}

function swivelFrame(axis, s) {
  let zero = reject(SWIVEL_REFERENCE, axis);
  if (norm(zero) < 1e-6) zero = reject([s === 'right' ? -1 : 1, 0, 0], axis);
  zero = unit(zero);
  const out = scale(cross(axis, zero), s === 'right' ? -1 : 1);
  return [zero, out];
}

export function swivel(pose, s) {
  const x = positions(pose);
  side(s);
  const [sh, e, w] = ['shoulder', 'elbow', 'wrist'].map((j) => joint(x, `${s}_${j}`));
  const axis = unit(sub(w, sh));
  const off = reject(sub(e, sh), axis);
  if (norm(off) < 1e-9) return 0;
  const [zero, out] = swivelFrame(axis, s);
  return Math.atan2(dot(off, out), dot(off, zero)) / RAD;
}

// The `s` wrist at `target` (or the nearest point in reach), the shoulder kept; the elbow at
// `options.swivel` degrees, else as near `options.pole` as it can, else as near where it was.
export function solveArm(pose, s, target, options = {}) {
  const p = checked(pose);
  side(s);
  const a = LENGTHS[`${s}_elbow`];
  const b = LENGTHS[`${s}_wrist`];
  const x = positions(p);
  const [sh, e, w] = ['shoulder', 'elbow', 'wrist'].map((j) => joint(x, `${s}_${j}`));
  const t = Array.from(target, Number);
  if (t.length !== 3 || !t.every(Number.isFinite)) throw new Error('the target must be 3 finite numbers');
  const [lo, hi] = reach(s);
  const v = sub(t, sh);
  let d = norm(v);
  const axis = d > 1e-9 ? unit(v) : unit(sub(w, sh));
  d = clamp(d, lo, hi);
  const along = (a * a - b * b + d * d) / (2 * d);
  const radius = Math.sqrt(Math.max(a * a - along * along, 0));
  const [zero, out] = swivelFrame(axis, s);
  let toward;
  if (options.swivel !== undefined && options.swivel !== null) {
    const angle = options.swivel * RAD;
    toward = add(scale(zero, Math.cos(angle)), scale(out, Math.sin(angle)));
  } else {
    toward = reject(sub(options.pole ? Array.from(options.pole, Number) : e, sh), axis);
    toward = norm(toward) > 1e-9 ? unit(toward) : zero;
  }
  const elbow = add(add(sh, scale(axis, along)), scale(toward, radius));
  const wrist = add(sh, scale(axis, d));
  set(p, `${s}_elbow`, sub(elbow, sh));
  set(p, `${s}_wrist`, sub(wrist, elbow));
  return p;
}

// -- the head ----------------------------------------------------------------------------------------

// A rotation as rows: [[r00, r01, r02], [r10, ...], ...]
const mul = (A, B) => A.map((row) => [0, 1, 2].map((j) => row[0] * B[0][j] + row[1] * B[1][j] + row[2] * B[2][j]));
const transpose = (A) => [0, 1, 2].map((i) => [A[0][i], A[1][i], A[2][i]]);
const apply = (A, v) => A.map((row) => dot(row, v));

function headFrame(nose, top) { // columns: the nose, the head top square to it, their cross product
  const f = unit(nose);
  const u = unit(reject(top, f));
  const c = cross(f, u);
  return [[f[0], u[0], c[0]], [f[1], u[1], c[1]], [f[2], u[2], c[2]]];
}
const REST_HEAD = headFrame(unit([0, 0.78, 0.62]), unit([0, 0.9, -0.42]));

function rotation(yaw, pitch, roll) {
  const [y, x, z] = [yaw * RAD, pitch * RAD, roll * RAD];
  const ry = [[Math.cos(y), 0, Math.sin(y)], [0, 1, 0], [-Math.sin(y), 0, Math.cos(y)]];
  const rx = [[1, 0, 0], [0, Math.cos(x), -Math.sin(x)], [0, Math.sin(x), Math.cos(x)]];
  const rz = [[Math.cos(z), -Math.sin(z), 0], [Math.sin(z), Math.cos(z), 0], [0, 0, 1]];
  return mul(mul(ry, rx), rz);
}

export function headRotation(pose) {
  const p = checked(pose);
  return mul(headFrame(get(p, 'nose'), get(p, 'head_top')), transpose(REST_HEAD));
}

// [yaw, pitch, roll] in degrees of a rotation (rows) Ry(yaw) Rx(pitch) Rz(roll).
export function anglesOf(r) {
  const pitch = Math.asin(clamp(-r[1][2], -1, 1));
  return [Math.atan2(r[0][2], r[2][2]) / RAD, pitch / RAD, Math.atan2(r[1][0], r[1][1]) / RAD];
}

export function headAngles(pose) {
  return anglesOf(headRotation(pose));
}

export function setHead(pose, yaw, pitch, roll) {
  const p = checked(pose);
  const limits = Object.values(HEAD_LIMITS);
  const angles = [yaw, pitch, roll].map((v, i) => clamp(Number(v), limits[i][0], limits[i][1]));
  const turn = mul(rotation(...angles), transpose(headRotation(p)));
  for (const bone of ['nose', 'head_top']) set(p, bone, apply(turn, get(p, bone)));
  return p;
}

// -- torso and shoulders --------------------------------------------------------------------------------

function clampCone(direction, axis, degrees) {
  const d = unit(direction);
  const angle = Math.acos(clamp(dot(d, axis), -1, 1));
  const limit = degrees * RAD;
  if (angle <= limit) return d;
  let s = reject(d, axis);
  s = norm(s) > 1e-9 ? unit(s) : unit(reject([0, 0, 1], axis));
  return add(scale(axis, Math.cos(limit)), scale(s, Math.sin(limit)));
}

export function setTorso(pose, direction) {
  const p = checked(pose);
  const d = Array.from(direction, Number);
  if (d.length !== 3 || !d.every(Number.isFinite) || norm(d) < 1e-9) throw new Error('the direction must be 3 finite numbers, not all 0');
  set(p, 'neck', clampCone(d, UP, TORSO_LEAN));
  return p;
}

export function shoulderAngles(pose, s) {
  const v = unit(get(checked(pose), `${side(s)}_shoulder`));
  const out = s === 'right' ? -1 : 1;
  return [Math.asin(clamp(v[1], -1, 1)) / RAD, Math.atan2(v[2], v[0] * out) / RAD];
}

export function setShoulder(pose, s, direction) {
  const p = checked(pose);
  side(s);
  const d = unit(Array.from(direction, Number));
  if (d.length !== 3 || !d.every(Number.isFinite) || norm(d) < 0.5) throw new Error('the direction must be 3 finite numbers, not all 0');
  const out = s === 'right' ? -1 : 1;
  const elevation = clamp(Math.asin(clamp(d[1], -1, 1)), SHOULDER_ELEVATION[0] * RAD, SHOULDER_ELEVATION[1] * RAD);
  const protraction = clamp(Math.atan2(d[2], d[0] * out), SHOULDER_PROTRACTION[0] * RAD, SHOULDER_PROTRACTION[1] * RAD);
  const flat = Math.cos(elevation);
  set(p, `${s}_shoulder`, [out * flat * Math.cos(protraction), Math.sin(elevation), flat * Math.sin(protraction)]);
  return p;
}

// -- the forearm's twist -------------------------------------------------------------------------------------

export function palmDirection(name, s) {
  const inward = s === 'left' ? -1 : 1;
  return { down: [0, -1, 0], up: [0, 1, 0], in: [inward, 0, 0], out: [-inward, 0, 0], forward: [0, 0, 1], back: [0, 0, -1] }[name];
}

export function nearestPalm(palm, s) {
  let best = PALMS[0];
  let score = -Infinity;
  for (const name of PALMS) {
    const v = dot(palmDirection(name, s), palm);
    if (v > score) { best = name; score = v; }
  }
  return best;
}

export function twistPalm(pose, s, palm, degrees) {
  if (!PALMS.includes(palm)) throw new Error(`unknown palm ${palm}`);
  const p = checked(pose);
  side(s);
  const axis = unit(get(p, `${s}_wrist`));
  const n = palmDirection(palm, s);
  const angle = degrees * RAD * (s === 'right' ? 1 : -1);
  const c = Math.cos(angle);
  const turned = add(add(scale(n, c), scale(cross(axis, n), Math.sin(angle))), scale(axis, dot(axis, n) * (1 - c)));
  return nearestPalm(turned, s);
}
