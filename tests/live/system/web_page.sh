#!/usr/bin/env bash
# The live web page in a real browser: headless Chromium opens `/` of a running stream
# (the in-process fake bracketing camera), runs the page's script until the stream ends,
# and the resulting DOM must show what a user expects: the light count, the frame, the
# method and the fps filled in from the server, one circle per light drawn over the
# probe, the table of the brightest lights, and the probe picture loaded.
# Usage: web_page.sh LIGHTPROBE   (exit 77 = skipped: no Chromium)
set -uo pipefail
LP=$1
WORK=$(mktemp -d)
. "$(dirname "$0")/stream_lib.sh"
browser=$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)
[ -n "$browser" ] || skip "no Chromium (Debian package chromium)"
trap '[ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null; wait 2>/dev/null; rm -rf "$WORK"' EXIT

N=200
# Twice: an open server, and one with a token, where the page reads the token from the
# URL fragment and sends it as a header on every request it makes.
for TOKEN in "" "s3cret-token"; do
  args=(); page="http://127.0.0.1:PORT/"
  [ -n "$TOKEN" ] && args=(--token "$TOKEN") && page="http://127.0.0.1:PORT/#token=$TOKEN"
  start_stream --source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method pharr --n $N --duration 9 "${args[@]}"
  wait_for_lights 15
  # The page keeps its stream open, so Chromium's virtual time runs until the server
  # closes at the end of --duration: by then every update the page makes has happened.
  timeout 60 "$browser" --headless=new --no-sandbox --disable-gpu --disable-dev-shm-usage \
    --user-data-dir="$WORK/profile" --virtual-time-budget=20000 --dump-dom "${page/PORT/$PORT}" \
    >"$WORK/dom.html" 2>"$WORK/chromium.log" || fail "Chromium failed: $(grep -v dbus "$WORK/chromium.log" | tail -1)"
  wait "$STREAM_PID"; STREAM_PID=""

  dom=$WORK/dom.html
  field() { sed -n "s|.*<b id=\"$1\">\([^<]*\)</b>.*|\1|p" "$dom" | head -1; }
  count=$(field count); frame=$(field frame); method=$(field method); fps=$(field fps)
  circles=$(grep -o '<circle' "$dom" | wc -l)
  rows=$(sed -n 's|.*<tbody id="rows">\(.*\)</tbody>.*|\1|p' "$dom" | grep -o '<tr>' | wc -l)
  what=${TOKEN:+"with a token: "}
  [ "$count" = "$N" ] || fail "${what}page shows '$count' lights, the server sends $N"
  [ "$circles" -eq "$N" ] || fail "${what}page draws $circles light marks, expected $N"
  [ "$rows" -eq 16 ] || fail "${what}table of brightest lights has $rows rows, expected 16"
  [ "$method" = "pharr" ] || fail "${what}page shows method '$method', expected pharr"
  [[ "$frame" =~ ^[0-9]+$ ]] && [ "$frame" -ge 1 ] || fail "${what}page shows frame '$frame'"
  [[ "$fps" =~ ^[0-9]+\.[0-9]$ ]] || fail "${what}page shows fps '$fps' (status never polled?)"
  grep -q '<img id="probe"[^>]*src="blob:' "$dom" || fail "${what}the probe picture was never loaded"
  echo "web_page: ${what}Chromium rendered $count lights ($circles marks, $rows rows), frame $frame, $fps fps, method $method"
done
