"""What the Create Lights button does, apart from the UI: find the world's Environment Texture,
compute with libenvlight, build sun lamps and the world nodes.

Everything the add-on creates carries the custom property TAG (objects, lamps, the collection,
world nodes, images), so a re-run or Remove deletes exactly that and never the user's own
lamps or nodes.
"""
import math
import os
import time

import bpy
import mathutils

from . import eevee_dome, exact_discs, ground_edge, other_lights
from . import scene as scene_reader

TAG = "envlight"
COLLECTION = "EnvLight"
NODE_PREFIX = "EnvLight "
#: world custom property: the name of the user's World Output that was active before ours
USER_OUTPUT = "envlight_user_output"
# the user's Cycles world sampling settings while the SH world is in place
USER_SAMPLING = "envlight_user_sampling"
# the SH world is not light-sampled by Cycles (world sampling None): measured on kiara_1_dawn,
# a matte sphere on a ground (scripts/scene_bench.py --host blender), noise 3.7 % -> 2.4 % at 64
# samples and 0.75 -> 0.50 s per render against an importance map of 64 (Cycles' default
# 1024-wide map, evaluated through the SH node tree at every render, cost 3.0 s of a 3.1 s
# render)
SH_SAMPLING = "NONE"
# the user's EEVEE-Next (Blender 4.2+) World.sun_threshold while our world is in place: EEVEE
# turns the world's radiance above it into a sun light, which would count again the light
# envlight's sun lamps already carry; 0 is the documented "off" ("If non-zero, ...")
USER_SUN_THRESHOLD = "envlight_user_sun_threshold"
SUN_THRESHOLD_OFF = 0.0
#: the most suns split off as lamps of their own (envlight's lights method "sun")
MAX_SUNS = 4
#: Cycles' exact recipe changes the scene only when the suns hold at least this share of the
#: map's light (luminance): then the sun lamp takes away what makes the plain world noisy
#: (the built-in sky, 56 %: 2.1x sooner on a matte scene, 37x with a glossy sphere); below it
#: the plain world is as fast (immenstadter_horn, 22 %: 0.6x; scripts/scene_bench.py --host
#: blender, docs/blender_scenes.md)
SUN_SHARE_MIN = 0.5
#: Create Lamps Anyway on a map without a sun: lamps taken exactly around the directions of
#: the fit's this many lights (exact_discs)
EXACT_LAMPS = 4


def luminance(rgb):
    """Rec. 709 luminance of an rgb triple (LUMINANCE)."""
    return sum(w * v for w, v in zip(LUMINANCE, rgb))


def sun_share(summary):
    """The share of the map's light (luminance) its suns took."""
    total = luminance(summary["power"])
    return luminance(summary["lights_power"]) / total if total > 0 else 0.0

# order-2 real SH basis constants (docs/design.md, Ramamoorthi & Hanrahan 2001)
_Y00, _Y1, _Y2, _Y20, _Y22 = 0.282095, 0.488603, 1.092548, 0.315392, 0.546274
# Rec. 709 luminance weights (docs/design.md, the library's envl_luminance)
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


#: the Environment Texture's projection -> the library's layout of its image
PROJECTION_LAYOUTS = {"EQUIRECTANGULAR": "latlong", "MIRROR_BALL": "mirrorball"}
#: colour spaces whose 8-bit pixels are used as they are (linear or data); "sRGB" is decoded
_LINEAR_SPACES = ("Linear", "Linear Rec.709", "Non-Color", "Raw")


def source_layout(node):
    """The library's layout for the Environment Texture's projection (RuntimeError if none)."""
    proj = getattr(node, "projection", "EQUIRECTANGULAR")
    if proj not in PROJECTION_LAYOUTS:
        raise RuntimeError("projection '%s' is not supported (Equirectangular and Mirror Ball "
                           "are)" % proj)
    return PROJECTION_LAYOUTS[proj]


def projection_warning(layout, w, h, name):
    """The warning for an image whose shape does not fit the Environment Texture's projection
    (issue 28: a mirror ball left on Equirectangular), or None. Blender renders the world as
    the projection says, so the lamps follow that; the warning says it is likely not meant."""
    if layout == "latlong" and w != 2 * h:
        return ("image '%s' is %d x %d, not 2:1, on an Equirectangular projection: %s; the "
                "lamps follow the world as Blender shows it" % (
                    name, w, h, "a square image is usually a mirror ball (set the Environment "
                    "Texture's projection to Mirror Ball) or an angular probe (Blender has no "
                    "such projection: convert it with `envlight convert`)" if w == h else
                    "a lat-long map is twice as wide as high"))
    return None   # (a stretched mirror ball: envmap_of_image says how it reads it)


def _image_file(image):
    try:
        return bpy.path.abspath(image.filepath, library=image.library)
    except (AttributeError, TypeError, ValueError):
        return image.filepath


def image_layout(image):
    """(width, height, channels) of an image whose pixels can be read; RuntimeError naming the
    image and what is wrong when there are none (missing or unreadable file, render result,
    UDIM). Blender decodes the file here (Image.size) if it had not yet."""
    if image.source == "VIEWER":
        raise RuntimeError("image '%s' is a render result or viewer: not an environment"
                           % image.name)
    if image.source == "TILED":
        raise RuntimeError("image '%s' is a UDIM tiled image: not an environment" % image.name)
    w, h = image.size
    if w == 0 or h == 0:
        path = _image_file(image)
        if image.packed_file is None and image.source in ("FILE", "SEQUENCE", "MOVIE"):
            if not path or not os.path.isfile(path):
                raise RuntimeError("image '%s': its file '%s' is missing"
                                   % (image.name, image.filepath))
            raise RuntimeError("image '%s': Blender cannot read its file '%s' (not an image, "
                               "or damaged)" % (image.name, image.filepath))
        raise RuntimeError("image '%s' has no pixels (%s%s)" % (
            image.name, image.source.lower(), ", packed data unreadable"
            if image.packed_file is not None else ""))
    ch = image.channels
    n = len(image.pixels)
    if ch not in (1, 3, 4) or n != w * h * ch:
        raise RuntimeError("image '%s': %d values for %d x %d pixels of %d channels: cannot be "
                           "read" % (image.name, n, w, h, ch))
    return w, h, ch


#: values an 8-bit image's sRGB decode works on at a time: its temporaries stay this small
#: whatever the image's size (the image is copied once, into the library's memory)
DECODE_BLOCK = 1 << 14


def pixel_writer(image, ch, warnings=None):
    """fill(buf): Blender's pixels of `image` (RGBA..., row 0 at the bottom, `ch` channels)
    written straight into buf (flat float32: the library's memory, envlight's
    from_pixels_in_place) by Image.pixels.foreach_get, linear. An 8-bit image's pixels are its
    stored values (Image.pixels does not colour-manage them): sRGB ones are decoded to linear in
    buf, DECODE_BLOCK values at a time, as Cycles does; notes in `warnings`."""
    decode = False
    if not image.is_float:
        space = image.colorspace_settings.name
        notes = warnings if warnings is not None else []
        notes.append("image '%s' is 8-bit (low dynamic range): light brighter than white is "
                     "clipped, so the lamps are weaker than the real light" % image.name)
        decode = space == "sRGB"
        if not decode and space not in _LINEAR_SPACES:
            notes.append("image '%s': colour space '%s' is not decoded: its 8-bit values are "
                         "read as linear" % (image.name, space))

    def fill(buf):
        import numpy as np
        image.pixels.foreach_get(buf)
        if not decode:
            return
        step = DECODE_BLOCK * ch
        for start in range(0, len(buf), step):
            block = buf[start:start + step]
            rgb = block.reshape(-1, ch)[:, :3] if ch == 4 else block
            rgb[...] = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    return fill


