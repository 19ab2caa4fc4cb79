#!/usr/bin/env bash
# Issue 18 item 5: the Blender live link (tools/blender/lightprobe_live.py) against a running
# `lightprobe stream` replaying a turning camera (the scene turns 2 deg a frame): headless Blender follows /lights/stream, and
# at a frame where /lights serves the list it applied, its sun lamps match that list (count,
# direction to 1e-4 rad, strength to 1e-3 relative, colour), lamps of ids that went away are
# gone, and the world holds the list's SH9 (blender_live_check.py).
# Usage: blender_live.sh LIGHTPROBE   (exit 77 = skipped: blender not installed)
set -uo pipefail
LP=$1
HERE=$(cd "$(dirname "$0")" && pwd)
WORK=$(mktemp -d)
. "$HERE/stream_lib.sh"
command -v blender >/dev/null || skip "blender not installed (Debian package blender)"
trap '[ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null; wait 2>/dev/null; rm -rf "$WORK"' EXIT

"$LP" --no-progress synth sequence --scenario camera-turn --base scene --size 128x64 --frames 24 \
  -o "$WORK/seq" >/dev/null 2>"$WORK/synth.err" || fail "synth sequence: $(tail -1 "$WORK/synth.err")"
# 4 lists a second: Blender applies one and asks /lights before the next one comes.
start_stream --source "replay:$WORK/seq" --maps --layout latlong --size 128x64 --fps 4 --loop \
  --method q2tree --n 24 --duration 120
wait_for_lights 20
blender -b --factory-startup --python "$HERE/blender_live_check.py" -- "$HERE/../../../tools/blender" \
  "http://127.0.0.1:$PORT" >"$WORK/blender.log" 2>&1 ||
  { grep -E "blender_live:|Error|error|Traceback" "$WORK/blender.log" | head -8; fail "the live link in Blender"; }
grep -q "relative' units" "$WORK/blender.log" || fail "no warning about relative units: $(grep 'lightprobe live' "$WORK/blender.log")"
grep '^blender_live:' "$WORK/blender.log"
# The README's headless command saves under the name given: a relative one raised inside
# Blender (it takes only absolute paths) and nothing was written, with exit 0. A run that
# fails (no server) exits 1.
SCRIPT="$HERE/../../../tools/blender/lightprobe_live.py"
(cd "$WORK" && blender -b --factory-startup --python "$SCRIPT" -- --url "http://127.0.0.1:$PORT" --frames 2 \
  --save lit.blend) >"$WORK/save.log" 2>&1 || fail "headless --save: $(tail -2 "$WORK/save.log")"
[ -s "$WORK/lit.blend" ] || fail "--save lit.blend wrote nothing: $(grep -iE 'error|lightprobe_live:' "$WORK/save.log" | head -2)"
blender -b --factory-startup --python "$SCRIPT" -- --url http://127.0.0.1:1 --frames 1 >"$WORK/nohost.log" 2>&1 &&
  fail "a run with no server exited 0"
grep -q "^lightprobe_live: " "$WORK/nohost.log" || fail "no one-line reason: $(tail -2 "$WORK/nohost.log")"
echo "PASSED"
