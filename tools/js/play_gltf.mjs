// Plays a .glb or .gltf the way a three.js application does (GLTFLoader, AnimationMixer) and prints, as
// JSON on stdout, every node's world position at each time asked:
//   node tools/js/play_gltf.mjs FILE TIME [TIME...]        (seconds on the clip's own time line)
// {"animations": [{"name", "duration", "start", "end"}], "nodes": [original glTF node names],
//  "positions": [time][node][x, y, z]}  (glTF's axes: +Y up, metres)
// The first animation is played (an export that should hold one clip is judged by "animations").
// A .gltf's external buffers are read from disk and handed over as data: URIs (node's fetch reads no
// file: URLs); armature-only files have no images to decode.
import fs from 'node:fs';
import path from 'node:path';
import { AnimationMixer, LoopOnce, Vector3 } from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

// three's FileLoader reports progress with the browser's ProgressEvent, which node lacks.
globalThis.ProgressEvent ??= class ProgressEvent extends Event {
  constructor(type, init = {}) {
    super(type);
    Object.assign(this, init);
  }
};

function fail(message) {
  process.stderr.write(`play_gltf: ${message}\n`);
  process.exit(2);
}

function readAsset(file) {
  const bytes = fs.readFileSync(file);
  if (path.extname(file).toLowerCase() !== '.gltf') {
    return bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  }
  const json = JSON.parse(bytes.toString('utf8'));
  for (const buffer of json.buffers || []) {
    if (buffer.uri && !buffer.uri.startsWith('data:')) {
      const data = fs.readFileSync(path.resolve(path.dirname(file), decodeURIComponent(buffer.uri)));
      buffer.uri = 'data:application/octet-stream;base64,' + data.toString('base64');
    }
  }
  return JSON.stringify(json);
}

function parse(asset) {
  return new Promise((resolve, reject) => new GLTFLoader().parse(asset, '', resolve, reject));
}

function clipRange(clip) {
  let start = Infinity, end = -Infinity;
  for (const track of clip.tracks) {
    start = Math.min(start, track.times[0]);
    end = Math.max(end, track.times[track.times.length - 1]);
  }
  return { name: clip.name, duration: clip.duration, start, end };
}

async function main() {
  const [file, ...timeArgs] = process.argv.slice(2);
  if (!file || !timeArgs.length) fail('usage: play_gltf.mjs FILE TIME [TIME...]');
  const times = timeArgs.map(Number);
  if (times.some((t) => !Number.isFinite(t) || t < 0)) fail(`times must be numbers >= 0: ${timeArgs.join(' ')}`);
  let gltf;
  try {
    gltf = await parse(readAsset(file));
  } catch (error) {
    fail(`${file}: ${error && error.message ? error.message : error}`);
  }
  const names = gltf.parser.json.nodes.map((n, i) => n.name ?? `node${i}`);
  const objects = [];
  gltf.scene.traverse((object) => {
    const index = gltf.parser.associations.get(object)?.nodes;
    if (index !== undefined) objects.push([index, object]);
  });
  objects.sort((a, b) => a[0] - b[0]);
  const mixer = new AnimationMixer(gltf.scene);
  if (gltf.animations.length) {
    // Held at its last pose past the end, as a game plays a clip once; a repeating action would wrap
    // its last frame back to the first.
    const action = mixer.clipAction(gltf.animations[0]);
    action.setLoop(LoopOnce, 1);
    action.clampWhenFinished = true;
    action.play();
  }
  const positions = times.map((time) => {
    mixer.setTime(time);
    gltf.scene.updateMatrixWorld(true);
    return objects.map(([, object]) => object.getWorldPosition(new Vector3()).toArray());
  });
  process.stdout.write(JSON.stringify({
    animations: gltf.animations.map(clipRange),
    nodes: objects.map(([index]) => names[index]),
    positions,
  }));
}

main();
