"""What the Create Lights button does, apart from the UI: find the world's Environment Texture,
compute with libenvlight, build sun lamps and the world nodes.

Everything the add-on creates carries the custom property TAG (objects, lamps, the collection,
world nodes, images), so a re-run or Remove deletes exactly that and never the user's own
lamps or nodes.
"""
import math
import os
import tempfile
import time

import bpy
import mathutils

TAG = "envlight"
COLLECTION = "EnvLight"
NODE_PREFIX = "EnvLight "
#: world custom property: the name of the user's World Output that was active before ours
USER_OUTPUT = "envlight_user_output"
# the user's Cycles world sampling settings while the SH world is in place
USER_SAMPLING = "envlight_user_sampling"
# the SH world is an order-2 polynomial: a 64 x 32 importance map holds it. Cycles' default map
# (1024) is evaluated through the SH node tree at every render (measured on a 64 x 64 px sphere:
# 3.0 s of a 3.1 s render at 16 spp, 0.08 s with 64)
SH_MAP_RESOLUTION = 64
# the user's EEVEE-Next (Blender 4.2+) World.sun_threshold while our world is in place: EEVEE
# turns the world's radiance above it into a sun light, which would count again the light
# envlight's sun lamps already carry; 0 is the documented "off" ("If non-zero, ...")
USER_SUN_THRESHOLD = "envlight_user_sun_threshold"
SUN_THRESHOLD_OFF = 0.0

# order-2 real SH basis constants (DESIGN.md, Ramamoorthi & Hanrahan 2001)
_Y00, _Y1, _Y2, _Y20, _Y22 = 0.282095, 0.488603, 1.092548, 0.315392, 0.546274
# Rec. 709 luminance weights (DESIGN.md, the library's envl_luminance)
LUMINANCE = (0.2126, 0.7152, 0.0722)
#: the label (after NODE_PREFIX) of the SH world's clamp at 0, the chain's last node
SH_CLAMP = "SH Clamp"
#: the dict the last create_lights returned (for scripts and tests; the panel shows a summary)
last_result = None


def shim():
    """The envlight package: always the add-on's own copy (scripts/blender_addon_zip.py puts
    the shim and lib/libenvlight.so.1 inside the zip), never an `envlight` on sys.path, which
    could be another version with another library."""
    from . import envlight as pkg
    return pkg


def tagged(idblock_or_node):
    try:
        return bool(idblock_or_node.get(TAG))
    except (AttributeError, TypeError):
        return False


# ---- finding the source ------------------------------------------------------------------------

class Source:
    """The world's Environment Texture as found: the node, the tree holding it, its Mapping
    rotation and the Background strength it feeds."""

    def __init__(self, node, tree):
        self.node = node
        self.tree = tree
        self.mapping = None
        self.strength = 1.0
        self.warnings = []


def _active_output(tree):
    outs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    for n in outs:
        if n.is_active_output:
            return n
    return outs[0] if outs else None


def _upstream_env(tree, node, seen):
    """Depth-first search upstream of `node` for an Environment Texture, into node groups."""
    if node is None or (tree, node.name) in seen:
        return None
    seen.add((tree, node.name))
    if node.bl_idname == "ShaderNodeTexEnvironment" and not tagged(node):
        return Source(node, tree)
    if node.bl_idname == "ShaderNodeGroup" and node.node_tree:
        inner = node.node_tree
        gout = next((n for n in inner.nodes if n.bl_idname == "NodeGroupOutput"), None)
        found = _upstream_env(inner, gout, seen)
        if found:
            return found
    for sock in node.inputs:
        for link in sock.links:
            found = _upstream_env(tree, link.from_node, seen)
            if found:
                return found
    return None


