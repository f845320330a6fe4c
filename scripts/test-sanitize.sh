#!/usr/bin/env bash
# The whole test suite under AddressSanitizer + UndefinedBehaviorSanitizer, in build-asan/
# (a second build directory; CI runs it after the README's test command). Any sanitizer report
# fails the test that triggered it. Leaks inside Mesa/LLVM (llvmpipe's JIT keeps caches until
# exit) are suppressed by tests/sanitize/lsan.supp; leaks in dgv are not. One test is left out
# (below).
# Usage: scripts/test-sanitize.sh [ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
export DGV_BUILD_DIR=${DGV_ASAN_BUILD_DIR:-build-asan}
scripts/install-deps.sh --tests
if [[ ! -f "$DGV_BUILD_DIR/CMakeCache.txt" ]]; then
  cmake -S . -B "$DGV_BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DDGV_SANITIZE=address,undefined
fi
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1
export LSAN_OPTIONS=suppressions=$PWD/tests/sanitize/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
# Left out here (it runs in the normal suite): Mesa's EGL driver is dlopen'ed and unloaded before
# LeakSanitizer reports, so its exit-time allocations show as "<unknown module>" and cannot be
# suppressed by name.
exec scripts/test.sh -E "EGL and OSMesa give bit-identical images" "$@"
