// The browser tests (ctest label `browser`; docs/viewer.md, "Tests"):
//   node viewer_test.mjs replay SERVER_EXE OUT_DIR   a recorded run (viewer_test_server)
//   node viewer_test.mjs live SODA_EXE OUT_DIR       soda run --serve 0 (a running scene)
//   node viewer_test.mjs file SODA_EXE OUT_DIR       soda run --record, then soda view FILE
//   node viewer_test.mjs inputs SODA_EXE OUT_DIR     the same with --inputs: bodies come and go
//   node viewer_test.mjs shapes SODA_EXE OUT_DIR     the same on compounds: each drawn as its children
// Starts the server on 127.0.0.1, loads the page in headless chromium, waits
// for the page to report a frame, screenshots it into OUT_DIR, checks that
// every world's colour is drawn somewhere and the background elsewhere, and
// the step shown. Exits 1 with "FAIL: ..." on any failure; stops itself
// (every wait has a timeout).
import { execFileSync } from 'node:child_process';
import { mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { countColours, fail, launchBrowser, loadPlaywright, startServer, status } from './browser.mjs';

const [mode, exe, outDir] = process.argv.slice(2);
if (!['replay', 'live', 'file', 'inputs', 'shapes'].includes(mode) || !exe || !outDir)
  fail('usage: node viewer_test.mjs replay|live|file|inputs|shapes EXE OUT_DIR');
const playwright = loadPlaywright();
const palette = paletteFromSource();
const TERRITORIES = 4;
const TIMEOUT_MS = 60000;
const LIVE_STEPS = 300;
// Each world's colour must cover at least this many pixels (a few cubes at
// 960x640), the background at least this fraction of the canvas.
const MIN_WORLD_PIXELS = 40;
const MIN_BACKGROUND_FRACTION = 0.2;
// inputs: a plank added at step 30 (in the frames from 31 on) and body 5
// removed at step 50 (in the frames up to 50), on falling-cubes 400.
const ADDED = 100000;
const REMOVED = 5;
const ADD_STEP = 30;
const REMOVE_STEP = 50;
const CUBES = 400;
// shapes: chairs and tables (compounds of boxes) over two static tables.
const COMPOUNDS = 120;
// Vertices of a box drawn unindexed (a compound drawn as one box has these).
const BOX_VERTICES = 36;
const INPUTS = {
  format: 'soda-inputs', version: 1,
  inputs: [
    { type: 'add_body', step: ADD_STEP,
      body: { id: ADDED, type: 'dynamic', mass: 4, shape: { type: 'box', half_extents: [2.0, 0.2, 0.5] },
              position: [0, 12, 0], linear_velocity: [0, -2, 0] } },
    { type: 'remove_body', step: REMOVE_STEP, id: REMOVED },
  ],
};

// WORLD_COLOURS and BACKGROUND_COLOUR as the page has them (palette.js).
function paletteFromSource() {
  const text = readFileSync(new URL('../web/palette.js', import.meta.url), 'utf8');
  const list = /WORLD_COLOURS = \[([^\]]*)\]/.exec(text)[1].match(/0x[0-9a-f]{6}/gi).map(Number);
  const background = Number(/BACKGROUND_COLOUR = (0x[0-9a-f]{6})/i.exec(text)[1]);
  return { list, background };
}

function checkPixels(px, label) {
  const worlds = px.counts.slice(0, TERRITORIES);
  console.log(`${label}: ${px.width}x${px.height}, background ${px.background} px, per world ${worlds.join(' ')} px`);
  if (px.background < MIN_BACKGROUND_FRACTION * px.total)
    fail(`${label}: only ${px.background} of ${px.total} pixels are background`);
  worlds.forEach((n, w) => {
    if (n < MIN_WORLD_PIXELS) fail(`${label}: world ${w}'s colour covers ${n} pixels (< ${MIN_WORLD_PIXELS}): bodies not drawn?`);
  });
}

