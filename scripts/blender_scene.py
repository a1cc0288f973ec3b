"""Pieces shared by the scripts that run inside Blender (blender_addon_check.py,
blender_hard_cases.py, scene_bench_blender.py): one-node materials, a white diffuse unit sphere at
the origin seen by an orthographic camera on -Y, and the way a script ends."""
import math
import sys
import traceback

import bpy


def run_main(main):
    """Runs main() as a `blender -b --python` script: exit status 0, or the traceback and 1
    when it raises (Blender itself would exit 0)."""
    try:
        main()
    except Exception:
        traceback.print_exc()
        sys.exit(1)
    sys.exit(0)


def world_with_image(name, image_path, projection="EQUIRECTANGULAR"):
    """A new world `name`, made the scene's, lit by an Environment Texture of the image file
    (Blender loads it; its pixels are decoded on first use): -> (world, texture node)."""
    scene = bpy.context.scene
    world = bpy.data.worlds.new(name)
    scene.world = world
    world.use_nodes = True
    tree = world.node_tree
    tex = tree.nodes.new("ShaderNodeTexEnvironment")
    tex.projection = projection
    tex.image = bpy.data.images.load(image_path)
    tree.links.new(tex.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    return world, tex


def node_material(name, shader="ShaderNodeBsdfDiffuse", color=(1, 1, 1)):
    """A material whose surface is one shader node (Diffuse BSDF, Emission...) of `color`."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        if n.bl_idname != "ShaderNodeOutputMaterial":
            nt.nodes.remove(n)
    node = nt.nodes.new(shader)
    node.inputs["Color"].default_value = tuple(color)[:3] + (1,)
    nt.links.new(node.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    return mat


def add_white_sphere_and_camera(scene, name):
    """Adds the sphere (object `name`Sphere, material `name`White) and the camera (`name`Cam),
    and makes it the scene's camera."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0)
    sph = bpy.context.active_object
    sph.name = name + "Sphere"
    bpy.ops.object.shade_smooth()
    sph.data.materials.append(node_material(name + "White"))
    cam = bpy.data.cameras.new(name + "Cam")
    cam.type = "ORTHO"
    cam.ortho_scale = 2.2
    co = bpy.data.objects.new(name + "Cam", cam)
    scene.collection.objects.link(co)
    co.location = (0, -5, 0)
    co.rotation_euler = (math.radians(90), 0, 0)
    scene.camera = co
    return sph
