#!/usr/bin/env python3
"""Render a caustix scene with LuxCoreRender: a reference from another
renderer, and one that carries what no path tracer finds (a point light's
caustics), to hold caustix's images against (BENCHMARKS.md).

    scripts/luxcore-reference.py SCENE.toml -o OUT.exr [--engine E]
        [--width W --height H] [--spp N | --time SECONDS] [--seed S]
        [--max-depth D] [--threads T] [--caustix PATH]

Engines: `path` (LuxCore's path tracer), `path+light` (the path tracer
with light tracing for the paths that end in a caustic, LuxCore's hybrid
back/forward tracing), `bidir` (bidirectional path tracing), `bidirvm`
(bidirectional with vertex merging, as caustix's VCM; the default: it finds
caustics of point lights, also seen in a mirror), `light` (light tracing).
The bidirectional engines run without Russian roulette: with it, LuxCore
2.11's bidirectional path tracing rendered a box of matte walls 4-9%
brighter than its own path tracer and caustix's (BENCHMARKS.md, "Against
LuxCoreRender").

Every object goes over as the very triangles caustix renders (`caustix
export` writes each to a PLY file, with its normals), so the two renderers
see the same geometry and shading normals. What maps exactly:

- materials of one part, Lambertian `diffuse`, `mirror` or
  `transmittance` (a smooth dielectric of index `ior`): LuxCore's `matte`,
  `mirror` and `glass`;
- area lights (one-sided, radiance power / (pi area) by LuxCore's emission
  gain, and a black back that blocks light), point lights (intensity power
  / (4 pi): LuxCore's colour is the power when its `power` is 0);
- the pinhole camera (LuxCore's field of view spans the longer side of the
  image, caustix's the height; LuxCore's rows are moved back by one, see
  `luxcore_properties`), each sample in its own pixel (no filter);
- the longest path: caustix's `max_depth` rays from the camera, each hit
  lit by a light sample, is a path of `max_depth + 1` segments; the path
  and light engines take that (path+light's light paths take the path
  tracer's bound, a bounce more). The bidirectional engines bound the
  camera's and the light's subpaths apart, so they render some longer
  paths too: render both renderers with a larger `--max-depth` to compare
  them there (20 in BENCHMARKS.md).

What does not map (the Phong lobe `specular`, materials of several parts,
spot lights, whose intensity LuxCore divides by the cosine off their axis,
ambient light) is refused with a message rather than
approximated.

Needs `pip install pyluxcore numpy` (LuxCore 2.11 wheels; no GPU needed)
and a caustix binary (target/release/caustix by default).
"""
import argparse
import math
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import caustix_scene as cs

ENGINES = {
    "path": "PATHCPU",
    "path+light": "PATHCPU",
    "bidir": "BIDIRCPU",
    "bidirvm": "BIDIRVMCPU",
    "light": "LIGHTCPU",
}


def spectrum(c):
    return " ".join(repr(float(x)) for x in c)


def material_lines(scene, name, material):
    """LuxCore's properties for a caustix material, or a refusal."""
    kind, colour = cs.material_part(scene, name, material, "LuxCore")
    key = f"scene.materials.{name}"
    if kind == "mirror":
        return [f'{key}.type = "mirror"', f"{key}.kr = {spectrum(colour)}"]
    if kind == "transmittance":
        ior = float(material.get("ior", 1.5))
        return [
            f'{key}.type = "glass"',
            f"{key}.kr = {spectrum(colour)}",
            f"{key}.kt = {spectrum(colour)}",
            f"{key}.interiorior = {ior!r}",
            f"{key}.exteriorior = 1.0",
        ]
    # LuxCore's matte reflects on either side, as caustix's diffuse part.
    return [f'{key}.type = "matte"', f"{key}.kd = {spectrum(colour)}"]


def mesh_lines(key, ply, material):
    """An object of the triangles in `ply`, of the named material."""
    return [
        f'scene.shapes.{key}.type = "mesh"',
        f'scene.shapes.{key}.ply = "{ply}"',
        f'scene.objects.{key}.shape = "{key}"',
        f'scene.objects.{key}.material = "{material}"',
    ]


