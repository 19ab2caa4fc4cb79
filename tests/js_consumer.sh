# Sourced by the consumer tests that run JavaScript tools on node (three.js, Khronos' glTF
# validator, from npm: scripts/install-js-tools.sh). Sets LIGHTPROBE_JS (the node_modules
# the .mjs scripts import from), skip (exit 77, CTest's SKIP_RETURN_CODE) and fail, and
# skips when node or a package named in the arguments is missing; WORK is a scratch
# directory removed on exit.
#   . "$(dirname "$0")/../../js_consumer.sh" three gltf-validator
export LIGHTPROBE_JS=$(cd "$(dirname "${BASH_SOURCE[0]}")/../tools/js" && pwd)/node_modules
skip() { echo "SKIPPED: $*"; exit 77; }
fail() { echo "FAILED: $*"; exit 1; }
command -v node >/dev/null || skip "node not installed (Debian package nodejs)"
for package in "$@"; do
  [ -d "$LIGHTPROBE_JS/$package" ] || skip "$package not in $LIGHTPROBE_JS: run scripts/install-js-tools.sh"
done
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
