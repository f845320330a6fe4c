#!/usr/bin/env bash
# Fuzzes the parsers with libFuzzer (clang, AddressSanitizer + UndefinedBehaviorSanitizer):
# the scene parser, the curve reader, mesh import and the state checkpoint reader. Installs
# clang and its runtime if missing, builds in build-fuzz/ (DGV_FUZZ_JOBS parallel jobs, default
# all cores), runs each target for SECONDS (default 60) from the seed corpus in
# tests/fuzz/corpus/<target>/ (copied: the committed corpus is never modified).
# Usage: scripts/fuzz.sh [SECONDS] [TARGET ...]     TARGET: scene curve mesh state (default: all)
# Exit 0 when every target ran its time box clean; 1 with the crashing input's path otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=(scene curve mesh state)

scripts/install-deps.sh --fuzz
build=${DGV_FUZZ_BUILD_DIR:-build-fuzz}
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DDGV_FUZZ=ON -DDGV_BUILD_TESTS=OFF -DDGV_SANITIZE=address,undefined,fuzzer-no-link
fi
cmake --build "$build" --parallel "${DGV_FUZZ_JOBS:-$(nproc)}" --target $(printf 'fuzz_%s ' "${targets[@]}")

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
export LSAN_OPTIONS=suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0
status=0
for t in "${targets[@]}"; do
  work="$build/fuzz-work/$t"
  mkdir -p "$work/corpus" "$work/artifacts"
  cp -n tests/fuzz/corpus/"$t"/* "$work/corpus/" 2>/dev/null || true
  echo "fuzz: $t for ${seconds}s (corpus $(ls "$work/corpus" | wc -l) files)"
  if ! "$build/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 \
       -max_len=65536 -print_final_stats=1 -artifact_prefix="$work/artifacts/" \
       "$work/corpus" > "$work/log.txt" 2>&1; then
    echo "fuzz: $t FAILED: $(ls "$work"/artifacts/* 2>/dev/null | head -1) (log: $work/log.txt)" >&2
    tail -40 "$work/log.txt" >&2
    status=1
  else
    grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb" "$work/log.txt" | sed "s/^/fuzz: $t /"
  fi
done
exit $status
