#!/usr/bin/env bash
# Issue 19, `stream --publish mqtts://...` against a mosquitto TLS listener the test starts
# on loopback, with a CA and a server certificate (for IP 127.0.0.1) made here by openssl:
# with --mqtt-cafile the lists arrive (read back over TLS); the broker SIGKILLed and
# restarted, publishing resumes by itself, also after ten kills in quick succession
# (live/mqtt_client.cpp's own network thread reconnects); without the CA the certificate is refused
# in one line naming --publish.
# Usage: mqtt_tls.sh LIGHTPROBE   (exit 77 = skipped: no mosquitto, clients, curl or openssl)
. "$(dirname "$0")/mqtt_lib.sh" "$1"  # LP, WORK, the broker; skips without mosquitto
command -v openssl >/dev/null || skip "openssl not installed"

chmod a+x "$WORK"  # mosquitto started as root reads its files as user mosquitto
( cd "$WORK" &&
  openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj "/CN=lightprobe test CA" -keyout ca.key -out ca.crt &&
  openssl req -newkey rsa:2048 -nodes -subj "/CN=127.0.0.1" -keyout server.key -out server.csr &&
  printf 'subjectAltName=IP:127.0.0.1\n' >san.ext &&
  openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial -days 2 -extfile san.ext -out server.crt &&
  chmod 644 ca.crt server.crt server.key ) >/dev/null 2>&1 || fail "openssl could not make the test certificates"
start_broker "allow_anonymous true" "cafile $WORK/ca.crt" "certfile $WORK/server.crt" "keyfile $WORK/server.key"
tls_sub() { mosquitto_sub -h 127.0.0.1 -p "$BROKER_PORT" --cafile "$WORK/ca.crt" -t "$1" -C 1 -W "$2" 2>/dev/null; }

start_bg S stream --source aravis:Fake_1 --method pharr --n 32 --listen 127.0.0.1:0 --duration 60 --name tlscam \
  --publish "mqtts://127.0.0.1:$BROKER_PORT/studio" --mqtt-cafile "$WORK/ca.crt"
has_list() { case "$(tls_sub studio/tlscam/lights 1)" in *'"format":"lightprobe.lights/1"'*) return 0 ;; esac; return 1; }
wait_until 20 has_list || fail "no list over TLS within 20 s: $(tail -1 "$WORK/S.err")"

kill_broker KILL
sleep 2
alive "$S_PID" S
restart_broker
t0=$SECONDS
wait_until 30 has_list || fail "publishing over TLS did not resume within 30 s of the broker's restart"
echo "publishing over TLS resumed $((SECONDS - t0)) s after the broker's restart"
# /metrics is refreshed every 200 ms: the count may trail the list that showed the reconnect.
reconnected_s_port() { [ "$(labelled_metric "$S_PORT" 'lightprobe_mqtt_connects_total{link="publish"}')" -ge 2 ]; }
wait_until 5 reconnected_s_port || fail "no reconnect counted"

# Broker kills in quick succession, while the stream reconnects: with libmosquitto's own
# thread restarted after each TLS loss, the reconnect raced that thread on the SSL object
# and the stream died in libssl, about once in 50 kills.
for cycle in 1 2 3 4 5 6 7 8 9 10; do
  sleep "0.$((RANDOM % 10))"; kill_broker KILL
  sleep "0.$((RANDOM % 10))"; alive "$S_PID" S; restart_broker
done
wait_until 30 has_list || fail "publishing over TLS did not resume after ten broker kills"
alive "$S_PID" S

timeout 60 "$LP" stream --source aravis:Fake_1 --method pharr --n 32 --listen 127.0.0.1:0 --duration 30 \
  --publish "mqtts://127.0.0.1:$BROKER_PORT/studio" >"$WORK/noca.out" 2>"$WORK/noca.err"; rc=$?
[ "$rc" = 2 ] || fail "a certificate from an unknown CA: exit $rc, not 2: $(tail -1 "$WORK/noca.err")"
[ "$(wc -l <"$WORK/noca.err")" = 1 ] && grep -q -- "--publish: TLS" "$WORK/noca.err" ||
  fail "a certificate from an unknown CA: not one line naming --publish: $(cat "$WORK/noca.err")"
echo "mqtt_tls: lists over TLS with --mqtt-cafile, back after a broker restart; an unknown CA refused in one line"
