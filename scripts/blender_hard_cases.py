"""Runs inside Blender for tests/py_blender_hard_cases.py: Create Lights on hard cases and bad
input (issue 14), each world set up as a user would have it, the scene fingerprinted before and
after the button:

    blender -b --factory-startup --python scripts/blender_hard_cases.py -- SPEC.json

With a window (no -b; under `xvfb-run -a`) it runs the undo sequence instead (bpy.ops.ed.undo
needs a window): Create, Remove, Undo, Undo, Redo, Redo, a fingerprint after each.

SPEC (JSON): {"zip": the add-on zip, "out": RESULT.json, "cases": [CASE, ...]} or
{"zip", "out", "undo": {"hdr": PATH}}. A CASE: {"name", "world": "none" (no world nodes) |
"background" (a Background, no texture) | "texture" (default), and for a texture:
  "image": {"file": PATH (loaded), "missing": true (the file is deleted and the image reloaded),
            "pack": true (packed, then the file deleted), "png_from": NPY (an 8-bit PNG written
            from these RGBA pixels, row 0 at the top, then loaded as PATH),
            "generated": NPY or null (bpy.data.images.new, "float": true/false, size "size";
            the pixels, row 0 at the top, set through Image.pixels)} or absent (no image),
  "projection": "MIRROR_BALL", "group_depth": N (the texture inside N nested node groups),
  "panorama": PATH.exr (render the world as Blender shows it, before the button),
  "first": IMAGE (a successful Create with that image first, then the case's image)}.
RESULT: per case: the operator's status or its ERROR report (the RuntimeError bpy.ops raises in
-b), the panel's message and power, the lamps, the image as Blender holds it, and the
fingerprints before and after. Blender exits 1 (a traceback) if anything else raises."""
import json
import os
import sys

# --help prints the above and ends here, before bpy is imported or anything runs
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_help import exit_on_help  # noqa: E402
if __name__ == "__main__":
    exit_on_help(__doc__, __file__)

import bpy
import numpy as np

import blender_addon_check as check  # noqa: E402  (its helpers; it runs nothing when imported)
from blender_scene import run_main  # noqa: E402


def _r(v):
    """A value for the fingerprint: floats rounded (1e-6), sequences as lists."""
    if isinstance(v, float):
        return round(v, 6)
    if isinstance(v, (str, int, bool)) or v is None:
        return v
    try:
        return [_r(x) for x in v]
    except TypeError:
        return str(v)


def _tree(tree):
    nodes = []
    for n in sorted(tree.nodes, key=lambda n: n.name):
        ins = [(s.identifier, _r(s.default_value)) for s in n.inputs
               if not s.is_linked and hasattr(s, "default_value")]
        nodes.append({"name": n.name, "type": n.bl_idname, "label": n.label,
                      "location": _r(n.location), "keys": sorted(n.keys()),
                      "active": getattr(n, "is_active_output", None),
                      "image": n.image.name if getattr(n, "image", None) else None,
                      "projection": getattr(n, "projection", None),
                      "group": n.node_tree.name if getattr(n, "node_tree", None) else None,
                      "inputs": ins})
    links = sorted((l.from_node.name, l.from_socket.identifier, l.to_node.name,
                    l.to_socket.identifier) for l in tree.links)
    return {"nodes": nodes, "links": [list(l) for l in links]}


