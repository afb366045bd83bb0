#!/usr/bin/env bash
# Fresh machine -> every test: dependencies, then each build with its tests:
#   default   host build: unit, hil, vcan (CAN in a qemu VM) tiers
#   aarch64   firmware + C tests cross-built, run under qemu-aarch64 (label qemu)
#   armhf     the same for 32-bit ARM under qemu-arm
#   cortex-m4 model/ bare metal: freestanding check, size, tests under qemu-system-arm
#   asan      unit + hil tiers under AddressSanitizer + UndefinedBehaviorSanitizer
#   tsan      unit + hil tiers under ThreadSanitizer (loop, rings, LCM threads)
#   fuzz      libFuzzer on the CAN decoder, INI parser, command handler, log reader (45 s each)
# Extra arguments go to every ctest run (e.g. -L unit). Ends with one summary line.
set -uo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh || exit 1

total_pass=0
total_fail=0
failed_presets=()
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
  rm -f "$log"
  if [ -z "$line" ]; then
    total_fail=$((total_fail + 1))
    failed_presets+=("$preset(no tests)")
    return
  fi
  total_pass=$((total_pass + pass - fail))
  total_fail=$((total_fail + fail))
  [ "$fail" -eq 0 ] || failed_presets+=("$preset")
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
[ ${#failed_presets[@]} -eq 0 ] || echo "failing: ${failed_presets[*]}"
echo "omni4: $total_pass passed, $total_fail failed"
[ "$total_fail" -eq 0 ]
