"""What the scripts that render a caustix scene with another renderer
(`mitsuba-reference.py`, `luxcore-reference.py`) share: reading the scene
file, caustix's own triangles of each object (`caustix export`), the image
size and the longest path, and refusing what has no exact counterpart.
"""
import os
import subprocess
import sys
import tomllib

import numpy as np

SHAPES = ("sphere", "quad", "box", "ring", "teapot", "mesh")
MATERIAL_PARTS = ("diffuse", "mirror", "transmittance")


def refuse(scene, message):
    sys.exit(f"error: {scene}: {message}")


def load(path):
    """The scene file as a dictionary, or a refusal naming the file."""
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as e:
        refuse(path, f"cannot read the scene: {e}")


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


def material_part(scene, name, material, peer):
    """The one part of a caustix material, as (kind, colour): kind one of
    MATERIAL_PARTS, or None for a black material. Refuses what the peer
    renderer has no exact counterpart for: unknown keys, the Phong lobe,
    several parts at once."""
    known = {"diffuse", "specular", "phong_exponent", "mirror", "transmittance", "ior"}
    unknown = set(material) - known
    if unknown:
        refuse(scene, f"material `{name}` has {sorted(unknown)}, which this script does not know")
    if any(c > 0 for c in rgb(material.get("specular", 0.0))):
        refuse(scene, f"material `{name}` has a Phong lobe (`specular`), which {peer} has no exact counterpart for")
    parts = [(kind, rgb(material.get(kind, 0.0))) for kind in MATERIAL_PARTS]
    parts = [(kind, colour) for kind, colour in parts if max(colour) > 0]
    if len(parts) > 1:
        # Mitsuba's `blendbsdf` of a diffuse and a mirror BSDF (weights 0.4
        # and 0.5) rendered a sphere 6-7% off the sum of the two parts
        # rendered apart in two channels, where caustix's image of the same
        # material held to that sum within 1-3% (BENCHMARKS.md): a blend is
        # not the sum caustix renders, so no blends at all.
        refuse(scene, f"material `{name}` has several parts; this script converts materials of one part only")
    return parts[0] if parts else (None, [0.0, 0.0, 0.0])


def export_object(caustix, scene_path, camera, kind, obj, out_ply, workdir):
    """The triangles of one object, as caustix makes them, into `out_ply`
    (binary PLY with caustix's vertex normals)."""
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
    done = subprocess.run([caustix, "export", one, "-o", out_ply], check=False, capture_output=True, text=True)
    if done.returncode != 0:
        refuse(scene_path, f"[[{kind}]]: caustix could not export it: {done.stderr.strip()}")


def objects(args, scene, workdir):
    """Each object of the scene as (key, its PLY file, its material's
    name), the PLY written by caustix; refuses an object whose material is
    not in the scene's [materials]."""
    out = []
    for kind in SHAPES:
        for i, obj in enumerate(scene.get(kind, [])):
            name = obj.get("material")
            if name not in scene.get("materials", {}):
                refuse(args.scene, f"[[{kind}]] #{i + 1}: give it a material from [materials] (the file's own are not converted)")
            ply = os.path.join(workdir, f"{kind}-{i}.ply")
            export_object(args.caustix, args.scene, scene["camera"], kind, obj, ply, workdir)
            out.append((f"{kind}-{i}", ply, name))
    return out


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
        f.writelines(" ".join(repr(float(x)) for x in p) + "\n" for p in corners)
        f.write("3 0 1 2\n3 0 2 3\n")


def area_light_radiance(light):
    """An area light's radiance: its power over pi times its area."""
    u, v = np.array(light["u"], float), np.array(light["v"], float)
    area = np.linalg.norm(np.cross(u, v))
    return [p / (np.pi * area) for p in rgb(light["power"])]


def spot_lights(path, scene, peer):
    """Each spot light as (position, unit direction, cone half-angle in
    degrees, intensity on its axis), for spot lights with a hard edge
    (`falloff_start` equal to `cone_angle`) only: those send the same
    intensity every way inside the cone, which every peer gives. A soft edge
    falls off differently in each (caustix, like pbrt-v4, as a smoothstep in
    the cosine; Mitsuba linearly in the angle; LuxCore as the fourth power of
    the cosine's share), so those are refused."""
    out = []
    for i, light in enumerate(scene.get("spot_light", [])):
        cone = float(light["cone_angle"])
        start = float(light.get("falloff_start", 0.8 * cone))
        if start != cone:
            refuse(
                path,
                f"[[spot_light]] #{i + 1}: its soft edge (falloff_start {start} of cone_angle {cone}) falls off "
                f"differently in {peer}; give it falloff_start = cone_angle (a hard edge) to compare",
            )
        direction = np.array(light["direction"], float)
        direction /= np.linalg.norm(direction)
        # The cone's solid angle, 2 pi (1 - cos), with 1 - cos as caustix
        # works it out (from the sine), so narrow cones keep their digits.
        solid_angle = 4 * np.pi * np.sin(np.radians(cone) / 2) ** 2
        intensity = [p / solid_angle for p in rgb(light["power"])]
        out.append((list(map(float, light["position"])), direction.tolist(), cone, intensity))
    return out


def perpendicular(direction):
    """A unit vector at right angles to `direction` (an "up" for a light's frame)."""
    d = np.array(direction, float)
    axis = np.eye(3)[np.argmin(np.abs(d))]
    p = np.cross(d, axis)
    return (p / np.linalg.norm(p)).tolist()


def checked(args, scene, peer):
    """The camera, the image's size and caustix's longest path (rays from
    the camera, `--max-depth` over the scene's), after refusing what the
    peer has no counterpart for (ambient light, soft-edged spot lights)."""
    path = args.scene
    camera = scene.get("camera") or refuse(path, "no [camera]")
    image = scene.get("image", {})
    render = scene.get("render", {})
    if any(c != 0 for c in rgb(render.get("ambient", 0.0))):
        refuse(path, f"ambient light has no counterpart in {peer}")
    spot_lights(path, scene, peer)
    max_depth = getattr(args, "max_depth", None) or int(render.get("max_depth", 10))
    width = args.width or int(image.get("width", 640))
    height = args.height or int(image.get("height", 480))
    return camera, width, height, max_depth


def caustix_binary(args):
    if not os.access(args.caustix, os.X_OK):
        sys.exit(f"error: no caustix binary at {args.caustix}: build it (cargo build --release) or give --caustix")


def default_caustix():
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "target", "release", "caustix")
