// Drives the web page in the system Chromium with playwright-core, as a
// person would. Run by tests/web_page.rs, which starts the server:
//
//   node page.mjs flow       BASE_URL OUT_DIR DATA_DIR TEXTURED_OBJ_DIR
//   node page.mjs frame-time BASE_URL OUT_DIR MESH_FILE
//
// Chromium comes from CHROMIUM (default /usr/bin/chromium); playwright never
// downloads a browser. Screenshots go to OUT_DIR. The last line printed is
// `RESULT {json}` with the measurements; any failed check throws, and the
// process exits non-zero with the reason.

import assert from 'node:assert/strict';
import { readFile, writeFile, mkdir } from 'node:fs/promises';
import path from 'node:path';
import { chromium } from 'playwright-core';

const [scenario, base, outDir, arg, arg2] = process.argv.slice(2);
const JOB_TIMEOUT = 240_000;

async function launch() {
  return chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    args: [
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader',
    ],
  });
}

/** A page that fails the run on any CSP violation or uncaught error. */
async function openPage(browser) {
  const context = await browser.newContext({ viewport: { width: 1200, height: 900 }, acceptDownloads: true });
  const page = await context.newPage();
  const problems = [];
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('console', (m) => {
    const text = m.text();
    if (m.type() === 'error' && /Content.Security.Policy|Refused to/i.test(text)) problems.push(`CSP: ${text}`);
  });
  const started = Date.now();
  await page.goto(base + '/', { waitUntil: 'load' });
  await page.waitForFunction(() => document.getElementById('iterations').value !== '');
  const ready = Date.now() - started;
  const load = await page.evaluate(() => {
    const nav = performance.getEntriesByType('navigation')[0];
    const res = performance.getEntriesByType('resource');
    return {
      load_event_ms: nav.loadEventEnd,
      transfer_bytes: nav.transferSize + res.reduce((t, r) => t + r.transferSize, 0),
      decoded_bytes: nav.decodedBodySize + res.reduce((t, r) => t + r.decodedBodySize, 0),
      requests: 1 + res.length,
    };
  });
  return { page, problems, load: { ...load, ready_ms: ready } };
}

/**
 * Pixel statistics of a PNG screenshot of the canvas, decoded in the page:
 * per half (left, right), the fraction of pixels that differ from the
 * background, the number of distinct coarse colours, and the fraction of
 * "reddish", "greenish" and "yellowish" pixels; `raw` for comparisons.
 */
async function pixels(page, png) {
  return page.evaluate(async (b64) => {
    const blob = await (await fetch(`data:image/png;base64,${b64}`)).blob();
    const bmp = await createImageBitmap(blob);
    const c = new OffscreenCanvas(bmp.width, bmp.height);
    const g = c.getContext('2d');
    g.drawImage(bmp, 0, 0);
    const { data, width, height } = g.getImageData(0, 0, bmp.width, bmp.height);
    const half = (x0, x1) => {
      let drawn = 0, red = 0, green = 0, yellow = 0, n = 0;
      const colours = new Set();
      for (let y = 0; y < height; y++) {
        for (let x = x0; x < x1; x++) {
          const i = 4 * (y * width + x);
          const [r, gg, b] = [data[i], data[i + 1], data[i + 2]];
          n++;
          if (Math.abs(r - 0xf4) + Math.abs(gg - 0xf6) + Math.abs(b - 0xf8) > 24) drawn++;
          colours.add(`${r >> 4},${gg >> 4},${b >> 4}`);
          if (r > 150 && gg < 110 && b < 110) red++;
          if (gg > r + 40 && gg > b + 30) green++;
          if (r > 150 && gg > 120 && b < 90) yellow++;
        }
      }
      return { drawn: drawn / n, colours: colours.size, red: red / n, green: green / n, yellow: yellow / n };
    };
    const mid = Math.floor(width / 2);
    let sum = 0;
    for (let i = 0; i < data.length; i += 4) sum = (sum * 31 + data[i] + data[i + 1] * 3 + data[i + 2] * 7) >>> 0;
    return { left: half(0, mid), right: half(mid, width), checksum: sum, raw: Array.from(data.filter((_, i) => i % 16 === 0)) };
  }, png.toString('base64'));
}

