// Opens puppet's outputs in headless Chromium: the sprite-sheet atlas in a PixiJS page
// (sheet.html) and the APNG/GIF animations over a checkerboard (alpha.html); takes screenshots
// and checks what the pages report against the files.
//
//   node check.mjs OUTPUT_DIR [SCREENS_DIR]
//
// OUTPUT_DIR is a `puppet demo` output folder (inbetween_walk_sprites.json/.png,
// inbetween_walk.apng/.gif, drag.apng/.gif). Prints one line per check; exits 1 if any fails.
import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const here = path.dirname(fileURLToPath(import.meta.url));
const outDir = path.resolve(process.argv[2] || '/tmp/browser-demo');
const screensDir = path.resolve(process.argv[3] || path.join(here, 'screens'));
// ATLAS: the atlas to play (default the demo's walk in-between); ANIMATIONS: the stems of the
// APNG/GIF pairs to show ('' for none); START: the animation entry the sprites start at.
const atlasName = process.env.ATLAS || 'inbetween_walk_sprites.json';
const animations = (process.env.ANIMATIONS ?? 'inbetween_walk,drag').split(',').filter(Boolean);
fs.mkdirSync(screensDir, { recursive: true });

// --- a static server: /out/… from OUTPUT_DIR, everything else from this folder -----------------
const types = { '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript', '.json': 'application/json',
  '.png': 'image/png', '.apng': 'image/apng', '.gif': 'image/gif', '.map': 'application/json' };
const server = http.createServer((req, res) => {
  const url = new URL(req.url, 'http://x');
  if (url.pathname === '/favicon.ico') {
    res.writeHead(204).end();
    return;
  }
  const [root, rel] = url.pathname.startsWith('/out/') ? [outDir, url.pathname.slice(5)] : [here, url.pathname.slice(1)];
  const file = path.resolve(root, decodeURIComponent(rel));
  if (!file.startsWith(root + path.sep) || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
    res.writeHead(404).end('not found');
    return;
  }
  res.writeHead(200, { 'content-type': types[path.extname(file)] || 'application/octet-stream', 'cache-control': 'no-store' });
  fs.createReadStream(file).pipe(res);
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const base = `http://127.0.0.1:${server.address().port}`;

// --- checks ------------------------------------------------------------------------------------
let failed = 0;
let passed = 0;
const results = { date: new Date().toISOString(), outDir, checks: [] };
function check(name, ok, detail) {
  const line = `${ok ? 'PASS' : 'FAIL'} ${name}${detail === undefined ? '' : `: ${typeof detail === 'string' ? detail : JSON.stringify(detail)}`}`;
  console.log(line);
  results.checks.push({ name, ok: !!ok, detail });
  if (ok) passed++; else failed++;
}
const same = (a, b) => JSON.stringify(a) === JSON.stringify(b);
const sleep = (ms) => new Promise((ok) => setTimeout(ok, ms));

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update',
    '--no-first-run', '--force-color-profile=srgb'],
});
console.log(`Chromium ${browser.version()} · serving ${outDir} at ${base}`);

async function open(urlPath, viewport) {
  const page = await browser.newPage({ viewport, deviceScaleFactor: 1 });
  page.on('console', (m) => { if (m.type() === 'error' || m.type() === 'warning') console.log(`  [page ${m.type()}] ${m.text()}`); });
  page.on('pageerror', (e) => console.log(`  [page error] ${e.message}`));
  await page.goto(base + urlPath);
  await page.waitForFunction(() => document.title !== 'loading', null, { timeout: 30000 });
  return page;
}

