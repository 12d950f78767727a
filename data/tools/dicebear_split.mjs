// Splits DiceBear avatars into layered characters for the accessory rig (data/README.md,
// "DiceBear characters"): one full-canvas straight-alpha PNG per component, a character.toml in
// the layer-PNG form (the skin of the head, and the torso where the style draws one, are body
// layers; everything else is an accessory), and rig_truth.json naming each accessory's parent.
//
//   cd data/tools && npm ci
//   node dicebear_split.mjs ../rigs/dicebear            # 6 seeds × 3 styles at 256²
//   node dicebear_split.mjs ../../benches/data --size 640 --only notionists:puppet-1 --name dicebear-640
//
// Only these three styles are used: notionists (CC0 1.0), personas and big-smile (CC BY 4.0).
// A style draws its components as <g transform="translate(…)"> (or matrix) groups in a fixed order inside
// the avatar's viewbox mask; that order is read from the style's own template, so each group is
// named by its component. Drawing outside the components (personas' head) is the "head" layer.

import { mkdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { createAvatar } from '@dicebear/core';
import * as notionists from '@dicebear/notionists';
import * as personas from '@dicebear/personas';
import * as bigSmile from '@dicebear/big-smile';
import { Resvg } from '@resvg/resvg-js';

// Per style: its module, what each component is called as a layer, which are body layers, and
// the true parent of each accessory (accessories left out are not judged: notionists' gesture
// is a hand that may rest on the torso or the face).
const STYLES = {
  notionists: {
    style: notionists,
    rename: { base: 'head', body: 'torso' },
    body: ['head', 'torso'],
    root: 'head',
    parents: { hair: 'head', lips: 'head', beard: 'head', nose: 'head', eyes: 'head', glasses: 'head', brows: 'head' },
  },
  personas: {
    style: personas,
    rename: { body: 'torso' },
    body: ['head', 'torso'],
    root: 'head',
    parents: { eyes: 'head', hair: 'head', mouth: 'head', nose: 'head', facialHair: 'head' },
  },
  'big-smile': {
    style: bigSmile,
    rename: { face: 'head' },
    body: ['head'],
    root: 'head',
    parents: { mouth: 'head', eyes: 'head', hair: 'head', accessories: 'head' },
  },
};

const SEEDS = ['puppet-1', 'puppet-2', 'puppet-3', 'puppet-4', 'puppet-5', 'puppet-6'];

/** The component names of a style, in the order its template draws them. */
function componentOrder(style) {
  const source = style.create.toString();
  const body = source.slice(source.indexOf('body:'));
  return [...new Set([...body.matchAll(/components\.(\w+)\)/g)].map((m) => m[1]))];
}

/** The top-level children of the element whose content starts at `start` in `svg`. */
function children(svg, start) {
  const out = [];
  let depth = 0;
  let begin = -1;
  const tag = /<(\/?)([a-zA-Z]+)[^>]*?(\/?)>/g;
  tag.lastIndex = start;
  for (let m; (m = tag.exec(svg)); ) {
    const [text, closing, , selfClosing] = m;
    if (!closing && depth === 0) begin = m.index;
    if (closing) {
      if (depth === 0) return out; // the parent's own end tag
      depth -= 1;
      if (depth === 0) out.push(svg.slice(begin, m.index + text.length));
    } else if (selfClosing) {
      if (depth === 0) out.push(text);
    } else {
      depth += 1;
    }
  }
  throw new Error('unbalanced SVG');
}

/** The avatar's layers: [name, svg markup of that layer alone]. */
function layersOf(svg, order) {
  const open = '<g mask="url(#viewboxMask)">';
  const at = svg.indexOf(open);
  if (at < 0) throw new Error('no viewbox mask group');
  const head = svg.slice(0, at + open.length);
  const parts = children(svg, at + open.length);
  const defs = parts.filter((p) => /^<(mask|defs|clipPath|linearGradient|radialGradient)\b/.test(p));
  const drawn = parts.filter((p) => !defs.includes(p));
  const layers = [];
  const loose = [];
  let k = 0;
  for (const part of drawn) {
    if (/^<g transform="(translate|matrix)\(/.test(part) && k < order.length) {
      layers.push([order[k], part]);
      k += 1;
    } else {
      loose.push(part);
    }
  }
  if (loose.length) layers.unshift(['head', loose.join('')]);
  return layers.map(([name, part]) => [name, `${head}${defs.join('')}${part}</g></svg>`]);
}

