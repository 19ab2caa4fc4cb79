#!/usr/bin/env bash
# Installs the JavaScript consumers the tests check exports with (Khronos' gltf-validator,
# three.js) into tools/js/node_modules (untracked), at the versions tools/js/package.json
# pins. Needs node and npm (Debian: nodejs npm); without them, or offline, it says so and
# the tests that need them skip.
set -uo pipefail
here=$(cd "$(dirname "$0")/../tools/js" && pwd)
if ! command -v npm >/dev/null; then
  echo "install-js-tools: npm not found; glTF validation and three.js tests will skip" >&2
  exit 0
fi
if [ -d "$here/node_modules/gltf-validator" ] && [ -d "$here/node_modules/three" ]; then
  exit 0
fi
echo "install-js-tools: npm install in $here" >&2
(cd "$here" && npm install --no-audit --no-fund --loglevel=error) ||
  echo "install-js-tools: npm install failed; glTF validation and three.js tests will skip" >&2
exit 0
