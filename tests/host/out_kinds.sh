#!/usr/bin/env bash
# Outputs the user names, per kind of target, for every tool that writes one (docs/design.md,
# "Output files"): a device node made with mknod in this test's own folder (/dev/full's 1,7:
# "No space left on device" as one line, status 1, never "wrote", the node kept; /dev/null's
# 1,3: written in place), a FIFO whose reader must receive the output, a symbolic link (kept, its
# target replaced with the right contents), a directory (refused, untouched). Needs CAP_MKNOD.
# usage: out_kinds.sh BUILD/bin SOURCE_DIR [native|python]: the C/C++ tools, or the Python
# ones (omni4-mcap, omni4-rosbag, the report); both without the third argument.
set -u
BIN=$1
SRC=$2
PART=${3:-all}
part() { [ "$PART" = all ] || [ "$PART" = "$1" ]; }
VENV=$SRC/.venv/bin
. "$(dirname "$0")/../hil/bounded_wait.sh"
T=$(mktemp -d)
READERS=()
cleanup() {
  local p
  for p in "${READERS[@]}"; do kill "$p" 2>/dev/null; done
  rm -rf "$T"
}
trap cleanup EXIT
fail=0
pass=0
PORT=$((9000 + RANDOM % 1000))
URL="udpm://239.255.76.67:$PORT?ttl=0"

ok() { echo "ok: $1"; pass=$((pass + 1)); }
bad() { echo "FAIL: $1"; fail=$((fail + 1)); }
check() { local what=$1; shift; if "$@"; then ok "$what"; else bad "$what"; fi; }

# run WHAT STATUS PATTERN -- command...: the status, PATTERN in stderr; a failure is one line
# on stderr and nothing says "wrote" (but a file written before, matching $WROTE_BEFORE).
run() {
  local what=$1 want=$2 pattern=$3 rc
  shift 4
  bounded_run 60 "$what" -- "$@" >"$T/stdout" 2>"$T/stderr"
  rc=$?
  if [ "$rc" -ne "$want" ] || { [ -n "$pattern" ] && ! grep -q -- "$pattern" "$T/stderr"; }; then
    bad "$what -> status $rc (want $want): $(cat "$T/stderr" "$T/stdout" | head -5)"
    return 1
  fi
  if [ "$want" -ne 0 ] && { [ "$(grep -vc '^omni4-mcap: .*truncated' "$T/stderr")" -ne 1 ] ||
    cat "$T/stdout" "$T/stderr" | grep -v "${WROTE_BEFORE:-^$}" | grep -q wrote; }; then
    bad "$what: not one line, or says wrote: $(cat "$T/stderr" "$T/stdout" | head -5)"
    return 1
  fi
  ok "$what -> $rc${pattern:+: $(grep -m1 -- "$pattern" "$T/stderr")}"
}

# kinds DIR: full, null (device nodes), fifo, link -> real/target (holding "old"), dir.
kinds() {
  mkdir -p "$1/real" "$1/dir"
  mknod "$1/full" c 1 7 && mknod "$1/null" c 1 3 && mkfifo "$1/fifo" || {
    bad "mknod/mkfifo in $1 (needs CAP_MKNOD)"
    exit 1
  }
  echo old >"$1/real/target"
  ln -s real/target "$1/link"
}

# reader DIR: copies DIR/fifo to DIR/fifo.out in the background (bounded).
reader() {
  timeout 60 cat "$1/fifo" >"$1/fifo.out" &
  READERS+=($!)
  RPID=$!
}

# reader_done DIR WHAT: waits for the reader; one the tool never wrote to (still waiting for a
# writer) is given an end of file, or stopped if the FIFO is gone, so that nothing hangs.
reader_done() {
  sleep 0.2
  if kill -0 "$RPID" 2>/dev/null; then
    if [ -p "$1/fifo" ]; then timeout 5 sh -c ": >'$1/fifo'"; else kill "$RPID"; fi
  fi
  bounded_wait "$RPID" 20 "$2: the FIFO's reader" >/dev/null
}

