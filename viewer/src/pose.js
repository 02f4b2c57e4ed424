// The page's pose editor: make a gesture by hand (docs/view.md, "Pose it yourself").
//
// The gesture being made is what library/posing.py's Draft holds (its JSON: keyframes with their
// times, labels, the stroke mark, each with the whole pose, 27 numbers, and both hands by name;
// the limbs it drives). The figure shows the keyframe chosen; handles on its joints move it:
// a wrist dragged moves the arm by inverse kinematics at its bone lengths (ik.js, core/ik.py's
// twin), an elbow swivels about the shoulder-wrist line, a shoulder shrugs, the neck leans the
// torso; the head and the forearm (the palm's turn) have rotation rings. The server computes
// what sgt computes: the hands of a pose (api/pose/frame), the gesture played as the library
// plays it, with its spec file's text (api/pose/preview), the take with the gesture at a word
// (api/pose/context), and, with the page's edit token, saves the gesture and puts it at a word.
// Every edit can be undone and redone.

import * as THREE from 'three';
import { TransformControls } from 'three/examples/jsm/controls/TransformControls.js';
import { Mannequin } from './mannequin.js';
import * as ik from './ik.js';

const TINT = [0.25, 0.36, 0.55];
const HANDLE_COLOR = 0xf2a23a;
const HEAD_COLOR = 0x3aa0f2;
const HANDLES = [ // [name, joint, radius]
  ['neck', 'neck', 0.035], ['left_shoulder', 'left_shoulder', 0.032], ['right_shoulder', 'right_shoulder', 0.032],
  ['left_elbow', 'left_elbow', 0.032], ['right_elbow', 'right_elbow', 0.032],
  ['left_wrist', 'left_wrist', 0.036], ['right_wrist', 'right_wrist', 0.036],
];
const LIMB_NAMES = { torso: 'torso', head: 'head', left_arm: 'left arm', right_arm: 'right arm' };
const FPS = 15;
const copy = (x) => JSON.parse(JSON.stringify(x));
const flat = (joints) => joints.flat();

export class PoseEditor {
  // deps: {scene, camera, canvas, controls (OrbitControls), request(url, options), base ('api/pose/' or
  // '../v1/pose/'), take() (the take shown), time() (its time), showTake(doc), leavePreview(),
  // status(text), redraw(), editToken()}
  constructor(deps) {
    this.d = deps;
    this.active = false;
    this.info = null;
    this.gesture = null;
    this.key = 0;
    this.undoStack = [];
    this.redoStack = [];
    this.saved = null; // JSON of the gesture as last saved (or opened from a file)
    this.source = null; // {name, folder, sha256} of the file it was opened from or saved to
    this.hands = null; // the hand joints (120 numbers) of the pose shown
    this.handsFor = '';
    this.inFlight = false;
    this.playing = null;
    this.previewing = false;
    this.message = '';
    this.wordChoice = null; // {utterance, n, word, start}
    this.group = new THREE.Group();
    this.group.visible = false;
    deps.scene.add(this.group);
    this.handles = {};
    for (const [name, , r] of HANDLES) this._handle(name, r, HANDLE_COLOR);
    this._handle('head', 0.04, HEAD_COLOR);
    this.raycaster = new THREE.Raycaster();
    this.drag = null;
    this.gizmo = new TransformControls(deps.camera, deps.canvas);
    this.gizmo.setMode('rotate');
    this.gizmo.setSize(0.7);
    this.gizmo.enabled = false;
    this.proxy = new THREE.Object3D();
    deps.scene.add(this.proxy);
    this.gizmoHelper = this.gizmo.getHelper();
    this.gizmoHelper.visible = false;
    deps.scene.add(this.gizmoHelper);
    this.gizmo.addEventListener('dragging-changed', (e) => this._gizmoDragging(e.value));
    this.gizmo.addEventListener('objectChange', () => this._gizmoMoved());
    deps.canvas.addEventListener('pointerdown', (e) => this._press(e), { capture: true });
    window.addEventListener('pointermove', (e) => this._move(e));
    window.addEventListener('pointerup', (e) => this._release(e));
    this._panel();
  }

  _handle(name, radius, color) {
    const mesh = new THREE.Mesh(new THREE.SphereGeometry(radius, 16, 12),
      new THREE.MeshBasicMaterial({ color, transparent: true, opacity: 0.85, depthTest: false }));
    mesh.renderOrder = 10;
    mesh.name = name;
    this.group.add(mesh);
    this.handles[name] = mesh;
  }

  // -- requests -----------------------------------------------------------------------------------

