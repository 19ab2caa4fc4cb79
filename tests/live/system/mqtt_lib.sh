# Shared by the MQTT tests (issue 19): a mosquitto broker of the test's own on a free
# loopback port with its own config file, killed and restarted at will, and small
# helpers around mosquitto_sub. Sourced as `. mqtt_lib.sh LIGHTPROBE`: sets LP, WORK and
# PIDS (killed on exit, WORK removed), sources stream_lib.sh, and skips (77) without the
# tools.
set -uo pipefail
LP=$1
WORK=$(mktemp -d)
. "$(dirname "${BASH_SOURCE[0]}")/stream_lib.sh"

MOSQUITTO=$(command -v mosquitto || echo /usr/sbin/mosquitto)
PY=/usr/bin/python3  # Debian's python3 (DEPENDENCIES.md): JSON checks

need_mqtt() {
  [ -x "$MOSQUITTO" ] || skip "mosquitto not installed (Debian package mosquitto)"
  command -v mosquitto_sub >/dev/null && command -v mosquitto_pub >/dev/null ||
    skip "mosquitto_sub/mosquitto_pub not installed (Debian package mosquitto-clients)"
  command -v curl >/dev/null || skip "curl not installed (Debian package curl)"
  [ -x "$PY" ] || skip "no $PY for the JSON checks"
}

# mqtt_test_setup: skips without the tools; PIDS, killed on exit with WORK removed.
mqtt_test_setup() {
  need_mqtt
  PIDS=()
  trap 'for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null; done; wait 2>/dev/null; rm -rf "$WORK"' EXIT
}

# launch_broker: mosquitto -c $WORK/mosquitto.conf in the background (BROKER_PID); true
# once it listens on BROKER_PORT, false when it exits or 5 s pass (then it is stopped).
launch_broker() {
  "$MOSQUITTO" -c "$WORK/mosquitto.conf" >>"$WORK/mosquitto.log" 2>&1 &
  BROKER_PID=$!; PIDS+=("$BROKER_PID")
  for _ in $(seq 50); do
    kill -0 "$BROKER_PID" 2>/dev/null || return 1
    (exec 3<>"/dev/tcp/127.0.0.1/$BROKER_PORT") 2>/dev/null && return 0
    sleep 0.1
  done
  kill "$BROKER_PID" 2>/dev/null; wait "$BROKER_PID" 2>/dev/null
  return 1
}

# start_broker [CONFIG LINE...]: a broker with `listener PORT 127.0.0.1`, no persistence
# and the given lines, in its own config file. Picks a free port unless BROKER_PORT is
# set (another one if that is taken), and keeps it for restart_broker.
start_broker() {
  printf '%s\n' "$@" >"$WORK/mosquitto.extra"
  local attempt
  for attempt in 1 2 3 4 5 6 7 8; do
    [ -n "${BROKER_PORT:-}" ] || BROKER_PORT=$((20000 + RANDOM % 40000))
    { printf 'listener %s 127.0.0.1\npersistence false\n' "$BROKER_PORT"; cat "$WORK/mosquitto.extra"; } >"$WORK/mosquitto.conf"
    launch_broker && return 0
    BROKER_PORT=""  # taken by someone else: another one
  done
  fail "mosquitto did not start: $(tail -2 "$WORK/mosquitto.log")"
}

# kill_broker [SIGNAL]: the broker gone (SIGKILL by default: no goodbye to anyone).
kill_broker() { kill -"${1:-KILL}" "$BROKER_PID" 2>/dev/null; wait "$BROKER_PID" 2>/dev/null; }

# restart_broker: the same port and config again (retained messages are gone with it).
restart_broker() {
  local tries
  for tries in $(seq 15); do  # the port may linger for a moment
    launch_broker && return 0
    sleep 0.5
  done
  fail "mosquitto did not restart on port $BROKER_PORT: $(tail -2 "$WORK/mosquitto.log")"
}

# sub TOPIC COUNT SECONDS [ARGS...]: mosquitto_sub printing COUNT payloads of TOPIC, one a
# line, waiting at most SECONDS.
sub() {
  local topic=$1 count=$2 secs=$3; shift 3
  mosquitto_sub -h 127.0.0.1 -p "$BROKER_PORT" -t "$topic" -C "$count" -W "$secs" "$@" 2>/dev/null
}
pub() { mosquitto_pub -h 127.0.0.1 -p "$BROKER_PORT" "$@"; }

# wait_until SECONDS COMMAND...: true as soon as COMMAND is, false after SECONDS.
wait_until() {
  local deadline=$((SECONDS + $1)); shift
  while [ $SECONDS -lt $deadline ]; do
    "$@" && return 0
    sleep 0.25
  done
  return 1
}

# merge_used PORT: the cameras a merge's last round used, sorted, space-separated.
merge_used() {
  [ "$(code "http://127.0.0.1:$1/status")" = 200 ] || return 1
  "$PY" -c 'import json, sys
m = json.load(open(sys.argv[1]))["merge"]
print(" ".join(sorted(i["url"] for i in m["inputs"] if i["state"] == "used")))' "$WORK/body"
}

# frame_of URL: the frame number of the light list at URL.
frame_of() {
  [ "$(code "$1")" = 200 ] || return 1
  "$PY" -c 'import json, sys; print(json.load(open(sys.argv[1]))["frame"])' "$WORK/body"
}

# labelled_metric PORT NAME{LABELS}: one sample of /metrics (integer part).
labelled_metric() {
  curl -s --max-time 5 "http://127.0.0.1:$1/metrics" | awk -v n="$2" '$1 == n { printf "%d", $2; exit }'
}

# serving PORT: /lights answers 200.
serving() { [ "$(code "http://127.0.0.1:$1/lights")" = 200 ]; }

mqtt_test_setup
