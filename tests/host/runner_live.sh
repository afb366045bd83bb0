#!/usr/bin/env bash
# The experiment runner against the real controller binary over real LCM (udpm, ttl=0):
# omni4-fw on the sim backend, omni4-ident run recording, then identify the steps' log parts.
set -u
BIN=$1
. "$(dirname "$0")/../hil/bounded_wait.sh"
T=$(mktemp -d)
PORT=$((7700 + RANDOM % 200))
URL="udpm://239.255.76.67:$PORT?ttl=0"
trap 'kill ${FW:-} 2>/dev/null; rm -rf "$T"' EXIT
printf '[lcm]\nurl = %s\n[control]\ncmd_timeout_ms = 300\n' "$URL" > "$T/fw.ini"
"$BIN/omni4-fw" --config "$T/fw.ini" --duration 60 -q &
FW=$!
sleep 0.5
bounded_run 60 "omni4-ident run (9 steps of 0.6 s)" -- \
  "$BIN/omni4-ident" run --lcm "$URL" --out "$T/live.lcmlog" --only step --hold 0.6 --settle 0.6
rc=$?
kill -INT $FW
bounded_wait $FW 10 "omni4-fw after SIGINT"
fwrc=$?
[ $fwrc -eq 0 ] || { echo "FAIL: omni4-fw exited $fwrc after SIGINT"; echo "0 passed, 1 failed"; exit 1; }
[ $rc -eq 0 ] || { echo "FAIL: runner exited $rc"; echo "0 passed, 1 failed"; exit 1; }
out=$(bounded_run 60 "omni4-ident validate" -- "$BIN/omni4-ident" validate --params /dev/null --json "$T/v.json" "$T/live.lcmlog" 2>&1)
# /dev/null is an empty INI: Table III, the simulated robot itself.
echo "$out"
if grep -q "validation on 9 step runs" <<<"$out" && grep -q '"v": {"e_max"' "$T/v.json"; then
  echo "1 passed, 0 failed"
else
  echo "FAIL: the recorded log does not hold the 9 step runs"
  echo "0 passed, 1 failed"
  exit 1
fi
