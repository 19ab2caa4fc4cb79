#!/usr/bin/env bash
# Fault test over the real GigE Vision protocol: Aravis' simulator serves a camera on
# loopback, `lightprobe stream` brackets it and serves lights; the camera process is
# killed (SIGKILL, as an unplugged cable looks), the stream must keep serving the last
# lights, and when the camera comes back the stream recovers by itself; a client that
# disconnects mid-stream must not matter. Runs in a private network namespace so that
# the simulator's discovery never reaches another network.
# Usage: gige_fault.sh LIGHTPROBE   (exit 77 = skipped: no simulator or no namespaces)
set -uo pipefail
LP=$1
WORK=$(mktemp -d)
. "$(dirname "$0")/stream_lib.sh"

if [ -z "${LP_IN_NETNS:-}" ]; then
  command -v arv-fake-gv-camera-0.8 >/dev/null || skip "arv-fake-gv-camera-0.8 not installed (aravis-tools)"
  unshare -n true 2>/dev/null || skip "cannot create a network namespace (needs root or CAP_SYS_ADMIN)"
  LP_IN_NETNS=1 exec unshare -n bash "$0" "$@"
fi
ip link set lo up || fail "cannot bring up loopback in the namespace"

SIM_PID=""
cleanup() {
  [ -n "$SIM_PID" ] && kill -9 "$SIM_PID" 2>/dev/null
  [ -n "${STREAM_PID:-}" ] && kill "$STREAM_PID" 2>/dev/null
  wait 2>/dev/null
  rm -rf "$WORK"
}
trap cleanup EXIT

start_simulator() {
  arv-fake-gv-camera-0.8 -i 127.0.0.1 >"$WORK/sim.log" 2>&1 &
  SIM_PID=$!
  for _ in $(seq 50); do
    arv-tool-0.8 2>/dev/null | grep -q Aravis-Fake-GV01 && return 0
    sleep 0.1
  done
  fail "the GigE simulator did not come up: $(tail -1 "$WORK/sim.log")"
}

start_simulator
# The simulator has no SFNC sequencer: requiring one is a clear usage error (exit 2).
"$LP" stream --source aravis:Aravis-Fake-GV01 --exposures 0.001,0.004 --bracketing sequencer \
  --listen 127.0.0.1:0 --duration 5 >"$WORK/seq.out" 2>"$WORK/seq.err"
code=$?
[ "$code" -eq 2 ] && grep -q "no sequencer" "$WORK/seq.err" ||
  fail "--bracketing sequencer on a camera without one: exit $code, said: $(tail -1 "$WORK/seq.err")"
start_stream --source aravis:Aravis-Fake-GV01 --exposures 0.0002,0.002,0.02 --duration 40
wait_for_lights 15

# A client that goes away mid-stream: open the live stream, read a little, hang up.
exec 4<>"/dev/tcp/127.0.0.1/$PORT"
printf 'GET /lights/stream HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n' >&4
timeout 2 head -c 2000 <&4 >/dev/null
exec 4<&- 4>&-

deadline=$((SECONDS + 15))
before=0
while [ $SECONDS -lt $deadline ] && [ "$before" -lt 12 ]; do
  before=$(metric lightprobe_frames_in_total); before=${before:-0}
  sleep 0.3
done
[ "$before" -ge 12 ] || fail "only $before frames from the simulator in 15 s"
kill -9 "$SIM_PID"
wait "$SIM_PID" 2>/dev/null
SIM_PID=""
sleep 3
code=$(curl -s -o /dev/null -w "%{http_code}" --max-time 5 "http://127.0.0.1:$PORT/lights"); [ "$code" = 200 ] || fail "/lights stopped answering while the camera was away (HTTP $code): $(tail -3 "$STREAM_ERR" | tr "\n" " ")"
stalled=$(metric lightprobe_frames_in_total)
[ "$stalled" -ge "$before" ] || fail "frame counter went backwards ($before -> $stalled)"

start_simulator
deadline=$((SECONDS + 20))
recovered=""
while [ $SECONDS -lt $deadline ]; do
  now=$(metric lightprobe_frames_in_total)
  if [ -n "$now" ] && [ "$now" -ge $((stalled + 15)) ]; then recovered=$now; break; fi
  sleep 0.5
done
[ -n "$recovered" ] || fail "no frames within 20 s of the camera's return (frames_in stayed at $stalled)"
frame_a=$(metric lightprobe_server_frame)
sleep 1.5
frame_b=$(metric lightprobe_server_frame)
[ "$frame_b" -gt "$frame_a" ] || fail "lights not updating after recovery (frame $frame_a -> $frame_b)"
reconnects=$(metric lightprobe_camera_reconnects_total)
[ "$reconnects" -ge 1 ] || fail "the camera loss was not noticed (0 reconnects)"

kill -INT "$STREAM_PID"
wait "$STREAM_PID"; rc=$?  # a clean stop on SIGINT ends with the shell's 130
[ "$rc" = 130 ] || fail "stream exited with $rc after SIGINT (130 expected)"
STREAM_PID=""
check_accounting 3
echo "gige_fault: frames $before before the kill, $stalled while away, $recovered after return;" \
  "$reconnects reconnect(s); lights frame $frame_a -> $frame_b; $(cat "$STREAM_OUT")"
