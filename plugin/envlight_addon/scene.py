"""Reading the scene: what Create Lights computes for it and what it leaves out.

The render engine, the materials in use (any glossy surface, the roughness range), what casts
shadows, and a ground (a large flat horizontal object under the others) decide the request;
every choice comes with its reason, and what is skipped is said with why. Nothing here changes
the scene.
"""
import math

import bpy
import mathutils

from .figures import BENCH_DATE, BENCH_DATE_LEGACY, EXPECTED_ERROR, EXPECTED_ERROR_LEGACY

#: a surface is glossy when its roughness is below this (Principled BSDF, Glossy BSDF) or it
#: is metallic above GLOSSY_METALLIC: its reflection shows the environment, not only its
#: irradiance. Principled's default roughness is 0.5 (a broad dielectric sheen).
GLOSSY_ROUGHNESS = 0.4
GLOSSY_METALLIC = 0.5
#: a ground: flat (height below GROUND_FLAT of its width), horizontal (the normal of its
#: largest face within 10 degrees of +Z), at least GROUND_WIDE x the other objects' extent,
#: and its top at most GROUND_BELOW (in the other objects' heights) above their lowest point
GROUND_FLAT = 0.01
GROUND_WIDE = 3.0
GROUND_BELOW = 0.05
#: the ground's albedo when its material has no readable colour (Blender's default 0.8)
DEFAULT_ALBEDO = 0.8
LUMINANCE = (0.2126, 0.7152, 0.0722)

#: the in-scene error to expect per recipe (figures.py, written by scripts/figures.py from the
#: scene benchmark's JSON, docs/scene_bench_blender.json): the median over the scenes where the
#: add-on picks it of the converged error against a path-traced reference, relative RMS over
#: the objects' pixels, and its worst; a figure of the benchmark's scenes, not of the user's map
#: (EXPECTED_ERROR, imported above; EXPECTED_ERROR_LEGACY legacy EEVEE's, measured in 3.4)

#: the fit's SH remainder order for EEVEE: its world diffuse light is an L1 SH
EEVEE_ORDER = 1

#: EEVEE-Next's volume probe (Bake Volume Probe): a box around the objects other than the
#: ground, PROBE_MARGIN x their horizontal extent wider on each side (the floor they light
#: and shade), PROBE_BELOW of their height below their lowest point (so the lowest valid
#: layer of probes sits just above the ground, not in it: a layer on the ground gave the
#: ground none of the objects' bounce) and as much above; probes PROBE_STEP x their smallest
#: extent apart, at most PROBE_MAX per axis
PROBE_MARGIN = 1.0
PROBE_BELOW = 0.25
PROBE_STEP = 0.125
PROBE_MAX = 32
#: the probe's Normal Bias (EEVEE's default 0.3): a surface reads the grid this far out along
#: its normal, past the probes beside it that its own object half-blinds. Scene (a), the EEVEE
#: recipe with the probe, error against Cycles: the built-in sky 7.2 / 4.4 / 5.9 % at 0.3 / 1 / 2,
#: potsdamer_platz 10.6 / 4.3 / 4.9 %, rooitou_park 6.8 / 8.2 / 10.4 % (without a probe:
#: 4.4, 6.6, 10.9 %)
PROBE_NORMAL_BIAS = 1.0
PROBE_OFF = ("volume probe: off (Bake Volume Probe: the objects' bounce light and the sky they "
             "hide; in the scene benchmark nearer Cycles on some maps, further on others)")

ENGINES = {"CYCLES": "Cycles", "BLENDER_EEVEE_NEXT": "EEVEE", "BLENDER_EEVEE": "EEVEE",
           "BLENDER_WORKBENCH": "Workbench"}
EEVEE_ENGINES = ("BLENDER_EEVEE_NEXT", "BLENDER_EEVEE")