def envmap_of_image(pkg, fill, w, h, ch, layout, warnings=None, name="image"):
    """The library's envmap of an image's pixels (fill: pixel_writer's, bottom-up) in the frame
    the Environment Texture looks them up in, and the library's info() of the pixels as read
    (the counts of NaN/Inf and negative pixels it set to 0 or the largest value). The pixels
    are written straight into the library's memory, which becomes the map (from_pixels_in_place:
    no other copy of the image), but for a non-square mirror ball, resampled first.

    Lat-long: Blender's equirectangular frame is the library's canonical one. Mirror ball:
    Blender (Cycles' direction_to_mirrorball) photographs the ball looking along +Y with the
    image's right = +X and up = +Z (the centre sees -Y), the library along +X with right = -Y
    (layout.c): Blender's direction = Rz(+90 degrees) the library's. The library's lat-long of
    the ball is turned by that quarter turn as it is made (rotate=90: a shift by a quarter of
    its width, a multiple of 4, exactly). Blender stretches the ball over the whole image: a
    non-square one is resampled (nearest) to a square first."""
    import numpy as np
    if layout == "latlong":
        env = pkg.from_pixels_in_place(fill, w, h, ch, flip=True, layout="latlong")
        return env, env.info()
    width = 4 * ((max(w, h) + 1) // 2)  # 2 x the ball's diameter, a multiple of 4
    if w == h:
        ball = pkg.from_pixels_in_place(fill, w, h, ch, flip=True, layout="mirrorball",
                                        map_width=width, rotate=90.0)
        return ball, ball.info()
    buf = np.empty(w * h * ch, dtype=np.float32)
    fill(buf)
    n = max(w, h)
    rows = ((np.arange(n) + 0.5) * h / n).astype(np.int64)
    cols = ((np.arange(n) + 0.5) * w / n).astype(np.int64)
    buf = np.ascontiguousarray(buf.reshape(h, w, ch)[rows][:, cols]).ravel()
    if warnings is not None:
        warnings.append("mirror ball %s is %d x %d, not square: Blender stretches the ball "
                        "over the image; read resampled to %d x %d" % (name, w, h, n, n))
    ball = pkg.from_pixels(buf, n, n, ch, flip=True, layout="mirrorball", map_width=width,
                           rotate=90.0)
    return ball, ball.info()


def repair_warnings(what, stats):
    """What the library did to the image's values (envl_info; docs/methods.md, "Negative
    pixels"): NaN set to 0, +Inf to the largest finite value, negative values filled from the
    light around them (the image's signed sum of light kept) or, with too little light around,
    set to 0 (the light that adds)."""
    out = []
    if stats["nonfinite_pixels"]:
        out.append("%s: %d pixels with NaN or infinite values: NaN set to 0, +Inf to the largest "
                   "finite value" % (what, stats["nonfinite_pixels"]))
    if stats["negative_pixels"]:
        signed = luminance(stats["signed_power"])
        moved = luminance(stats["filled_energy"])
        added = luminance(stats["added_energy"])
        parts = []
        if stats["fill_window"]:
            parts.append("filled from the light around them, moving %.2g %% of its light "
                         "(the image's sum of light kept)" % (100.0 * moved / signed if signed > 0
                                                              else 0.0))
        if stats["unfilled_values"]:
            parts.append("%d with too little light around them set to 0, adding %.2g %%" % (
                stats["unfilled_values"], 100.0 * added / signed if signed > 0 else 0.0))
        out.append("%s: %d negative pixels (down to %g, a lossy codec's or a resize's ringing): "
                   "%s" % (what, stats["negative_pixels"], stats["negative_min"],
                           "; ".join(parts)))
    return out


#: the progress bar while the image is read: (before, after) Blender's pixels are copied into
#: the library's memory, then the span its conversion to the map reports over (the copy and
#: the conversion take about the same time; the whole reading up to 0.2, where the fits start)
READ_PROGRESS = ((0.02, 0.1), (0.1, 0.2))
#: where the bar is once the suns are found (from 0.2; the fits then move it to 0.6)
SUN_PROGRESS = 0.35
# The world image that lights (the residual, the ground's bounce) is made no wider than the
# rays that see it resolve, and at most this where only diffuse rays see it: Cycles' fitted
# lamps (camera and glossy rays see the map, or the map less the suns, at full size). EEVEE
# reads it through its world probe (4.2+: world.probe_resolution, 1024 by default; 3.x: a cube
# of scene.eevee.gi_cubemap_resolution faces): at least 4 x that. Cycles' sun-residual pick
# (camera_only), whose glossy and transmission rays see it: as wide as the sharpest surface
# resolves, a GGX lobe of alpha = roughness^2 spreading a reflection over about alpha radians
# and a pixel 2 pi / W wide, W >= 4 pi / alpha keeps the pixels under half the lobe (roughness
# 0.2: 314; 0.05: 5027; a mirror: the map's own width). Area-resampled, the integral of L dw
# kept pixel by pixel: the irradiance moves by about (pi / W)^2, 6e-7 at 4096. A 16K map's
# residual is then 96 MiB, not 1.5 GiB (docs/blender_16k.md).
LIGHTING_WIDTH = 4096
NO_CAP = 2 ** 31 - 1


def lighting_width(scene, plan):
    """-> (the widest lighting image the scene can use, why) (LIGHTING_WIDTH above)."""
    if plan.engine in scene_reader.EEVEE_ENGINES:
        probe = getattr(scene.world, "probe_resolution", None)  # EEVEE-Next
        if probe is None:
            probe = getattr(getattr(scene, "eevee", None), "gi_cubemap_resolution", None)
        try:
            probe = int(probe)
        except (TypeError, ValueError):
            probe = 0
        return (max(LIGHTING_WIDTH, 4 * probe),
                "EEVEE reads it through its world probe of %d: 4 x that" % probe)
    if not plan.camera_only:
        return LIGHTING_WIDTH, "only diffuse rays see it"
    r = plan.min_roughness
    if r is None:
        return LIGHTING_WIDTH, "no surface with a roughness: no glossy ray resolves it"
    if r <= 0.0:
        return NO_CAP, "a mirror-sharp surface (roughness 0) sees it"
    return (max(LIGHTING_WIDTH, int(math.ceil(4.0 * math.pi / (r * r)))),
            "the sharpest surface, roughness %.2f, resolves 4 pi / roughness^2" % r)


def resampled(pkg, m, width):
    """The map `m` area-resampled to `width` wide, a new Envmap (m stays open)."""
    return pkg.from_pixels(m.to_layout("latlong", width), layout="latlong")


def read_source(pkg, world, step=None):
    """Create Lights' first step for Source: World Texture: the world's Environment Texture
    (with its Mapping and strength: inspect_source) and the library's envmap of its image, in
    the texture's lookup frame. Nothing in the scene changes. RuntimeError naming the world,
    the node or image and what is wrong: no nodes, no Environment Texture, no image, missing
    or unreadable file, no pixels, an unsupported projection, an image without light.
    step(fraction): the progress, 0.02 before the pixels are copied, 0.1 once they are, then
    to 0.2 as the library makes its map of them (READ_PROGRESS)."""
    step = step or (lambda v: None)
    if not world.use_nodes or not world.node_tree:
        raise RuntimeError("the world '%s' does not use nodes: there is no Environment Texture "
                           "to read (Use Nodes and an Environment Texture, or Source: File)"
                           % world.name)
    src = find_environment_texture(world)
    if src is None:
        raise RuntimeError("no Environment Texture in the world '%s' (add one with an HDR "
                           "image, or use Source: File)" % world.name)
    where = "world '%s', Environment Texture '%s'" % (world.name, src.node.name)
    image = src.node.image
    if image is None:
        raise RuntimeError("%s: no image in the texture" % where)
    inspect_source(src)
    try:
        layout = source_layout(src.node)
        w, h, ch = image_layout(image)
        fill = pixel_writer(image, ch, src.warnings)
    except RuntimeError as e:
        raise RuntimeError("%s: %s" % (where, e)) from None
    shape = projection_warning(layout, w, h, image.name)
    if shape:
        src.warnings.append(shape)
    what = "image '%s'" % image.name
    copy, convert = READ_PROGRESS

    def fill_reported(buf):
        step(copy[0])
        fill(buf)
        step(copy[1])
    try:
        with pkg.progress(lambda f, stage: step(convert[0] + (convert[1] - convert[0]) * f)):
            env, stats = envmap_of_image(pkg, fill_reported, w, h, ch, layout, src.warnings,
                                         what)
    except pkg.Error as e:
        raise RuntimeError("%s: the library cannot use %s: %s" % (where, what, e)) from None
    src.warnings.extend(repair_warnings(what, stats))
    if not max(env.info()["power"]) > 0.0:
        env.close()
        raise RuntimeError("%s: %s has no light (every pixel is black%s)" % (
            where, what, ", NaN or negative" if stats["nonfinite_pixels"] or
            stats["negative_pixels"] else ""))
    return env, src


# ---- removing what we made ---------------------------------------------------------------------

def remove_created(world):
    """Deletes what a previous run created (tagged objects, lamps, the volume probe, nodes,
    residual images) and re-activates the user's World Output."""
    removed = 0
    for obj in [o for o in bpy.data.objects if tagged(o)]:
        data = obj.data
        bpy.data.objects.remove(obj, do_unlink=True)
        removed += 1
        if data is not None and tagged(data) and data.users == 0:
            if isinstance(data, bpy.types.LightProbe):
                bpy.data.lightprobes.remove(data)
            else:
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
        restore_raytracing(world)
    for img in [i for i in bpy.data.images if tagged(i) and i.users == 0]:
        bpy.data.images.remove(img)
    # a probe whose object was deleted by hand: its data is ours and used by nothing
    for probe in [d for d in bpy.data.lightprobes if tagged(d) and d.users == 0]:
        bpy.data.lightprobes.remove(probe)
    return removed


def set_world_sampling(world, method):
    """Cycles' world light sampling `method` (NONE: no light sampling), the user's settings
    kept for Remove."""
    cw = getattr(world, "cycles", None)
    if cw is None or not hasattr(cw, "sample_map_resolution"):
        return
    if USER_SAMPLING not in world:
        world[USER_SAMPLING] = {"method": cw.sampling_method,
                                "resolution": cw.sample_map_resolution}
    cw.sampling_method = method


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


#: scene custom property: the user's EEVEE-Next ray tracing settings while ours are in place
USER_RAYTRACING = "envlight_user_raytracing"
#: EEVEE-Next's ray tracing as the dome recipe was measured with (scripts/
#: blender_eevee_parts.py's variant "screen-noclamp"): on, screen-traced for every roughness
#: (no horizon-scan fallback), at full resolution, the traced (indirect) light unclamped:
#: EEVEE's default clamp of 10 cut a traced world's bright pixels (empty_warehouse_01, 63 %
#: of its light above 10: a matte sphere on a ground -50 %). (target, attribute, value);
#: target "eevee" is Scene.eevee, "rt" its ray_tracing_options
RAYTRACING = (("eevee", "use_raytracing", True), ("eevee", "ray_tracing_method", "SCREEN"),
              ("rt", "trace_max_roughness", 1.0), ("rt", "resolution_scale", "1"),
              ("eevee", "clamp_surface_indirect", 0.0))


def _raytracing_targets(scene):
    e = getattr(scene, "eevee", None)
    return {"eevee": e, "rt": getattr(e, "ray_tracing_options", None)}


def enable_raytracing(scene):
    """EEVEE-Next's ray tracing as RAYTRACING, the user's settings kept on the scene for
    Remove. Returns what changed for the report, None where Blender has no such settings."""
    targets = _raytracing_targets(scene)
    if any(targets[t] is None or not hasattr(targets[t], a) for t, a, _ in RAYTRACING):
        return None
    if USER_RAYTRACING not in scene:
        scene[USER_RAYTRACING] = {"%s.%s" % (t, a): getattr(targets[t], a)
                                  for t, a, _ in RAYTRACING}
    changed = []
    for t, a, v in RAYTRACING:
        if getattr(targets[t], a) != v:
            changed.append("%s %s -> %s" % (a, getattr(targets[t], a), v))
            setattr(targets[t], a, v)
    return "EEVEE: ray tracing %s" % ("; ".join(changed) if changed else "already as needed")


def restore_raytracing(world):
    """The user's ray tracing settings back, on every scene of `world` that holds them."""
    import bpy
    for scene in bpy.data.scenes:
        saved = scene.get(USER_RAYTRACING)
        if saved is None or scene.world not in (world, None):
            continue
        targets = _raytracing_targets(scene)
        for key, value in dict(saved).items():
            t, a = key.split(".", 1)
            if targets.get(t) is not None and hasattr(targets[t], a):
                setattr(targets[t], a, value)
        del scene[USER_RAYTRACING]


# ---- lamps ------------------------------------------------------------------------------------

def sun_rotation(direction):
    """A sun shines along its object's -Z: point +Z at the light's direction."""
    return mathutils.Vector(direction).to_track_quat("Z", "Y").to_euler()


def _collection(scene):
    """The EnvLight collection (made and linked to the scene when missing)."""
    coll = next((c for c in bpy.data.collections if tagged(c) and c.name.startswith(COLLECTION)),
                None)
    if coll is None:
        coll = bpy.data.collections.new(COLLECTION)
        coll[TAG] = True
    if coll.name not in scene.collection.children:
        scene.collection.children.link(coll)
    return coll


def legacy_eevee_sun_gain(angle):
    """Legacy EEVEE (Blender 3.x) lights a surface facing a sun lamp of angular diameter
    `angle` with (3 + cos angle) / 4 of its strength (measured in Blender 3.4.1: a diffuse
    plane under one sun overhead and at 30 degrees' elevation, angles 30-150 degrees: 0.967,
    0.875, 0.750, 0.625, 0.533 of a point sun's light, the formula to 3 decimals), where
    EEVEE-Next and Cycles 4.x give the strength itself at any angle (the irradiance at normal
    incidence, as create_suns sets it). A legacy lamp gets 4 / (3 + cos angle) of it."""
    return 4.0 / (3.0 + math.cos(angle))


def cycles3_sun_gain(angle):
    """Cycles before 4.0 lights a surface facing a sun lamp of angular diameter `angle` with
    2 c / (1 + c) of its strength, c = cos(angle / 2): it samples a disc of radius
    r = tan(angle / 2) at unit distance uniformly, with radiance strength / (pi r^2 cos^3)
    along each sample (its pdf in solid angle, as eval_fac), so a normal n that sees the
    whole disc gets strength (n.D) / (pi r^2) x the integral over the disc of 1 / sqrt(1 + rho^2)
    = strength (n.D) 2 c / (1 + c) (the disc's odd part integrates to 0): a point sun's light
    times 2 c / (1 + c) for every such normal (measured in Blender 3.4.1 on a diffuse plane
    overhead, 30-150 degrees: 0.983, 0.928, 0.828, 0.667, 0.411; the formula to 3 decimals).
    Cycles 4.x gives the strength itself. A Cycles 3.x lamp gets (1 + c) / (2 c) of it: exact
    for the normals that see its whole disc; nearer the terminator its disc is brighter at the
    rim (1 / cos^3) than the uniform cone it stands for. Taken at 170 degrees for wider lamps
    (x6.2; at 180 the disc's radius is infinite and Cycles 3.x's lamp gives nothing)."""
    c = math.cos(0.5 * min(angle, math.radians(170.0)))
    return (1.0 + c) / (2.0 * c)


def sun_gain(scene, angle):
    """The factor on a sun lamp's strength that makes the render engine of `scene` (in this
    Blender) light a surface facing it with the strength create_suns means: legacy EEVEE
    (before 4.2) legacy_eevee_sun_gain, Cycles before 4.0 cycles3_sun_gain, else 1."""
    engine, version = scene.render.engine, tuple(bpy.app.version)
    if engine == "BLENDER_EEVEE" and version < (4, 2, 0):
        return legacy_eevee_sun_gain(angle)
    if engine == "CYCLES" and version < (4, 0, 0):
        return cycles3_sun_gain(angle)
    return 1.0


def create_suns(scene, lights, rot, strength, shadows, glossy=True, name="EnvLight Light",
                shadow_resolution=None, over_residual=False):
    """Sun lamps in the EnvLight collection: energy * color = strength * rgb * (1 - w / 4 pi)
    (energy = the largest channel, so colour <= 1), w = the light's solid angle: a Blender sun
    is given by its irradiance at normal incidence, which for a disc of solid angle w holding
    the power rgb is rgb (1 - w / 4 pi), the light's first moment (lights.c). Angle from the
    light's angle (soft), 0 (sharp), or no shadows (none). glossy False: the lamps light no
    glossy reflection (Object.visible_glossy, Cycles), where glossy rays see the map itself
    (EEVEE has no such split: its lamps keep their specular; without it the bench's glossy
    sphere lost their light, legacy EEVEE's fitted lamps 22 -> 36 % on the built-in sky).
    shadow_resolution: EEVEE-Next's finest shadow texel (Light.shadow_maximum_resolution, m):
    the dome's many soft lamps need no fine one, and at the default 1 mm 32 of them overflow
    EEVEE's shadow pool ("Shadow buffer full ... (3284 / 2048)": shadows missing).
    over_residual: the world is the residual the lights left, so each lamp stands for what
    its light took: along take_direction, of take_solid_angle and take_angle (the library's
    envl_light; for the fit its direction is where the fit aims with its SH remainder, which
    may differ)."""
    coll = _collection(scene)
    made = []
    for i, light in enumerate(lights):
        direction, solid_angle, angle = light.direction, light.solid_angle, light.angle
        if over_residual and hasattr(light, "take_direction"):
            direction = light.take_direction
            solid_angle, angle = light.take_solid_angle, light.take_angle
        rgb = [strength * c * (1.0 - solid_angle / (4.0 * math.pi)) for c in light.rgb]
        energy = max(rgb)
        if energy <= 0:
            continue
        data = bpy.data.lights.new("%s %d" % (name, i + 1), "SUN")
        data[TAG] = True
        data.energy = energy
        data.color = [c / energy for c in rgb]
        if shadow_resolution and hasattr(data, "shadow_maximum_resolution"):
            data.shadow_maximum_resolution = shadow_resolution
        data.angle = angle if shadows == "SOFT" else 0.0
        data.energy = energy * sun_gain(scene, data.angle)  # legacy EEVEE, Cycles 3.x
        cast = shadows != "NONE"
        if hasattr(data, "use_shadow"):
            data.use_shadow = cast
        if hasattr(data, "cycles") and hasattr(data.cycles, "cast_shadow"):
            data.cycles.cast_shadow = cast
        obj = bpy.data.objects.new(data.name, data)
        obj[TAG] = True
        if hasattr(obj, "visible_glossy"):
            obj.visible_glossy = glossy
        obj["envlight_index"] = i
        obj["envlight_rgb"] = rgb
        obj["envlight_solid_angle"] = solid_angle
        obj.rotation_mode = "XYZ"
        obj.rotation_euler = sun_rotation(rot @ mathutils.Vector(direction))
        obj.location = rot @ mathutils.Vector(direction) * 10.0
        coll.objects.link(obj)
        made.append(obj)
    return made


def bake_probe(scene, probe):
    """EEVEE-Next's volume probe over the box `probe` = (centre, half size, resolution),
    tagged, in the EnvLight collection, then baked (Object > Bake Light Cache for it alone):
    the light the objects bounce onto one another and the sky they hide, which EEVEE's
    lamps and world light alone leave out. -> (the report's note, None), or (None, a warning)
    when the bake fails (the probe is then removed)."""
    centre, half, res = probe
    coll = _collection(scene)
    data = bpy.data.lightprobes.new("EnvLight Volume Probe", "VOLUME")
    data[TAG] = True
    data.resolution_x, data.resolution_y, data.resolution_z = res
    data.normal_bias = scene_reader.PROBE_NORMAL_BIAS
    obj = bpy.data.objects.new(data.name, data)
    obj[TAG] = True
    obj.location = centre
    obj.scale = half          # a volume probe spans its object's unit cube (-1..1)
    coll.objects.link(obj)
    t = time.perf_counter()
    try:
        with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj],
                                       scene=scene):
            r = bpy.ops.object.lightprobe_cache_bake(subset="ACTIVE")
    except RuntimeError as e:   # the operator's poll or its own error report
        r = {str(e).strip() or "error"}
    if r != {"FINISHED"}:
        # the lamps and the world are made and valid: the probe alone is given up
        bpy.data.objects.remove(obj, do_unlink=True)
        bpy.data.lightprobes.remove(data)
        return None, "EEVEE could not bake the volume probe (%s): none made" % ", ".join(r)
    return "EEVEE: volume probe %d x %d x %d baked in %.1f s" % (
        res[0], res[1], res[2], time.perf_counter() - t), None


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