function render(svg, size) {
  const image = new Resvg(svg, { fitTo: { mode: 'width', value: size } }).render();
  const pixels = image.pixels;
  const alpha = new Uint8Array(pixels.length / 4);
  let covered = 0;
  for (let i = 0; i < alpha.length; i += 1) {
    alpha[i] = pixels[4 * i + 3] > 127 ? 1 : 0;
    covered += alpha[i];
  }
  return { png: image.asPng(), covered, alpha };
}

/** Whether two coverage masks share at least 16 pixels. */
function overlaps(a, b) {
  let shared = 0;
  for (let i = 0; i < a.length; i += 1) shared += a[i] & b[i];
  return shared >= 16;
}

function writeCharacter(dir, styleName, seed, size, name) {
  const spec = STYLES[styleName];
  const svg = createAvatar(spec.style, { seed }).toString();
  const order = componentOrder(spec.style);
  const out = join(dir, name);
  mkdirSync(out, { recursive: true });
  const toml = [
    `# DiceBear ${styleName} (seed ${JSON.stringify(seed)}), split by data/tools/dicebear_split.mjs; see data/README.md.`,
    `name = ${JSON.stringify(name)}`,
    `root = ${JSON.stringify(spec.root)}`,
  ];
  const body = [];
  const layers = [];
  const coverage = {};
  for (const [component, markup] of layersOf(svg, order)) {
    const layer = spec.rename[component] ?? component;
    const { png, covered, alpha } = render(markup, size);
    coverage[layer] = alpha;
    // Specks of a few pixels are not layers a person would draw or rig.
    if (covered < 8) continue;
    writeFileSync(join(out, `${layer}.png`), png);
    const kind = spec.body.includes(layer) ? 'body' : 'accessory';
    if (kind === 'body') body.push(layer);
    layers.push(['[[layer]]', `name = ${JSON.stringify(layer)}`, `file = "${layer}.png"`, `kind = "${kind}"`, '']);
  }
  // Joints between body layers only, where they overlap (a personas head may only touch its
  // torso): the rig attaches the accessories.
  const joints = [];
  for (let i = 0; i < body.length; i += 1) {
    for (let j = i + 1; j < body.length; j += 1) {
      if (overlaps(coverage[body[i]], coverage[body[j]])) joints.push([body[i], body[j]]);
    }
  }
  toml.push(`joints = ${JSON.stringify(joints)}`);
  toml.push('', ...layers.flat());
  writeFileSync(join(out, 'character.toml'), toml.join('\n'));
  const written = layers.map((l) => JSON.parse(l[1].slice('name = '.length)));
  const truth = Object.fromEntries(Object.entries(spec.parents).filter(([child]) => written.includes(child)));
  writeFileSync(join(out, 'rig_truth.json'), JSON.stringify({ attach_to: truth }, null, 2) + '\n');
  return { name, layers: written };
}

function main() {
  const args = process.argv.slice(2);
  const dir = args[0];
  if (!dir) throw new Error('usage: node dicebear_split.mjs OUT_DIR [--size N] [--only style:seed] [--name NAME]');
  const option = (key) => {
    const i = args.indexOf(key);
    return i >= 0 ? args[i + 1] : undefined;
  };
  const size = Number(option('--size') ?? 256);
  const only = option('--only');
  const jobs = only
    ? [only.split(':')]
    : Object.keys(STYLES).flatMap((style) => SEEDS.map((seed) => [style, seed]));
  for (const [style, seed] of jobs) {
    const name = option('--name') ?? `${style}-${seed.replace('puppet-', '')}`;
    const { layers } = writeCharacter(dir, style, seed, size, name);
    console.log(`${name}: ${layers.join(', ')}`);
  }
}

main();
