#!/usr/bin/env bash
# Fresh machine -> every test: install dependencies, configure, build, run CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset default
cmake --build --preset default
ctest --preset default "$@"
