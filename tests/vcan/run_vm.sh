#!/usr/bin/env bash
# The vcan test tier: boots Debian's kernel under qemu (TCG; this machine's own kernel has no
# AF_CAN) with a busybox initramfs holding the CAN modules, omni4-fw, omni4-motorsim, the test
# programs and can-utils, runs vcan_tests.sh inside, and checks what it printed. The candump
# captured inside is decoded here with the DBC (cantools); so are the VESC and ODrive buses,
# against the controller's own log of the same stretch (check_drive_log.py), both left in
# BUILD/vcan/ (vesc.candump, vesc.lcmlog, odrive.candump, odrive.lcmlog).
# usage: run_vm.sh BUILD_BIN_DIR SOURCE_DIR
set -euo pipefail
BIN=$(cd "$1" && pwd)
SRC=$(cd "$2" && pwd)
WORK="$BIN/../vm"
mkdir -p "$WORK"

if ! command -v qemu-system-x86_64 >/dev/null; then
  echo "vcan tier: qemu-system-x86_64 not installed (scripts/setup.sh installs it)"
  echo "0 passed, 1 failed"
  exit 1
fi

# 1. Debian's kernel image: vmlinuz and the four CAN modules (cached).
if [ ! -f "$WORK/vmlinuz" ]; then
  resolve() { apt-cache depends linux-image-amd64 2>/dev/null | sed -n 's/.*Depends: \(linux-image-[0-9].*\)/\1/p' | head -1; }
  pkg=$(resolve)
  if [ -z "$pkg" ]; then apt-get update -qq >/dev/null 2>&1 || true; pkg=$(resolve); fi
  [ -n "$pkg" ] || { echo "vcan tier: cannot resolve Debian's linux-image-amd64 package"; echo "0 passed, 1 failed"; exit 1; }
  rm -rf "$WORK/kpkg" && mkdir -p "$WORK/kpkg"
  (cd "$WORK/kpkg" && apt-get download "$pkg" >/dev/null 2>&1 && dpkg -x ./*.deb x) ||
    { echo "vcan tier: cannot download $pkg"; echo "0 passed, 1 failed"; exit 1; }
  mkdir -p "$WORK/modules"
  for m in can can-raw can-dev vcan; do
    find "$WORK/kpkg/x/lib/modules" -name "$m.ko" -exec cp {} "$WORK/modules/" \;
  done
  cp "$WORK"/kpkg/x/boot/vmlinuz-* "$WORK/vmlinuz"
  rm -rf "$WORK/kpkg"
fi

# 2. The initramfs.
R="$WORK/root"
rm -rf "$R"
mkdir -p "$R"/{bin,sbin,proc,sys,dev,tmp,omni4,modules,etc}
cp /bin/busybox "$R/bin/busybox"
for a in sh mount insmod sleep cat grep sed kill date poweroff echo ps cut awk gzip base64; do ln -sf busybox "$R/bin/$a"; done
cp "$WORK"/modules/*.ko "$R/modules/"
copy_with_libs() {
  cp "$1" "$2"
  ldd "$1" | awk '/=>/ { print $3 } /ld-linux/ { print $1 }' | while read -r lib; do
    [ -f "$lib" ] || continue
    mkdir -p "$R$(dirname "$lib")"
    cp -L "$lib" "$R$lib"
  done
}
for b in omni4-fw omni4-fw-test-hooks omni4-motorsim vcan_check; do copy_with_libs "$BIN/$b" "$R/omni4/"; done
for b in candump cansend cangen lcm-logger; do copy_with_libs "$(command -v $b)" "$R/bin/"; done
copy_with_libs "$(command -v ip)" "$R/sbin/"
cp "$SRC/tests/vcan/vm_init.sh" "$R/init"
cp "$SRC/tests/vcan/vcan_tests.sh" "$SRC/tests/vcan/vcan.ini" "$SRC/tests/vcan/vesc.ini" \
  "$SRC/tests/vcan/odrive.ini" "$SRC/tests/hil/bounded_wait.sh" "$R/omni4/"
chmod +x "$R/init"
(cd "$R" && find . | cpio -o -H newc --quiet | gzip -1 > "$WORK/initrd.gz")

# 3. Boot and run.
echo "vcan tier: booting $(basename "$WORK/vmlinuz") under qemu (TCG)"
set +e
timeout 1800 qemu-system-x86_64 -accel tcg -smp 2 -m 768 -nographic -no-reboot \
  -kernel "$WORK/vmlinuz" -initrd "$WORK/initrd.gz" \
  -append "console=ttyS0 quiet panic=-1 loglevel=3" > "$WORK/console.log" 2>&1
qrc=$?
set -e
tr -d '\r' < "$WORK/console.log" | grep -v "^$" | sed -n '/VCAN: kernel/,$p' | sed '/^VCAN-FILE-BEGIN/,/^VCAN-FILE-END/d' |
  grep -v "VCAN-CANDUMP" | grep -v "^(" | grep -v " vcan0 [0-9A-F]*#" || true
[ $qrc -eq 0 ] || echo "vcan tier: qemu exited with $qrc"

# 4. Decode the frames captured inside with the DBC.
tr -d '\r' < "$WORK/console.log" | sed -n '/VCAN-CANDUMP-BEGIN/,/VCAN-CANDUMP-END/p' | grep "#" > "$WORK/candump.log" || true
dbc_rc=1
if [ -s "$WORK/candump.log" ]; then
  "$SRC/.venv/bin/python" - "$SRC/drivers/can/omni4.dbc" "$WORK/candump.log" <<'PY' && dbc_rc=0
import sys, cantools
db = cantools.database.load_file(sys.argv[1])
seen = {}
for line in open(sys.argv[2]):
    frame = line.split()[2]
    ident, data = frame.split("#")
    msg = db.get_message_by_frame_id(int(ident, 16))
    seen[msg.name] = msg.decode(bytes.fromhex(data))
for name, sig in sorted(seen.items()):
    print(f"  DBC decode {name}: " + ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in sig.items()))
ok = {"CMD_VOLTAGE", "STATUS_0", "STATUS_1"} <= seen.keys()
print(("ok" if ok else "FAIL") + ": the candump frames decode with drivers/can/omni4.dbc")
sys.exit(0 if ok else 1)
PY
fi
# 5. The VESC and ODrive buses: the files brought out, every frame decoded with the drive's DBC
# and compared with the controller's log (the independent decoder).
OUT="$BIN/../vcan"
mkdir -p "$OUT"
drive_rc=0
for name in vesc odrive; do
  for ext in candump lcmlog; do
    rm -f "$OUT/$name.$ext"
    tr -d '\r' < "$WORK/console.log" | sed -n "/^VCAN-FILE-BEGIN $name.$ext\$/,/^VCAN-FILE-END $name.$ext\$/p" |
      grep -v "^VCAN-FILE" | base64 -d 2>/dev/null | gunzip > "$OUT/$name.$ext" 2>/dev/null || rm -f "$OUT/$name.$ext"
  done
  if [ -s "$OUT/$name.candump" ] && [ -s "$OUT/$name.lcmlog" ]; then
    timeout 300 "$SRC/.venv/bin/python" "$SRC/tests/vcan/check_drive_log.py" "$name" \
      "$SRC/drivers/can/$name.dbc" "$OUT/$name.candump" "$OUT/$name.lcmlog" \
      "$SRC/tests/vcan/$name.ini" "$BIN/omni4-config-keys" || drive_rc=$((drive_rc + 1))
  else
    echo "FAIL: $name: no candump or LCM log came out of the VM"
    drive_rc=$((drive_rc + 1))
  fi
done
line=$(tr -d '\r' < "$WORK/console.log" | grep -o "VCAN: [0-9]* passed, [0-9]* failed" | tail -1)
p=$(sed -n 's/VCAN: \([0-9]*\) passed.*/\1/p' <<<"$line")
f=$(sed -n 's/.* \([0-9]*\) failed/\1/p' <<<"$line")
p=${p:-0}
f=${f:-1}
if [ $dbc_rc -eq 0 ]; then p=$((p + 1)); else f=$((f + 1)); fi
p=$((p + 2 - drive_rc))
f=$((f + drive_rc))
echo "$p passed, $f failed"
[ "$f" -eq 0 ] && [ "$p" -gt 0 ]
