#!/usr/bin/env bash
# Where a render's time goes, by function: perf samples the release binary
# rendering SCENE with INTEGRATOR (and any further caustix flags), then prints
# the time by library (Embree against caustix) and the functions that take
# the most time by themselves (no children), top N.
#
#   scripts/profile.sh SCENE INTEGRATOR [N] [-- extra caustix render flags]
#   scripts/profile.sh scenes/teapot.toml photon 15 -- --width 320 --height 240
#
# Needs Debian's linux-perf (apt-get install linux-perf) and a release build.
set -euo pipefail
cd "$(dirname "$0")/.."
scene=$1
integrator=$2
top=${3:-15}
shift $(( $# >= 3 ? 3 : $# ))
[ "${1:-}" = "--" ] && shift
data=$(mktemp -d)/perf.data
out=$(mktemp -d)/image.exr
perf record -q -F 999 -g -o "$data" target/release/caustix render "$scene" --integrator "$integrator" "$@" -o "$out" 2>&1 \
    | grep -v '^\[' >&2 || true
echo "by library:"
perf report -i "$data" --no-children --sort dso --stdio 2>/dev/null | grep -E '^ +[0-9.]+%' | head -n 5
echo "by function:"
perf report -i "$data" --no-children --sort symbol --stdio 2>/dev/null \
    | grep -E '^ +[0-9.]+%' | head -n "$top" \
    | sed -E 's/ +- +- +$//; s/\[\.\] //; s/<([^<>]*)>//g' | cut -c1-130
