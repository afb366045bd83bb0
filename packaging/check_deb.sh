#!/usr/bin/env bash
# Builds the .deb with cpack and checks its contents and metadata.
# usage: check_deb.sh BUILD_DIR [EMULATOR...] OMNI4_RECORD
set -euo pipefail
src=$(cd "$(dirname "$0")" && pwd)
cd "$1"
shift
rec=("$@") # omni4-record of this build, behind qemu-user when cross compiled
rm -f omni4-fw_*.deb
cpack -G DEB >/dev/null
deb=$(ls omni4-fw_*.deb)
echo "package: $deb ($(du -h "$deb" | cut -f1))"
dpkg-deb -I "$deb" | sed -n 's/^ \(Package\|Architecture\|Depends\|Suggests\|Version\):/  \1:/p'
files=$(dpkg-deb -c "$deb")
fail=0
for f in ./usr/bin/omni4-fw ./usr/bin/omni4-record ./usr/lib/systemd/system/omni4-fw.service \
         ./usr/lib/systemd/system/omni4-logger.service ./etc/omni4/robot.ini; do
  if grep -q " $f\$" <<<"$files"; then echo "ok: $f"; else echo "FAIL: $f missing"; fail=1; fi
done
dpkg-deb -I "$deb" conffiles | grep -q /etc/omni4/robot.ini && echo "ok: robot.ini is a conffile" || { echo "FAIL: robot.ini not a conffile"; fail=1; }
# The recorder unit listens where the packaged INI publishes (both on the default URL, or the
# same --lcm as the INI's url), and its command line is accepted (run for two seconds with the
# log directory moved to a scratch folder).
ini_url=$(sed -n 's/^url *= *//p' "$src/robot.ini")
unit_url=$(sed -n 's/^ExecStart=.* --lcm \([^ ]*\).*/\1/p' "$src/omni4-logger.service")
[ "$ini_url" = "$unit_url" ] && echo "ok: recorder URL = robot.ini url (${ini_url:-both the default})" ||
  { echo "FAIL: omni4-logger.service URL '$unit_url' differs from robot.ini's '$ini_url'"; fail=1; }
scratch=$(mktemp -d)
read -r -a args < <(sed -n 's/^ExecStart=[^ ]*//p' "$src/omni4-logger.service" |
                    sed "s|/var/log/omni4|$scratch|; s/%%/%/g")
timeout -s INT 2 "${rec[@]}" "${args[@]}" || true
if ls "$scratch"/omni4-*.lcmlog.00 >/dev/null 2>&1; then echo "ok: recorder unit command runs"; else
  echo "FAIL: recorder unit command did not open a log"; fail=1; fi
rm -rf "$scratch"
# Both units verify (systemd-analyze), their ExecStart pointed at the package's own binaries.
if command -v systemd-analyze >/dev/null; then
  x=$(mktemp -d)
  dpkg-deb -x "$deb" "$x/root"
  for u in omni4-fw omni4-logger; do
    sed "s|^ExecStart=/usr/bin/|ExecStart=$x/root/usr/bin/|" "$x/root/usr/lib/systemd/system/$u.service" > "$x/$u.service"
  done
  systemd-analyze verify "$x/omni4-fw.service" "$x/omni4-logger.service" &&
    echo "ok: omni4-fw.service and omni4-logger.service verify" ||
    { echo "FAIL: systemd-analyze verify"; fail=1; }
  rm -rf "$x"
fi
exit $fail
