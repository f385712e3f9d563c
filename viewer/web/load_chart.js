// The per-world load chart: one bar per world in its colour — busy CPU per
// step (ms) when the frame carries it (a replay), else bodies owned (live).
import { cssColour, worldColour } from './palette.js';

export function drawLoadChart(canvas, label, frame, worlds) {
  const ctx = canvas.getContext('2d');
  const w = canvas.width;
  const h = canvas.height;
  ctx.clearRect(0, 0, w, h);
  let values;
  let unit;
  if (frame.worldBusyMs.length === worlds && worlds > 0) {
    values = Array.from(frame.worldBusyMs);
    unit = 'busy ms per step';
  } else {
    values = new Array(worlds).fill(0);
    for (const o of frame.owner) if (o < worlds) values[o] += 1;
    unit = 'bodies';
  }
  const max = Math.max(1e-9, ...values);
  const gap = 2;
  const barW = Math.max(1, (w - gap * (worlds + 1)) / Math.max(1, worlds));
  values.forEach((v, i) => {
    const bh = (v / max) * (h - 4);
    ctx.fillStyle = cssColour(worldColour(i));
    ctx.fillRect(gap + i * (barW + gap), h - bh, barW, bh);
  });
  const mean = values.reduce((a, b) => a + b, 0) / Math.max(1, worlds);
  label.textContent = `load per world (${unit}); max/mean ${(Math.max(...values) / Math.max(1e-9, mean)).toFixed(2)}`;
}