def find_environment_texture(world):
    """The Environment Texture that drives the world: upstream of the active World Output
    (through node groups), else any Environment Texture in the tree or its groups."""
    if not world or not world.use_nodes or not world.node_tree:
        return None
    tree = world.node_tree
    found = _upstream_env(tree, _active_output(tree), set())
    if found:
        return found
    stack = [tree]
    while stack:
        t = stack.pop()
        for n in t.nodes:
            if n.bl_idname == "ShaderNodeTexEnvironment" and not tagged(n):
                return Source(n, t)
            if n.bl_idname == "ShaderNodeGroup" and n.node_tree:
                stack.append(n.node_tree)
    return None


def _from_node(sock):
    """The node feeding an input socket, skipping reroutes."""
    while sock.links:
        node = sock.links[0].from_node
        if node.bl_idname == "NodeReroute":
            sock = node.inputs[0]
            continue
        return node
    return None


def inspect_source(src):
    """Reads the Mapping node feeding the texture's Vector and the Background strength."""
    m = _from_node(src.node.inputs["Vector"])
    if m is not None and m.bl_idname == "ShaderNodeMapping":
        src.mapping = m
        for name in ("Rotation", "Location", "Scale"):
            s = m.inputs.get(name)
            if s is not None and s.is_linked:
                src.warnings.append("the Mapping node's %s is linked: its value is not used"
                                    % name)
        loc = m.inputs.get("Location")
        if loc is not None and m.vector_type in ("POINT", "TEXTURE") and \
                any(abs(v) > 1e-9 for v in loc.default_value):
            src.warnings.append("the Mapping node's Location is ignored for directions")
    elif m is not None:
        src.warnings.append("the texture's Vector comes from %s, not a Mapping node: "
                            "treated as the plain direction" % m.bl_idname)
    for link in src.node.outputs["Color"].links:
        if link.to_node.bl_idname == "ShaderNodeBackground":
            st = link.to_node.inputs["Strength"]
            if not st.is_linked:
                src.strength = float(st.default_value)
            break
    return src


def mapping_matrix(mapping):
    """World direction of image direction d: v = R d (a 3x3 matrix). The Environment Texture
    looks up M v for Mapping types POINT/VECTOR/NORMAL (M = the Euler XYZ rotation), and M^-1 v
    for TEXTURE; the image direction d shows in world direction v = M^-1 d or M d."""
    if mapping is None:
        return mathutils.Matrix.Identity(3)
    rot = mapping.inputs["Rotation"].default_value
    m = mathutils.Euler((rot[0], rot[1], rot[2]), "XYZ").to_matrix()
    return m if mapping.vector_type == "TEXTURE" else m.inverted()


def image_pixels(image):
    """Blender's float pixels (RGBA, row 0 at the bottom) -> numpy (flat), width, height,
    channels, for envlight.from_pixels(..., flip=True)."""
    import numpy as np
    w, h = image.size
    if w == 0 or h == 0:
        raise RuntimeError("image '%s' has no pixels (file missing?)" % image.name)
    ch = image.channels
    buf = np.empty(w * h * ch, dtype=np.float32)
    image.pixels.foreach_get(buf)
    return buf, w, h, ch


# ---- removing what we made ---------------------------------------------------------------------

def remove_created(world):
    """Deletes what a previous run created (tagged objects, lamps, nodes, residual images)
    and re-activates the user's World Output."""
    removed = 0
    for obj in [o for o in bpy.data.objects if tagged(o)]:
        data = obj.data
        bpy.data.objects.remove(obj, do_unlink=True)
        removed += 1
        if data is not None and tagged(data) and data.users == 0:
            bpy.data.lights.remove(data)
    for coll in [c for c in bpy.data.collections if tagged(c)]:
        if len(coll.objects) == 0 and len(coll.children) == 0:
            bpy.data.collections.remove(coll)
    if world and world.node_tree:
        tree = world.node_tree
        for n in [n for n in tree.nodes if tagged(n)]:
            tree.nodes.remove(n)
        name = world.get(USER_OUTPUT)
        if name and name in tree.nodes:
            tree.nodes[name].is_active_output = True
        if USER_OUTPUT in world:
            del world[USER_OUTPUT]
    if world is not None:
        restore_world_sampling(world)
        restore_sun_extraction(world)
    for img in [i for i in bpy.data.images if tagged(i) and i.users == 0]:
        bpy.data.images.remove(img)
    return removed