  async _call(path, body, write = false) {
    const headers = { 'Content-Type': 'application/json' };
    if (write) headers['X-SGT-Edit'] = this.d.editToken();
    const r = await this.d.request(this.d.base + path, body === undefined ? {} : { method: 'POST', headers, body: JSON.stringify(body) });
    let answer;
    try { answer = await r.json(); } catch (e) { answer = { error: `the server answered ${r.status}` }; }
    return [r.status, answer];
  }

  async load() {
    const [status, info] = await this._call('info');
    if (status !== 200) throw new Error(info.error || `the pose editor's server answered ${status}`);
    this.info = info;
    this._fillPanel();
    return info;
  }

  // -- the gesture ------------------------------------------------------------------------------------

  // a new gesture as the server makes it (library/posing.py's new_draft: start, stroke, retract at rest)
  newGesture(name) {
    return { ...copy(this.info.new), name };
  }

  setGesture(gesture, key, source = null) {
    this.gesture = gesture;
    this.key = Math.max(0, Math.min(key, gesture.keyframes.length - 1));
    this.source = source;
    this.undoStack = [];
    this.redoStack = [];
    this.saved = source ? JSON.stringify(gesture) : null;
    this._changed();
  }

  async open(name) {
    const [status, answer] = await this._call(`gesture?name=${encodeURIComponent(name)}`);
    if (status !== 200) return this.say(answer.error);
    this.edit(() => {
      this.gesture = answer.gesture;
      this.key = Math.max(0, answer.gesture.keyframes.findIndex((k) => k.stroke));
    });
    this.source = { name: answer.gesture.name, folder: answer.folder, sha256: answer.sha256 };
    this.saved = answer.folder ? JSON.stringify(this.gesture) : null;
    this.say(`opened ${name} (${answer.origin === 'built-in' ? 'built in' : answer.path})`);
    this._changed();
  }

  get current() { return this.gesture.keyframes[this.key]; }

  // An edit: `change()` changes this.gesture (or this.key), undoable as one step.
  edit(change) {
    const before = JSON.stringify({ gesture: this.gesture, key: this.key });
    change();
    const after = JSON.stringify({ gesture: this.gesture, key: this.key });
    if (after === before) return false;
    this.undoStack.push(before);
    if (this.undoStack.length > 500) this.undoStack.shift();
    this.redoStack = [];
    this._changed();
    return true;
  }

  undo() { this._step(this.undoStack, this.redoStack); }
  redo() { this._step(this.redoStack, this.undoStack); }
  _step(from, to) {
    if (!from.length) return;
    to.push(JSON.stringify({ gesture: this.gesture, key: this.key }));
    const s = JSON.parse(from.pop());
    this.gesture = s.gesture;
    this.key = s.key;
    this._changed();
  }

  // the limbs a pose moves off the rest pose
  _moved(pose) {
    const rest = this.info.rest;
    return Object.entries(this.info.limbs).filter(([, bones]) => bones.some((b) => {
      const i = 3 * ik.BONES.indexOf(b);
      return pose[i] !== rest[i] || pose[i + 1] !== rest[i + 1] || pose[i + 2] !== rest[i + 2];
    })).map(([limb]) => limb);
  }

  driven() {
    const limbs = new Set(this.gesture.drives);
    for (const k of this.gesture.keyframes) this._moved(k.pose).forEach((l) => limbs.add(l));
    return Object.keys(this.info.limbs).filter((l) => limbs.has(l));
  }

  setPose(pose) {
    this.current.pose = Array.from(pose);
  }

  // A limb driven or not: a limb let go goes back to the rest pose in every keyframe.
  setDriven(limb, on) {
    this.edit(() => {
      const drives = new Set(this.gesture.drives);
      if (on) {
        drives.add(limb);
      } else {
        drives.delete(limb);
        for (const k of this.gesture.keyframes) {
          for (const b of this.info.limbs[limb]) {
            const i = 3 * ik.BONES.indexOf(b);
            for (let c = 0; c < 3; c++) k.pose[i + c] = this.info.rest[i + c];
          }
        }
      }
      this.gesture.drives = Object.keys(this.info.limbs).filter((l) => drives.has(l));
    });
  }

  addKey() {
    const t = this._newKeyTime();
    this.edit(() => {
      const k = this.gesture.keyframes;
      const at = k.findIndex((x) => x.time > t);
      const i = at < 0 ? k.length : at;
      const from = k[Math.max(0, i - 1)];
      k.splice(i, 0, { time: t, label: i === k.length ? 'retract' : (k.some((x) => x.stroke) && k.findIndex((x) => x.stroke) < i ? 'hold' : 'prepare'),
        stroke: false, pose: from.pose.slice(), hands: { ...from.hands } });
      this.gesture.duration = Math.max(this.gesture.duration, t);
      this.key = i;
    });
  }

