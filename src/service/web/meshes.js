// Turning files into three.js objects: the user's input, read in the
// browser with its materials and textures (so "before" shows what the file
// shows), and the job's result, fetched as GLB. Companion files (a .gltf's
// buffers and images, an OBJ's .mtl and textures) are found by name among
// the files given together.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { MTLLoader } from 'three/addons/loaders/MTLLoader.js';
import { STLLoader } from 'three/addons/loaders/STLLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';

export const MESH_EXTENSIONS = ['obj', 'gltf', 'glb', 'stl', 'ply', 'off'];

export const extension = (name) => (name.match(/\.([^./]+)$/)?.[1] ?? '').toLowerCase();

/** The file to remesh among those given together: the first mesh file. */
export function mainFile(files) {
  return files.find((f) => MESH_EXTENSIONS.includes(extension(f.name))) ?? files[0];
}

/** The uris of a .gltf's external buffers and images: the parts the API takes with it. */
export async function gltfBufferUris(file) {
  const doc = JSON.parse(await file.text());
  return [...(doc.buffers ?? []), ...(doc.images ?? [])]
    .map((b) => b.uri)
    .filter((u) => u && !u.startsWith('data:'))
    .map((u) => baseName(u));
}

/**
 * The companions of an OBJ among `files`: the material libraries its
 * `mtllib` lines name, and the texture maps those libraries name in the
 * statements the server carries (as `io::companions` reads them). The API
 * refuses a part that the model does not name, so only these are sent.
 */
export async function objCompanions(main, files) {
  const byName = new Map(files.filter((f) => f !== main).map((f) => [f.name, f]));
  const out = [];
  const take = (name) => {
    const f = byName.get(baseName(name));
    if (f && !out.includes(f)) out.push(f);
    return f;
  };
  const libraries = (await main.text())
    .split('\n')
    .map((l) => l.trim())
    .filter((l) => /^mtllib\s/.test(l))
    .flatMap((l) => {
      const rest = l.slice(6).trim();
      const words = rest.split(/\s+/);
      return words.length > 1 && words.every((w) => /\.mtl$/i.test(w)) ? words : [rest];
    });
  for (const name of libraries) {
    const mtl = take(name);
    if (!mtl) continue;
    for (const line of (await mtl.text()).split('\n')) {
      const words = line.trim().split(/\s+/);
      if (!CARRIED_MAPS.includes(words[0]) || words.length < 2) continue;
      // Options come first; the file name is the last word (or words).
      for (let k = words.length - 1; k >= 1; k--) if (take(words.slice(k).join(' '))) break;
    }
  }
  return out;
}

// The map statements whose textures the server carries into the result.
const CARRIED_MAPS = ['map_Kd', 'map_Bump', 'map_bump', 'bump', 'norm', 'map_Ke'];

const baseName = (url) => decodeURIComponent(url.split(/[\\/]/).pop().split(/[?#]/)[0]);

/** A loading manager that resolves relative names to the given files. */
function managerFor(files) {
  const urls = new Map(files.map((f) => [f.name, URL.createObjectURL(f)]));
  const manager = new THREE.LoadingManager();
  manager.setURLModifier((url) => {
    if (url.startsWith('data:') || url.startsWith('blob:')) return url;
    return urls.get(baseName(url)) ?? url;
  });
  manager.release = () => urls.forEach((u) => URL.revokeObjectURL(u));
  return manager;
}

const defaultMaterial = () =>
  new THREE.MeshStandardMaterial({ color: 0xb8c4d0, roughness: 0.7, metalness: 0, side: THREE.DoubleSide });

function meshOf(geometry) {
  if (!geometry.getAttribute('normal')) geometry.computeVertexNormals();
  return new THREE.Mesh(geometry, defaultMaterial());
}

/** Reads an OFF file (the one input format three.js has no loader for). */
export function parseOff(text) {
  const lines = text
    .split('\n')
    .map((l) => l.replace(/#.*/, '').trim())
    .filter((l) => l);
  let at = 0;
  let head = lines[at++].split(/\s+/);
  if (/OFF$/.test(head[0])) head = head.length > 1 ? head.slice(1) : lines[at++].split(/\s+/);
  const [nv, nf] = head.map(Number);
  if (!Number.isInteger(nv) || !Number.isInteger(nf)) throw new Error('not an OFF file');
  const positions = new Float32Array(nv * 3);
  for (let v = 0; v < nv; v++) {
    const xyz = lines[at++].split(/\s+/).map(Number);
    positions.set(xyz.slice(0, 3), v * 3);
  }
  const index = [];
  for (let f = 0; f < nf; f++) {
    const [n, ...rest] = lines[at++].split(/\s+/).map(Number);
    for (let k = 1; k + 1 < n; k++) index.push(rest[0], rest[k], rest[k + 1]);
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  g.setIndex(index);
  return g;
}

/** The user's input as an Object3D, with materials and textures. */
export async function loadInput(files) {
  const main = mainFile(files);
  const ext = extension(main.name);
  const manager = managerFor(files);
  try {
    switch (ext) {
      case 'gltf':
      case 'glb': {
        const loader = new GLTFLoader(manager);
        const gltf = await loader.parseAsync(await main.arrayBuffer(), '');
        return gltf.scene;
      }
      case 'obj': {
        const loader = new OBJLoader(manager);
        const mtl = files.find((f) => extension(f.name) === 'mtl');
        if (mtl) {
          const materials = new MTLLoader(manager).parse(await mtl.text(), '');
          materials.preload();
          loader.setMaterials(materials);
        }
        const group = loader.parse(await main.text());
        group.traverse((o) => {
          if (o.isMesh && !mtl) o.material = defaultMaterial();
          if (o.isMesh && !o.geometry.getAttribute('normal')) o.geometry.computeVertexNormals();
        });
        return group;
      }
      case 'stl':
        return meshOf(new STLLoader(manager).parse(await main.arrayBuffer()));
      case 'ply':
        return meshOf(new PLYLoader(manager).parse(await main.arrayBuffer()));
      case 'off':
        return meshOf(parseOff(await main.text()));
      default:
        throw new Error(`the browser cannot preview .${ext} files`);
    }
  } finally {
    // Textures are decoded asynchronously; release the names a little later.
    setTimeout(() => manager.release(), 10000);
  }
}

/** The job's result as an Object3D: fetched as GLB, whatever its stored format. */
export async function loadResult(bytes) {
  const gltf = await new GLTFLoader().parseAsync(bytes, '');
  // A textured result keeps its material, so the texture shows after too.
  gltf.scene.traverse((o) => {
    if (o.isMesh && !o.material?.map) o.material = defaultMaterial();
  });
  return gltf.scene;
}
