#!/usr/bin/env bash
# Issue 19, `merge --subscribe` against a real mosquitto the test starts on loopback, with
# two cameras publishing to it:
# - the merge uses both and publishes PREFIX/merged/lights;
# - the broker killed (SIGKILL) and restarted on its port: the streams go on meanwhile,
#   and stream and merge reconnect by themselves; the lists that come after are whole
#   and in order;
# - a camera killed (SIGKILL): its last will drops it from the merge in seconds, well
#   within --timeout (30 s), and it is taken back when it returns;
# - malformed payloads on the merge's topics (not JSON, another format, NaN, 1e999, 17 MB,
#   a negative light) are counted against their camera and skipped; the merge lives on.
# Usage: mqtt_merge.sh LIGHTPROBE   (exit 77 = skipped: no mosquitto, clients or curl)
. "$(dirname "$0")/mqtt_lib.sh" "$1"  # LP, WORK, the broker; skips without mosquitto

start_broker "allow_anonymous true"
URL=mqtt://127.0.0.1:$BROKER_PORT/studio
FAKE=(--source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method q2tree --n 64 --listen 127.0.0.1:0 --duration 120)
start_bg A stream "${FAKE[@]}" --name camA --publish "$URL"
start_bg B stream "${FAKE[@]}" --name camB --publish "$URL"
start_bg M merge --subscribe "$URL/+/lights" --n 64 --timeout 30 --listen 127.0.0.1:0 --duration 110
both() { [ "$(merge_used "$M_PORT")" = "camA camB" ]; }
wait_until 30 both || fail "the merge does not use camA and camB within 30 s: uses '$(merge_used "$M_PORT")'"
case "$(sub studio/merged/lights 1 5)" in *'"format":"lightprobe.lights/1"'*) ;; *) fail "no list on studio/merged/lights" ;; esac

# The broker killed mid-stream and restarted on the same port.
kill_broker KILL
f0=$(frame_of "http://127.0.0.1:$A_PORT/lights")
sleep 3
f1=$(frame_of "http://127.0.0.1:$A_PORT/lights")
[ "${f1:-0}" -gt "${f0:-0}" ] || fail "camA's pipeline stalled without its broker (frame $f0 -> $f1)"
alive "$A_PID" A; alive "$M_PID" M
restart_broker
t0=$SECONDS
back() { [ -n "$(sub studio/camA/lights 1 1)" ] && [ -n "$(sub studio/merged/lights 1 1)" ]; }
wait_until 30 back || fail "camA or the merge did not publish again within 30 s of the broker's restart"
echo "publisher and merge back on the broker $((SECONDS - t0)) s after its restart"
# /metrics is refreshed every 200 ms: the count may trail the list that showed the reconnect.
reconnected_a_port() { [ "$(labelled_metric "$A_PORT" 'lightprobe_mqtt_connects_total{link="publish"}')" -ge 2 ]; }
wait_until 5 reconnected_a_port || fail "camA's metrics count no reconnect"
# /metrics is refreshed every 200 ms: the count may trail the list that showed the reconnect.
reconnected_m_port() { [ "$(labelled_metric "$M_PORT" 'lightprobe_mqtt_connects_total{link="subscribe"}')" -ge 2 ]; }
wait_until 5 reconnected_m_port || fail "the merge's metrics count no reconnect"
sub studio/camA/lights 15 20 >"$WORK/after.txt"
"$PY" - "$WORK/after.txt" <<'EOF' || fail "lists after the restart are not whole and in order"
import json, sys
frames = [json.loads(line)["frame"] for line in open(sys.argv[1])]
assert len(frames) == 15, frames
assert all(a < b for a, b in zip(frames, frames[1:])), frames
EOF
wait_until 30 both || fail "the merge does not use both cameras after the restart: '$(merge_used "$M_PORT")'"

# camB killed: no clean goodbye, its last will must drop it.
kill -KILL "$B_PID"; wait "$B_PID" 2>/dev/null
t0=$SECONDS
only_a() { [ "$(merge_used "$M_PORT")" = camA ]; }
wait_until 10 only_a || fail "camB's last will did not drop it from the merge within 10 s (timeout 30): '$(merge_used "$M_PORT")'"
echo "camB dropped $((SECONDS - t0)) s after SIGKILL (will; the timeout is 30 s)"
case "$(sub studio/camB/status 1 3)" in *'"state":"offline"'*) ;; *) fail "camB's status is not offline after its death" ;; esac
start_bg B2 stream "${FAKE[@]}" --name camB --publish "$URL"
wait_until 30 both || fail "camB not taken back within 30 s of its return: '$(merge_used "$M_PORT")'"

# Malformed payloads from a camera "evil": five that are no light list, then one that is
# but cannot be merged (a negative light).
list() { printf '{"format":"lightprobe.lights/1","frame":1,"timestamp":1,"method":"q2tree","units":"relative","frame_convention":"z-up","lights":[{"id":4,"direction":[0,0,1],"rgb":[%s,1,1],"solid_angle":1}]}' "$1"; }
pub -t studio/evil/lights -m 'not json' || fail "mosquitto_pub failed"
pub -t studio/evil/lights -m '{"format":"other/1","lights":[]}'
pub -t studio/evil/lights -m "$(list NaN)"
pub -t studio/evil/lights -m "$(list 1e999)"
head -c 17000000 /dev/zero | tr '\0' ' ' >"$WORK/huge"
pub -t studio/evil/lights -f "$WORK/huge"
pub -t studio/evil/status -m '{"state":'
pub -t studio/evil/lights -m "$(list -1)"
evil_counted() {
  [ "$(code "http://127.0.0.1:$M_PORT/status")" = 200 ] || return 1
  "$PY" - "$WORK/body" <<'EOF'
import json, sys
m = json.load(open(sys.argv[1]))["merge"]
evil = [i for i in m["inputs"] if i["url"] == "evil"]
assert evil and evil[0]["polls_failed"] == 5 and evil[0]["polls_ok"] == 1, evil
assert evil[0]["state"] == "skipped" and evil[0]["reason"] == "negative", evil
assert evil[0]["skipped"].get("malformed", 0) + evil[0]["skipped"].get("negative", 0) >= 1, evil
EOF
}
wait_until 10 evil_counted || fail "the malformed payloads were not counted against 'evil': $(cat "$WORK/body")"
alive "$M_PID" M
wait_until 10 both || fail "the merge stopped using camA and camB after the malformed payloads: '$(merge_used "$M_PORT")'"
[ "$(frame_of "http://127.0.0.1:$M_PORT/lights")" -ge 0 ] || fail "the merge serves no lights"
echo "mqtt_merge: merged camA + camB; recovered from a broker restart; camB's will dropped it, its return took it back;" \
  "6 bad payloads counted against 'evil', none merged"
