#!/usr/bin/env bash
# An integrator's error (SPPM's by default) under a time budget on both
# Cornell boxes, several seeds, as BENCHMARKS.md measures issue 16's first
# goal: renders of the area-lit box (seeds 0-2) and the point-lit box
# (seeds 1-2) at 256 x 256, each against the mean of two references of its
# box (`error-against-two-references.py`: RMSE, and in brackets less the
# references' noise; the window is the caustic under the glass sphere).
#
#   scripts/error-at-budget.sh BINARY SECONDS AREA_REF_A PASSES_A AREA_REF_B PASSES_B \
#       POINT_REF_A PASSES_A POINT_REF_B PASSES_B [caustix render arguments]
#
# The references are long renders with another method and different seeds,
# for example (their passes are in their notes):
#   caustix render scenes/cornell.toml --integrator vcm --width 256 --height 256 --time 600 --seed 7 -o area-vcm-7.exr
#   caustix render scenes/cornell-point.toml --integrator vcm --width 256 --height 256 --time 300 --seed 9 -o point-vcm-9.exr
# Extra arguments go to every render; INTEGRATOR (environment, default
# sppm) picks the integrator. Paths may be relative to where it is run.
set -euo pipefail
if [ $# -lt 10 ]; then
    sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
fi
root=$(cd "$(dirname "$0")/.." && pwd)
bin=$(realpath "$1")
budget=$2
area=("$(realpath "$3")" "$4" "$(realpath "$5")" "$6")
point=("$(realpath "$7")" "$8" "$(realpath "$9")" "${10}")
shift 10
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# Renders SCENE with SEED to IMAGE (and the extra arguments), printing its
# samples and time, or all it said if it failed.
render() {
    local scene=$1 seed=$2 image=$3 said
    shift 3
    if ! said=$("$bin" render "$root/scenes/$scene" --integrator "${INTEGRATOR:-sppm}" --width 256 \
        --height 256 --time "$budget" --seed "$seed" "$@" -o "$image" 2>&1); then
        echo "$said" >&2
        echo "error-at-budget: rendering $scene with seed $seed failed" >&2
        exit 1
    fi
    echo "$(basename "$image"): $(grep -o '[0-9]* spp in [0-9.]* s' <<<"$said")"
}
for seed in 0 1 2; do render cornell.toml "$seed" "$out/area-$seed.exr" "$@"; done
for seed in 1 2; do render cornell-point.toml "$seed" "$out/point-$seed.exr" "$@"; done
window=(--window 224:256,160:224)
echo "area-lit box:"
python3 "$root/scripts/error-against-two-references.py" "${area[@]}" "$out"/area-{0,1,2}.exr "${window[@]}" \
    | sed "s|$out/||"
echo "point-lit box:"
python3 "$root/scripts/error-against-two-references.py" "${point[@]}" "$out"/point-{1,2}.exr "${window[@]}" \
    | sed "s|$out/||"