function differing(a, b) {
  let n = 0;
  for (let i = 0; i < a.raw.length; i++) if (Math.abs(a.raw[i] - b.raw[i]) > 16) n++;
  return n / a.raw.length;
}

async function shot(page, name) {
  // A heavy mesh is first drawn through its stand-in: wait for the full frame.
  await page.waitForFunction(() => !['quick', 'refining'].includes(document.getElementById('canvas').dataset.frame), null, { timeout: JOB_TIMEOUT });
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const png = await page.locator('#canvas').screenshot();
  await writeFile(path.join(outDir, name), png);
  return pixels(page, png);
}

async function select(page, id, value) {
  await page.selectOption(`#${id}`, value);
}

/** Chooses files, submits, and waits until the job is finished; returns the job. */
async function remesh(page, files, { faces } = {}) {
  await page.setInputFiles('#files', files);
  if (faces) {
    await page.check('input[name=target_kind][value=target_faces]');
    await page.fill('#target_value', String(faces));
  } else {
    await page.check('input[name=target_kind][value=none]');
  }
  const before = await page.evaluate(() => window.isoremesh.state.job?.id ?? null);
  await page.click('#submit');
  await page.waitForFunction(
    (previous) => {
      const { jobStatus, viewer } = document.body.dataset;
      const id = window.isoremesh.state.job?.id ?? null;
      const done = ['succeeded', 'failed', 'cancelled'].includes(jobStatus);
      return id !== previous && done && (jobStatus !== 'succeeded' || viewer === 'ready');
    },
    before,
    { timeout: JOB_TIMEOUT },
  );
  return page.evaluate(() => window.isoremesh.state.job);
}

async function download(page, format) {
  const [dl] = await Promise.all([page.waitForEvent('download'), page.click(`#downloads a[data-format=${format}]`)]);
  return readFile(await dl.path());
}

