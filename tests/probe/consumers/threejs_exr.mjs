// three.js' EXRLoader on a map lightprobe wrote (what a web viewer of `stream`'s /probe.exr
// does): it decodes without a warning, its lightprobe.world_from_probe attribute holds the
// rotation `info` reports, its alpha is the validity mask, and the valid pixels' mean and
// largest luminance are lightprobe's own (float32 data, 1e-6 relative).
// Usage: node threejs_exr.mjs MAP.exr INFO.json   (INFO: `lightprobe info --json MAP.exr`)
import { readFileSync } from 'fs';
import { join } from 'path';

const js = process.env.LIGHTPROBE_JS;
const THREE = await import(join(js, 'three/build/three.module.js'));
const { EXRLoader } = await import(join(js, 'three/examples/jsm/loaders/EXRLoader.js'));

const fail = (msg) => { console.error('FAILED: ' + msg); process.exit(1); };
const warnings = [];
console.warn = (...args) => warnings.push(args.join(' '));

const bytes = readFileSync(process.argv[2]);
const info = JSON.parse(readFileSync(process.argv[3], 'utf8'));
const loader = new EXRLoader();
loader.setDataType(THREE.FloatType);
const map = loader.parse(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
if (warnings.length) fail('EXRLoader warned: ' + warnings.join('; '));
if (map.width !== info.width || map.height !== info.height)
  fail(`size ${map.width}x${map.height}, lightprobe says ${info.width}x${info.height}`);

const recorded = String(map.header['lightprobe.world_from_probe'] ?? '').trim().split(/\s+/).map(Number);
if (recorded.length !== 9 || recorded.some((v, k) => Math.abs(v - info.world_from_probe[k]) > 1e-15))
  fail(`lightprobe.world_from_probe '${map.header['lightprobe.world_from_probe']}' is not ${info.world_from_probe}`);

// RGBA floats, alpha 1 valid, 0 invalid. three.js flips rows (setDataType does not matter
// for that): only whole-map statistics are compared.
let n = 0, sum = 0, max = 0;
for (let i = 0; i < map.width * map.height; ++i) {
  const a = map.data[4 * i + 3];
  if (a !== 0 && a !== 1) fail(`alpha ${a} at pixel ${i}: not a mask`);
  if (a === 0) continue;
  const y = 0.2126 * map.data[4 * i] + 0.7152 * map.data[4 * i + 1] + 0.0722 * map.data[4 * i + 2];
  ++n; sum += y; max = Math.max(max, y);
}
const valid = n / (map.width * map.height);
if (Math.abs(valid - info.valid_fraction) > 1e-12) fail(`valid fraction ${valid}, lightprobe says ${info.valid_fraction}`);
const rel = (a, b) => Math.abs(a - b) / Math.max(Math.abs(b), 1e-30);
if (rel(sum / n, info.luminance.mean) > 1e-6) fail(`mean luminance ${sum / n}, lightprobe says ${info.luminance.mean}`);
if (rel(max, info.luminance.max) > 1e-6) fail(`largest luminance ${max}, lightprobe says ${info.luminance.max}`);
console.log(`three.js reads ${process.argv[2]}: ${map.width}x${map.height}, ${n} valid pixels, mean luminance ` +
            `${(sum / n).toPrecision(7)}, the probe rotation as recorded, no warning`);
