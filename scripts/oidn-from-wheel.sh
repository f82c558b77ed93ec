#!/usr/bin/env bash
# A testing route to Intel Open Image Denoise 2.x, which Debian 12 does not
# package: downloads the `pyoidn` wheel from PyPI (it carries OIDN 2.5.1's
# libraries, its CPU device and TBB) and unpacks the CPU parts into
# target/oidn/lib, where the build looks by default (.cargo/config.toml sets
# OIDN_DIR to it unless it is set). Then build with
#     cargo test --release --features denoise
# (build.rs gives the binaries target/oidn/lib as their run-time search path).
#
# A real user installs Intel's release archive (oidn-2.x.x.x86_64.linux.tar.gz)
# and sets OIDN_DIR to the folder it unpacks to; see the README.
set -euo pipefail

cd "$(dirname "$0")/.."
dest=target/oidn
version=2.5.1.0
if [ -e "$dest/lib/libOpenImageDenoise.so" ]; then
    echo "Open Image Denoise already unpacked in $dest"
    exit 0
fi
download=target/oidn-wheel
mkdir -p "$download" "$dest/lib"
if ! ls "$download"/pyoidn-"$version"-*.whl >/dev/null 2>&1; then
    python3 -m pip download --quiet --no-deps --only-binary=:all: \
        --platform manylinux2014_x86_64 -d "$download" "pyoidn==$version"
fi
wheel=$(ls "$download"/pyoidn-"$version"-*.whl | head -n 1)
# The wheel is a zip. Take the library, its core, the CPU device (loaded at
# run time from the library's folder) and TBB; leave the GPU devices.
python3 - "$wheel" "$dest/lib" <<'PY'
import os, sys, zipfile
wheel, out = sys.argv[1], sys.argv[2]
wanted = ("libOpenImageDenoise.so", "libOpenImageDenoise_core.so",
          "libOpenImageDenoise_device_cpu.so", "libtbb.so")
with zipfile.ZipFile(wheel) as z:
    names = [n for n in z.namelist()
             if n.startswith("pyoidn/oidn/lib/") and os.path.basename(n).startswith(wanted)]
    for name in names:
        target = os.path.join(out, os.path.basename(name))
        with z.open(name) as src, open(target, "wb") as dst:
            dst.write(src.read())
        os.chmod(target, 0o755)
    print("unpacked", ", ".join(sorted(os.path.basename(n) for n in names)))
PY
echo "Open Image Denoise in $dest/lib; build with cargo build --release --features denoise"