  // between the keyframe shown and the next one (or after the last, the gesture made longer)
  _newKeyTime() {
    const k = this.gesture.keyframes;
    const here = k[this.key].time;
    if (this.key + 1 < k.length) return Math.round(((here + k[this.key + 1].time) / 2) * 1000) / 1000;
    return Math.round(Math.min(10, here + 0.3) * 1000) / 1000;
  }

  removeKey() {
    if (this.gesture.keyframes.length <= 1) return;
    this.edit(() => {
      this.gesture.keyframes.splice(this.key, 1);
      this.key = Math.min(this.key, this.gesture.keyframes.length - 1);
    });
  }

  setStroke() {
    this.edit(() => {
      this.gesture.keyframes.forEach((k, i) => { k.stroke = i === this.key ? !k.stroke : false; });
      if (this.current.stroke && !this.current.label) this.current.label = 'stroke';
    });
  }

  // keyframe i moved to time t (to the hundredth of a second, between its neighbours, inside the gesture)
  setTime(i, t) {
    const k = this.gesture.keyframes;
    const lo = i > 0 ? k[i - 1].time + 0.01 : 0;
    const hi = i + 1 < k.length ? k[i + 1].time - 0.01 : this.gesture.duration;
    k[i].time = Math.round(Math.max(lo, Math.min(hi, t)) * 100) / 100;
  }

  mirror() {
    return this._server('mirror', (answer) => { this.gesture = answer.gesture; });
  }

  // The current keyframe takes the pose and hands of the take's frame shown (speaker `s`).
  fromFrame(frame, s = 0) {
    const take = this.d.take();
    if (!take) return;
    const sp = take.speakers[Math.min(s, take.speakers.length - 1)];
    const x = (j) => sp.positions.slice(30 * frame + 3 * j, 30 * frame + 3 * j + 3);
    const parent = { neck: 0, nose: 1, head_top: 2, left_shoulder: 1, left_elbow: 4, left_wrist: 5, right_shoulder: 1, right_elbow: 7, right_wrist: 8 };
    const pose = [];
    ik.BONES.forEach((b, i) => {
      const a = x(parent[b]);
      const c = x(i + 1);
      const d = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
      const n = Math.hypot(...d);
      pose.push(d[0] / n, d[1] / n, d[2] / n);
    });
    const names = sp.hand_names.slice(4 * frame, 4 * frame + 4);
    const hands = { left_hand: take.shapes[names[0]], left_palm: take.palms[names[1]], right_hand: take.shapes[names[2]], right_palm: take.palms[names[3]] };
    this.edit(() => {
      this.current.pose = pose;
      this.current.hands = hands;
    });
    this.say(`keyframe ${this.key + 1} is now frame ${frame} of the take`);
  }

  async _server(path, apply) {
    const before = JSON.stringify({ gesture: this.gesture, key: this.key });
    const [status, answer] = await this._call(path, { gesture: this.gesture });
    if (status !== 200) return this.say(answer.error);
    if (JSON.stringify({ gesture: this.gesture, key: this.key }) !== before) return this.say('changed meanwhile: try again');
    this.edit(() => apply(answer));
    return answer;
  }

  // -- showing it ------------------------------------------------------------------------------------

  dirty() { return this.saved !== JSON.stringify(this.gesture); }

  redraw() { this._changed(); }

  _changed() {
    if (!this.gesture) return;
    this._show(this.current.pose);
    if (this.active && this.gizmoWhat && !this.gizmoStart) this._attachGizmo(this.gizmoWhat); // the rings where the joint is now
    this._fillPanel();
    this.d.redraw();
  }

  _ensureFigure(hands) {
    if (this.figure) return;
    this.figure = new Mannequin(TINT, Float32Array.from(hands));
    this.group.add(this.figure.group);
  }

  // The figure at `pose` (27 numbers) with the current keyframe's hands: the hands' joints as sgt
  // places them come from the server; until they do, the last ones carried along with the forearms.
  _show(pose, hands = this.current.hands) {
    const joints = ik.positions(pose);
    const key = JSON.stringify([pose, hands]);
    if (this.hands && this.handsFor !== key) this.hands = carry(this.shownJoints, joints, this.hands);
    this.shownJoints = joints;
    if (this.hands) {
      this._ensureFigure(this.hands);
      this.figure.pose(Float32Array.from(flat(joints)), Float32Array.from(this.hands));
    }
    for (const [name, joint] of HANDLES) this.handles[name].position.fromArray(joints[ik.JOINTS.indexOf(joint)]);
    const top = joints[ik.JOINTS.indexOf('head_top')];
    const neck = joints[ik.JOINTS.indexOf('neck')];
    this.handles.head.position.set(...top).lerp(new THREE.Vector3(...neck), 0.3);
    if (this.handsFor !== key) this._askHands(pose, hands, key);
    this.d.redraw();
  }