node_is() { [ "$(stat -c '%F %t,%T' "$1")" = "$2" ]; }
link_kept() { [ -L "$1/link" ] && [ "$(readlink "$1/link")" = real/target ]; }
dir_untouched() { [ -d "$1/dir" ] && [ -z "$(ls -A "$1/dir")" ]; }
starts_lcm() { [ "$(head -c 4 "$1" | od -An -tx1 | tr -d ' \n')" = eda1da01 ]; }
starts_mcap() { [ "$(head -c 5 "$1" | od -An -c | tr -d ' \n')" = '211MCAP' ]; }

# every_kind TOOL CONTENT_CHECK -- command with @OUT@ for the output: the five kinds.
every_kind() {
  local tool=$1 content=$2 d="$T/$1" a
  shift 3
  kinds "$d"
  local -a cmd=("$@")
  for a in full null fifo link dir; do
    local -a c=("${cmd[@]/@OUT@/$d/$a}")
    case $a in
    full)
      run "$tool to /dev/full's 1,7" 1 "$d/full: No space left on device" -- "${c[@]}" &&
        check "$tool: the full node kept" node_is "$d/full" "character special file 1,7"
      ;;
    null)
      run "$tool to /dev/null's 1,3" 0 "" -- "${c[@]}" &&
        check "$tool: the null node kept" node_is "$d/null" "character special file 1,3"
      ;;
    fifo)
      reader "$d"
      run "$tool to a FIFO" 0 "" -- "${c[@]}"
      reader_done "$d" "$tool"
      check "$tool: the FIFO's reader got the output" "$content" "$d/fifo.out"
      check "$tool: the FIFO kept" test -p "$d/fifo"
      ;;
    link)
      run "$tool to a symbolic link" 0 "" -- "${c[@]}" &&
        check "$tool: the link kept" link_kept "$d" &&
        check "$tool: the link's target replaced" "$content" "$d/real/target"
      check "$tool: nothing left beside the link or its target" test \
        "$(ls -A "$d" "$d/real" | tr '\n' ' ')" = "$d: dir fifo fifo.out full link null real  $d/real: target "
      ;;
    dir)
      run "$tool to a directory" 1 "dir: Is a directory" -- "${c[@]}" &&
        check "$tool: the directory untouched" dir_untouched "$d"
      ;;
    esac
  done
}

printf '[model]\nd = 0.089\nr = 0.0325\nl = 5\nM = 2.34\n' >"$T/base.ini"
printf '; Table III\n' >"$T/t3.ini"
bounded_run 120 "omni4-sim --experiments" -- "$BIN/omni4-sim" --experiments --speed max \
  --out "$T/full.lcmlog" -q >/dev/null || bad "omni4-sim --experiments"
bounded_run 60 "omni4-sim --duration 1" -- "$BIN/omni4-sim" --duration 1 --out "$T/short.lcmlog" \
  -q >/dev/null || bad "omni4-sim --duration 1"

is_ini() { grep -q '^\[model\]' "$1" && grep -q '^R = ' "$1"; }
is_json() { grep -q '"e_max"' "$1"; }
if part native; then
every_kind identify is_ini -- "$BIN/omni4-ident" identify --robot "$T/base.ini" --out @OUT@ "$T/full.lcmlog"
every_kind validate is_json -- "$BIN/omni4-ident" validate --params "$T/t3.ini" --json @OUT@ "$T/full.lcmlog"
every_kind sim starts_lcm -- "$BIN/omni4-sim" --duration 1 -q --out @OUT@

# --csv DIR: a file named as the folder is refused; a CSV that is a symbolic link has its target
# replaced; a CSV that is a full device fails the run.
echo keep >"$T/csvfile"
run "identify --csv FILE" 1 "csvfile: not a folder" -- "$BIN/omni4-ident" identify \
  --robot "$T/base.ini" --out "$T/c1.ini" --csv "$T/csvfile" "$T/full.lcmlog"
check "identify --csv FILE: the file untouched" grep -qx keep "$T/csvfile"
mkdir -p "$T/csv" "$T/csvreal"
echo old >"$T/csvreal/params.csv"
ln -s ../csvreal/params.csv "$T/csv/params.csv"
run "identify --csv DIR with a linked CSV" 0 "" -- "$BIN/omni4-ident" identify \
  --robot "$T/base.ini" --out "$T/c2.ini" --csv "$T/csv" "$T/full.lcmlog"
