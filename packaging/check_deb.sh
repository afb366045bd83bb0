#!/usr/bin/env bash
# Builds the .deb with cpack and checks its contents and metadata.
set -euo pipefail
cd "$1"
rm -f omni4-fw_*.deb
cpack -G DEB >/dev/null
deb=$(ls omni4-fw_*.deb)
echo "package: $deb ($(du -h "$deb" | cut -f1))"
dpkg-deb -I "$deb" | sed -n 's/^ \(Package\|Architecture\|Depends\|Recommends\|Version\):/  \1:/p'
files=$(dpkg-deb -c "$deb")
fail=0
for f in ./usr/bin/omni4-fw ./usr/lib/systemd/system/omni4-fw.service \
         ./usr/lib/systemd/system/omni4-logger.service ./etc/omni4/robot.ini; do
  if grep -q " $f\$" <<<"$files"; then echo "ok: $f"; else echo "FAIL: $f missing"; fail=1; fi
done
dpkg-deb -I "$deb" conffiles | grep -q /etc/omni4/robot.ini && echo "ok: robot.ini is a conffile" || { echo "FAIL: robot.ini not a conffile"; fail=1; }
# The logger unit listens where the packaged INI publishes, and its command line is accepted by
# lcm-logger (run for a second with the log directory moved to a scratch folder).
src=$(dirname "$0")
ini_url=$(sed -n 's/^url *= *//p' "$src/robot.ini")
grep -q -- "--lcm-url=$ini_url " "$src/omni4-logger.service" && echo "ok: logger URL = robot.ini url" ||
  { echo "FAIL: omni4-logger.service URL differs from robot.ini ($ini_url)"; fail=1; }
if command -v lcm-logger >/dev/null; then
  scratch=$(mktemp -d)
  cmd=$(sed -n 's/^ExecStart=//p' "$src/omni4-logger.service" | sed "s|/var/log/omni4|$scratch|; s/%%/%/g")
  # shellcheck disable=SC2086 # the unit's command line, split as systemd splits it
  timeout -s INT 1 $cmd || true
  if ls "$scratch"/omni4-*.00 >/dev/null 2>&1; then echo "ok: logger unit command runs"; else
    echo "FAIL: logger unit command did not open a log"; fail=1; fi
  rm -rf "$scratch"
fi
if command -v systemd-analyze >/dev/null; then
  systemd-analyze verify "$src/omni4-logger.service" && echo "ok: omni4-logger.service verifies" ||
    { echo "FAIL: systemd-analyze verify omni4-logger.service"; fail=1; }
fi
exit $fail
