#!/usr/bin/env python3
"""Render a caustix scene with Mitsuba 3's path tracer: a reference from
another renderer, to hold caustix's images against (BENCHMARKS.md).

    scripts/mitsuba-reference.py SCENE.toml -o OUT.exr [--width W --height H]
        [--spp N | --time SECONDS] [--seed S] [--caustix PATH] [--variant V]

Every object goes over as the very triangles caustix renders (`caustix
export` writes each to a PLY file, with its normals), so the two renderers
see the same geometry and shading normals. What maps exactly:

- materials of one part, Lambertian `diffuse`, `mirror` or
  `transmittance` (a smooth dielectric of index `ior`): Mitsuba's `diffuse`
  and `conductor` (no absorption, scaled by the part), both two-sided as
  caustix's are, and `dielectric`;
- area lights (one-sided, radiance power / (pi area), a black back that
  blocks light), point lights (intensity power / (4 pi));
- the pinhole camera (vertical field of view), a box pixel filter, and the
  longest path: caustix's `max_depth` rays from the camera, each hit lit
  by a light sample, is Mitsuba's `max_depth + 1` segments.

What does not (the Phong lobe `specular`, materials of several parts, spot
lights, ambient light) is refused with a message rather than approximated. Mitsuba's path tracer
finds a point light's caustics no better than caustix's path tracer: it
has no path for light through glass from a point light, so for scenes that
have such light its image lacks it.

Needs `pip install mitsuba numpy` and a caustix binary (target/release/caustix
by default). The `llvm_ad_rgb` variant needs libLLVM 16 or later (`apt-get install
libllvm19` on Debian 12, whose libLLVM 15 fails on Dr.Jit's code; the
newest found is used unless DRJIT_LIBLLVM_PATH names one); `--variant
scalar_rgb` needs nothing more and runs about 2.5x slower.
"""
import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

SHAPES = ("sphere", "quad", "box", "ring", "teapot", "mesh")


def refuse(scene, message):
    sys.exit(f"error: {scene}: {message}")


