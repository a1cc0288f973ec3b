"""Runs inside Blender (headless) for tests/py_blender_addon.py and the benchmark:

    blender -b --factory-startup --python scripts/blender_addon_check.py -- SPEC.json

With a window (no -b; e.g. under `xvfb-run -a`), the same script runs from a timer once the
window is up, inside a context override of that window, and ends Blender with its exit status:
this is how "undo" is checked (bpy.ops.ed.undo needs a window).

SPEC (JSON): {"zip": add-on zip to install (optional: else the add-on must be importable),
  "hdr": image for the world's Environment Texture, "group": put the texture in a node group,
  "mapping": {"type": "POINT", "rotation": [x, y, z] degrees} (optional), "strength": 1.0,
  "pack": pack the image (Cycles then renders the pixels the add-on reads; a file-backed .hdr
  is read by Cycles through OpenImageIO, whose RGBE decode lacks Radiance's +0.5: 0.4 % darker),
  "settings": {count, method, shadows, world_mode, ...}, "runs": 2,
  "undo": true (Create Lights as one undo step, then undo and redo: needs a window),
  "user_lamp": true, "panorama": PATH.exr (render the world through an equirectangular camera),
  "render": {...} (see render_sphere), "source_pixels": PATH.npy (the Environment Texture's
  pixels as Blender decoded the file: float32 RGB, row 0 at the top), "out": RESULT.json}
Writes RESULT.json with what the tests check (lamps, powers, panel values, node counts; the
Blender version)."""
import json
import math
import os
import sys
import time

# --help prints the above and ends here, before bpy is imported or anything runs
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_help import exit_on_help  # noqa: E402
if __name__ == "__main__":
    exit_on_help(__doc__, __file__)

import bpy
import mathutils
import numpy as np

from blender_scene import add_white_sphere_and_camera, node_material, run_main  # noqa: E402


def spec_from_argv():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    with open(argv[0]) as f:
        return json.load(f)


def install(zip_path):
    bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True)
    bpy.ops.preferences.addon_enable(module="envlight_addon")
    import envlight_addon
    return envlight_addon


def setup_world(spec):
    scene = bpy.context.scene
    world = bpy.data.worlds.new("HDR World")
    scene.world = world
    world.use_nodes = True
    tree = world.node_tree
    bg = tree.nodes["Background"]
    bg.inputs["Strength"].default_value = spec.get("strength", 1.0)
    img = bpy.data.images.load(spec["hdr"])
    if spec.get("pack"):  # Cycles renders Blender's decode, not the file read through OIIO
        img.pack()
    mp = spec.get("mapping")
    if spec.get("group"):
        grp = bpy.data.node_groups.new("UserEnvGroup", "ShaderNodeTree")
        gout = grp.nodes.new("NodeGroupOutput")
        if hasattr(grp, "outputs"):
            grp.outputs.new("NodeSocketColor", "Color")
        else:  # 4.x interface API
            grp.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
        t = grp
        env = t.nodes.new("ShaderNodeTexEnvironment")
        env.image = img
        t.links.new(env.outputs["Color"], gout.inputs[0])
        gnode = tree.nodes.new("ShaderNodeGroup")
        gnode.node_tree = grp
        tree.links.new(gnode.outputs[0], bg.inputs["Color"])
    else:
        t = tree
        env = t.nodes.new("ShaderNodeTexEnvironment")
        env.image = img
        t.links.new(env.outputs["Color"], bg.inputs["Color"])
    if mp:
        tc = t.nodes.new("ShaderNodeTexCoord")
        m = t.nodes.new("ShaderNodeMapping")
        m.vector_type = mp.get("type", "POINT")
        m.inputs["Rotation"].default_value = [math.radians(a) for a in mp["rotation"]]
        t.links.new(tc.outputs["Generated"], m.inputs["Vector"])
        t.links.new(m.outputs["Vector"], env.inputs["Vector"])
    # a node of the user's own that must survive
    v = tree.nodes.new("ShaderNodeValue")
    v.name = "UserValue"
    return world, env


