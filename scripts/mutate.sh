#!/usr/bin/env bash
# Mutation check: plants one-line bugs (scripts/mutations.txt) one at a time in a copy of the
# committed tree, rebuilds, runs the tests that cover the code, and reports which mutations the
# tests caught (a test failed or the build broke) and which survived. The whole list (385) took
# 75 minutes on a 2-core machine beside a CI run; not part of scripts/test.sh.
#
#   bash scripts/mutate.sh                 every mutation on the list
#   bash scripts/mutate.sh -k estop        only those whose id contains "estop"
#   bash scripts/mutate.sh --list          print the list and exit
#   bash scripts/mutate.sh --keep DIR      build in DIR and keep it (default: a temporary folder)
#
# scripts/mutations.txt, one mutation per line, fields separated by " | ":
#   id | file | text | replacement | ctest regex of the tests that must catch it
# The text must occur exactly once in the file (else the mutation is reported STALE and
# counts as a failure of this script: the list has to follow the code). Exit status 0 only if
# every mutation was caught.
set -uo pipefail
cd "$(dirname "$0")/.."
root=$PWD
list=scripts/mutations.txt
filter="" keep="" only_list=0
while [ $# -gt 0 ]; do
  case "$1" in
    -k) filter=${2:?-k needs a pattern}; shift 2 ;;
    --keep) keep=${2:?--keep needs a folder}; shift 2 ;;
    --list) only_list=1; shift ;;
    -h|--help) sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "mutate.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -f "$list" ] || { echo "mutate.sh: $list not found" >&2; exit 2; }

ids=() files=() texts=() repls=() regexes=()
# Fields are split at " | " only (C's "||" and "|" inside a field stay).
parsed=$(python3 - "$list" <<'EOF'
import sys
for n, line in enumerate(open(sys.argv[1]), 1):
    line = line.rstrip("\n")
    if not line.strip() or line.lstrip().startswith("#"):
        continue
    f = [x.strip() for x in line.split(" | ")]
    if len(f) != 5 or not all(f):
        sys.exit(f"mutate.sh: {sys.argv[1]}:{n}: expected 5 fields separated by ' | '")
    print("\x1f".join(f))
EOF
) || exit 2
while IFS=$'\x1f' read -r id file text repl regex; do
  [ -n "$id" ] || continue
  [ -z "$filter" ] || [[ "$id" == *"$filter"* ]] || continue
  ids+=("$id") files+=("$file") texts+=("$text") repls+=("$repl") regexes+=("$regex")
done <<<"$parsed"
if [ "$only_list" = 1 ]; then
  for i in "${!ids[@]}"; do
    printf '%-24s %s: "%s" -> "%s"  [%s]\n' "${ids[$i]}" "${files[$i]}" "${texts[$i]}" \
      "${repls[$i]}" "${regexes[$i]}"
  done
  exit 0
