"""A POV-Ray bench scene (povray_include/examples/bench_scene.pov, bench_occlusion.pov) built in
Blender and path traced by Cycles: an independent reference for the POV-Ray scene bench
(scripts/pov_path_traced.py runs it; docs/pov_path_traced.md).

Runs inside Blender: blender -b --factory-startup -P pov_cycles_scene.py -- --pov FILE
--map HDR --out NPY [--samples N] [--seed S] [--size W H] [--ids]

The scene is read from the .pov file itself, so there is one description of it: its camera
(location, look_at, angle: the horizontal field of view; POV-Ray's default `right`, 1.33), its
albedo declarations (#declare Name = <r, g, b>;) and the objects of its `#case (0)` block:
spheres, the `plane { y, 0 }` and `object { Name ... }` of a #declare'd sphere or union of
boxes, each with the albedo named last in its EnvLight_Add_Ambient(Texture, Albedo). Every
surface is a Lambertian Diffuse BSDF of that albedo (a glossy finish's highlights are POV-Ray's
own and are not rendered: its diffuse part is). POV-Ray's frame is left-handed with +Y up: a
POV-Ray point <x, y, z> is Blender's (x, z, y) (docs/design.md), and the map, canonical, is the
world as it is. The camera samples each pixel at its centre (POV-Ray's -A): a Gaussian pixel
filter 0.01 pixels wide (Cycles' box filter spreads its samples over the whole pixel). --ids: each object an emission of one channel (the bench's id pass: red, green, blue in
the block's order) at 16 samples, to check the geometry against POV-Ray's own id pass (and that
each pixel is sampled at one point: no pixel part one object, part another).
Writes the image as float32 (H, W, 3), top row first (numpy .npy).
"""
import argparse
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_help import exit_on_help  # noqa: E402

if __name__ == "__main__":
    exit_on_help(__doc__, __file__, "--pov FILE --map HDR --out NPY [--samples N] [--seed S] "
                 "[--size W H] [--ids]")

import bpy  # noqa: E402
import mathutils  # noqa: E402
import numpy as np  # noqa: E402

from blender_scene import node_material, run_main, world_with_image  # noqa: E402


POV_RIGHT = 1.33   # POV-Ray's default camera `right` length (the bench scenes give none)


def vec(text):
    return tuple(float(v) for v in text.split(","))


def braced(text, start):
    """The text from `start` (just past an opening brace) to its closing brace."""
    depth, i = 1, start
    while depth:
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
    return text[start:i - 1]


def primitives(body):
    """[("sphere", centre, radius) | ("box", corner, corner)] in a POV-Ray object's text."""
    out = [("sphere", vec(c), float(r))
           for c, r in re.findall(r"sphere\s*\{\s*<([^>]*)>\s*,\s*([\d.]+)", body)]
    out += [("box", vec(a), vec(b))
            for a, b in re.findall(r"box\s*\{\s*<([^>]*)>\s*,\s*<([^>]*)>\s*\}", body)]
    return out


def read_scene(path):
    """{camera: (location, look_at, angle), objects: [(primitives, albedo)]} of a bench scene;
    a plane's primitives are [("plane",)]."""
    text = open(path).read()
    m = re.search(r"camera\s*\{\s*location\s*<([^>]*)>\s*look_at\s*<([^>]*)>\s*angle\s*"
                  r"([\d.]+)\s*\}", text)
    assert m, "%s: no camera { location look_at angle }" % path
    camera = (vec(m.group(1)), vec(m.group(2)), float(m.group(3)))
    colours = {n: vec(v) for n, v in re.findall(r"#declare\s+(\w+)\s*=\s*<([^>]*)>\s*;", text)}
    declared = {}
    for m in re.finditer(r"#declare\s+(\w+)\s*=\s*(sphere|union)\s*\{", text):
        body = m.group(2) + " {" + braced(text, m.end()) + "}"
        declared[m.group(1)] = primitives(body)
    block = text[text.index("#case (0)"):]
    block = block[:block.index("#break")]
    objects = []
    for m in re.finditer(r"\b(sphere|plane|object)\s*\{", block):
        body = braced(block, m.end())
        a = re.search(r",\s*(\w+)\s*\)\s*$", body.strip())
        assert a and a.group(1) in colours, "%s: no albedo in %r" % (path, body)
        if m.group(1) == "plane":
            assert re.match(r"\s*y\s*,\s*0\b", body), "%s: only plane { y, 0 }" % path
            prims = [("plane",)]
        elif m.group(1) == "object":
            prims = declared[body.split()[0]]
        else:
            prims = primitives("sphere {" + body + "}")
        objects.append((prims, colours[a.group(1)]))
    return dict(camera=camera, objects=objects)