def sh_radiance_socket(tree, coeffs, x, y, sky_only=False):
    """A node chain evaluating the order-2 SH radiance sum_c coeffs[c] Y_c(d) as an RGB
    vector, d = the ray direction in the canonical frame: a polynomial in x, y, z (vector math
    SCALE of each coefficient colour by its basis term, then ADD). sky_only: 0 below the
    horizon (z < 0), where a ground hides the world: Cycles then spends no light sample there
    (measured on kiara_1_dawn over a plane: the ground's noise 6.7 % -> see docs/blender_scenes.md)."""
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
    if not sky_only:
        return clamp.outputs["Vector"]
    up = _new(tree, "ShaderNodeMath", "SH Sky Only", x + 1100, y - 150)
    up.operation = "GREATER_THAN"
    tree.links.new(Z, up.inputs[0])
    up.inputs[1].default_value = 0.0
    step = _new(tree, "ShaderNodeVectorMath", "SH Sky Step", x + 1250, y)
    step.operation = "SCALE"
    tree.links.new(clamp.outputs["Vector"], step.inputs[0])
    tree.links.new(up.outputs[0], step.inputs["Scale"])
    return step.outputs["Vector"]


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
                keep_background, glossy_hdr=False, sky_only=False, glossy_image=None,
                camera_only=False, eevee=True):
    """Our own World Output, made active (the user's nodes are left as they were):
       residual: camera and glossy rays see `original_socket`, other rays the residual image;
       sh: other rays see the SH radiance (camera rays the original if keep_background; with
           glossy_hdr, glossy rays the original too). Cycles does not light-sample the SH
           world (SH_SAMPLING): a smooth world is found as well by the surfaces' own (cosine)
           sampling, without shadow rays, and a shadow ray could not tell a glossy from a
           diffuse bounce (light sampling would weigh the SH world where a glossy bounce sees
           the original);
       glossy_image: what glossy rays see instead of the original (the map less the suns,
           whose lamps draw them), in the residual and lights worlds and with glossy_hdr;
       camera_only: only camera rays see the original, all others the lighting world (EEVEE,
           which shades its one world capture as a glossy ray);
       lights: other rays see black (camera and glossy rays the original).
    eevee: the render engine is EEVEE, whose world sun extraction (4.2+) is turned off (the
    lamps carry the suns); Cycles has none, and its report does not speak of it."""
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
        set_world_sampling(world, SH_SAMPLING)
        tree.links.new(sh_radiance_socket(tree, sh_coeffs, x0, y0 - 400, sky_only),
                       lighting.inputs["Color"])
    else:
        lighting.inputs["Color"].default_value = (0, 0, 0, 1)
    shader = lighting.outputs[0]
    if original_socket is not None and (keep_background or mode != "SH" or glossy_hdr):
        lp = _new(tree, "ShaderNodeLightPath", "Light Path", x0 + 800, y0 + 300)
        fac = lp.outputs["Is Camera Ray"]
        if (mode != "SH" or glossy_hdr) and not camera_only:
            mx = _new(tree, "ShaderNodeMath", "Camera or Glossy", x0 + 1000, y0 + 300)
            mx.operation = "MAXIMUM"
            tree.links.new(lp.outputs["Is Camera Ray"], mx.inputs[0])
            tree.links.new(lp.outputs["Is Glossy Ray"], mx.inputs[1])
            fac = mx.outputs[0]
        if glossy_image is not None and (mode != "SH" or glossy_hdr) and not camera_only:
            # camera rays the original, glossy rays the map less the suns
            env = _new(tree, "ShaderNodeTexEnvironment", "Glossy", x0 + 800, y0 + 600)
            env.image = glossy_image
            env.interpolation = "Linear"
            tree.links.new(_direction_socket(tree, mapping_src, x0 + 300, y0 + 600),
                           env.inputs["Vector"])
            gbg = _new(tree, "ShaderNodeBackground", "Glossy Background", x0 + 1000, y0 + 600)
            gbg.inputs["Strength"].default_value = strength
            tree.links.new(env.outputs["Color"], gbg.inputs["Color"])
            cam = _new(tree, "ShaderNodeMixShader", "Camera Mix", x0 + 1150, y0 + 450)
            tree.links.new(lp.outputs["Is Camera Ray"], cam.inputs["Fac"])
            tree.links.new(gbg.outputs[0], cam.inputs[1])
            tree.links.new(original_socket, cam.inputs[2])
            original_socket = cam.outputs[0]
        mix = _new(tree, "ShaderNodeMixShader", "Mix", x0 + 1300, y0)
        tree.links.new(fac, mix.inputs["Fac"])
        tree.links.new(shader, mix.inputs[1])
        tree.links.new(original_socket, mix.inputs[2])
        shader = mix.outputs[0]
    tree.links.new(shader, out.inputs["Surface"])
    out.is_active_output = True
    return out, disable_sun_extraction(world) if eevee else None


