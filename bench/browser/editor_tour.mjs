// Screenshots of the web editor on a running `puppet serve` (the demo's model, with its
// outfits): the loaded page, a dragged arm, another outfit with the rig's pins shown, an
// in-between with onion skin, "what to draw next" with the first suggestion posed, and a BVH walk
// played on the character (the motion's panel alone beside the canvas, in these two). For eyes,
// not checks: tests/browser/editor.mjs holds the checks.
//
//   node editor_tour.mjs URL OUT_DIR [MOTION]   (MOTION: default data/motion/walk.bvh)
import path from 'node:path';
import fs from 'node:fs';
import { chromium } from 'playwright-core';

const [url, out, motion = 'data/motion/walk.bvh'] = process.argv.slice(2);
if (!url || !out) { console.error('usage: node editor_tour.mjs URL OUT_DIR'); process.exit(2); }
fs.mkdirSync(out, { recursive: true });
const browser = await chromium.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update', '--no-first-run'] });
const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
const idle = () => page.waitForFunction(() => window.puppetEditor && !window.puppetEditor.busy(), null, { timeout: 120000, polling: 20 });
const shot = async (name) => { await page.screenshot({ path: path.join(out, name) }); console.log(path.join(out, name)); };
const state = () => page.evaluate(() => window.puppetEditor.state());
await page.goto(url);
await idle();
await shot('editor_loaded.png');
// Drag the front arm's far end up by 60 screen px.
let st = await state();
const layers = st.puppet.outfits[st.outfit].layers;
const arm = layers.filter((l) => l.kind === 'body' && /arm/.test(l.name)).pop() || layers[layers.length - 1];
const vs = arm.rest.map((_, i) => st.fitted[arm.offset + i]);
const lowest = vs.reduce((a, b) => (b[1] > a[1] ? b : a));
const c = vs.reduce((a, b) => [a[0] + b[0] / vs.length, a[1] + b[1] / vs.length], [0, 0]);
const p = [lowest[0] + (c[0] - lowest[0]) * 0.15, lowest[1] + (c[1] - lowest[1]) * 0.15];
const box = await page.evaluate(() => { const r = document.getElementById('stage').getBoundingClientRect(); return [r.left, r.top]; });
const s = [box[0] + p[0] * st.scale, box[1] + p[1] * st.scale];
await page.mouse.move(...s); await page.mouse.down();
for (let k = 1; k <= 12; k++) { await page.mouse.move(s[0] - 3 * k, s[1] - 5 * k); await new Promise((r) => setTimeout(r, 16)); }
await page.mouse.up(); await idle();
st = await state();
console.log(`pin error after the drag: ${st.pinError.map((e) => e.toFixed(2)).join(', ')} px`);
await shot('editor_dragged.png');
const outfits = st.puppet.outfits.length;
if (outfits > 1) {
  await page.selectOption('#outfit', String(outfits - 1)); await idle();
  await page.check('#showpins');
  await shot('editor_outfit_pins.png');
}
await page.selectOption('#ib-easing', 'ease-in-out');
await page.fill('#ib-count', '6');
await page.evaluate(() => { document.getElementById('ib-from').value = '0'; document.getElementById('ib-to').value = String(Math.min(4, window.puppetEditor.state().puppet ? 4 : 1)); });
await page.click('#ib-make');
await page.waitForFunction(() => window.puppetEditor.state().inbetween, null, { timeout: 60000 });
await page.evaluate(() => { const e = document.getElementById('ib-scrub'); e.value = 3; e.dispatchEvent(new Event('input')); });
await shot('editor_inbetween.png');
await page.click('#ib-close');

// The canvas and the side panels `keep` (ids), the others hidden for the shot.
const panelShot = async (name, keep) => {
  await page.evaluate((keep) => { for (const f of document.querySelectorAll('#side fieldset')) f.style.display = keep.includes(f.id) ? '' : 'none'; }, keep);
  const clip = await page.evaluate(() => {
    const rects = ['view', 'side'].map((id) => document.getElementById(id).getBoundingClientRect());
    const [x, y] = [Math.min(...rects.map((r) => r.left)), Math.min(...rects.map((r) => r.top))];
    const [right, bottom] = [Math.max(...rects.map((r) => r.right)), Math.max(...rects.map((r) => r.bottom))];
    return { x: x + window.scrollX - 6, y: y + window.scrollY - 6, width: right - x + 12, height: bottom - y + 12 };
  });
  await page.screenshot({ path: path.join(out, name), clip, fullPage: true });
  await page.evaluate(() => { for (const f of document.querySelectorAll('#side fieldset')) f.style.display = ''; });
  console.log(path.join(out, name));
};
if (outfits > 1) { await page.selectOption('#outfit', '0'); await idle(); }
await page.uncheck('#showpins');
await page.click('#next-suggest');
await page.waitForFunction(() => window.puppetEditor.state().next.suggestions.length > 0, null, { timeout: 120000 });
await idle();
await page.waitForFunction(() => [...document.querySelectorAll('#suggestions img')].every((im) => im.complete && im.naturalWidth > 0));
console.log(await page.locator('#status').textContent());
await page.locator('#suggestions .suggestion button').first().click();
await panelShot('editor_suggest.png', ['nextpanel']);
await page.locator('#suggestions .suggestion button').first().click();
await page.selectOption('#motion-view', 'side');
await page.setInputFiles('#motion-file', motion);
await page.waitForFunction(() => window.puppetEditor.state().inbetween?.kind === 'motion', null, { timeout: 60000 });
console.log(await page.locator('#motion-info').textContent());
await page.click('#motion-play');
await page.evaluate(() => { const e = document.getElementById('ib-scrub'); e.value = 8; e.dispatchEvent(new Event('input')); });
await panelShot('editor_motion.png', ['motionpanel']);
await browser.close();