class Plan:
    """What Create Lights will do for a scene (the add-on's request) and why."""

    def __init__(self):
        self.engine = "CYCLES"
        self.world_mode = "SH"
        self.method = "fit"
        self.count = 4
        self.order = None              # the fit's SH remainder order; None: the panel's
        self.shadows = "SOFT"
        self.ground_albedo = None      # None: no ground treatment
        self.ground_object = None
        self.ground_edge = None        # (ground box lo, hi, the objects' centre): ground_edge.py
        self.ground_band = None        # core: the world's turn, when the map's pixels beyond
                                       # the ground's edge go back in the world (band_pixels)
        self.glossy = False
        self.min_roughness = None      # the sharpest surface's roughness (None: no BSDF has one)
        self.glossy_hdr = False        # glossy rays see the map itself (SH world)
        self.suns = True               # the suns split off first as lamps of their own
        self.camera_only = False       # only camera rays see the map (EEVEE: no ray split)
        self.compute = True            # False: nothing to compute for this engine
        self.reasons = []              # what was chosen and why
        self.skipped = []              # what was left out and why
        self.recipe = ""
        self.probe = None              # EEVEE volume probe: (centre, half size, resolution)
        self.force = False             # Create Lamps Anyway (Cycles)
        self.dome = 0                  # EEVEE: lamps in the dome (eevee_dome), 0: none
        self.raytrace = False          # EEVEE-Next: its ray tracing turned on (core)

    def settings_lines(self, lamps, suns, order):
        """What was used, one line per setting, for the panel (with Read Scene on the panel's
        own settings are not what the recipe uses: issue 28's greyed-out Remainder Order 2
        beside an EEVEE recipe of order 1). lamps: how many were made, suns: how many of
        them are the map's suns; order: the fit's remainder order used, or None."""
        world = {"RESIDUAL": "the residual image (what the lamps leave)",
                 "SH": "an order-2 SH node tree", "LIGHTS": "black (the lamps carry all)"}
        made = {"sun-residual": "the suns", "lamps-residual": "taken exactly"}.get(
            self.recipe, "%d by %s" % (lamps - suns, self.method))
        if self.dome:
            made = "%d in the dome" % (lamps - suns)
            made = "%d sun%s + %s" % (suns, "s" if suns > 1 else "", made) if suns else made
            order = None
        if suns and self.recipe not in ("sun-residual", "lamps-residual"):
            made = "%d sun%s + %s" % (suns, "s" if suns > 1 else "", made)
        out = ["lamps: %d (%s%s)" % (lamps, made, ", remainder order %d" % order
                                     if order is not None and self.count else ""),
            "shadows: %s" % self.shadows.lower(),
            "world: %s; camera rays: the map%s" % (
                world.get(self.world_mode, self.world_mode),
                "" if self.camera_only or self.world_mode == "SH" else ", glossy rays: the map")]
        if self.ground_albedo is not None:
            out.append("ground: %s, albedo %.2f" % (
                "'%s'" % self.ground_object if self.ground_object else "a plane z = 0",
                self.ground_albedo))
        return out

    def diffuse_label(self):
        """What the diffuse error figure measures for this recipe (unoccluded)."""
        if self.recipe in ("sun-residual", "lamps-residual"):
            return "the lamps + the residual world: exact but for the lamps' disc shape"
        if self.world_mode == "RESIDUAL" and self.camera_only:
            return ("the lamps + an order-1 SH of what they leave, as EEVEE lights its world's "
                    "diffuse")
        if self.world_mode == "SH":
            return "the lamps + the SH world"
        if self.world_mode == "LIGHTS":
            return "the lamps alone"
        return "the lamps + the fit's SH remainder"

    def expected(self):
        """'in-scene error to expect ...' for the report, or None without a figure: legacy
        EEVEE's own (measured in Blender 3.4) there, else Blender 4.3's."""
        legacy = self.engine == "BLENDER_EEVEE"
        fig = (EXPECTED_ERROR_LEGACY if legacy else EXPECTED_ERROR).get(self.recipe)
        if fig is None:
            return None
        return ("in-scene error to expect: %.1f %% (median over the benchmark's scenes where "
                "this recipe is picked, worst %.1f %%; scene benchmark of %s%s, not this map)"
                % (100 * fig[0], 100 * fig[1], BENCH_DATE_LEGACY if legacy else BENCH_DATE,
                   " in legacy EEVEE (Blender 3.4)" if legacy else ""))


