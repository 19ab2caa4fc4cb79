#!/usr/bin/env bash
# Soak: the fake bracketing camera streams through the whole pipeline (fuse, unwrap,
# sample with FIR filtering, publish) for SECONDS while a live-stream client and a poller
# stay connected. Memory must not grow after warm-up, every frame must be accounted for
# (processed in a bracket, dropped with a whole bracket, or dropped in a broken one), no
# bracket may be broken on a healthy camera, and the published frames must only go up.
# Writes the resident-memory trace as CSV when SOAK_CSV is set.
# Usage: soak.sh LIGHTPROBE [SECONDS]   (CI runs 60 s; docs/live.md reports a 10-minute run)
set -uo pipefail
LP=$1
SECS=${2:-60}
WORK=$(mktemp -d)
. "$(dirname "$0")/stream_lib.sh"
trap '[ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null; wait 2>/dev/null; rm -rf "$WORK"' EXIT

start_stream --source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method hemigon --n 300 \
  --cluster 64 --duration "$SECS"
wait_for_lights 15

exec 5<>"/dev/tcp/127.0.0.1/$PORT"
printf 'GET /lights/stream?format=ndjson HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n' >&5
cat <&5 >"$WORK/live.ndjson" &
reader=$!

csv=$WORK/rss.csv
echo "seconds,rss_kb,frames_in" >"$csv"
start=$SECONDS
polls=0
while kill -0 "$STREAM_PID" 2>/dev/null; do
  rss=$(rss_kb "$STREAM_PID"); frames=$(metric lightprobe_frames_in_total 2>/dev/null)
  [ -n "$rss" ] && [ -n "$frames" ] && echo "$((SECONDS - start)),$rss,$frames" >>"$csv"
  http_get /lights >/dev/null 2>&1 && polls=$((polls + 1))
  sleep 1
done
wait "$STREAM_PID" || fail "stream exited with $?: $(tail -1 "$STREAM_ERR")"
STREAM_PID=""
kill "$reader" 2>/dev/null
exec 5<&- 5>&-
[ -n "${SOAK_CSV:-}" ] && cp "$csv" "$SOAK_CSV"

check_accounting 3
partial=$(json_field frames_dropped_partial)
# Only the bracket the stop cut short may be incomplete (at most 2 of its 3 frames).
[ "$partial" -le 2 ] || fail "$partial frames in broken brackets from a healthy camera"
# Published frame numbers seen by the live client only increase (no stale or mixed lists).
frames_seen=$(grep -o '"frame":[0-9]*' "$WORK/live.ndjson" | cut -d: -f2)
n_seen=$(echo "$frames_seen" | grep -c .)
[ "$n_seen" -ge 5 ] || fail "the live client got only $n_seen lists"
echo "$frames_seen" | awk 'NR > 1 && $1 <= prev { bad = 1 } { prev = $1 } END { exit bad }' ||
  fail "published frame numbers went backwards"

# Memory: after a warm-up quarter, the median resident size of the last third against
# that of the third before it. The allocator makes RSS swing by several MB from second to
# second, so medians, not end points: one leaked 360x90 map per bracket would add ~3 MB/s,
# one leaked light list ~0.1 MB/s; the bound catches both within a minute.
read -r first last growth rate < <(awk -F, -v w="$((SECS / 4))" '
  NR > 1 && $1 >= w { n++; y[n] = $2; x[n] = $1 }
  function median(a, b,   i, j, k, t, m) {
    k = 0; for (i = a; i <= b; i++) t[++k] = y[i]
    for (i = 1; i <= k; i++) for (j = i + 1; j <= k; j++) if (t[j] < t[i]) { m = t[i]; t[i] = t[j]; t[j] = m }
    return t[int((k + 1) / 2)]
  }
  END {
    third = int(n / 3); a = median(n - 2 * third + 1, n - third); b = median(n - third + 1, n)
    span = (x[n] + x[n - third + 1]) / 2 - (x[n - third] + x[n - 2 * third + 1]) / 2
    printf "%d %d %d %.1f\n", a, b, b - a, (span > 0 ? (b - a) / span : 0)
  }' "$csv")
[ "$growth" -lt 6144 ] || fail "resident memory grew by $growth kB ($rate kB/s): median $first -> $last kB"

echo "soak: ${SECS} s, $(json_field frames_in) frames in, $(json_field brackets_processed) brackets processed," \
  "$(json_field brackets_dropped) dropped whole, $partial in the bracket cut by the stop; median RSS $first -> $last kB" \
  "($rate kB/s); $n_seen lists streamed, $polls polls"