def set_world_sampling(world, resolution):
    """Cycles' world importance map at `resolution`, the user's settings kept for Remove."""
    cw = getattr(world, "cycles", None)
    if cw is None or not hasattr(cw, "sample_map_resolution"):
        return
    if USER_SAMPLING not in world:
        world[USER_SAMPLING] = {"method": cw.sampling_method,
                                "resolution": cw.sample_map_resolution}
    cw.sampling_method = "MANUAL"
    cw.sample_map_resolution = resolution


def restore_world_sampling(world):
    saved = world.get(USER_SAMPLING)
    if saved is None:
        return
    cw = getattr(world, "cycles", None)
    if cw is not None:
        cw.sampling_method = saved["method"]
        cw.sample_map_resolution = int(saved["resolution"])
    del world[USER_SAMPLING]


def disable_sun_extraction(world):
    """EEVEE-Next's world sun extraction off (World.sun_threshold = 0), the user's threshold
    kept for Remove. Returns what changed for the report, None without the property (< 4.2)."""
    if not hasattr(world, "sun_threshold"):
        return None
    if USER_SUN_THRESHOLD not in world:
        world[USER_SUN_THRESHOLD] = float(world.sun_threshold)
    before = world.sun_threshold
    world.sun_threshold = SUN_THRESHOLD_OFF
    return "EEVEE: world sun extraction off (sun_threshold %g -> %g)" % (before,
                                                                        world.sun_threshold)


def restore_sun_extraction(world):
    saved = world.get(USER_SUN_THRESHOLD)
    if saved is None:
        return
    if hasattr(world, "sun_threshold"):
        world.sun_threshold = float(saved)
    del world[USER_SUN_THRESHOLD]


# ---- lamps ------------------------------------------------------------------------------------

def sun_rotation(direction):
    """A sun shines along its object's -Z: point +Z at the light's direction."""
    return mathutils.Vector(direction).to_track_quat("Z", "Y").to_euler()


def create_suns(scene, lights, rot, strength, shadows):
    """Sun lamps in the EnvLight collection: energy * color = strength * rgb (DESIGN.md; energy
    = the largest channel, so colour <= 1), angle from the light's angle (soft), 0 (sharp), or
    no shadows (none)."""
    coll = next((c for c in bpy.data.collections if tagged(c) and c.name.startswith(COLLECTION)),
                None)
    if coll is None:
        coll = bpy.data.collections.new(COLLECTION)
        coll[TAG] = True
    if coll.name not in scene.collection.children:
        scene.collection.children.link(coll)
    made = []
    for i, light in enumerate(lights):
        rgb = [strength * c for c in light.rgb]
        energy = max(rgb)
        if energy <= 0:
            continue
        data = bpy.data.lights.new("EnvLight Sun %d" % (i + 1), "SUN")
        data[TAG] = True
        data.energy = energy
        data.color = [c / energy for c in rgb]
        data.angle = light.angle if shadows == "SOFT" else 0.0
        cast = shadows != "NONE"
        if hasattr(data, "use_shadow"):
            data.use_shadow = cast
        if hasattr(data, "cycles") and hasattr(data.cycles, "cast_shadow"):
            data.cycles.cast_shadow = cast
        obj = bpy.data.objects.new(data.name, data)
        obj[TAG] = True
        obj["envlight_index"] = i
        obj["envlight_rgb"] = rgb
        obj["envlight_solid_angle"] = light.solid_angle
        obj.rotation_mode = "XYZ"
        obj.rotation_euler = sun_rotation(rot @ mathutils.Vector(light.direction))
        obj.location = rot @ mathutils.Vector(light.direction) * 10.0
        coll.objects.link(obj)
        made.append(obj)
    return made


# ---- world nodes ------------------------------------------------------------------------------