def _ours(obj):
    try:
        return bool(obj.get("envlight"))
    except (AttributeError, TypeError):
        return False


def _visible_meshes(scene):
    out = []
    for o in scene.objects:
        if o.type not in ("MESH", "CURVE", "SURFACE", "META", "FONT") or _ours(o):
            continue
        if o.hide_render:
            continue
        out.append(o)
    return out


def _world_box(o):
    pts = [o.matrix_world @ mathutils.Vector(c) for c in o.bound_box]
    lo = mathutils.Vector((min(p.x for p in pts), min(p.y for p in pts), min(p.z for p in pts)))
    hi = mathutils.Vector((max(p.x for p in pts), max(p.y for p in pts), max(p.z for p in pts)))
    return lo, hi


def _casts_shadow(o):
    if hasattr(o, "visible_shadow"):
        return bool(o.visible_shadow)
    vis = getattr(o, "cycles_visibility", None)
    return bool(getattr(vis, "shadow", True))


def _socket_value(node, names, default=None):
    for n in names:
        s = node.inputs.get(n)
        if s is not None and not s.is_linked and hasattr(s, "default_value"):
            v = s.default_value
            try:
                return [float(x) for x in v]
            except TypeError:
                return float(v)
    return default


def material_surface(mat):
    """-> (glossy, roughness or None, albedo luminance or None) of a material's surface: the
    BSDF nodes in its tree (node groups not entered: their surface counts as matte)."""
    if mat is None or not mat.use_nodes or mat.node_tree is None:
        rough = getattr(mat, "roughness", 0.5) if mat is not None else 0.5
        metal = getattr(mat, "metallic", 0.0) if mat is not None else 0.0
        col = list(getattr(mat, "diffuse_color", (0.8, 0.8, 0.8)))[:3] if mat else None
        glossy = rough < GLOSSY_ROUGHNESS or metal > GLOSSY_METALLIC
        return glossy, rough, _lum(col) if col else None
    glossy, roughs, albedo = False, [], None
    for n in mat.node_tree.nodes:
        kind = n.bl_idname
        if kind == "ShaderNodeBsdfPrincipled":
            r = _socket_value(n, ("Roughness",), 0.5)
            m = _socket_value(n, ("Metallic",), 0.0)
            if isinstance(r, float):
                roughs.append(r)
                glossy = glossy or r < GLOSSY_ROUGHNESS
            if isinstance(m, float) and m > GLOSSY_METALLIC:
                glossy = True
            col = _socket_value(n, ("Base Color",))
            if isinstance(col, list) and albedo is None:
                albedo = _lum(col[:3])
        elif kind in ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic",
                      "ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction",
                      "ShaderNodeBsdfMetallic"):
            r = _socket_value(n, ("Roughness",), 0.5)
            if isinstance(r, float):
                roughs.append(r)
                glossy = glossy or r < GLOSSY_ROUGHNESS
        elif kind in ("ShaderNodeBsdfDiffuse",):
            col = _socket_value(n, ("Color",))
            if isinstance(col, list) and albedo is None:
                albedo = _lum(col[:3])
    return glossy, (min(roughs) if roughs else None), albedo


def _lum(rgb):
    return sum(w * c for w, c in zip(LUMINANCE, rgb))


def _materials(o):
    return [s.material for s in o.material_slots] or [None]


def find_ground(objs):
    """The ground: a large flat horizontal object under the others, or None."""
    boxes = {o.name: _world_box(o) for o in objs}
    best = None
    for o in objs:
        lo, hi = boxes[o.name]
        size = hi - lo
        width = min(size.x, size.y)
        if width <= 0 or size.z > GROUND_FLAT * max(size.x, size.y):
            continue
        others = [boxes[p.name] for p in objs if p is not o]
        if others:
            olo = mathutils.Vector((min(b[0].x for b in others), min(b[0].y for b in others),
                                    min(b[0].z for b in others)))
            ohi = mathutils.Vector((max(b[1].x for b in others), max(b[1].y for b in others),
                                    max(b[1].z for b in others)))
            extent = max(ohi.x - olo.x, ohi.y - olo.y)
            height = max(ohi.z - olo.z, 1e-6)
            if width < GROUND_WIDE * extent or hi.z > olo.z + GROUND_BELOW * height:
                continue
        if best is None or width > best[1]:
            best = (o, width)
    return best[0] if best else None


