import * as PIXI from './node_modules/pixi.js/dist/pixi.mjs';
import { CHECKER, checkerAt, pixelsOf, screenshotPixels, rgbaAt } from './common.js';

const PAD = 20;
const SCALE = 2;
const GAP = 40;
const report = { ready: false };
window.__report = report;

function fail(e) {
  report.error = String(e && e.stack ? e.stack : e);
  document.title = 'error';
  document.getElementById('state').textContent = report.error;
}

async function main() {
  const atlasUrl = new URL(location.href).searchParams.get('atlas');
  const preference = new URL(location.href).searchParams.get('renderer') || 'webgl';
  const sheet = await PIXI.Assets.load(atlasUrl);
  if (!(sheet instanceof PIXI.Spritesheet)) throw new Error(`Assets.load(${atlasUrl}) gave no Spritesheet`);
  const names = Object.keys(sheet.animations);
  if (names.length === 0) throw new Error('the atlas has no animations');
  const name = names[0];
  // Every page: this one and those its meta.related_multi_packs made PixiJS load with it. As
  // TexturePacker's multipack, the first page's `animations` names frames on all of them, so
  // frames are looked up by name across the pages (sheet.animations holds this page's only).
  const sheets = [sheet, ...sheet.linkedSheets];
  const byName = {};
  sheets.forEach((sh, page) => {
    sh.textureSource.scaleMode = 'nearest';
    for (const [n, t] of Object.entries(sh.textures)) byName[n] = { texture: t, page, data: sh.data.frames[n] };
  });
  const frameNames = sheet.data.animations[name];
  const missing = frameNames.filter((n) => !byName[n]);
  if (missing.length) throw new Error(`animation frames on no loaded page: ${missing.join(', ')}`);
  const textures = frameNames.map((n) => byName[n].texture);
  const durations = frameNames.map((n) => byName[n].data.duration);

  const pageW = sheet.textureSource.width;
  // A page taller than 512 px (a long animation's) is not shown.
  const showPage = sheet.textureSource.height <= 512;
  const pageH = showPage ? sheet.textureSource.height : -GAP;
  const cellW = textures[0].orig.width;
  const cellH = textures[0].orig.height;
  const width = Math.max(pageW, 2 * SCALE * cellW + GAP) + 2 * PAD;
  const height = PAD + pageH + GAP + SCALE * cellH + PAD;

  const app = new PIXI.Application();
  await app.init({ width, height, antialias: false, resolution: 1, preference, background: '#ffffff' });
  document.getElementById('stage').appendChild(app.canvas);

  const checker = new PIXI.Graphics();
  for (let y = 0; y < height; y += CHECKER.side) {
    for (let x = 0; x < width; x += CHECKER.side) {
      const [r, g, b] = checkerAt(x, y);
      checker.rect(x, y, CHECKER.side, CHECKER.side).fill((r << 16) | (g << 8) | b);
    }
  }
  app.stage.addChild(checker);

  if (showPage) {
    const page = new PIXI.Sprite(new PIXI.Texture({ source: sheet.textureSource }));
    page.position.set(PAD, PAD);
    app.stage.addChild(page);
  }
  const outline = new PIXI.Graphics();
  app.stage.addChild(outline);

  // A: the usual PixiJS way — the atlas's animation textures and one animationSpeed
  // (frames per 1/60 s tick) from the frames' duration (their mean, were they to differ).
  const meanMs = durations.reduce((s, d) => s + d, 0) / durations.length;
  const a = new PIXI.AnimatedSprite({ textures, animationSpeed: 1000 / 60 / meanMs, updateAnchor: true });
  // B: FrameObjects, each with its own duration in ms.
  const b = new PIXI.AnimatedSprite({
    textures: textures.map((texture, i) => ({ texture, time: durations[i] })),
    updateAnchor: true,
  });
  const row = PAD + pageH + GAP;
  const boxes = {};
  [[a, 'a', PAD], [b, 'b', PAD + SCALE * cellW + GAP]].forEach(([s, key, x]) => {
    s.scale.set(SCALE);
    s.position.set(x + s.anchor.x * SCALE * cellW, row + s.anchor.y * SCALE * cellH);
    boxes[key] = { x, y: row, w: SCALE * cellW, h: SCALE * cellH };
    app.stage.addChild(s);
  });

  const pageOf = new Map(Object.values(byName).map((v) => [v.texture, v.page]));
  const cellOf = (sprite) => {
    const f = sprite.texture.frame;
    return { page: pageOf.get(sprite.texture), x: f.x, y: f.y, w: f.width, h: f.height };
  };
  const drawOutline = () => {
    const c = cellOf(a);
    outline.clear();
    if (showPage && c.page === 0) outline.rect(PAD + c.x + 1, PAD + c.y + 1, c.w - 2, c.h - 2).stroke({ width: 2, color: 0xff2020 });
  };

  // When sprite A's frame changes, and how long since the last change (while playing).
  const changes = [];
  let last = null;
  a.onFrameChange = () => {
    const now = performance.now();
    if (last !== null) changes.push(now - last);
    last = now;
    drawOutline();
  };
  drawOutline();
  // ?start=N: begin at entry N of the animation (to see frames on a later page).
  const start = Number(new URL(location.href).searchParams.get('start') || 0);
  a.gotoAndPlay(start);
  b.gotoAndPlay(start);

  const base = new URL(atlasUrl, location.href);
  const sheetPixels = await Promise.all(sheets.map((sh) => pixelsOf(new URL(sh.data.meta.image, base).href)));

  Object.assign(report, {
    ready: true,
    pixi: PIXI.VERSION,
    renderer: app.renderer.name,
    atlas: atlasUrl,
    pages: sheets.map((sh) => ({ image: sh.data.meta.image, size: [sh.textureSource.width, sh.textureSource.height],
      resolution: sh.resolution, frames: Object.keys(sh.textures).length })),
    frameCount: Object.keys(byName).length,
    animations: names,
    animationLength: textures.length,
    ownAnimationTextures: sheet.animations[name].filter(Boolean).length,
    totalFrames: [a.totalFrames, b.totalFrames],
    textures: Object.fromEntries(Object.entries(byName).map(([n, { texture: t }]) => [n, {
      frame: [t.frame.x, t.frame.y, t.frame.width, t.frame.height],
      orig: [t.orig.width, t.orig.height],
      trim: t.trim ? [t.trim.x, t.trim.y, t.trim.width, t.trim.height] : null,
      anchor: t.defaultAnchor ? [t.defaultAnchor.x, t.defaultAnchor.y] : null,
    }])),
    durations,
    animationSpeed: a.animationSpeed,
    spriteAnchor: [a.anchor.x, a.anchor.y],
    playing: [a.playing, b.playing],
    boxes,
  });
  const show = (paused = null) => {
    document.getElementById('state').textContent =
      `PixiJS ${report.pixi} (${report.renderer}) · ${atlasUrl} (${sheets.length} page${sheets.length > 1 ? 's' : ''}) · ${report.frameCount} textures ` +
      `${cellW}×${cellH} · animation "${name}": ${textures.length} frames, durations ` +
      `${[...new Set(durations)].join('/')} ms → animationSpeed ${a.animationSpeed.toFixed(4)} · ` +
      `A frame ${a.currentFrame} (${frameNames[a.currentFrame]}), B frame ${b.currentFrame} ` +
      `(${frameNames[b.currentFrame]}) · ` +
      (paused ? `stopped for this screenshot, was playing ${paused.join('/')}` : `playing ${a.playing}/${b.playing}`);
  };
  show();
  document.title = 'ready';

  // Stops both sprites (so a screenshot shows the state reported), renders, reports.
  window.__snap = () => {
    const wasPlaying = [a.playing, b.playing];
    a.stop();
    b.stop();
    last = null;
    drawOutline();
    show(wasPlaying);
    app.render();
    const state = (s) => ({ currentFrame: s.currentFrame, name: frameNames[s.currentFrame], cell: cellOf(s) });
    return { wasPlaying, a: state(a), b: state(b), changesMs: changes.slice() };
  };
  window.__resume = () => {
    a.play();
    b.play();
  };

  // Which sheet cell each sprite's box on a screenshot shows: the mean |RGB| difference of the
  // box from every cell composited over the checkerboard at SCALE×; best is the smallest.
  window.__match = async (b64) => {
    const shot = await screenshotPixels(b64);
    const cells = [...new Set(frameNames)].map((n) => ({ name: n, ...cellOf({ texture: byName[n].texture }) }));
    const out = {};
    for (const [key, box] of Object.entries(boxes)) {
      const diffs = cells.map((c) => {
        let sum = 0;
        for (let dy = 0; dy < box.h; dy++) {
          for (let dx = 0; dx < box.w; dx++) {
            const sx = box.x + dx;
            const sy = box.y + dy;
            const src = rgbaAt(sheetPixels[c.page], c.x + Math.floor(dx / SCALE), c.y + Math.floor(dy / SCALE));
            const bg = checkerAt(sx, sy);
            const got = rgbaAt(shot, sx, sy);
            const al = src[3] / 255;
            for (let ch = 0; ch < 3; ch++) sum += Math.abs(got[ch] - (src[ch] * al + bg[ch] * (1 - al)));
          }
        }
        return { name: c.name, meanAbs: sum / (3 * box.w * box.h) };
      });
      const best = diffs.reduce((m, d) => (d.meanAbs < m.meanAbs ? d : m));
      const sorted = diffs.map((d) => d.meanAbs).sort((x, y) => x - y);
      out[key] = { best: best.name, bestMeanAbs: best.meanAbs, secondMeanAbs: sorted[1] };
    }
    // A point of the checkerboard beside sprite A (inside the canvas, outside every sprite).
    const bx = boxes.b.x + boxes.b.w + 8;
    const by = boxes.b.y + 8;
    out.checkerPoint = { at: [bx, by], got: rgbaAt(shot, bx, by), expected: checkerAt(bx, by) };
    return out;
  };
}

main().catch(fail);