  async _askHands(pose, hands, key) {
    this.wanted = [pose, hands, key];
    if (this.inFlight) return;
    this.inFlight = true;
    try {
      while (this.wanted) {
        const [p, h, k] = this.wanted;
        this.wanted = null;
        const [status, answer] = await this._call('frame', { pose: Array.from(p), hands: h });
        if (status !== 200) { this.say(answer.error); break; }
        this.angles = answer.angles;
        if (!this.wanted) {
          this.hands = answer.hands;
          this.handsFor = k;
          this.shownJoints = ik.positions(p);
          if (!this.playing) this._show(p, h);
        }
      }
    } catch (e) {
      this.say(String(e.message || e));
    } finally {
      this.inFlight = false;
    }
  }

  setActive(on) {
    this.active = on;
    this.group.visible = on;
    if (!on) this._detachGizmo();
    this.panel.hidden = !on;
    if (on && this.gesture) this._changed();
    this.d.redraw();
  }

  // -- dragging the handles ------------------------------------------------------------------------------

  _ray(e) {
    const r = this.d.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
    this.raycaster.setFromCamera(ndc, this.d.camera);
    return this.raycaster.ray;
  }

  _press(e) {
    if (!this.active || this.playing || e.button !== 0 || this.gizmo.dragging) return;
    this._ray(e);
    const hit = this.raycaster.intersectObjects(Object.values(this.handles), false)[0];
    if (!hit) return;
    e.stopImmediatePropagation();
    e.preventDefault(); // (which keeps the focus where it was: a field typed in last would keep the keys)
    if (document.activeElement && document.activeElement !== document.body) document.activeElement.blur();
    this.d.controls.enabled = false;
    const name = hit.object.name;
    const normal = this.d.camera.getWorldDirection(new THREE.Vector3());
    this.drag = { name, plane: new THREE.Plane().setFromNormalAndCoplanarPoint(normal, hit.object.position.clone()),
      before: JSON.stringify({ gesture: this.gesture, key: this.key }), moved: false, pointer: e.pointerId,
      offset: hit.object.position.clone().sub(hit.point) };
    this.select(name);
  }

  _move(e) {
    if (!this.drag || e.pointerId !== this.drag.pointer) return;
    const at = this._ray(e).intersectPlane(this.drag.plane, new THREE.Vector3());
    if (!at) return;
    at.add(this.drag.offset);
    const target = at.toArray();
    const pose = this.current.pose;
    const x = ik.positions(pose);
    const J = (j) => x[ik.JOINTS.indexOf(j)];
    const name = this.drag.name;
    let next = null;
    if (name.endsWith('_wrist')) next = ik.solveArm(pose, name.split('_')[0], target);
    else if (name.endsWith('_elbow')) { const s = name.split('_')[0]; next = ik.solveArm(pose, s, J(`${s}_wrist`), { pole: target }); }
    else if (name.endsWith('_shoulder')) next = ik.setShoulder(pose, name.split('_')[0], sub(target, J('neck')));
    else if (name === 'neck') next = ik.setTorso(pose, sub(target, J('spine')));
    if (!next) return;
    this.drag.moved = true;
    this.setPose(next);
    this._show(this.current.pose);
  }

  _release(e) {
    if (!this.drag || e.pointerId !== this.drag.pointer) return;
    const drag = this.drag;
    this.drag = null;
    this.d.controls.enabled = true;
    if (drag.moved && drag.before !== JSON.stringify({ gesture: this.gesture, key: this.key })) {
      this.undoStack.push(drag.before);
      this.redoStack = [];
    }
    this._changed();
  }

  // A handle chosen: the head gets its rotation rings, a wrist or an elbow its forearm's twist ring.
  select(name) {
    this.selected = name;
    if (name === 'head') this._attachGizmo('head');
    else if (name.endsWith('_wrist') || name.endsWith('_elbow')) this._attachGizmo(`${name.split('_')[0]}_twist`);
    else this._detachGizmo();
    this._fillPanel();
  }

  _attachGizmo(what) {
    const x = ik.positions(this.current.pose);
    const J = (j) => new THREE.Vector3(...x[ik.JOINTS.indexOf(j)]);
    this.gizmoWhat = what;
    if (what === 'head') {
      this.proxy.position.copy(this.handles.head.position);
      this.proxy.quaternion.setFromRotationMatrix(matrixOf(ik.headRotation(this.current.pose)));
      this.gizmo.setSpace('local');
      this.gizmo.showX = this.gizmo.showY = this.gizmo.showZ = true;
    } else {
      const s = what.split('_')[0];
      const along = J(`${s}_wrist`).sub(J(`${s}_elbow`)).normalize();
      this.proxy.position.copy(J(`${s}_elbow`).lerp(J(`${s}_wrist`), 0.6));
      this.proxy.quaternion.setFromUnitVectors(new THREE.Vector3(1, 0, 0), along);
      this.gizmo.setSpace('local');
      this.gizmo.showX = true;
      this.gizmo.showY = this.gizmo.showZ = false;
    }
    this.proxy.updateMatrixWorld(true);
    this.gizmo.attach(this.proxy);
    this.gizmo.enabled = true;
    this.gizmoHelper.visible = true;
    this.d.redraw();
  }

