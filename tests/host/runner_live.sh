#!/usr/bin/env bash
# The experiment runner against the real controller binary over real LCM (udpm, ttl=0):
# omni4-fw on the sim backend, omni4-ident run recording, then identify the steps' log parts.
set -u
BIN=$1
. "$(dirname "$0")/../hil/bounded_wait.sh"
T=$(mktemp -d)
URL=$(test_lcm_url)  # udpm, ttl=0, a port of this test's own (bounded_wait.sh)
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
# The 9 step runs are validated, except those whose ticks were so unevenly timed (a loaded
# machine: the loop late again and again) that the encoders' smoothing cannot see the motion;
# validate names those, and at least one run is validated.
runs=$(sed -n 's/^validation on \([0-9]*\) step runs.*/\1/p' <<<"$out")
timed=$(grep -c "samples evenly timed (late ticks or lost samples)" <<<"$out")
other=$(grep "^not validated: step" <<<"$out" | grep -vc "samples evenly timed")
echo "step runs validated: ${runs:-0}; not validated for the loop's timing: $timed; for other reasons: $other"
[ "${runs:-0}" -ge 1 ] && [ "$other" -eq 0 ] && [ $((runs + timed)) -eq 9 ] ||
  { echo "FAIL: the recorded log does not hold the 9 step runs"; echo "0 passed, 1 failed"; exit 1; }
# The figures, against the paper's Table IV (final parameters: e_max v 0.061 m/s, vn 0.068 m/s,
# w 2.504 rad/s; sigma 0.024, 0.026, 0.732) and tighter where this test's runs on the simulated
# robot allow. Live LCM timing and loop overruns on a busy machine move them: worst measured
# (quiet machine, then beside two sanitizer builds) e_max 0.0281, 0.0361, 0.258; sigma 0.0054,
# 0.0082, 0.061; |mean| 0.0040, 0.0105, 0.050. Bounds ~2.5-3x those, never above Table IV,
# times OMNI4_TEST_TIME_SCALE (the sanitizer builds). A late tick no longer moves them: the
# simulated plant catches up with the loop's clock (robot_sim_follow_clock); before it did, the
# plant advanced one period per executed tick while the log's clock ran on (v e_max 0.108 at
# a load average of 20, 0.066 under ASan); with it, at a load average of 21: v e_max 0.0065,
# sigma 0.0012; w e_max 0.069.
/usr/bin/python3 - "$T/v.json" "${OMNI4_TEST_TIME_SCALE:-1}" <<'PY' || { echo "0 passed, 1 failed"; exit 1; }
import json, sys
v = json.load(open(sys.argv[1]))
scale = max(1.0, float(sys.argv[2]))
# axis: (e_max, |mean|, sigma) bounds = min(Table IV, 2.5 x worst measured)
bounds = {"v": (0.061, 0.012, 0.0135), "vn": (0.068, 0.03, 0.024), "w": (0.75, 0.15, 0.18)}
fail = 0
for axis, (emax, mean, sigma) in bounds.items():
    got = v[axis]
    for key, lim, val in (("e_max", emax * scale, got["e_max"]),
                          ("|mean|", mean * scale, abs(got["e_mean"])),
                          ("sigma", sigma * scale, got["sigma"])):
        ok = val == val and val <= lim
        print(f"{'ok' if ok else 'FAIL'}: {axis} {key} {val:.4f} (bound {lim:.4g})")
        fail += not ok
sys.exit(1 if fail else 0)
PY
echo "1 passed, 0 failed"
