#!/usr/bin/env bash
# Applies .clang-format to dgv's C++ sources (src/, render/, tests/), or with --check lists the
# files it would change and exits 1 if any (docs/conventions.md, "Code layout").
# Needs clang-format (Debian: apt-get install clang-format).
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format > /dev/null || { echo "format.sh: clang-format not found (apt-get install clang-format)" >&2; exit 2; }
mapfile -t files < <(git ls-files 'src/*.cpp' 'src/*.hpp' 'src/*.inc' 'render/*.cpp' 'render/*.hpp' 'tests/*.cpp' 'tests/*.hpp')
if [ "${1:-}" = "--check" ]; then
    bad=0
    for f in "${files[@]}"; do
        if ! clang-format "$f" | cmp -s - "$f"; then echo "$f"; bad=1; fi
    done
    exit $bad
fi
[ $# -eq 0 ] || { echo "usage: scripts/format.sh [--check]" >&2; exit 2; }
clang-format -i "${files[@]}"
