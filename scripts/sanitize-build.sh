#!/usr/bin/env bash
# Configures (once, or again when the cache lacks the ignore list) and builds the sanitizer build in build-san/: clang, RelWithDebInfo,
# AddressSanitizer + UndefinedBehaviorSanitizer and libFuzzer's coverage instrumentation
# (fuzzer-no-link), with the test suite and the fuzz targets. One build serves both
# scripts/test-sanitize.sh and scripts/fuzz.sh, so CI compiles the sanitized code once.
# Installs what is missing first (clang and its runtime included).
# Usage: scripts/sanitize-build.sh [TARGET ...]     (default: every target)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --tests --fuzz
build=${DGV_SAN_BUILD_DIR:-build-san}
# A build configured before the ignore list was added lacks it (its TBB reports then fail 19
# tests): configure it again.
if [[ -f "$build/CMakeCache.txt" ]] && ! grep -q 'fsanitize-ignorelist' "$build/CMakeCache.txt"; then
  rm -f "$build/CMakeCache.txt"
fi
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  # Line tables only: the sanitizers' stack traces keep file:line, and the Eigen-heavy sources
  # compile faster than with full debug info (-g). tests/sanitize/ubsan.ignore: third-party
  # header code the sanitizers leave alone (TBB's hash map, which clang's UBSan flags).
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
    -DCMAKE_CXX_FLAGS="-fsanitize-ignorelist=$PWD/tests/sanitize/ubsan.ignore" \
    -DDGV_FUZZ=ON -DDGV_SANITIZE=address,undefined,fuzzer-no-link
fi
targets=()
[[ $# -gt 0 ]] && targets=(--target "$@")
cmake --build "$build" --parallel "${DGV_SAN_JOBS:-$(nproc)}" "${targets[@]}"
