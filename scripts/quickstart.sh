#!/usr/bin/env bash
# Quick start 1: install what is missing, build (Release), render the default scene into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
./build/dgv "$@"
