#!/usr/bin/env bash
# The dynamics stress suite (scenes/stress/README.md): runs every scene of scenes/stress/ with
# `dgv simulate` and judges it against the volume goals. Not part of ctest.
#
#   scripts/stress.sh [--big] [--scenes DIR] [--solver chain|one] [--dgv PATH] [--jobs N] [--out DIR] [--timeout S] [--keep] [PATTERN...]
#
#   --big        also run the big scenes of scenes/stress/big/ (137k points; minutes each)
#   --scenes DIR the scenes of DIR/*.json instead (scripts/models.sh writes its scenes there)
#   --solver S   every object's material.solver (dgv simulate --solver; default: each scene's own)
#   --dgv PATH   the dgv launcher, dgv-core beside it (default: $DGV, else build/dgv)
#   --jobs N     scenes run at once (default 1); each run is `dgv --threads 1`
#   --out DIR    output folder (default out/stress): DIR/<name>/stats.csv, DIR/logs/<name>.log,
#                DIR/summary.tsv
#   --timeout S  stop a scene after S seconds and fail it (default 0: no limit)
#   --keep       keep each run's state checkpoints (DIR/<name>/state; removed by default)
#   PATTERN      run only the scenes whose name matches a shell glob ('goo_*'); a word without
#                glob characters matches as a substring ('fast' runs every *fast* scene)
#
# A scene passes only if dgv exits 0, stats.csv reaches the scene's last frame and every frame
# has max_cell_volume_error <= 1e-4, |total_volume_drift| <= 1e-6, inverted_cells = 0 and (if
# the column exists) torn_edges = 0, all finite. (dgv itself refuses to write a frame whose
# surface tears or folds over on more than 2 % of its triangles; flipped_triangles below
# that, specks, are counted in summary.tsv's max_flipped column.) One line per scene (a failure
# with its kind: dgv's fault kind, lattice_folded, twist_too_far, cells_inverted, flex_inverted,
# non_finite or surface_torn, else volume_goals, rejected, timeout or other), then a count per
# group (jelly/putty, goo), the failures by kind, and last the line 'stress: N passed, M
# failed'. Exit 0 iff all passed.
set -u
export LC_ALL=C

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
SCENES=$ROOT/scenes/stress
DGV=${DGV:-$ROOT/build/dgv}
JOBS=1
OUT=out/stress
TIMEOUT=0
BIG=0
KEEP=0
SOLVER=()
PATTERNS=()

usage() { sed -n '2,27p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
die() { echo "stress: $*" >&2; exit 2; }

while [ $# -gt 0 ]; do
    case $1 in
        --big) BIG=1 ;;
        --keep) KEEP=1 ;;
        --scenes) [ $# -ge 2 ] || die "--scenes needs a folder"; SCENES=$2; shift ;;
        --scenes=*) SCENES=${1#*=} ;;
        --solver) [ $# -ge 2 ] || die "--solver needs chain or one"; SOLVER=(--solver "$2"); shift ;;
        --solver=*) SOLVER=(--solver "${1#*=}") ;;
        --dgv) [ $# -ge 2 ] || die "--dgv needs a path"; DGV=$2; shift ;;
        --dgv=*) DGV=${1#*=} ;;
        --jobs|-j) [ $# -ge 2 ] || die "--jobs needs a number"; JOBS=$2; shift ;;
        --jobs=*) JOBS=${1#*=} ;;
        --out) [ $# -ge 2 ] || die "--out needs a folder"; OUT=$2; shift ;;
        --out=*) OUT=${1#*=} ;;
        --timeout) [ $# -ge 2 ] || die "--timeout needs seconds"; TIMEOUT=$2; shift ;;
        --timeout=*) TIMEOUT=${1#*=} ;;
        -h|--help) usage; exit 0 ;;
        --) shift; PATTERNS+=("$@"); break ;;
        -*) die "unknown option '$1' (see --help)" ;;
        *) PATTERNS+=("$1") ;;
    esac
    shift