// --- 1. the sprite sheet in PixiJS -------------------------------------------------------------
{
  const readJson = (name) => JSON.parse(fs.readFileSync(path.join(outDir, name), 'utf8'));
  const json = readJson(atlasName);
  const pageJsons = [json, ...(json.meta.related_multi_packs || []).map(readJson)];
  const allFrames = Object.assign({}, ...pageJsons.map((j) => j.frames));
  const page = await open(`/sheet.html?atlas=/out/${atlasName}&start=${process.env.START || 0}`, { width: 1000, height: 520 });
  const r = await page.evaluate(() => window.__report);
  check('PixiJS loads the atlas as a Spritesheet', r.ready && !r.error, r.error || `PixiJS ${r.pixi}, renderer ${r.renderer}`);
  if (r.ready) {
    const animName = Object.keys(json.animations)[0];
    const list = json.animations[animName];
    check('pages', r.pages.length === pageJsons.length && r.pages.every((p, i) => p.image === pageJsons[i].meta.image
      && same(p.size, [pageJsons[i].meta.size.w, pageJsons[i].meta.size.h]) && p.resolution === Number(pageJsons[i].meta.scale)
      && p.frames === Object.keys(pageJsons[i].frames).length),
      r.pages.map((p, i) => `${p.image} ${p.size.join('×')} @${p.resolution}: ${p.frames} textures (JSON ${Object.keys(pageJsons[i].frames).length}, meta.size ${pageJsons[i].meta.size.w}×${pageJsons[i].meta.size.h})`).join('; '));
    check('frame count', r.frameCount === Object.keys(allFrames).length, `PixiJS ${r.frameCount} textures, JSON ${Object.keys(allFrames).length} frames`);
    check('animations', same(r.animations, Object.keys(json.animations)) && r.animationLength === list.length && same(r.totalFrames, [list.length, list.length]),
      `PixiJS ${JSON.stringify(r.animations)} ${r.animationLength} frames (AnimatedSprite totalFrames ${r.totalFrames}), JSON ${list.length}`);
    if (r.pages.length > 1) {
      check('first page\'s own animation textures (PixiJS sheet.animations; informational)', true,
        `${r.ownAnimationTextures} of ${r.animationLength} entries are on the first page`);
    }
    const bad = Object.entries(allFrames).filter(([n, f]) => {
      const t = r.textures[n];
      return !t || !same(t.frame, [f.frame.x, f.frame.y, f.frame.w, f.frame.h]) || !same(t.orig, [f.sourceSize.w, f.sourceSize.h])
        || !same(t.anchor, [f.anchor.x, f.anchor.y]);
    }).map(([n]) => n);
    const sizes = [...new Set(Object.values(r.textures).map((t) => `${t.frame[2]}×${t.frame[3]}`))];
    check('texture rectangles, source sizes and anchors', bad.length === 0,
      bad.length ? `differ: ${bad.join(', ')}` : `all ${r.frameCount} as in the JSON: sizes ${sizes.join(', ')}, anchor ${JSON.stringify(Object.values(r.textures)[0].anchor)}, trim ${Object.values(r.textures)[0].trim}`);
    const want = list.map((n) => allFrames[n].duration);
    const mean = want.reduce((s, d) => s + d, 0) / want.length;
    check('durations read', same(r.durations, want) && Math.abs(r.animationSpeed - 1000 / 60 / mean) < 1e-9,
      `${[...new Set(r.durations)].join('/')} ms for all ${r.durations.length} entries → animationSpeed ${r.animationSpeed.toFixed(5)} (1000/60/${mean})`);
    check('sprite anchor from the atlas', same(r.spriteAnchor, [allFrames[list[0]].anchor.x, allFrames[list[0]].anchor.y]), JSON.stringify(r.spriteAnchor));
    check('playing', r.playing.every(Boolean), `A ${r.playing[0]}, B ${r.playing[1]}`);

    const shown = new Set();
    let changes = [];
    for (const [i, waitMs] of [250, 450, 450].entries()) {
      await sleep(waitMs);
      const s = await page.evaluate(() => window.__snap());
      // The whole page for the first; the two sprites for the others (committed screenshots stay small).
      const file = path.join(screensDir, `sheet_${i + 1}.png`);
      const png = await page.screenshot();
      const clip = { x: 0, y: r.boxes.a.y - 12, width: r.boxes.b.x + r.boxes.b.w + 12, height: r.boxes.a.h + 24 };
      fs.writeFileSync(file, i === 0 ? png : await page.screenshot({ clip }));
      const m = await page.evaluate((b64) => window.__match(b64), png.toString('base64'));
      await page.evaluate(() => window.__resume());
      changes = s.changesMs;
      shown.add(m.a.best);
      check(`screenshot ${i + 1}: was playing, sprite A shows its frame`, s.wasPlaying.every(Boolean) && m.a.best === s.a.name && m.a.bestMeanAbs < 1,
        `A at ${s.a.currentFrame} (${s.a.name}); screen best matches ${m.a.best} (mean |ΔRGB| ${m.a.bestMeanAbs.toFixed(3)}, next ${m.a.secondMeanAbs.toFixed(2)}) → ${path.relative(process.cwd(), file)}`);
      check(`screenshot ${i + 1}: sprite B (FrameObjects) shows its frame`, m.b.best === s.b.name && m.b.bestMeanAbs < 1,
        `B at ${s.b.currentFrame} (${s.b.name}); screen best matches ${m.b.best} (mean |ΔRGB| ${m.b.bestMeanAbs.toFixed(3)})`);
      check(`screenshot ${i + 1}: checkerboard beside the sprites`, same(m.checkerPoint.got.slice(0, 3), m.checkerPoint.expected), m.checkerPoint);
    }
    check('screenshots show different frames', shown.size >= 2, [...shown].join(', '));
    // Wall-clock intervals between sprite A's frame changes. The median is the check (a busy
    // machine stalls requestAnimationFrame, and PixiJS's ticker counts at most 100 ms a tick);
    // it may be off by one 60 Hz display frame.
    const sorted = changes.slice().sort((x, y) => x - y);
    const median = sorted.length ? sorted[sorted.length >> 1] : NaN;
    const meanChange = changes.reduce((t, d) => t + d, 0) / (changes.length || 1);
    check('frame changes come at the atlas duration (median within max(25 %, 16.7 ms))',
      changes.length >= 5 && Math.abs(median - mean) <= Math.max(0.25 * mean, 1000 / 60),
      `${changes.length} changes of sprite A while playing: median ${median.toFixed(1)} ms, mean ${meanChange.toFixed(1)} (min ${sorted[0].toFixed(1)}, max ${sorted[sorted.length - 1].toFixed(1)}) vs ${mean} ms`);
  }
  await page.close();
}

