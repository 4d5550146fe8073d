// Coarse stand-ins for big meshes, drawn while the camera moves so that
// orbiting a million triangles stays interactive; the full mesh is drawn
// again once the camera rests. The stand-in is built by vertex clustering
// (Rossignac and Borrel 1993): vertices are merged per cell of a uniform
// grid, each cell keeping the mean position and colour of its vertices,
// and the triangles whose three corners fall in three different cells are
// kept, once each. Cheap (one pass over the mesh), and faithful to the
// shape at the cell size, which is all a moving view needs.

import * as THREE from 'three';

/** A side with more triangles than this is drawn through its stand-in while moving. */
export const PROXY_ABOVE = 150_000;

/** Grid cells the surface should cover: about twice as many triangles. */
const PROXY_CELLS = 20_000;

/** Triangles of every mesh under `object` (wire overlays excluded). */
export function triangleTotal(object) {
  let n = 0;
  surfaces(object, (m) => (n += triangles(m.geometry)));
  return n;
}

function surfaces(object, visit) {
  object.traverse((o) => {
    if (o.isMesh && !o.userData.wire) visit(o);
  });
}

const triangles = (g) => Math.floor((g.index ? g.index.count : g.getAttribute('position').count) / 3);

/**
 * The stand-in of everything under `object`, in world space: one mesh with
 * per-vertex colours (the mean of the merged vertices' colours, or of the
 * materials' colours where a mesh has none).
 */
export function proxyOf(object) {
  object.updateMatrixWorld(true);
  const parts = [];
  let area = 0;
  const box = new THREE.Box3();
  const [a, b, c] = [new THREE.Vector3(), new THREE.Vector3(), new THREE.Vector3()];
  let look = null; // the first material, whose finish the stand-in takes
  let flat = false;
  surfaces(object, (m) => {
    look ??= [m.material].flat()[0];
    flat ||= Boolean(look.flatShading);
    const pos = m.geometry.getAttribute('position');
    const world = new Float32Array(pos.count * 3);
    for (let i = 0; i < pos.count; i++) {
      a.fromBufferAttribute(pos, i).applyMatrix4(m.matrixWorld);
      a.toArray(world, 3 * i);
      box.expandByPoint(a);
    }
    const index = m.geometry.index;
    const corner = index ? (k) => index.getX(k) : (k) => k;
    const n = triangles(m.geometry);
    for (let t = 0; t < n; t++) {
      a.fromArray(world, 3 * corner(3 * t));
      b.fromArray(world, 3 * corner(3 * t + 1)).sub(a);
      c.fromArray(world, 3 * corner(3 * t + 2)).sub(a);
      area += b.cross(c).length() / 2;
    }
    parts.push({ mesh: m, world, corner, n });
  });
  const h = Math.sqrt(area / PROXY_CELLS) || 1;
  const cells = box.getSize(new THREE.Vector3()).divideScalar(h).floor().addScalar(1);
  const cluster = new Map(); // cell key -> cluster id
  const sums = []; // per cluster: x, y, z, r, g, b, count
  const faces = new Map(); // sorted cluster triple -> [c0, c1, c2] in first orientation
  const colour = new THREE.Color();
  for (const { mesh, world, corner, n } of parts) {
    const col = mesh.geometry.getAttribute('color');
    const base = [mesh.material].flat()[0]?.color ?? colour.set(0xb8c4d0);
    const ids = new Int32Array(world.length / 3);
    for (let i = 0; i < ids.length; i++) {
      const x = Math.floor((world[3 * i] - box.min.x) / h);
      const y = Math.floor((world[3 * i + 1] - box.min.y) / h);
      const z = Math.floor((world[3 * i + 2] - box.min.z) / h);
      const key = x + cells.x * (y + cells.y * z);
      let id = cluster.get(key);
      if (id === undefined) {
        id = cluster.size;
        cluster.set(key, id);
        sums.push(0, 0, 0, 0, 0, 0, 0);
      }
      ids[i] = id;
      const s = 7 * id;
      sums[s] += world[3 * i];
      sums[s + 1] += world[3 * i + 1];
      sums[s + 2] += world[3 * i + 2];
      sums[s + 3] += col ? col.getX(i) : base.r;
      sums[s + 4] += col ? col.getY(i) : base.g;
      sums[s + 5] += col ? col.getZ(i) : base.b;
      sums[s + 6] += 1;
    }
    const k = cluster.size + 1;
    for (let t = 0; t < n; t++) {
      const tri = [ids[corner(3 * t)], ids[corner(3 * t + 1)], ids[corner(3 * t + 2)]];
      if (tri[0] === tri[1] || tri[1] === tri[2] || tri[0] === tri[2]) continue;
      const [p, q, r] = [...tri].sort((u, v) => u - v);
      const key = k ** 3 < Number.MAX_SAFE_INTEGER ? p + k * (q + k * r) : `${p},${q},${r}`;
      if (!faces.has(key)) faces.set(key, tri);
    }
  }
  const count = cluster.size;
  const positions = new Float32Array(3 * count);
  const colours = new Float32Array(3 * count);
  for (let id = 0; id < count; id++) {
    const s = 7 * id;
    for (let j = 0; j < 3; j++) {
      positions[3 * id + j] = sums[s + j] / sums[s + 6];
      colours[3 * id + j] = sums[s + 3 + j] / sums[s + 6];
    }
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
  geometry.setIndex([...faces.values()].flat());
  geometry.computeVertexNormals();
  const material = new THREE.MeshStandardMaterial({
    vertexColors: true,
    roughness: look?.roughness ?? 0.8,
    metalness: look?.metalness ?? 0,
    flatShading: flat,
    side: THREE.DoubleSide,
  });
  return new THREE.Mesh(geometry, material);
}