done
[[ $JOBS =~ ^[1-9][0-9]*$ ]] || die "--jobs: expected a positive integer, got '$JOBS'"
[[ $TIMEOUT =~ ^[0-9]+$ ]] || die "--timeout: expected whole seconds, got '$TIMEOUT'"
[ -x "$DGV" ] || die "no dgv binary at '$DGV' (build it, or give --dgv PATH)"
[ -d "$SCENES" ] || die "--scenes: no folder '$SCENES'"
case $DGV in /*) ;; *) DGV=$PWD/$DGV ;; esac

# The scenes, in name order (big ones after the others).
list=()
for f in "$SCENES"/*.json; do [ -e "$f" ] && list+=("$f"); done
if [ $BIG = 1 ]; then for f in "$SCENES"/big/*.json; do [ -e "$f" ] && list+=("$f"); done; fi
. "$ROOT/scripts/lib/patterns.sh"  # matches NAME
files=() names=()
for f in "${list[@]}"; do
    n=$(basename "$f" .json)
    matches "$n" && { files+=("$f"); names+=("$n"); }
done
[ ${#files[@]} -gt 0 ] || die "no scene matches ${PATTERNS[*]:-} in $SCENES"

mkdir -p "$OUT/logs" "$OUT/.results" || die "cannot create '$OUT'"

# The scene's frames.end (the schema's default: frames.start, default 1).
last_frame() {
    tr -d '\n' <"$1" | grep -o '"frames"[[:space:]]*:[[:space:]]*{[^}]*}' | head -n1 | awk '
        { s = $0; e = ""; b = 1
          if (match(s, /"end"[[:space:]]*:[[:space:]]*[0-9]+/)) { e = substr(s, RSTART, RLENGTH); sub(/.*:[[:space:]]*/, "", e) }
          if (match(s, /"start"[[:space:]]*:[[:space:]]*[0-9]+/)) { b = substr(s, RSTART, RLENGTH); sub(/.*:[[:space:]]*/, "", b) }
          print (e != "" ? e : b) }
        END { if (NR == 0) print 1 }'
}

