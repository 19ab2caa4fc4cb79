#!/usr/bin/env bash
# /metrics of a live stream and of a merge, checked by Prometheus' own linter
# (`promtool check metrics`: HELP and TYPE for every family, counters ending in _total,
# base units, no abbreviated units), and the families issue 18 asks for present: the
# per-stage and end-to-end latency histograms in seconds and one frame-rate gauge.
# Usage: metrics_promtool.sh LIGHTPROBE   (exit 77 = skipped: no promtool or curl)
set -uo pipefail
LP=$1
WORK=$(mktemp -d)
. "$(dirname "$0")/stream_lib.sh"
command -v promtool >/dev/null || skip "promtool not installed (Debian package prometheus)"
command -v curl >/dev/null || skip "curl not installed (Debian package curl)"
MERGE_PID=""
trap '[ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null; [ -n "$MERGE_PID" ] && kill "$MERGE_PID" 2>/dev/null; wait 2>/dev/null; rm -rf "$WORK"' EXIT

lint() {  # lint NAME FILE
  promtool check metrics <"$2" >"$WORK/promtool.out" 2>&1 ||
    fail "promtool rejects the $1's /metrics: $(head -5 "$WORK/promtool.out")"
  [ -s "$WORK/promtool.out" ] && fail "promtool warns about the $1's /metrics: $(head -5 "$WORK/promtool.out")"
  return 0
}

start_stream --source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method hemigon --n 64 --duration 30
wait_for_lights 15
sleep 1.5
curl -s --max-time 5 "http://127.0.0.1:$PORT/metrics" >"$WORK/stream.txt" || fail "no /metrics from the stream"
lint stream "$WORK/stream.txt"
for family in lightprobe_stage_duration_seconds lightprobe_latency_seconds lightprobe_frame_rate_hertz \
    lightprobe_frames_in_total lightprobe_server_connections_rejected_total; do
  grep -q "^# TYPE $family " "$WORK/stream.txt" || fail "the stream's /metrics has no $family"
  grep -q "^# HELP $family " "$WORK/stream.txt" || fail "$family has no HELP"
done
grep -q '^lightprobe_stage_duration_seconds_bucket{stage="fuse_unwrap",le="+Inf"} [1-9]' "$WORK/stream.txt" ||
  fail "no bracket counted in the fuse_unwrap stage: $(grep fuse_unwrap "$WORK/stream.txt" | tail -3)"
[ "$(grep -c '^# TYPE .* gauge' "$WORK/stream.txt" | head -1)" -ge 1 ] || fail "no gauges"
rates=$(grep -c -E '^# TYPE [a-z_]*(fps|frame_rate)[a-z_]* ' "$WORK/stream.txt")
[ "$rates" -eq 1 ] || fail "$rates frame-rate gauges, expected one"

"$LP" merge "http://127.0.0.1:$PORT" --listen 127.0.0.1:0 --duration 20 --n 64 >"$WORK/merge.out" 2>&1 &
MERGE_PID=$!
mport=""
for _ in $(seq 100); do
  mport=$(sed -n 's|.*-> http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$WORK/merge.out" | head -1)
  [ -n "$mport" ] && break
  sleep 0.1
done
[ -n "$mport" ] || fail "merge did not start: $(tail -1 "$WORK/merge.out")"
sleep 1.5
curl -s --max-time 5 "http://127.0.0.1:$mport/metrics" >"$WORK/merge.txt" || fail "no /metrics from the merge"
lint merge "$WORK/merge.txt"
grep -q '^lightprobe_merge_inputs_used 1$' "$WORK/merge.txt" || fail "the merge does not report its input: $(grep merge_inputs "$WORK/merge.txt")"
families=$(grep -c '^# TYPE ' "$WORK/stream.txt"); mfamilies=$(grep -c '^# TYPE ' "$WORK/merge.txt")
echo "metrics_promtool: promtool accepts the stream's /metrics ($families families) and the merge's ($mfamilies)"