def fingerprint():
    """Everything Create Lights could change: objects, lamps, collections, images, node groups,
    worlds (nodes, links, active output, custom properties, sampling), the scene's world."""
    scene = bpy.context.scene
    d = bpy.data
    out = {
        "counts": {k: len(getattr(d, k)) for k in ("objects", "lights", "collections", "images",
                                                    "node_groups", "worlds", "materials",
                                                    "meshes", "textures", "cameras")},
        "objects": [{"name": o.name, "type": o.type, "data": o.data.name if o.data else None,
                     "collections": sorted(c.name for c in o.users_collection),
                     "matrix": _r([list(r) for r in o.matrix_world]), "keys": sorted(o.keys())}
                    for o in sorted(d.objects, key=lambda o: o.name)],
        "lights": [{"name": l.name, "type": l.type, "energy": _r(l.energy),
                    "color": _r(l.color), "keys": sorted(l.keys())}
                   for l in sorted(d.lights, key=lambda l: l.name)],
        "collections": [{"name": c.name, "objects": sorted(o.name for o in c.objects),
                         "children": sorted(x.name for x in c.children)}
                        for c in sorted(d.collections, key=lambda c: c.name)],
        "scene_collections": sorted(c.name for c in scene.collection.children),
        "images": [{"name": i.name, "source": i.source, "filepath": i.filepath,
                    "packed": i.packed_file is not None, "keys": sorted(i.keys())}
                   for i in sorted(d.images, key=lambda i: i.name)],
        "node_groups": {g.name: _tree(g) for g in d.node_groups},
        "scene_world": scene.world.name if scene.world else None,
        "worlds": {},
    }
    for w in d.worlds:
        out["worlds"][w.name] = {
            "use_nodes": w.use_nodes, "tree": _tree(w.node_tree) if w.node_tree else None,
            # ID properties but the storage of registered property groups (the add-on's
            # settings, whose panel message is UI state; Cycles', made on first access)
            "props": {k: _r(w[k]) if not hasattr(w[k], "to_dict") else _r(w[k].to_dict())
                      for k in w.keys() if k not in w.bl_rna.properties},
            "sampling": [w.cycles.sampling_method, w.cycles.sample_map_resolution],
            "sun_threshold": _r(getattr(w, "sun_threshold", None))}
    return out


def _rgba_top_down(path):
    a = np.load(path).astype(np.float32)
    if a.shape[2] == 3:
        a = np.concatenate([a, np.ones(a.shape[:2] + (1,), np.float32)], axis=2)
    return a


def make_image(spec, name):
    """The case's image datablock (see SPEC), or None."""
    if spec is None:
        return None
    if "generated" in spec:
        w, h = spec["size"]
        img = bpy.data.images.new(name, w, h, float_buffer=spec.get("float", False))
        if spec["generated"]:
            img.pixels.foreach_set(_rgba_top_down(spec["generated"])[::-1].ravel())
        return img
    path = spec["file"]
    if spec.get("png_from"):  # an 8-bit PNG written by Blender, then read back as a file
        a = _rgba_top_down(spec["png_from"])
        tmp = bpy.data.images.new("png writer", a.shape[1], a.shape[0])
        tmp.pixels.foreach_set(a[::-1].ravel())
        tmp.filepath_raw = path
        tmp.file_format = "PNG"
        tmp.save()
        bpy.data.images.remove(tmp)
    img = bpy.data.images.load(path)
    img.name = name
    if spec.get("pack"):
        img.pack()
        os.remove(path)
        img.reload()  # from the packed data now
    if spec.get("missing"):
        os.remove(path)
        img.reload()
    return img


def setup_case(case):
    """A fresh world for the case (the scene emptied first): see SPEC."""
    scene = bpy.context.scene
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    for coll in (bpy.data.lights, bpy.data.images, bpy.data.node_groups, bpy.data.cameras):
        for x in list(coll):
            coll.remove(x)
    for c in list(bpy.data.collections):
        bpy.data.collections.remove(c)
    world = bpy.data.worlds.new("Case " + case["name"])
    scene.world = world
    for w in list(bpy.data.worlds):
        if w != world:
            bpy.data.worlds.remove(w)
    kind = case.get("world", "texture")
    if kind == "none":
        world.use_nodes = False
        return world, None
    world.use_nodes = True
    tree = world.node_tree
    if kind == "background":
        return world, None
    bg = tree.nodes["Background"]
    t, feed = tree, bg.inputs["Color"]
    for i in range(case.get("group_depth", 0)):  # the texture inside nested node groups
        grp = bpy.data.node_groups.new("UserGroup%d" % (i + 1), "ShaderNodeTree")
        gout = grp.nodes.new("NodeGroupOutput")
        if hasattr(grp, "outputs"):
            grp.outputs.new("NodeSocketColor", "Color")
        else:  # 4.x interface API
            grp.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
        gnode = t.nodes.new("ShaderNodeGroup")
        gnode.node_tree = grp
        t.links.new(gnode.outputs[0], feed)
        t, feed = grp, gout.inputs[0]
    env = t.nodes.new("ShaderNodeTexEnvironment")
    env.name = "UserEnvTexture"
    if case.get("projection"):
        env.projection = case["projection"]
    t.links.new(env.outputs["Color"], feed)
    env.image = make_image(case.get("image"), "UserImage")
    return world, env