def pixels_to_image(residual, name, rows=256):
    """A lat-long map (numpy, row 0 at the top; or an Envmap, copied `rows` rows at a time and
    closed before Blender copies the buffer, so that the map and Blender's image are not held
    at once) as a float Blender image made in memory and packed as OpenEXR by Blender (the
    .blend carries it; no file, and no OpenEXR in the add-on's library)."""
    import numpy as np
    if isinstance(residual, np.ndarray):
        h, w = residual.shape[:2]
    else:
        h, w = residual.height, residual.width
    rgba = np.ones((h, w, 4), dtype=np.float32)
    if isinstance(residual, np.ndarray):
        rgba[..., :3] = residual[::-1]
    else:
        with residual:
            for r in range(0, h, rows):
                end = min(h, r + rows)
                rgba[h - end:h - r, :, :3] = residual.pixels(r, end)[::-1]
    img = bpy.data.images.new(name, w, h, alpha=False, float_buffer=True)
    img[TAG] = True
    img.pixels.foreach_set(rgba.ravel())
    del rgba  # before pack() encodes the image: not both at once
    img.file_format = "OPEN_EXR"
    img.pack()
    return img


def fit_rest(pkg, env, rest, plan, method, order, strength, step, start=0.2):
    """The plan's lamps (method, count) and world from `rest` (the map, or the map less its
    suns): -> (lights, summary, residual image or None, SH coefficients or None). Over a
    ground, Cycles traces the ground's bounce itself, so the lamps and the world take the sky
    half only (Envmap.sky_hemisphere; the SH fitted to the sky half, sky_sh2); EEVEE gathers
    little of it, so its world keeps the ground's bounce as the map's lower half
    (Envmap.ground_plane, as envlight pov --ground). Closes `rest` unless it is `env`. The
    library's progress moves the bar from `start` to 0.6."""
    import numpy as np
    mode = plan.world_mode
    residual = sh_coeffs = None
    used = rest
    if plan.ground_albedo is not None and plan.camera_only:
        used, _ = env.ground_plane(plan.ground_albedo)
        if rest is not env:
            # the lower half is the bounce of the whole map's light, the suns' too (their lamps
            # light the ground, whose bounce EEVEE does not trace): the map over the ground
            # less the suns (above the horizon) = rest above, the whole bounce below. With
            # rest's own bounce the sun's was lost: scene (a), sky, matte -19.6 %
            px = np.maximum(used.pixels() - (env.pixels() - rest.pixels()), 0.0)
            used.close()
            used = pkg.from_pixels(px, layout="latlong")
    elif plan.ground_albedo is not None:
        used = rest.sky_hemisphere()
    band = band_pixels(plan, rest, used)
    if plan.dome:
        return dome_rest(pkg, env, rest, used, plan, step, start, band)
    try:
        # the library's own progress moves the bar to 0.6 while it fits (issue 16)
        with pkg.progress(lambda f, stage: step(min(0.6, start + (0.6 - start) * f))), \
                used.lights(plan.count, method=method, order=order) as res:
            step(0.6)
            lights = list(res.lights)
            summary = dict(res.summary)
            if mode == "RESIDUAL" or (mode == "SH" and plan.ground_albedo is not None):
                residual = res.residual
            if mode == "SH" and plan.ground_albedo is not None and not plan.camera_only:
                # the ground hides the lower half: the SH that best fits the sky half
                sh_coeffs = sky_sh2(residual) * strength
            elif mode == "SH":
                if res.remainder is not None:
                    sh_coeffs = np.asarray(res.remainder_radiance) * strength
                else:
                    # the plain expansion: the world's clamp at 0 handles (and reports) negatives
                    with pkg.from_pixels(res.residual) as rmap, rmap.sh(2, window="none") as sh:
                        sh_coeffs = np.asarray(sh.radiance) * strength
    finally:
        for m in {id(used): used, id(rest): rest}.values():
            if m is not env:
                m.close()
    if band is not None and mode == "RESIDUAL" and residual is not None:
        residual = ground_edge.add(residual, *band)
    return lights, summary, residual, sh_coeffs