check "identify --csv: the CSV's link kept" test -L "$T/csv/params.csv"
check "identify --csv: the link's target written" grep -q '^param,method,value' "$T/csvreal/params.csv"
mknod "$T/csv/validation.csv" c 1 7
WROTE_BEFORE="wrote $T/c.json" run "validate --csv DIR with a full device CSV" 1 "validation.csv: No space left on device" -- \
  "$BIN/omni4-ident" validate --params "$T/t3.ini" --json "$T/c.json" --csv "$T/csv" "$T/full.lcmlog"

# omni4-record: a FIFO (a reader streams the log) and a full device, with messages on the bus.
# No timing: the messages are published once the recorder says it has subscribed, and it is
# stopped (SIGTERM) once its progress line says it has written all 30, or that its writes fail
# (LCM's receive thread may not yet have taken from the socket what was sent: a SIGTERM right
# after the publisher lost them on a loaded machine).
# record_start OUT: omni4-record to OUT in the background (its pid in rec, its stderr in
# $T/rec.err), waited for until it says it has subscribed (bounded: 60 s) or has exited.
record_start() {
  local n=0
  "$BIN/omni4-record" --lcm "$URL" --out "$1" >/dev/null 2>"$T/rec.err" &
  rec=$!
  while ! grep -q ' <- ' "$T/rec.err" && kill -0 "$rec" 2>/dev/null && [ "$n" -lt 600 ]; do
    sleep 0.1
    n=$((n + 1))
  done
}
# record_published OUT STATUS PATTERN
record_published() {
  local out=$1 want=$2 pattern=$3 rec n=0 rc
  record_start "$out"
  bounded_run 60 publisher -- "$VENV/python" -c '
import sys, lcm
bus = lcm.LCM(sys.argv[1])
for _ in range(30):
    bus.publish("OMNI4_TEST", b"x" * 4000)' "$URL"
  n=0
  while ! grep -Eq ' 30 messages|writes failing' "$T/rec.err" && kill -0 "$rec" 2>/dev/null &&
    [ "$n" -lt 600 ]; do
    sleep 0.1
    n=$((n + 1))
  done
  kill -TERM "$rec" 2>/dev/null
  bounded_wait "$rec" 30 "omni4-record --out $out"
  rc=$?
  if [ "$rc" -eq "$want" ] && grep -q -- "$pattern" "$T/rec.err"; then
    ok "omni4-record to $(basename "$out") -> $rc: $(grep -m1 -- "$pattern" "$T/rec.err")"
  else
    bad "omni4-record to $(basename "$out") -> $rc (want $want): $(tail -3 "$T/rec.err")"
  fi
}
R="$T/record"
kinds "$R"
reader "$R"
record_published "$R/fifo" 0 "30 messages"
reader_done "$R" omni4-record
check "omni4-record: the FIFO's reader got the log" starts_lcm "$R/fifo.out"
check "omni4-record: the reader got every message" test "$(stat -c %s "$R/fifo.out")" -ge \
  $((30 * (28 + 10 + 4000)))
# A full device: the first failed write stops the recorder by itself (no signal), one line
# after its start line, "PATH: No space left on device", status 1. Messages are published until
# it has exited (bounded).
record_stops_on_full() {
  local out=$1 rec n=0 rc
  record_start "$out"
  bounded_run 120 publisher -- "$VENV/python" -c '
import os, sys, time, lcm
bus = lcm.LCM(sys.argv[1])
def running(pid):  # a recorder that has exited is a zombie until the shell waits for it
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False
for _ in range(6000):
    if not running(sys.argv[2]):
        break
    bus.publish("OMNI4_TEST", b"x" * 4000)
    time.sleep(0.01)' "$URL" "$rec"
  bounded_wait "$rec" 30 "omni4-record --out $out, stopping by itself"
  rc=$?
  local after
  after=$(grep -v ' <- ' "$T/rec.err")
  if [ "$rc" -eq 1 ] && [ "$(printf '%s\n' "$after" | wc -l)" -eq 1 ] &&
    printf '%s\n' "$after" | grep -q "^omni4-record: $out: No space left on device"; then
    ok "omni4-record to $(basename "$out") stops at the first failed write -> 1: $after"
  else
    bad "omni4-record to $(basename "$out") -> $rc (want 1, one line): $(tail -3 "$T/rec.err")"
  fi
}
record_stops_on_full "$R/full"
check "omni4-record: the full node kept" node_is "$R/full" "character special file 1,7"
run "omni4-record to a link to a file" 1 "link exists; not overwriting it" -- \
  "$BIN/omni4-record" --lcm "$URL" --out "$R/link" --duration 1 -q
