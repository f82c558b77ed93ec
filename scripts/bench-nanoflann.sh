#!/bin/sh
# Compares caustix's kd-tree (kiddo) with nanoflann, the C++ kd-tree the seed
# report used, on the same photons and queries:
#   scripts/bench-nanoflann.sh [SCENE] [PHOTONS]
# (defaults: scenes/cornell.toml, 10000000). Installs Debian's
# libnanoflann-dev if it is missing, builds benches/nanoflann/knn.cpp with
# g++ -O3 -march=native, and needs a release build of caustix.
set -eu
cd "$(dirname "$0")/.."
scene=${1:-scenes/cornell.toml}
photons=${2:-10000000}
if [ ! -f /usr/include/nanoflann.hpp ]; then
    sudo=""; [ "$(id -u)" = 0 ] || sudo=sudo
    $sudo apt-get install -y -q libnanoflann-dev >/dev/null
fi
mkdir -p target
g++ -O3 -march=native -std=c++17 -pthread benches/nanoflann/knn.cpp -o target/nanoflann-knn
./target/release/caustix bench photons "$scene" --counts "$photons" --dump target/photons.bin
./target/nanoflann-knn target/photons.bin