def image_state(img):
    if img is None:
        return None
    return {"name": img.name, "source": img.source, "size": list(img.size),
            "is_float": img.is_float, "depth": img.depth, "channels": img.channels,
            "colorspace": img.colorspace_settings.name, "packed": img.packed_file is not None,
            "file_exists": os.path.isfile(bpy.path.abspath(img.filepath))
            if img.filepath else None}


def press_create():
    """The button: the operator's status, or its ERROR report (bpy.ops raises RuntimeError
    with the report's text in -b)."""
    try:
        return {"rc": list(bpy.ops.envlight.create_lights()), "report": None}
    except RuntimeError as e:
        return {"rc": None, "report": str(e)}


def run_case(case, settings):
    from envlight_addon import core
    world, env = setup_case(case)
    s = world.envlight
    for k, v in settings.items():
        setattr(s, k, v)
    out = {"name": case["name"], "image": image_state(env.image if env else None)}
    if case.get("panorama"):
        check.render_panorama(bpy.context.scene, case["panorama"])
    if case.get("first"):  # a successful run first: its lamps must survive the failing one
        good = env.image
        env.image = make_image(case["first"], "FirstImage")
        out["first"] = press_create()
        env.image = good
    core.last_result = None
    out["before"] = fingerprint()
    out.update(press_create())
    out["after"] = fingerprint()
    out["message"] = s.result_message
    out["warnings"] = list((core.last_result or {}).get("warnings", []))
    out["lamps"] = [l for l in check.lamps() if l["tagged"]]
    out["power"] = list(s.result_power) if out["rc"] else None
    out["residual_power"] = list(s.result_residual_power) if out["rc"] else None
    return out


def undo_sequence(spec):
    """Create, Remove, Undo (-> as created), Undo (-> as before), Redo, Redo: each a button
    press or an Edit menu entry (one undo step each), a fingerprint after each."""
    case = {"name": "undo", "image": {"file": spec["hdr"]}}
    world, _ = setup_case(case)
    for k, v in spec.get("settings", {}).items():
        setattr(world.envlight, k, v)
    out = {"undo_poll": None, "states": {}}
    bpy.ops.ed.undo_push(message="before envlight")
    out["states"]["before"] = fingerprint()
    out["create"] = list(bpy.ops.envlight.create_lights("EXEC_DEFAULT", True))
    out["states"]["created"] = fingerprint()
    out["remove"] = list(bpy.ops.envlight.remove("EXEC_DEFAULT", True))
    out["states"]["removed"] = fingerprint()
    out["undo_poll"] = bpy.ops.ed.undo.poll()
    for name, op in (("undo_remove", bpy.ops.ed.undo), ("undo_create", bpy.ops.ed.undo),
                     ("redo_create", bpy.ops.ed.redo), ("redo_remove", bpy.ops.ed.redo)):
        out[name + "_rc"] = list(op())
        out["states"][name] = fingerprint()  # bpy.data after undo: fresh references
    return out


def main():
    spec = check.spec_from_argv()
    result = {"blender": bpy.app.version_string, "blender_version": list(bpy.app.version)}
    check.install(spec["zip"])
    from envlight_addon import core
    result["library_path"] = os.path.realpath(core.shim().library_path)
    if spec.get("undo"):
        result["undo"] = undo_sequence(spec["undo"])
    else:
        result["cases"] = [run_case(c, spec.get("settings", {})) for c in spec["cases"]]
    with open(spec["out"], "w") as f:
        json.dump(result, f, indent=1)
    print("ENVLIGHT_CHECK_DONE", spec["out"])


if __name__ == "__main__":
    if bpy.app.background:
        run_main(main)
    else:
        bpy.app.timers.register(lambda: check.main_in_window(main), first_interval=0.5)