def _new(tree, kind, label, x, y):
    n = tree.nodes.new(kind)
    n[TAG] = True
    n.name = NODE_PREFIX + label
    n.label = NODE_PREFIX + label
    n.location = (x, y)
    return n


def _direction_socket(tree, mapping_src, x, y):
    """The ray direction (Texture Coordinate > Generated is the ray direction in a world
    shader), through a copy of the source's Mapping node when it has one."""
    tc = _new(tree, "ShaderNodeTexCoord", "Direction", x, y)
    out = tc.outputs["Generated"]
    if mapping_src is not None:
        m = _new(tree, "ShaderNodeMapping", "Mapping", x + 180, y)
        m.vector_type = mapping_src.vector_type
        for s in m.inputs:
            if s.name in mapping_src.inputs and hasattr(s, "default_value") and s.name != "Vector":
                s.default_value = mapping_src.inputs[s.name].default_value
        tree.links.new(out, m.inputs["Vector"])
        out = m.outputs["Vector"]
    return out


def sh_radiance_socket(tree, coeffs, x, y):
    """A node chain evaluating the order-2 SH radiance sum_c coeffs[c] Y_c(d) as an RGB
    vector, d = the ray direction in the canonical frame: a polynomial in x, y, z (vector math
    SCALE of each coefficient colour by its basis term, then ADD)."""
    tc = _new(tree, "ShaderNodeTexCoord", "SH Direction", x, y)
    norm = _new(tree, "ShaderNodeVectorMath", "SH Normalize", x + 160, y)
    norm.operation = "NORMALIZE"
    tree.links.new(tc.outputs["Generated"], norm.inputs[0])
    sep = _new(tree, "ShaderNodeSeparateXYZ", "SH xyz", x + 320, y)
    tree.links.new(norm.outputs["Vector"], sep.inputs[0])
    X, Y, Z = sep.outputs["X"], sep.outputs["Y"], sep.outputs["Z"]

    def math_node(op, a, b, label, dy):
        n = _new(tree, "ShaderNodeMath", label, x + 500, y - dy)
        n.operation = op
        for i, v in enumerate((a, b)):
            if isinstance(v, (int, float)):
                n.inputs[i].default_value = v
            else:
                tree.links.new(v, n.inputs[i])
        return n.outputs[0]

    xy = math_node("MULTIPLY", X, Y, "SH xy", 0)
    yz = math_node("MULTIPLY", Y, Z, "SH yz", 60)
    xz = math_node("MULTIPLY", X, Z, "SH xz", 120)
    zz = math_node("MULTIPLY", Z, Z, "SH zz", 180)
    z2 = math_node("MULTIPLY_ADD", zz, 3.0, "SH 3zz-1", 240)
    z2.node.inputs[2].default_value = -1.0
    xx = math_node("MULTIPLY", X, X, "SH xx", 300)
    yy = math_node("MULTIPLY", Y, Y, "SH yy", 360)
    x2y2 = math_node("SUBTRACT", xx, yy, "SH xx-yy", 420)
    # (basis term, constant) per coefficient index l (l + 1) + m
    terms = [(None, _Y00), (Y, _Y1), (Z, _Y1), (X, _Y1), (xy, _Y2), (yz, _Y2), (z2, _Y20),
             (xz, _Y2), (x2y2, _Y22)]
    acc = None
    n = min(len(coeffs), 9)
    for i in range(n):
        term, k = terms[i]
        col = [k * float(c) for c in coeffs[i]]
        if term is None:
            v = _new(tree, "ShaderNodeCombineXYZ", "SH c0", x + 700, y + 80)
            for j in range(3):
                v.inputs[j].default_value = col[j]
            cur = v.outputs[0]
        else:
            sc = _new(tree, "ShaderNodeVectorMath", "SH c%d" % i, x + 700, y - 70 * i)
            sc.operation = "SCALE"
            sc.inputs[0].default_value = col
            tree.links.new(term, sc.inputs["Scale"])
            cur = sc.outputs["Vector"]
        if acc is None:
            acc = cur
        else:
            add = _new(tree, "ShaderNodeVectorMath", "SH sum %d" % i, x + 900, y - 70 * i)
            add.operation = "ADD"
            tree.links.new(acc, add.inputs[0])
            tree.links.new(cur, add.inputs[1])
            acc = add.outputs["Vector"]
    # the order-2 polynomial can go below 0 (ringing of a truncated SH, e.g. -0.36 on
    # empty_warehouse_01 after a 4-light fit): Blender gets max(radiance, 0) per channel, never
    # negative light (create_lights reports how much the clamp adds: sh_negative_figures)
    clamp = _new(tree, "ShaderNodeVectorMath", SH_CLAMP, x + 1100, y)
    clamp.operation = "MAXIMUM"
    clamp.inputs[1].default_value = (0.0, 0.0, 0.0)
    tree.links.new(acc, clamp.inputs[0])
    return clamp.outputs["Vector"]


