#!/usr/bin/env bash
# stream --exposures auto on Aravis' simulated camera (a fisheye sky of 20 .. 80 with a sun
# of 20 000, painted as radiance x exposure): the planner moves off its first bracket to
# one that covers the sun, says so in /status (section bracket) and in /metrics (promtool
# accepts it), and a replayed source, which cannot set its exposure, is refused with one
# line and exit 2.
# Usage: auto_bracket.sh LIGHTPROBE   (exit 77 = skipped: no promtool)
set -uo pipefail
LP=$1
WORK=$(mktemp -d)
. "$(dirname "$0")/stream_lib.sh"
command -v promtool >/dev/null || skip "promtool not installed (Debian package prometheus)"
trap '[ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null; wait 2>/dev/null; rm -rf "$WORK"' EXIT

# A source that cannot set exposure: refused before it streams, in one line, exit 2.
mkdir -p "$WORK/replay"
"$LP" synth scene -o "$WORK/replay/a.exr" --size 64x32 >/dev/null 2>&1 || fail "synth scene failed"
"$LP" stream --source "replay:$WORK/replay" --exposures auto --listen 127.0.0.1:0 --duration 5 \
  >"$WORK/refused.out" 2>"$WORK/refused.err"
rc=$?
[ "$rc" -eq 2 ] || fail "--exposures auto on a replay exited $rc, expected 2: $(tail -2 "$WORK/refused.err")"
grep -q "cannot set its exposure, so it cannot auto-bracket" "$WORK/refused.err" ||
  fail "the refusal does not say why: $(tail -2 "$WORK/refused.err")"

# --fov 187.5: the fake paints its 180 degrees within 0.48 of the short side, the default
# model puts them at 0.5, so that without it the map's horizon is a black ring (3.5 % of
# the pixels) the planner would chase to the camera's longest exposure.
start_stream --source aravis:Fake_1 --exposures auto --fov 187.5 --method hemigon --n 32 --duration 60
wait_for_lights 20
# Poll /status until the plan covers the sun and holds (the fake paints it at 20 000).
deadline=$((SECONDS + 40))
status=""
while [ $SECONDS -lt $deadline ]; do
  status=$(http_get /status) || status=""
  if [ -n "$status" ] && echo "$status" | jq -e '.bracket.mode == "auto" and .bracket.covered_fraction == 1
      and (.bracket.reason | contains("guessed") | not) and .bracket.decision == "steady"' >/dev/null 2>&1; then
    break
  fi
  sleep 0.5
done
echo "$status" | jq -e '.bracket.covered_fraction == 1 and .bracket.decision == "steady"' >/dev/null ||
  fail "the plan did not settle on the scene within 40 s: $(echo "$status" | jq -c .bracket)"
shortest=$(echo "$status" | jq '.bracket.exposure_seconds | min')
awk -v t="$shortest" 'BEGIN { exit !(t * 20000 < 1) }' ||
  fail "the shortest exposure $shortest s clips the sun (20000 x t >= 1): $(echo "$status" | jq -c .bracket)"
curl -s --max-time 5 "http://127.0.0.1:$PORT/metrics" >"$WORK/metrics.txt" || fail "no /metrics"
promtool check metrics <"$WORK/metrics.txt" >"$WORK/promtool.out" 2>&1 ||
  fail "promtool rejects /metrics: $(head -3 "$WORK/promtool.out")"
[ -s "$WORK/promtool.out" ] && fail "promtool warns: $(head -3 "$WORK/promtool.out")"
n=$(echo "$status" | jq '.bracket.exposure_seconds | length')
grep -q "^lightprobe_bracket_exposures $n$" "$WORK/metrics.txt" ||
  fail "/metrics disagrees with /status on the bracket: $(grep bracket_exposures "$WORK/metrics.txt")"
echo "auto_bracket: $(echo "$status" | jq -r .bracket.reason)"
