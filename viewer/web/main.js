// The viewer's page logic: the header, then frames — a finished source (a
// replay) is played, paused and scrubbed step by step with /frame?at=N; a
// live one is polled with /frame?after=N (the newest committed frame).
// URL parameters: ?play=0 starts paused; ?step=N starts at step N;
// ?colour=sleep colours by sleep. Bodies added during the run are described
// by the server's /bodies when a frame first holds them. docs/viewer.md.
import { fetchBodies, fetchFrame, fetchJson } from './protocol.js';
import { drawLoadChart } from './load_chart.js';
import { cssColour, worldColour } from './palette.js';
import { SceneView } from './scene_view.js';

// Live: how long to wait before asking again when no newer frame exists.
const LIVE_POLL_MS = 30;
// Replay: played at this many scene steps per second of wall time x dt
// (1: real time).
const PLAY_SPEED = 1;

const $ = (id) => document.getElementById(id);
const status = $('status');
const params = new URLSearchParams(location.search);

const state = {
  header: null,
  view: null,
  mode: '',
  first: 0,
  last: -1,
  playing: params.get('play') !== '0',
  shown: null,         // the frame drawn last
  framesShown: 0,
  hash: '',
  finished: false,
  colourMode: params.get('colour') === 'sleep' ? 'sleep' : 'world',
  busy: false,          // a request is under way
  pending: null,        // a step asked for meanwhile (replay)
  asked: new Set(),     // bodies asked of /bodies
};

function report(error) {
  const f = state.shown;
  status.dataset.step = f ? String(f.step) : '-1';
  status.dataset.bodies = f ? String(f.n) : '0';
  status.dataset.drawn = state.view ? String(state.view.drawnCount()) : '0';
  status.dataset.frames = String(state.framesShown);
  status.dataset.finished = state.finished ? '1' : '0';
  status.dataset.hash = state.hash;
  status.dataset.mode = state.mode;
  status.dataset.worlds = state.header ? String(state.header.territories) : '0';
  if (error) status.dataset.error = String(error);
  status.textContent = error ? `error: ${error}`
    : `${state.mode}: step ${f ? f.step : '–'} of ${state.first}..${state.last}, ${f ? f.n : 0} bodies` +
      (state.finished ? ', finished' : '');
}

// Shows a frame; bodies it holds that the page has no description of yet
// (added during the run) are asked of the server first.
async function show(frame) {
  const missing = state.view.undescribed(frame.ids).filter((id) => !state.asked.has(id));
  if (missing.length > 0) {
    for (const id of missing) state.asked.add(id);  // asked once: one the server cannot describe is not drawn
    state.view.describe(await fetchBodies(missing));
  }
  state.view.update(frame, state.colourMode);
  state.view.render();
  state.shown = frame;
  state.framesShown += 1;
  if (frame.stateHash) state.hash = frame.stateHash;
  if (frame.finished) state.finished = true;
  if (frame.step > state.last) state.last = frame.step;
  const timeline = $('timeline');
  timeline.min = String(state.first);
  timeline.max = String(Math.max(state.first, state.last));
  timeline.value = String(frame.step);
  $('step-label').textContent = `step ${frame.step}`;
  $('hash').textContent = state.hash ? `state_hash ${state.hash}` : '';
  drawLoadChart($('load-chart'), $('load-label'), frame, state.header.territories);
  report();
}

async function liveLoop() {
  for (;;) {
    try {
      const after = state.shown ? state.shown.step : -1;
      const frame = await fetchFrame(`after=${after}`);
      if (frame) await show(frame);
      if (state.finished) return;
      if (!frame) {
        // Nothing newer: the run may have ended on the step shown (the pump
        // read it before the hash was added), so ask whether it finished and
        // fetch that step again with its hash.
        const range = await fetchJson('/range');
        if (range.finished) {
          const last = await fetchFrame(`at=${range.last}`);
          if (last) await show(last);
          return;
        }
        await new Promise((r) => setTimeout(r, LIVE_POLL_MS));
      }
    } catch (e) {
      report(e.message);  // the server went away (the run ended): keep the last frame
      return;
    }
  }
}

// Shows the frame at `step`; true if the source held it. A request made
// while another is under way (a scrub during play) is kept and shown after
// it (the newest such request wins), never dropped.
async function showStep(step) {
  if (state.busy) {
    state.pending = step;
    return false;
  }
  state.busy = true;
  try {
    const frame = await fetchFrame(`at=${step}`);
    if (frame) await show(frame);
    while (state.pending !== null) {
      const next = state.pending;
      state.pending = null;
      const f = await fetchFrame(`at=${next}`);
      if (f) await show(f);
    }
    return frame !== null;
  } catch (e) {
    report(e.message);
    return false;
  } finally {
    state.busy = false;
  }
}

// Replay: advance by wall time; a step the source does not hold is skipped.
function replayLoop() {
  let target = state.shown ? state.shown.step : state.first;
  let then = performance.now();
  const tick = async (now) => {
    const elapsed = (now - then) / 1000;
    then = now;
    if (state.playing && !state.busy && state.shown) {
      target = Math.max(target, state.shown.step) + Math.max(1, Math.round(elapsed * PLAY_SPEED / state.header.dt));
      if (target > state.last) {
        target = state.last;
        setPlaying(false);
      }
      for (let s = target; s <= state.last; ++s)
        if (await showStep(s)) break;
    }
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
}

function setPlaying(playing) {
  state.playing = playing;
  $('play').textContent = playing ? 'Pause' : 'Play';
}

function legend(worlds) {
  const el = $('legend');
  el.innerHTML = '';
  for (let w = 0; w < Math.min(worlds, 24); ++w) {
    const item = document.createElement('span');
    item.innerHTML = `<i style="background:${cssColour(worldColour(w))}"></i>${w}`;
    el.appendChild(item);
  }
}

async function main() {
  state.header = await fetchJson('/header');
  const range = await fetchJson('/range');
  state.first = range.first;
  state.last = range.last;
  state.mode = range.finished ? 'replay' : 'live';
  $('title').textContent = `SODA · ${state.header.scene} · ${state.header.dynamic_count} bodies · ` +
                           `${state.header.territories} worlds · ${state.mode}`;
  $('colour-mode').value = state.colourMode;
  legend(state.header.territories);
  state.view = new SceneView($('view'), state.header);
  window.sodaView = state.view;  // for the browser tests: isDrawn(id), drawnCount(), vertexCount(id)
  state.view.render();
  report();
  $('colour-mode').addEventListener('change', (e) => {
    state.colourMode = e.target.value;
    if (state.shown) show(state.shown).catch((err) => report(err.message));
  });
  $('borders').addEventListener('change', (e) => state.view.setBordersVisible(e.target.checked));
  setPlaying(state.playing && state.mode === 'replay');
  $('play').disabled = state.mode !== 'replay';
  $('play').addEventListener('click', () => setPlaying(!state.playing));
  $('timeline').addEventListener('input', (e) => {
    if (state.mode !== 'replay') return;
    setPlaying(false);
    showStep(Number(e.target.value));
  });
  if (state.mode === 'live') {
    $('timeline').disabled = true;
    await liveLoop();
  } else {
    const start = params.has('step') ? Number(params.get('step')) : state.first;
    const frame = await fetchFrame(`at=${start}`) ?? await fetchFrame(`after=${start - 1}`);
    if (frame) await show(frame);
    replayLoop();
  }
}

main().catch((e) => report(e.message));
