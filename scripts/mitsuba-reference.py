#!/usr/bin/env python3
"""Render a caustix scene with Mitsuba 3's path tracer: a reference from
another renderer, to hold caustix's images against (BENCHMARKS.md).

    scripts/mitsuba-reference.py SCENE.toml -o OUT.exr [--width W --height H]
        [--spp N | --time SECONDS] [--seed S] [--caustix PATH] [--variant V]
        [--integrator path|ptracer]

Every object goes over as the very triangles caustix renders (`caustix
export` writes each to a PLY file, with its normals), so the two renderers
see the same geometry and shading normals. What maps exactly:

- materials of one part, Lambertian `diffuse`, `mirror` or
  `transmittance` (a smooth dielectric of index `ior`): Mitsuba's `diffuse`
  and `conductor` (no absorption, scaled by the part), both two-sided as
  caustix's are, and `dielectric`;
- area lights (one-sided, radiance power / (pi area), a black back that
  blocks light), point lights (intensity power / (4 pi)), spot lights with
  a hard edge (`falloff_start` = `cone_angle`; intensity power / (2 pi (1 -
  cos cone_angle)));
- the pinhole camera (vertical field of view), a box pixel filter, and the
  longest path: caustix's `max_depth` rays from the camera, each hit lit
  by a light sample, is Mitsuba's `max_depth + 1` segments.

What does not (the Phong lobe `specular`, materials of several parts,
spot lights' soft edges, ambient light) is refused with a message rather than
approximated. Mitsuba's path tracer finds a point light's caustics no
better than caustix's path tracer: it has no path for light through glass
from a point light, so for scenes that have such light its image lacks it.
Its particle tracer (`--integrator ptracer`, as caustix's `light`) finds
those seen directly, but not what a camera sees in a mirror or through
glass.

Needs `pip install mitsuba numpy` and a caustix binary (target/release/caustix
by default). The `llvm_ad_rgb` variant needs libLLVM 16 or later (`apt-get install
libllvm19` on Debian 12, whose libLLVM 15 fails on Dr.Jit's code; the
newest found is used unless DRJIT_LIBLLVM_PATH names one); `--variant
scalar_rgb` needs nothing more and runs about 2.5x slower.
"""
import argparse
import math
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import caustix_scene as cs


def bsdf_of(scene, name, material):
    """Mitsuba's BSDF for a caustix material, or a refusal."""
    kind, colour = cs.material_part(scene, name, material, "Mitsuba 3")
    value = {"type": "rgb", "value": colour}
    # caustix's diffuse and mirror parts act on the side a ray comes from;
    # Mitsuba's are black from behind unless made two-sided.
    if kind == "diffuse":
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": value}}
    if kind == "mirror":
        return {"type": "twosided", "bsdf": {"type": "conductor", "material": "none", "specular_reflectance": value}}
    if kind == "transmittance":
        return {
            "type": "dielectric",
            "int_ior": float(material.get("ior", 1.5)),
            "ext_ior": 1.0,
            "specular_reflectance": value,
            "specular_transmittance": value,
        }
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}


def mitsuba_scene(args, scene, workdir):
    """The Mitsuba scene dictionary for the caustix scene file."""
    path = args.scene
    camera, width, height, max_depth = cs.checked(args, scene, "Mitsuba")
    up = camera.get("up", [0.0, 1.0, 0.0])

    import mitsuba as mi

    out = {
        "type": "scene",
        # caustix: `max_depth` rays from the camera and a light sample at
        # the last hit (BSDF-sampled hits of lights on all but the last).
        # The particle tracer (`ptracer`) counts its segments the same way.
        "integrator": {"type": args.integrator, "max_depth": max_depth + 1},
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
    for key, ply, material in cs.objects(args, scene, workdir):
        out[key] = {"type": "ply", "filename": ply, "bsdf": materials[material]}
    for i, light in enumerate(scene.get("area_light", [])):
        ply = os.path.join(workdir, f"area-light-{i}.ply")
        cs.write_quad_ply(ply, light["center"], light["u"], light["v"])
        out[f"area-light-{i}"] = {
            "type": "ply",
            "filename": ply,
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": cs.area_light_radiance(light)}},
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
        }
    for i, light in enumerate(scene.get("point_light", [])):
        intensity = [p / (4 * math.pi) for p in cs.rgb(light["power"])]
        out[f"point-light-{i}"] = {
            "type": "point",
            "position": light["position"],
            "intensity": {"type": "rgb", "value": intensity},
        }
    for i, (position, direction, cone, intensity) in enumerate(cs.spot_lights(path, scene, "Mitsuba")):
        target = [p + d for p, d in zip(position, direction)]
        out[f"spot-light-{i}"] = {
            "type": "spot",
            # Mitsuba's spot shines along its frame's z, which look_at turns
            # towards the target.
            "to_world": mi.ScalarTransform4f().look_at(origin=position, target=target, up=cs.perpendicular(direction)),
            "intensity": {"type": "rgb", "value": intensity},
            # A hard edge: the beam as wide as the cone.
            "cutoff_angle": cone,
            "beam_width": cone,
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
    parser.add_argument(
        "--integrator",
        choices=("path", "ptracer"),
        default="path",
        help="Mitsuba's path tracer (default) or its particle tracer, which traces light from the lights to the camera "
        "and so renders a point or spot light's caustics seen directly",
    )
    parser.add_argument("--caustix", default=cs.default_caustix())
    args = parser.parse_args()

    if args.variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        newest = newest_llvm()
        if newest:
            os.environ["DRJIT_LIBLLVM_PATH"] = newest
    import mitsuba as mi

    cs.caustix_binary(args)
    mi.set_variant(args.variant)
    scene = cs.load(args.scene)
    with tempfile.TemporaryDirectory() as workdir:
        description = mitsuba_scene(args, scene, workdir)
        loaded = mi.load_dict(description)
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
    print(
        f"{args.output}: {spp} spp in {seconds:.1f} s with Mitsuba {mi.__version__} "
        f"({args.variant}, {args.integrator}, max_depth {description['integrator']['max_depth']})"
    )


if __name__ == "__main__":
    main()