def lamps():
    out = []
    for o in bpy.data.objects:
        if o.type != "LIGHT":
            continue
        d = o.matrix_world.to_3x3() @ mathutils.Vector((0, 0, 1))
        out.append({"name": o.name, "tagged": bool(o.get("envlight")),
                    "collection": [c.name for c in o.users_collection],
                    "type": o.data.type, "energy": o.data.energy, "color": list(o.data.color),
                    "angle": getattr(o.data, "angle", None),
                    # Light.use_shadow: EEVEE's flag in 3.x, the only one (also Cycles') in 4.x;
                    # Cycles' own cycles.cast_shadow exists up to 3.x (None when absent)
                    "use_shadow": bool(o.data.use_shadow),
                    "cycles_cast_shadow": bool(o.data.cycles.cast_shadow)
                    if hasattr(getattr(o.data, "cycles", None), "cast_shadow") else None,
                    "direction": list(d.normalized()),
                    # Cycles: does the lamp light glossy reflections (3.0+)
                    "visible_glossy": getattr(o, "visible_glossy", None),
                    # the library light's solid angle (the add-on's custom property)
                    "solid_angle": o.get("envlight_solid_angle")})
    return out


def latlong_power(pixels_bottom_up, w, h, ch):
    a = np.asarray(pixels_bottom_up, dtype=np.float64).reshape(h, w, ch)[::-1, :, :3]
    r = np.arange(h)
    sa = (2 * np.pi / w) * (np.sin(np.pi * (0.5 - r / h)) - np.sin(np.pi * (0.5 - (r + 1) / h)))
    return list((a * sa[:, None, None]).sum(axis=(0, 1)))


def core_module():
    from envlight_addon import core
    return core


def path_to_active_output(tree, node):
    """Labels/names of the nodes from `node` along output links to the tree's active World
    Output (depth first), or None when no link path reaches it."""
    def walk(n, seen):
        if n.bl_idname == "ShaderNodeOutputWorld" and n.is_active_output:
            return [n.label or n.name]
        for o in n.outputs:
            for link in o.links:
                m = link.to_node
                if m.name in seen or not link.is_valid or getattr(link, "is_muted", False):
                    continue
                rest = walk(m, seen | {m.name})
                if rest is not None:
                    return [n.label or n.name] + rest
        return None
    return walk(node, {node.name})


def world_state(world):
    tree = world.node_tree
    active = [n.name for n in tree.nodes
              if n.bl_idname == "ShaderNodeOutputWorld" and n.is_active_output]
    res = next((n for n in tree.nodes if n.get("envlight") and
                n.bl_idname == "ShaderNodeTexEnvironment"), None)
    out = {"nodes": len(tree.nodes), "tagged_nodes": sum(1 for n in tree.nodes if n.get("envlight")),
           "user_value": "UserValue" in tree.nodes, "active_outputs": active,
           "images": [i.name for i in bpy.data.images],
           "image_sizes": {i.name: list(i.size) for i in bpy.data.images},
           "sampling": [world.cycles.sampling_method, world.cycles.sample_map_resolution],
           # EEVEE-Next's (4.2+) world sun extraction threshold; None: no such property (3.4)
           "sun_threshold": getattr(world, "sun_threshold", None),
           "labels": sorted(n.label for n in tree.nodes if n.get("envlight"))}
    clamp = next((n for n in tree.nodes if n.get("envlight") and
                  n.label == core_module().NODE_PREFIX + core_module().SH_CLAMP), None)
    if clamp is not None:
        # the SH world's clamp at 0: its operation, constant, what feeds it and the nodes from
        # it to the active World Output (downstream links, first path found)
        feed = clamp.inputs[0].links[0].from_node.label if clamp.inputs[0].is_linked else None
        out["sh_clamp"] = {"type": clamp.bl_idname, "operation": clamp.operation,
                           "constant": list(clamp.inputs[1].default_value),
                           "input": feed, "path_to_output": path_to_active_output(tree, clamp)}
    if res is not None and res.image is not None:
        img = res.image
        buf = np.empty(img.size[0] * img.size[1] * img.channels, np.float32)
        img.pixels.foreach_get(buf)
        from envlight_addon import eevee_dome
        w, h, ch = img.size[0], img.size[1], img.channels
        rows = buf.reshape(h, w, ch)[::-1, :, :3]     # Blender's rows bottom up: row 0 top
        I, M = eevee_dome.moments(np, rows)
        out["residual_image"] = {"name": img.name, "size": list(img.size),
                                 "packed": img.packed_file is not None,
                                 "power": latlong_power(buf, w, h, ch),
                                 # EEVEE-Next derings the world's L1 above DERING_BOUND
                                 "dering_measure": eevee_dome.dering_measure(np, I, M)}
    return out