  _detachGizmo() {
    this.gizmo.detach();
    this.gizmo.enabled = false;
    this.gizmoHelper.visible = false;
    this.gizmoWhat = null;
  }

  _gizmoDragging(on) {
    this.d.controls.enabled = !on;
    if (on) {
      this.gizmoStart = { before: JSON.stringify({ gesture: this.gesture, key: this.key }), pose: this.current.pose.slice(),
        hands: { ...this.current.hands }, q: this.proxy.quaternion.clone() };
    } else if (this.gizmoStart) {
      if (this.gizmoStart.before !== JSON.stringify({ gesture: this.gesture, key: this.key })) {
        this.undoStack.push(this.gizmoStart.before);
        this.redoStack = [];
      }
      this.gizmoStart = null;
      this._attachGizmo(this.gizmoWhat); // the rings where the head or forearm is now
      this._changed();
    }
  }

  _gizmoMoved() {
    const start = this.gizmoStart;
    if (!start) return;
    if (this.gizmoWhat === 'head') {
      const m = new THREE.Matrix4().makeRotationFromQuaternion(this.proxy.quaternion).elements;
      const r = [[m[0], m[4], m[8]], [m[1], m[5], m[9]], [m[2], m[6], m[10]]];
      this.setPose(ik.setHead(start.pose, ...ik.anglesOf(r)));
    } else {
      const s = this.gizmoWhat.split('_')[0];
      const turn = start.q.clone().invert().multiply(this.proxy.quaternion); // about the proxy's x: the forearm
      const degrees = (2 * Math.atan2(turn.x, turn.w) * 180) / Math.PI;
      this.current.hands[`${s}_palm`] = ik.twistPalm(start.pose, s, start.hands[`${s}_palm`], degrees);
    }
    this._show(this.current.pose);
  }

  // -- playing -----------------------------------------------------------------------------------------

  async play() {
    if (this.playing) return this.stop();
    const [status, answer] = await this._call('preview', { gesture: this.gesture });
    if (status !== 200) return this.say(answer.error);
    this.lastPreview = answer;
    this._showText(answer.text);
    const started = performance.now();
    this.playing = { answer, started };
    const step = () => {
      if (!this.playing || this.playing.answer !== answer) return;
      const f = Math.floor(((performance.now() - started) / 1000) * FPS);
      if (f >= answer.frames) { this.stop(); return; }
      const p = answer.positions.slice(30 * f, 30 * f + 30);
      const h = answer.hands.slice(120 * f, 120 * f + 120);
      this._ensureFigure(h);
      this.figure.pose(Float32Array.from(p), Float32Array.from(h));
      this.playingFrame = f;
      this.d.redraw();
      requestAnimationFrame(step);
    };
    this.say(`playing ${this.gesture.name}: ${answer.frames} frames, the stroke at frame ${answer.stroke_frame ?? '-'}`);
    requestAnimationFrame(step);
    return answer;
  }

  stop() {
    this.playing = null;
    this._changed();
  }

  // The take with the gesture before the chosen word, generated by the server without writing.
  async playInContext() {
    const take = this.d.take();
    const word = this.wordChoice;
    if (!take || !take.script || !word) return this.say('choose a word of the script first (a click on a word of the timeline)');
    this.say(`generating the take with [pose:${this.gesture.name}] before '${word.word}'…`);
    const [status, answer] = await this._call('context', { gesture: this.gesture, utterance: word.utterance, word: word.n, sha256: take.script.sha256 });
    if (status !== 200) return this.say(answer.error);
    this.previewing = true;
    this.setActive(false);
    this.panel.hidden = false;
    await this.d.showTake(answer, word.start);
    this.say(`showing the take with [pose:${this.gesture.name}] before '${word.word}' (nothing saved): Pose returns to posing`);
    this._fillPanel();
    return answer;
  }

  // -- saving --------------------------------------------------------------------------------------------

