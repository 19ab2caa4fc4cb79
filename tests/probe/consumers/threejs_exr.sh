#!/usr/bin/env bash
# three.js' EXRLoader reads an unwrapped map as lightprobe does (threejs_exr.mjs): a mirror
# ball synthesised, unwrapped with a probe rotation (recorded in the map) and a blind spot
# (the validity mask in alpha).
# Usage: threejs_exr.sh LIGHTPROBE   (exit 77 = skipped: no node, or three.js not installed:
# scripts/install-js-tools.sh)
set -uo pipefail
LP=$1
HERE=$(cd "$(dirname "$0")" && pwd)
. "$HERE/../../js_consumer.sh" three
"$LP" --no-progress synth probe scene --type mirrorball --size 300x300 -o "$WORK/ball.exr" >/dev/null || fail "synth probe"
"$LP" --no-progress probe unwrap "$WORK/ball.exr" --type mirrorball --layout latlong --size 256x128 \
  --rotation 30,10,-5 -o "$WORK/map.exr" >/dev/null || fail "probe unwrap"
"$LP" info --json "$WORK/map.exr" >"$WORK/info.json" 2>/dev/null || fail "info"
node "$HERE/threejs_exr.mjs" "$WORK/map.exr" "$WORK/info.json" || fail "three.js reads the map otherwise"
echo "PASSED"
