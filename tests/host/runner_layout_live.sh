#!/usr/bin/env bash
# The experiment runner drives the wheels the controller describes: omni4-fw (sim backend) on a
# three-wheel robot ([model] wheels = 3 at 0/120/240 deg), omni4-ident run over real LCM (udpm,
# ttl=0) with no --robot:
# - the run takes the layout from the controller's OMNI4_ROBOT and says so;
# - every step drives the layout's least-norm pattern: no command refused (FAULT_CMD_REJECTED
#   never set), slot 3 of every OMNI4_CMD and OMNI4_MOTORS voltage 0 V, the three wheels driven
#   (the paper's pattern has slot 3 non-zero: the controller refuses it for three wheels);
# - a --robot naming another layout than the controller's is refused with one line, exit 2,
#   and no log left.
set -u
BIN=$1
PY=$2
. "$(dirname "$0")/../hil/bounded_wait.sh"
T=$(mktemp -d)
URL=$(test_lcm_url) # udpm, ttl=0, a port of this test's own (bounded_wait.sh)
trap 'kill ${FW:-} 2>/dev/null; rm -rf "$T"' EXIT
fail=0
check() { # check OK WHAT
  if [ "$1" = 0 ]; then echo "ok   $2"; else echo "FAIL $2"; fail=$((fail + 1)); fi
}
cat > "$T/fw.ini" <<INI
[lcm]
url = $URL
[control]
cmd_timeout_ms = 300
[model]
wheels = 3
wheel_angle_0 = 0
wheel_angle_1 = 120
wheel_angle_2 = 240
INI
printf '[model]\nd = 0.089\nr = 0.0325\nl = 5\nM = 2.34\n' > "$T/paper.ini"
"$BIN/omni4-fw" --config "$T/fw.ini" --duration 60 -q &
FW=$!
sleep 0.5
bounded_run 60 "omni4-ident run (9 steps of 0.4 s)" -- \
  "$BIN/omni4-ident" run --lcm "$URL" --out "$T/live.lcmlog" --only step --hold 0.4 \
  --settle 0.4 2> "$T/run.err"
rc=$?
check $rc "omni4-ident run with no --robot: exit $rc"
grep -q "3 wheels at 0/120/240 deg" "$T/run.err"
check $? "the run names the controller's layout: $(grep -o '3 wheels at [^(]*' "$T/run.err")"
bounded_run 30 "omni4-ident run --robot (another layout)" -- \
  "$BIN/omni4-ident" run --lcm "$URL" --out "$T/wrong.lcmlog" --robot "$T/paper.ini" \
  --only step 2> "$T/wrong.err"
rc2=$?
[ $rc2 -eq 2 ] && grep -q "the controller runs 3 wheels" "$T/wrong.err" && [ ! -e "$T/wrong.lcmlog" ]
check $? "--robot with the paper's layout on a three-wheel controller: exit $rc2, one line, no log: $(head -c 200 "$T/wrong.err")"
kill -INT $FW
bounded_wait $FW 10 "omni4-fw after SIGINT"
check $? "omni4-fw exits 0 after SIGINT"
PYTHONPATH="$PY" "$(dirname "$0")/../../.venv/bin/python" - "$T/live.lcmlog" <<'PY'
import sys
import lcm
import omni4
cmd_v3, mot_v3, driven, rejected, n_cmd, n_mot = 0.0, 0.0, [0.0] * 3, 0, 0, 0
for ev in lcm.EventLog(sys.argv[1], "r"):
    if ev.channel == "OMNI4_CMD":
        c = omni4.command_t.decode(ev.data)
        if c.mode == omni4.command_t.MODE_VOLTAGE:
            n_cmd += 1
            cmd_v3 = max(cmd_v3, abs(c.voltage[3]))
    elif ev.channel == "OMNI4_MOTORS":
        m = omni4.motors_t.decode(ev.data)
        n_mot += 1
        mot_v3 = max(mot_v3, abs(m.voltage[3]))
        driven = [max(d, abs(v)) for d, v in zip(driven, m.voltage[:3])]
        rejected += bool(m.faults & omni4.motors_t.FAULT_CMD_REJECTED)
ok = n_cmd > 0 and cmd_v3 == 0.0 and mot_v3 == 0.0 and min(driven) > 1.0 and rejected == 0
print(("ok   " if ok else "FAIL ") + f"{n_cmd} VOLTAGE commands, slot 3 at most {cmd_v3} V; "
      f"{n_mot} OMNI4_MOTORS: slot 3 at most {mot_v3} V, wheels 0-2 up to "
      + "/".join(f"{d:.2f}" for d in driven) + f" V, {rejected} with FAULT_CMD_REJECTED")
sys.exit(0 if ok else 1)
PY
check $? "the recorded run drives the three wheels alone, nothing refused"
if [ $fail -eq 0 ]; then echo "1 passed, 0 failed"; else echo "0 passed, 1 failed"; exit 1; fi