// Scrubs the page to `step` (as a drag of the slider does) and checks which
// bodies it draws: every body of the frame, the added one from its step on,
// the removed one up to its step.
async function checkBodiesAt(page, step) {
  await page.fill('#timeline', String(step));
  await page.waitForFunction((s) => document.getElementById('status').dataset.step === String(s), step,
                             { timeout: TIMEOUT_MS });
  const st = await status(page);
  const drawn = await page.evaluate(([a, r]) => [window.sodaView.isDrawn(a), window.sodaView.isDrawn(r)],
                                    [ADDED, REMOVED]);
  const bodies = CUBES + (step > ADD_STEP ? 1 : 0) - (step > REMOVE_STEP ? 1 : 0);
  console.log(`inputs: step ${step}: ${st.bodies} bodies in the frame, ${st.drawn} drawn, added ${drawn[0]}, ` +
              `removed body drawn ${drawn[1]}`);
  if (st.bodies !== String(bodies) || st.drawn !== String(bodies))
    fail(`step ${step}: the page shows ${st.bodies} bodies and draws ${st.drawn}, the run had ${bodies}`);
  if (drawn[0] !== step > ADD_STEP) fail(`step ${step}: the added body ${drawn[0] ? 'is' : 'is not'} drawn`);
  if (drawn[1] !== step <= REMOVE_STEP) fail(`step ${step}: the removed body ${drawn[1] ? 'is' : 'is not'} drawn`);
}

