#!/usr/bin/env bash
# CLI contract of omni4-sim / omni4-ident / omni4-fw / omni4-record on bad input: a clear one-line error, a non-zero
# status, and no half-written output file. Every program that opens LCM here is on this test's
# own URL (test_lcm_url): a robot running on the default URL on this machine changes nothing.
set -u
BIN=$1
. "$(dirname "$0")/../hil/bounded_wait.sh"
URL=$(test_lcm_url)
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fail=0
pass=0

# expect STATUS PATTERN -- command...
expect() {
  local want=$1 pattern=$2
  shift 3
  local out rc
  out=$(bounded_run 60 "$*" -- "$@" 2>&1)
  rc=$?
  if [ "$rc" -ne "$want" ] || ! grep -q -- "$pattern" <<<"$out"; then
    echo "FAIL: $* -> status $rc (want $want), output: $out"
    fail=$((fail + 1))
  else
    echo "ok: $* -> $rc: $(grep -- "$pattern" <<<"$out" | head -1)"
    pass=$((pass + 1))
  fi
}

printf '[model]\nd = 0.089\nr = 0.0325\nl = 5\nM = 2.34\n' > "$T/base.ini"
printf '[model]\nd = 0.089\n' > "$T/nomass.ini"
printf '[model]\nd = 0.089\nr = 0.0325\nl = 5\nKv = 0.0259\nKt = 0.0259\nR = -4.3\nM = 2.34\nJ = 0.02\nBv = 0.5\nBvn = 0.6\nBw = 0.01\nCv = 1.8\nCvn = 2.2\nCw = 0.13\n' > "$T/negR.ini"
printf '[model]\nR = 4.3\nbogus = 1\n' > "$T/bogus.ini"
printf '; Table III\n' > "$T/t3.ini"

bounded_run 60 "omni4-sim --duration 2" -- "$BIN/omni4-sim" --duration 2 --out "$T/nomarks.lcmlog" -q >/dev/null ||
  { echo "FAIL: omni4-sim --duration 2"; fail=$((fail + 1)); }
bounded_run 120 "omni4-sim --experiments" -- "$BIN/omni4-sim" --experiments --out "$T/full.lcmlog" -q >/dev/null ||
  { echo "FAIL: omni4-sim --experiments"; fail=$((fail + 1)); }
head -c 100000 "$T/full.lcmlog" > "$T/short.lcmlog"