def toml_value(value):
    """A TOML value for the few kinds a scene's object holds."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise ValueError(f"cannot write {value!r} as TOML")


def rgb(value):
    """A colour: one number for all three channels, or [r, g, b]."""
    return [float(value)] * 3 if isinstance(value, (int, float)) else [float(v) for v in value]


def bsdf_of(scene, name, material):
    """Mitsuba's BSDF for a caustix material, or a refusal."""
    known = {"diffuse", "specular", "phong_exponent", "mirror", "transmittance", "ior"}
    unknown = set(material) - known
    if unknown:
        refuse(scene, f"material `{name}` has {sorted(unknown)}, which this script does not know")
    if any(c > 0 for c in rgb(material.get("specular", 0.0))):
        refuse(scene, f"material `{name}` has a Phong lobe (`specular`), which Mitsuba 3 has no BSDF for")
    # Each part as (its colour, the BSDF of a colour).
    parts = []
    diffuse = rgb(material.get("diffuse", 0.0))
    # caustix's diffuse and mirror parts act on the side a ray comes from;
    # Mitsuba's are black from behind unless made two-sided.
    parts.append(
        (diffuse, lambda c: {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": c}}})
    )
    mirror = rgb(material.get("mirror", 0.0))
    parts.append(
        (
            mirror,
            lambda c: {
                "type": "twosided",
                "bsdf": {"type": "conductor", "material": "none", "specular_reflectance": {"type": "rgb", "value": c}},
            },
        )
    )
    transmittance = rgb(material.get("transmittance", 0.0))
    ior = float(material.get("ior", 1.5))
    parts.append(
        (
            transmittance,
            lambda c: {
                "type": "dielectric",
                "int_ior": ior,
                "ext_ior": 1.0,
                "specular_reflectance": {"type": "rgb", "value": c},
                "specular_transmittance": {"type": "rgb", "value": c},
            },
        )
    )
    parts = [(colour, make) for colour, make in parts if max(colour) > 0]
    if len(parts) > 1:
        # Mitsuba's `blendbsdf` of a diffuse and a mirror BSDF (weights 0.4
        # and 0.5) rendered a sphere 6-7% off the sum of the two parts
        # rendered apart in two channels, where caustix's image of the same
        # material held to that sum within 1-3% (BENCHMARKS.md): no exact
        # counterpart, so none at all.
        refuse(scene, f"material `{name}` has several parts; this script converts materials of one part only")
    if not parts:
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}
    colour, make = parts[0]
    return make(colour)


def export_object(caustix, scene_path, camera, kind, obj, out_ply, workdir):
    """The triangles of one object, as caustix makes them, into `out_ply`."""
    obj = dict(obj)
    obj["material"] = "m"
    if "file" in obj:
        # A mesh's or a teapot's file, relative to the scene file.
        obj["file"] = os.path.join(os.path.dirname(os.path.abspath(scene_path)), obj["file"])
    lines = ["[camera]"] + [f"{k} = {toml_value(v)}" for k, v in camera.items()]
    lines += ["[materials.m]", "diffuse = 0.5", f"[[{kind}]]"]
    lines += [f"{k} = {toml_value(v)}" for k, v in obj.items()]
    one = os.path.join(workdir, "one.toml")
    with open(one, "w") as f:
        f.write("\n".join(lines) + "\n")
    done = subprocess.run([caustix, "export", one, "-o", out_ply], capture_output=True, text=True)
    if done.returncode != 0:
        refuse(scene_path, f"[[{kind}]]: caustix could not export it: {done.stderr.strip()}")


def write_quad_ply(path, center, u, v):
    """A parallelogram as two triangles whose normal is u x v (no vertex normals)."""
    c, u, v = np.array(center, float), np.array(u, float), np.array(v, float)
    corners = [c - u / 2 - v / 2, c + u / 2 - v / 2, c + u / 2 + v / 2, c - u / 2 + v / 2]
    header = (
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "w") as f:
        f.write(header)
        for p in corners:
            f.write(" ".join(repr(float(x)) for x in p) + "\n")
        f.write("3 0 1 2\n3 0 2 3\n")


def mitsuba_scene(args, scene, workdir):
    """The Mitsuba scene dictionary for the caustix scene file."""
    path = args.scene
    camera = scene.get("camera") or refuse(path, "no [camera]")
    image = scene.get("image", {})
    render = scene.get("render", {})
    if any(c != 0 for c in rgb(render.get("ambient", 0.0))):
        refuse(path, "ambient light has no counterpart in Mitsuba")
    if scene.get("spot_light"):
        refuse(path, "spot lights fall off differently in Mitsuba; this script does not convert them")
    max_depth = int(render.get("max_depth", 10))
    width = args.width or int(image.get("width", 640))
    height = args.height or int(image.get("height", 480))
    up = camera.get("up", [0.0, 1.0, 0.0])

    import mitsuba as mi

    out = {
        "type": "scene",
        # caustix: `max_depth` rays from the camera and a light sample at
        # the last hit (BSDF-sampled hits of lights on all but the last).
        "integrator": {"type": "path", "max_depth": max_depth + 1},
        "camera": {
            "type": "perspective",
            "fov": float(camera.get("fov", 40.0)),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=camera["eye"], target=camera["look_at"], up=up),
            "film": {
                "type": "hdrfilm",
                "width": width,
                "height": height,
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
            "sampler": {"type": "independent"},
        },
    }
    materials = {name: bsdf_of(path, name, m) for name, m in scene.get("materials", {}).items()}
    for kind in SHAPES:
        for i, obj in enumerate(scene.get(kind, [])):
            name = obj.get("material")
            if name not in materials:
                refuse(path, f"[[{kind}]] #{i + 1}: give it a material from [materials] (the file's own are not converted)")
            ply = os.path.join(workdir, f"{kind}-{i}.ply")
            export_object(args.caustix, path, camera, kind, obj, ply, workdir)
            out[f"{kind}-{i}"] = {"type": "ply", "filename": ply, "bsdf": materials[name]}
    for i, light in enumerate(scene.get("area_light", [])):
        u, v = np.array(light["u"], float), np.array(light["v"], float)
        area = np.linalg.norm(np.cross(u, v))
        radiance = [p / (math.pi * area) for p in rgb(light["power"])]
        ply = os.path.join(workdir, f"area-light-{i}.ply")
        write_quad_ply(ply, light["center"], light["u"], light["v"])
        out[f"area-light-{i}"] = {
            "type": "ply",
            "filename": ply,
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": radiance}},
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
        }
    for i, light in enumerate(scene.get("point_light", [])):
        intensity = [p / (4 * math.pi) for p in rgb(light["power"])]
        out[f"point-light-{i}"] = {
            "type": "point",
            "position": light["position"],
            "intensity": {"type": "rgb", "value": intensity},
        }
    return out


def newest_llvm():
    """The newest libLLVM of version 16 or later in the system's library
    folders (Dr.Jit's code fails on Debian 12's default, 15), if any."""
    import glob
    import re

    found = []
    for path in glob.glob("/usr/lib/*/libLLVM-*.so") + glob.glob("/usr/lib/*/libLLVM.so.*"):
        match = re.search(r"libLLVM(?:-|\.so\.)(\d+)", path)
        if match and int(match.group(1)) >= 16:
            found.append((int(match.group(1)), path))
    return max(found)[1] if found else None


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene")
    parser.add_argument("-o", "--output", required=True, help="the image to write (.exr)")
    parser.add_argument("--width", type=int)
    parser.add_argument("--height", type=int)
    parser.add_argument("--spp", type=int, default=256, help="samples a pixel (default 256)")
    parser.add_argument("--time", type=float, help="render rounds of --round-spp samples until this many seconds")
    parser.add_argument("--round-spp", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--caustix", default=os.path.join(os.path.dirname(__file__), "..", "target", "release", "caustix"))
    args = parser.parse_args()

    if args.variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        newest = newest_llvm()
        if newest:
            os.environ["DRJIT_LIBLLVM_PATH"] = newest
    import mitsuba as mi

    if not os.access(args.caustix, os.X_OK):
        sys.exit(f"error: no caustix binary at {args.caustix}: build it (cargo build --release) or give --caustix")
    mi.set_variant(args.variant)
    try:
        with open(args.scene, "rb") as f:
            scene = tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as e:
        refuse(args.scene, f"cannot read the scene: {e}")
    with tempfile.TemporaryDirectory() as workdir:
        loaded = mi.load_dict(mitsuba_scene(args, scene, workdir))
    start = time.time()
    total, spp, rounds = None, 0, 0
    while True:
        n = args.round_spp if args.time else args.spp
        # Each round its own seed: independent rounds, averaged by their samples.
        image = np.array(mi.render(loaded, spp=n, seed=args.seed * 1_000_003 + rounds), dtype=np.float64)
        total = image * n if total is None else total + image * n
        spp, rounds = spp + n, rounds + 1
        if not args.time or time.time() - start >= args.time:
            break
    seconds = time.time() - start
    mi.Bitmap((total / spp).astype(np.float32)).write(args.output)
    print(f"{args.output}: {spp} spp in {seconds:.1f} s with Mitsuba {mi.__version__} ({args.variant}, path, max_depth {int(scene.get('render', {}).get('max_depth', 10)) + 1})")


if __name__ == "__main__":
    main()
