#!/usr/bin/env bash
# The live page's 3D preview and operator's view in headless Chromium (issue 18 items 3
# and 6): a stream with a token replays two maps in turn, the sun at azimuth -20 deg then
# 200 deg (2.5 s each); the page, opened as /#token=T, must light the diffuse sphere from
# the right, then from the left, as its screenshots show (web_preview.py measures the
# pixels), and fill in the operator's view. three.js is loaded from the server itself
# without the token (it is public, like the page).
# Usage: web_preview.sh LIGHTPROBE   (exit 77 = skipped: no Chromium, no python3, or a
# lightprobe built without three.js). LIGHTPROBE_SCREENSHOTS=DIR keeps the screenshots.
set -uo pipefail
LP=$1
WORK=$(mktemp -d)
here=$(dirname "$0")
. "$here/stream_lib.sh"
browser=$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)
[ -n "$browser" ] || skip "no Chromium (Debian package chromium)"
command -v python3 >/dev/null || skip "no python3"
trap '[ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null; wait 2>/dev/null; rm -rf "$WORK"' EXIT

python3 "$here/web_preview.py" maps "$WORK/maps" || fail "could not write the test maps"
TOKEN=preview-token
start_stream --source "replay:$WORK/maps" --maps --layout latlong --size 128x64 --loop --fps 0.4 \
  --method mediancut --n 16 --token "$TOKEN"
wait_for_lights 30
python3 "$here/web_preview.py" check "$browser" "http://127.0.0.1:$PORT/#token=$TOKEN" "$WORK" \
  "${LIGHTPROBE_SCREENSHOTS:-}"
rc=$?
[ $rc -eq 1 ] && echo "chromium said: $(grep -v dbus "$WORK/chromium.log" | tail -2)" >&2
exit $rc
