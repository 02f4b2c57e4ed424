// A user's VRM character (a .vrm file chosen in the page, never uploaded) playing a speaker's
// motion as VRM Animation (`sgt export -o x.vrma`, served per speaker): three-vrm loads the
// character, three-vrm-animation turns the .vrma into a clip on its normalized bones, and the
// page's clock sets the clip's time every frame.

import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { VRMLoaderPlugin, VRMUtils } from '@pixiv/three-vrm';
import { VRMAnimationLoaderPlugin, createVRMAnimationClip } from '@pixiv/three-vrm-animation';

function loader() {
  const l = new GLTFLoader();
  l.register((parser) => new VRMLoaderPlugin(parser));
  l.register((parser) => new VRMAnimationLoaderPlugin(parser));
  return l;
}

export async function parseVRM(buffer) {
  const gltf = await loader().parseAsync(buffer.slice(0), '');
  const vrm = gltf.userData.vrm;
  if (!vrm) throw new Error('not a VRM file (no VRM extension)');
  VRMUtils.removeUnnecessaryVertices(gltf.scene);
  VRMUtils.rotateVRM0(vrm); // VRM 0.x characters face -z: turn them to face +z, as sgt's do
  vrm.scene.traverse((o) => { o.frustumCulled = false; });
  return vrm;
}

export async function parseVRMA(buffer) {
  const gltf = await loader().parseAsync(buffer, '');
  const animation = gltf.userData.vrmAnimations && gltf.userData.vrmAnimations[0];
  if (!animation) throw new Error('no VRM Animation in the file');
  return animation;
}

// One speaker's character and its motion.
export class Character {
  constructor(vrm, animation) {
    this.vrm = vrm;
    this.mixer = new THREE.AnimationMixer(vrm.scene);
    this.action = this.mixer.clipAction(createVRMAnimationClip(animation, vrm));
    this.action.play();
  }

  pose(t) {
    this.mixer.setTime(t);
    this.vrm.update(0);
  }

  dispose() {
    this.mixer.stopAllAction();
    VRMUtils.deepDispose(this.vrm.scene);
  }
}
