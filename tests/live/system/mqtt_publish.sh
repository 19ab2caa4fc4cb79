#!/usr/bin/env bash
# Issue 19, `stream --publish` against a real mosquitto the test starts on loopback, after
# the stream (which connects when the broker comes up): every list /lights serves is, byte for byte, a message on PREFIX/CAMERA/lights; the
# status says online with the camera's HTTP address; after the stream stops, a late
# subscriber still gets the newest list (retained) and the status says offline; a wrong
# password is refused in one line naming --publish (the password not in it), for stream
# and merge alike, and the right one, given in the stream's config file, publishes.
# Usage: mqtt_publish.sh LIGHTPROBE   (exit 77 = skipped: no mosquitto, clients or curl)
. "$(dirname "$0")/mqtt_lib.sh" "$1"  # LP, WORK, the broker; skips without mosquitto

# The stream comes up before its broker: it streams, and connects when the broker does.
BROKER_PORT=$((20000 + RANDOM % 40000))
FAKE=(--source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method q2tree --n 64)
start_bg S stream "${FAKE[@]}" --duration 60 --listen 127.0.0.1:0 --name cam1 \
  --publish "mqtt://127.0.0.1:$BROKER_PORT/studio" --mqtt-qos 1
wait_until 20 serving "$S_PORT" || fail "no /lights within 20 s"
sleep 1
early=$BROKER_PORT
start_broker "allow_anonymous true"
[ "$BROKER_PORT" = "$early" ] || skip "port $early was taken; the test needs it free"
has_list() { [ -n "$(sub studio/cam1/lights 1 1)" ]; }
wait_until 20 has_list || fail "the stream did not connect to a broker that came up after it"

# Everything the stream publishes, from now until it stops.
mosquitto_sub -h 127.0.0.1 -p "$BROKER_PORT" -t studio/cam1/lights >"$WORK/all.txt" 2>/dev/null &
ALL_PID=$!; PIDS+=("$ALL_PID")
sub studio/cam1/lights 12 20 >"$WORK/some.txt" &
SOME_PID=$!
sleep 1
[ "$(code "http://127.0.0.1:$S_PORT/lights")" = 200 ] || fail "/lights failed"
served=$(cat "$WORK/body")
wait "$SOME_PID"
[ "$(wc -l <"$WORK/some.txt")" -ge 12 ] || fail "only $(wc -l <"$WORK/some.txt") lists on studio/cam1/lights in 20 s"
grep -Fxq -- "$served" "$WORK/some.txt" ||
  fail "the list /lights served (frame $(frame_of "http://127.0.0.1:$S_PORT/lights")) is not among the published ones"

status=$(sub studio/cam1/status 1 3)
case "$status" in *'"state":"online"'*) ;; *) fail "status while streaming: '$status'" ;; esac
case "$status" in *"\"http\":\"http://127.0.0.1:$S_PORT/\""*) ;; *) fail "status without the HTTP address: '$status'" ;; esac

# A clean stop: the newest list stays retained for whoever comes later; status offline.
kill -TERM "$S_PID"; wait "$S_PID"; rc=$?
[ "$rc" = 0 ] || [ "$rc" = 143 ] || fail "stream exited with $rc: $(tail -2 "$WORK/S.err")"
sleep 0.5
kill "$ALL_PID" 2>/dev/null; wait "$ALL_PID" 2>/dev/null
late=$(sub studio/cam1/lights 1 3 -F '%r %p')
[ "${late%% *}" = 1 ] || fail "the late subscriber's list is not retained: '${late:0:80}'"
[ "${late#* }" = "$(tail -1 "$WORK/all.txt")" ] || fail "the retained list is not the newest one published"
case "$(sub studio/cam1/status 1 3)" in *'"state":"offline"'*) ;; *) fail "status after a clean stop is not offline" ;; esac
published=$(sed -n 's/.*"mqtt_published":\([0-9]*\).*/\1/p' "$WORK/S.json")
[ "${published:-0}" -ge "$(wc -l <"$WORK/all.txt")" ] || fail "the summary counts ${published:-0} published lists, the broker sent $(wc -l <"$WORK/all.txt")"

# Credentials: a broker with a password file.
kill_broker TERM
mosquitto_passwd -b -c "$WORK/passwd" cam s3cret 2>/dev/null || fail "mosquitto_passwd failed"
chmod a+x "$WORK"; chmod 644 "$WORK/passwd"  # mosquitto started as root reads it as user mosquitto
BROKER_PORT=""; start_broker "allow_anonymous false" "password_file $WORK/passwd"
for cmd in stream merge; do
  if [ $cmd = stream ]; then
    args=(stream "${FAKE[@]}" --listen 127.0.0.1:0 --duration 30 --publish "mqtt://cam:wrong@127.0.0.1:$BROKER_PORT/studio")
  else
    args=(merge --listen 127.0.0.1:0 --duration 30 --subscribe "mqtt://cam:wrong@127.0.0.1:$BROKER_PORT/studio/+/lights")
  fi
  start=$SECONDS
  timeout 60 "$LP" "${args[@]}" >"$WORK/$cmd.out" 2>"$WORK/$cmd.err"; rc=$?
  [ "$rc" = 2 ] || fail "$cmd with a wrong password exited $rc, not 2: $(tail -2 "$WORK/$cmd.err")"
  [ "$(wc -l <"$WORK/$cmd.err")" = 1 ] || fail "$cmd: not one line on stderr: $(cat "$WORK/$cmd.err")"
  flag=--publish; [ $cmd = merge ] && flag=--subscribe
  grep -q -- "$flag" "$WORK/$cmd.err" || fail "$cmd: the error does not name $flag: $(cat "$WORK/$cmd.err")"
  grep -q wrong "$WORK/$cmd.err" && fail "$cmd: the error shows the password: $(cat "$WORK/$cmd.err")"
  [ $((SECONDS - start)) -lt 20 ] || fail "$cmd took $((SECONDS - start)) s to give up on a refused password"
done
# The right one, from the stream's config file this time.
printf '[stream]\npublish = "mqtt://cam:s3cret@127.0.0.1:%s/studio"\nname = "cam2"\nmqtt-qos = 0\n' "$BROKER_PORT" >"$WORK/rig.toml"
"$LP" stream "${FAKE[@]}" --listen 127.0.0.1:0 --duration 5 --json --config "$WORK/rig.toml" >"$WORK/ok.json" 2>"$WORK/ok.err" ||
  fail "stream with the right password failed: $(tail -1 "$WORK/ok.err")"
published=$(sed -n 's/.*"mqtt_published":\([0-9]*\).*/\1/p' "$WORK/ok.json")
[ "${published:-0}" -gt 0 ] || fail "nothing published with the right password: $(cat "$WORK/ok.json")"
echo "mqtt_publish: /lights among $(wc -l <"$WORK/some.txt") published lists; the newest retained after a clean stop," \
  "status online then offline; wrong password refused in one line by stream and merge; right one published $published lists"
