import { checkerAt, checkerTile, screenshotPixels, rgbaAt, rgbDiff } from './common.js';

const report = { ready: false };
window.__report = report;
const PAD = 16;
const TOP = 40;
const GAP = 24;

function fail(e) {
  report.error = String(e && e.stack ? e.stack : e);
  document.title = 'error';
  document.body.append(report.error);
}

/** Every frame of an animated image, decoded by Chromium (WebCodecs ImageDecoder). */
async function decodeAll(url) {
  const bytes = await (await fetch(url)).arrayBuffer();
  const type = url.endsWith('.gif') ? 'image/gif' : 'image/png';
  if (!(await ImageDecoder.isTypeSupported(type))) throw new Error(`ImageDecoder does not take ${type}`);
  const decoder = new ImageDecoder({ data: bytes, type, premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
  await decoder.tracks.ready;
  await decoder.completed;
  const track = decoder.tracks.selectedTrack;
  const frames = [];
  for (let i = 0; i < track.frameCount; i++) {
    const { image } = await decoder.decode({ frameIndex: i });
    const w = image.displayWidth;
    const h = image.displayHeight;
    const c = new OffscreenCanvas(w, h);
    const g = c.getContext('2d');
    g.drawImage(image, 0, 0);
    frames.push({ durationMs: image.duration / 1000, img: g.getImageData(0, 0, w, h) });
    image.close();
  }
  return { type, animated: track.animated, repetitionCount: track.repetitionCount, frames };
}

/** Alpha statistics over all frames and the pixels that are background / character in every one. */
function analyse(dec) {
  const { width: w, height: h } = dec.frames[0].img;
  const alpha = { zero: 0, partial: 0, full: 0 };
  const everVisible = new Uint8Array(w * h);
  const alwaysOpaque = new Uint8Array(w * h).fill(1);
  for (const { img } of dec.frames) {
    for (let p = 0; p < w * h; p++) {
      const a = img.data[4 * p + 3];
      if (a === 0) alpha.zero++;
      else if (a === 255) alpha.full++;
      else alpha.partial++;
      if (a > 0) everVisible[p] = 1;
      if (a < 255) alwaysOpaque[p] = 0;
    }
  }
  // A pixel whose 5×5 neighbourhood is all in `mask`, nearest the centroid of `near`.
  const inner = (mask) => (x, y) => {
    for (let dy = -2; dy <= 2; dy++) {
      for (let dx = -2; dx <= 2; dx++) {
        const xx = x + dx;
        const yy = y + dy;
        if (xx < 0 || yy < 0 || xx >= w || yy >= h || !mask[yy * w + xx]) return false;
      }
    }
    return true;
  };
  let cx = 0;
  let cy = 0;
  let n = 0;
  let box = [w, h, -1, -1];
  for (let y = 0; y < h; y++) {
    for (let x = 0; x < w; x++) {
      if (everVisible[y * w + x]) {
        cx += x; cy += y; n++;
        box = [Math.min(box[0], x), Math.min(box[1], y), Math.max(box[2], x), Math.max(box[3], y)];
      }
    }
  }
  cx /= n || 1;
  cy /= n || 1;
  const nearest = (ok, x0, y0, x1, y1) => {
    let best = null;
    for (let y = y0; y <= y1; y++) {
      for (let x = x0; x <= x1; x++) {
        if (!ok(x, y)) continue;
        const d = (x - cx) ** 2 + (y - cy) ** 2;
        if (!best || d < best.d) best = { x, y, d };
      }
    }
    return best && [best.x, best.y];
  };
  const never = everVisible.map((v) => 1 - v);
  const alwaysTransparent = never.reduce((s, v) => s + v, 0);
  return {
    size: [w, h],
    alpha,
    alwaysTransparent,
    alwaysOpaque: alwaysOpaque.reduce((s, v) => s + v, 0),
    visibleBox: box,
    // Background inside the character's box (between limbs / beside the head), else anywhere.
    bgPoint: nearest(inner(never), box[0], box[1], box[2], box[3]) || nearest(inner(never), 0, 0, w - 1, h - 1),
    charPoint: nearest(inner(alwaysOpaque), 0, 0, w - 1, h - 1),
    never,
  };
}

/** GIF against APNG, frame by frame: where the GIF's edge pixels get their colour from. */
function compareGifToApng(gif, apng) {
  const n = Math.min(gif.frames.length, apng.frames.length);
  const out = { framesCompared: n, edge: 0, edgeMeanMaxDiff: 0, edgeMeanLumaGifMinusApng: 0, edgeMeanApngAlpha: 0,
    interior: 0, interiorMeanMaxDiff: 0, gifOpaqueWhereApngAlphaBelowHalf: 0, gifClearWhereApngAlphaHalfOrMore: 0, bothOpaque: 0, offBy40: 0, maxDiff: 0 };
  const luma = (c) => 0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2];
  for (let k = 0; k < n; k++) {
    const G = gif.frames[k].img;
    const A = apng.frames[k].img;
    const { width: w, height: h } = G;
    for (let y = 0; y < h; y++) {
      for (let x = 0; x < w; x++) {
        const g = rgbaAt(G, x, y);
        const a = rgbaAt(A, x, y);
        if (g[3] === 255 && a[3] < 128) out.gifOpaqueWhereApngAlphaBelowHalf++;
        if (g[3] === 0 && a[3] >= 128) out.gifClearWhereApngAlphaHalfOrMore++;
        if (g[3] === 255 && a[3] === 255) {
          const d = rgbDiff(g, a);
          out.bothOpaque++;
          if (d > 40) out.offBy40++;
          out.maxDiff = Math.max(out.maxDiff, d);
        }
        if (g[3] !== 255 || a[3] === 0) continue;
        const edge = [[1, 0], [-1, 0], [0, 1], [0, -1]].some(([dx, dy]) => {
          const xx = x + dx;
          const yy = y + dy;
          return xx >= 0 && yy >= 0 && xx < w && yy < h && G.data[4 * (yy * w + xx) + 3] === 0;
        });
        if (edge) {
          out.edge++;
          out.edgeMeanMaxDiff += rgbDiff(g, a);
          out.edgeMeanLumaGifMinusApng += luma(g) - luma(a);
          out.edgeMeanApngAlpha += a[3];
        } else if (a[3] === 255) {
          out.interior++;
          out.interiorMeanMaxDiff += rgbDiff(g, a);
        }
      }
    }
  }
  for (const k of ['edgeMeanMaxDiff', 'edgeMeanLumaGifMinusApng', 'edgeMeanApngAlpha']) out[k] /= out.edge || 1;
  out.interiorMeanMaxDiff /= out.interior || 1;
  return out;
}

async function main() {
  const params = new URL(location.href).searchParams;
  const files = (params.get('files') || '').split(',').filter(Boolean);
  const scale = Number(params.get('scale') || 3);
  document.body.style.background = `url(${checkerTile()}) 0 0 repeat`;
  document.body.style.minHeight = '100vh';
  const items = [];
  let x = PAD;
  for (const url of files) {
    const dec = await decodeAll(url);
    const info = analyse(dec.frames.length ? dec : { frames: [] });
    const [w, h] = info.size;
    const fig = document.createElement('figure');
    fig.style.left = `${x}px`;
    fig.style.top = `${TOP}px`;
    const cap = document.createElement('figcaption');
    cap.textContent = `${url.split('/').pop()} ${scale}×`;
    const img = new Image(w * scale, h * scale);
    img.src = url;
    fig.append(cap, img);
    document.body.append(fig);
    await img.decode();
    items.push({ url, x, y: TOP, scale, dec, info });
    x += w * scale + GAP;
  }
  const gifVsApng = {};
  for (const it of items.filter((i) => i.url.endsWith('.gif'))) {
    const twin = items.find((i) => i.url === it.url.replace(/\.gif$/, '.apng'));
    if (twin) gifVsApng[it.url] = compareGifToApng(it.dec, twin.dec);
  }
  Object.assign(report, {
    ready: true,
    width: x - GAP + PAD,
    height: TOP + Math.max(...items.map((i) => i.info.size[1] * scale)) + PAD,
    files: items.map(({ url, x: ix, y, dec, info }) => ({
      url, box: [ix, y, info.size[0] * scale, info.size[1] * scale], type: dec.type, animated: dec.animated,
      repetitionCount: dec.repetitionCount, frames: dec.frames.length,
      durationsMs: [...new Set(dec.frames.map((f) => f.durationMs))],
      size: info.size, alpha: info.alpha, alwaysTransparent: info.alwaysTransparent, alwaysOpaque: info.alwaysOpaque,
      visibleBox: info.visibleBox, bgPoint: info.bgPoint, charPoint: info.charPoint,
    })),
    gifVsApng,
  });
  document.title = 'ready';

  // Reads a screenshot back at each image's background and character points, and at the centre
  // of every image pixel that is transparent in all frames (all must show the checkerboard).
  window.__check = async (b64) => {
    const shot = await screenshotPixels(b64);
    const at = (it, [px, py]) => [it.x + px * it.scale + (it.scale >> 1), it.y + py * it.scale + (it.scale >> 1)];
    return items.map((it) => {
      const [w, h] = it.info.size;
      let clear = 0;
      let showsChecker = 0;
      let worst = 0;
      for (let py = 0; py < h; py++) {
        for (let px = 0; px < w; px++) {
          if (!it.info.never[py * w + px]) continue;
          const [sx, sy] = at(it, [px, py]);
          const d = rgbDiff(rgbaAt(shot, sx, sy), checkerAt(sx, sy));
          clear++;
          if (d <= 2) showsChecker++;
          worst = Math.max(worst, d);
        }
      }
      const sample = (p) => {
        if (!p) return null;
        const [sx, sy] = at(it, p);
        const got = rgbaAt(shot, sx, sy);
        const checker = checkerAt(sx, sy);
        const frameColours = it.dec.frames.map((f) => rgbaAt(f.img, p[0], p[1]));
        return {
          imagePixel: p, pagePixel: [sx, sy], got: got.slice(0, 3), checker,
          diffFromChecker: rgbDiff(got, checker),
          diffFromWhite: rgbDiff(got, [255, 255, 255]),
          nearestFrameColourDiff: Math.min(...frameColours.map((c) => rgbDiff(got, c))),
        };
      };
      return {
        url: it.url,
        background: sample(it.info.bgPoint),
        corner: sample([0, 0]),
        character: sample(it.info.charPoint),
        transparentPixels: clear,
        transparentShowingChecker: showsChecker,
        transparentWorstDiff: worst,
      };
    });
  };
  // Pixels that differ between two screenshots inside each image's box (is it playing?).
  window.__changed = async (b64a, b64b) => {
    const [s, t] = [await screenshotPixels(b64a), await screenshotPixels(b64b)];
    return items.map((it) => {
      let changed = 0;
      const [w, h] = it.info.size;
      for (let y = it.y; y < it.y + h * it.scale; y++) {
        for (let x = it.x; x < it.x + w * it.scale; x++) {
          if (rgbDiff(rgbaAt(s, x, y), rgbaAt(t, x, y)) > 0) changed++;
        }
      }
      return { url: it.url, changedPixels: changed, of: w * h * it.scale * it.scale };
    });
  };
}

main().catch(fail);
