// A picture of a run in the viewer, through the browser tests' headless
// path (browser.mjs): starts `soda run ... --serve 0 --serve-wait`, opens
// the page, waits for the run's last frame (its hash shown), saves a PNG.
//   node viewer/tests/screenshot.mjs SODA_EXE OUT.png [soda run options...]
//   node viewer/tests/screenshot.mjs build/bin/soda docs/images/viewer-cube-pile.png \
//        --scene cube-pile --n 1000 --territories 4 --steps 300
import { fail, launchBrowser, loadPlaywright, startServer, status } from './browser.mjs';

const [exe, out, ...runArgs] = process.argv.slice(2);
if (!exe || !out) fail('usage: node screenshot.mjs SODA_EXE OUT.png [soda run options...]');
const TIMEOUT_MS = 600000;
const playwright = loadPlaywright();
const server = await startServer(exe, ['run', ...runArgs, '--serve', '0', '--serve-wait', '--serve-linger', '600'],
                                 60000);
const browser = await launchBrowser(playwright);
try {
  const page = await browser.context.newPage();
  await page.setViewportSize({ width: 1200, height: 720 });
  await page.goto(server.url);
  await page.waitForFunction(() => document.getElementById('status').dataset.finished === '1', null,
                             { timeout: TIMEOUT_MS });
  await page.screenshot({ path: out });
  const st = await status(page);
  console.log(`${out}: step ${st.step}, ${st.bodies} bodies, ${st.worlds} worlds, state_hash ${st.hash}`);
} finally {
  await browser.close();
  server.child.kill('SIGTERM');
}
process.exit(0);