def band_pixels(plan, rest, used):
    """Over a ground whose edge is known (plan.ground_band: the world's turn, ground_edge.py):
    (the band at `rest`'s size, the map's pixels there less what `used`, the map as the ground
    leaves it, has there), else None. Only the band's rows are copied out of the library."""
    import numpy as np
    if plan.ground_band is None or used is rest:
        return None
    band = ground_edge.band(np, rest.height, rest.width, *plan.ground_edge,
                            rot=plan.ground_band)
    first, mask = band
    end = first + mask.shape[0]
    return band, rest.pixels(first, end)[mask] - used.pixels(first, end)[mask]


def exact_figures(pkg, env, lamps, residual):
    """The summary figures of lamps taken exactly and their residual: the diffuse error of
    the lamps (rgb max(0, n.l), as the library measures lights) + the residual's exact
    irradiance against the map's (design.md's measure), and the residual's power."""
    import numpy as np
    normals = pkg.fibonacci_directions()
    with pkg.from_pixels(residual, layout="latlong") as rmap:
        approx = np.array(rmap.irradiance(normals))
        residual_power = rmap.info()["power"]
    n = np.array(normals)
    for l in lamps:
        approx += np.maximum(n @ np.array(l.direction), 0.0)[:, None] * np.array(l.rgb)[None]
    return {"diffuse_error": pkg.relative_rms_luminance(approx, env.irradiance(normals)),
            "residual_power": residual_power}


