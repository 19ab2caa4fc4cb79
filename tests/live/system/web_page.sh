#!/usr/bin/env bash
# The live web page in a real browser: headless Chromium opens `/` of a running stream
# (the in-process fake bracketing camera), runs the page's script until it has filled in
# everything, and the resulting DOM must show what a user expects: the light count, the frame, the
# method and the fps filled in from the server, the 8 strongest lights numbered over the
# probe once each (whose picture draws every light: the page does not draw them again), the table
# of the brightest lights, the camera's state and bracket counters, and the probe picture
# loaded. (web_preview.sh checks the 3D preview's pixels.)
# Usage: web_page.sh LIGHTPROBE   (exit 77 = skipped: no Chromium)
set -uo pipefail
LP=$1
WORK=$(mktemp -d)
. "$(dirname "$0")/stream_lib.sh"
browser=$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)
[ -n "$browser" ] || skip "no Chromium (Debian package chromium)"
command -v python3 >/dev/null || skip "no python3"
trap '[ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null; wait 2>/dev/null; rm -rf "$WORK"' EXIT

N=200
# Twice: an open server, and one with a token, where the page reads the token from the
# URL fragment and sends it as a header on every request it makes.
for TOKEN in "" "s3cret-token"; do
  args=(); page="http://127.0.0.1:PORT/"
  [ -n "$TOKEN" ] && args=(--token "$TOKEN") && page="http://127.0.0.1:PORT/#token=$TOKEN"
  start_stream --source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method pharr --n $N --duration 200 "${args[@]}"
  wait_for_lights 15
  # Chromium in real time through the DevTools protocol (page_driver.py): the DOM is taken
  # once the page has filled in everything it shows (90 s at most), while the stream runs.
  ready="document.getElementById('probe').src.startsWith('blob:') && document.getElementById('fps').textContent !== '-'
    && document.querySelectorAll('#rows tr').length === 16 && document.querySelectorAll('#marks text').length > 0
    && document.getElementById('camera').textContent.startsWith('streaming')"
  rm -rf "$WORK/profile"
  python3 "$(dirname "$0")/page_driver.py" dump "$browser" "${page/PORT/$PORT}" "$ready" "$WORK/dom.html" "$WORK" ||
    fail "Chromium: the page never filled in: $(grep -v dbus "$WORK/chromium.log" | tail -1)"
  kill "$STREAM_PID"; wait "$STREAM_PID"; STREAM_PID=""

  dom=$WORK/dom.html
  field() { sed -n "s|.*<b id=\"$1\">\([^<]*\)</b>.*|\1|p" "$dom" | head -1; }
  count=$(field count); frame=$(field frame); method=$(field method); fps=$(field fps)
  # Ranks over the probe, one label per group of lights within ~10 deg ("1,2,5").
  ranks=$(grep -o '<text [^>]*>[0-9,]*' "$dom" | sed 's/.*>//' | tr ',' '\n' | sort -n | tr '\n' ' ')
  circles=$(grep -o '<circle' "$dom" | wc -l)
  camera=$(sed -n 's|.*<div id="camera"><b>\([^<]*\)</b>.*|\1|p' "$dom" | head -1)
  broken=$(field broken); bdropped=$(field brackets-dropped)
  rows=$(sed -n 's|.*<tbody id="rows">\(.*\)</tbody>.*|\1|p' "$dom" | grep -o '<tr>' | wc -l)
  what=${TOKEN:+"with a token: "}
  [ "$count" = "$N" ] || fail "${what}page shows '$count' lights, the server sends $N"
  [ "$ranks" = "1 2 3 4 5 6 7 8 " ] || fail "${what}page numbers '$ranks' over the probe, expected the 8 strongest once each"
  [ "$circles" -eq 0 ] || fail "${what}page draws $circles rings over the probe, which draws its lights itself"
  [ "$camera" = "streaming" ] || fail "${what}camera state '$camera', expected streaming"
  [[ "$broken" =~ ^[0-9]+$ && "$bdropped" =~ ^[0-9]+$ ]] || fail "${what}bracket counters '$bdropped' '$broken'"
  [ "$rows" -eq 16 ] || fail "${what}table of brightest lights has $rows rows, expected 16"
  [ "$method" = "pharr" ] || fail "${what}page shows method '$method', expected pharr"
  [[ "$frame" =~ ^[0-9]+$ ]] && [ "$frame" -ge 1 ] || fail "${what}page shows frame '$frame'"
  [[ "$fps" =~ ^[0-9]+\.[0-9]$ ]] || fail "${what}page shows fps '$fps' (status never polled?)"
  grep -q '<img id="probe"[^>]*src="blob:' "$dom" || fail "${what}the probe picture was never loaded"
  echo "web_page: ${what}Chromium rendered $count lights (ranks $ranks over the probe, $rows rows), frame $frame, $fps fps, method $method, camera $camera, $bdropped brackets dropped, $broken frames in broken ones"
done
