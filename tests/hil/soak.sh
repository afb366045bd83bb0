#!/usr/bin/env bash
# Soak: omni4-fw (sim backend) at 1 kHz for OMNI4_SOAK_S seconds (default 30; 600 for the full
# soak) through real LCM (udpm, ttl=0) into lcm-logger and omni4-record (split into 1 MB parts)
# side by side, with a command stream. Checks: every sample in the omni4-record log (no seq gap, across
# the parts), the lcm-logger log well formed (its misses reported), none dropped in the
# controller, RSS flat (no leak), the loop's figures there and consistent. How fast the loop
# wakes (latency, overruns) is the machine's: printed here, measured by bench/run beside
# cyclictest; never a bound here.
# lcm-logger is Debian's C binary (liblcm-bin), called by path: the PyPI lcm package's
# lcm-logger (in .venv/bin, first on the PATH when the venv is active) is a Python wrapper
# that, started in the background of a script, ignores SIGINT and never passes it on, so
# the real logger under it never stopped. Every wait below is bounded.
set -u
BIN=$1
. "$(dirname "$0")/bounded_wait.sh"
LCM_LOGGER=${OMNI4_LCM_LOGGER:-/usr/bin/lcm-logger}
[ -x "$LCM_LOGGER" ] || { echo "FAIL: $LCM_LOGGER missing (apt-get install liblcm-bin)"; echo "0 passed, 1 failed"; exit 1; }
D=${OMNI4_SOAK_S:-30}
T=$(mktemp -d)
URL=$(test_lcm_url)  # udpm, ttl=0, a port of this test's own (bounded_wait.sh)
trap 'kill ${FW:-} ${LG:-} ${RC:-} ${DR:-} 2>/dev/null; rm -rf "$T"' EXIT
printf '[lcm]\nurl = %s\n' "$URL" > "$T/fw.ini"
"$LCM_LOGGER" --lcm-url="$URL" -c OMNI4_MOTORS -f "$T/soak.lcmlog" >/dev/null 2>&1 &
LG=$!
"$BIN/omni4-record" --lcm "$URL" --channel OMNI4_MOTORS --split-mb 1 --out "$T/rec.lcmlog" 2>"$T/rec.err" &
RC=$!
# The controller starts once the recorder has subscribed (its " <- " line): an event, not a time.
n=0
until grep -q " <- " "$T/rec.err" 2>/dev/null; do
  [ "$n" -lt 300 ] && kill -0 $RC 2>/dev/null ||
    { echo "FAIL: omni4-record did not subscribe within 30 s: $(cat "$T/rec.err")"; echo "0 passed, 1 failed"; exit 1; }
  sleep 0.1; n=$((n + 1))