  async save(replace = false, sha256 = undefined) {
    const info = this.info;
    const choice = this.el.folder.value;
    if (!info.can_write || !choice) {
      const [status, answer] = await this._call('preview', { gesture: this.gesture });
      if (status !== 200) return this.say(answer.error);
      this._showText(answer.text, true);
      return this.say(info.can_write ? 'choose a folder to save in' : 'this page cannot write files: download or copy the TOML below');
    }
    const body = { gesture: this.gesture, replace };
    if (choice === '+new') {
      body.new_folder = this.el.newFolder.value.trim();
      const take = this.d.take();
      body.script_sha256 = take && take.script ? take.script.sha256 : null;
    } else {
      body.folder = choice;
    }
    if (sha256 !== undefined) body.sha256 = sha256;
    else if (this.source && this.source.name === this.gesture.name && this.source.folder === choice) body.sha256 = this.source.sha256;
    const [status, answer] = await this._call('save', body, true);
    if (status === 409 && answer.exists) {
      this.pendingReplace = answer.sha256;
      this.el.replace.hidden = false;
      return this.say(answer.error);
    }
    if (status !== 200) return this.say(answer.error);
    this.pendingReplace = undefined;
    this.el.replace.hidden = true;
    this.gesture = answer.gesture; // as read back from the file: the same keyframes (the same text again)
    this.saved = JSON.stringify(this.gesture);
    this.source = { name: answer.gesture.name, folder: answer.folder, sha256: answer.sha256 };
    this.lastSaved = answer;
    this._showText(answer.text);
    await this.load();
    this.el.folder.value = answer.folder;
    this.say(`saved ${answer.path}`);
    this._changed();
    return answer;
  }

  async useAtWord() {
    const take = this.d.take();
    const word = this.wordChoice;
    if (!take || !take.script || !word) return this.say('choose a word of the script first (a click on a word of the timeline)');
    if (this.dirty() || !this.saved) return this.say('save the gesture first');
    const [status, answer] = await this._call('use', { name: this.gesture.name, utterance: word.utterance, word: word.n, sha256: take.script.sha256 }, true);
    if (status !== 200) return this.say(answer.error);
    this.say(`[pose:${this.gesture.name}] is before '${word.word}' (line ${answer.line}); the take is generated again`);
    this.usedSha = answer.sha256;
    return answer;
  }

  chooseWord(word) {
    this.wordChoice = word;
    this._fillPanel();
  }

  say(text) {
    this.message = text || '';
    if (this.el) this.el.message.textContent = this.message;
    return null;
  }

  // -- the panel ------------------------------------------------------------------------------------------

  _panel() {
    const panel = document.getElementById('posepanel');
    this.panel = panel;
    const q = (sel) => panel.querySelector(sel);
    this.el = {
      name: q('#pose-name'), open: q('#pose-open'), neu: q('#pose-new'), duration: q('#pose-duration'), strip: q('#pose-strip'),
      add: q('#pose-add'), remove: q('#pose-remove'), label: q('#pose-label'), stroke: q('#pose-stroke'), drives: q('#pose-drives'),
      hands: q('#pose-hands'), mirror: q('#pose-mirror'), frame: q('#pose-frame'), undo: q('#pose-undo'), redo: q('#pose-redo'),
      play: q('#pose-play'), context: q('#pose-context'), word: q('#pose-word'), folder: q('#pose-folder'),
      newFolder: q('#pose-newfolder'), save: q('#pose-save'), replace: q('#pose-replace'), use: q('#pose-use'),
      message: q('#pose-message'), text: q('#pose-text'), toml: q('#pose-toml'), download: q('#pose-download'),
      copy: q('#pose-copytext'), angles: q('#pose-angles'), back: q('#pose-back'),
    };
    const el = this.el;
    el.name.addEventListener('change', () => {
      const name = el.name.value.trim();
      if (!/^[a-z][a-z0-9_]*$/.test(name)) { el.name.value = this.gesture.name; return this.say('a name is lower-case letters, digits and _, starting with a letter'); }
      this.edit(() => { this.gesture.name = name; });
    });
    el.open.addEventListener('change', () => { if (el.open.value) this.open(el.open.value); el.open.value = ''; });
    el.neu.addEventListener('click', () => this.edit(() => { this.gesture = this.newGesture(this.gesture.name); this.key = 1; }));
    el.duration.addEventListener('change', () => {
      const d = parseFloat(el.duration.value);
      const last = this.gesture.keyframes[this.gesture.keyframes.length - 1].time;
      if (!(d > 0 && d <= 10)) { el.duration.value = String(this.gesture.duration); return this.say('a duration of 0 to 10 seconds'); }
      this.edit(() => { this.gesture.duration = Math.max(d, last); });
    });
    el.add.addEventListener('click', () => this.addKey());
    el.remove.addEventListener('click', () => this.removeKey());
    el.label.addEventListener('change', () => this.edit(() => { this.current.label = el.label.value.trim(); }));
    el.stroke.addEventListener('click', () => this.setStroke());
    el.mirror.addEventListener('click', () => this.mirror());
    el.frame.addEventListener('click', () => this.fromFrame(this.d.frame(), this.d.speaker()));
    el.undo.addEventListener('click', () => this.undo());
    el.redo.addEventListener('click', () => this.redo());
    el.play.addEventListener('click', () => this.play());
    el.context.addEventListener('click', () => this.playInContext());
    el.save.addEventListener('click', () => this.save());
    el.replace.addEventListener('click', () => this.save(true, this.pendingReplace));
    el.use.addEventListener('click', () => this.useAtWord());
    el.back.addEventListener('click', () => this.d.leavePreview());
    el.word.addEventListener('change', () => {
      const take = this.d.take();
      const w = take && take.words[parseInt(el.word.value, 10)];
      if (w) this.chooseWord(w);
    });
    el.folder.addEventListener('change', () => { el.newFolder.hidden = el.folder.value !== '+new'; });
    el.download.addEventListener('click', () => {
      const blob = new Blob([el.toml.textContent], { type: 'application/toml' });
      const a = document.createElement('a');
      a.href = URL.createObjectURL(blob);
      a.download = `${this.gesture.name}.toml`;
      a.click();
      setTimeout(() => URL.revokeObjectURL(a.href), 1000);
    });
    el.copy.addEventListener('click', async () => {
      try { await navigator.clipboard.writeText(el.toml.textContent); this.say('copied'); } catch (e) { this.say('select the text and copy it'); }
    });
    // the keyframe strip: a click on a keyframe shows it, a drag moves it in time
    el.strip.addEventListener('pointerdown', (e) => {
      const mark = e.target.closest('[data-key]');
      if (!mark) return;
      const i = parseInt(mark.dataset.key, 10);
      const box = el.strip.getBoundingClientRect();
      const before = JSON.stringify({ gesture: this.gesture, key: this.key });
      this.key = i;
      const move = (ev) => {
        this.setTime(i, ((ev.clientX - box.left) / box.width) * this.gesture.duration);
        this._fillPanel();
      };
      const up = () => {
        window.removeEventListener('pointermove', move);
        window.removeEventListener('pointerup', up);
        const after = JSON.stringify({ gesture: this.gesture, key: this.key });
        if (after !== before) { this.undoStack.push(before); this.redoStack = []; }
        this._changed();
      };
      window.addEventListener('pointermove', move);
      window.addEventListener('pointerup', up);
      this._changed();
    });
  }

