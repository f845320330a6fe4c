#!/usr/bin/env bash
# Configures (once) and builds dgv in build/ (Release). Incremental: a second run rebuilds
# only what changed. Extra arguments go to CMake's configure step on the first run.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${DGV_BUILD_DIR:-build}
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
fi
cmake --build "$build" --parallel "$(nproc)"
