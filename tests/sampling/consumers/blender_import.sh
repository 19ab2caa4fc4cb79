#!/usr/bin/env bash
# Blender's own glTF importer (Debian's blender, headless) reads the .glb and .gltf that
# `sample` writes: its sun lamps match lightprobe's light list in count, direction, strength
# (lux / 683) and colour, for absolute units and for relative ones (blender_check.py).
# Usage: blender_import.sh LIGHTPROBE   (exit 77 = skipped: blender not installed)
set -uo pipefail
LP=$1
HERE=$(cd "$(dirname "$0")" && pwd)
skip() { echo "SKIPPED: $*"; exit 77; }
fail() { echo "FAILED: $*"; exit 1; }
command -v blender >/dev/null || skip "blender not installed (Debian package blender)"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
"$LP" --no-progress synth scene -o "$WORK/scene.exr" --size 256x128 >/dev/null || fail "synth scene"
check() {  # name sample-options...: the same lights as JSON and as glTF/GLB, then Blender
  local name=$1
  shift
  for ext in json glb gltf; do
    "$LP" --no-progress sample "$WORK/scene.exr" "$@" -o "$WORK/$name.$ext" 2>>"$WORK/log" || fail "sample $* -o $name.$ext"
  done
  for ext in glb gltf; do
    blender -b --factory-startup --python "$HERE/blender_check.py" -- "$WORK/$name.$ext" "$WORK/$name.json" \
      >"$WORK/blender.log" 2>&1 || { grep -E "blender:|Error|error" "$WORK/blender.log" | head -5; fail "$name.$ext in Blender"; }
    echo "$name.$ext: $(grep '^blender:' "$WORK/blender.log")"
  done
}
check lux --method q2tree --n 64 --normalize-illuminance 20000
check relative --method mediancut --n 8
echo "PASSED"
