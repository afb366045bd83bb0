#!/usr/bin/env bash
# The style check: (a) every C and C++ file under FORMAT_DIRS is laid out as .clang-format says
# (clang-format --dry-run --Werror: nothing is changed; fix with `.venv/bin/clang-format -i
# FILE`), (b) no production function under LENGTH_DIRS is longer than MAX_LINES lines (lizard).
# One line per offender; exit 0 when clean, 1 otherwise, 2 when a tool is missing.
# Both tools are pinned in the .venv (scripts/setup.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

# Folders whose C and C++ files must be formatted: every one that holds C or C++.
FORMAT_DIRS="core config drivers firmware sil mcu model tests lcmtypes host-tools bench"
# Production folders whose functions must stay within MAX_LINES (tests/ and the model's and
# mcu's test programs are not production).
LENGTH_DIRS="host-tools core config drivers firmware sil mcu model/src python/omni4"
# Test programs inside the production folders (lizard --exclude patterns).
LENGTH_EXCLUDE=("*/tests/*" "*/test/*" "*/test_*")
MAX_LINES=80

CLANG_FORMAT=.venv/bin/clang-format
LIZARD=.venv/bin/lizard
for tool in "$CLANG_FORMAT" "$LIZARD"; do
  if [ ! -x "$tool" ]; then
    echo "check_style: $tool missing (run scripts/setup.sh)" >&2
    exit 2
  fi
done

status=0

# (a) Layout. One line per file that clang-format would change (its first differing line).
mapfile -d '' files < <(find $FORMAT_DIRS -type f \
  \( -name '*.c' -o -name '*.h' -o -name '*.cpp' -o -name '*.hpp' \) -print0 | sort -z)
if [ "${#files[@]}" -gt 0 ]; then
  if ! out=$("$CLANG_FORMAT" --dry-run --Werror "${files[@]}" 2>&1); then
    # clang-format prints FILE:LINE:COL: error: code should be clang-formatted ... per place.
    printf '%s\n' "$out" | grep -E '^[^ ].*:[0-9]+:[0-9]+: error:' \
      | awk -F: '!seen[$1]++ { printf "format: %s:%s: not as .clang-format lays it out\n", $1, $2 }'
    status=1
  fi
fi

# (b) Function length. lizard -w prints one warning line per function over a threshold; the
# cyclomatic complexity threshold is set out of reach so that only length counts.
excludes=()
for pattern in "${LENGTH_EXCLUDE[@]}"; do excludes+=(-x "$pattern"); done
# shellcheck disable=SC2086
if ! out=$("$LIZARD" -L "$MAX_LINES" -C 1000 -w "${excludes[@]}" $LENGTH_DIRS 2>&1); then
  printf '%s\n' "$out" | grep -E ': warning: ' \
    | sed -E 's/^([^:]+:[0-9]+): warning: ([^ ]+) has .* ([0-9]+) length.*/length: \1: \2 is \3 lines (max '"$MAX_LINES"')/'
  status=1
fi

if [ "$status" -eq 0 ]; then
  echo "check_style: format ($FORMAT_DIRS) and function length <= $MAX_LINES ($LENGTH_DIRS): clean"
fi
exit "$status"