check "omni4-record: the link's target untouched" grep -qx old "$R/real/target"
run "omni4-record to a directory" 1 "dir: Is a directory" -- \
  "$BIN/omni4-record" --lcm "$URL" --out "$R/dir" --duration 1 -q

fi

if part python; then
every_kind mcap starts_mcap -- "$VENV/omni4-mcap" -q --out @OUT@ "$T/short.lcmlog"

# omni4-rosbag --out DIR: a new folder through a link; an existing file or non-empty folder is
# refused and left as it was; an empty folder is used; a missing log is one line.
B="$T/bag"
mkdir -p "$B/full" "$B/empty"
echo keep >"$B/file"
echo keep >"$B/full/mine"
run "omni4-rosbag, a missing log" 1 "^omni4-rosbag: cannot read $B/none.lcmlog: No such file or directory$" -- \
  "$VENV/omni4-rosbag" "$B/none.lcmlog" --out "$B/new"
check "omni4-rosbag, a missing log: no bag" test ! -e "$B/new"
run "omni4-rosbag --out FILE" 1 "file: exists and is not a folder" -- \
  "$VENV/omni4-rosbag" "$T/short.lcmlog" --out "$B/file"
check "omni4-rosbag --out FILE: untouched" grep -qx keep "$B/file"
run "omni4-rosbag --out non-empty folder" 1 "full: exists and is not empty" -- \
  "$VENV/omni4-rosbag" "$T/short.lcmlog" --out "$B/full"
check "omni4-rosbag --out non-empty folder: untouched" test "$(ls -A "$B/full")" = mine
run "omni4-rosbag --out empty folder" 0 "" -- "$VENV/omni4-rosbag" "$T/short.lcmlog" --out "$B/empty" -q
check "omni4-rosbag --out empty folder: the bag in it" test -s "$B/empty/metadata.yaml"
ln -s later "$B/link"
run "omni4-rosbag --out a link to a new folder" 0 "" -- "$VENV/omni4-rosbag" "$T/short.lcmlog" --out "$B/link" -q
check "omni4-rosbag: the link kept, the bag at its target" test -L "$B/link" -a -s "$B/later/metadata.yaml"
check "omni4-rosbag: no work folder left" test -z "$(ls -A "$B" | grep tmp)"

# The report's OUT_DIR: report.md a symbolic link (kept, target written), a figure a full device
# (one line, status 1, the node kept), OUT_DIR an existing file (refused, untouched).
P="$T/report"
mkdir -p "$P/out" "$P/real"
bounded_run 60 "identify --csv" -- "$BIN/omni4-ident" identify --robot "$T/base.ini" \
  --out "$P/p.ini" --csv "$P/csv" "$T/full.lcmlog" >/dev/null || bad "identify --csv for the report"
echo old >"$P/real/report.md"
ln -s ../real/report.md "$P/out/report.md"
run "report with report.md a link" 0 "" -- "$VENV/python" "$SRC/host-tools/plots/omni4_report.py" \
  "$P/csv" "$P/out"
check "report: the link kept, its target written" test -L "$P/out/report.md" -a \
  "$(head -1 "$P/real/report.md")" = "# omni4 identification report"
rm "$P/out/motor_test.png"
mknod "$P/out/motor_test.png" c 1 7
run "report with a figure a full device" 1 "motor_test.png: No space left on device" -- \
  "$VENV/python" "$SRC/host-tools/plots/omni4_report.py" "$P/csv" "$P/out"
check "report: the full node kept" node_is "$P/out/motor_test.png" "character special file 1,7"
echo keep >"$P/file"
run "report OUT_DIR a file" 1 "file: exists and is not a folder" -- \
  "$VENV/python" "$SRC/host-tools/plots/omni4_report.py" "$P/csv" "$P/file"
check "report: OUT_DIR file untouched" grep -qx keep "$P/file"

fi

echo "out_kinds $PART: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
