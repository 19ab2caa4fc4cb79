#!/usr/bin/env bash
# Load: wrk hammers GET /lights on loopback (2 threads, 32 connections) while the fake
# bracketing camera streams through the whole pipeline and a live-stream client listens.
# Every request must succeed, and the pipeline must keep processing brackets while the
# server is saturated (clients cannot stall it: publishing never waits for them).
# Prints requests/s, latency percentiles and the pipeline rate with and without load.
# Usage: load_wrk.sh LIGHTPROBE [SECONDS]   (exit 77 = skipped: no wrk)
set -uo pipefail
LP=$1
SECS=${2:-6}
WORK=$(mktemp -d)
. "$(dirname "$0")/stream_lib.sh"
command -v wrk >/dev/null || skip "wrk not installed (Debian package wrk)"
trap '[ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null; wait 2>/dev/null; rm -rf "$WORK"' EXIT

start_stream --source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method hemigon --n 300 \
  --duration $((3 * SECS + 20))
wait_for_lights 15

processed() { metric lightprobe_brackets_processed_total; }
a=$(processed); sleep "$SECS"; b=$(processed)
idle_rate=$(awk -v a="$a" -v b="$b" -v s="$SECS" 'BEGIN { printf "%.2f", (b - a) / s }')

# A live-stream client for the whole run, reading everything it is sent.
exec 5<>"/dev/tcp/127.0.0.1/$PORT"
printf 'GET /lights/stream HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n' >&5
cat <&5 >"$WORK/sse.txt" &
sse_pid=$!

a=$(processed)
wrk -t2 -c32 -d"${SECS}s" --latency "http://127.0.0.1:$PORT/lights" >"$WORK/wrk.txt" 2>&1 ||
  fail "wrk failed: $(tail -1 "$WORK/wrk.txt")"
b=$(processed)
load_rate=$(awk -v a="$a" -v b="$b" -v s="$SECS" 'BEGIN { printf "%.2f", (b - a) / s }')
kill "$sse_pid" 2>/dev/null
exec 5<&- 5>&-

requests=$(awk '/requests in/ { print $1 }' "$WORK/wrk.txt")
rps=$(awk '/^Requests\/sec/ { print $2 }' "$WORK/wrk.txt")
p50=$(awk '$1 == "50%" { print $2 }' "$WORK/wrk.txt")
p99=$(awk '$1 == "99%" { print $2 }' "$WORK/wrk.txt")
grep -q 'Socket errors' "$WORK/wrk.txt" && fail "socket errors under load: $(grep 'Socket errors' "$WORK/wrk.txt")"
grep -q 'Non-2xx' "$WORK/wrk.txt" && fail "failed requests under load: $(grep 'Non-2xx' "$WORK/wrk.txt")"
[ "${requests:-0}" -gt 0 ] || fail "wrk made no requests: $(cat "$WORK/wrk.txt")"
sse_events=$(grep -c '^data:' "$WORK/sse.txt")
[ "$sse_events" -ge 1 ] || fail "the live-stream client got no lists during the load"
# Two cores shared by wrk, the server and the pipeline: the pipeline slows but must not stall.
awk -v l="$load_rate" -v i="$idle_rate" 'BEGIN { exit !(l >= 0.25 * i && l > 0) }' ||
  fail "pipeline stalled under load: $load_rate brackets/s against $idle_rate idle"

kill -INT "$STREAM_PID"
wait "$STREAM_PID"; rc=$?  # a clean stop on SIGINT ends with the shell's 130
[ "$rc" = 130 ] || fail "stream exited with $rc after SIGINT (130 expected)"
STREAM_PID=""
check_accounting 3
echo "load_wrk: $requests requests in ${SECS} s = $rps req/s (p50 $p50, p99 $p99), none failed;" \
  "pipeline $idle_rate brackets/s idle, $load_rate under load; live client got $sse_events lists"