def dome_rest(pkg, env, rest, used, plan, step, start=0.2, band=None):
    """EEVEE's dome (eevee_dome) over `used` (the map less the suns; over a ground its lower
    half the bounce): -> (the dome's lamps, the cut's summary, the world's image: the ground's
    bounce below the horizon over a ground, else nothing, None). Closes `used` and `rest`
    unless they are `env`. band: band_pixels'."""
    import numpy as np
    world = used.pixels()
    if band is not None:  # the world as it will be, the share below computed on it
        world = ground_edge.add(world, *band)
    ground = plan.ground_albedo is not None
    sky = eevee_dome.upper_half(np, world) if ground else world
    share = 0.0
    if ground and plan.engine == "BLENDER_EEVEE_NEXT":
        # a share of the sky stays in the world so that EEVEE-Next does not dering it
        share, after, before = eevee_dome.world_share(np, world - sky, sky)
    try:
        with pkg.from_pixels(sky * (1.0 - share), layout="latlong") as smap, \
                pkg.progress(lambda f, stage: step(min(0.6, start + (0.6 - start) * f))), \
                smap.lights(plan.dome, method="variance") as res:
            lights, summary = list(res.lights), dict(res.summary)
    finally:
        for m in {id(used): used, id(rest): rest}.values():
            if m is not env:
                m.close()
    step(0.6)
    lo, hi = eevee_dome.dome_angle_degrees(lights)
    plan.reasons.append(
        "EEVEE: the sky as a dome of %d soft-shadowed lamps (its variance cut, %.0f-%.0f "
        "degrees each: the objects occlude the sky's light as they hide the sky)%s" % (
            len(lights), lo, hi, "; the world is the ground's bounce below the horizon "
            "(EEVEE lights it unoccluded)" if ground else "; the world is black"))
    if share > 0:
        plan.reasons.append(
            "EEVEE-Next: %.0f %% of the sky kept in the world, unoccluded: the least that "
            "keeps EEVEE from deringing the world's order-1 light (its first moment %.2f -> "
            "%.2f, bound 1/3), which lit open ground from below" % (100 * share, before, after))
    return lights, summary, world - sky * (1.0 - share), None


class NothingToDo(Exception):
    """Create Lights has nothing to compute for this scene: `reason` (else the plan's skipped
    items) says why; `warnings` what it found on the way (the scene's other lights...)."""

    def __init__(self, plan, reason=None, warnings=()):
        super().__init__(reason or "; ".join(plan.skipped) or "nothing to compute")
        self.plan = plan
        self.warnings = list(warnings)


# ---- the whole button --------------------------------------------------------------------------

