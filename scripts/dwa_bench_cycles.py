"""Runs inside Blender for scripts/dwa_bench.py (docs/dwa_bench.md): Cycles lights a white
diffuse plane facing N with the EXR as the world (Environment Texture, Background strength 1,
no bounce, 1024 samples, or $CYC_SAMPLES), an orthographic camera just above it renders 16 x 16
pixels to OUT.exr (Standard view, 32-bit), and the last line printed is
`RESULT {"cycles": pi x the mean radiance (RGB), "blender": version}`: the irradiance Cycles
computes at N (the plane is white: radiance = E / pi).

    blender -b --factory-startup --python scripts/dwa_bench_cycles.py -- EXR OUT.exr NX NY NZ
"""
import json
import math
import os
import sys

# --help (after "--" under Blender, or as usual under python3) prints the above and ends here,
# before bpy is imported or anything runs.
if __name__ == "__main__" and {"-h", "--help"} & set(
        sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]):
    print("usage: blender -b --factory-startup --python %s -- EXR OUT.exr NX NY NZ\n\n%s"
          % ("scripts/" + os.path.basename(__file__), __doc__))
    sys.exit(0)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
exr, out, nx, ny, nz = argv[0], argv[1], *map(float, argv[2:5])
scene = bpy.context.scene
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o, do_unlink=True)
scene.render.engine = "CYCLES"
scene.cycles.samples = int(os.environ.get("CYC_SAMPLES", "1024"))
scene.cycles.use_denoising = False
scene.cycles.max_bounces = 0  # the plane's direct light from the world only
scene.render.resolution_x = scene.render.resolution_y = 16
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure = 0
scene.view_settings.gamma = 1
scene.render.filter_size = 0.01
world = bpy.data.worlds.new("w"); scene.world = world; world.use_nodes = True
nt = world.node_tree; bg = nt.nodes["Background"]
tex = nt.nodes.new("ShaderNodeTexEnvironment")
tex.image = bpy.data.images.load(exr)
tex.image.colorspace_settings.name = "Linear" if "Linear" in [c.name for c in
    bpy.types.ColorManagedInputColorspaceSettings.bl_rna.properties["name"].enum_items] else "Linear Rec.709"
nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
bg.inputs["Strength"].default_value = 1.0
# a white diffuse plane facing n, the camera just above it looking back at it
bpy.ops.mesh.primitive_plane_add(size=1000)
plane = bpy.context.object
mat = bpy.data.materials.new("white"); mat.use_nodes = True
mt = mat.node_tree
for node in list(mt.nodes):
    if node.type != "OUTPUT_MATERIAL":
        mt.nodes.remove(node)
diff = mt.nodes.new("ShaderNodeBsdfDiffuse"); diff.inputs["Color"].default_value = (1, 1, 1, 1)
mt.links.new(diff.outputs["BSDF"], mt.nodes["Material Output"].inputs["Surface"])
plane.data.materials.append(mat)
n = np.array([nx, ny, nz])
rot = np.array([0, 0, 1.0])
plane.rotation_mode = "QUATERNION"
axis = np.cross(rot, n); s = np.linalg.norm(axis); c = float(rot @ n)
if s > 1e-9:
    axis = axis / s; ang = math.atan2(s, c)
    plane.rotation_quaternion = (math.cos(ang / 2), *(axis * math.sin(ang / 2)))
bpy.ops.object.camera_add()
cam = bpy.context.object; scene.camera = cam
cam.data.type = "ORTHO"; cam.data.ortho_scale = 0.1
cam.rotation_mode = "QUATERNION"; cam.rotation_quaternion = plane.rotation_quaternion
cam.location = tuple(n * 0.01)
cam.data.clip_start = 0.001
plane.visible_shadow = False
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
img = bpy.data.images.load(out)
v = np.array(img.pixels[:]).reshape(-1, 4)[:, :3].mean(0)
print("RESULT " + json.dumps({"cycles": list(v * math.pi), "blender": bpy.app.version_string}))