expect 2 "out is required" -- "$BIN/omni4-sim" --experiments
expect 2 "nothing to do" -- "$BIN/omni4-sim" --out "$T/x.lcmlog"
expect 2 "speed must be" -- "$BIN/omni4-sim" --experiments --speed fast --out "$T/x.lcmlog"
expect 2 "bogus.ini:3: unknown key 'bogus' in \[model\]" -- "$BIN/omni4-sim" --params "$T/bogus.ini" --experiments --out "$T/x.lcmlog"
expect 2 "out of range value for 'R' in \[model\]: -.* outside \[0.001, 1000\]" -- "$BIN/omni4-sim" --params "$T/negR.ini" --experiments --out "$T/x.lcmlog"
expect 1 "cannot create log" -- "$BIN/omni4-sim" --experiments --out /nonexistent/dir/x.lcmlog
expect 1 "no experiment segments" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out "$T/p1.ini" "$T/nomarks.lcmlog"
expect 1 "no 'motor' segments" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out "$T/p2.ini" "$T/short.lcmlog"
expect 2 "must give the measured 'r'" -- "$BIN/omni4-ident" identify --robot "$T/nomass.ini" --out "$T/p3.ini" "$T/full.lcmlog"
expect 1 "No such file" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out "$T/p4.ini" "$T/missing.lcmlog"
expect 2 "bootstrap: Value -3 not in range" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out "$T/p4.ini" --bootstrap -3 "$T/full.lcmlog"
expect 2 "out of range value for 'R'" -- "$BIN/omni4-ident" validate --params "$T/negR.ini" --json "$T/v.json" "$T/full.lcmlog"
expect 1 "no experiment segments" -- "$BIN/omni4-ident" validate --params "$T/t3.ini" --json "$T/v2.json" "$T/nomarks.lcmlog"
# Two robot files of different wheel layouts and a log that describes none (written before
# OMNI4_ROBOT): which robot the log is of cannot be told.
/usr/bin/python3 "$(dirname "$0")/lcmlog_edit.py" "$T/full.lcmlog" "$T/prerobot.lcmlog" --drop OMNI4_ROBOT
printf '[model]\nwheels = 3\nwheel_angle_0 = 0\nwheel_angle_1 = 120\nwheel_angle_2 = 240\n' > "$T/three.ini"
expect 2 "describe different wheel layouts and the log describes none" -- "$BIN/omni4-ident" validate --params "$T/t3.ini" --params "$T/three.ini" --json "$T/v3.json" "$T/prerobot.lcmlog"
[ ! -e "$T/v3.json" ] || { echo "FAIL: v3.json written"; fail=$((fail + 1)); }
expect 0 "wrote" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out "$T/good.ini" "$T/full.lcmlog"
# Thin data are said: with the camera, Bv and Bvn rest on experiment 3 through Kv (SE 1.5-2.0 %
# on this log; 1.2-1.5 % when the motor test drove axis patterns), flagged THIN and named in a
# warning; with the encoders nothing is thin.
expect 0 "warning: thin data: Bv ±[12].[0-9] %, Bvn ±1.[0-9] %" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out "$T/cam.ini" --velocity camera "$T/full.lcmlog"
thin_enc=$("$BIN/omni4-ident" identify --robot "$T/base.ini" --out "$T/enc.ini" "$T/full.lcmlog" 2>&1)
grep -q "thin data" <<<"$thin_enc" && { echo "FAIL: thin data reported with the encoders: $(grep 'thin data' <<<"$thin_enc")"; fail=$((fail + 1)); }
# Marks but no motor samples (a run with no controller on the bus) is said as such.
/usr/bin/python3 "$(dirname "$0")/lcmlog_edit.py" "$T/full.lcmlog" "$T/marksonly.lcmlog" --keep OMNI4_EXPERIMENT
expect 1 "carry 91 OMNI4_EXPERIMENT marks but no OMNI4_MOTORS samples" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out "$T/p1.ini" "$T/marksonly.lcmlog"
# An axis without step runs is "no data" in the table and null in the JSON, never a perfect 0.
/usr/bin/python3 "$(dirname "$0")/lcmlog_edit.py" "$T/full.lcmlog" "$T/now.lcmlog" --drop-steps w
expect 0 "w     | no data" -- "$BIN/omni4-ident" validate --params "$T/good.ini" --json "$T/now.json" "$T/now.lcmlog"
expect 0 '"w": {"e_max": null, "e_mean": null, "sigma": null, "n": 0}' -- cat "$T/now.json"
expect 0 '"v": {"e_max": 0.00' -- cat "$T/now.json"
expect 0 "Usage\|usage" -- "$BIN/omni4-ident" --help
# One house style: one line naming the tool, --version on every tool, no test hooks in help.
expect 2 "^omni4-ident: --robot is required (see omni4-ident --help)$" -- "$BIN/omni4-ident" identify --out "$T/p5.ini" "$T/full.lcmlog"
expect 2 "^omni4-ident: unknown command 'idnetify' (identify, validate or run" -- "$BIN/omni4-ident" idnetify
for tool in omni4-ident omni4-sim omni4-motorsim; do
  expect 0 "^$tool [0-9]*\.[0-9]*\.[0-9]*" -- "$BIN/$tool" --version
done
motorsim_help=$("$BIN/omni4-motorsim" --help 2>&1)
if grep -q -- "--replay-at\|--corrupt-at" <<<"$motorsim_help"; then
  echo "FAIL: omni4-motorsim --help shows its test hooks"; fail=$((fail + 1))
else
  echo "ok: omni4-motorsim --help shows no test hooks"; pass=$((pass + 1))
