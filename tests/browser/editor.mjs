// The web editor (`puppet serve`) end to end in Debian's headless Chromium, driven by Playwright:
//
//   node editor.mjs URL OUT_DIR
//
// Loads the page at URL, pins the character's "hand" with the mouse, drags it, checks that the
// pin reached its target (recomputed here from the vertices the page holds), removes the pin
// with a right-click, undoes and redoes that, resets to the fit, clicks off the character and
// checks the page says so; then makes and plays an in-between, shows the appearance stage's
// redraws of the pose and of an in-between and downloads them (when served with --appearance),
// hides and shows an accessory,
// downloads the pose as PNG; asks what to draw next, shows a suggestion posed, sends drawings
// back (one of the wrong size, refused) and continues the model on them; plays a BVH motion in a
// loop; and opens a second page that drags its own pin unseen by the first. Screenshots in
// OUT_DIR: loaded.png, dragged.png, removed.png, inbetween.png, appearance.png,
// accessory_hidden.png, suggest.png, motion.png (failure.png when a step could not finish), and
// the downloads, export.png and appearance.gif.
// Prints one PASS/FAIL line per check; exits 1 if any failed. Run by tests/browser.rs
// (`cargo test --release browser`), which starts the server on the tiny test character.
//
// Environment (all optional):
//   HAND_LAYER    the layer whose hand to grab (default: the front-most body layer)
//   DRAG_PX       how far to drag, in DRAG_UNIT (default 20)
//   DRAG_UNIT     screen (CSS pixels; default) or frame (the puppet's pixels; × scale on screen)
//   DRAG_MOVES    mouse moves in the drag (default 10)
//   MOVE_MS       pause between two moves, ms (default 16: about one display frame)
//   PIN_TOLERANCE how far the pin may end from its target, frame pixels (default 2)
//   ALPHA_REG, ALPHA_JOINTS  set on the page's α1 (ARAP) and α2 (joints) sliders before the
//                 drag (default: the page's own, 25 and 50)
//   ACCESSORY     the accessory layer to hide and show (default: the first one)
//   UPLOAD_FRAME  a frame file to upload and use as the in-between's second key (default: none;
//                 the second frame is the second key)
//   DRAWING       a frame file to send back as the drawing of the first suggestion (default: none)
//   BAD_DRAWING   an image of another size, to send first and see refused (default: none)
//   CONTINUE_STEPS  steps of the continuation started once the drawing joined (default: none)
//   MOTION        a BVH file to play on the character, seen from the side (default: none)
//   MOTION_FRAMES the frames it must have (default: any)
//   CHROMIUM      the browser (default /usr/bin/chromium)
import fs from 'node:fs';
import path from 'node:path';
import { chromium } from 'playwright-core';

const [url, outArg] = process.argv.slice(2);
if (!url || !outArg) {
  console.error('usage: node editor.mjs URL OUT_DIR');
  process.exit(2);
}
const outDir = path.resolve(outArg);
fs.mkdirSync(outDir, { recursive: true });
fs.rmSync(path.join(outDir, 'failure.png'), { force: true });
const env = process.env;
const handLayer = env.HAND_LAYER || '';
const dragPx = Number(env.DRAG_PX || 20);
const dragUnit = env.DRAG_UNIT || 'screen';
const dragMoves = Math.max(1, Math.round(Number(env.DRAG_MOVES || 10)));
const moveMs = Number(env.MOVE_MS ?? 16);
const tolerance = Number(env.PIN_TOLERANCE || 2);
if (!['screen', 'frame'].includes(dragUnit) || !(dragPx > 0) || !(tolerance > 0)) {
  console.error(`DRAG_UNIT must be screen or frame, DRAG_PX and PIN_TOLERANCE positive numbers (got ${dragUnit}, ${dragPx}, ${tolerance})`);
  process.exit(2);
}

// --- checks ------------------------------------------------------------------------------------
let failed = 0;
function check(name, ok, detail) {
  console.log(`${ok ? 'PASS' : 'FAIL'} ${name}${detail === undefined ? '' : `: ${detail}`}`);
  if (!ok) failed++;
  return ok;
}
// A check the later steps depend on: a failure stops the run.
class Stop extends Error {}
function must(name, ok, detail) {
  if (!check(name, ok, detail)) throw new Stop(`${name} failed: later steps need it`);
}
const sleep = (ms) => new Promise((ok) => setTimeout(ok, ms));
const f1 = (x) => x.toFixed(1);
const f2 = (x) => x.toFixed(2);
const pt = (p) => `(${f2(p[0])}, ${f2(p[1])})`;

