// node validate_gltf.mjs FILE...: Khronos' glTF validator on each file; prints every
// issue and exits 1 if any file has an error.
import { readFileSync } from 'node:fs';
import { createRequire } from 'node:module';
const require = createRequire(process.env.LIGHTPROBE_JS + '/');
const validator = require('gltf-validator');
let failed = false;
for (const file of process.argv.slice(2)) {
  const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), { uri: file });
  const { numErrors, numWarnings } = report.issues;
  console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings (${report.info?.mimeType ?? '?'})`);
  for (const m of report.issues.messages) console.log(`  ${m.severity === 0 ? 'error' : 'note'} ${m.code}: ${m.message} ${m.pointer ?? ''}`);
  if (numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