  _fillPanel() {
    const el = this.el;
    if (!el || !this.info || !this.gesture) return;
    const g = this.gesture;
    const k = this.current;
    if (document.activeElement !== el.name) el.name.value = g.name;
    if (document.activeElement !== el.duration) el.duration.value = String(g.duration);
    if (el.open.options.length !== this.info.gestures.length + 1) {
      el.open.replaceChildren(new Option('start from a gesture…', ''), ...this.info.gestures.map((n) => new Option(n, n)));
    }
    // the strip
    el.strip.replaceChildren(...g.keyframes.map((key, i) => {
      const m = document.createElement('div');
      m.className = `pose-key${i === this.key ? ' on' : ''}${key.stroke ? ' stroke' : ''}`;
      m.style.left = `${(100 * key.time) / g.duration}%`;
      m.dataset.key = String(i);
      m.title = `${key.label || 'keyframe'} at ${key.time.toFixed(2)} s${key.stroke ? ' (the stroke)' : ''}`;
      m.textContent = key.stroke ? '★' : '◆';
      const label = document.createElement('span');
      label.textContent = key.label || `${i + 1}`;
      m.append(label);
      return m;
    }));
    if (document.activeElement !== el.label) el.label.value = k.label;
    el.stroke.classList.toggle('on', k.stroke);
    el.remove.disabled = g.keyframes.length <= 1;
    // drives
    const driven = new Set(this.driven());
    el.drives.replaceChildren(...Object.keys(this.info.limbs).map((limb) => {
      const label = document.createElement('label');
      const box = document.createElement('input');
      box.type = 'checkbox';
      box.checked = driven.has(limb);
      box.dataset.limb = limb;
      box.addEventListener('change', () => this.setDriven(limb, box.checked));
      label.append(box, ` ${LIMB_NAMES[limb]}`);
      return label;
    }));
    // hands
    el.hands.replaceChildren(...['left', 'right'].map((side) => {
      const row = document.createElement('div');
      const pick = (key, names) => {
        const s = document.createElement('select');
        s.id = `pose-${side}-${key}`;
        s.replaceChildren(...names.map((n) => new Option(n, n)));
        s.value = k.hands[`${side}_${key}`];
        s.addEventListener('change', () => this.edit(() => { this.current.hands[`${side}_${key}`] = s.value; }));
        return s;
      };
      row.append(`${side} `, pick('hand', this.info.shapes), ' palm ', pick('palm', this.info.palms));
      return row;
    }));
    el.undo.disabled = !this.undoStack.length;
    el.redo.disabled = !this.redoStack.length;
    // words
    const take = this.d.take();
    const words = take && take.script && !this.previewing ? take.words : [];
    el.word.replaceChildren(new Option('choose a word (click one in the timeline)', ''),
      ...words.map((w, i) => new Option(`${w.utterance}: ${w.word} (${w.start.toFixed(2)} s)`, String(i))));
    const chosen = this.wordChoice ? words.findIndex((w) => w.utterance === this.wordChoice.utterance && w.n === this.wordChoice.n) : -1;
    el.word.value = chosen >= 0 ? String(chosen) : '';
    const canWord = !!(take && take.script) && !this.previewing;
    el.context.disabled = !canWord;
    el.use.disabled = !canWord || !this.info.can_write;
    // folders
    const folders = this.info.folders || [];
    const want = el.folder.value;
    el.folder.replaceChildren(...folders.map((f) => new Option(`save in ${f.label}`, f.path)),
      ...(this.info.new_folder ? [new Option('save in a new folder beside the script…', '+new')] : []),
      ...(this.info.can_write ? [] : [new Option('(this page does not write: download)', '')]));
    if ([...el.folder.options].some((o) => o.value === want)) el.folder.value = want;
    el.newFolder.hidden = el.folder.value !== '+new';
    if (!el.newFolder.value && this.info.new_folder) el.newFolder.value = this.info.new_folder;
    el.save.textContent = this.info.can_write ? 'Save' : 'Show TOML';
    el.back.hidden = !this.previewing;
    const a = this.angles;
    el.angles.textContent = a ? `right elbow ${a.right.flexion.toFixed(0)}° (swivel ${a.right.swivel.toFixed(0)}°) · left elbow ${a.left.flexion.toFixed(0)}° ` +
      `(swivel ${a.left.swivel.toFixed(0)}°) · head ${a.head.map((v) => v.toFixed(0)).join('/')}°` : '';
    el.message.textContent = `${this.dirty() ? '● ' : ''}${this.message}`;
  }

