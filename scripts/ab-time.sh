#!/usr/bin/env bash
# Render times of two caustix binaries, alternated run by run so that both
# see the same machine load: the least and the mean of RUNS renders each, as
# the binary reports them ("... spp in T s").
#
#   scripts/ab-time.sh OLD_BINARY NEW_BINARY RUNS [caustix render arguments]
#   scripts/ab-time.sh target/baseline target/release/caustix 5 scenes/cornell.toml --width 256 --height 256
set -euo pipefail
old=$1
new=$2
runs=$3
shift 3
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for _ in $(seq "$runs"); do
    for bin in "$old" "$new"; do
        seconds=$("$bin" render "$@" -o "$out/image.exr" 2>&1 | grep -o 'spp in [0-9.]* s' | grep -o '[0-9.]*')
        echo "$bin $seconds"
    done
done | awk '{ if (!($1 in least) || $2 < least[$1]) least[$1] = $2; sum[$1] += $2; n[$1]++ }
    END { for (b in least) printf "%s: least %.2f s, mean %.2f s over %d runs\n", b, least[b], sum[b] / n[b], n[b] }'
