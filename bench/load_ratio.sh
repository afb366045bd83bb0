#!/usr/bin/env bash
# Each test's wall time under a background load beside its unloaded time, and beside a CPU-bound
# peer measured in the same run: a program that only computes, as many copies at once as ctest
# runs tests. A test whose ratio sits well above the peer's waits on something the load slows
# more than computation (a poll, a sleep sized for an idle machine, a lock); a test at the peer's
# ratio is CPU-bound and slowed by its share of the cores alone. Prints; fails only when a test
# fails or the load cannot start.
#
# usage: bench/load_ratio.sh [--preset NAME] [--load "COMMAND"] [--min-s S] [-- CTEST-ARGS...]
#   --preset  a configured and built CMake test preset (default: default)
#   --load    the background load (default: stress-ng --cpu 2 --vm 1)
#   --min-s   list only tests taking at least S s unloaded (default: 1)
#   CTEST-ARGS go to both ctest runs, e.g. -- -L unit
set -uo pipefail
cd "$(dirname "$0")/.."
PRESET=default
LOAD="stress-ng --cpu 2 --vm 1"
MIN_S=1
while [ $# -gt 0 ]; do
  case $1 in
    --preset) PRESET=$2; shift 2 ;;
    --load) LOAD=$2; shift 2 ;;
    --min-s) MIN_S=$2; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "load_ratio: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
command -v "${LOAD%% *}" >/dev/null ||
  { echo "load_ratio: '${LOAD%% *}' not found (apt-get install stress-ng)" >&2; exit 2; }
JOBS=$(python3 -c '
import json, sys
p = {t["name"]: t for t in json.load(open("CMakePresets.json"))["testPresets"]}
print(p.get(sys.argv[1], {}).get("execution", {}).get("jobs", 1))' "$PRESET") ||
  { echo "load_ratio: cannot read CMakePresets.json" >&2; exit 2; }
W=$(mktemp -d)
LOAD_PID=
stop_load() {
  [ -n "$LOAD_PID" ] && kill -- -"$LOAD_PID" 2>/dev/null && wait "$LOAD_PID" 2>/dev/null
  LOAD_PID=
}
trap 'stop_load; rm -rf "$W"' EXIT
trap 'exit 130' INT TERM

# The peer: a fixed amount of floating-point work, no I/O, no allocation (about 3 s alone).
peer() {
  local i
  for ((i = 0; i < JOBS; i++)); do
    /usr/bin/time -f %e -o "$W/peer.$i" python3 -c '
x = 0.0
for i in range(40_000_000):
    x += i * 1e-9' &
  done
  wait
  cat "$W"/peer.* | sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'
}
run_tests() {  # $1 = output file
  ctest --preset "$PRESET" "$@" >"$1" 2>&1
}

echo "machine: $(nproc) cores; preset $PRESET, $JOBS test(s) at once; load: $LOAD"
echo "[1/4] peer, unloaded ($JOBS at once)"
PEER_U=$(peer)
echo "[2/4] ctest --preset $PRESET, unloaded"
run_tests "$W/u.txt" "$@"
U_RC=$?
echo "[3/4] the same under the load"
setsid $LOAD >/dev/null 2>&1 &
LOAD_PID=$!
sleep 2
kill -0 "$LOAD_PID" 2>/dev/null || { echo "load_ratio: the load exited at once" >&2; exit 2; }
run_tests "$W/s.txt" "$@"
S_RC=$?
echo "[4/4] peer under the load"
PEER_S=$(peer)
stop_load

python3 - "$W/u.txt" "$W/s.txt" "$PEER_U" "$PEER_S" "$MIN_S" <<'PY'
import re, sys
def times(path):
    t = {}
    for line in open(path, errors="replace"):
        m = re.search(r"Test +#\d+: (\S+) \.+.*?([\d.]+) sec", line)
        if m:
            t[m.group(1)] = float(m.group(2))
    return t
u, s = times(sys.argv[1]), times(sys.argv[2])
peer_u, peer_s, min_s = float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
peer = peer_s / peer_u
rows = sorted(((s[k] / u[k], k) for k in u if k in s and u[k] >= min_s), reverse=True)
print(f"{'test':44s} {'unloaded_s':>10s} {'loaded_s':>9s} {'ratio':>6s}  vs peer")
for r, k in rows:
    print(f"{k:44s} {u[k]:10.1f} {s[k]:9.1f} {r:6.2f}  {r / peer:5.2f}")
print(f"{'peer (CPU-bound, computes only)':44s} {peer_u:10.2f} {peer_s:9.2f} {peer:6.2f}  1.00")
over2 = sum(r > 2 for r, _ in rows)
over_peer = [k for r, k in rows if r > 1.25 * peer]
print(f"tests >= {min_s:g} s unloaded: {len(rows)}; over 2x: {over2}; "
      f"over 1.25x the peer's ratio: {len(over_peer)}{' (' + ', '.join(over_peer) + ')' if over_peer else ''}")
PY
for f in u s; do grep -E "tests passed|FAILED|\*\*\*" "$W/$f.txt" | sed "s/^/$f: /"; done
[ "$U_RC" = 0 ] && [ "$S_RC" = 0 ] || { echo "load_ratio: a test failed (see above)"; exit 1; }
