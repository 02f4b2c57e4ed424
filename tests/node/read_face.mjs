// three.js reads sgt's face exports the way an application does; prints one JSON object.
//   node read_face.mjs vrma FILE.vrma TIME...   the VRM Animation's expression tracks, as
//       @pixiv/three-vrm-animation's loader plugin parses them, and the weights a VRM's
//       expression manager holds when the clip made by createVRMAnimationClip plays at each TIME
//   node read_face.mjs glb FILE.glb TIME...     the glTF's morph targets as GLTFLoader makes them
//       (the face mesh's morphTargetDictionary) and its influences when the clip plays at each TIME
import { readFile } from "node:fs/promises";
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { VRMAnimationLoaderPlugin, createVRMAnimationClip } from "@pixiv/three-vrm-animation";
import { VRMExpression, VRMExpressionManager, VRMExpressionPresetName, VRMHumanoid } from "@pixiv/three-vrm-core";

const [kind, file, ...times] = process.argv.slice(2);
const data = await readFile(file);
const buffer = data.buffer.slice(data.byteOffset, data.byteOffset + data.byteLength);
const loader = new GLTFLoader();
loader.register((parser) => new VRMAnimationLoaderPlugin(parser));
const gltf = await loader.parseAsync(buffer, "");
const at = times.map(Number);
const out = { kind, animations: gltf.animations.map((a) => ({ name: a.name, duration: a.duration, tracks: a.tracks.length })) };

if (kind === "vrma") {
  const animation = gltf.userData.vrmAnimations[0];
  out.presetTracks = {};
  for (const [name, track] of animation.expressionTracks.preset) {
    out.presetTracks[name] = { trackName: track.name, times: Array.from(track.times), values: Array.from(track.values) };
  }
  out.customTracks = [...animation.expressionTracks.custom.keys()];
  // A stand-in VRM: the file's own skeleton as its humanoid and an expression for every preset,
  // so that the clip createVRMAnimationClip makes plays through three's AnimationMixer.
  const scene = gltf.scene;
  const humanBones = {};
  const ext = gltf.parser.json.extensions.VRMC_vrm_animation;
  for (const [bone, { node }] of Object.entries(ext.humanoid.humanBones)) {
    humanBones[bone] = { node: await gltf.parser.getDependency("node", node) };
  }
  const humanoid = new VRMHumanoid(humanBones);
  scene.add(humanoid.normalizedHumanBonesRoot);
  const expressionManager = new VRMExpressionManager();
  for (const name of Object.values(VRMExpressionPresetName)) {
    const expression = new VRMExpression(name);
    scene.add(expression);
    expressionManager.registerExpression(expression);
  }
  const vrm = { scene, humanoid, expressionManager, lookAt: null, meta: { metaVersion: "1" } };
  const clip = createVRMAnimationClip(animation, vrm);
  const mixer = new THREE.AnimationMixer(scene);
  mixer.clipAction(clip).play();
  out.played = at.map((t) => {
    mixer.setTime(t);
    const weights = {};
    for (const name of Object.keys(out.presetTracks)) weights[name] = expressionManager.getValue(name);
    return { time: t, weights };
  });
} else {
  const faces = [];
  gltf.scene.traverse((o) => { if (o.isMesh && o.morphTargetDictionary && o.name.startsWith("face")) faces.push(o); });
  out.meshes = faces.map((m) => ({ name: m.name, targets: Object.keys(m.morphTargetDictionary).sort((a, b) => m.morphTargetDictionary[a] - m.morphTargetDictionary[b]) }));
  const clip = gltf.animations[0];
  out.weightTracks = clip.tracks.filter((t) => t.name.endsWith(".morphTargetInfluences")).map((t) => t.name);
  const mixer = new THREE.AnimationMixer(gltf.scene);
  mixer.clipAction(clip).play();
  out.played = at.map((t) => {
    mixer.setTime(t);
    return { time: t, influences: faces.map((m) => Array.from(m.morphTargetInfluences)) };
  });
}
console.log(JSON.stringify(out));
