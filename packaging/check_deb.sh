#!/usr/bin/env bash
# Builds the .deb with cpack and checks its contents and metadata.
set -euo pipefail
cd "$1"
rm -f omni4-fw_*.deb
cpack -G DEB >/dev/null
deb=$(ls omni4-fw_*.deb)
echo "package: $deb ($(du -h "$deb" | cut -f1))"
dpkg-deb -I "$deb" | sed -n 's/^ \(Package\|Architecture\|Depends\|Version\):/  \1:/p'
files=$(dpkg-deb -c "$deb")
fail=0
for f in ./usr/bin/omni4-fw ./usr/lib/systemd/system/omni4-fw.service ./etc/omni4/robot.ini; do
  if grep -q " $f\$" <<<"$files"; then echo "ok: $f"; else echo "FAIL: $f missing"; fail=1; fi
done
dpkg-deb -I "$deb" conffiles | grep -q /etc/omni4/robot.ini && echo "ok: robot.ini is a conffile" || { echo "FAIL: robot.ini not a conffile"; fail=1; }
exit $fail
