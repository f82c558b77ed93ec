#!/usr/bin/env bash
# caustix quick start. On a fresh Debian or Ubuntu machine:
#   ./dev.sh render   install what is missing, build, render scenes/teapot.toml to teapot.png
#   ./dev.sh test     install what is missing, then rustfmt, clippy and the whole test suite
#   ./dev.sh deps     only install the system packages
# System packages come from apt (with sudo when not root); Rust itself comes from rustup.
# With Embree 3 installed (Debian 12) `test` runs the suite twice: on it, and on
# Embree 4 unpacked from PyPI (scripts/embree4-from-wheel.sh), the testing route
# for the `embree4` feature. With Embree 4 installed (Debian 13, Ubuntu 24.04)
# everything builds with `--features embree4` against it. Then once more with
# the `denoise` feature, on Open Image Denoise unpacked from PyPI
# (scripts/oidn-from-wheel.sh). The default build needs neither. Last, as
# root, scripts/slurm-test.sh renders on a one-node Slurm cluster it starts.
set -euo pipefail
cd "$(dirname "$0")"

# Installs the missing apt packages among "$@".
apt_install() {
    local missing=()
    for pkg in "$@"; do
        dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
    done
    if ((${#missing[@]})); then
        local sudo=""
        [ "$(id -u)" -eq 0 ] || sudo="sudo"
        echo "dev.sh: installing ${missing[*]}" >&2
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
    fi
}

install_deps() {
    if ! command -v dpkg >/dev/null 2>&1; then
        echo "dev.sh: not a Debian/Ubuntu system; install Embree (headers and library) and libclang yourself" >&2
    else
        apt_install libembree-dev libclang-dev
        command -v cc >/dev/null 2>&1 || apt_install gcc libc6-dev
    fi
    if ! command -v cargo >/dev/null 2>&1; then
        echo "dev.sh: caustix needs a recent stable Rust toolchain (tested with 1.95); install it with rustup, then run this again" >&2
        exit 1
    fi
}

# The cargo flags for the system's Embree: none for Embree 3, the feature for Embree 4.
system_embree_flags() {
    if [ ! -e /usr/include/embree3/rtcore.h ] && [ -e /usr/include/embree4/rtcore.h ]; then
        echo "--features embree4"
    fi
}

# Clippy (everything, then the library alone as a library user builds it),
# the API docs without warnings, and the tests, with the cargo flags given.
check() {
    cargo clippy --release --all-targets "$@" -- -D warnings
    cargo clippy --release --lib --no-default-features "$@" -- -D warnings
    RUSTDOCFLAGS="-D warnings" cargo doc --release --no-deps "$@"
    cargo test --release "$@"
}

case "${1:-}" in
    deps)
        install_deps
        ;;
    render)
        install_deps
        # shellcheck disable=SC2046
        cargo build --release $(system_embree_flags)
        ./target/release/caustix render scenes/teapot.toml -o teapot.png
        ;;
    test)
        install_deps
        cargo fmt --check
        flags=$(system_embree_flags)
        if [ -n "$flags" ]; then
            echo "dev.sh: testing with the system's Embree 4" >&2
            # shellcheck disable=SC2086
            check $flags
        else
            echo "dev.sh: testing with the system's Embree 3" >&2
            check
            echo "dev.sh: testing with Embree 4 from PyPI (the embree4 feature)" >&2
            python3 -m pip --version >/dev/null 2>&1 || apt_install python3-pip
            scripts/embree4-from-wheel.sh
            EMBREE_DIR=target/embree4 check --features embree4
        fi
        echo "dev.sh: testing the denoise feature with Open Image Denoise from PyPI" >&2
        python3 -m pip --version >/dev/null 2>&1 || apt_install python3-pip
        scripts/oidn-from-wheel.sh
        # shellcheck disable=SC2086
        # (.cargo/config.toml points the build at target/oidn.)
        check $flags --features denoise
        # Leave target/release/caustix built as `render` builds it.
        # shellcheck disable=SC2086
        cargo build --release $flags
        # The Slurm route end to end on a one-node cluster (as root on
        # Debian/Ubuntu; elsewhere it says why it skips).
        scripts/slurm-test.sh
        ;;
    *)
        sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
        exit 2
        ;;
esac
