#!/usr/bin/env bash
# Quick start 2: install what is missing, build (Release), run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --tests
scripts/build.sh
ctest --test-dir "${DGV_BUILD_DIR:-build}" --output-on-failure --parallel "$(nproc)" "$@"
