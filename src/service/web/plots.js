// The statistics as SVG plots and tables, input beside output. Reads the
// fields the API documents and ignores any it does not know; a histogram
// that carries its own bin edges (`bin_edges` or `edges`) is drawn with them.

import { BAND } from './quality.js';

const NS = 'http://www.w3.org/2000/svg';
const W = 420;
const H = 180;
const PAD = { left: 44, right: 10, top: 10, bottom: 34 };

function el(name, attrs = {}, text) {
  const e = document.createElementNS(NS, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

function html(name, attrs = {}, text) {
  const e = document.createElement(name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

/** Bins of a numeric histogram as [lo, hi, count]; the last may be open. */
function bins(h, overflow) {
  const edges = h.bin_edges ?? h.edges;
  return h.counts.map((n, k) => {
    const lo = edges ? edges[k] : k * h.bin_width;
    const hi = edges && edges[k + 1] !== undefined ? edges[k + 1] : (k + 1) * h.bin_width;
    return [lo, overflow && k === h.counts.length - 1 ? Infinity : hi, n];
  });
}

/**
 * A bar chart of one or two series of fractions over common categories.
 * `series`: [{name, cls, bins: [[lo, hi, count]]}], `band`: [lo, hi] or null.
 */
function barChart({ title, id, series, xLabel, band, tick }) {
  const figure = html('figure', { class: 'plot', id });
  figure.append(html('figcaption', {}, title));
  const svg = el('svg', { viewBox: `0 0 ${W} ${H}`, role: 'img', 'aria-label': title });
  const n = Math.max(...series.map((s) => s.bins.length));
  const fractions = series.map((s) => {
    const total = s.bins.reduce((t, b) => t + b[2], 0) || 1;
    return s.bins.map((b) => b[2] / total);
  });
  const top = Math.max(0.01, ...fractions.flat());
  const plotW = W - PAD.left - PAD.right;
  const plotH = H - PAD.top - PAD.bottom;
  const slot = plotW / n;
  const x = (k) => PAD.left + k * slot;
  const y = (f) => PAD.top + plotH * (1 - f / top);
  if (band) {
    const first = series[0].bins;
    const pos = (v) => {
      const k = first.findIndex(([lo, hi]) => v >= lo && v < hi);
      const [lo, hi] = first[k];
      return x(k) + slot * (Number.isFinite(hi) ? (v - lo) / (hi - lo) : 0);
    };
    const [a, b] = [pos(band[0]), pos(band[1])];
    svg.append(el('rect', { class: 'band', x: a, y: PAD.top, width: b - a, height: plotH }));
    svg.append(el('text', { class: 'band-label', x: (a + b) / 2, y: PAD.top + 10, 'text-anchor': 'middle' }, 'band [4/5·L, 4/3·L]'));
  }
  const barW = (slot * 0.8) / series.length;
  series.forEach((s, i) => {
    fractions[i].forEach((f, k) => {
      if (f === 0) return;
      const [lo, hi] = s.bins[k];
      const bar = el('rect', { class: `bar ${s.cls}`, x: x(k) + slot * 0.1 + i * barW, y: y(f), width: barW, height: PAD.top + plotH - y(f) });
      bar.append(el('title', {}, `${s.name} ${tick(lo, hi)}: ${(100 * f).toFixed(2)} %`));
      svg.append(bar);
    });
  });
  svg.append(el('line', { class: 'axis', x1: PAD.left, y1: PAD.top + plotH, x2: W - PAD.right, y2: PAD.top + plotH }));
  svg.append(el('line', { class: 'axis', x1: PAD.left, y1: PAD.top, x2: PAD.left, y2: PAD.top + plotH }));
  const every = Math.ceil(n / 10);
  for (let k = 0; k < n; k += every) {
    const [lo, hi] = series[0].bins[k] ?? series[1].bins[k];
    svg.append(el('text', { class: 'tick', x: x(k) + slot / 2, y: PAD.top + plotH + 12, 'text-anchor': 'middle' }, tick(lo, hi)));
  }
  for (const f of [0, top / 2, top]) {
    svg.append(el('text', { class: 'tick', x: PAD.left - 4, y: y(f) + 4, 'text-anchor': 'end' }, `${(100 * f).toFixed(f ? 1 : 0)} %`));
  }
  svg.append(el('text', { class: 'label', x: PAD.left + plotW / 2, y: H - 4, 'text-anchor': 'middle' }, xLabel));
  const legend = html('p', { class: 'series-legend' });
  for (const s of series) legend.append(html('span', { class: `swatch ${s.cls}` }), html('span', {}, s.name));
  figure.append(svg, legend);
  return figure;
}

const SIDES = [
  ['input', 'in'],
  ['output', 'out'],
];

/** The histogram plots for a job's `stats`. */
export function plots(stats) {
  const out = [];
  const edge = SIDES.filter(([s]) => stats[s]?.edge_length).map(([s, cls]) => ({
    name: s,
    cls,
    bins: bins(stats[s].edge_length.histogram, true),
  }));
  if (edge.length) {
    const len = stats.output.edge_length;
    const band = [len.band?.lower ?? BAND[0], len.band?.upper ?? BAND[1]];
    out.push(
      barChart({
        title: `Edge length / L (L = ${fmt(len.target)}); in band: input ${pct(stats.input.edge_length?.within_band)}, output ${pct(len.within_band)}`,
        id: 'plot-edge-length',
        series: edge,
        xLabel: 'edge length / L',
        band,
        tick: (lo, hi) => (Number.isFinite(hi) ? lo.toFixed(1) : `≥${lo.toFixed(1)}`),
      }),
    );
  }
  const angle = SIDES.filter(([s]) => stats[s]?.angles).map(([s, cls]) => ({ name: s, cls, bins: bins(stats[s].angles.histogram, false) }));
  if (angle.length) {
    const a = stats.output.angles;
    out.push(
      barChart({
        title: `Angles (°); smallest: input ${fmt(stats.input.angles?.min_deg)}°, output ${fmt(a.min_deg)}°`,
        id: 'plot-angles',
        series: angle,
        xLabel: 'interior angle (°)',
        band: null,
        tick: (lo) => `${Math.round(lo)}`,
      }),
    );
  }
  const keys = [...new Set(SIDES.flatMap(([s]) => Object.keys(stats[s]?.valence?.histogram ?? {})))].map(Number).sort((a, b) => a - b);
  if (keys.length) {
    out.push(
      barChart({
        title: `Valence; regular (6) interior: input ${pct(stats.input.valence.regular_fraction)}, output ${pct(stats.output.valence.regular_fraction)}`,
        id: 'plot-valence',
        series: SIDES.map(([s, cls]) => ({ name: s, cls, bins: keys.map((k) => [k, k + 1, stats[s].valence.histogram[k] ?? 0]) })),
        xLabel: 'valence',
        band: null,
        tick: (lo) => `${lo}`,
      }),
    );
  }
  return out;
}

const fmt = (v) => (v === null || v === undefined ? '–' : typeof v === 'number' ? (Number.isInteger(v) ? String(v) : v.toPrecision(4)) : String(v));
const pct = (v) => (typeof v === 'number' ? `${(100 * v).toFixed(1)} %` : '–');

function table(caption, rows, headers = ['', 'input', 'output']) {
  const t = html('table', { class: 'stats' });
  t.append(html('caption', {}, caption));
  const head = html('tr');
  headers.forEach((h) => head.append(html('th', {}, h)));
  t.append(head);
  for (const row of rows) {
    const tr = html('tr');
    row.forEach((c, i) => tr.append(html(i ? 'td' : 'th', {}, fmt(c))));
    t.append(tr);
  }
  return t;
}

/** The tables: counts, distance, features. */
export function tables(stats) {
  const { input: i, output: o } = stats;
  const counts = ['vertices', 'faces', 'edges', 'boundary_edges', 'boundary_loops', 'components', 'euler_characteristic', 'manifold', 'consistently_oriented', 'non_manifold_edges', 'degenerate_faces'];
  const result = [table('Counts', counts.filter((k) => k in o).map((k) => [k, i[k], o[k]]))];
  const lengths = ['min', 'max', 'mean', 'std', 'target', 'within_band'];
  if (o.edge_length) result.push(table('Edge lengths', lengths.map((k) => [k, i.edge_length?.[k], o.edge_length[k]])));
  if (o.angles || o.triangle_quality) {
    result.push(
      table('Angles and shape', [
        ['smallest angle (°)', i.angles?.min_deg, o.angles?.min_deg],
        ['largest angle (°)', i.angles?.max_deg, o.angles?.max_deg],
        ['mean smallest angle (°)', i.angles?.mean_min_deg, o.angles?.mean_min_deg],
        ['triangles below 30°', pct(i.angles?.below_30_fraction), pct(o.angles?.below_30_fraction)],
        ['shape quality min', i.triangle_quality?.min, o.triangle_quality?.min],
        ['shape quality mean', i.triangle_quality?.mean, o.triangle_quality?.mean],
      ]),
    );
  }
  if (o.distance) {
    result.push(table('Distance of the output to the input', Object.entries(o.distance).filter(([, v]) => typeof v === 'number').map(([k, v]) => [k, v]), ['', 'value']));
  }
  if (o.features) {
    const f = o.features;
    const rows = Object.entries(f).filter(([, v]) => typeof v !== 'object').map(([k, v]) => [k, i.features?.[k], v]);
    result.push(table('Features', rows));
    if (f.fidelity) {
      result.push(table('Feature fidelity (output against input)', Object.entries(f.fidelity).filter(([, v]) => typeof v !== 'object' || v === null).map(([k, v]) => [k, v]), ['', 'value']));
    }
  }
  return result;
}
