# Shared by the whole-system tests: start `lightprobe stream`, talk HTTP to it with bash
# alone (no curl on a minimal machine), read its memory, fail with one clear line.
# Sourced; expects LP (the lightprobe binary) and WORK (a scratch directory).

fail() { echo "FAIL: $*" >&2; exit 1; }
skip() { echo "SKIP: $*" >&2; exit 77; }

# start_stream ARGS...: starts the stream on an ephemeral loopback port, waits until it
# listens; sets STREAM_PID, PORT, STREAM_OUT (its --json report) and STREAM_ERR.
start_stream() {
  STREAM_OUT=$WORK/stream.json
  STREAM_ERR=$WORK/stream.err
  "$LP" stream --listen 127.0.0.1:0 --json "$@" >"$STREAM_OUT" 2>"$STREAM_ERR" &
  STREAM_PID=$!
  PORT=""
  for _ in $(seq 100); do
    PORT=$(sed -n 's|.*-> http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$STREAM_ERR" | head -1)
    [ -n "$PORT" ] && return 0
    kill -0 "$STREAM_PID" 2>/dev/null || fail "stream exited at start: $(tail -1 "$STREAM_ERR")"
    sleep 0.1
  done
  fail "stream did not start listening within 10 s"
}

# http_get PATH: prints the body of a GET on the stream's port; returns 1 unless 200.
# With TOKEN set, sends it as "Authorization: Bearer $TOKEN".
http_get() {
  local reply auth=""
  [ -n "${TOKEN:-}" ] && auth="Authorization: Bearer $TOKEN"$'\r\n'
  exec 3<>"/dev/tcp/127.0.0.1/$PORT" || return 1
  printf 'GET %s HTTP/1.0\r\nHost: 127.0.0.1\r\n%sConnection: close\r\n\r\n' "$1" "$auth" >&3
  reply=$(timeout 5 cat <&3)
  exec 3<&- 3>&-
  case "${reply%%$'\r'*}" in *" 200 "*) ;; *) return 1 ;; esac
  printf '%s' "${reply#*$'\r\n\r\n'}"
}

# metric NAME: the value of one Prometheus sample from /metrics (integer part).
metric() {
  http_get /metrics | awk -v n="$1" '$1 == n { printf "%d", $2; exit }'
}

# wait_for_lights SECONDS: until /lights answers 200.
wait_for_lights() {
  local deadline=$((SECONDS + $1))
  while [ $SECONDS -lt $deadline ]; do
    http_get /lights >/dev/null 2>&1 && return 0
    sleep 0.2
  done
  fail "no lights on :$PORT/lights within $1 s; stream said: $(tail -1 "$STREAM_ERR")"
}

# json_field NAME: a number from the stream's final --json report.
json_field() {
  sed -n "s/.*\"$1\":\([-0-9.e+]*\).*/\1/p" "$STREAM_OUT" | head -1
}

rss_kb() { awk '/^VmRSS:/ { print $2 }' "/proc/$1/status" 2>/dev/null; }

# check_accounting: every frame the camera delivered was processed in a bracket, dropped
# with a whole bracket, or dropped as part of a broken one; brackets are 3 frames.
check_accounting() {
  local cycle=$1 fin proc drop part
  fin=$(json_field frames_in); proc=$(json_field brackets_processed)
  drop=$(json_field brackets_dropped); part=$(json_field frames_dropped_partial)
  [ -n "$fin" ] || fail "no --json report from the stream: $(tail -1 "$STREAM_ERR")"
  [ "$fin" -eq $((cycle * (proc + drop) + part)) ] ||
    fail "frames unaccounted for: in=$fin, processed=$proc, dropped=$drop brackets, partial=$part"
}

# start_bg NAME ARGS...: runs lightprobe ARGS --json in the background (its report in
# $WORK/NAME.json, its stderr in $WORK/NAME.err); sets NAME_PID, NAME_PORT; adds the pid to
# PIDS (the caller's EXIT trap kills them).
start_bg() {
  local name=$1 port="" pid; shift
  "$LP" "$@" --json >"$WORK/$name.json" 2>"$WORK/$name.err" &
  pid=$!; PIDS+=("$pid")
  for _ in $(seq 100); do
    port=$(sed -n 's|.*-> http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$WORK/$name.err" | head -1)
    [ -n "$port" ] && break
    kill -0 "$pid" 2>/dev/null || fail "$name exited at start: $(tail -1 "$WORK/$name.err")"
    sleep 0.1
  done
  [ -n "$port" ] || fail "$name did not start listening within 10 s"
  printf -v "${name}_PID" '%s' "$pid"; printf -v "${name}_PORT" '%s' "$port"
}
# code URL...: curl's HTTP status; the body in $WORK/body.
code() { curl -s -o "$WORK/body" -w '%{http_code}' --max-time 5 "$@"; }
# alive PID NAME: fails with NAME's last words if it died.
alive() { kill -0 "$1" 2>/dev/null || fail "$2 died (exit $(wait "$1"; echo $?)): $(tail -2 "$WORK/$2.err")"; }
