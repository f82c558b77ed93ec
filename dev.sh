#!/usr/bin/env bash
# caustix quick start. On a fresh Debian or Ubuntu machine:
#   ./dev.sh render   install what is missing, build, render scenes/teapot.toml to teapot.png
#   ./dev.sh test     install what is missing, then rustfmt, clippy and the whole test suite
#   ./dev.sh deps     only install the system packages
# System packages come from apt (with sudo when not root); Rust itself comes from rustup.
set -euo pipefail
cd "$(dirname "$0")"

install_deps() {
    local missing=()
    if ! command -v dpkg >/dev/null 2>&1; then
        echo "dev.sh: not a Debian/Ubuntu system; install Embree 3 (headers and library) and libclang yourself" >&2
    else
        for pkg in libembree-dev libclang-dev; do
            dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
        done
        command -v cc >/dev/null 2>&1 || missing+=(gcc libc6-dev)
    fi
    if ((${#missing[@]})); then
        local sudo=""
        [ "$(id -u)" -eq 0 ] || sudo="sudo"
        echo "dev.sh: installing ${missing[*]}" >&2
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
    fi
    if ! command -v cargo >/dev/null 2>&1; then
        echo "dev.sh: caustix needs a recent stable Rust toolchain (tested with 1.95); install it with rustup, then run this again" >&2
        exit 1
    fi
}

case "${1:-}" in
    deps)
        install_deps
        ;;
    render)
        install_deps
        cargo build --release
        ./target/release/caustix render scenes/teapot.toml -o teapot.png
        ;;
    test)
        install_deps
        cargo fmt --check
        cargo clippy --release --all-targets -- -D warnings
        cargo test --release
        ;;
    *)
        sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'
        exit 2
        ;;
esac
