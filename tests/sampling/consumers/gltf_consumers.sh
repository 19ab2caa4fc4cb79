#!/usr/bin/env bash
# Every .gltf and .glb the exporters write, checked by their consumers: Khronos' glTF
# validator reports 0 errors on each, and three.js' SphericalHarmonics3 evaluates the SH9
# a glTF carries to lightprobe's own irradiance (1e-4 relative).
# Usage: gltf_consumers.sh LIGHTPROBE   (exit 77 = skipped: no node, or the JS tools are
# not installed: scripts/install-js-tools.sh)
set -uo pipefail
LP=$1
HERE=$(cd "$(dirname "$0")" && pwd)
. "$HERE/../../js_consumer.sh" gltf-validator three

"$LP" --no-progress synth scene -o "$WORK/scene.exr" --size 256x128 >/dev/null || fail "synth scene"
run() { "$LP" --no-progress "$@" >>"$WORK/log" 2>&1 || fail "lightprobe $* ($(tail -2 "$WORK/log"))"; }
for ext in gltf glb; do
  run sample "$WORK/scene.exr" --method q2tree --n 64 -o "$WORK/plain.$ext"
  run sample "$WORK/scene.exr" --method pharr --n 8 --sh9 --exposure 2 -o "$WORK/map_sh9.$ext"
  run sample "$WORK/scene.exr" --method pharr --n 4 --residual sh9 --normalize-illuminance 20000 -o "$WORK/residual.$ext"
  run sample "$WORK/scene.exr" --method mediancut --n 1 -o "$WORK/one.$ext"
done
node "$HERE/validate_gltf.mjs" "$WORK"/*.gltf "$WORK"/*.glb || fail "the glTF validator reports errors"

run sample "$WORK/scene.exr" --method pharr --n 8 --sh9 -o "$WORK/sh9.gltf"
"$LP" --no-progress sh "$WORK/scene.exr" -o "$WORK/sh.json" --json >"$WORK/sh_report.json" || fail "sh"
node "$HERE/threejs_sh.mjs" "$WORK/sh9.gltf" "$WORK/sh_report.json" || fail "three.js disagrees with lightprobe's SH9 irradiance"
echo "PASSED"
