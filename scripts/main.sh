#!/usr/bin/env bash
# Fresh machine -> the main job: the simulated Table III robot runs the paper's experiments
# (omni4-sim, firmware loop + plant, LCM event log), then omni4-ident identifies the model,
# validates it (Table IV) and draws the plots. Everything lands in out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --main
cmake --preset default >/dev/null
cmake --build --preset default
OUT=${OMNI4_OUT:-out}
mkdir -p "$OUT"
BIN=build/bin

# What is measured, not identified: d, r, l, M (the paper's robot).
cat > "$OUT/base.ini" <<'INI'
; measured by hand: wheel distance, wheel radius, gearbox, mass
[model]
d = 0.089
r = 0.0325
l = 5
M = 2.34
INI
# The simulated robot: Table III (the default [model]).
printf '; the paper'"'"'s Table III\n' > "$OUT/table3.ini"

echo "== 1. simulated robot runs the paper's experiments =="
"$BIN/omni4-sim" --params "$OUT/table3.ini" --experiments --speed max --out "$OUT/sim.lcmlog"
echo
echo "== 2. identification (true values: Table III) =="
"$BIN/omni4-ident" identify --robot "$OUT/base.ini" --out "$OUT/params.ini" \
  --truth "$OUT/table3.ini" --bootstrap 200 --csv "$OUT/csv" "$OUT/sim.lcmlog"
echo
echo "== 3. validation: identified vs Table III parameters, beside the paper's Table IV =="
"$BIN/omni4-ident" validate --params "$OUT/params.ini" --params "$OUT/table3.ini" \
  --json "$OUT/validation.json" --csv "$OUT/csv" "$OUT/sim.lcmlog"
echo
echo "== 4. plots and report =="
# The project's venv: it has the omni4 package (omni4.read_log draws the log's raw series).
.venv/bin/python host-tools/plots/omni4_report.py "$OUT/csv" "$OUT/report" --json "$OUT/validation.json" \
  --log "$OUT/sim.lcmlog" --params "$OUT/params.ini"
echo "report: $OUT/report/report.md"
echo
echo "== 5. the log for Foxglove (MCAP, with the identified model's prediction beside the encoders) =="
.venv/bin/omni4-mcap "$OUT/sim.lcmlog" --params "$OUT/params.ini" --out "$OUT/sim.mcap"
echo "Foxglove: open $OUT/sim.mcap, then import the layout docs/foxglove-layout.json"