def blender(v):
    """POV-Ray <x, y, z> -> Blender (x, z, y)."""
    return (v[0], v[2], v[1])


def add(prim, mat):
    if prim[0] == "plane":
        # 200 km each way: its edge 0.0004 deg below the horizon (row 6 of scene (a) is
        # 0.003 deg below it)
        bpy.ops.mesh.primitive_plane_add(size=4e5)
    elif prim[0] == "sphere":
        bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=128, radius=prim[2],
                                             location=blender(prim[1]))
        bpy.ops.object.shade_smooth()
    else:
        a, b = blender(prim[1]), blender(prim[2])
        bpy.ops.mesh.primitive_cube_add(location=[(a[i] + b[i]) / 2 for i in range(3)])
        bpy.context.active_object.scale = [abs(b[i] - a[i]) / 2 for i in range(3)]
    bpy.context.active_object.data.materials.append(mat)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--pov", required=True)
    p.add_argument("--map", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--samples", type=int, default=512)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--size", type=int, nargs=2, default=(200, 150))
    p.add_argument("--ids", action="store_true")
    args = p.parse_args(sys.argv[sys.argv.index("--") + 1:])
    spec = read_scene(args.pov)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = 16 if args.ids else args.samples
    c.seed = args.seed
    c.use_denoising = False
    c.use_adaptive_sampling = False
    c.max_bounces = c.diffuse_bounces = 64   # the bounces POV-Ray's reference stops at 6
    c.glossy_bounces = c.transmission_bounces = c.transparent_max_bounces = 0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0
    c.pixel_filter_type = "GAUSSIAN"   # Cycles' box filter is a pixel wide whatever its width
    c.filter_width = 0.01
    scene.render.resolution_x, scene.render.resolution_y = args.size
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    world, tex = world_with_image("PovBenchWorld", args.map)
    tex.interpolation = "Closest"
    if args.ids:
        world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0
    for k, (prims, albedo) in enumerate(spec["objects"]):
        if args.ids:
            mat = node_material("Id%d" % k, "ShaderNodeEmission",
                                [1.0 if ch == k else 0.0 for ch in range(3)])
        else:
            mat = node_material("Albedo%d" % k, color=albedo)
        for prim in prims:
            add(prim, mat)
    # POV-Ray's camera: `angle` the horizontal field of view over `right`, whose default is
    # 1.33 x (not 4/3), with `up` y: at W x H its pixels are (W / H) / 1.33 as tall as wide
    # (a 0.25 % taller view at 4:3: up to 0.2 pixels at the image's top and bottom rows)
    aspect = (args.size[0] / args.size[1]) / POV_RIGHT
    scene.render.pixel_aspect_x = max(1.0, 1 / aspect)
    scene.render.pixel_aspect_y = max(1.0, aspect)
    loc, at, angle = spec["camera"]
    cam = bpy.data.cameras.new("PovBenchCam")
    cam.sensor_fit = "HORIZONTAL"
    cam.angle = math.radians(angle)
    cam.clip_start, cam.clip_end = 1e-3, 1e7   # the plane to its edge (the default ends at 100 m)
    co = bpy.data.objects.new("PovBenchCam", cam)
    scene.collection.objects.link(co)
    scene.camera = co
    co.location = blender(loc)
    look = mathutils.Vector(blender(at)) - mathutils.Vector(blender(loc))
    co.rotation_euler = look.to_track_quat("-Z", "Y").to_euler()
    exr = args.out + ".exr"
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = exr
    bpy.ops.render.render(write_still=True)
    im = bpy.data.images.load(exr)
    w, h = im.size
    px = np.array(im.pixels[:], np.float32).reshape(h, w, 4)[::-1, :, :3]
    np.save(args.out, np.ascontiguousarray(px))
    os.remove(exr)


run_main(main)