  _showText(text, open = false) {
    this.el.toml.textContent = text;
    if (open) this.el.text.open = true;
  }

  // for tests and scripts: where handle `name` is on the canvas (CSS pixels from its top left)
  onCanvas(name) {
    const h = this.handles[name];
    if (!h) return null;
    this.group.updateMatrixWorld(true);
    const v = h.getWorldPosition(new THREE.Vector3()).project(this.d.camera);
    const r = this.d.canvas.getBoundingClientRect();
    return [((v.x + 1) / 2) * r.width, ((1 - v.y) / 2) * r.height];
  }

  state() {
    return {
      active: this.active, gesture: this.gesture ? copy(this.gesture) : null, key: this.key, undo: this.undoStack.length,
      redo: this.redoStack.length, message: this.message, dirty: this.gesture ? this.dirty() : false, driven: this.gesture ? this.driven() : [],
      playing: !!this.playing, previewing: this.previewing, word: this.wordChoice, gizmo: this.gizmoWhat || null,
      saved: this.lastSaved ? { path: this.lastSaved.path, sha256: this.lastSaved.sha256 } : null, handsReady: !!this.hands,
      joints: this.shownJoints || null,
    };
  }
}

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];

// rows [[...], ...] -> a THREE.Matrix4 (rotation)
function matrixOf(r) {
  return new THREE.Matrix4().set(r[0][0], r[0][1], r[0][2], 0, r[1][0], r[1][1], r[1][2], 0, r[2][0], r[2][1], r[2][2], 0, 0, 0, 0, 1);
}

// The hand joints (120 numbers) carried from joints `from` to joints `to` (10 x 3 each): each hand
// turned with its forearm and moved with its wrist.
function carry(from, to, hands) {
  if (!from) return hands;
  const out = hands.slice();
  ['left', 'right'].forEach((side, s) => {
    const w0 = new THREE.Vector3(...from[ik.JOINTS.indexOf(`${side}_wrist`)]);
    const e0 = new THREE.Vector3(...from[ik.JOINTS.indexOf(`${side}_elbow`)]);
    const w1 = new THREE.Vector3(...to[ik.JOINTS.indexOf(`${side}_wrist`)]);
    const e1 = new THREE.Vector3(...to[ik.JOINTS.indexOf(`${side}_elbow`)]);
    const q = new THREE.Quaternion().setFromUnitVectors(w0.clone().sub(e0).normalize(), w1.clone().sub(e1).normalize());
    for (let j = 0; j < 20; j++) {
      const i = (s * 20 + j) * 3;
      const v = new THREE.Vector3(hands[i], hands[i + 1], hands[i + 2]).sub(w0).applyQuaternion(q).add(w1);
      out[i] = v.x; out[i + 1] = v.y; out[i + 2] = v.z;
    }
  });
  return out;
}