fi
# The simulated drives' options: one line, status 2, before any socket is opened.
expect 2 "^omni4-motorsim: --protocol: canopen not in {omni4,vesc,odrive} (see omni4-motorsim --help)$" -- "$BIN/omni4-motorsim" --protocol canopen
expect 2 "^omni4-motorsim: --ids: At least 4 required" -- "$BIN/omni4-motorsim" --protocol vesc --ids 1,2,3
expect 2 "^omni4-motorsim: --ids and --nodes must be four different numbers$" -- "$BIN/omni4-motorsim" --protocol odrive --nodes 1,2,2,3
expect 2 "^omni4-motorsim: --fault-node: Value 4 not in range 0 to 3" -- "$BIN/omni4-motorsim" --protocol vesc --fault-at-s 1 --fault-node 4
expect 2 "^omni4-motorsim: --iq-ms: Value -1 not in range 0 to 1000 (see omni4-motorsim --help)$" -- "$BIN/omni4-motorsim" --protocol odrive --iq-ms -1
expect 2 "^omni4-motorsim: --encoder-ms: Value 0 not in range 1 to 1000 (see omni4-motorsim --help)$" -- "$BIN/omni4-motorsim" --protocol odrive --encoder-ms 0
# An output that cannot be written is refused before any log is read.
expect 1 "^omni4-ident: /nonexistent/x.ini: /nonexistent: No such file or directory$" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out /nonexistent/x.ini "$T/full.lcmlog"
expect 1 "^omni4-ident: /nonexistent/v.json: /nonexistent: No such file or directory$" -- "$BIN/omni4-ident" validate --params "$T/t3.ini" --json /nonexistent/v.json "$T/full.lcmlog"
expect 0 "usage" -- "$BIN/omni4-fw" --help
expect 2 "cannot open" -- "$BIN/omni4-fw" --config "$T/none.ini"
expect 0 "^omni4-fw [0-9]*\.[0-9]*\.[0-9]*" -- "$BIN/omni4-fw" --version
expect 2 "^omni4-fw: '--conf': give the whole option name" -- "$BIN/omni4-fw" --conf "$T/t3.ini"
expect 2 "^omni4-fw: '--bogus' is not an option or lacks its value" -- "$BIN/omni4-fw" --bogus
# The crash test's timer is a test build's (omni4-fw-test-hooks), not an option of omni4-fw.
expect 2 "^omni4-fw: '--crash-after' is not an option or lacks its value" -- "$BIN/omni4-fw" --crash-after 1 --config "$T/t3.ini"
# LCM unavailable at start: a clear error, nothing runs.
printf '[lcm]\nurl = udpm://300.1.1.1:7667?ttl=0\n' > "$T/badlcm.ini"
expect 1 "cannot open LCM at 'udpm://300.1.1.1" -- "$BIN/omni4-fw" --config "$T/badlcm.ini" --duration 1
# [can] bitrate: the protocol at 1 kHz needs 43.2 % of 1 Mbit/s (worst-case stuffing); the bus
# may be at most half used, so 800 kbit/s (54 %) is refused before any interface is opened.
printf '[hal]\nmotor = socketcan\nlines = none\n[can]\nbitrate = 800000\n[lcm]\nurl = %s\n' "$URL" > "$T/slowcan.ini"
expect 1 "\[can\] bitrate 800000 bit/s is too slow for \[loop\] rate_hz 1000: the motor-driver protocol would take 54 % of the bus" -- "$BIN/omni4-fw" --config "$T/slowcan.ini" --duration 1
# A layout that cannot drive the body (two wheels on one line): refused by the INI's check,
# naming model.wheels.
printf '[hal]\nmotor = sim\n[model]\nwheels = 3\nwheel_angle_1 = 180\nwheel_angle_2 = 0\n' > "$T/w3line.ini"
expect 2 "model.*wheels.*drive v, vn and w" -- "$BIN/omni4-fw" --config "$T/w3line.ini"
# The packaged default config parses; it then asks for the robot's CAN interface (on this
# test's URL: the packaged file has no [lcm] section, so one is added to a copy).
{ cat "$(dirname "$0")/../../packaging/robot.ini"; printf '\n[lcm]\nurl = %s\n' "$URL"; } > "$T/packaged.ini"
expect 1 "CAN interface 'can0'" -- "$BIN/omni4-fw" --config "$T/packaged.ini"
# omni4-sim interrupted: status 130, one line, and a log whose every event is whole.
"$BIN/omni4-sim" --experiments --speed 1 --out "$T/int.lcmlog" -q >"$T/int.out" 2>&1 &
sim=$!
# interrupted once it is writing its log (an event, not a time: a loaded machine starts it late);
# the log is written to int.lcmlog.tmpPID and renamed into place when the run ends
writing() { for f in "$T"/int.lcmlog.tmp*; do [ -s "$f" ] && return 0; done; return 1; }
n=0
while ! writing && [ "$n" -lt 600 ] && kill -0 "$sim" 2>/dev/null; do
  sleep 0.1; n=$((n + 1))