def sh_negative_figures(coeffs, n=1024):
    """The order-2 SH radiance sum_c coeffs[c] Y_c(d) over the library's n Fibonacci
    directions: its minimum Rec. 709 luminance, the share of directions where the luminance is
    below 0, and what clamping each channel at 0 (as the SH world does) adds to the world's
    power, sum_d max(-f(d), 0) 4 pi / n per channel (RGB), with its luminance."""
    import numpy as np
    pkg = shim()
    dirs = pkg.fibonacci_directions(n)
    basis = np.array([pkg.sh_basis(2, d) for d in dirs])
    c = np.zeros((9, 3))
    k = min(len(coeffs), 9)
    c[:k] = np.asarray(coeffs, dtype=np.float64)[:k]
    rad = basis @ c                                                  # (n, 3)
    lum = rad @ np.array(LUMINANCE)
    clamp = np.maximum(-rad, 0.0).sum(axis=0) * (4.0 * math.pi / n)
    return {"sh_min": float(lum.min()), "sh_negative_share": float(np.mean(lum < 0.0)),
            "sh_clamp_power": [float(v) for v in clamp],
            "sh_clamp_luminance": float(clamp @ np.array(LUMINANCE)),
            "sh_power_luminance": float(np.array(c[0]) @ np.array(LUMINANCE) *
                                        math.sqrt(4.0 * math.pi))}


def build_world(world, mode, original_socket, residual_image, sh_coeffs, mapping_src, strength,
                keep_background):
    """Our own World Output, made active (the user's nodes are left as they were):
       residual: camera and glossy rays see `original_socket`, other rays the residual image;
       sh: other rays see the SH radiance (camera rays the original if keep_background);
       lights: other rays see black (camera and glossy rays the original)."""
    tree = world.node_tree
    user_out = _active_output(tree)
    if user_out is not None and not tagged(user_out):
        world[USER_OUTPUT] = user_out.name
    x0, y0 = 300, -600
    out = _new(tree, "ShaderNodeOutputWorld", "World Output", x0 + 1500, y0)
    lighting = _new(tree, "ShaderNodeBackground", "Lighting", x0 + 1100, y0 - 200)
    lighting.inputs["Strength"].default_value = strength
    if mode == "RESIDUAL":
        env = _new(tree, "ShaderNodeTexEnvironment", "Residual", x0 + 800, y0 - 200)
        env.image = residual_image
        env.interpolation = "Linear"
        tree.links.new(_direction_socket(tree, mapping_src, x0 + 300, y0 - 200),
                       env.inputs["Vector"])
        tree.links.new(env.outputs["Color"], lighting.inputs["Color"])
    elif mode == "SH":
        lighting.inputs["Strength"].default_value = 1.0  # the coefficients include it
        set_world_sampling(world, SH_MAP_RESOLUTION)
        tree.links.new(sh_radiance_socket(tree, sh_coeffs, x0, y0 - 400), lighting.inputs["Color"])
    else:
        lighting.inputs["Color"].default_value = (0, 0, 0, 1)
    shader = lighting.outputs[0]
    if original_socket is not None and (keep_background or mode != "SH"):
        lp = _new(tree, "ShaderNodeLightPath", "Light Path", x0 + 800, y0 + 300)
        fac = lp.outputs["Is Camera Ray"]
        if mode != "SH":
            mx = _new(tree, "ShaderNodeMath", "Camera or Glossy", x0 + 1000, y0 + 300)
            mx.operation = "MAXIMUM"
            tree.links.new(lp.outputs["Is Camera Ray"], mx.inputs[0])
            tree.links.new(lp.outputs["Is Glossy Ray"], mx.inputs[1])
            fac = mx.outputs[0]
        mix = _new(tree, "ShaderNodeMixShader", "Mix", x0 + 1300, y0)
        tree.links.new(fac, mix.inputs["Fac"])
        tree.links.new(shader, mix.inputs[1])
        tree.links.new(original_socket, mix.inputs[2])
        shader = mix.outputs[0]
    tree.links.new(shader, out.inputs["Surface"])
    out.is_active_output = True
    return out, disable_sun_extraction(world)


