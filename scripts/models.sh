#!/usr/bin/env bash
# Real meshes nobody here wrote: every model of Debian's assimp-testmodels (/usr/share/assimp/models)
# that dgv imports and voxelises to a solid, dropped onto the ground as jelly, putty and goo, run
# and judged by scripts/stress.sh (the same volume goals and fault kinds). Not part of ctest.
#
#   scripts/models.sh [--dgv PATH] [--jobs N] [--out DIR] [--timeout S] [--materials LIST]
#                     [--resolution N] [--frames N] [--list] [PATTERN...]
#
#   --dgv PATH        the dgv launcher, dgv-core beside it (default: $DGV, else build/dgv)
#   --jobs N          runs at once (default 1; `dgv info` and each simulation use one thread)
#   --out DIR         output folder (default out/models): DIR/scenes/<material>_<model>.json,
#                     DIR/imports.tsv (what import and voxelisation made of every file),
#                     DIR/summary.tsv and DIR/logs/ (scripts/stress.sh's)
#   --timeout S       a simulation running longer fails (default 300)
#   --materials LIST  comma-separated presets (default jelly,putty,goo)
#   --resolution N    lattice points along the longest side (default 16)
#   --frames N        frames at 24 fps (default 36: the drop, the landing and a second of settling)
#   --list            write the scenes and imports.tsv, run nothing
#   PATTERN           only the models whose name (path under the models folder, / and . as _)
#                     matches: a shell glob, or a substring
#
# A model takes part when `dgv info --resolution N` imports it (exit 0), it is not flat and its
# lattice has at least 64 points; the others are listed in imports.tsv with dgv's one line (a refusal with a reason is
# not a failure; a crash, exit >= 128, is, and makes this script exit 1). Each scene scales the
# model to 0.5 m across (its longest side), centres it over the origin and drops it from 5 cm
# above the ground: the `material.preset` and nothing else, as a user trying a mesh would write it.
# Exit 0 iff every import was clean and every scene passed.
set -u
export LC_ALL=C

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
MODELS=/usr/share/assimp/models
DGV=${DGV:-$ROOT/build/dgv}
JOBS=1
OUT=out/models
TIMEOUT=300
MATERIALS=jelly,putty,goo
RES=16
FRAMES=36
LIST=0
PATTERNS=()

usage() { sed -n '2,27p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
die() { echo "models: $*" >&2; exit 2; }

while [ $# -gt 0 ]; do
    case $1 in
        --dgv) [ $# -ge 2 ] || die "--dgv needs a path"; DGV=$2; shift ;;
        --jobs|-j) [ $# -ge 2 ] || die "--jobs needs a number"; JOBS=$2; shift ;;
        --out) [ $# -ge 2 ] || die "--out needs a folder"; OUT=$2; shift ;;
        --timeout) [ $# -ge 2 ] || die "--timeout needs seconds"; TIMEOUT=$2; shift ;;
        --materials) [ $# -ge 2 ] || die "--materials needs a list"; MATERIALS=$2; shift ;;
        --resolution) [ $# -ge 2 ] || die "--resolution needs a number"; RES=$2; shift ;;
        --frames) [ $# -ge 2 ] || die "--frames needs a number"; FRAMES=$2; shift ;;
        --list) LIST=1 ;;
        -h|--help) usage; exit 0 ;;
        --) shift; PATTERNS+=("$@"); break ;;
        -*) die "unknown option '$1' (see --help)" ;;
        *) PATTERNS+=("$1") ;;
    esac
    shift
done
[[ $JOBS =~ ^[1-9][0-9]*$ ]] || die "--jobs: expected a positive integer, got '$JOBS'"
[[ $TIMEOUT =~ ^[0-9]+$ ]] || die "--timeout: expected whole seconds, got '$TIMEOUT'"
[[ $RES =~ ^[0-9]+$ ]] && [ "$RES" -ge 4 ] || die "--resolution: expected a whole number >= 4, got '$RES'"
[[ $FRAMES =~ ^[0-9]+$ ]] && [ "$FRAMES" -ge 2 ] || die "--frames: expected a whole number >= 2, got '$FRAMES'"
for m in ${MATERIALS//,/ }; do
    case $m in jelly|putty|goo) ;; *) die "--materials: '$m' is not jelly, putty or goo" ;; esac
