#!/usr/bin/env bash
# Issue 22 against the real binary: a request with bytes that are not UTF-8 used to abort
# `stream` and `merge` (exit 134), with or without a token, and `merge` of a q2tree and a
# pharr stream died with "terminate called without an active exception". Here both
# streams and the merge of them must answer '/%ff' with 404 and live on, the merge must
# serve lights merged by direction and exit 0 at the end of --duration, and the token
# must be "Authorization: Bearer T" exactly (no lower-case scheme, no ?access_token=).
# Usage: server_abuse.sh LIGHTPROBE   (exit 77 = skipped: no curl)
set -uo pipefail
LP=$1
WORK=$(mktemp -d)
. "$(dirname "$0")/stream_lib.sh"
command -v curl >/dev/null || skip "curl not installed (Debian package curl)"
PIDS=()
trap 'for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null; done; wait 2>/dev/null; rm -rf "$WORK"' EXIT

start_bg A stream --source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method q2tree --n 64 --duration 40 --listen 127.0.0.1:0
start_bg B stream --source aravis:Fake_1 --exposures 0.0002,0.002,0.02 --method pharr --n 64 --duration 40 --listen 127.0.0.1:0
for p in "$A_PORT" "$B_PORT"; do
  PORT=$p wait_for_lights 15
done
start_bg M merge "http://127.0.0.1:$A_PORT" "http://127.0.0.1:$B_PORT" --n 64 --duration 6 --listen 127.0.0.1:0

for who in A B M; do
  port_var=${who}_PORT; pid_var=${who}_PID
  c=$(code "http://127.0.0.1:${!port_var}/%ff")
  [ "$c" = 404 ] || fail "$who answered /%ff with $c: $(cat "$WORK/body")"
  grep -q '"error"' "$WORK/body" || fail "$who's 404 for /%ff is not a JSON error: $(cat "$WORK/body")"
  c=$(code "http://127.0.0.1:${!port_var}/%ff%fe?x=%ff")
  [ "$c" = 404 ] || fail "$who answered /%ff%fe with $c"
  sleep 0.2
  alive "${!pid_var}" "$who"
done

# The merge of a q2tree and a pharr stream: lights merged by direction.
got=""
for _ in $(seq 50); do
  [ "$(code "http://127.0.0.1:$M_PORT/lights")" = 200 ] && got=1 && break
  sleep 0.1
done
[ -n "$got" ] || fail "the merge served no lights within 5 s: $(tail -1 "$WORK/M.err")"
grep -q '"method":"q2tree"' "$WORK/body" || fail "merged lights are not a q2tree list: $(head -c 200 "$WORK/body")"
[ "$(code "http://127.0.0.1:$M_PORT/status")" = 200 ] || fail "merge /status failed"
grep -q '"mode":"direction"' "$WORK/body" || fail "merge /status does not say it merges by direction: $(cat "$WORK/body")"
wait "$M_PID"; rc=$?
[ "$rc" = 0 ] || fail "merge exited with $rc: $(tail -2 "$WORK/M.err")"
published=$(sed -n 's/.*"published":\([0-9]*\).*/\1/p' "$WORK/M.json")
[ "${published:-0}" -gt 0 ] || fail "merge published nothing: $(cat "$WORK/M.json")"

# --n is read by a Q2-tree or direction merge: above it merged by direction, without a word;
# one pharr camera is merged light by light (index), which keeps its count: said once.
grep -q -- "--n 64 is not used" "$WORK/M.err" && fail "a direction merge said its --n was not used: $(cat "$WORK/M.err")"
start_bg N merge "http://127.0.0.1:$B_PORT" --n 20 --duration 2 --listen 127.0.0.1:0
wait "$N_PID"; rc=$?
[ "$rc" = 0 ] || fail "merge of one camera exited with $rc: $(tail -2 "$WORK/N.err")"
[ "$(grep -c -- "--n 20 is not used" "$WORK/N.err")" = 1 ] || fail "an index merge did not say once that --n is unused: $(cat "$WORK/N.err")"

# With a token: authenticated '/%ff' is a 404 too, and only the exact scheme is taken.
start_bg T stream --source aravis:Fake_1 --method pharr --n 32 --duration 30 --listen 127.0.0.1:0 --token s3cret
PORT=$T_PORT TOKEN=s3cret wait_for_lights 15
c=$(code -H "Authorization: Bearer s3cret" "http://127.0.0.1:$T_PORT/%ff")
[ "$c" = 404 ] || fail "authenticated /%ff answered $c"
alive "$T_PID" T
[ "$(code -H "Authorization: Bearer s3cret" "http://127.0.0.1:$T_PORT/lights")" = 200 ] || fail "the bearer token was refused"
[ "$(code -H "Authorization: bearer s3cret" "http://127.0.0.1:$T_PORT/lights")" = 401 ] || fail "a lower-case 'bearer' was accepted"
[ "$(code "http://127.0.0.1:$T_PORT/lights?access_token=s3cret")" = 401 ] || fail "?access_token= was accepted"
[ "$(code "http://127.0.0.1:$T_PORT/")" = 200 ] || fail "the page needs no token (it reads it from the fragment)"
echo "server_abuse: /%ff answered 404 by two streams, their merge and a stream with a token; q2tree + pharr merged by" \
  "direction ($published lists), merge exited 0; only 'Bearer <token>' accepted"