def residual_to_image(pkg, residual):
    """The residual (numpy, row 0 at the top) as a packed float Blender image: written as EXR
    by the library, loaded and packed (so the .blend carries it), the temporary file removed."""
    fd, path = tempfile.mkstemp(suffix=".exr", prefix="envlight_residual_")
    os.close(fd)
    try:
        pkg.save_image(path, residual)
        img = bpy.data.images.load(path)
        img.pack()
        img.name = "EnvLight Residual"
        img[TAG] = True
        img.filepath = "//EnvLight Residual.exr"
    finally:
        try:
            os.remove(path)
        except OSError:
            pass
    return img


# ---- the whole button --------------------------------------------------------------------------

def create_lights(context, settings, progress=None):
    """Runs Create Lights for context.scene.world with `settings` (the world's envlight
    properties). Returns a dict for the panel; raises RuntimeError / envlight.Error.

    All the library work happens first; the scene is changed only once it has succeeded, so a
    failure leaves the previous lamps and nodes as they were."""
    import numpy as np
    pkg = shim()
    scene = context.scene
    world = scene.world
    if world is None:
        raise RuntimeError("the scene has no world")
    t0 = time.perf_counter()
    step = progress or (lambda v: None)
    warnings = []
    mode = settings.world_mode
    method = settings.method
    rot = mathutils.Matrix.Identity(3)
    mapping_node = None
    strength = 1.0
    # ---- 1. read the source (nothing in the scene changes) ----
    if settings.source == "WORLD":
        src = find_environment_texture(world)
        if src is None or src.node.image is None:
            raise RuntimeError("no Environment Texture with an image in the world '%s'"
                               % world.name)
        inspect_source(src)
        warnings += src.warnings
        buf, w, h, ch = image_pixels(src.node.image)
        env = pkg.from_pixels(buf, w, h, ch, flip=True, layout="latlong")
        rot = mapping_matrix(src.mapping)
        mapping_node = src.mapping
        strength = src.strength
        path = None
    else:
        if not settings.filepath:
            raise RuntimeError("no file chosen")
        path = bpy.path.abspath(settings.filepath)
        env = pkg.load(path)
    step(0.2)
    # ---- 2. compute only what the mode needs: the fit remainder for the residual and SH
    # worlds (lights-only: the lights take everything), the residual image only for the
    # residual world, SH of the residual only for an SH world after a cut ----
    order = settings.order if method == "fit" and mode in ("RESIDUAL", "SH") else None
    residual = None
    sh_coeffs = None
    sh_figures = {}
    with env:
        power = env.info()["power"]
        with env.lights(settings.count, method=method, order=order) as res:
            step(0.6)
            lights = list(res.lights)
            summary = dict(res.summary)
            if mode == "RESIDUAL":
                residual = res.residual
            elif mode == "SH":
                if res.remainder is not None:
                    sh_coeffs = np.asarray(res.remainder_radiance) * strength
                else:
                    with pkg.from_pixels(res.residual) as rmap, rmap.sh(2) as sh:
                        sh_coeffs = np.asarray(sh.radiance) * strength
                if mapping_node is not None:
                    sh_coeffs = rotate_sh2(sh_coeffs, rot)
                sh_figures = sh_negative_figures(sh_coeffs)
                if sh_figures["sh_min"] < 0.0:
                    share = sh_figures["sh_power_luminance"]
                    warnings.append(
                        "the SH world's radiance goes negative: minimum luminance %.4g, below 0 "
                        "on %.1f %% of directions; the world clamps it to 0, which adds %.4g "
                        "(luminance, RGB %s) to the world's power%s"
                        % (sh_figures["sh_min"], 100.0 * sh_figures["sh_negative_share"],
                           sh_figures["sh_clamp_luminance"],
                           "(%s)" % ", ".join("%.4g" % v for v in sh_figures["sh_clamp_power"]),
                           " (%.2f %% of the SH world's %.4g)"
                           % (100.0 * sh_figures["sh_clamp_luminance"] / share, share)
                           if share > 0 else ""))
    step(0.75)
    # ---- 3. replace what a previous run made, then build ----
    remove_created(world)
    original_socket = None
    if world.use_nodes and world.node_tree:
        out = _active_output(world.node_tree)
        if out is not None and out.inputs["Surface"].is_linked:
            original_socket = out.inputs["Surface"].links[0].from_socket
    if path is not None:
        # the camera (and glossy rays) see the chosen file
        world.use_nodes = True
        tree = world.node_tree
        img = bpy.data.images.load(path, check_existing=True)
        tex = _new(tree, "ShaderNodeTexEnvironment", "Source", 300, -200)
        tex.image = img
        bgn = _new(tree, "ShaderNodeBackground", "Source Background", 600, -200)
        tree.links.new(tex.outputs["Color"], bgn.inputs["Color"])
        original_socket = bgn.outputs[0]
    suns = create_suns(scene, lights, rot, strength, settings.shadows)
    residual_image = residual_to_image(pkg, residual) if residual is not None else None
    notes = []
    if world.use_nodes and world.node_tree:
        _, sun_note = build_world(world, mode, original_socket, residual_image, sh_coeffs,
                                  mapping_node, strength, settings.keep_background)
        if sun_note:
            notes.append(sun_note)
    elif mode != "LIGHTS":
        warnings.append("the world does not use nodes: world left as it was")
    step(1.0)
    result = {
        "count": len(suns), "diffuse_error": summary["diffuse_error"],
        "seconds": time.perf_counter() - t0, "library_seconds": summary["seconds"],
        "power": [strength * p for p in power],
        "residual_power": [strength * p for p in summary["residual_power"]],
        "warnings": warnings,
        # what the add-on changed in the world's render settings (reported as INFO)
        "notes": notes,
    }
    if sh_coeffs is not None:
        # the SH world's coefficients (canonical frame, strength included) and, over the
        # library's 1024 Fibonacci directions, its minimum luminance, the share below 0 and
        # the power the clamp at 0 adds (sh_negative_figures)
        result["sh_coeffs"] = np.asarray(sh_coeffs, dtype=np.float64).tolist()
        result.update(sh_figures)
    global last_result
    last_result = result
    return result


def rotate_sh2(coeffs, rot):
    """Order-2 SH coefficients of a function f(d) -> those of g(v) = f(R^-1 v), by projecting
    on 9 x N sample directions (exact for l <= 2: the bands are closed under rotation)."""
    import numpy as np
    pkg = shim()
    dirs = pkg.fibonacci_directions(64)
    R = np.array(rot)
    basis = np.array([pkg.sh_basis(2, d) for d in dirs])            # Y(v)
    src = np.array([pkg.sh_basis(2, R.T @ d) for d in dirs])        # Y(R^-1 v)
    values = src @ np.asarray(coeffs)                                # g(v)
    fitted, *_ = np.linalg.lstsq(basis, values, rcond=None)
    return fitted