done
[ -d "$MODELS" ] || die "no models at $MODELS (Debian: apt-get install assimp-testmodels)"
[ -x "$DGV" ] || die "no dgv binary at '$DGV' (build it, or give --dgv PATH)"
case $DGV in /*) ;; *) DGV=$PWD/$DGV ;; esac
mkdir -p "$OUT/scenes" "$OUT/.info" || die "cannot create '$OUT'"
rm -f "$OUT"/scenes/*.json "$OUT"/.info/*

# The mesh files: the formats assimp reads, outside the folders of deliberately broken files.
files=()
while IFS= read -r f; do files+=("$f"); done < <(
    find "$MODELS" -type f \( -false $(for e in obj dae ply stl off 3ds fbx gltf glb blend x lwo ac ase ms3d md2 \
        md5mesh b3d cob irrmesh nff smd xgl zgl amf 3mf ogex q3o m3d iqm sib dxf raw csm; do
        printf -- '-o -iname *.%s ' "$e"; done) \) -not -path '*/invalid/*' -not -path '*/ReferenceImages/*' | sort)
. "$ROOT/scripts/lib/patterns.sh"  # matches NAME
model_name() { local r=${1#"$MODELS"/}; r=${r//\//_}; r=${r//./_}; r=${r// /_}; printf '%s' "${r//[^A-Za-z0-9_-]/_}"; }

# What import and voxelisation make of each file (dgv info), JOBS at a time.
info_one() {
    local f=$1 idx=$2 rc
    timeout -k 5 120 "$DGV" --threads 1 info --resolution "$RES" "$f" >"$OUT/.info/$idx.out" 2>"$OUT/.info/$idx.err"
    rc=$?
    echo $rc >"$OUT/.info/$idx.rc"
}
picked=() names=()
for f in "${files[@]}"; do
    n=$(model_name "$f")
    matches "$n" && { picked+=("$f"); names+=("$n"); }
done
[ ${#picked[@]} -gt 0 ] || die "no model matches ${PATTERNS[*]:-}"
printf 'models: %d files, dgv info at resolution %d\n' ${#picked[@]} "$RES"
running=0
for i in "${!picked[@]}"; do
    while [ $running -ge "$JOBS" ]; do wait -n; running=$((running - 1)); done
    info_one "${picked[$i]}" "$i" &
    running=$((running + 1))
done
wait

crashes=0 solid=0
{
    printf 'model\tfile\texit\tpoints\tcomponents\tsize\tline\n'
    for i in "${!picked[@]}"; do
        f=${picked[$i]} n=${names[$i]} rc=$(cat "$OUT/.info/$i.rc")
        out=$OUT/.info/$i.out
        line=$(grep -E '^dgv: (error|warning)' "$OUT/.info/$i.err" | head -n1 | tr '\t' ' ')
        points=$(awk '$1 == "voxels:" { print $2 }' "$out")
        comps=$(awk '$1 == "components:" { print $2 }' "$out")
        size=$(awk '$1 == "size:" { printf "%s %s %s", $2, $3, $4 }' "$out")
        if [ "$rc" -ge 124 ]; then crashes=$((crashes + 1)); line="exit $rc (crash or hang) ${line}"; fi
        printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$n" "$f" "$rc" "${points:--}" "${comps:--}" "${size:--}" "${line:--}"
        [ "$rc" = 0 ] && [ -n "$points" ] && [ "$points" -ge 64 ] || continue
        # A flat mesh (one side of zero size) bounds no volume: a scene refuses it (exit 2).
        awk '$1 == "size:" { exit !($2 > 0 && $3 > 0 && $4 > 0) }' "$out" || continue
        solid=$((solid + 1))
        # Scale to 0.5 m across, centre over the origin, the lowest point 5 cm above the ground.
        read -r s tx ty tz < <(awk '
            $1 == "bounds_min:" { x0 = $2; y0 = $3; z0 = $4 }
            $1 == "bounds_max:" { x1 = $2; y1 = $3; z1 = $4 }
            END { l = x1 - x0; if (y1 - y0 > l) l = y1 - y0; if (z1 - z0 > l) l = z1 - z0
                  s = 0.5 / l; printf "%.9g %.9g %.9g %.9g\n", s, -s * (x0 + x1) / 2, 0.05 - s * y0, -s * (z0 + z1) / 2 }' "$out")
        for m in ${MATERIALS//,/ }; do
            cat >"$OUT/scenes/${m}_$n.json" <<EOF
{
  "name": "${m}_$n",
  "frames": { "start": 1, "end": $FRAMES, "fps": 24 },
  "objects": [
    {
      "name": "model",
      "mesh": "$f",
      "resolution": $RES,
      "transform": { "translate": [$tx, $ty, $tz], "scale": $s },
      "material": { "preset": "$m" }
    }
  ],
  "forces": [{ "type": "gravity" }],
  "colliders": [{ "type": "ground", "height": 0 }]
}
EOF
        done
    done
} >"$OUT/imports.tsv"
rm -rf "$OUT/.info"
printf 'models: %d of %d files import and voxelise to a solid (not flat, >= 64 points); %d crashed in dgv info; imports in %s/imports.tsv\n' \
    "$solid" ${#picked[@]} "$crashes" "$OUT"
[ $LIST = 1 ] && { [ $crashes = 0 ]; exit; }
[ $solid -gt 0 ] || exit $((crashes > 0))
"$ROOT/scripts/stress.sh" --scenes "$OUT/scenes" --dgv "$DGV" --jobs "$JOBS" --out "$OUT" --timeout "$TIMEOUT"
rc=$?
[ $crashes = 0 ] && exit $rc
exit 1
