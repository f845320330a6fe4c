#!/usr/bin/env bash
# Fuzzes the parsers with libFuzzer (clang, AddressSanitizer + UndefinedBehaviorSanitizer):
# the scene parser, the curve reader, mesh import and the state checkpoint reader. Builds the
# fuzz targets in the sanitizer build build-san/ (scripts/sanitize-build.sh, which installs
# clang if missing), then runs each target from its seed corpus tests/fuzz/corpus/<target>/
# (copied: the committed corpus is never modified).
# Usage: scripts/fuzz.sh [SECONDS|ci] [TARGET ...]     TARGET: scene curve mesh state (default: all)
#   SECONDS (default 60): explore for that long per target with a random seed, growing the
#           corpus kept in build-san/fuzz-work/<target>/corpus between runs.
#   ci:     the reproducible gate CI runs: a fixed seed, a fixed number of inputs per target
#           (about a minute each on 2 cores) from a fresh copy of the seeds, so every machine
#           tries the same inputs and a pass here is a pass there.
# Exit 0 when every target ran clean; 1 with the failing input's path otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-60}
shift || true
if [[ $mode != ci && ! $mode =~ ^[0-9]+$ ]]; then
  echo "fuzz.sh: the first argument must be a number of seconds or 'ci', got '$mode'" >&2
  exit 2
fi
# ci: inputs per target, each about a minute on 2 cores (mesh goes through assimp and a file).
declare -A ci_runs=([scene]=300000 [curve]=1000000 [mesh]=6000 [state]=500000)
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=(scene curve mesh state)

# The sanitizer build (scripts/sanitize-build.sh: clang, ASan + UBSan, coverage instrumentation)
# that the sanitized test suite shares.
build=${DGV_SAN_BUILD_DIR:-build-san}
scripts/sanitize-build.sh $(printf 'fuzz_%s ' "${targets[@]}")

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
export LSAN_OPTIONS=suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0
status=0
for t in "${targets[@]}"; do
  work="$build/fuzz-work/$t"
  if [[ $mode == ci ]]; then
    work="$build/fuzz-ci/$t"
    rm -rf "$work"
    budget=(-seed=1 -runs="${ci_runs[$t]}")
    what="${ci_runs[$t]} inputs, seed 1"
  else
    budget=(-max_total_time="$mode")
    what="${mode}s"
  fi
  mkdir -p "$work/corpus" "$work/artifacts"
  cp -n tests/fuzz/corpus/"$t"/* "$work/corpus/" 2>/dev/null || true
  echo "fuzz: $t for $what (corpus $(ls "$work/corpus" | wc -l) files)"
  if ! "$build/fuzz/fuzz_$t" "${budget[@]}" -timeout=10 -rss_limit_mb=4096 \
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
