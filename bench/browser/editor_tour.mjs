// Screenshots of the web editor on a running `puppet serve` (the demo's model, with its
// outfits): the loaded page, a dragged arm, another outfit with the rig's pins shown, and an
// in-between with onion skin. For eyes, not checks: tests/browser/editor.mjs holds the checks.
//
//   node editor_tour.mjs URL OUT_DIR
import path from 'node:path';
import fs from 'node:fs';
import { chromium } from 'playwright-core';

const [url, out] = process.argv.slice(2);
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
await browser.close();