# Judge one run: prints the result's TSV fields
#   result frames_done max_cell_err max_drift fail_frame reason
judge() {
    local stats=$1 rc=$2 last=$3 log=$4 fault="" ffault=""
    # Objects that start inside each other are refused by design (docs/math.md, "Overlapping
    # starts"): exit 2 with that line, nothing written, is the right outcome for such a scene.
    if [ "$rc" = 2 ] && grep -q 'start inside each other' "$log"; then
        printf 'PASS\t0\tnan\tnan\t-\trefused as documented: %s\t0\n' \
            "$(grep -oE "objects '[^']*' and '[^']*' start inside each other, [^;]*" "$log" | head -n1)"
        return
    fi
    if [ "$rc" != 0 ]; then
        fault=$(grep -E '^dgv: (error|interrupted)' "$log" | tail -n1 | sed 's/^dgv: error: //')
        [ -n "$fault" ] || fault=$(grep -v '^[[:space:]]*$' "$log" | tail -n1)
        case $rc in
            2) fault="scene rejected (exit 2): $fault" ;;
            124|137) fault="timed out after ${TIMEOUT} s" ;;
            1) ;;
            *) [ "$rc" -gt 128 ] && fault="killed by signal $((rc - 128)) ${fault:+($fault)}" || fault="exit $rc: $fault" ;;
        esac
        ffault=$(printf '%s' "$fault" | grep -oE 'frame [0-9]+' | head -n1 | awk '{print $2}')
    fi
    awk -F, -v last="$last" -v rc="$rc" -v fault="$fault" -v ffault="$ffault" '
        function num(v) { return v ~ /^[-+]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?$/ }
        function absv(v) { return v < 0 ? -v : v }
        function miss(f, what) { if (bad == "" ) { bad = what; badf = f } }
        NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
        {
            f = $col["frame"] + 0; frames = f
            ce = $col["max_cell_volume_error"]; dr = $col["total_volume_drift"]; inv = $col["inverted_cells"]
            fl = ("flipped_triangles" in col) ? $col["flipped_triangles"] : 0
            te = ("torn_edges" in col) ? $col["torn_edges"] : 0
            ke = ("kinetic_energy" in col) ? $col["kinetic_energy"] : 0
            if (!num(ce) || !num(dr) || !num(inv) || !num(fl) || !num(te) || !num(ke)) { miss(f, "non-finite stats"); next }
            if (fl + 0 > maxfl) maxfl = fl + 0
            if (ce + 0 > maxce) maxce = ce + 0
            if (absv(dr + 0) > maxdr) maxdr = absv(dr + 0)
            if (ce + 0 > 1e-4) miss(f, sprintf("max cell volume error %.2e > 1e-4", ce))
            if (absv(dr + 0) > 1e-6) miss(f, sprintf("total drift %.2e > 1e-6", dr))
            if (inv + 0 > 0) miss(f, inv " inverted cells")
            # dgv writes no frame whose surface tears or folds on more than 2 % of its
            # triangles (docs/math.md, "Never a torn frame"); specks below that are reported
            if (te + 0 > 0) miss(f, te " torn edges")
        }
        END {
            if (NR == 0 && rc == 0) { print "FAIL\t0\tnan\tnan\t-\tno stats.csv"; exit }
            if (!("max_cell_volume_error" in col) && rc == 0) { print "FAIL\t0\tnan\tnan\t-\tstats.csv lacks the volume columns"; exit }
            reason = ""; rf = ""
            if (bad != "" && (rc == 0 || ffault == "" || badf < ffault + 0)) { reason = bad " at frame " badf; rf = badf }
            if (rc != 0) { reason = (reason != "" ? reason "; then " : "") fault; if (rf == "") rf = ffault }
            else if (reason == "" && frames < last) { reason = "stopped at frame " frames " of " last; rf = frames + 1 }
            # no empty fields: a tab-separated read would merge them
            printf "%s\t%d\t%s\t%s\t%s\t%s\t%d\n", (reason == "" ? "PASS" : "FAIL"), frames,
                   (NR > 1 ? sprintf("%.2e", maxce) : "nan"), (NR > 1 ? sprintf("%.2e", maxdr) : "nan"),
                   (rf == "" ? "-" : rf), (reason == "" ? "-" : reason), maxfl
        }' "$stats" 2>/dev/null || printf 'FAIL\t0\tnan\tnan\t%s\t%s\t0\n' "${ffault:--}" "${fault:-no stats.csv}"
}

# Run scene $1 (index $2): writes $OUT/.results/<index>.
run_one() {
    local file=$1 idx=$2 name dir log last t0 t1 rc secs
    name=$(basename "$file" .json)
    dir=$OUT/$name
    log=$OUT/logs/$name.log
    rm -rf "$dir"
    last=$(last_frame "$file")
    t0=$(date +%s.%N)
    if [ "$TIMEOUT" -gt 0 ]; then
        timeout -k 10 "$TIMEOUT" "$DGV" --threads 1 -q simulate "$file" --out "$dir" "${SOLVER[@]}" >"$log" 2>&1
    else
        "$DGV" --threads 1 -q simulate "$file" --out "$dir" "${SOLVER[@]}" >"$log" 2>&1
    fi
    rc=$?
    t1=$(date +%s.%N)
    secs=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }')
    [ $KEEP = 1 ] || rm -rf "$dir/state"
    local verdict
    if [ -f "$dir/stats.csv" ]; then verdict=$(judge "$dir/stats.csv" "$rc" "$last" "$log")
    else verdict=$(judge /dev/null "$rc" "$last" "$log"); fi
    local group=jelly/putty
    case $name in goo_*) group=goo ;; esac
    # Why a failure failed, as one word to count: dgv's fault kind (its error line reads
    # 'dynamics [kind]: ...'), else what the judge or the runner saw.
    local kind=-
    case $verdict in
        FAIL*)
            kind=$(grep -E '^dgv: error: dynamics \[' "$log" | tail -n1 | sed -E 's/^dgv: error: dynamics \[([a-z_]+)\].*/\1/')
            if [ -z "$kind" ]; then
                case $rc in
                    0) kind=volume_goals ;;
                    2) kind=rejected ;;
                    124|137) kind=timeout ;;
                    *) kind=other ;;
                esac
            fi ;;
    esac
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$group" "$rc" "$last" "$secs" "$verdict" "$kind" >"$OUT/.results/$idx.tmp"
    mv "$OUT/.results/$idx.tmp" "$OUT/.results/$idx"
}

