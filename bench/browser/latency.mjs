// Drag latency of the web editor as a person sees it, in Debian's headless Chromium:
//
//   node latency.mjs URL [N=100]
//
// On a running `puppet serve` at URL, makes drags — each a press on a point of a body layer, a
// few mouse moves of a few pixels about one display frame apart, a release, Reset — until N
// moves are made, after one warm-up drag that is not counted. The page records each move as a
// Performance API measure "drag-move": from the move's event time to the animation frame after
// the answer that covers it is drawn (moves made while a request is out wait for the next one:
// that wait is part of the latency). Prints count, median, p95, max (ms) of those measures, and
// how many drag requests the moves took and their round trips.
//
// Environment (optional): MOVES (moves per drag, 10; N for one long drag), STEP_PX (screen
// pixels per move, 3), MOVE_MS (pause between moves, 16), SEED (which points, 1), CHROMIUM.
import os from 'node:os';
import { chromium } from 'playwright-core';

const url = process.argv[2];
const total = Number(process.argv[3] || 100);
if (!url || !(total > 0)) {
  console.error('usage: node latency.mjs URL [N=100]');
  process.exit(2);
}
const env = process.env;
const perDrag = Math.max(1, Number(env.MOVES || 10));
const stepPx = Number(env.STEP_PX || 3);
const moveMs = Number(env.MOVE_MS ?? 16);
let seed = Number(env.SEED || 1);
// A small seeded generator (mulberry32), so two runs press the same points.
const random = () => {
  seed = (seed + 0x6d2b79f5) | 0;
  let t = Math.imul(seed ^ (seed >>> 15), 1 | seed);
  t = (t + Math.imul(t ^ (t >>> 7), 61 | t)) ^ t;
  return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
};
const sleep = (ms) => new Promise((ok) => setTimeout(ok, ms));
const load = () => os.loadavg().map((x) => x.toFixed(2)).join(' ');

const browser = await chromium.launch({
  executablePath: env.CHROMIUM || '/usr/bin/chromium',
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update', '--no-first-run'],
});
let status = 0;
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 }, deviceScaleFactor: 1 });
  page.on('pageerror', (e) => console.log(`[page error] ${e.message}`));
  const trips = [];
  page.on('requestfinished', (r) => {
    if (r.url().endsWith('/api/drag')) { const t = r.timing(); trips.push(t.responseEnd - t.requestStart); }
  });
  const idle = () => page.waitForFunction(() => !window.puppetEditor.busy(), null, { timeout: 120000, polling: 10 });
  await page.goto(url);
  await page.waitForFunction(() => window.puppetEditor && !window.puppetEditor.busy(), null, { timeout: 120000 });
  const st = await page.evaluate(() => window.puppetEditor.state());
  // The puppet as the outfit drawn (outfit 0 on loading: the model's own).
  const P = { ...st.puppet, ...st.puppet.outfits[st.outfit] };
  const geo = await page.evaluate(() => {
    const c = document.getElementById('stage'), r = c.getBoundingClientRect();
    return { left: r.left + c.clientLeft, top: r.top + c.clientTop };
  });
  // Points to press: centroids of body-layer triangles in the fitted pose, on the pixel grid.
  const points = [];
  P.layers.forEach((l) => {
    if (l.kind !== 'body') return;
    for (const t of l.triangles) {
      const c = [0, 1].map((k) => t.reduce((s, i) => s + st.fitted[l.offset + i][k], 0) / 3);
      points.push([Math.round(geo.left + c[0] * st.scale), Math.round(geo.top + c[1] * st.scale)]);
    }
  });
  const w = P.width * st.scale, h = P.height * st.scale;
  console.log(`Chromium ${browser.version()} · ${url}: ${P.width}×${P.height} puppet, ${P.layers.length} layers, ${P.vertex_count} vertices, scale ${st.scale}`);
  console.log(`${total} moves in drags of ${perDrag} moves of ${stepPx} screen px, ${moveMs} ms apart (+1 warm-up drag); ${os.cpus().length} CPUs, load average ${load()}`);

  async function drag(moves) {
    const [x, y] = points[Math.floor(random() * points.length)];
    const a = random() * 2 * Math.PI;
    // Away from the nearer edges: flip a direction that would leave the canvas.
    let dx = Math.cos(a) * stepPx, dy = Math.sin(a) * stepPx;
    if (x - geo.left + dx * moves < 0 || x - geo.left + dx * moves > w) dx = -dx;
    if (y - geo.top + dy * moves < 0 || y - geo.top + dy * moves > h) dy = -dy;
    await page.mouse.move(x, y);
    await page.mouse.down();
    for (let k = 1; k <= moves; k++) {
      await page.mouse.move(x + dx * k, y + dy * k);
      if (moveMs > 0) await sleep(moveMs);
    }
    await page.mouse.up();
    await idle();
    await page.click('#reset');
    await idle();
  }
  await drag(perDrag);
  await page.evaluate(() => performance.clearMeasures('drag-move'));
  trips.length = 0;
  const started = Date.now();
  for (let done = 0; done < total; done += perDrag) await drag(Math.min(perDrag, total - done));
  const seconds = (Date.now() - started) / 1000;
  const ms = (await page.evaluate(() => performance.getEntriesByName('drag-move').map((m) => m.duration))).sort((a, b) => a - b);
  const q = (s, p) => s[Math.min(s.length - 1, Math.ceil(p * s.length) - 1)];
  const f = (x) => x.toFixed(1);
  if (ms.length !== total) {
    console.log(`FAIL ${ms.length} drag-move measures for ${total} moves`);
    status = 1;
  }
  if (ms.length) {
    console.log(`drag-move: count ${ms.length}, median ${f(q(ms, 0.5))} ms, p95 ${f(q(ms, 0.95))} ms, max ${f(ms[ms.length - 1])} ms (min ${f(ms[0])}, mean ${f(ms.reduce((s, x) => s + x, 0) / ms.length)})`);
  }
  const tr = trips.slice().sort((a, b) => a - b);
  if (tr.length) {
    console.log(`drag requests: ${tr.length} for ${total} moves and ${Math.ceil(total / perDrag)} releases (each settles the pose with 40 steps); round trip median ${f(q(tr, 0.5))} ms, p95 ${f(q(tr, 0.95))} ms, max ${f(tr[tr.length - 1])} ms`);
  }
  console.log(`${f(seconds)} s; load average after ${load()}`);
} catch (e) {
  console.log(`FAIL ${e.stack || e}`);
  status = 1;
} finally {
  await browser.close();
}
process.exit(status);