def set_ground(p, ground, others=()):
    """The ground treatment of plan p for the object `ground` (or None), with its reason;
    `others`: the objects on it, whose box's centre sees the ground's edge (ground_edge.py,
    used by core where the world is an image)."""
    if ground is None:
        p.skipped.append("ground treatment: no large flat object under the others")
        return
    if others:
        boxes = [_world_box(o) for o in others]
        centre = [(min(b[0][i] for b in boxes) + max(b[1][i] for b in boxes)) / 2
                  for i in range(3)]
        lo, hi = _world_box(ground)
        p.ground_edge = (tuple(lo), tuple(hi), tuple(centre))
    albedo = None
    for m in _materials(ground):
        _, _, a = material_surface(m)
        if a is not None:
            albedo = a
            break
    p.ground_object = ground.name
    p.ground_albedo = max(0.0, min(1.0, albedo if albedo is not None else DEFAULT_ALBEDO))
    p.reasons.append("ground '%s' (albedo %.2f%s): the map's lower half is left to it"
                     % (ground.name, p.ground_albedo, "" if albedo is not None else ", default"))


def set_probe(p, scene):
    """Plan p's EEVEE volume probe (Bake Volume Probe), with its reason or why not: a box
    around the visible objects other than the ground (PROBE_*)."""
    if p.engine != "BLENDER_EEVEE_NEXT":
        p.skipped.append("volume probe: %s" % ("EEVEE-Next's (Blender 4.2+) only"
                                               if p.engine == "BLENDER_EEVEE" else
                                               "EEVEE's only (%s traces the bounce itself)"
                                               % ENGINES.get(p.engine, p.engine)))
        return
    objs = _visible_meshes(scene)
    ground = find_ground(objs)
    rest = [o for o in objs if o is not ground]
    if not rest:
        p.skipped.append("volume probe: no object to bake it around")
        return
    boxes = [_world_box(o) for o in rest]
    lo = [min(b[0][i] for b in boxes) for i in range(3)]
    hi = [max(b[1][i] for b in boxes) for i in range(3)]
    ext = [max(h - l, 1e-3) for l, h in zip(lo, hi)]
    margin = PROBE_MARGIN * max(ext[0], ext[1])
    below = PROBE_BELOW * ext[2]
    lo = [lo[0] - margin, lo[1] - margin, lo[2] - below]
    hi = [hi[0] + margin, hi[1] + margin, hi[2] + below]
    step = PROBE_STEP * min(ext)
    # (a box 1e-3 of a step over a whole number of steps is that number: float bounds)
    res = [max(2, min(PROBE_MAX, int(math.ceil((h - l) / step - 1e-3))))
           for l, h in zip(lo, hi)]
    p.probe = ([(l + h) / 2 for l, h in zip(lo, hi)], [(h - l) / 2 for l, h in zip(lo, hi)],
               res)
    p.reasons.append("EEVEE: a volume probe of %d x %d x %d around %d object%s, baked (the "
                     "light they bounce onto each other and the sky they hide)"
                     % (res[0], res[1], res[2], len(rest), "s" if len(rest) > 1 else ""))


