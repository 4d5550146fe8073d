// The page: files in, a job through the API, the viewer, plots, downloads
// and the list of recent jobs. State lives in `state`; every DOM update is
// by textContent or element creation (no HTML from data).

import * as api from './api.js';
import { Viewer } from './viewer.js';
import { loadInput, loadResult, mainFile, extension, gltfBufferUris, objCompanions } from './meshes.js';
import { plots, tables } from './plots.js';
import { legend } from './quality.js';

const $ = (id) => document.getElementById(id);
const POLL_MS = 400;

const state = { files: [], job: null, polling: null, formats: [] };
const viewer = new Viewer($('canvas'));
// For people and scripts driving the page: the viewer and the current job.
window.isoremesh = { viewer, state };

function setStatus(text) {
  $('status').textContent = text;
}

function showProblem(p) {
  // A 401 means the server runs with API keys: ask for one.
  if (p?.status === 401) {
    $('key-form').hidden = false;
    document.body.dataset.needsKey = 'true';
  }
  const box = $('problem');
  box.replaceChildren();
  if (!p) {
    box.hidden = true;
    return;
  }
  const title = document.createElement('strong');
  title.textContent = `${p.title ?? 'Error'}${p.status ? ` (${p.status})` : ''}`;
  const detail = document.createElement('p');
  detail.textContent = p.detail ?? '';
  box.append(title, detail);
  if (p.field) {
    const field = document.createElement('p');
    field.textContent = `field: ${p.field}`;
    box.append(field);
  }
  if (p.type) {
    const type = document.createElement('p');
    type.className = 'problem-type';
    type.textContent = p.type;
    box.append(type);
  }
  box.hidden = false;
}

// ---- files ----

async function takeFiles(list) {
  state.files = [...list];
  const main = mainFile(state.files);
  const ul = $('file-list');
  ul.replaceChildren(
    ...state.files.map((f) => {
      const li = document.createElement('li');
      li.textContent = `${f.name} (${f.size.toLocaleString()} bytes)${f === main ? ' — the mesh' : ''}`;
      return li;
    }),
  );
  $('submit').disabled = !main;
  showProblem(null);
  $('view-info').textContent = '';
  try {
    viewer.set('after', null);
    viewer.set('before', await loadInput(state.files));
  } catch (e) {
    viewer.set('before', null);
    $('view-info').textContent = `The browser cannot preview this file (${e.message}); the server will still read it.`;
  }
}

const drop = $('drop');
drop.addEventListener('dragover', (e) => {
  e.preventDefault();
  drop.classList.add('over');
});
drop.addEventListener('dragleave', () => drop.classList.remove('over'));
drop.addEventListener('drop', (e) => {
  e.preventDefault();
  drop.classList.remove('over');
  takeFiles(e.dataTransfer.files);
});
drop.addEventListener('keydown', (e) => {
  if (e.key === 'Enter' || e.key === ' ') $('files').click();
});
$('files').addEventListener('change', (e) => takeFiles(e.target.files));

// ---- parameters ----

async function fillDefaults() {
  const { params, formats } = await api.defaults();
  state.formats = formats;
  $('iterations').value = params.iterations;
  $('preserve_features').checked = params.preserve_features;
  $('feature_angle').value = params.feature_angle;
  $('sizing').value = params.sizing;
  for (const f of formats) $('output_format').append(new Option(f, f));
}

for (const radio of document.querySelectorAll('input[name=target_kind]')) {
  radio.addEventListener('change', () => {
    const kind = document.querySelector('input[name=target_kind]:checked').value;
    $('target_value').disabled = kind === 'none';
    $('target_value').step = kind === 'target_faces' ? '1' : 'any';
  });
}

function readParams() {
  const p = {
    iterations: Number($('iterations').value),
    preserve_features: $('preserve_features').checked,
    feature_angle: Number($('feature_angle').value),
    sizing: $('sizing').value,
  };
  const kind = document.querySelector('input[name=target_kind]:checked').value;
  if (kind !== 'none') p[kind] = Number($('target_value').value);
  if (p.sizing === 'adaptive' && $('tolerance_ratio').value !== '') p.tolerance_ratio = Number($('tolerance_ratio').value);
  if ($('output_format').value) p.output_format = $('output_format').value;
  return p;
}

$('params').addEventListener('submit', async (e) => {
  e.preventDefault();
  const main = mainFile(state.files);
  if (!main) return;
  showProblem(null);
  delete document.body.dataset.viewer;
  delete document.body.dataset.jobStatus;
  let extra = [];
  try {
    if (extension(main.name) === 'gltf') {
      const uris = await gltfBufferUris(main);
      extra = state.files.filter((f) => f !== main && uris.includes(f.name));
    } else if (extension(main.name) === 'obj') {
      extra = await objCompanions(main, state.files);
    }
    $('submit').disabled = true;
    setStatus('Uploading…');
    const job = await api.submit(main, readParams(), extra);
    track(job);
  } catch (err) {
    setStatus('Not submitted.');
    showProblem(err.problem ?? { title: 'Cannot submit', detail: err.message });
  } finally {
    $('submit').disabled = false;
  }
});

// ---- the job ----

function track(job) {
  clearTimeout(state.polling);
  state.job = job;
  showJob(job);
  if (!['succeeded', 'failed', 'cancelled'].includes(job.status)) {
    state.polling = setTimeout(async () => {
      try {
        if (state.job?.id === job.id) track(await api.getJob(job.id));
      } catch (err) {
        showProblem(err.problem ?? { title: 'Lost the job', detail: err.message });
      }
    }, POLL_MS);
  } else {
    finished(job);
    refreshJobs();
  }
}