def raytracing_state(scene):
    """Scene.eevee's ray tracing settings the add-on may change (None before 4.2)."""
    e = scene.eevee
    if not hasattr(e, "ray_tracing_options"):
        return None
    rt = e.ray_tracing_options
    return {"use_raytracing": e.use_raytracing, "ray_tracing_method": e.ray_tracing_method,
            "trace_max_roughness": rt.trace_max_roughness,
            "resolution_scale": rt.resolution_scale,
            "clamp_surface_indirect": e.clamp_surface_indirect}


def add_objects(scene, objects):
    """The spec's "objects": [{"kind": "sphere"|"plane"|"cube", "name", "location", "size",
    "material": {"type": "diffuse"|"principled", "color": [r, g, b], "roughness",
    "metallic"}}]: a scene for Create Lights to read."""
    for spec in objects:
        kind, loc, size = spec["kind"], spec.get("location", (0, 0, 0)), spec.get("size", 1.0)
        if kind == "sphere":
            bpy.ops.mesh.primitive_uv_sphere_add(radius=size, location=loc)
        elif kind == "plane":
            bpy.ops.mesh.primitive_plane_add(size=size, location=loc)
        else:
            bpy.ops.mesh.primitive_cube_add(size=size, location=loc)
        o = bpy.context.active_object
        o.name = spec["name"]
        ms = spec.get("material")
        if ms:
            col = list(ms.get("color", (0.8, 0.8, 0.8)))
            if ms["type"] == "diffuse":
                m = node_material(spec["name"] + "Material", color=col)
            else:
                m = bpy.data.materials.new(spec["name"] + "Material")
                m.use_nodes = True
                pb = m.node_tree.nodes["Principled BSDF"]
                pb.inputs["Base Color"].default_value = col + [1.0]
                pb.inputs["Roughness"].default_value = ms.get("roughness", 0.5)
                pb.inputs["Metallic"].default_value = ms.get("metallic", 0.0)
            o.data.materials.append(m)


def setup_render(scene, spec):
    r = spec.get("render", {})
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    scene.cycles.samples = r.get("samples", 16)
    if hasattr(scene.cycles, "use_adaptive_sampling"):
        scene.cycles.use_adaptive_sampling = False
    scene.cycles.max_bounces = r.get("bounces", 1)
    scene.cycles.seed = r.get("seed", 0)
    scene.render.resolution_x = r.get("size", 64)
    scene.render.resolution_y = r.get("size", 64)
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.threads_mode = "FIXED"
    scene.render.threads = r.get("threads", 2)


def render_panorama(scene, path, w=256):
    """The world as seen from the origin, through an equirectangular camera oriented so that
    the render is the canonical lat-long frame (measured: rotation (90, 0, -90) degrees)."""
    cam = bpy.data.cameras.new("EnvLightCheckPano")
    cam.type = "PANO"
    if hasattr(cam, "cycles") and hasattr(cam.cycles, "panorama_type"):
        cam.cycles.panorama_type = "EQUIRECTANGULAR"
    else:
        cam.panorama_type = "EQUIRECTANGULAR"
    obj = bpy.data.objects.new("EnvLightCheckPano", cam)
    scene.collection.objects.link(obj)
    obj.rotation_euler = (math.radians(90), 0, math.radians(-90))
    old_cam, old = scene.camera, (scene.render.resolution_x, scene.render.resolution_y)
    scene.camera = obj
    setup_render(scene, {"render": {"samples": 1, "size": w}})
    scene.render.resolution_x, scene.render.resolution_y = w, w // 2
    scene.cycles.filter_width = 0.01
    # hide lamps and meshes: the world only
    hidden = []
    for o in scene.objects:
        if o.type in ("LIGHT", "MESH") and not o.hide_render:
            o.hide_render = True
            hidden.append(o)
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    for o in hidden:
        o.hide_render = False
    scene.camera = old_cam
    scene.render.resolution_x, scene.render.resolution_y = old
    bpy.data.objects.remove(obj)
    return path


