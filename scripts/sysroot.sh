#!/usr/bin/env bash
# Debian multiarch packages for a cross build, unpacked into build/sysroot/TRIPLET.
# (liblcm-dev is not Multi-Arch: same, so it cannot be installed beside the amd64 one:
# the packages are downloaded with apt and unpacked, not installed.)
# usage: scripts/sysroot.sh aarch64|armhf
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in
  aarch64) ARCH=arm64; TRIPLET=aarch64-linux-gnu ;;
  armhf) ARCH=armhf; TRIPLET=arm-linux-gnueabihf ;;
  *) echo "usage: scripts/sysroot.sh aarch64|armhf" >&2; exit 2 ;;
esac
PKGS=(liblcm1 liblcm-dev libglib2.0-0 libpcre2-8-0 libinih1 libinih-dev libcmocka0 libcmocka-dev
      libgpiod2 libgpiod-dev)
DEST=build/sysroot/$TRIPLET
STAMP=$DEST/.done-$(echo "${PKGS[*]}" | md5sum | cut -c1-8)
[ -f "$STAMP" ] && exit 0

SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
if ! dpkg --print-foreign-architectures | grep -qx "$ARCH"; then
  echo "sysroot: adding Debian architecture $ARCH"
  $SUDO dpkg --add-architecture "$ARCH"
  $SUDO apt-get update -qq || true  # a mirror mid-sync can fail one index; retried below
fi
rm -rf "$DEST" && mkdir -p "$DEST/debs"
for try in 1 2 3; do
  if ( cd "$DEST/debs" && apt-get download "${PKGS[@]/%/:$ARCH}" >/dev/null 2>&1 ); then
    break
  fi
  [ "$try" = 3 ] && { echo "sysroot: cannot download the $ARCH packages: ${PKGS[*]}" >&2; exit 1; }
  sleep $((try * 5))
  $SUDO apt-get update -qq || true
done
for d in "$DEST"/debs/*.deb; do dpkg -x "$d" "$DEST"; done
rm -rf "$DEST/debs"
# Absolute symlinks (e.g. libfoo.so -> /usr/lib/...) must point inside the sysroot.
find "$DEST" -type l | while read -r l; do
  t=$(readlink "$l")
  case "$t" in /*) ln -sf "$(realpath -m "$DEST$t")" "$l" ;; esac
done
touch "$STAMP"
echo "sysroot: $DEST ready (${#PKGS[@]} packages)"
