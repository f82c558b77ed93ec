#!/usr/bin/env bash
# Checks that a change keeps the pictures: renders every example scene with
# every integrator through two caustix binaries (same seed, small sizes) and
# compares the linear EXR images, bit for bit first, then by RMSE.
#
#   scripts/same-images.sh OLD_BINARY NEW_BINARY [OUT_DIR [-- RENDER FLAGS]]
#   scripts/same-images.sh old new target/same-images -- --backend native
#
# Exit 0 when every pair is bit-identical; 1 otherwise. For a pair that
# differs, the table gives its RMSE beside the RMSE between two seeds of the
# old binary: a change made on purpose is "within noise" when the first is
# far below the second.
set -euo pipefail
cd "$(dirname "$0")/.."
old=$1
new=$2
out=${3:-target/same-images}
shift $(( $# >= 3 ? 3 : $# ))
[ "${1:-}" = "--" ] && shift
extra=("$@")
mkdir -p "$out/old" "$out/new"
integrators=(photon sppm whitted path normals depth)
flags=(--width 64 --height 48 --spp 2 --photons 20000 --caustic-photons 20000
       --passes 4 --pass-photons 20000 ${extra[@]+"${extra[@]}"})
status=0
printf '%-10s %-8s %-10s %-26s %s\n' scene integrator result "rmse new-old (relative)" "rmse between seeds (old)"
for scene in scenes/*.toml; do
    name=$(basename "$scene" .toml)
    for integrator in "${integrators[@]}"; do
        for side in old new; do
            bin=$old
            [ "$side" = new ] && bin=$new
            "$bin" render "$scene" --integrator "$integrator" "${flags[@]}" --seed 7 \
                -o "$out/$side/$name-$integrator.exr" 2>/dev/null
        done
        a="$out/old/$name-$integrator.exr"
        b="$out/new/$name-$integrator.exr"
        if cmp -s "$a" "$b"; then
            printf '%-10s %-8s %-10s\n' "$name" "$integrator" identical
        elif "$new" compare "$b" "$a" | grep -q '^identical yes'; then
            # (Tiles from binaries before 6fc0995 kept their two header
            # attributes in one map, which the exr crate writes in no fixed order.)
            printf '%-10s %-8s %-10s\n' "$name" "$integrator" "identical values (the files' headers differ)"
        else
            status=1
            summary=$("$new" compare "$b" "$a" | awk '/^rmse/ {r=$2} /^mean/ {m=$2} END {printf "%s (%.2e)", r, (m > 0 ? r / m : 0)}')
            other="$out/old/$name-$integrator-seed8.exr"
            "$old" render "$scene" --integrator "$integrator" "${flags[@]}" --seed 8 -o "$other" 2>/dev/null
            noise=$("$new" compare "$other" "$a" | awk '/^rmse/ {print $2}')
            printf '%-10s %-8s %-10s %-26s %s\n' "$name" "$integrator" DIFFERENT "$summary" "$noise"
        fi
    done
done
exit $status