async function run() {
  mkdirSync(outDir, { recursive: true });
  // file: a replay file recorded by soda run --record and served by soda
  // view, the user's path (the same checks as the in-memory replay).
  let fileHash = null;
  let args;
  if (mode === 'file' || mode === 'inputs' || mode === 'shapes') {
    const file = path.join(outDir, `viewer-test-${mode}.replay`);
    const extra = [];
    if (mode === 'inputs') {
      const inputs = path.join(outDir, 'viewer-test-inputs.json');
      writeFileSync(inputs, JSON.stringify(INPUTS));
      extra.push('--inputs', inputs);
    }
    const scene = mode === 'shapes' ? ['--scene', 'compounds', '--n', String(COMPOUNDS)]
                                    : ['--scene', 'falling-cubes', '--n', String(CUBES)];
    const out = execFileSync(exe, ['run', ...scene, '--territories', String(TERRITORIES), '--steps', '90', '--record',
                                   file, '--log-level', 'warn', ...extra],
                             { encoding: 'utf8', timeout: TIMEOUT_MS });
    fileHash = /state_hash ([0-9a-f]{16})/.exec(out)?.[1];
    if (!fileHash) fail(`soda run --record printed no state_hash: ${out}`);
    args = ['view', file, '--port', '0', '--seconds', '120'];
  } else args = mode === 'replay'
    ? ['--scene', 'falling-cubes', '--n', '400', '--territories', String(TERRITORIES), '--steps', '90', '--seconds', '120']
    : ['run', '--scene', 'falling-cubes', '--n', '1000', '--territories', String(TERRITORIES), '--steps', String(LIVE_STEPS),
       '--serve', '0', '--serve-linger', '60', '--serve-wait'];
  const server = await startServer(exe, args, TIMEOUT_MS);
  const browser = await launchBrowser(playwright);
  try {
    const page = await browser.context.newPage();
    const errors = [];
    page.on('pageerror', (e) => errors.push(e.message));
    page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
    if (mode === 'inputs') {
      // Played from step 0 to the end, as a user presses Play: every frame
      // drawn, bodies created and removed on the way.
      await page.goto(`${server.url}?play=1&step=0`, { timeout: TIMEOUT_MS });
      await page.waitForFunction(() => document.getElementById('status').dataset.step === '90', null,
                                 { timeout: TIMEOUT_MS });
      const played = await status(page);
      console.log(`inputs: played to step ${played.step} in ${played.frames} frames`);
      if (Number(played.frames) < 10) fail(`playing showed ${played.frames} frames: it did not play`);
      if (played.hash !== fileHash || played.finished !== '1')
        fail(`after playing the page shows hash '${played.hash}' (finished ${played.finished}), the run's is ${fileHash}`);
      // Scrubbed around each input, forwards and back.
      for (const step of [ADD_STEP, ADD_STEP + 1, REMOVE_STEP, REMOVE_STEP + 1, 60, ADD_STEP - 10, 90, REMOVE_STEP])
        await checkBodiesAt(page, step);
      await checkBodiesAt(page, 60);
      await page.screenshot({ path: path.join(outDir, 'viewer-inputs.png') });
      checkPixels(await countColours(page, palette.list, palette.background), 'inputs step 60');
    } else if (mode === 'shapes') {
      // Every compound, static or dynamic, is drawn as its children: as
      // many boxes as it has children, not the one box of its bounds.
      await page.goto(`${server.url}?play=0&step=90`, { timeout: TIMEOUT_MS });
      await page.waitForFunction(() => document.getElementById('status').dataset.step === '90', null,
                                 { timeout: TIMEOUT_MS });
      const header = await page.evaluate(() => window.sodaView.header);
      const compounds = header.bodies.filter((b) => b.shape.kind === 'compound');
      const drawn = await page.evaluate((ids) => ids.map((id) => window.sodaView.vertexCount(id)),
                                        compounds.map((b) => b.id));
      const statics = compounds.filter((b) => b.static).length;
      console.log(`shapes: ${compounds.length} compounds (${statics} static), ` +
                  `${compounds[0]?.shape.children.length} children and ${drawn[0]} vertices drawn for body ${compounds[0]?.id}`);
      if (compounds.length < 2 || statics === 0 || statics === compounds.length)
        fail(`the header has ${compounds.length} compounds, ${statics} of them static: expected both kinds`);
      compounds.forEach((b, i) => {
        const boxes = b.shape.children.filter((c) => c.shape.kind === 'box').length;
        if (boxes !== b.shape.children.length) fail(`body ${b.id}: children that are not boxes`);
        if (drawn[i] !== boxes * BOX_VERTICES)
          fail(`body ${b.id}: ${drawn[i]} vertices drawn for ${boxes} boxes (${boxes * BOX_VERTICES} expected)`);
      });
      await page.screenshot({ path: path.join(outDir, 'viewer-shapes.png') });
      const end = await status(page);
      if (end.hash !== fileHash || end.finished !== '1')
        fail(`at the end the page shows hash '${end.hash}' (finished ${end.finished}), the run's is ${fileHash}`);
    } else if (mode === 'replay' || mode === 'file') {
      const step = 60;
      await page.goto(`${server.url}?play=0&step=${step}`, { timeout: TIMEOUT_MS });
      await page.waitForFunction((s) => document.getElementById('status').dataset.step === String(s), step,
                                 { timeout: TIMEOUT_MS });
      const st = await status(page);
      const label = await page.textContent('#step-label');
      if (label !== `step ${step}`) fail(`the step label reads '${label}', expected 'step ${step}'`);
      if (st.mode !== 'replay' || st.worlds !== String(TERRITORIES)) fail(`status ${JSON.stringify(st)}`);
      await page.screenshot({ path: path.join(outDir, 'viewer-replay.png') });
      checkPixels(await countColours(page, palette.list, palette.background), 'replay step 60');
      // The last frame carries the run's hash, shown on the page.
      const hash = fileHash ?? server.lines.find((l) => l.startsWith('state_hash ')).split(' ')[1];
      await page.fill('#timeline', '90');  // sets the slider and fires its input event, as a drag does
      await page.waitForFunction(() => document.getElementById('status').dataset.step === '90', null, { timeout: TIMEOUT_MS });
      const end = await status(page);
      if (end.hash !== hash || end.finished !== '1') fail(`at the end the page shows hash '${end.hash}' (finished ${end.finished}), the run's is ${hash}`);
      if (!(await page.textContent('#hash')).includes(hash)) fail('the hash is not displayed');
    } else {
      await page.goto(server.url, { timeout: TIMEOUT_MS });
      await page.waitForFunction(() => Number(document.getElementById('status').dataset.step) >= 0, null,
                                 { timeout: TIMEOUT_MS });
      const first = await status(page);
      await page.screenshot({ path: path.join(outDir, 'viewer-live.png') });
      if (first.mode !== 'live') fail(`status ${JSON.stringify(first)}`);
      // The live page follows the run to its end and shows the hash soda prints.
      await page.waitForFunction(() => document.getElementById('status').dataset.finished === '1', null,
                                 { timeout: TIMEOUT_MS });
      const end = await status(page);
      const line = server.lines.find((l) => l.includes('state_hash'));
      const hash = /state_hash ([0-9a-f]{16})/.exec(line)[1];
      console.log(`live: first frame step ${first.step}, ${end.frames} frames shown, last step ${end.step}, hash ${end.hash}`);
      if (end.step !== String(LIVE_STEPS)) fail(`the live page ended on step ${end.step}, the run on ${LIVE_STEPS}`);
      if (end.hash !== hash) fail(`the live page shows hash '${end.hash}', soda printed ${hash}`);
      if (Number(end.frames) < 2) fail(`the live page showed ${end.frames} frame(s): it did not follow the run`);
      checkPixels(await countColours(page, palette.list, palette.background), 'live end');
    }
    const st = await status(page);
    if (st.error) fail(`the page reports an error: ${st.error}`);
    if (errors.length) fail(`the page logged errors: ${errors.join(' | ')}`);
    console.log(`${mode}: ok (step ${st.step}, ${st.bodies} bodies)`);
  } finally {
    await browser.close();
    server.child.kill('SIGTERM');
  }
}

const watchdog = setTimeout(() => fail(`still running after ${4 * TIMEOUT_MS} ms`), 4 * TIMEOUT_MS);
run().then(() => { clearTimeout(watchdog); process.exit(0); }, (e) => fail(e.stack || e.message));