rm -f "$OUT"/.results/*
printf 'stress: %d scenes, %d at a time, %s\n' ${#files[@]} "$JOBS" "$DGV"

printed=0
print_ready() {
    local name group rc last secs result frames ce dr ff reason folds kind
    while [ $printed -lt ${#files[@]} ] && [ -f "$OUT/.results/$printed" ]; do
        IFS=$'\t' read -r name group rc last secs result frames ce dr ff reason folds kind <"$OUT/.results/$printed"
        if [ "$result" = PASS ] && [ "$reason" != - ]; then
            printf 'PASS %s: %s (%s s)\n' "$name" "$reason" "$secs"
        elif [ "$result" = PASS ]; then
            printf 'PASS %s (%d frames, max cell err %s, max drift %s, folded specks %s, %s s)\n' "$name" "$frames" "$ce" "$dr" "$folds" "$secs"
        else
            printf 'FAIL %s [%s]: %s (%s s)\n' "$name" "$kind" "$reason" "$secs"
        fi
        printed=$((printed + 1))
    done
}

trap 'kill $(jobs -p) 2>/dev/null; exit 130' INT TERM
running=0
for i in "${!files[@]}"; do
    while [ $running -ge "$JOBS" ]; do wait -n; running=$((running - 1)); print_ready; done
    run_one "${files[$i]}" "$i" &
    running=$((running + 1))
done
wait
print_ready

{
    printf 'scene\tgroup\tresult\texit\tframes\tlast_frame\tmax_cell_err\tmax_drift\tfail_frame\tseconds\treason\tmax_flipped\tfault_kind\n'
    for i in "${!files[@]}"; do
        IFS=$'\t' read -r name group rc last secs result frames ce dr ff reason folds kind <"$OUT/.results/$i"
        printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$group" "$result" "$rc" "$frames" "$last" "$ce" "$dr" "$ff" "$secs" "$reason" "${folds:-0}" "${kind:--}"
    done
} >"$OUT/summary.tsv"
rm -rf "$OUT/.results"

awk -F'\t' 'NR > 1 { n[$2 "," $3]++; if ($3 == "PASS") p++; else { f++; if (!($13 in k)) order[++kinds] = $13; k[$13]++ }; t += $10 }
    END {
        for (g = 1; g <= 2; g++) { grp = g == 1 ? "jelly/putty" : "goo"
            printf "  %s: %d passed, %d failed\n", grp, n[grp ",PASS"], n[grp ",FAIL"] }
        if (f > 0) { line = ""; for (i = 1; i <= kinds; i++) line = line (i > 1 ? ", " : "") order[i] " " k[order[i]]
            printf "  failures by kind: %s\n", line }
        printf "  %.0f s of runs; summary in '"$OUT"'/summary.tsv\n", t
        printf "stress: %d passed, %d failed\n", p, f
        exit (f > 0) }' "$OUT/summary.tsv"
