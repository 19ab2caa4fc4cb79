#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite (ctest); then the fuzz
# targets for a bounded time each (scripts/fuzz.sh) and the suite once more under ASan and
# UBSan (scripts/sanitize.sh). Every stage runs even when an earlier one failed; the exit
# status is non-zero when any did. Each stage ends with a "<stage>: N passed, M failed"
# line, and the times of all stages close the run.
# LIGHTPROBE_SKIP_FUZZ=1 / LIGHTPROBE_SKIP_SANITIZE=1 leave those stages out.
# Real data is read from ../shared/data beside the repository.
set -euo pipefail
cd "$(dirname "$0")/.."
status=0
times=""
failed_stages=""
stage() {  # name command...: runs it, notes its time and whether it failed
  local name=$1 start=$SECONDS
  shift
  local mark=""
  "$@" || { status=1; mark=" FAILED"; failed_stages="$failed_stages $name "; echo "test: stage $name failed" >&2; }
  times="$times $name $((SECONDS - start)) s$mark,"
}
stage build bash scripts/build.sh
stage ctest ctest --test-dir build --output-on-failure -j "$(nproc)" --timeout 900
[ "${LIGHTPROBE_SKIP_FUZZ:-0}" = 1 ] || stage fuzz bash scripts/fuzz.sh
# CI stops a run at 5,400 s. The sanitizer stage (a second, instrumented build and the suite
# again) starts only if half of LIGHTPROBE_CI_SECONDS is left, and its tests stop at the
# budget's end, saying so (scripts/sanitize.sh).
budget=${LIGHTPROBE_CI_SECONDS:-5000}
if [ "${LIGHTPROBE_SKIP_SANITIZE:-0}" != 1 ]; then
  if [ "$SECONDS" -gt $((budget / 2)) ]; then
    echo "sanitize: skipped: $SECONDS s of the ${budget} s CI budget spent before it"
  else
    export LIGHTPROBE_SANITIZE_DEADLINE=$(($(date +%s) + budget - SECONDS))
    stage sanitize bash scripts/sanitize.sh
  fi
fi
# What failed, once more at the very end: CI may show only the tail of a long log.
case $failed_stages in *" ctest "*) echo "test: ctest failed: $(cut -d: -f2 build/Testing/Temporary/LastTestsFailed.log 2>/dev/null | tr '\n' ' ')" ;; esac
case $failed_stages in *" fuzz "*) grep -h -A3 ' FAILED ' build-fuzz/logs/summary.txt 2>/dev/null | sed 's/^/test: /' || true ;; esac
# A sanitizer run cut short at the budget writes no LastTestsFailed.log: its log names them.
case $failed_stages in *" sanitize "*) echo "test: sanitize failed: $( { cut -d: -f2 build-asan/Testing/Temporary/LastTestsFailed.log 2>/dev/null ||
  sed -n 's/^ *[0-9]*\/[0-9]* Test *#[0-9]*: \([^ ]*\) .*\*\*\*\(Failed\|Exception\|Timeout\).*/\1/p' build-asan/ctest.log 2>/dev/null; } | tr '\n' ' ')" ;; esac
echo "test: times:${times%,}"
exit $status