async function flow() {
  const data = arg;
  const browser = await launch();
  const result = {};
  try {
    const { page, problems, load } = await openPage(browser);
    result.load = load;

    // Dropping a file onto the drop zone takes it as the mesh.
    const cube = await readFile(path.join(data, 'cube.obj'), 'utf8');
    const dropped = await page.evaluateHandle((text) => {
      const dt = new DataTransfer();
      dt.items.add(new File([text], 'cube.obj', { type: 'model/obj' }));
      return dt;
    }, cube);
    await page.dispatchEvent('#drop', 'drop', { dataTransfer: dropped });
    await page.waitForFunction(() => /^cube\.obj \([\d,]+ bytes\) — the mesh$/.test(document.getElementById('file-list').textContent));
    assert.ok(await page.isEnabled('#submit'), 'a dropped mesh does not enable the submit button');

    // Every other input format previews in the "before" view.
    for (const file of ['spot_binary.stl', 'spot_binary_le.ply', 'fertility.off', 'cube_quads_be.ply']) {
      await page.evaluate(() => {
        const shown = window.isoremesh.viewer.objects.before;
        if (shown) shown.seen = true;
      });
      await page.setInputFiles('#files', [path.join(data, file)]);
      await page.waitForFunction(() => window.isoremesh.viewer.objects.before?.seen === undefined);
      assert.equal(await page.textContent('#view-info'), '', `${file}: ${await page.textContent('#view-info')}`);
      const preview = await shot(page, `preview-${file.replace('.', '-')}.png`);
      assert.ok(preview.left.drawn > 0.03, `${file} does not preview: ${JSON.stringify(preview.left)}`);
    }

    // spot.obj: before and after side by side.
    let job = await remesh(page, [path.join(data, 'spot.obj')]);
    assert.equal(job.status, 'succeeded', JSON.stringify(job.error));
    const shaded = await shot(page, 'before-after.png');
    assert.ok(shaded.left.drawn > 0.05, `the before view is blank: ${JSON.stringify(shaded.left)}`);
    assert.ok(shaded.right.drawn > 0.05, `the after view is blank: ${JSON.stringify(shaded.right)}`);
    assert.ok(shaded.right.colours > 20, 'the after view is one flat colour: no shading');

    await select(page, 'display', 'wireframe');
    const wire = await shot(page, 'wireframe.png');
    assert.ok(differing(shaded, wire) > 0.05, `the wireframe toggle changed ${differing(shaded, wire)} of the image`);
    await select(page, 'display', 'both');
    const both = await shot(page, 'shaded-wireframe.png');
    assert.ok(differing(shaded, both) > 0.02 && differing(wire, both) > 0.02, 'shaded + wireframe equals one of the others');
    await select(page, 'display', 'shaded');

    await select(page, 'colour', 'ratio');
    const ratio = await shot(page, 'quality-edge-ratio.png');
    assert.ok(ratio.right.green > 0.05, `edge-ratio colours: the remeshed side should be mostly in band (green): ${JSON.stringify(ratio.right)}`);
    const legendText = await page.textContent('#legend');
    assert.match(legendText, /in band/);
    const inBand = Number(legendText.match(/([\d.]+) % in band/)[1]);
    assert.ok(inBand > 80, `only ${inBand} % of output triangles in band`);
    result.output_triangles_in_band_pct = inBand;
    await select(page, 'colour', 'angle');
    const angle = await shot(page, 'quality-smallest-angle.png');
    assert.ok(differing(ratio, angle) > 0.01, 'angle colours look like ratio colours');
    assert.match(await page.textContent('#legend'), /below 30°/);
    await select(page, 'colour', 'material');

    await select(page, 'layout', 'slider');
    await page.fill('#split', '0.3');
    await page.dispatchEvent('#split', 'input');
    const slider = await shot(page, 'slider.png');
    assert.ok(slider.left.drawn > 0.03 && slider.right.drawn > 0.03, 'the slider view is blank');
    await select(page, 'layout', 'side');

    // Histograms with the band marked, and the tables.
    for (const id of ['plot-edge-length', 'plot-angles', 'plot-valence']) {
      const bars = await page.locator(`#${id} rect.bar`).count();
      assert.ok(bars > 3, `${id} has ${bars} bars`);
    }
    const band = await page.locator('#plot-edge-length rect.band');
    assert.equal(await band.count(), 1, 'the edge-length histogram has no band');
    const bandBox = await band.boundingBox();
    const plotBox = await page.locator('#plot-edge-length svg').boundingBox();
    // The band [0.8, 1.333] of an axis [0, 2.1): starts near 38 % of the plot.
    const startFrac = (bandBox.x - plotBox.x) / plotBox.width;
    assert.ok(startFrac > 0.3 && startFrac < 0.5 && bandBox.width > plotBox.width * 0.15, `band at ${startFrac}, width ${bandBox.width}`);
    for (const caption of ['Counts', 'Distance of the output to the input', 'Features']) {
      assert.ok(await page.locator('#tables caption', { hasText: caption }).count(), `no ${caption} table`);
    }
    await page.screenshot({ path: path.join(outDir, 'page.png'), fullPage: true });

    // Downloads: the stored OBJ, a re-encoded binary STL, the statistics.
    const obj = (await download(page, 'obj')).toString();
    const faces = obj.split('\n').filter((l) => l.startsWith('f ')).length;
    assert.equal(faces, job.result.triangles, 'the OBJ download has another face count');
    const stl = await download(page, 'stl');
    assert.equal(stl.length, 84 + 50 * stl.readUInt32LE(80), 'the STL download is not a binary STL');
    assert.equal(stl.readUInt32LE(80), job.result.triangles);
    const glb = await download(page, 'glb');
    assert.equal(glb.subarray(0, 4).toString(), 'glTF');
    const stats = JSON.parse((await download(page, 'stats')).toString());
    assert.equal(stats.output.faces, job.result.triangles);
    result.spot = { triangles: job.result.triangles };

    // A textured GLB: the texture shows before and, carried through the
    // remesh, after.
    await select(page, 'colour', 'material');
    job = await remesh(page, [path.join(data, 'gltf', 'Duck.glb')]);
    assert.equal(job.status, 'succeeded', JSON.stringify(job.error));
    const duck = await shot(page, 'textured-duck.png');
    assert.ok(duck.left.yellow > 0.02, `the duck's texture is not visible: ${JSON.stringify(duck.left)}`);
    assert.ok(duck.right.drawn > 0.02, 'the remeshed duck is not visible');
    assert.ok(duck.right.yellow > 0.02, `the remeshed duck's texture is not visible: ${JSON.stringify(duck.right)}`);
    result.duck = { triangles: job.result.triangles };

    // A .gltf with its external buffer and image, chosen together.
    const box = path.join(data, 'gltf', 'BoxTextured');
    job = await remesh(page, [path.join(box, 'BoxTextured.gltf'), path.join(box, 'BoxTextured0.bin'), path.join(box, 'CesiumLogoFlat.png')]);
    assert.equal(job.status, 'succeeded', JSON.stringify(job.error));
    assert.deepEqual(job.input.buffers, ['BoxTextured0.bin', 'CesiumLogoFlat.png']);

    // An OBJ with its material library and texture, chosen together (and a
    // stray file, which stays behind): the texture shows before and after,
    // and the OBJ download is a zip that holds the .mtl and the image.
    const tex = arg2;
    await select(page, 'output_format', 'obj');
    job = await remesh(page, [path.join(tex, 'spot.obj'), path.join(tex, 'spot.mtl'), path.join(tex, 'checker.png'), path.join(data, 'cube.obj')]);
    assert.equal(job.status, 'succeeded', JSON.stringify(job.error));
    assert.deepEqual([...job.input.buffers].sort(), ['checker.png', 'spot.mtl']);
    const spotTex = await shot(page, 'textured-obj.png');
    assert.ok(spotTex.left.yellow > 0.01, `the OBJ's texture is not visible before: ${JSON.stringify(spotTex.left)}`);
    assert.ok(spotTex.right.yellow > 0.01, `the OBJ's texture is not visible after: ${JSON.stringify(spotTex.right)}`);
    const zip = await download(page, 'obj-zip');
    assert.equal(zip.subarray(0, 2).toString(), 'PK', 'the OBJ bundle is not a zip');
    for (const name of ['.obj', '.mtl', 'checker.png']) assert.ok(zip.includes(name), `the OBJ bundle has no ${name}`);
    result.textured_obj = { triangles: job.result.triangles, parts: job.input.buffers };
    await select(page, 'output_format', '');

    // Cancel a long job while it is queued or running.
    await page.setInputFiles('#files', [path.join(data, 'spot.obj')]);
    await page.check('input[name=target_kind][value=target_faces]');
    await page.fill('#target_value', '4000000');
    await page.click('#submit');
    await page.waitForFunction(() => ['queued', 'running'].includes(document.body.dataset.jobStatus));
    await page.waitForSelector('#cancel:not([hidden])');
    await page.waitForFunction(() => /running — iteration \d+ of \d+, \w+/.test(document.getElementById('status').textContent), null, { timeout: 60_000 });
    await page.click('#cancel');
    await page.waitForFunction(() => document.body.dataset.jobStatus === 'cancelled', null, { timeout: 30_000 });
    assert.match(await page.textContent('#status'), /cancelled/);

    // A bad file: the problem document is shown.
    await page.setInputFiles('#files', [{ name: 'broken.obj', mimeType: 'text/plain', buffer: Buffer.from('this is not a mesh\n') }]);
    await page.check('input[name=target_kind][value=none]');
    await page.click('#submit');
    await page.waitForSelector('#problem:not([hidden])');
    const problem = await page.textContent('#problem');
    assert.match(problem, /\((4\d\d)\)/, `no status in the problem shown: ${problem}`);
    result.bad_file_problem = problem;
    await page.screenshot({ path: path.join(outDir, 'problem.png') });

    // The jobs list reopens a finished job in the viewer.
    await page.click('#refresh-jobs');
    await page.waitForFunction(() => document.querySelectorAll('#jobs tbody tr').length >= 4);
    const rows = await page.locator('#jobs tbody tr').allTextContents();
    assert.ok(rows.some((r) => r.includes('cancelled')) && rows.filter((r) => r.includes('succeeded')).length >= 3, rows.join('\n'));
    await page.locator('#jobs tbody tr', { hasText: 'succeeded' }).last().locator('button').click();
    await page.waitForFunction(() => document.body.dataset.viewer === 'ready' && document.body.dataset.jobStatus === 'succeeded');
    const reopened = await shot(page, 'reopened.png');
    assert.ok(reopened.right.drawn > 0.05, 'the reopened job shows nothing');

    assert.deepEqual(problems, [], 'errors or CSP violations in the page');
    return result;
  } finally {
    await browser.close();
  }
}