// --- geometry on the page's state (frame pixels, global vertex numbering) ------------------------
// Barycentric coordinates of p in triangle (a, b, c), or null for a degenerate triangle.
function barycentric(p, a, b, c) {
  const det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
  if (Math.abs(det) < 1e-12) return null;
  const w1 = ((p[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (p[1] - a[1])) / det;
  const w2 = ((b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1])) / det;
  return [1 - w1 - w2, w1, w2];
}
const inside = (w) => w && w.every((x) => x >= -1e-4);
// The front-most triangle holding p in pose V: {layer, tri (global indices), w}, or null.
function hit(puppet, V, p, layers = puppet.layers.map((_, i) => i)) {
  for (let li = puppet.layers.length - 1; li >= 0; li--) {
    if (!layers.includes(li)) continue;
    const l = puppet.layers[li];
    for (const t of l.triangles) {
      const tri = t.map((i) => l.offset + i);
      const w = barycentric(p, ...tri.map((i) => V[i]));
      if (inside(w)) return { layer: li, tri, w };
    }
  }
  return null;
}
const apply = (V, h) => [0, 1].map((k) => h.tri.reduce((s, i, j) => s + h.w[j] * V[i][k], 0));
const dist = (p, q) => Math.hypot(p[0] - q[0], p[1] - q[1]);
const layerVertices = (l, V) => l.rest.map((_, i) => V[l.offset + i]);
const centroid = (ps) => [0, 1].map((k) => ps.reduce((s, p) => s + p[k], 0) / ps.length);

// The hand: on layer `name` (else the front-most body layer), the vertex on the canvas farthest
// from the layer's joint — estimated as the centroid of its vertices lying on another body layer
// (parts overlap where they join; the layer's centroid when none does). Returns the layer, the
// vertex and the point to press: the vertex moved inward until the front-most layer under it,
// on the screen's pixel grid, is that layer.
function pickHand(st, box) {
  const P = st.puppet, V = st.vertices;
  let li = handLayer ? P.layers.findIndex((l) => l.name === handLayer) : -1;
  if (handLayer && li < 0) throw new Stop(`HAND_LAYER ${handLayer} is not a layer (layers: ${P.layers.map((l) => l.name).join(', ')})`);
  if (li < 0) li = P.layers.map((l) => l.kind).lastIndexOf('body');
  if (li < 0) throw new Stop('the puppet has no body layer');
  const l = P.layers[li];
  const vs = layerVertices(l, V);
  const bodyOthers = P.layers.map((m, i) => i).filter((i) => i !== li && P.layers[i].kind === 'body');
  const overlapping = vs.filter((v) => hit(P, V, v, bodyOthers));
  const joint = centroid(overlapping.length ? overlapping : vs);
  const middle = centroid(vs);
  const onCanvas = (p) => p[0] >= 0 && p[1] >= 0 && p[0] <= P.width && p[1] <= P.height;
  const order = vs.map((v, i) => i).filter((i) => onCanvas(vs[i])).sort((a, b) => dist(vs[b], joint) - dist(vs[a], joint));
  for (const vi of order) {
    const v = vs[vi];
    for (let inward = 0.5; inward <= 4; inward += 0.5) {
      const d = dist(middle, v) || 1;
      const p = [0, 1].map((k) => v[k] + (middle[k] - v[k]) / d * inward);
      const screen = box.toScreen(p).map(Math.round);
      const frame = box.toFrame(screen);
      const h = hit(P, V, frame);
      if (h && h.layer === li) {
        return { layer: l.name, vertex: vi, at: v, joint, jointFrom: overlapping.length ? `${overlapping.length} vertices on other body layers` : 'the layer centroid', screen, frame };
      }
    }
  }
  throw new Stop(`no vertex of layer ${l.name} has a point of the layer in front near it on the canvas`);
}

// --- in-betweens, accessories, downloads ---------------------------------------------------------
// Each gets { page, state, idle, box, check, must, shot } (box: frame ↔ screen pixels) and
// returns null when it ran its checks, or why it was skipped.

// A hash of a canvas's pixels (the WebGL canvas keeps its drawing buffer).
const canvasHash = (page, id = 'stage') => page.evaluate((id) => {
  const d = document.getElementById(id).toDataURL();
  let h = 0;
  for (let i = 0; i < d.length; i++) h = (h * 31 + d.charCodeAt(i)) | 0;
  return h;
}, id);
// Sets a range or select input as a person would, firing its events.
const setInput = (page, id, value) => page.evaluate(([id, value]) => {
  const e = document.getElementById(id);
  e.value = value;
  e.dispatchEvent(new Event('input', { bubbles: true }));
  e.dispatchEvent(new Event('change', { bubbles: true }));
}, [id, String(value)]);

async function playInbetween({ page, state, check, must, shot }) {
  let frames = await page.locator('#thumbs img').count();
  if (process.env.UPLOAD_FRAME) {
    await page.setInputFiles('#upload', process.env.UPLOAD_FRAME);
    await page.waitForFunction((n) => document.querySelectorAll('#thumbs img').length > n, frames, { timeout: 10000 })
      .catch(() => {});
    const now = await page.locator('#thumbs img').count();
    must('an uploaded frame joins the thumbnails', now === frames + 1, `${frames} → ${now} (#error: ${await page.locator('#error').textContent()})`);
    frames = now;
    // Posing the upload: it is also fitted from the prior, and the status line says which start
    // the session kept, with both L2s.
    const before = await page.locator('#frame').inputValue();
    await setInput(page, 'frame', frames - 1);
    await page.waitForFunction(() => /^fitted .* (from the prior's fit|by the network) \(L2 \d+/.test(document.getElementById('status').textContent),
      null, { timeout: 30000 }).catch(() => {});
    const said = await page.locator('#status').textContent();
    check('a session on the upload says which start it kept', /(from the prior's fit|by the network) \(L2 \d+/.test(said), said);
    await setInput(page, 'frame', before);
    await page.waitForFunction(() => /^fitted /.test(document.getElementById('status').textContent), null, { timeout: 30000 }).catch(() => {});
  }
  if (frames < 2) return `${frames} frame(s): an in-between needs two`;
  // Keys by thumbnail: a click for the first, shift-click for the second (the upload, if any).
  const second = process.env.UPLOAD_FRAME ? frames - 1 : 1;
  await page.locator('#thumbs img').nth(0).click();
  await page.locator('#thumbs img').nth(second).click({ modifiers: ['Shift'] });
  const keys = await page.evaluate(() => [document.getElementById('ib-from').value, document.getElementById('ib-to').value]);
  check('thumbnails pick the keys (click, shift-click)', keys[0] === '0' && keys[1] === String(second), `from ${keys[0]}, to ${keys[1]}`);
  await page.fill('#ib-count', '6');
  await page.selectOption('#ib-easing', 'ease-in-out');
  await page.click('#ib-make');
  await page.waitForFunction(() => window.puppetEditor.state().inbetween, null, { timeout: 30000 });
  let st = await state();
  must('the in-between has the keys and 6 in-betweens', st.inbetween.frames === 8, `${st.inbetween.frames} frames`);
  const t = st.inbetween.t;
  check('slow in, slow out: short steps at the keys', t[1] - t[0] < 1 / 7 && t[7] - t[6] < 1 / 7 && t[4] - t[3] > 1 / 7,
    t.map((x) => x.toFixed(3)).join(' '));
  const first = await canvasHash(page);
  await setInput(page, 'ib-scrub', 7);
  check('scrubbing to the last frame changes the picture', (await canvasHash(page)) !== first);
  await setInput(page, 'ib-fps', 30);
  await page.click('#ib-play');
  await page.waitForFunction(() => window.puppetEditor.state().played >= 8, null, { timeout: 10000 });
  await page.click('#ib-play');
  st = await state();
  check('play runs through every frame and pauses', st.played >= 8 && !st.inbetween.playing, `${st.played} frames shown`);
  await setInput(page, 'ib-scrub', 4);
  console.log(`  screenshot ${await shot('inbetween.png')} (frame 4 of 7, onion skin on)`);
  await page.click('#ib-close');
  return null;
}

async function toggleAccessory({ page, state, check, must, shot }) {
  const boxes = page.locator('#accessories input[type=checkbox]');
  if ((await boxes.count()) === 0) return 'the puppet has no accessory layer';
  const name = process.env.ACCESSORY || await boxes.first().getAttribute('data-layer');
  const box = page.locator(`#accessories input[data-layer="${name}"]`);
  must(`an accessory checkbox for ${name}`, (await box.count()) === 1);
  const shown = await canvasHash(page);
  await box.uncheck();
  let st = await state();
  const hidden = await canvasHash(page);
  check(`unchecking ${name} hides it`, st.hidden.includes(name) && hidden !== shown, `hidden: ${st.hidden.join(', ')}`);
  console.log(`  screenshot ${await shot('accessory_hidden.png')}`);
  await box.check();
  st = await state();
  check(`checking ${name} shows it again, the same picture`, !st.hidden.includes(name) && (await canvasHash(page)) === shown);
  return null;
}

async function exportPng({ page, state, check, must }) {
  await page.selectOption('#export-what', 'pose');
  await page.selectOption('#export-format', 'png');
  const [download] = await Promise.all([page.waitForEvent('download', { timeout: 30000 }), page.click('#export')]);
  const file = path.join(outDir, 'export.png');
  await download.saveAs(file);
  const bytes = fs.readFileSync(file);
  const P = (await state()).puppet;
  must('the download is a PNG', bytes.subarray(0, 8).equals(Buffer.from([137, 80, 78, 71, 13, 10, 26, 10])),
    `${download.suggestedFilename()}, ${bytes.length} bytes`);
  const [w, h] = [bytes.readUInt32BE(16), bytes.readUInt32BE(20)];
  check('the PNG is the puppet\'s frame size', w === P.width && h === P.height, `${w}×${h} (${download.suggestedFilename()})`);
  // Its pixels, decoded by the browser: the character is drawn (opaque pixels) on transparency.
  const counts = await page.evaluate(async (b64) => {
    const img = new Image(); img.src = 'data:image/png;base64,' + b64; await img.decode();
    const c = document.createElement('canvas'); c.width = img.width; c.height = img.height;
    const ctx = c.getContext('2d'); ctx.drawImage(img, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    let opaque = 0, clear = 0;
    for (let i = 3; i < d.length; i += 4) { if (d[i] > 128) opaque++; else if (d[i] === 0) clear++; }
    return { opaque, clear };
  }, bytes.toString('base64'));
  check('the PNG shows the character on a transparent background', counts.opaque > 50 && counts.clear > 50,
    `${counts.opaque} opaque, ${counts.clear} clear pixels`);
  return null;
}

// The appearance stage (served with --appearance): the redraw of the pose beside the render,
// one per frame of an in-between, following the scrubber, and a GIF of the redrawn in-between.
async function appearanceStage({ page, state, idle, check, must, shot }) {
  let st = await state();
  if (!st.appearance.available) return 'the editor has no appearance stage (puppet serve --appearance)';
  must('the appearance panel is shown', await page.locator('#apppanel').isVisible());
  await page.locator('#appearance').check();
  await idle('redrawing the pose');
  st = await state();
  const opaque = () => page.evaluate(() => {
    const c = document.getElementById('generated');
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 3; i < d.length; i += 4) if (d[i] > 128) n++;
    return n;
  });
  const drawn = await opaque();
  must('the redraw of the pose is shown beside the render', st.appearance.shown && st.appearance.frames === 1
    && await page.locator('#generated').isVisible() && drawn > 50,
    `${st.appearance.frames} frame(s), ${drawn} opaque pixels (#error: ${JSON.stringify(await page.locator('#error').textContent())})`);
  await page.click('#ib-make');
  await page.waitForFunction(() => window.puppetEditor.state().inbetween, null, { timeout: 30000 });
  await idle('redrawing the in-between');
  st = await state();
  must('every frame of the in-between is redrawn', st.appearance.frames === st.inbetween.frames,
    `${st.appearance.frames} redrawn of ${st.inbetween.frames}`);
  await setInput(page, 'ib-scrub', 0);
  const first = await canvasHash(page, 'generated');
  await setInput(page, 'ib-scrub', st.inbetween.frames - 1);
  check('the redraw follows the scrubber', (await canvasHash(page, 'generated')) !== first);
  console.log(`  screenshot ${await shot('appearance.png')} (the last key: render, redraw)`);
  await page.selectOption('#export-what', 'inbetween');
  await page.selectOption('#export-format', 'gif');
  await page.locator('#export-appearance').check();
  const [download] = await Promise.all([page.waitForEvent('download', { timeout: 60000 }), page.click('#export')]);
  const file = path.join(outDir, 'appearance.gif');
  await download.saveAs(file);
  const bytes = fs.readFileSync(file);
  check('the redrawn in-between downloads as a GIF', bytes.subarray(0, 6).toString() === 'GIF89a', `${download.suggestedFilename()}, ${bytes.length} bytes`);
  await page.locator('#export-appearance').uncheck();
  await page.click('#ib-close');
  await page.locator('#appearance').uncheck();
  check('unchecking hides the redraw', !(await page.locator('#generated').isVisible()));
  return null;
}

// A screenshot of the elements `ids` (their bounding box in the page, scrolled or not).
async function shotOf(name, ids) {
  const file = path.join(outDir, name);
  const clip = await page.evaluate((ids) => {
    const rects = ids.map((id) => document.getElementById(id).getBoundingClientRect());
    const [x, y] = [Math.min(...rects.map((r) => r.left)), Math.min(...rects.map((r) => r.top))];
    const [right, bottom] = [Math.max(...rects.map((r) => r.right)), Math.max(...rects.map((r) => r.bottom))];
    return { x: x + window.scrollX - 6, y: y + window.scrollY - 6, width: right - x + 12, height: bottom - y + 12 };
  }, ids);
  await page.screenshot({ path: file, clip, fullPage: true });
  return path.relative(process.cwd(), file);
}

// What to draw next: suggestions listed with their trace-over pictures, one shown posed, a
// drawing of the wrong size refused, a drawing joining the frames, the continuation run.
async function drawNext({ page, state, idle, check, must }) {
  let st = await state();
  if (!st.next.status) return 'the page has no "what to draw next" status';
  await page.fill('#next-count', '3');
  const started = Date.now();
  await page.click('#next-suggest');
  await page.waitForFunction(() => window.puppetEditor.state().next.suggestions.length > 0, null, { timeout: 60000 }).catch(() => {});
  await idle('suggesting');
  st = await state();
  must('suggestions are listed', st.next.suggestions.length > 0,
    `${st.next.suggestions.length} in ${Date.now() - started} ms (#error: ${JSON.stringify(await page.locator('#error').textContent())})`);
  const loaded = await page.waitForFunction(() => [...document.querySelectorAll('#suggestions img')]
    .every((im) => im.complete && im.naturalWidth > 0), null, { timeout: 10000 }).then(() => true, () => false);
  const sizes = await page.evaluate(() => [...document.querySelectorAll('#suggestions img')].map((im) => `${im.naturalWidth}×${im.naturalHeight}`));
  check('each suggestion\'s trace-over picture is drawn', loaded && sizes.length === st.next.suggestions.length, sizes.join(', '));
  check('each suggestion says where it came from and how badly it is read',
    st.next.suggestions.every((s) => s.origin.length > 0 && Number.isFinite(s.misread_px) && s.vertices === st.puppet.vertex_count),
    st.next.suggestions.map((s) => `${s.origin} (${f1(s.misread_px)} px)`).join('; '));
  const before = await canvasHash(page);
  await page.locator('#suggestions .suggestion button').first().click();
  st = await state();
  check('"Show posed" draws the suggestion on the canvas', st.inbetween?.kind === 'suggestion' && st.next.shown === 0
    && (await canvasHash(page)) !== before);
  console.log(`  screenshot ${await shotOf('suggest.png', ['view', 'nextpanel'])}`);
  const drawingInput = page.locator('#suggestions input.drawing').first();
  if (env.BAD_DRAWING) {
    await drawingInput.setInputFiles(env.BAD_DRAWING);
    await page.waitForFunction(() => document.getElementById('error').textContent !== '', null, { timeout: 10000 }).catch(() => {});
    const said = await page.locator('#error').textContent();
    st = await state();
    check('a drawing of another size is refused, saying why', /the puppet's frames are/.test(said) && !st.next.status.folder, JSON.stringify(said));
  }
  if (env.DRAWING) {
    await drawingInput.setInputFiles(env.DRAWING);
    await page.waitForFunction(() => window.puppetEditor.state().next.status.drawings.length > 0, null, { timeout: 30000 }).catch(() => {});
    st = await state();
    const command = await page.locator('#next-command').textContent();
    must('the drawing joins the training frames', st.next.status.drawings.length === 1 && st.next.status.folder,
      `${JSON.stringify(st.next.status.drawings)} in ${st.next.status.folder} (#error: ${JSON.stringify(await page.locator('#error').textContent())})`);
    check('the page shows the command that continues the model', command.startsWith('puppet train --from '), command);
    if (env.CONTINUE_STEPS) {
      await page.fill('#next-steps', env.CONTINUE_STEPS);
      const shown = await page.locator('#next-command').textContent();
      check('the command follows the steps asked for', shown.endsWith(`--steps ${env.CONTINUE_STEPS}`), shown);
      await page.click('#next-continue');
      await page.waitForFunction(() => { const t = window.puppetEditor.state().next.status.training; return t && t.state !== 'running'; },
        null, { timeout: 180000, polling: 200 }).catch(() => {});
      st = await state();
      const t = st.next.status.training;
      check('the continuation runs to its end in the background', t && t.state === 'done' && t.step === Number(env.CONTINUE_STEPS),
        t ? `${t.state}: ${t.step}/${t.steps} steps in ${f1(t.seconds)} s → ${t.output} ${t.error || ''}` : 'none');
      check('the page says where the continued model is', (await page.locator('#next-training').textContent()).includes(t?.output ?? '?'));
    }
  }
  await page.locator('#suggestions .suggestion button').first().click();
  st = await state();
  check('"Hide" goes back to posing', !st.inbetween);
  await page.evaluate(() => window.scrollTo(0, 0));
  return null;
}

// A BVH motion played on the character in a loop by the player.
async function playMotion({ page, state, idle, check, must }) {
  if (!env.MOTION) return 'no MOTION file given';
  await page.selectOption('#motion-view', 'side');
  await page.setInputFiles('#motion-file', env.MOTION);
  await page.waitForFunction(() => window.puppetEditor.state().inbetween?.kind === 'motion', null, { timeout: 60000 }).catch(() => {});
  let st = await state();
  must('the motion is played on the character', st.inbetween?.kind === 'motion',
    `#error: ${JSON.stringify(await page.locator('#error').textContent())}`);
  const frames = st.inbetween.frames;
  check('with the file\'s frames', !env.MOTION_FRAMES || frames === Number(env.MOTION_FRAMES), `${frames} frames`);
  const info = await page.locator('#motion-info').textContent();
  check('the page says which joint drives which layer', info.includes('→'), info);
  await page.waitForFunction((n) => window.puppetEditor.state().played > n, frames, { timeout: 20000 }).catch(() => {});
  st = await state();
  check('it plays in a loop', st.inbetween.playing && st.played > frames, `${st.played} frames shown of ${frames}`);
  console.log(`  screenshot ${await shotOf('motion.png', ['view', 'motionpanel'])}`);
  await page.click('#motion-play');
  st = await state();
  check('Pause stops it', !st.inbetween.playing);
  await setInput(page, 'ib-scrub', 0);
  const first = await canvasHash(page);
  await setInput(page, 'ib-scrub', Math.floor(frames / 4));
  check('its frames differ', (await canvasHash(page)) !== first);
  await page.click('#motion-stop');
  await idle('after the motion');
  st = await state();
  check('"Back to posing" ends it', !st.inbetween);
  await page.evaluate(() => window.scrollTo(0, 0));
  return null;
}

// A second page on the same server drags its own pin; neither page sees the other's.
async function twoPages({ page, state, check, must, hand, dragScreen }) {
  const other = await browser.newPage({ viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 });
  try {
    await other.goto(url);
    await other.waitForFunction(() => window.puppetEditor && !window.puppetEditor.busy(), null, { timeout: 60000, polling: 20 });
    const otherState = () => other.evaluate(() => window.puppetEditor.state());
    const mine = await state();
    let theirs = await otherState();
    must('a second page opens its own session', theirs.session && theirs.session !== mine.session && theirs.pins.length === 0,
      `sessions ${mine.session} and ${theirs.session}`);
    // The same layout: the hand is under the same screen point on both pages.
    await other.mouse.move(...hand.screen);
    await other.mouse.down();
    for (let k = 1; k <= 5; k++) await other.mouse.move(hand.screen[0] + dragScreen * k / 5, hand.screen[1]);
    await other.mouse.up();
    await other.waitForFunction(() => !window.puppetEditor.busy(), null, { timeout: 30000, polling: 20 });
    theirs = await otherState();
    const after = await state();
    check('the second page drags its own pin', theirs.pins.length === 1 && JSON.stringify(theirs.vertices) !== JSON.stringify(theirs.fitted));
    check('the first page sees none of it', after.pins.length === mine.pins.length && JSON.stringify(after.vertices) === JSON.stringify(mine.vertices),
      `${after.pins.length} pins on the first page`);
    // The first page's own drag still works, and does not reach the second page.
    await page.mouse.move(...hand.screen);
    await page.mouse.down();
    for (let k = 1; k <= 5; k++) await page.mouse.move(hand.screen[0], hand.screen[1] + dragScreen * k / 5);
    await page.mouse.up();
    await page.waitForFunction(() => !window.puppetEditor.busy(), null, { timeout: 30000, polling: 20 });
    const again = await otherState();
    const first = await state();
    check('a drag on the first page leaves the second as it was', first.pins.length === 1
      && JSON.stringify(again.vertices) === JSON.stringify(theirs.vertices) && again.pins.length === 1,
      `first page: ${first.pins.length} pins (#error: ${JSON.stringify(await page.locator('#error').textContent())}); second page: ${again.pins.length} pins, `
      + `pose ${JSON.stringify(again.vertices) === JSON.stringify(theirs.vertices) ? 'unchanged' : 'changed'}`);
  } finally {
    await other.close();
  }
  return null;
}

// --- the run -----------------------------------------------------------------------------------
const browser = await chromium.launch({
  executablePath: env.CHROMIUM || '/usr/bin/chromium',
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update',
    '--no-first-run', '--force-color-profile=srgb'],
});
// Wide enough that the page's tool bar does not wrap (at 900 px it wraps when the status line
// grows during a drag, which moves the canvas under the pointer: see canvasStill below).
const page = await browser.newPage({ viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 });
const pageErrors = [];
page.on('console', (m) => {
  // The browser asks for /favicon.ico on its own; the server has none (a 404, harmless).
  if (m.location().url?.endsWith('/favicon.ico')) return;
  if (m.type() === 'error' || m.type() === 'warning') console.log(`  [page ${m.type()}] ${m.text()} (${m.location().url || 'page'})`);
});
page.on('pageerror', (e) => { pageErrors.push(e.message); console.log(`  [page error] ${e.message}`); });
page.on('response', (r) => { if (r.status() >= 400) console.log(`  [HTTP ${r.status()}] ${r.request().method()} ${r.url()}`); });
let dragRequests = 0;
let lastDrag = null;
page.on('request', (r) => {
  if (r.url().endsWith('/api/drag')) {
    dragRequests++;
    lastDrag = r.postDataJSON();
  }
});
// The tool bar, the canvas and the error line (the rest of the page is blank).
const shot = async (name) => {
  const file = path.join(outDir, name);
  const clip = await page.evaluate(() => {
    const rect = (e) => e.getBoundingClientRect();
    const wide = [...document.querySelectorAll('#bar > *, #main > *')].map(rect);
    const tall = ['bar', 'main'].map((id) => document.getElementById(id)).filter(Boolean).map(rect);
    const right = Math.max(...wide.map((r) => r.right)), bottom = Math.max(...tall.map((r) => r.bottom));
    return { x: 0, y: 0, width: Math.ceil(right + 14), height: Math.ceil(bottom + 10) };
  }).catch(() => undefined);
  await page.screenshot({ path: file, clip });
  return path.relative(process.cwd(), file);
};
// The page's state, the puppet seen as the outfit it draws (layers, vertex_count).
const state = () => page.evaluate(() => {
  const st = window.puppetEditor.state();
  const o = st.puppet.outfits[st.outfit];
  return { ...st, puppet: { ...st.puppet, layers: o.layers, vertex_count: o.vertex_count } };
});
const errorText = () => page.locator('#error').textContent();
// Until the page has a session and no drag request in flight or pending.
async function idle(what, timeout = 30000) {
  try {
    await page.waitForFunction(() => window.puppetEditor && !window.puppetEditor.busy(), null, { timeout, polling: 20 });
  } catch (e) {
    throw new Stop(`the page stayed busy ${timeout / 1000} s ${what} (#error: ${JSON.stringify(await errorText().catch(() => '?'))})`);
  }
}

try {
  const t0 = Date.now();
  await page.goto(url);
  await idle('after loading (fitting the first frame)', 60000);
  console.log(`Chromium ${browser.version()} · ${url} · ready in ${Date.now() - t0} ms`);
  let st = await state();
  const P = st.puppet;
  // Frame pixels ↔ viewport (CSS) pixels through the canvas's content box (inside its border).
  const canvasBox = () => page.evaluate(() => {
    const c = document.getElementById('stage'), r = c.getBoundingClientRect();
    return { left: r.left + c.clientLeft, top: r.top + c.clientTop, cssW: c.clientWidth, cssH: c.clientHeight, w: c.width, h: c.height };
  });
  const geo = await canvasBox();
  // The canvas must not move while the pointer is on it (a pin would jump by as much).
  const canvasStill = async (when) => {
    const g = await canvasBox();
    check(`the canvas stays where it was ${when}`, g.left === geo.left && g.top === geo.top,
      `at (${g.left}, ${g.top}), was (${geo.left}, ${geo.top})`);
  };
  const css = [geo.cssW / geo.w, geo.cssH / geo.h];
  const box = {
    toScreen: (p) => [geo.left + p[0] * st.scale * css[0], geo.top + p[1] * st.scale * css[1]],
    toFrame: (s) => [(s[0] - geo.left) / (st.scale * css[0]), (s[1] - geo.top) / (st.scale * css[1])],
  };
  must('loaded', st.session && st.vertices && st.fitted && st.vertices.length === P.vertex_count,
    `${P.width}×${P.height} puppet, layers ${P.layers.map((l) => `${l.name} (${l.kind})`).join(', ')}; ${P.vertex_count} vertices; scale ${st.scale}; canvas ${geo.w}×${geo.h} at (${geo.left}, ${geo.top})`);
  check('no error shown after loading', (await errorText()) === '', JSON.stringify(await errorText()));
  console.log(`  screenshot ${await shot('loaded.png')}`);

  // 1. Pin the hand and drag it.
  for (const [name, id] of [['ALPHA_REG', '#alphareg'], ['ALPHA_JOINTS', '#alphajoints']]) {
    if (env[name] !== undefined) await setInput(page, id.slice(1), env[name]);
  }
  const alphas = await page.evaluate(() => ['alphareg', 'alphajoints'].map((id) => document.getElementById(id).value));
  const hand = pickHand(st, box);
  const dragFrame = dragUnit === 'screen' ? dragPx / st.scale : dragPx;
  const dragScreen = dragFrame * st.scale;
  console.log(`  hand: layer ${hand.layer} vertex ${hand.vertex} at ${pt(hand.at)}, farthest from its joint ${pt(hand.joint)} (${hand.jointFrom}); pressing at screen (${hand.screen.join(', ')}) = frame ${pt(hand.frame)}`);
  console.log(`  drag: ${f1(dragScreen)} screen px up = ${f2(dragFrame)} frame px (DRAG_UNIT ${dragUnit}, scale ${st.scale}) in ${dragMoves} moves, ${moveMs} ms apart; α1 ${alphas[0]}, α2 ${alphas[1]}`);
  await page.mouse.move(...hand.screen);
  await page.mouse.down();
  await idle('after pressing on the hand');
  st = await state();
  must('press on the hand makes a pin', st.pins.length === 1, `${st.pins.length} pins`);
  const pressOffset = dist(st.pins[0].to, hand.frame) * st.scale;
  check('the pin is where the pointer pressed (within 0.5 screen px)', pressOffset <= 0.5,
    `pin target ${pt(st.pins[0].to)} vs pointer ${pt(hand.frame)}: ${f2(pressOffset)} screen px off`);
  const requestsBefore = dragRequests;
  for (let k = 1; k <= dragMoves; k++) {
    await page.mouse.move(hand.screen[0], hand.screen[1] - dragScreen * k / dragMoves);
    if (moveMs > 0 && k < dragMoves) await sleep(moveMs);
  }
  await page.mouse.up();
  await idle('after the drag');
  st = await state();
  await canvasStill('after the drag');
  must('after the drag there is still one pin', st.pins.length === 1, `${st.pins.length} pins`);
  const pin = st.pins[0];
  check('the drag requests carry the page\'s α1 and α2', lastDrag && String(lastDrag.alpha_reg) === String(Number(alphas[0]))
    && String(lastDrag.alpha_joints) === String(Number(alphas[1])), `last request: alpha_reg ${lastDrag?.alpha_reg}, alpha_joints ${lastDrag?.alpha_joints}`);
  const target = box.toFrame([hand.screen[0], hand.screen[1] - dragScreen]);
  check('the pin\'s target is where the pointer let go (within 2 screen px)', dist(pin.to, target) * st.scale <= 2,
    `${pt(pin.to)} vs ${pt(target)}`);
  // Where the pinned point is now: its barycentric coordinates in the fitted pose, applied to the
  // vertices the page shows.
  const bound = hit(P, st.fitted, pin.from);
  must('the pin\'s point lies on the fitted character', bound, `from ${pt(pin.from)}`);
  const now = apply(st.vertices, bound);
  const pinError = dist(now, pin.to);
  const moved = dist(now, apply(st.fitted, bound));
  const handMoved = dist(st.vertices[P.layers.find((l) => l.name === hand.layer).offset + hand.vertex], hand.at);
  console.log(`  ${dragRequests - requestsBefore} drag requests for ${dragMoves} moves (the last settling on release); the pinned point moved ${f2(moved)} frame px toward a target ${f2(dist(apply(st.fitted, bound), pin.to))} away; the hand vertex moved ${f2(handMoved)}`);
  console.log(`PIN_ERROR ${pinError.toFixed(3)} frame px (server's pin_error ${st.pinError.map((e) => e.toFixed(3)).join(', ')})`);
  check(`pin ends within ${tolerance} frame px of its target`, pinError <= tolerance,
    `at ${pt(now)}, target ${pt(pin.to)}: ${f2(pinError)} frame px = ${f1(pinError * st.scale)} screen px`);
  check('the page\'s pin error agrees with the vertices', Math.abs(pinError - st.pinError[0]) < 0.05,
    `recomputed ${f2(pinError)}, server ${f2(st.pinError[0])}`);
  console.log(`  screenshot ${await shot('dragged.png')}`);

  // 2. Right-click the pin: it goes, and the pose returns to the fit.
  const pinScreen = box.toScreen(pin.to).map(Math.round);
  await page.mouse.click(...pinScreen, { button: 'right' });
  await idle('after removing the pin');
  st = await state();
  check('right-click removes the pin', st.pins.length === 0, `${st.pins.length} pins after a right-click at screen (${pinScreen.join(', ')})`);
  const dragged = JSON.stringify(st.vertices);
  check('the pose stays where the pin left it', dragged !== JSON.stringify(st.fitted));
  console.log(`  screenshot ${await shot('removed.png')}`);
  await page.click('#undo');
  await idle('after undo');
  st = await state();
  check('undo brings the pin back', st.pins.length === 1 && st.future === 1, `${st.pins.length} pins`);
  await page.click('#redo');
  await idle('after redo');
  st = await state();
  check('redo removes it again', st.pins.length === 0 && JSON.stringify(st.vertices) === dragged);
  await page.click('#reset');
  await idle('after reset');
  st = await state();
  const offFit = Math.max(...st.vertices.map((v, i) => dist(v, st.fitted[i])));
  check('reset returns to the fit', st.pins.length === 0 && offFit < 1e-3, `farthest vertex ${offFit.toExponential(2)} frame px from the fit`);

  // 3. A click off the character pins nothing and says why.
  const offFrame = [[1, 1], [P.width - 1, 1], [1, P.height - 1], [P.width - 1, P.height - 1]]
    .map((p) => box.toFrame(box.toScreen(p).map(Math.round))).find((p) => !hit(P, st.vertices, p));
  must('a point off the character on the canvas', offFrame, offFrame ? `frame ${pt(offFrame)}` : 'every canvas corner is on the character');
  const offScreen = box.toScreen(offFrame).map(Math.round);
  await page.mouse.click(...offScreen);
  await idle('after clicking off the character');
  st = await state();
  const said = await errorText();
  check('a click off the character pins nothing', st.pins.length === 0, `${st.pins.length} pins`);
  check('and #error says it is not on the character', /not on the character/.test(said), JSON.stringify(said));

  // 4–6. Later steps.
  const tools = { page, state, idle, box, check, must, shot, hand, dragScreen };
  for (const [name, step] of [['in-between', playInbetween], ['appearance', appearanceStage], ['accessory toggle', toggleAccessory],
    ['PNG export', exportPng], ['what to draw next', drawNext], ['motion', playMotion], ['two pages', twoPages]]) {
    const skipped = await step(tools);
    if (skipped) console.log(`SKIP ${name}: ${skipped}`);
  }

  const measures = await page.evaluate(() => performance.getEntriesByName('drag-move').map((m) => m.duration));
  if (measures.length) {
    const s = measures.slice().sort((x, y) => x - y);
    console.log(`  drag-move latency (information): ${s.length} moves, median ${f1(s[s.length >> 1])} ms, max ${f1(s[s.length - 1])} ms`);
  }
  check('no uncaught error on the page', pageErrors.length === 0, pageErrors.join(' | '));
} catch (e) {
  failed++;
  console.log(`FAIL ${e instanceof Stop ? e.message : `the run stopped: ${e.stack || e}`}`);
  try { console.log(`  screenshot ${await shot('failure.png')}`); } catch { /* the page is gone */ }
} finally {
  await browser.close();
}
console.log(failed ? `${failed} check(s) failed` : 'all checks passed');
process.exit(failed ? 1 : 0);
