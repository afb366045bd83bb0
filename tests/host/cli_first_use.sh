#!/usr/bin/env bash
# What a new user meets first, on bad input: one line on stderr, nothing on stdout, and the
# documented status (2 for a configuration or usage error, 1 at run time, 0 for --help and
# --version). omni4-fw's --config (a directory, a file that cannot be read, a section met
# twice), omni4-ident's value check (FILE:LINE), omni4-config-keys' --help and --version, and
# omni4-fw with motor = socketcan where the kernel has no CAN (or, on a kernel with CAN, an
# interface that does not exist): the error says what to check.
set -u
BIN=$1
. "$(dirname "$0")/../hil/bounded_wait.sh"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
URL=$(test_lcm_url)  # a bus of its own: nothing here may meet a robot on the default URL
fail=0
pass=0

# expect STATUS STREAM LINES PATTERN -- command...: the status, and STREAM (stdout or stderr)
# holds exactly LINES lines with one matching PATTERN (grep -E); the other stream is empty.
expect() {
  local want=$1 stream=$2 lines=$3 pattern=$4
  shift 5
  bounded_run 30 "$*" -- "$@" >"$T/out" 2>"$T/err"
  local rc=$? main=$T/out other=$T/err
  [ "$stream" = stderr ] && main=$T/err other=$T/out
  if [ "$rc" -ne "$want" ] || [ "$(wc -l <"$main")" -ne "$lines" ] || [ -s "$other" ] ||
    ! grep -qE -- "$pattern" "$main"; then
    echo "FAIL: $* -> status $rc (want $want), stdout: $(cat "$T/out"), stderr: $(cat "$T/err")"
    fail=$((fail + 1))
  else
    echo "ok: $* -> $rc: $(grep -E -- "$pattern" "$main" | head -1)"
    pass=$((pass + 1))
  fi
}

mkdir "$T/robot.d"
printf '[lcm]\nurl = %s\n[model]\n[model]\n' "$URL" > "$T/twice.ini"
printf '[lcm]\nurl = %s\n[hal]\nmotor = socketcan\n[can]\niface = omni4none0\n' "$URL" > "$T/can.ini"
printf '[model]\nd = -0.089\nr = 0.0325\nl = 5\nKv = 0.0259\nKt = 0.0259\nR = 4.3\nM = 2.34\nJ = 0.02\nBv = 0.5\nBvn = 0.6\nBw = 0.01\nCv = 1.8\nCvn = 2.2\nCw = 0.13\n' > "$T/negd.ini"

expect 2 stderr 1 "^omni4-fw: $T/robot.d: cannot read: Is a directory$" -- \
  "$BIN/omni4-fw" --config "$T/robot.d" --duration 1
# a file that opens but cannot be read (offset 0 of a process's memory is not mapped)
expect 2 stderr 1 "^omni4-fw: /proc/self/mem: cannot read: Input/output error$" -- \
  "$BIN/omni4-fw" --config /proc/self/mem --duration 1
expect 2 stderr 1 "^omni4-fw: $T/twice.ini:4: duplicate section \[model\]$" -- \
  "$BIN/omni4-fw" --config "$T/twice.ini" --duration 1
expect 2 stderr 1 "^omni4-ident: $T/negd.ini:2: out of range value for 'd' in \[model\]: -0.089 outside \[0.01, 10\]$" -- \
  "$BIN/omni4-ident" validate --params "$T/negd.ini" --json "$T/v.json" "$T/none.lcmlog"

expect 0 stdout 9 "^usage: omni4-config-keys --markdown \| --json$" -- "$BIN/omni4-config-keys" --help
expect 0 stdout 1 "^omni4-config-keys [0-9]+\.[0-9]+\.[0-9]+" -- "$BIN/omni4-config-keys" --version
expect 2 stderr 1 "give one of --markdown or --json \(see omni4-config-keys --help\)" -- \
  "$BIN/omni4-config-keys"
expect 2 stderr 1 "'--jso': give the whole option name" -- "$BIN/omni4-config-keys" --jso

# Whether this kernel has CAN, asked of the kernel itself (Python's socket module).
if python3 -c 'import socket; socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)' \
  2>/dev/null; then
  expect 1 stderr 1 "CAN interface 'omni4none0': No such device \(no network interface of that name: 'ip link' lists them; \[can\] iface names it; for a test bus see docs/can.md\)$" -- \
    "$BIN/omni4-fw" --config "$T/can.ini" --duration 1
else
  expect 1 stderr 1 "CAN interface 'omni4none0': Address family not supported by protocol \(this kernel has no CAN support: load the can and can_raw modules, or use a kernel with CONFIG_CAN; for a test bus see docs/can.md\)$" -- \
    "$BIN/omni4-fw" --config "$T/can.ini" --duration 1
fi
# omni4-motorsim opens the bus through the same adapter and says the same.
expect 1 stderr 1 "^omni4-motorsim: CAN interface 'omni4none0': (No such device \(no network interface|Address family not supported by protocol \(this kernel has no CAN support)" -- \
  "$BIN/omni4-motorsim" --iface omni4none0

# omni4-ident run records as omni4-record does: an existing log is refused and kept whole.
echo "a recorded run" > "$T/old.lcmlog"
expect 1 stderr 1 "^omni4-ident run: $T/old.lcmlog exists; not overwriting it$" -- \
  "$BIN/omni4-ident" run --lcm "$URL" --out "$T/old.lcmlog" --only coast
if [ "$(cat "$T/old.lcmlog")" != "a recorded run" ]; then
  echo "FAIL: omni4-ident run changed an existing log"; fail=$((fail + 1))
else
  echo "ok: omni4-ident run left the existing log as it was"; pass=$((pass + 1))
fi

echo "cli_first_use: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