function showJob(job) {
  const p = job.progress;
  $('progress').value = job.status === 'succeeded' ? 1 : p?.fraction ?? 0;
  const where = p ? ` — iteration ${p.iteration} of ${p.iterations}, ${p.pass}` : '';
  setStatus(`Job ${job.id.slice(0, 8)}: ${job.status}${job.status === 'running' ? where : ''}${job.cancel_requested ? ' (cancelling)' : ''}`);
  $('cancel').hidden = !['queued', 'running'].includes(job.status);
  document.body.dataset.jobStatus = job.status;
}

$('cancel').addEventListener('click', async () => {
  if (!state.job) return;
  try {
    track(await api.cancelJob(state.job.id));
  } catch (err) {
    showProblem(err.problem ?? { title: 'Cannot cancel', detail: err.message });
  }
});

async function finished(job) {
  if (job.status === 'failed') showProblem(job.error);
  if (job.status !== 'succeeded') return;
  showStats(job.stats);
  showDownloads(job);
  try {
    const t0 = performance.now();
    const object = await loadResult(await api.resultBytes(job.id, 'glb'));
    viewer.set('after', object, job.stats.output.edge_length?.target ?? 1);
    viewer.setTarget('before', job.stats.input.edge_length?.target ?? 1);
    $('view-info').textContent = `Output: ${job.result.triangles.toLocaleString()} triangles, loaded in ${Math.round(performance.now() - t0)} ms.`;
    document.body.dataset.viewer = 'ready';
    updateLegend();
  } catch (err) {
    showProblem(err.problem ?? { title: 'Cannot show the result', detail: err.message });
  }
}

function showStats(stats) {
  $('plots').replaceChildren(...plots(stats));
  $('tables').replaceChildren(...tables(stats));
}

function showDownloads(job) {
  const items = state.formats.map((f) => {
    const a = document.createElement('a');
    a.href = api.resultUrl(job.id, f);
    a.textContent = f === job.result.format ? `${f} (stored)` : f;
    a.download = '';
    a.dataset.format = f;
    return a;
  });
  // OBJ's material library and textures are separate files: one zip holds them all.
  const zip = document.createElement('a');
  zip.href = `${api.resultUrl(job.id, 'obj')}&bundle=zip`;
  zip.textContent = 'obj + mtl + textures (zip)';
  zip.download = '';
  zip.dataset.format = 'obj-zip';
  items.push(zip);
  const stats = document.createElement('a');
  const blob = new Blob([JSON.stringify(job.stats, null, 2)], { type: 'application/json' });
  stats.href = URL.createObjectURL(blob);
  stats.download = `${job.id}-stats.json`;
  stats.textContent = 'statistics (JSON)';
  stats.dataset.format = 'stats';
  $('downloads').replaceChildren(
    ...[...items, stats].map((a) => {
      const li = document.createElement('li');
      li.append(a);
      return li;
    }),
  );
}

// ---- the viewer's controls ----

function updateLegend() {
  const mode = $('colour').value;
  $('legend').replaceChildren(...(mode === 'material' || !viewer.counts ? [] : legend(mode, viewer.counts)));
}

for (const id of ['layout', 'display', 'colour']) {
  $(id).addEventListener('change', () => {
    viewer.setMode({ [id]: $(id).value });
    $('split').hidden = $('layout').value !== 'slider';
    document.getElementById('view').dataset.layout = $('layout').value;
    updateLegend();
  });
}
$('split').addEventListener('input', () => viewer.setMode({ split: Number($('split').value) }));

// ---- recent jobs ----

async function refreshJobs() {
  try {
    const { jobs } = await api.listJobs();
    $('jobs').tBodies[0].replaceChildren(
      ...jobs.map((j) => {
        const tr = document.createElement('tr');
        for (const text of [new Date(j.created_at).toLocaleString(), j.status, j.input_format, j.output_format ?? '']) {
          const td = document.createElement('td');
          td.textContent = text;
          tr.append(td);
        }
        const open = document.createElement('button');
        open.type = 'button';
        open.textContent = 'open';
        open.addEventListener('click', () => openJob(j.id));
        const td = document.createElement('td');
        td.append(open);
        tr.append(td);
        return tr;
      }),
    );
  } catch (err) {
    showProblem(err.problem ?? { title: 'Cannot list jobs', detail: err.message });
  }
}

async function openJob(id) {
  showProblem(null);
  viewer.set('before', null);
  viewer.set('after', null);
  $('view-info').textContent = 'Only the output is shown: the input files stay with the browser that sent them.';
  try {
    track(await api.getJob(id));
  } catch (err) {
    showProblem(err.problem ?? { title: 'Cannot open the job', detail: err.message });
  }
}

$('refresh-jobs').addEventListener('click', refreshJobs);

// ---- API key ----

$('key-form').addEventListener('submit', (e) => {
  e.preventDefault();
  api.setApiKey($('api-key').value.trim());
  $('api-key').value = '';
  delete document.body.dataset.needsKey;
  showProblem(null);
  refreshJobs();
});

// Result links carry no header: with a key, a click fetches the file with
// the key and saves it from memory instead.
$('downloads').addEventListener('click', async (e) => {
  const a = e.target.closest('a');
  if (!a || !api.apiKey() || a.href.startsWith('blob:')) return;
  e.preventDefault();
  try {
    const { blob, name } = await api.resultFile(a.href);
    const url = URL.createObjectURL(blob);
    const save = document.createElement('a');
    save.href = url;
    save.download = name;
    save.click();
    setTimeout(() => URL.revokeObjectURL(url), 60_000);
  } catch (err) {
    showProblem(err.problem ?? { title: 'Cannot download', detail: err.message });
  }
});

if (api.apiKey()) $('key-form').hidden = false;
fillDefaults().catch((err) => showProblem({ title: 'Cannot read the defaults', detail: err.message }));
refreshJobs();
