#!/usr/bin/env bash
# A testing route to Embree 4 on a system that ships only Embree 3 (Debian 12):
# downloads the `embreex4` wheel from PyPI (manylinux_2_28; it carries
# libembree4 4.4 and its libtbb), unpacks those two libraries into
# target/embree4/lib and adds the libembree4.so link the linker looks for.
# Then build with
#     EMBREE_DIR=target/embree4 cargo test --release --features embree4
# (build.rs links from there and sets the binaries' run-time search path).
#
# A real user installs their distribution's package instead: Debian 13 and
# Ubuntu 24.04 ship Embree 4 as libembree-dev.
set -euo pipefail

cd "$(dirname "$0")/.."
dest=target/embree4
version=4.4.0.post1
if [ -e "$dest/lib/libembree4.so" ]; then
    echo "Embree 4 already unpacked in $dest"
    exit 0
fi
download=target/embree4-wheel
mkdir -p "$download" "$dest/lib"
if ! ls "$download"/embreex4-"$version"-*.whl >/dev/null 2>&1; then
    python3 -m pip download --quiet --no-deps --only-binary=:all: \
        --python-version 3.11 --platform manylinux_2_28_x86_64 \
        -d "$download" "embreex4==$version"
fi
wheel=$(ls "$download"/embreex4-"$version"-*.whl | head -n 1)
# The wheel is a zip; take the two libraries, keeping the names their
# sonames and the library's run path ($ORIGIN) refer to.
python3 - "$wheel" "$dest/lib" <<'PY'
import sys, zipfile, os
wheel, out = sys.argv[1], sys.argv[2]
with zipfile.ZipFile(wheel) as z:
    libs = [n for n in z.namelist() if n.startswith("embreex4.libs/") and ".so" in n]
    for name in libs:
        target = os.path.join(out, os.path.basename(name))
        with z.open(name) as src, open(target, "wb") as dst:
            dst.write(src.read())
        os.chmod(target, 0o755)
    print("unpacked", ", ".join(os.path.basename(n) for n in libs))
PY
embree=$(cd "$dest/lib" && ls libembree4-*.so.4 | head -n 1)
ln -sf "$embree" "$dest/lib/libembree4.so"
echo "Embree 4 in $dest/lib ($embree); build with EMBREE_DIR=$dest cargo build --features embree4"
