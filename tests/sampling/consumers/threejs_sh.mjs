// node threejs_sh.mjs LIGHTS.gltf SH_REPORT.json: three.js' own SphericalHarmonics3 reads
// the SH9 of the glTF (asset.extras.sh9, Y-up) and its getIrradianceAt, facing each axis,
// must give the irradiance lightprobe computed in its z-up frame (`sh --json`), to 1e-4 of
// the largest irradiance: three.js rounds its constants to 6 digits, and where SH9 rings
// close to 0 (facing away from a sun) a difference relative to the value itself means nothing.
import { readFileSync } from 'node:fs';
import { pathToFileURL } from 'node:url';
const { SphericalHarmonics3, Vector3 } = await import(pathToFileURL(process.env.LIGHTPROBE_JS + '/three/build/three.module.js'));
const gltf = JSON.parse(readFileSync(process.argv[2], 'utf8'));
const report = JSON.parse(readFileSync(process.argv[3], 'utf8'));
const sh = new SphericalHarmonics3().fromArray(gltf.asset.extras.sh9.coefficients.flat());
// Our (x, y, z) is (x, z, -y) in glTF's and three.js' Y-up world.
const yup = { '+x': [1, 0, 0], '-x': [-1, 0, 0], '+y': [0, 0, -1], '-y': [0, 0, 1], '+z': [0, 1, 0], '-z': [0, -1, 0] };
const scale = Math.max(...Object.values(report.irradiance_axes).flat().map(Math.abs));
let worst = 0;
for (const [axis, t] of Object.entries(yup)) {
  const e = sh.getIrradianceAt(new Vector3(...t), new Vector3());
  const ref = report.irradiance_axes[axis];
  const got = [e.x, e.y, e.z];
  for (let c = 0; c < 3; ++c) {
    const rel = Math.abs(got[c] - ref[c]) / scale;
    worst = Math.max(worst, rel);
    console.log(`${axis}[${c}]: three.js ${got[c]}, lightprobe ${ref[c]}, relative ${rel.toExponential(2)}`);
  }
}
console.log(`worst difference ${worst.toExponential(2)} of the largest irradiance ${scale}`);
process.exit(worst <= 1e-4 ? 0 : 1);
