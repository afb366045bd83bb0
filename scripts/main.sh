#!/usr/bin/env bash
# Fresh machine -> the main job: build, then simulate the Table III robot's response to the
# paper's ramped voltage steps and print it.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset default >/dev/null
cmake --build --preset default
./build/bin/omni4-demo "$@"
