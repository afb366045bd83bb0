#!/bin/bash
# repeat_costs.sh QEMU_COMMAND...: runs the Cortex-M4 image three times in a row and fails
# unless every figure of its cost lines (whole tick, controller, est_step, est_camera: means and
# maxima, in instructions) is within 1 % of the first run's. The meter's counter cannot glitch
# (main.c's self-test checks it against known spans); this checks that what it measures is the
# same from run to run. Costs are instruction counts of the emulator, not times: no machine
# speed enters.
set -u
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
figures() { grep -E '^(cost|estimator cost):' "$1" | sed -E 's/sizeof.*//' | grep -oE '[0-9]+'; }
for run in 1 2 3; do
	if ! timeout 300 "$@" > "$t/run$run.txt" 2>&1; then
		echo "FAIL: run $run exited non-zero:"
		cat "$t/run$run.txt"
		exit 1
	fi
	grep -E '^(cost|estimator cost|cortex-m4: meter)' "$t/run$run.txt" | sed "s/^/run $run: /"
	figures "$t/run$run.txt" > "$t/fig$run.txt"
done
if [ "$(wc -l < "$t/fig1.txt")" -lt 10 ]; then
	echo "FAIL: fewer than 10 figures in the cost lines of run 1"
	exit 1
fi
for run in 2 3; do
	if ! paste "$t/fig1.txt" "$t/fig$run.txt" | awk -v run=$run '
		NF != 2 { print "FAIL: run " run " has another number of figures"; bad = 1; next }
		{ d = $2 - $1; if (d < 0) d = -d
		  if (d > 0.01 * $1) { print "FAIL: figure " NR ": " $1 " in run 1, " $2 " in run " run; bad = 1 } }
		END { exit bad }'; then
		exit 1
	fi
done
echo "the cost figures of three runs agree within 1 %"