async function frameTime() {
  const browser = await launch();
  try {
    const { page, problems } = await openPage(browser);
    await select(page, 'output_format', 'glb');
    const t0 = Date.now();
    const job = await remesh(page, [arg], { faces: 1_000_000 });
    assert.equal(job.status, 'succeeded', JSON.stringify(job.error));
    const out = { triangles: job.result.triangles, submit_to_shown_ms: Date.now() - t0 };
    for (const [display, colour] of [['shaded', 'material'], ['shaded', 'ratio'], ['both', 'material']]) {
      await select(page, 'display', display);
      const c0 = Date.now();
      await select(page, 'colour', colour);
      const switch_ms = Date.now() - c0;
      const px = await shot(page, `torus-${display}-${colour}.png`);
      assert.ok(px.left.drawn > 0.05 && px.right.drawn > 0.05, `${display}/${colour}: a side is blank`);
      if (colour === 'ratio') assert.ok(px.right.green > 0.05, 'the remeshed torus is not mostly in band');
      const t = await page.evaluate(() => window.isoremesh.viewer.timeFrames(5));
      assert.ok(t.proxy_triangles.after > 1000 && t.proxy_triangles.after < 200_000, `stand-in of ${t.proxy_triangles.after} triangles`);
      assert.ok(t.slices.count > 1, 'the full frame was not drawn in slices');
      // The sliced frame is the full frame (up to the canvas's antialiasing).
      const refined = await shot(page, `torus-${display}-${colour}-refined.png`);
      await page.evaluate(() => window.isoremesh.viewer.draw());
      const direct = await shot(page, `torus-${display}-${colour}-direct.png`);
      const differ = differing(refined, direct);
      assert.ok(differ < 0.03, `${display}/${colour}: the sliced frame differs from the direct one in ${differ} of the pixels`);
      out[`${display}_${colour}`] = { ...t, mode_switch_ms: switch_ms, refined_vs_direct: differ };
    }
    assert.deepEqual(problems, []);
    return out;
  } finally {
    await browser.close();
  }
}