fi
[ ${#ids[@]} -gt 0 ] || { echo "mutate.sh: no mutation matches '$filter'" >&2; exit 2; }

work=${keep:-$(mktemp -d /tmp/omni4-mutate.XXXXXX)}
[ -n "$keep" ] || trap 'rm -rf "$work"' EXIT
src=$work/src
rm -rf "$src"
mkdir -p "$src"
git archive HEAD | tar -x -C "$src"
[ -e .venv ] && ln -s "$root/.venv" "$src/.venv"
# The Python tests import the installed package (.venv): a copy of it, its modules replaced by
# the committed tree's, goes first on PYTHONPATH, and a mutation of python/omni4/ is made in
# that copy as well (its compiled and generated modules stay the installed ones).
pyover=$work/pyover
rm -rf "$pyover"
mkdir -p "$pyover"
if site=$(.venv/bin/python -c 'import omni4, os; print(os.path.dirname(omni4.__path__[0]))' 2>/dev/null); then
  cp -r "$site/omni4" "$pyover/"
  (cd "$src/python" && find omni4 -name '*.py' -exec cp --parents {} "$pyover/" \;)
  export PYTHONPATH=$pyover${PYTHONPATH:+:$PYTHONPATH}
fi
echo "mutate.sh: ${#ids[@]} mutations of $(git rev-parse --short HEAD) in $src"
build=$src/build
if ! { cmake --preset default -S "$src" -B "$build" >"$work/configure.log" 2>&1 &&
       cmake --build "$build" >"$work/build.log" 2>&1; }; then
  echo "mutate.sh: the unmutated tree does not build (see $work/build.log)" >&2
  exit 2
fi

# The package's compiled modules (python/setup.py's extensions) built from $src/python into the
# copy on PYTHONPATH; the installed ones kept in so.orig to put back.
mkdir -p "$work/so.orig"
(cd "$pyover" && find . -name '*.so' -exec cp --parents {} "$work/so.orig/" \;)
build_ext() {
  (cd "$src/python" && "$root/.venv/bin/python" setup.py -q build_ext --inplace) >"$1" 2>&1 &&
    (cd "$src/python" && find omni4 -name '_omni4*.so' -exec cp --parents {} "$pyover/" \;)
}

caught=0 survived=0 stale=0
survivors=()
for i in "${!ids[@]}"; do
  id=${ids[$i]} f=$src/${files[$i]} text=${texts[$i]} repl=${repls[$i]} regex=${regexes[$i]}
  n=$(grep -cF -- "$text" "$f" 2>/dev/null || true)
  if [ "$n" != 1 ]; then
    echo "STALE     $id: '$text' occurs ${n:-0} times in ${files[$i]}"
    stale=$((stale + 1))
    continue
  fi
  cp "$f" "$work/orig"
  over=
  case ${files[$i]} in python/omni4/*) over=$pyover/${files[$i]#python/} ;; esac
  if [ -n "$over" ] && [ -e "$over" ]; then cp "$over" "$work/orig.over"; else over=; fi
  for g in "$f" $over; do
    python3 - "$g" "$text" "$repl" <<'EOF'
import sys
path, old, new = sys.argv[1:]
s = open(path).read()
open(path, "w").write(s.replace(old, new, 1))
EOF
  done
  t0=$SECONDS
  # the package's C (python/**/*.c) is compiled into its modules: rebuilt from the mutated tree
  # and put in the copy on PYTHONPATH (the installed ones put back after)
  ext=
  case ${files[$i]} in python/*.c) ext=1 ;; esac
  if [ -n "$ext" ] && ! build_ext "$work/$id.ext.log"; then
    verdict="CAUGHT    $id: the package's modules do not build"
    caught=$((caught + 1))
  elif ! cmake --build "$build" >"$work/$id.build.log" 2>&1; then
    verdict="CAUGHT    $id: the build fails"
    caught=$((caught + 1))
  elif ctest --test-dir "$build" -R "$regex" -j2 --timeout 900 >"$work/$id.test.log" 2>&1; then
    verdict="SURVIVED  $id: ${files[$i]}: '$text' -> '$repl' passes [$regex]"
    survived=$((survived + 1))
    survivors+=("$id")
  else
    failed=$(sed -n 's/^[[:space:]]*[0-9]* - \([^ ]*\) .*/\1/p' "$work/$id.test.log" | tr '\n' ' ')
    verdict="CAUGHT    $id: ${failed:-ctest failed}"
    caught=$((caught + 1))
  fi
  echo "$verdict ($((SECONDS - t0)) s)"
  cp "$work/orig" "$f"
  [ -z "$over" ] || cp "$work/orig.over" "$over"
  [ -z "$ext" ] || (cd "$work/so.orig" && find . -name '*.so' -exec cp --parents {} "$pyover/" \;)
done
cmake --build "$build" >/dev/null 2>&1 || true
echo
[ ${#survivors[@]} -eq 0 ] || echo "survived: ${survivors[*]}"
echo "mutations: $caught caught, $survived survived, $stale stale, of ${#ids[@]}"
[ "$survived" -eq 0 ] && [ "$stale" -eq 0 ]