done
sleep 0.5
kill -INT "$sim"
bounded_wait "$sim" 20 "omni4-sim after SIGINT"
rc=$?
if [ "$rc" -ne 130 ] || ! grep -q "omni4-sim: interrupted after" "$T/int.out"; then
  echo "FAIL: omni4-sim after SIGINT -> status $rc, output: $(cat "$T/int.out")"; fail=$((fail + 1))
else
  echo "ok: omni4-sim after SIGINT -> 130: $(grep interrupted "$T/int.out")"; pass=$((pass + 1))
fi
int_read=$("$BIN/omni4-ident" validate --params "$T/t3.ini" --json "$T/int.json" "$T/int.lcmlog" 2>&1)
if grep -q "skipped" <<<"$int_read" || ! grep -q "int.lcmlog: [0-9]* events" <<<"$int_read"; then
  echo "FAIL: the interrupted log is not whole: $int_read"; fail=$((fail + 1))
else
  echo "ok: the interrupted log reads whole: $(grep events <<<"$int_read")"; pass=$((pass + 1))
fi
# A run with no controller on its URL: one line naming the URL within 5 s, status 1, no log.
expect 1 "no OMNI4_MOTORS on $URL within 5 s" -- "$BIN/omni4-ident" run --lcm "$URL" --out "$T/norobot.lcmlog" --only coast
[ -e "$T/norobot.lcmlog" ] && { echo "FAIL: omni4-ident run left a log without a robot"; fail=$((fail + 1)); }
# omni4-record: bad options, an existing file (kept intact), an unwritable place, no LCM.
expect 0 "usage" -- "$BIN/omni4-record" --help
expect 2 "^omni4-record: --out FILE is required (see omni4-record --help)$" -- "$BIN/omni4-record"
expect 2 "^omni4-record: '--bogus' is not an option or lacks its value" -- "$BIN/omni4-record" --bogus
expect 2 "^omni4-record: '--dur': give the whole option name" -- "$BIN/omni4-record" --dur 5 --out "$T/r.lcmlog"
expect 0 "^omni4-record [0-9]*\.[0-9]*\.[0-9]*" -- "$BIN/omni4-record" --version
expect 2 "duration: 'soon' is not a number" -- "$BIN/omni4-record" --out "$T/r.lcmlog" --duration soon
expect 2 "split-mb: '0' is not a number" -- "$BIN/omni4-record" --out "$T/r.lcmlog" --split-mb 0
echo keep > "$T/old.lcmlog"
expect 1 "old.lcmlog exists; not overwriting it" -- "$BIN/omni4-record" --lcm "$URL" --out "$T/old.lcmlog" --duration 1
grep -qx keep "$T/old.lcmlog" || { echo "FAIL: old.lcmlog was touched"; fail=$((fail + 1)); }
expect 1 "nodir/r.lcmlog: No such file or directory" -- "$BIN/omni4-record" --lcm "$URL" --out "$T/nodir/r.lcmlog" --duration 1
expect 1 "cannot open LCM at 'udpm://300.1.1.1" -- "$BIN/omni4-record" --lcm "udpm://300.1.1.1:7667?ttl=0" --out "$T/r2.lcmlog" --duration 1
[ -e "$T/r.lcmlog" ] || [ -e "$T/r2.lcmlog" ] && { echo "FAIL: omni4-record wrote a log despite the error"; fail=$((fail + 1)); }

for f in p1 p2 p3 p4; do
  if ls "$T/$f.ini"* >/dev/null 2>&1; then
    echo "FAIL: $f.ini (or a temporary) was written despite the error"
    fail=$((fail + 1))
  fi
done
[ -f "$T/v.json" ] && { echo "FAIL: v.json written despite the error"; fail=$((fail + 1)); }
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
