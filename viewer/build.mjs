// Builds the page's bundle: src/main.js with three.js, three-vrm and three-vrm-animation (pinned in
// package-lock.json) into one minified file, sgt_tui/view/static/viewer.js, and the licences of
// every package in it into sgt_tui/view/static/viewer.LICENSES.txt.
//
//   cd viewer && npm ci && npm run build
//
// The bundle's first line names the packages and their versions and the SHA-256 of the sources it
// was built from (src/*.js, package-lock.json): tests/test_view.py checks it against the checkout,
// so a change to the sources without a rebuild fails the tests.

import { build } from 'esbuild';
import { createHash } from 'node:crypto';
import { readFileSync, readdirSync, writeFileSync, existsSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const out = join(here, '..', 'sgt_tui', 'view', 'static');

// The sources' digest: every file of src/ (sorted by name) and package-lock.json, each as
// "name\0" + contents + "\0" (tests/test_view.py computes the same).
export function sourcesDigest() {
  const h = createHash('sha256');
  const files = readdirSync(join(here, 'src')).filter((f) => f.endsWith('.js')).sort().map((f) => `src/${f}`);
  for (const f of [...files, 'package-lock.json']) {
    h.update(`${f}\0`);
    h.update(readFileSync(join(here, f)));
    h.update('\0');
  }
  return h.digest('hex');
}

const result = await build({
  entryPoints: [join(here, 'src', 'main.js')],
  bundle: true,
  minify: true,
  format: 'iife',
  target: ['es2020'],
  legalComments: 'external', // collected apart, into viewer.LICENSES.txt with the packages' licences
  outfile: join(out, 'viewer.js'),
  metafile: true,
  write: false,
  logLevel: 'warning',
});

// the packages in the bundle, from the files esbuild read
const packages = new Map();
for (const input of Object.keys(result.metafile.inputs)) {
  const m = /node_modules\/((?:@[^/]+\/)?[^/]+)\//.exec(input);
  if (!m || packages.has(m[1])) continue;
  const dir = join(here, 'node_modules', m[1]);
  const meta = JSON.parse(readFileSync(join(dir, 'package.json'), 'utf8'));
  const licence = ['LICENSE', 'LICENSE.md', 'LICENSE.txt', 'license'].map((f) => join(dir, f)).find(existsSync);
  packages.set(m[1], { version: meta.version, license: meta.license, text: licence ? readFileSync(licence, 'utf8').trim() : '' });
}
const names = [...packages.keys()].sort();
const list = names.map((n) => `${n}@${packages.get(n).version} (${packages.get(n).license})`).join(', ');
const banner = `/*! sgt view bundle: ${list}; licences in viewer.LICENSES.txt; built by viewer/build.mjs from sources sha256 ${sourcesDigest()} */\n`;
const js = result.outputFiles.find((f) => f.path.endsWith('.js')).text;
const legal = result.outputFiles.find((f) => f.path.endsWith('.LEGAL.txt'));
writeFileSync(join(out, 'viewer.js'), banner + js);

const notices = [
  'The page of `sgt view` (sgt_tui/view/static/viewer.js) bundles these packages, built from the npm',
  'registry by viewer/build.mjs (cd viewer && npm ci && npm run build). Their licences follow.',
  '',
];
for (const n of names) {
  const p = packages.get(n);
  notices.push('='.repeat(78), `${n} ${p.version} (${p.license})`, '='.repeat(78), '', p.text || `(no licence file; package.json says ${p.license})`, '');
}
if (legal) notices.push('='.repeat(78), 'Notices kept from the bundled sources (their /*! ... */ comments)', '='.repeat(78), '', legal.text.trim(), '');
writeFileSync(join(out, 'viewer.LICENSES.txt'), notices.join('\n'));
console.log(`wrote ${join(out, 'viewer.js')}: ${(banner.length + js.length) / 1024 | 0} KiB; ${list}`);