/**
 * Against a server with API keys (`arg` is tests/data, `arg2` a valid key):
 * the page asks for a key, refuses a wrong one with the server's problem,
 * and with the right one submits, shows the result, lists the job and
 * downloads the result with the key.
 */
async function keys() {
  const data = arg;
  const browser = await launch();
  const result = {};
  try {
    const { page, problems } = await openPage(browser);
    await page.waitForFunction(() => document.body.dataset.needsKey === 'true');
    assert.ok(await page.isVisible('#key-form'), 'the key form is hidden on a server with keys');
    await page.fill('#api-key', 'irk_wrong');
    await page.click('#use-key');
    await page.waitForFunction(() => /not valid/.test(document.getElementById('problem').textContent));
    await page.fill('#api-key', arg2);
    await page.click('#use-key');
    const job = await remesh(page, [path.join(data, 'cube.obj')]);
    assert.equal(job.status, 'succeeded', JSON.stringify(job.error));
    const glb = await download(page, 'glb');
    assert.equal(glb.subarray(0, 4).toString('latin1'), 'glTF', 'the download is not the GLB result');
    await page.click('#refresh-jobs');
    await page.waitForFunction((id) => document.getElementById('jobs').tBodies[0].rows.length === 1 && window.isoremesh.state.job.id === id, job.id);
    result.job = job.id;
    result.glb_bytes = glb.length;
    assert.deepEqual(problems, []);
  } finally {
    await browser.close();
  }
  return result;
}

await mkdir(outDir, { recursive: true });
try {
  const scenarios = { flow, keys, 'frame-time': frameTime };
  if (!scenarios[scenario]) throw new Error(`unknown scenario ${scenario}`);
  const result = await scenarios[scenario]();
  console.log(`RESULT ${JSON.stringify(result)}`);
} catch (e) {
  console.error(e.stack || String(e));
  process.exit(1);
}
