// Shared by the browser tests and the screenshot script: start a frame
// server, open the viewer in Debian's headless chromium (playwright-core,
// never a downloaded browser), read what the page reports and what it drew.
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { createRequire } from 'node:module';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

export const CHROMIUM = process.env.SODA_CHROMIUM || '/usr/bin/chromium';
// The headless flags: WebGL on SwiftShader (no GPU), nothing fetched.
export const CHROMIUM_ARGS = ['--no-sandbox', '--headless', '--disable-gpu', '--enable-unsafe-swiftshader',
  '--use-angle=swiftshader', '--disable-quic', '--disable-background-networking', '--disable-component-update', '--disable-sync',
  '--no-first-run'];

const here = path.dirname(fileURLToPath(import.meta.url));

export function fail(message) {
  console.error(`FAIL: ${message}`);
  process.exit(1);
}

// playwright-core from viewer/tests/node_modules (scripts/setup.sh installs it).
export function loadPlaywright() {
  if (!existsSync(CHROMIUM))
    fail(`${CHROMIUM} not found: the browser tests need Debian's chromium (scripts/setup.sh installs it)`);
  try {
    return createRequire(path.join(here, 'package.json'))('playwright-core');
  } catch (e) {
    fail(`playwright-core is not installed in ${here}/node_modules (scripts/setup.sh runs npm ci there): ${e.message}`);
  }
}

// Starts `command args`, resolves with {child, url, lines} once it prints
// "http://127.0.0.1:PORT/"; rejects if it exits first or after timeoutMs.
export function startServer(command, args, timeoutMs) {
  return new Promise((resolve, reject) => {
    const child = spawn(command, args, { stdio: ['ignore', 'pipe', 'pipe'] });
    const lines = [];
    let url = null;
    const timer = setTimeout(() => reject(new Error(`${command}: no URL within ${timeoutMs} ms`)), timeoutMs);
    child.stdout.setEncoding('utf8');
    child.stdout.on('data', (chunk) => {
      for (const line of chunk.split('\n')) if (line) lines.push(line);
      const m = /http:\/\/127\.0\.0\.1:\d+\//.exec(chunk);
      if (m && !url) {
        url = m[0];
        clearTimeout(timer);
        resolve({ child, url, lines });
      }
    });
    child.stderr.setEncoding('utf8');
    child.stderr.on('data', (chunk) => process.stderr.write(chunk));
    child.on('exit', (code) => {
      clearTimeout(timer);
      if (!url) reject(new Error(`${command} exited (${code}) before serving`));
    });
  });
}

export async function launchBrowser(playwright) {
  const userDataDir = mkdtempSync(path.join(tmpdir(), 'soda-viewer-chromium-'));
  const context = await playwright.chromium.launchPersistentContext(userDataDir, {
    executablePath: CHROMIUM, headless: true, args: CHROMIUM_ARGS, viewport: { width: 960, height: 640 },
  });
  return {
    context,
    async close() {
      await context.close();
      rmSync(userDataDir, { recursive: true, force: true });
    },
  };
}

// The #status element's data attributes.
export async function status(page) {
  return page.$eval('#status', (el) => ({ ...el.dataset, text: el.textContent }));
}

// Pixels of the WebGL canvas (drawn with preserveDrawingBuffer): how many
// match the background, and per palette colour how many have its
// chromaticity (r, g, b) / (r + g + b) within `tolerance` (lighting scales
// a colour, it keeps its chromaticity), the nearest of the palette.
export async function countColours(page, palette, background, tolerance = 0.05) {
  return page.evaluate(({ palette, background, tolerance }) => {
    const gl = document.querySelector('#view canvas');
    const c = document.createElement('canvas');
    c.width = gl.width;
    c.height = gl.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(gl, 0, 0);
    const data = ctx.getImageData(0, 0, c.width, c.height).data;
    const rgb = (hex) => [(hex >> 16) & 255, (hex >> 8) & 255, hex & 255];
    const chroma = ([r, g, b]) => { const s = r + g + b || 1; return [r / s, g / s, b / s]; };
    const targets = palette.map((hex) => chroma(rgb(hex)));
    const bg = rgb(background);
    const counts = new Array(palette.length).fill(0);
    let backgroundPixels = 0;
    for (let i = 0; i < data.length; i += 4) {
      const p = [data[i], data[i + 1], data[i + 2]];
      if (Math.abs(p[0] - bg[0]) <= 3 && Math.abs(p[1] - bg[1]) <= 3 && Math.abs(p[2] - bg[2]) <= 3) {
        ++backgroundPixels;
        continue;
      }
      if (p[0] + p[1] + p[2] < 90) continue;  // too dark to tell
      const q = chroma(p);
      let best = -1;
      let bestD = tolerance;
      targets.forEach((t, k) => {
        const d = Math.max(Math.abs(t[0] - q[0]), Math.abs(t[1] - q[1]), Math.abs(t[2] - q[2]));
        if (d < bestD) { bestD = d; best = k; }
      });
      if (best >= 0) ++counts[best];
    }
    return { width: c.width, height: c.height, total: data.length / 4, background: backgroundPixels, counts };
  }, { palette, background, tolerance });
}
