// Shared by sheet.js and alpha.js: the checkerboard both pages draw behind the animations, and
// pixel read-back of a screenshot (check.mjs hands the PNG back to the page, which decodes it).

/** Checkerboard squares: side in CSS px and the two colours (neither is white). */
export const CHECKER = { side: 12, light: [0xa0, 0xa0, 0xa0], dark: [0x50, 0x50, 0x50] };

/** The checkerboard's colour at page pixel (x, y). */
export function checkerAt(x, y) {
  const s = CHECKER.side;
  return (Math.floor(x / s) + Math.floor(y / s)) % 2 === 0 ? CHECKER.light : CHECKER.dark;
}

/** A 2·side square tile of the checkerboard as a data URL (pixel exact, for CSS backgrounds). */
export function checkerTile() {
  const s = CHECKER.side;
  const c = document.createElement('canvas');
  c.width = c.height = 2 * s;
  const g = c.getContext('2d');
  for (const [x, y] of [[0, 0], [s, 0], [0, s], [s, s]]) {
    g.fillStyle = `rgb(${checkerAt(x, y).join(',')})`;
    g.fillRect(x, y, s, s);
  }
  return c.toDataURL('image/png');
}

/** RGBA pixels of an image (URL or Blob) as { width, height, data } with straight alpha. */
export async function pixelsOf(source) {
  const blob = source instanceof Blob ? source : await (await fetch(source)).blob();
  const bitmap = await createImageBitmap(blob, { premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
  const c = new OffscreenCanvas(bitmap.width, bitmap.height);
  const g = c.getContext('2d');
  g.drawImage(bitmap, 0, 0);
  return g.getImageData(0, 0, bitmap.width, bitmap.height);
}

/** Decodes a base64 PNG (a Playwright screenshot). */
export async function screenshotPixels(b64) {
  const bytes = Uint8Array.from(atob(b64), (ch) => ch.charCodeAt(0));
  return pixelsOf(new Blob([bytes], { type: 'image/png' }));
}

/** The RGBA at (x, y) of an ImageData-like { width, data }. */
export function rgbaAt(img, x, y) {
  const i = 4 * (y * img.width + x);
  return [img.data[i], img.data[i + 1], img.data[i + 2], img.data[i + 3]];
}

/** Largest per-channel difference of two RGB(A) colours over their first three channels. */
export function rgbDiff(a, b) {
  return Math.max(Math.abs(a[0] - b[0]), Math.abs(a[1] - b[1]), Math.abs(a[2] - b[2]));
}