def read_scene(scene, volume_probe=False, dome=0):
    """The Plan for `scene` (its engine, objects, materials, shadows, ground); volume_probe:
    the panel's Bake Volume Probe; dome: EEVEE's dome of that many lamps (0: fitted lamps)."""
    p = Plan()
    engine = scene.render.engine
    p.engine = engine
    name = ENGINES.get(engine, engine)
    objs = _visible_meshes(scene)
    if engine == "BLENDER_WORKBENCH":
        p.compute = False
        p.recipe = "nothing"
        p.reasons.append("Workbench draws neither lamps nor the world's light")
        p.skipped.append("everything: Workbench lights with its own studio lights; switch to "
                         "Cycles or EEVEE, or turn Read Scene off")
        return p
    ground = find_ground(objs)
    rest = [o for o in objs if o is not ground]
    gloss, roughs = [], []
    for o in rest:
        for m in _materials(o):
            g, r, _ = material_surface(m)
            if g:
                gloss.append(o.name)
            if r is not None:
                roughs.append(r)
    p.glossy = bool(gloss)
    p.min_roughness = min(roughs) if roughs else None
    casters = [o.name for o in rest if _casts_shadow(o)]
    if casters:
        p.shadows = "SOFT"
        p.reasons.append("soft shadows (%d casting objects)" % len(casters))
    else:
        p.shadows = "NONE"
        p.skipped.append("shadows: no object casts one")
    # the world
    p.world_mode = "SH"
    p.method, p.count = "fit", 4
    if engine in EEVEE_ENGINES:
        # EEVEE lights from one capture of the world, shaded as a glossy ray (Is Glossy 1,
        # Is Camera 0): a world split by ray type cannot give diffuse and glossy different
        # light, so the lighting world is the map less the lamps for both, camera rays the map
        p.world_mode = "RESIDUAL"
        p.camera_only = True
        # EEVEE lights diffuse from an L1 (order-1) SH of the world (its volume probes and the
        # world's own irradiance): the lamps are fitted with an order-1 remainder, so what is
        # left in the world is what L1 holds. With order 2 the world kept an order-2 part that
        # EEVEE drops: scene (a) 25.9 -> 7.1 % on dikhololo_night, 14.9 -> 7.2 % on
        # potsdamer_platz (scripts/scene_bench.py --host blender, picked-eevee)
        p.order = EEVEE_ORDER
        set_ground(p, ground, rest)
        p.reasons.append("%s: %d fitted lamps + the residual image as the world's light "
                         "(EEVEE lights diffuse and glossy from one capture of the world)"
                         % (name, p.count))
        p.reasons.append("%s: the lamps fitted with an order-%d SH remainder (EEVEE's world "
                         "diffuse light is an order-1 SH)" % (name, p.order))
        p.skipped.append("the SH world: EEVEE captures the world once, the residual image is "
                         "as cheap there")
        p.recipe = "eevee-residual" + ("-ground" if p.ground_albedo is not None else "")
        # EEVEE-Next over a ground with objects casting shadows: the dome (its lamps' shadows
        # are the occlusion EEVEE's world light lacks) with EEVEE's own ray tracing (the
        # bounce between objects and the world light they hide, screen-traced). Measured on
        # every map: docs/scene_bench_blender.md (picked-eevee against fitted-eevee, the
        # fitted lamps without ray tracing, which they do not gain from: with it the residual
        # world's bright pixels are traced and clamped)
        next_gen = engine == "BLENDER_EEVEE_NEXT"
        # legacy EEVEE shadows 8 sun lamps at most (measured in 3.4: the 9th and later light
        # through the objects), and there domes of 4, 8 and 16 lamps were further from Cycles
        # than the fitted lamps (docs/blender_scenes.md, legacy EEVEE)
        why_not = None if next_gen and casters and p.ground_albedo is not None else (
            "EEVEE-Next's: legacy EEVEE shadows at most 8 sun lamps, and its domes of 4-16 "
            "were further from Cycles than the fitted lamps" if not next_gen else
            "no object casts a shadow" if not casters else "no ground found")
        if dome and why_not:
            p.skipped.append("the dome of %d lamps: %s" % (dome, why_not))
            dome = 0
        elif not dome and next_gen:
            p.skipped.append("the dome: EEVEE Dome is 0 (the panel)")
        if dome:
            p.raytrace = True
            p.reasons.append(
                "EEVEE-Next: ray tracing on (screen-traced at every roughness, full "
                "resolution, indirect light unclamped): the light the objects bounce onto "
                "one another and the sky they hide, which its world light does not know")
        elif next_gen:
            p.skipped.append("EEVEE-Next's ray tracing: it goes with the dome (the fitted "
                             "lamps' residual world, traced, was further from Cycles)")
        if dome:
            p.dome = dome
            p.shadows = "SOFT"
            p.reasons = [r for r in p.reasons if "fitted lamps" not in r and
                         "order-1 SH remainder" not in r]
            p.recipe = "eevee-dome" + ("-ground" if p.ground_albedo is not None else "")
        # EEVEE has no light bouncing between objects, and its world light is not occluded
        # by them, unless a volume probe is baked (EEVEE-Next): the panel's choice, as the
        # scene benchmark found it nearer Cycles on some maps and further on others
        if volume_probe and p.dome:
            # the bake renders the dome's lamps' shadows from every probe: EEVEE's shadow
            # pool overflowed (4474 of 2048 pages for 64 lamps) and the bake failed
            p.skipped.append("volume probe: not with the dome (baking it, the %d lamps' "
                             "shadows overflow EEVEE's shadow pool); EEVEE Dome 0 bakes it "
                             "with the fitted lamps" % p.dome)
        elif volume_probe:
            set_probe(p, scene)
        elif engine == "BLENDER_EEVEE_NEXT":
            p.skipped.append(PROBE_OFF)
        if p.probe is not None:
            p.recipe += "-probe"
        return p
    # Cycles: the suns as lamps (exact highlights and sharp shadows; the sun is what makes a
    # plain HDR world noisy), every other ray the map less the suns, importance-sampled by
    # Cycles: exact. The faster SH world (sh-ground: fitted lamps + an order-2 SH of the sky
    # half) is biased where the sky has structure the SH cannot hold: measured -1.6 to -14 %
    # on a matte sphere on a ground, -2 to -19 % under an overhang (docs/blender_scenes.md, the scene benchmark),
    # so it is the panel's choice (Read Scene off), never picked.
    p.world_mode, p.count, p.camera_only = "RESIDUAL", 0, True
    if p.glossy:
        p.reasons.append("%s: the suns as lamps, the map less the suns as the world (exact; "
                         "glossy surfaces %s, roughness from %.2f, see it as it is)"
                         % (name, ", ".join(gloss[:3]) + ("..." if len(gloss) > 3 else ""),
                            min(roughs) if roughs else 0.0))
    else:
        p.reasons.append("%s: the suns as lamps, the map less the suns as the world (exact)"
                         % name)
    p.skipped.append("fitted lamps and the SH world: faster, but biased by 2-19 % in the "
                     "scene benchmark (Read Scene off, World: SH World, Ground: Auto)")
    p.skipped.append("ground treatment: the world is the map itself, %s" % (
        "the ground '%s' is traced" % ground.name if ground is not None
        else "and there is no ground"))
    p.recipe = "sun-residual"
    return p


def plan_from_settings(settings, scene):
    """The Plan the panel's own settings give (Read Scene off); Ground Auto still looks for
    a ground in the scene."""
    p = Plan()
    p.engine = scene.render.engine
    p.world_mode = settings.world_mode
    p.method = settings.method
    p.count = settings.count
    p.shadows = settings.shadows
    p.glossy_hdr = settings.world_mode == "SH" and settings.glossy_hdr
    p.suns = settings.suns
    if settings.ground_mode == "ON":
        p.ground_albedo = settings.ground_albedo
        p.reasons.append("ground albedo %.2f (the panel)" % p.ground_albedo)
    elif settings.ground_mode == "AUTO":
        objs = _visible_meshes(scene)
        ground = find_ground(objs)
        set_ground(p, ground, [o for o in objs if o is not ground])
    if settings.volume_probe:
        set_probe(p, scene)
    elif p.engine == "BLENDER_EEVEE_NEXT":
        p.skipped.append(PROBE_OFF)
    p.recipe = "custom"
    p.reasons.append("the panel's settings (Read Scene off)")
    return p
