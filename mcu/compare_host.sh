#!/bin/bash
# compare_host.sh HOST_BINARY QEMU_COMMAND...
# Runs the core's scenarios on this host and on the Cortex-M4 (qemu) and fails unless every
# result line is the same in both (cost lines, which differ by nature, are left out).
set -u
host=$1
shift
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
results() { grep -E ' (ok|FAILED) |^[0-9]+ passed' "$1"; }
timeout 60 "$host" --no-cost > "$t/host.txt" 2>&1
hrc=$?
timeout 300 "$@" > "$t/mcu.txt" 2>&1
mrc=$?
echo "host (exit $hrc):"
results "$t/host.txt"
echo "cortex-m4 (exit $mrc):"
cat "$t/mcu.txt"
if [ $hrc -ne 0 ] || [ $mrc -ne 0 ]; then
	echo "FAIL: a run failed (host $hrc, cortex-m4 $mrc)"
	exit 1
fi
if [ "$(results "$t/host.txt" | wc -l)" -lt 8 ]; then
	echo "FAIL: the host run printed fewer than 7 scenario lines and a summary"
	exit 1
fi
if ! diff <(results "$t/host.txt") <(results "$t/mcu.txt"); then
	echo "FAIL: the Cortex-M4 results differ from the host's (lines above: < host, > cortex-m4)"
	exit 1
fi
echo "the Cortex-M4 results equal the host's, line for line"
