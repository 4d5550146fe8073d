// Per-triangle quality colours: each triangle painted by the edge of its
// three whose length / L lies farthest from 1 (L the target of the job's
// statistics), or by its smallest angle. The result is one flat-shaded,
// non-indexed BufferGeometry with a colour per corner, so a million
// triangles are still one draw call.

import * as THREE from 'three';

/** The band that split and collapse leave alone, in units of L. */
export const BAND = [4 / 5, 4 / 3];

// Colour stops, [value, r, g, b] with channels in 0..255.
const RATIO_STOPS = [
  [0.5, 40, 70, 200],
  [BAND[0], 120, 170, 240],
  [BAND[0], 60, 170, 90],
  [BAND[1], 60, 170, 90],
  [BAND[1], 245, 170, 60],
  [2, 200, 40, 40],
];
const ANGLE_STOPS = [
  [0, 200, 40, 40],
  [20, 245, 120, 50],
  [30, 240, 200, 60],
  [45, 150, 200, 80],
  [60, 60, 170, 90],
];

function colourAt(stops, v, out, o) {
  let k = 0;
  while (k < stops.length - 1 && v > stops[k + 1][0]) k++;
  const a = stops[k];
  const b = stops[Math.min(k + 1, stops.length - 1)];
  const t = b[0] > a[0] ? Math.min(Math.max((v - a[0]) / (b[0] - a[0]), 0), 1) : 0;
  out[o] = a[1] + (b[1] - a[1]) * t;
  out[o + 1] = a[2] + (b[2] - a[2]) * t;
  out[o + 2] = a[3] + (b[3] - a[3]) * t;
}

/**
 * A coloured copy of every mesh under `object`, in world space, merged
 * into one geometry. `mode` is 'ratio' (needs `target`) or 'angle'.
 * Returns { geometry, counts } where counts tallies triangles below, in
 * and above the band (ratio) or below / above 30° (angle).
 */
export function qualityGeometry(object, mode, target) {
  object.updateMatrixWorld(true);
  const meshes = [];
  object.traverse((o) => o.isMesh && meshes.push(o));
  const total = meshes.reduce((n, m) => n + triangleCount(m.geometry), 0);
  const positions = new Float32Array(total * 9);
  const colours = new Uint8Array(total * 9);
  const counts = [0, 0, 0];
  const v = [new THREE.Vector3(), new THREE.Vector3(), new THREE.Vector3()];
  const rgb = [0, 0, 0];
  let t = 0;
  for (const m of meshes) {
    const pos = m.geometry.getAttribute('position');
    const index = m.geometry.getIndex();
    const n = triangleCount(m.geometry);
    for (let f = 0; f < n; f++, t++) {
      for (let c = 0; c < 3; c++) {
        const i = index ? index.getX(3 * f + c) : 3 * f + c;
        v[c].fromBufferAttribute(pos, i).applyMatrix4(m.matrixWorld);
        positions[9 * t + 3 * c] = v[c].x;
        positions[9 * t + 3 * c + 1] = v[c].y;
        positions[9 * t + 3 * c + 2] = v[c].z;
      }
      const a = v[1].distanceTo(v[2]);
      const b = v[2].distanceTo(v[0]);
      const c = v[0].distanceTo(v[1]);
      let value;
      if (mode === 'ratio') {
        value = worstRatio(a / target, b / target, c / target);
        counts[value < BAND[0] ? 0 : value > BAND[1] ? 2 : 1]++;
        colourAt(RATIO_STOPS, value, rgb, 0);
      } else {
        value = smallestAngle(a, b, c);
        counts[value < 30 ? 0 : 2]++;
        colourAt(ANGLE_STOPS, value, rgb, 0);
      }
      for (let k = 0; k < 9; k++) colours[9 * t + k] = rgb[k % 3];
    }
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3, true));
  return { geometry, counts };
}

const triangleCount = (g) => (g.getIndex() ? g.getIndex().count : g.getAttribute('position').count) / 3;

/** The ratio of the three farthest from 1 on a log scale. */
function worstRatio(...ratios) {
  return ratios.reduce((w, r) => (Math.abs(Math.log(r)) > Math.abs(Math.log(w)) ? r : w));
}

/** The smallest angle in degrees, by the law of cosines, opposite the shortest side. */
export function smallestAngle(a, b, c) {
  const [s, p, q] = [a, b, c].sort((x, y) => x - y);
  if (s === 0) return 0;
  const cos = (p * p + q * q - s * s) / (2 * p * q);
  return (Math.acos(Math.min(1, Math.max(-1, cos))) * 180) / Math.PI;
}

/** An SVG legend for `mode`: a colour bar with its key values marked. */
export function legend(mode, counts) {
  const ns = 'http://www.w3.org/2000/svg';
  const stops = mode === 'ratio' ? RATIO_STOPS : ANGLE_STOPS;
  const [lo, hi] = [stops[0][0], stops[stops.length - 1][0]];
  const W = 260;
  const svg = document.createElementNS(ns, 'svg');
  svg.setAttribute('viewBox', `0 0 ${W + 20} 40`);
  svg.setAttribute('class', 'legend');
  const x = (value) => 10 + ((value - lo) / (hi - lo)) * W;
  const rgb = [0, 0, 0];
  for (let i = 0; i < W; i += 2) {
    colourAt(stops, lo + ((hi - lo) * i) / W, rgb, 0);
    const r = document.createElementNS(ns, 'rect');
    Object.entries({ x: 10 + i, y: 4, width: 2, height: 14, fill: `rgb(${rgb.map(Math.round)})` }).forEach(
      ([k, val]) => r.setAttribute(k, val),
    );
    svg.append(r);
  }
  const marks = mode === 'ratio' ? [[0.5, '≤0.5'], [BAND[0], '4/5'], [1, '1'], [BAND[1], '4/3'], [2, '≥2']] : [[0, '0°'], [30, '30°'], [60, '60°']];
  for (const [value, text] of marks) {
    const t = document.createElementNS(ns, 'text');
    t.setAttribute('x', x(value));
    t.setAttribute('y', 32);
    t.setAttribute('text-anchor', 'middle');
    t.textContent = text;
    svg.append(t);
  }
  const caption = document.createElement('span');
  caption.className = 'legend-caption';
  const total = counts[0] + counts[1] + counts[2];
  const pct = (n) => ((100 * n) / Math.max(total, 1)).toFixed(1) + ' %';
  caption.textContent =
    mode === 'ratio'
      ? `edge length / L, worst edge per triangle: ${pct(counts[0])} short, ${pct(counts[1])} in band, ${pct(counts[2])} long`
      : `smallest angle per triangle: ${pct(counts[0])} below 30°`;
  return [svg, caption];
}
