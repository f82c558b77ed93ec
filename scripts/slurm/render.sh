#!/usr/bin/env bash
# Renders a scene on a Slurm cluster as three dependent jobs:
#   1. `caustix photons`: traces the photon maps once and saves them;
#   2. a job array of `caustix render --tile I/N --photon-map`, one task per
#      tile, started when the photons are done (afterok);
#   3. `caustix merge`, started when every tile is done (afterok).
# The merged image is bit-identical to `caustix render` of the same scene
# and settings on one machine.
#
# Usage: scripts/slurm/render.sh SCENE TILES OUTPUT [caustix render settings...]
#   e.g. scripts/slurm/render.sh scenes/cornell.toml 16 cornell.exr --spp 64
# Settings (--spp, --width, --photons, --integrator, ...) go to every step.
# The work folder (photon maps, tiles, logs) is OUTPUT's name + .parts/,
# beside OUTPUT; it must be on storage every node sees.
# Environment: CAUSTIX (the binary; default: caustix on PATH, else
# target/release/caustix), SBATCH_ARGS (extra sbatch options for every job,
# e.g. "--partition=cpu --time=01:00:00"), CPUS (CPUs per task; default 2).
# Prints the three job ids. Other schedulers run the same three commands.
set -euo pipefail

if [ $# -lt 3 ]; then
    sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
scene=$(realpath "$1")
tiles=$2
output=$(realpath -m "$3")
shift 3
case "$tiles" in
    '' | *[!0-9]* | 0) echo "render.sh: TILES must be a whole number of at least 1, found '$tiles'" >&2; exit 2 ;;
esac
[ -f "$scene" ] || { echo "render.sh: $scene: no such scene file" >&2; exit 2; }
command -v sbatch >/dev/null || { echo "render.sh: sbatch not found: is this a Slurm login node?" >&2; exit 2; }

caustix=${CAUSTIX:-$(command -v caustix || echo "$(dirname "$0")/../../target/release/caustix")}
caustix=$(realpath "$caustix")
[ -x "$caustix" ] || { echo "render.sh: $caustix is not an executable; build it (cargo build --release) or set CAUSTIX" >&2; exit 2; }

parts="$output.parts"
mkdir -p "$parts"
# The settings, quoted once for the shell that runs each job.
settings=$(printf '%q ' "$@")
q() { printf '%q' "$1"; }
cpus=${CPUS:-2}
# shellcheck disable=SC2086
submit() { sbatch --parsable --cpus-per-task="$cpus" ${SBATCH_ARGS:-} "$@"; }

photons=$(submit --job-name=caustix-photons --output="$parts/photons.log" \
    --wrap="$(q "$caustix") photons $(q "$scene") $settings --threads $cpus -o $(q "$parts/maps.cxpm")")
# \$SLURM_ARRAY_TASK_ID is left for the task's shell to expand.
render=$(submit --job-name=caustix-tiles --dependency="afterok:$photons" --array="1-$tiles" \
    --output="$parts/tile-%a.log" \
    --wrap="$(q "$caustix") render $(q "$scene") $settings --threads $cpus --photon-map $(q "$parts/maps.cxpm") \
--tile \$SLURM_ARRAY_TASK_ID/$tiles -o $(q "$parts")/tile-\$SLURM_ARRAY_TASK_ID.exr")
tile_files=""
for i in $(seq 1 "$tiles"); do tile_files+=" $(q "$parts/tile-$i.exr")"; done
merge=$(submit --job-name=caustix-merge --dependency="afterok:$render" --output="$parts/merge.log" \
    --wrap="$(q "$caustix") merge$tile_files -o $(q "$output")")
echo "photons $photons, tiles $render (array of $tiles), merge $merge; logs in $parts"
