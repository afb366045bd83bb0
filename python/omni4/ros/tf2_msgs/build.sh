#!/usr/bin/env bash
# build.sh VENV: generates tf2_msgs/msg/TFMessage (C, Fast DDS and introspection typesupport,
# Python) with the rosidl generator wheels installed in VENV and installs it into VENV (its
# lib/ and site-packages). Called by scripts/setup.sh when `import tf2_msgs.msg` fails. ~10 s.
set -euo pipefail
venv=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export AMENT_PREFIX_PATH="$venv" PATH="$venv/bin:$PATH"
cmake -S "$here" -B "$work" -G Ninja -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
  -DCMAKE_PREFIX_PATH="$venv" -DCMAKE_INSTALL_PREFIX="$venv" \
  -DPython3_EXECUTABLE="$venv/bin/python" \
  -DCMAKE_INSTALL_RPATH="\$ORIGIN;$venv/lib" -DCMAKE_INSTALL_RPATH_USE_LINK_PATH=ON >"$work/configure.log" 2>&1 \
  || { tail -30 "$work/configure.log" >&2; exit 1; }
cmake --build "$work" >"$work/build.log" 2>&1 || { tail -30 "$work/build.log" >&2; exit 1; }
cmake --install "$work" >/dev/null
"$venv/bin/python" -c "from tf2_msgs.msg import TFMessage" 