def create_lights(context, settings, progress=None, force=False):
    """Runs Create Lights for context.scene.world with `settings` (the world's envlight
    properties). Returns a dict for the panel; raises RuntimeError / envlight.Error, or
    NothingToDo (the plan: nothing to compute for this scene; a previous result is removed).
    force (Create Lamps Anyway, Cycles): lamps even where the plain world is as fast: the
    suns, or on a map without one lamps taken exactly (exact_discs), still unbiased.

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
    step(0.01)  # the bar moves as the button is pressed, before the scene and image are read
    warnings = []
    plan = (scene_reader.read_scene(scene, settings.volume_probe, settings.eevee_dome)
            if settings.read_scene else scene_reader.plan_from_settings(settings, scene))
    plan.force = force
    lights_note = other_lights.warning(scene)
    if lights_note:
        warnings.append(lights_note)
    mode = plan.world_mode
    method = plan.method
    rot = mathutils.Matrix.Identity(3)
    mapping_node = None
    strength = 1.0
    # ---- 1. read the source (nothing in the scene changes) ----
    if settings.source == "WORLD":
        # the image in the texture's lookup frame (lat-long or mirror ball), checked
        env, src = read_source(pkg, world, step)
        warnings += src.warnings
        rot = mapping_matrix(src.mapping)
        mapping_node = src.mapping
        strength = src.strength
        path = None
    else:
        if not settings.filepath:
            raise RuntimeError("no file chosen")
        path = bpy.path.abspath(settings.filepath)
        with pkg.progress(lambda f, stage: step(0.2 * f)):
            env = pkg.load(path)
    step(0.2)
    if not plan.compute:
        env.close()
        raise NothingToDo(plan, warnings=warnings)
    # ---- 2. compute only what the plan needs: the fit remainder for the residual and SH
    # worlds (lights-only: the lights take everything), the residual image for the residual
    # world and the sky-only SH fit over a ground, SH of the residual only for an SH world
    # after a cut. Over a ground, everything from the map as the scene sees it: its lower half
    # the ground's bounce (envlight.Envmap.ground_plane), so no light is put where the ground
    # hides it ----
    order = plan.order if plan.order is not None else settings.order
    order = order if method == "fit" and mode in ("RESIDUAL", "SH") else None
    residual = None
    sh_coeffs = None
    sh_figures = {}
    if plan.ground_albedo is not None and abs(rot[2][2] - 1.0) > 1e-6:
        warnings.append("the Mapping node tilts the world: no ground treatment")
        plan.ground_albedo = None
    plan.ground_band = None
    if plan.ground_albedo is not None and plan.ground_edge and mode == "RESIDUAL" and \
            plan.count > 0:
        # the directions that pass beyond the ground's edge see the map in the world image
        # (ground_edge.py; an SH world cannot hold a band a few degrees high)
        least, most = ground_edge.depression_range(*plan.ground_edge)
        if most > 0:
            # the band itself is made at the size of the map that lights (band_pixels)
            plan.ground_band = [list(r) for r in rot]
            plan.reasons.append(
                "the ground ends: below the horizon the world keeps the map down to where "
                "the objects see the ground begin (%.1f-%.1f degrees)"
                % (math.degrees(least), math.degrees(most)))
    sun_lights, glossy_pixels, sun_summary = [], None, None
    # glossy rays see the map less the suns (a full-size image) only in these worlds (below)
    glossy_hdr = (mode != "SH" or plan.glossy_hdr) and not plan.camera_only
    width, width_why = lighting_width(scene, plan)
    try:  # env is the map, then (over the lighting width) what lights at that width
        info = env.info()
        power = info["power"]
        # +Inf pixels (a half float's overflow, as a sun's core in a DWAB EXR) became the
        # largest finite value here. Cycles renders NaN and +Inf black when the image is packed
        # or made in Blender, and from a DWA EXR's file too; from other half-float files it
        # reads +Inf as 65504 (measured in 3.4 and 4.3, docs/blender_scenes.md): either way
        # not what the library read
        infinity = info["infinity_value"]
        rest = env
        if plan.suns:
            # the suns first, as lamps of their own size (sharp shadows, exact highlights):
            # the rest of the plan works on the map less exactly what they took, made in the
            # library at the lighting width (no full-size copy of it unless glossy rays see it)
            with pkg.progress(lambda f, stage: step(0.2 + (SUN_PROGRESS - 0.2) * f)), \
                    env.lights(MAX_SUNS, method="sun", residual=glossy_hdr) as sres:
                sun_lights = list(sres.lights)
                sun_summary = dict(sres.summary)
                if sun_lights:
                    if glossy_hdr:
                        glossy_pixels = sres.residual
                    rest = sres.residual_map(width if env.width > width else None)
        if plan.count == 0 and plan.recipe == "sun-residual":
            share = sun_share(sun_summary)
            if share < SUN_SHARE_MIN and infinity > 0 and not force:
                plan.reasons.append(
                    "the image has %d pixels with NaN or +Inf, which Cycles renders black "
                    "(packed, made in Blender, or a DWA EXR's file) or as 65504 (other "
                    "half-float files): the plain HDR world would lose or change their light "
                    "(+Inf, a half float's overflow such as a sun's core, is read as %g, the "
                    "image's largest finite value), so the suns as lamps and the world the map "
                    "less them, from the map as read"
                    % (info["nonfinite_pixels"], infinity))
            elif share < SUN_SHARE_MIN and not force:
                if rest is not env:
                    rest.close()
                why = ("the map's suns hold %.0f %% of its light (under %.0f %%): the plain HDR "
                       "world is exact and, in Cycles, as fast (scene benchmark)"
                       % (100 * share, 100 * SUN_SHARE_MIN))
                raise NothingToDo(plan, why, warnings)
            if share < SUN_SHARE_MIN and sun_lights and force:
                plan.reasons.append(
                    "Create Lamps Anyway: the suns hold %.0f %% of the light (under %.0f %%, "
                    "where the scene benchmark found the plain world as fast or faster: "
                    "0.6x on a map whose sun holds 22 %%)" % (100 * share, 100 * SUN_SHARE_MIN))
        if plan.count == 0 and force and not sun_lights:
            # no sun: lamps taken exactly from the brightest areas (the fit's 4 lights'
            # directions and sizes), the world the map less exactly them
            with env.lights(EXACT_LAMPS, method="fit", order=2, measure=False,
                            residual=False) as fres:
                directions = [l.direction for l in
                              sorted(fres.lights, key=lambda l: -sum(l.rgb))]
            px = env.pixels()
            rows = [env.solid_angle(r) for r in range(px.shape[0])]
            sun_lights, glossy_pixels = exact_discs.take(np, px, rows, directions)
            del px
            rest = pkg.from_pixels(glossy_pixels, layout="latlong")
            lum = lambda c: sum(w * v for w, v in zip(LUMINANCE, c))  # noqa: E731
            taken = sum(lum(l.rgb) for l in sun_lights) / max(lum(power), 1e-30)
            plan.reasons = [r for r in plan.reasons if "the suns as lamps" not in r]
            plan.reasons.append(
                "Create Lamps Anyway: the map has no sun: %d lamps taken exactly from its "
                "brightest areas (%.0f %% of its light; the world is the map less exactly "
                "them: unbiased)" % (len(sun_lights), 100 * taken))
            plan.recipe = "lamps-residual"
            plan.suns = False
            sun_summary = dict(sun_summary, **exact_figures(pkg, env, sun_lights,
                                                            glossy_pixels))
            if not glossy_hdr:
                glossy_pixels = None
        if env.width > width:
            # from here on what lights, at the lighting width: the full map is needed no further
            plan.reasons.append(
                "the world's lighting image at %d wide, area-resampled from the map's %d "
                "(%s; the camera sees the map)" % (width, env.width, width_why)
                if mode == "RESIDUAL" else
                "the lamps%s fitted to the map area-resampled from %d to %d wide (the same "
                "light: the integral of L dw kept pixel by pixel)"
                % (" and the SH world" if mode == "SH" else "", env.width, width))
            if rest is not env and rest.width > width:
                with rest:
                    rest = resampled(pkg, rest, width)
            keep = rest is env or (plan.ground_albedo is not None and plan.camera_only)
            lit = resampled(pkg, env, width) if keep else rest
            if rest is env:
                rest = lit
            env.close()
            env = lit
        if plan.count == 0:
            # the suns alone: every other ray sees the map less them, exactly
            lights, summary = [], sun_summary
            # the library's map itself: pixels_to_image copies it into Blender's buffer by rows
            residual = rest if rest is not env else env.pixels()
        else:
            if rest is not env and not (plan.ground_albedo is not None and plan.camera_only):
                env.close()  # the fit needs only the map less the suns: one copy fewer
            lights, summary, residual, sh_coeffs = fit_rest(
                pkg, env, rest, plan, method, order, strength, step,
                SUN_PROGRESS if plan.suns else 0.2)
    finally:
        env.close()
    if plan.suns and sun_lights:
        plan.reasons.append("%d sun%s as lamps of %s own size (%s degrees)" % (
            len(sun_lights), "s" if len(sun_lights) > 1 else "",
            "their" if len(sun_lights) > 1 else "its",
            ", ".join("%.2f" % math.degrees(l.angle) for l in sun_lights)))
    elif plan.suns:
        plan.skipped.append("sun lamps: the map has no sun (no bright disc under 5 degrees)")
    if sh_coeffs is not None:
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
    # glossy rays see the map (less the suns, which their lamps draw) in the residual and
    # lights-only worlds and in an SH world for glossy surfaces: the fitted lamps' light is in
    # it, so those lamps light no glossy reflection (Cycles: the lamp's glossy visibility off)
    suns = create_suns(scene, sun_lights, rot, strength, plan.shadows, glossy=True,
                       name="EnvLight Sun")
    n_suns = len(suns) if plan.suns else 0
    suns += create_suns(scene, lights, rot, strength, plan.shadows, glossy=not glossy_hdr,
                        shadow_resolution=eevee_dome.shadow_resolution(scene)
                        if plan.dome else None, over_residual=mode == "RESIDUAL")
    gains = [sun_gain(scene, o.data.angle) for o in suns]
    if max(gains, default=1.0) >= 1.005:
        # said where it changes a lamp by half a percent or more (a sun of 11.5 degrees in
        # legacy EEVEE, 16.1 in Cycles 3.x)
        if scene.render.engine == "CYCLES":
            plan.reasons.append(
                "Cycles %d.%d: each lamp's strength x (1 + cos(angle / 2)) / (2 cos(angle / 2)) "
                "(x%.2f-%.2f here): Cycles before 4.0 lights a surface facing a sun of that "
                "angle with 2 cos(angle / 2) / (1 + cos(angle / 2)) of its strength, where "
                "Cycles 4 gives all of it" % (bpy.app.version[0], bpy.app.version[1],
                                               min(gains), max(gains)))
        else:
            plan.reasons.append(
                "legacy EEVEE: each lamp's strength x 4 / (3 + cos angle) (x%.2f-%.2f here): "
                "legacy EEVEE lights a surface facing a sun of that angle with (3 + cos angle) "
                "/ 4 of its strength, where EEVEE-Next and Cycles 4 give all of it"
                % (min(gains), max(gains)))
    # each map freed once Blender holds its image: at 16K each is 1.5 GB (docs/blender_16k.md)
    glossy_image = None
    if glossy_pixels is not None and glossy_hdr:
        glossy_image = pixels_to_image(glossy_pixels, "EnvLight Glossy")
    glossy_pixels = None
    residual_image = pixels_to_image(residual, "EnvLight Residual") \
        if mode == "RESIDUAL" and residual is not None else None
    if residual is not None and not isinstance(residual, np.ndarray):
        residual.close()
    residual = None
    notes = []
    if world.use_nodes and world.node_tree:
        _, sun_note = build_world(world, mode, original_socket, residual_image, sh_coeffs,
                                  mapping_node, strength, settings.keep_background,
                                  plan.glossy_hdr, plan.ground_albedo is not None,
                                  glossy_image, plan.camera_only,
                                  plan.engine in scene_reader.EEVEE_ENGINES)
        if sun_note:
            notes.append(sun_note)
    elif mode != "LIGHTS":
        warnings.append("the world does not use nodes: world left as it was")
    if plan.raytrace:
        note = enable_raytracing(scene)
        notes += [note] if note else []
    if plan.probe is not None:
        note, warning = bake_probe(scene, plan.probe)
        notes += [note] if note else []
        warnings += [warning] if warning else []
    step(1.0)
    result = {
        "count": len(suns), "diffuse_error": summary["diffuse_error"],
        "seconds": time.perf_counter() - t0, "library_seconds": summary["seconds"],
        "power": [strength * p for p in power],
        "residual_power": [strength * p for p in summary["residual_power"]],
        "warnings": warnings,
        # the plan: what was computed and why, what was skipped and why
        "recipe": plan.recipe, "reasons": list(plan.reasons), "skipped": list(plan.skipped),
        "expected": plan.expected(),
        "settings": plan.settings_lines(len(suns), n_suns, order if plan.count else None),
        "diffuse_label": plan.diffuse_label(),
        "ground_albedo": plan.ground_albedo, "ground_object": plan.ground_object,
        "ground_edge": plan.ground_edge if plan.ground_band is not None else None,
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


def sky_sh2(residual, rows=32):
    """Order-2 SH coefficients (9 x RGB) fitting the lat-long `residual` (row 0 at the top)
    over the upper hemisphere only, by least squares weighted by solid angle: a ground hides
    the lower half, so the 9 coefficients spend nothing on it (the world is 0 there, see
    sh_radiance_socket's sky_only). The map is averaged to 2 `rows` x 4 `rows` pixels first
    (order 2 varies slowly; the Gram matrix over a hemisphere is well conditioned at order
    2); directions and solid angles are the library's (Envmap.direction, solid_angle)."""
    import numpy as np
    pkg = shim()
    h, w = residual.shape[:2]
    ry, rx = max(1, h // (2 * rows)), max(1, w // (4 * rows))
    hh, ww = h // ry, w // rx
    small = residual[: hh * ry, : ww * rx].astype(np.float64).reshape(
        hh, ry, ww, rx, 3).mean(axis=(1, 3))
    dirs, wts, vals = [], [], []
    with pkg.from_pixels(small.astype(np.float32), layout="latlong") as m:
        for r in range(hh):
            for c in range(ww):
                d = m.direction(c, r)
                if d[2] > 0:
                    dirs.append(d)
                    wts.append(m.solid_angle(r))
                    vals.append(small[r, c])
    basis = np.array([pkg.sh_basis(2, d) for d in dirs])
    sw = np.sqrt(np.array(wts))[:, None]
    coeffs, *_ = np.linalg.lstsq(basis * sw, np.array(vals) * sw, rcond=None)
    return coeffs


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
