#!/usr/bin/env bash
# Fresh machine -> every test: dependencies, then each build with its tests:
#   default   host build: unit, hil, vcan (CAN in a qemu VM) tiers
#   aarch64   firmware + C tests cross-built, run under qemu-aarch64 (label qemu)
#   armhf     the same for 32-bit ARM under qemu-arm
#   cortex-m4 model + controller core bare metal: freestanding checks, sizes, the model test and
#             the core's HIL scenarios under qemu-system-arm (compared with the host's)
#   asan      unit + hil tiers under AddressSanitizer + UndefinedBehaviorSanitizer
#   tsan      unit + hil tiers under ThreadSanitizer (loop, rings, LCM threads)
#   fuzz      libFuzzer on the CAN decoder, INI parser, command handler, log reader (30 s each)
# Extra arguments go to every ctest run (e.g. -L unit). Ends with one summary line.
set -uo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh || exit 1

total_pass=0
total_fail=0
failed_presets=()
recap=$(mktemp)
trap 'rm -f "$recap"' EXIT
# The last lines of each failed test's output, kept for the end of the run: whoever reads only
# the tail of a long run still sees why a test failed.
recap_failures() {
  local preset=$1 log=$2 dir=build
  [ "$preset" = default ] || dir=build-$preset
  local name
  for name in $(sed -n '/The following tests FAILED:/,$p' "$log" |
                sed -n 's/^[[:space:]]*[0-9]* - \([^ ]*\) .*/\1/p'); do
    {
      echo "---- $preset: $name (last 25 lines of its output) ----"
      awk -v n="$name" '$0 ~ ("^[0-9]+/[0-9]+ Testing: " n "$") {on = 1; next}
                        on && index($0, "\"" n "\" end time") == 1 {exit}
                        on {print}' "$dir/Testing/Temporary/LastTest.log" 2>/dev/null | tail -25
    } >>"$recap"
  done
}
run_preset() {
  local preset=$1
  shift
  echo "==== $preset ===="
  if ! { cmake --preset "$preset" >/dev/null && cmake --build --preset "$preset"; }; then
    echo "$preset: build failed"
    total_fail=$((total_fail + 1))
    failed_presets+=("$preset(build)")
    return
  fi
  local log
  log=$(mktemp)
  ctest --preset "$preset" "$@" 2>&1 | tee "$log"
  local line pass fail
  line=$(grep -E "tests passed, [0-9]+ tests? failed out of [0-9]+" "$log" | tail -1)
  fail=$(sed -n 's/.*, \([0-9]*\) tests\{0,1\} failed out of.*/\1/p' <<<"$line")
  pass=$(sed -n 's/.* failed out of \([0-9]*\).*/\1/p' <<<"$line")
  if [ -z "$line" ]; then
    rm -f "$log"
    total_fail=$((total_fail + 1))
    failed_presets+=("$preset(no tests)")
    return
  fi
  total_pass=$((total_pass + pass - fail))
  total_fail=$((total_fail + fail))
  if [ "$fail" -ne 0 ]; then
    failed_presets+=("$preset")
    recap_failures "$preset" "$log"
  fi
  rm -f "$log"
}

run_preset default "$@"
for arch in aarch64 armhf; do
  if bash scripts/sysroot.sh "$arch"; then
    run_preset "$arch" "$@"
  else
    total_fail=$((total_fail + 1))
    failed_presets+=("$arch(sysroot)")
  fi
done
run_preset cortex-m4 "$@"
run_preset asan "$@"
run_preset tsan "$@"
run_preset fuzz "$@"

echo
[ -s "$recap" ] && cat "$recap"
[ ${#failed_presets[@]} -eq 0 ] || echo "failing: ${failed_presets[*]}"
echo "omni4: $total_pass passed, $total_fail failed"
[ "$total_fail" -eq 0 ]