def render_sphere(scene, path, spec):
    """A white diffuse sphere (radius 1 at the origin) seen by a camera on -Y, Cycles."""
    if "EnvLightCheckSphere" not in bpy.data.objects:
        add_white_sphere_and_camera(scene, "EnvLightCheck")
    setup_render(scene, spec)
    scene.render.film_transparent = True  # the background is not part of the comparison
    scene.render.filepath = path
    t = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - t
    # the pixels, row 0 at the top, as .npy for the tests
    img = bpy.data.images.load(path)
    buf = np.empty(img.size[0] * img.size[1] * img.channels, np.float32)
    img.pixels.foreach_get(buf)
    np.save(path + ".npy", buf.reshape(img.size[1], img.size[0], img.channels)[::-1])
    bpy.data.images.remove(img)
    return seconds


def probes():
    """The scene's light probe objects (the add-on's volume probe)."""
    return [{"name": o.name, "tagged": bool(o.get("envlight")), "type": o.data.type,
             "data_tagged": bool(o.data.get("envlight")),
             "location": list(o.location), "scale": list(o.scale),
             "normal_bias": getattr(o.data, "normal_bias", None),
             "resolution": [getattr(o.data, "resolution_" + a, None) for a in "xyz"]}
            for o in bpy.data.objects if o.type == "LIGHT_PROBE"]