done
sleep 0.5  # lcm-logger, started first, is not waited for: its misses are reported, not failed
"$BIN/omni4-fw" --config "$T/fw.ini" --duration "$D" > "$T/fw.log" 2>&1 &
FW=$!
# A robot that is being driven: velocity commands at 20 Hz, 0.5 m/s, through LCM.
"$BIN/omni4-ident" run --lcm "$URL" --out "$T/cmds.lcmlog" --only step --hold 60 --settle 1 >/dev/null 2>&1 &
DR=$!
rss() { awk '/VmRSS/ { print $2 }' "/proc/$FW/status" 2>/dev/null; }
sleep 5
rss0=$(rss)
sleep $((D > 10 ? D - 7 : 3))
rss1=$(rss)
hung=0
bounded_wait $FW 30 "omni4-fw --duration $D did not end on its own" || [ $? -ne 124 ] || hung=1
kill -INT $DR 2>/dev/null
bounded_wait $DR 10 "omni4-ident run after SIGINT" || [ $? -ne 124 ] || hung=1
sleep 0.5
kill -INT $LG $RC
bounded_wait $LG 10 "$LCM_LOGGER after SIGINT" || [ $? -ne 124 ] || hung=1
bounded_wait $RC 10 "omni4-record after SIGINT"; rrc=$?
[ $rrc -ne 124 ] || hung=1
cat "$T/fw.log"
check=$("$BIN/log_check" "$T/soak.lcmlog")
crc=$?
echo "lcm-logger log: $check"
parts=$(ls "$T"/rec.lcmlog.* | wc -l)
rcheck=$("$BIN/log_check" "$T"/rec.lcmlog.*)
rcrc=$?
echo "omni4-record log ($parts parts of ~1 MB): $rcheck"
rmotors=$(sed -n 's/motors \([0-9]*\),.*/\1/p' <<<"$rcheck")
ticks=$(sed -n 's/.*omni4-fw: \([0-9]*\) ticks.*/\1/p' "$T/fw.log")
dropped=$(sed -n 's/.*log dropped \([0-9]*\).*/\1/p' "$T/fw.log")
motors=$(sed -n 's/motors \([0-9]*\),.*/\1/p' <<<"$check")
growth=$(( ${rss1:-0} - ${rss0:-0} ))
echo "soak ${D} s: ticks $ticks, logged $motors, dropped $dropped, RSS ${rss0} kB at 5 s -> ${rss1} kB near the end (growth ${growth} kB)"
fail=$hung
# lcm-logger keeps LCM's default 30-message queue (docs/deployment.md, "Why not lcm-logger"): on a busy
# machine it misses samples, which is why omni4-record exists. Its log must be well formed (no
# duplicates, readable); the misses are reported. omni4-record must miss none.
ldups=$(sed -n 's/.*duplicates \([0-9]*\).*/\1/p' <<<"$check")
lgaps=$(sed -n 's/.*gaps \([0-9]*\),.*/\1/p' <<<"$check")
echo "lcm-logger: $(( ${ticks:-0} - ${motors:-0} )) of $ticks samples missed in $lgaps gaps (not a failure: see above)"
[ "${ldups:-1}" -eq 0 ] && [ "$crc" -le 1 ] && [ "${motors:-0}" -gt 0 ] ||
  { echo "FAIL: lcm-logger log unreadable or with duplicates (log_check status $crc)"; fail=1; }
[ "${dropped:-1}" -eq 0 ] || { echo "FAIL: samples dropped in the controller"; fail=1; }
[ "$rcrc" -eq 0 ] && [ "$rrc" -eq 0 ] && [ "${rmotors:-0}" -ge $(( ${ticks:-1} - 5 )) ] && [ "$parts" -ge 2 ] ||
  { echo "FAIL: omni4-record: status $rrc, log check $rcrc, $rmotors of $ticks, $parts parts"; fail=1; }
[ "$growth" -lt 512 ] || { echo "FAIL: RSS grew by $growth kB"; fail=1; }
# Loop timing, not real-time here (no SCHED_FIFO, a shared 2-core machine): measured p50
# 66-67 us, p99 175-314 us, 11-15 overruns and 34-51 ticks short in 10 s (0.1-0.5 %); a
# parallel compile pushes p99 to ~4 ms and overruns to ~2 %. Those are the machine's figures
# (bench/run measures them beside cyclictest): printed, not bounded. Checked: the summary has
# them, and they are consistent (p50 <= p99, ticks > 0).
overruns=$(sed -n 's/.* ticks, \([0-9]*\) overruns.*/\1/p' "$T/fw.log")
p50=$(sed -n 's/.*latency p50 \([0-9]*\) us.*/\1/p' "$T/fw.log")
p99=$(sed -n 's/.*p99 \([0-9]*\) us.*/\1/p' "$T/fw.log")
echo "loop: $overruns overruns, p50 $p50 us, p99 $p99 us, $ticks of $((D * 1000)) ticks"
awk -v o="${overruns:-x}" -v a="${p50:-x}" -v b="${p99:-x}" -v t="${ticks:-0}" -v d="$D" 'BEGIN {
  if (o !~ /^[0-9]+$/ || a !~ /^[0-9]+$/ || b !~ /^[0-9]+$/) { print "FAIL: no loop figures in the omni4-fw summary"; exit 1 }
  if (a > b || t <= 0) { printf "FAIL: inconsistent loop figures: p50 %d us, p99 %d us, %d ticks\n", a, b, t; exit 1 }
  exit 0 }' || fail=1
[ $fail -eq 0 ] && echo "1 passed, 0 failed" || echo "0 passed, 1 failed"
exit $fail