def luxcore_properties(args, scene, workdir):
    """The render configuration and the scene, as LuxCore property lines."""
    path = args.scene
    if scene.get("spot_light"):
        # Measured on a floor under a spot of 60 degrees, direct light
        # only: LuxCore / caustix = 1 / cos to within 0.1% at every pixel,
        # where caustix matched the analytic irradiance within 0.01% and
        # Mitsuba's spot matched caustix (BENCHMARKS.md).
        cs.refuse(
            path,
            "LuxCore 2.11's spot light sends its intensity over the cosine of the angle from its axis "
            "(1.15x at 30 degrees, 2x at 60), in every engine: no caustix spot light converts exactly",
        )
    camera, width, height, max_depth = cs.checked(args, scene, "LuxCore")
    depth = max_depth + 1
    # caustix's field of view is vertical; LuxCore's spans the longer side.
    fov = float(camera.get("fov", 40.0))
    if width > height:
        fov = math.degrees(2 * math.atan(math.tan(math.radians(fov) / 2) * width / height))
    up = camera.get("up", [0.0, 1.0, 0.0])
    # The path tracer's vertices: `depth` hits from the camera, or for light
    # tracing (which takes the same setting) `max_depth` bounces from the
    # light, each joined to the camera. LIGHTCPU at `max_depth` rendered
    # the teapot's room as caustix's light tracer and path tracer do
    # (1.0000 and 0.9998 of their means), at `max_depth + 1` 0.46% brighter.
    vertices = max_depth if args.engine == "light" else depth
    config = [
        f'renderengine.type = "{ENGINES[args.engine]}"',
        'sampler.type = "SOBOL"' if args.engine.startswith("path") else 'sampler.type = "RANDOM"',
        f"path.hybridbackforward.enable = {1 if args.engine == 'path+light' else 0}",
        # LuxCore takes a seed of 0 as 1: moved by one, every seed its own.
        f"renderengine.seed = {args.seed + 1}",
        f"native.threads.count = {args.threads or os.cpu_count()}",
        f"film.width = {width}",
        f"film.height = {height}",
        # Each sample in its own pixel, as caustix's box pixel filter; with a
        # filter, LuxCore's splats of light-traced samples spread past it.
        'film.filter.type = "NONE"',
        'film.outputs.0.type = "RGB"',
        f'film.outputs.0.filename = "{os.path.abspath(args.output)}"',
        f"path.pathdepth.total = {vertices}",
        f"path.pathdepth.diffuse = {vertices}",
        f"path.pathdepth.glossy = {vertices}",
        f"path.pathdepth.specular = {vertices}",
        f"path.maxdepth = {depth}",
        f"light.maxdepth = {depth}",
        # No clamping: a reference keeps every path's light.
        "path.clamping.variance.maxvalue = 0",
        # LuxCore 2.11's bidirectional engines with their Russian roulette
        # rendered a box of matte walls under a point light 4-9% brighter
        # than its path tracer and caustix's; without it, within the noise
        # (BENCHMARKS.md). Paths end at the longest path instead.
        *(["path.russianroulette.depth = 100000"] if args.engine in ("bidir", "bidirvm") else []),
    ]
    if not args.time:
        config.append(f"batch.haltspp = {args.spp}")
    # The screen window LuxCore would choose, moved a row: its camera turns
    # a film position y into the raster's H - y - 1, where a continuous
    # position's mirror is H - y (slg/cameras/perspective.cpp), so its
    # image shows every row one row low; measured against caustix's image
    # and against a light's edge worked out by hand.
    frame = width / height
    x0, x1, y0, y1 = (-1.0, 1.0, -1.0 / frame, 1.0 / frame) if frame >= 1 else (-frame, frame, -1.0, 1.0)
    row = (y1 - y0) / height
    lines = [
        'scene.camera.type = "perspective"',
        f"scene.camera.screenwindow = {x0!r} {x1!r} {y0 - row!r} {y1 - row!r}",
        f"scene.camera.lookat.orig = {spectrum(camera['eye'])}",
        f"scene.camera.lookat.target = {spectrum(camera['look_at'])}",
        f"scene.camera.up = {spectrum(up)}",
        f"scene.camera.fieldofview = {fov!r}",
    ]
    for name, material in scene.get("materials", {}).items():
        lines += material_lines(path, name, material)
    for key, ply, material in cs.objects(args, scene, workdir):
        lines += mesh_lines(key, ply, material)
    for i, light in enumerate(scene.get("area_light", [])):
        # One-sided: LuxCore's triangle lights emit on the side of their
        # winding's normal, u x v here; the black matte blocks light behind.
        key = f"area-light-{i}"
        ply = os.path.join(workdir, f"{key}.ply")
        cs.write_quad_ply(ply, light["center"], light["u"], light["v"])
        lines += [
            f'scene.materials.{key}.type = "matte"',
            f"scene.materials.{key}.kd = 0 0 0",
            f"scene.materials.{key}.emission = {spectrum(cs.area_light_radiance(light))}",
        ]
        lines += mesh_lines(key, ply, key)
    for i, light in enumerate(scene.get("point_light", [])):
        key = f"point-light-{i}"
        lines += [
            f'scene.lights.{key}.type = "point"',
            f"scene.lights.{key}.position = {spectrum(light['position'])}",
            # With `power` 0, LuxCore's point light sends colour x gain / (4 pi)
            # a steradian: caustix's power.
            f"scene.lights.{key}.color = {spectrum(cs.rgb(light['power']))}",
            f"scene.lights.{key}.gain = 1 1 1",
            f"scene.lights.{key}.power = 0",
        ]
    return config, lines, depth


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene")
    parser.add_argument("-o", "--output", required=True, help="the image to write (.exr)")
    parser.add_argument("--engine", choices=sorted(ENGINES), default="bidirvm")
    parser.add_argument("--width", type=int)
    parser.add_argument("--height", type=int)
    parser.add_argument("--spp", type=int, default=256, help="samples a pixel (default 256)")
    parser.add_argument("--time", type=float, help="render for this many seconds instead")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-depth", type=int, help="rays from the camera, as caustix's --max-depth (default: the scene's)")
    parser.add_argument("--threads", type=int)
    parser.add_argument("--caustix", default=cs.default_caustix())
    args = parser.parse_args()
    cs.caustix_binary(args)
    if not args.output.endswith(".exr"):
        sys.exit("error: the output is linear radiance: give it a name ending in .exr")
    scene = cs.load(args.scene)

    with tempfile.TemporaryDirectory() as workdir:
        # Everything is checked before LuxCore is loaded.
        config, lines, depth = luxcore_properties(args, scene, workdir)
        import pyluxcore

        # LuxCore's log goes to a Python function that drops it; that
        # function is taken away again before Python shuts down, since
        # LuxCore, logging as it was torn down, called it without the GIL
        # and the process ended in a segmentation fault (exit 139), after
        # a render as after a failure.
        pyluxcore.Init(lambda message: None)
        try:
            passes, seconds = render(pyluxcore, args, config, lines)
        finally:
            pyluxcore.SetLogHandler(None)
    print(
        f"{args.output}: {passes} samples a pixel in {seconds:.1f} s with LuxCore {pyluxcore.Version()} "
        f"({args.engine}: {ENGINES[args.engine]}, paths of up to {depth} segments)"
    )


def render(pyluxcore, args, config, lines):
    """Renders the scene `lines` with the render configuration `config` and
    writes the image; returns the samples a pixel and the seconds taken."""
    scene_props = pyluxcore.Properties()
    scene_props.SetFromString("\n".join(lines))
    lux_scene = pyluxcore.Scene()
    lux_scene.Parse(scene_props)
    config_props = pyluxcore.Properties()
    config_props.SetFromString("\n".join(config))
    session = pyluxcore.RenderSession(pyluxcore.RenderConfig(config_props, lux_scene))
    start = time.time()
    session.Start()
    # A time budget is kept here, to a tenth of a second (LuxCore's own
    # halt time is whole seconds).
    while not session.HasDone() and not (args.time and time.time() - start >= args.time):
        time.sleep(0.1)
        session.UpdateStats()
    session.Stop()
    seconds = time.time() - start
    passes = session.GetStats().Get("stats.renderengine.pass").GetInt()
    # LuxCore writes the film's linear radiance itself: the OpenEXR
    # module, written to in the same process, crashed (free(): invalid
    # pointer; pyluxcore loads TBB's malloc proxy).
    session.GetFilm().SaveOutputs()
    return passes, seconds


if __name__ == "__main__":
    main()