def eevee_ground_ring(scene, r0, r1, size=64, width=4.0):
    """Mean luminance of the ground (z = 0) between r0 and r1 from the origin, in an EEVEE
    render from straight above (orthographic, `width` across, so pixel (i, j) is the ground
    point x = (j + 0.5) / size * width - width / 2, y likewise from the top)."""
    cam = bpy.data.cameras.new("EnvLightCheckTop")
    cam.type = "ORTHO"
    cam.ortho_scale = width
    obj = bpy.data.objects.new("EnvLightCheckTop", cam)
    scene.collection.objects.link(obj)
    obj.location = (0, 0, 10)
    old_cam, scene.camera = scene.camera, obj
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.filter_size = 0.01
    scene.eevee.taa_render_samples = 16
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    path = os.path.join(os.path.dirname(spec_from_argv()["out"]), "eevee_top.exr")
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(path)
    img = bpy.data.images.load(path)
    buf = np.empty(size * size * 4, np.float32)
    img.pixels.foreach_get(buf)
    bpy.data.images.remove(img)
    y = buf.reshape(size, size, 4)[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    c = (np.arange(size) + 0.5) / size * width - width / 2
    r = np.hypot(c[None, :], c[:, None])
    scene.camera = old_cam
    bpy.data.objects.remove(obj)
    return float(y[(r > r0) & (r < r1)].mean())


def undo_redo():
    """The state before Create Lights (an undo step, as after any edit in the UI), after it
    (called with undo=True, as a button press: one undo step), after Edit > Undo, after Redo."""
    def state():
        world = bpy.context.scene.world
        return {"lamps": lamps(), "world": world_state(world), "world_name": world.name,
                "has_result": world.envlight.has_result}
    out = {}
    bpy.ops.ed.undo_push(message="before envlight")
    out["before"] = state()
    out["rc"] = list(bpy.ops.envlight.create_lights("EXEC_DEFAULT", True))
    out["created"] = state()
    out["undo_poll"] = bpy.ops.ed.undo.poll()  # False in blender -b
    bpy.ops.ed.undo()
    out["after_undo"] = state()
    bpy.ops.ed.redo()
    out["after_redo"] = state()
    return out


def main():
    spec = spec_from_argv()
    result = {"blender": bpy.app.version_string, "blender_version": list(bpy.app.version)}
    scene = bpy.context.scene
    for o in list(bpy.data.objects):  # factory startup: cube, camera, light
        bpy.data.objects.remove(o)
    if spec.get("zip"):
        mod = install(spec["zip"])
    else:
        import envlight_addon as mod
        mod.register()
    from envlight_addon import core
    pkg = core.shim()
    result["addon_file"] = mod.__file__
    result["library_path"] = os.path.realpath(pkg.library_path)
    world, env_node = setup_world(spec)
    if spec.get("source_pixels"):
        # what the add-on reads: Blender's decode of the file (Blender 4.x decodes RGBE without
        # Radiance's +0.5, Blender 3.4 and the library with it), for the tests' expected values
        img = env_node.image
        buf = np.empty(img.size[0] * img.size[1] * img.channels, np.float32)
        img.pixels.foreach_get(buf)
        np.save(spec["source_pixels"],
                buf.reshape(img.size[1], img.size[0], img.channels)[::-1, :, :3])
    if spec.get("user_lamp", True):
        ld = bpy.data.lights.new("UserLamp", "POINT")
        ud = bpy.data.objects.new("UserLamp", ld)
        scene.collection.objects.link(ud)
    result["world_properties"] = sorted(p.identifier for p in bpy.types.World.bl_rna.properties
                                        if p.identifier.startswith("sun_")
                                        or p.identifier.startswith("use_sun"))
    if spec.get("sun_threshold") is not None and hasattr(world, "sun_threshold"):
        world.sun_threshold = spec["sun_threshold"]  # the user's own value, for Remove
    result["world_before"] = {"sun_threshold": getattr(world, "sun_threshold", None)}
    add_objects(scene, spec.get("objects", []))
    if spec.get("engine"):
        scene.render.engine = spec["engine"]
    if spec.get("lighting_width"):  # a small map takes the path of one wider than this
        core.LIGHTING_WIDTH = spec["lighting_width"]
    if spec.get("probe_resolution"):  # EEVEE's world probe (4.2+) or cube map (3.x)
        if hasattr(world, "probe_resolution"):
            world.probe_resolution = spec["probe_resolution"]
        else:
            scene.eevee.gi_cubemap_resolution = spec["probe_resolution"]
    s = world.envlight
    for k, v in spec.get("settings", {}).items():
        setattr(s, k, v)
    if spec.get("raytracing_before") and hasattr(scene.eevee, "ray_tracing_options"):
        # the user's own ray tracing settings, for Remove to give back
        for k, v in spec["raytracing_before"].items():
            setattr(scene.eevee.ray_tracing_options if k in ("trace_max_roughness",
                    "resolution_scale") else scene.eevee, k, v)
    result["raytracing_before"] = raytracing_state(scene)
    if spec.get("reference_render"):
        result["reference_seconds"] = render_sphere(scene, spec["reference_render"], spec)
    if spec.get("reference_render_2"):  # another seed: the render noise
        spec2 = dict(spec, render=dict(spec.get("render", {}),
                                       seed=spec.get("render", {}).get("seed", 0) + 1))
        render_sphere(scene, spec["reference_render_2"], spec2)
    if spec.get("panorama_before"):
        render_panorama(scene, spec["panorama_before"])
    if spec.get("undo"):
        result["undo"] = undo_redo()
        scene = bpy.context.scene  # undo rebuilt the data: fresh references
        world = scene.world
        s = world.envlight
    result["world_state_before"] = world_state(world)
    runs = []
    for i in range(spec.get("runs", 1)):
        if spec.get("trace_python"):
            # the most memory Python (numpy, ctypes) holds at once during the button: not the
            # library's malloc nor Blender's images (tracemalloc counts Python's allocators)
            import tracemalloc
            tracemalloc.start()
            traced0 = tracemalloc.get_traced_memory()[0]
        t = time.perf_counter()
        rc = bpy.ops.envlight.create_lights()
        seconds = time.perf_counter() - t
        traced = None
        if spec.get("trace_python"):
            traced = tracemalloc.get_traced_memory()[1] - traced0
            tracemalloc.stop()
        runs.append({"rc": list(rc), "seconds": seconds, "lamps": lamps(),
                     "engine": scene.render.engine, "python_peak": traced,
                     "world": world_state(world),
                     "panel": {"count": s.result_count, "error_percent": s.result_error,
                               "seconds": s.result_seconds, "power": list(s.result_power),
                               "residual_power": list(s.result_residual_power),
                               "message": s.result_message},
                     # the SH figures of the dict create_lights returned (doubles, unrounded)
                     "sh": {k: v for k, v in (core.last_result or {}).items()
                            if k.startswith("sh_")},
                     "notes": list((core.last_result or {}).get("notes", [])),
                     # the plan Create Lights made from the scene (or the panel)
                     "plan": {k: (core.last_result or {}).get(k) for k in (
                         "recipe", "reasons", "skipped", "ground_object", "ground_albedo",
                         "ground_edge", "expected")},
                     "probes": probes(),
                     "raytracing": raytracing_state(scene),
                     "panel_recipe": s.result_recipe,
                     "panel_skipped": s.result_skipped})
    result["runs"] = runs
    if spec.get("record_progress"):
        # the operator's progress bar, as create_lights drives it: the values between 0.2 and
        # 0.6 come from the library's own callback while it fits (issue 16)
        values = []
        core.create_lights(bpy.context, s, progress=values.append)
        result["progress"] = values
    if spec.get("render_after"):
        result["approx_seconds"] = render_sphere(scene, spec["render_after"], spec)
    if spec.get("render_after_2"):  # another seed: the approximation's own render noise
        spec2 = dict(spec, render=dict(spec.get("render", {}),
                                       seed=spec.get("render", {}).get("seed", 0) + 1))
        render_sphere(scene, spec["render_after_2"], spec2)
    if spec.get("probe_effect"):
        # the ground around a sphere at the origin (radius 1, on z = 0), with the baked probe
        # and once its object is deleted (the bake lives on it)
        r0, r1 = spec["probe_effect"]
        with_probe = eevee_ground_ring(scene, r0, r1)
        for o in [o for o in bpy.data.objects if o.type == "LIGHT_PROBE" and o.get("envlight")]:
            bpy.data.objects.remove(o, do_unlink=True)
        result["probe_effect"] = {"with": with_probe,
                                  "without": eevee_ground_ring(scene, r0, r1)}
    if spec.get("panorama"):
        render_panorama(scene, spec["panorama"])
    if spec.get("bad_file"):
        s.source = "FILE"
        s.filepath = spec["bad_file"]
        try:
            rc = bpy.ops.envlight.create_lights()
            result["bad_file"] = {"rc": list(rc)}
        except RuntimeError as e:  # the operator's ERROR report surfaces as RuntimeError
            result["bad_file"] = {"report": str(e)}
        result["bad_file"]["message"] = s.result_message
        result["bad_file"]["lamps_after"] = len(lamps())
        s.source = "WORLD"
    if spec.get("remove"):
        bpy.ops.envlight.remove()
        result["after_remove"] = {"lamps": lamps(), "world": world_state(scene.world),
                                  "probes": probes(), "raytracing": raytracing_state(scene),
                                  "lightprobe_data": [d.name for d in bpy.data.lightprobes]}
    with open(spec["out"], "w") as f:
        json.dump(result, f, indent=1)
    print("ENVLIGHT_CHECK_DONE", spec["out"])


def main_in_window(entry=None):
    """Timer callback: `entry` (default main()) inside the first window's context, then Blender
    ends with its status (os._exit: sys.exit from a timer would only be reported)."""
    status = 1
    try:
        win = bpy.context.window_manager.windows[0]
        with bpy.context.temp_override(window=win, screen=win.screen):
            (entry or main)()
        status = 0
    except Exception:
        import traceback
        traceback.print_exc()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


if __name__ == "__main__":  # blender --python runs it as __main__; other scripts import it
    if bpy.app.background:
        run_main(main)
    else:
        bpy.app.timers.register(main_in_window, first_interval=0.5)