// --- 2. APNG and GIF over a checkerboard -------------------------------------------------------
if (animations.length) {
  const files = animations.flatMap((a) => [`/out/${a}.apng`, `/out/${a}.gif`]);
  const page = await open(`/alpha.html?scale=3&files=${files.join(',')}`, { width: 1280, height: 460 });
  const r = await page.evaluate(() => window.__report);
  check('alpha page decodes every file', r.ready && !r.error, r.error || `${r.files.length} files`);
  if (r.ready) {
    await page.setViewportSize({ width: r.width, height: r.height });
    for (const f of r.files) {
      const gif = f.url.endsWith('.gif');
      const a = f.alpha;
      check(`${f.url}: animated, alpha kept`, f.animated && f.frames > 1 && a.zero > 0 && a.full > 0 && (gif ? a.partial === 0 : a.partial > 0),
        `${f.frames} frames of ${f.size.join('×')}, ${f.durationsMs.join('/')} ms, loop ${f.repetitionCount}; alpha over all frames: 0 ×${a.zero}, 1–254 ×${a.partial}, 255 ×${a.full}; transparent in every frame ${f.alwaysTransparent} px, opaque in every frame ${f.alwaysOpaque} px`);
    }
    for (const [url, g] of Object.entries(r.gifVsApng)) {
      const apng = r.files.find((f) => f.url === url.replace(/\.gif$/, '.apng'));
      const gf = r.files.find((f) => f.url === url);
      check(`${url}: same frames as the APNG`, gf.frames === apng.frames && same(gf.durationsMs, apng.durationsMs), `${gf.frames} vs ${apng.frames}`);
      check(`${url}: GIF palette (opaque in both, informational)`, true,
        `${g.bothOpaque} px: ${g.offBy40} off by more than 40 in a channel, worst ${g.maxDiff}`);
      check(`${url}: GIF alpha = APNG alpha ≥ ½`, g.gifOpaqueWhereApngAlphaBelowHalf === 0 && g.gifClearWhereApngAlphaHalfOrMore === 0,
        `opaque where APNG α<½: ${g.gifOpaqueWhereApngAlphaBelowHalf}, clear where α≥½: ${g.gifClearWhereApngAlphaHalfOrMore}`);
      check(`${url}: no halo on the GIF's edges`, g.edge > 0 && Math.abs(g.edgeMeanLumaGifMinusApng) < 12,
        g.edge === 0 ? 'the GIF has no transparent pixels, so no edges to judge' : `${g.edge} edge px (mean APNG α ${g.edgeMeanApngAlpha.toFixed(0)}): mean max|ΔRGB| vs APNG ${g.edgeMeanMaxDiff.toFixed(2)}, mean Δluma ${g.edgeMeanLumaGifMinusApng.toFixed(2)}; interior ${g.interior} px: mean max|ΔRGB| ${g.interiorMeanMaxDiff.toFixed(2)}`);
    }
    const shots = [];
    // Three times (a ping-pong shows the same picture at mirrored times, so two could match).
    for (const [i, waitMs] of [300, 450, 230].entries()) {
      await sleep(waitMs);
      const file = path.join(screensDir, 'alpha.png');
      const png = await page.screenshot();
      // Only the first is kept on disk (committed screenshots stay under 200 KB); the second
      // is compared with it to see the images play.
      if (i === 0) fs.writeFileSync(file, png);
      shots.push(png.toString('base64'));
      const rows = await page.evaluate((b64) => window.__check(b64), png.toString('base64'));
      if (i === 0) console.log(`  screenshot → ${path.relative(process.cwd(), file)}`);
      for (const row of rows) {
        const b = row.background;
        const c = row.character;
        const bgText = b ? `image px ${b.imagePixel} → page ${b.pagePixel}: ${b.got} (checker ${b.checker}); ` : 'no pixel is transparent in every frame; ';
        check(`screenshot ${i + 1} ${row.url}: background shows the checkerboard`, b && b.diffFromChecker <= 2 && row.corner.diffFromChecker <= 2
          && row.transparentShowingChecker === row.transparentPixels,
          `${bgText}corner px 0,0 → ${row.corner.got} (checker ${row.corner.checker}${row.corner.diffFromWhite === 0 ? ', i.e. WHITE' : ''}); `
          + `${row.transparentShowingChecker}/${row.transparentPixels} always-transparent px show the checker (worst Δ ${row.transparentWorstDiff})`);
        check(`screenshot ${i + 1} ${row.url}: character drawn`, c && c.diffFromChecker > 10 && c.nearestFrameColourDiff <= 2,
          c && `image px ${c.imagePixel} → page ${c.pagePixel}: ${c.got} (checker ${c.checker}; nearest frame colour Δ ${c.nearestFrameColourDiff})`);
      }
    }
    const pairs = [[0, 1], [1, 2], [0, 2]];
    const moved = await Promise.all(pairs.map(([x, y]) => page.evaluate(([s, t]) => window.__changed(s, t), [shots[x], shots[y]])));
    moved[0].forEach((m, f) => {
      const counts = moved.map((pair) => pair[f].changedPixels);
      check(`${m.url}: plays (pixels differ between screenshots)`, Math.max(...counts) > 0,
        `changed px between screenshots 1–2, 2–3, 1–3: ${counts.join(', ')} of ${m.of}`);
    });
  }
  await page.close();
}

await browser.close();
server.close();
fs.writeFileSync(path.join(screensDir, 'results.json'), `${JSON.stringify(results, null, 1)}\n`);
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
