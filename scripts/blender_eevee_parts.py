#!/usr/bin/python3
"""Where EEVEE's error against Cycles comes from (issue 28): the scene benchmark's scenes
(scripts/scene_bench_blender.py's Bench) lit by one of the add-on's EEVEE recipes, rendered
in parts in EEVEE and in Cycles, each part compared with its Cycles twin, so each percent of
EEVEE's error is attributed. Cycles with the same lamps and the same world is the exact
answer of what EEVEE should show; the reference is the bench's (Cycles, the plain HDR world,
cached in --tmp the same way).

Renders (luminance, objects' pixels), per map, scene, recipe and EEVEE variant:
  E      EEVEE, lamps + world                 C4     Cycles, lamps + world, 4 bounces
  El     EEVEE, lamps only (world light 0)    Cl     Cycles, lamps only, direct light
  Eln    EEVEE, lamps only, no shadows        Cln    Cycles, lamps only, no shadows, direct
                                                      (the lamps' MIS off: Cycles blocks
                                                      their BSDF-sampled rays at geometry
                                                      even without shadows)
  Eln0   Eln with EEVEE's ray tracing off (only when the variant has it on; else Eln)
  Ew     EEVEE, world only (lamps hidden)     Cw     Cycles, world only, direct light
and from the shading normals (a Cycles render of them) and each object's albedo a, with
f the world image's lighting (its residual or ground image, what EEVEE lights diffuse with):
  X      a E(n) / pi, E the exact irradiance of f at n, nothing occluded
  L1     a mu (1 + 2 m.n): the order-1 SH of f (mu its mean radiance, m its first moment
         / its integral, per channel), what an unclamped L1 irradiance gives
  L1d    the same with EEVEE-Next's deringing: m scaled by min(1, 1 / (3 max_i |m_i|))
         (the least over the channels; Blender's spherical_harmonics_dering)
E - ref then splits into (each a difference image, over an object: its mean / the
reference's mean = a bias in %, its RMS / the reference's mean = an error in %):
  recipe     C4 - ref                  the recipe in Cycles (lamps + world = the map?)
  shading    Eln0 - Cln                EEVEE shades the lamps (no shadows, no ray tracing)
  traced     Eln - Eln0                what EEVEE's ray tracing adds to the lamps' light: their
                                       light off the surfaces on screen (its own bounce)
  shadows    (El - Eln) - (Cl - Cln)   EEVEE's lamp shadows against Cycles'
  L1         L1 - X                    the world's light cut to order 1
  dering     L1d - L1                  EEVEE-Next's deringing of the world's L1
  world      Ew - L1d                  EEVEE's world light otherwise (probe, clamps, AO)
  occlusion  X - Cw                    the world light EEVEE does not occlude
  bounce     Cl + Cw - C4              the light between objects EEVEE does not bounce
  additive   E - El - Ew               EEVEE's parts do not add up
(the glossy sphere: world = Ew - Cw, the next three left out). Cycles renders 2 x SPP
samples (two seeds); the terms with a Cycles render have its noise in their RMS. Each part's
luminance image stays in --tmp (MAP/part_SCENE_RECIPE_VARIANT_PART.npy) to be looked at.

  scripts/blender_eevee_parts.py [--map FILE ...] [--scenes a,c] [--recipes R1,R2]
      [--variants V1,V2] [--only-full] [--tmp DIR] [--json OUT] [--docs DIR]
Blender: $ENVL_BLENDER, else Debian 13's 4.3 (scripts/blender4.sh), else `blender`.
"""
import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import time

if __name__ == "__main__" and {"-h", "--help"} & set(
        sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]) and \
        "bpy" in sys.modules:
    print("usage: blender -b --factory-startup --python %s -- SPEC.json\n(run by "
          "scripts/blender_eevee_parts.py itself)\n\n%s"
          % ("scripts/" + os.path.basename(__file__), __doc__))
    sys.exit(0)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import scene_bench_blender as bench  # noqa: E402

#: Cycles samples of each part (two seeds)
SPP = 256
#: EEVEE variants: settings over the recipe's scene, (what, attribute, value); what is
#: "eevee" (Scene.eevee), "rt" (its ray_tracing_options), "lamps" (each EnvLight lamp's
#: Light), "world" (World)
VARIANTS = {
    "default": [],
    "noclamp": [("eevee", "clamp_surface_indirect", 0.0)],
    "jitter": [("lamps", "use_shadow_jitter", True)],
    "jitter-noclamp": [("lamps", "use_shadow_jitter", True),
                       ("eevee", "clamp_surface_indirect", 0.0)],
    "raytrace": [("eevee", "use_raytracing", True)],
    "raytrace-noclamp": [("eevee", "use_raytracing", True),
                         ("eevee", "clamp_surface_indirect", 0.0)],
    "shadow-rays": [("eevee", "shadow_ray_count", 4), ("eevee", "shadow_step_count", 16)],
    "filter0": [("lamps", "shadow_filter_radius", 0.0)],
    # every surface by the horizon scan (fast GI: occlusion and a screen-space bounce)
    "fastgi": [("eevee", "use_raytracing", True), ("rt", "trace_max_roughness", 0.0),
               ("eevee", "fast_gi_method", "GLOBAL_ILLUMINATION"),
               ("eevee", "fast_gi_resolution", "1"), ("eevee", "fast_gi_quality", 1.0),
               ("eevee", "fast_gi_step_count", 16), ("eevee", "fast_gi_ray_count", 4)],
    "fastgi-ao": [("eevee", "use_raytracing", True), ("rt", "trace_max_roughness", 0.0),
                  ("eevee", "fast_gi_method", "AMBIENT_OCCLUSION_ONLY"),
                  ("eevee", "fast_gi_resolution", "1"), ("eevee", "fast_gi_quality", 1.0),
                  ("eevee", "fast_gi_step_count", 16), ("eevee", "fast_gi_ray_count", 4)],
    "screen": [("eevee", "use_raytracing", True), ("rt", "trace_max_roughness", 1.0),
               ("rt", "resolution_scale", "1")],
    # EEVEE's ray tracing off (the add-on turns it on with the dome)
    "nort": [("eevee", "use_raytracing", False)],
    "screen-noclamp": [("eevee", "use_raytracing", True), ("rt", "trace_max_roughness", 1.0),
                       ("rt", "resolution_scale", "1"), ("eevee", "clamp_surface_indirect", 0.0)],
}
TERMS = ("recipe", "shading", "traced", "shadows", "L1", "dering", "world", "occlusion", "bounce",
         "additive")


def parse_args(argv):
    p = argparse.ArgumentParser(prog="blender_eevee_parts.py", description=__doc__.split(
        "\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--map", action="append", default=[], metavar="FILE",
                   help="a map ('-': the built-in sky); repeatable (default: potsdamer_platz_1k)")
    p.add_argument("--scenes", default="a,c", help="scenes (default a,c)")
    p.add_argument("--recipes", default="picked-eevee",
                   help="the bench's EEVEE recipes (scene_bench_blender.RECIPES), default "
                        "picked-eevee")
    p.add_argument("--variants", default="default",
                   help="EEVEE settings over the recipe (%s)" % ",".join(VARIANTS))
    p.add_argument("--only-full", action="store_true",
                   help="EEVEE lamps + world only (no parts): a quick comparison of variants")
    p.add_argument("--spp", type=int, default=SPP, help="Cycles samples per part and seed")
    p.add_argument("--tmp", default="/tmp/envl_eevee_parts", help="work folder; the "
                   "references are cached in TMP/references (as scene_bench.py --tmp)")
    p.add_argument("--json", metavar="OUT", help="write the results as JSON")
    p.add_argument("--docs", metavar="DIR", help="write DIR/blender_scene_parts.md and .json")
    p.add_argument("--envlight", default=os.path.join("build", "envlight"))
    p.add_argument("--library", default=os.path.join("build", "libenvlight.so"))
    a = p.parse_args(argv)
    for r in a.recipes.split(","):
        if r not in bench.EEVEE:
            p.error("--recipes: %s is not an EEVEE recipe (%s)" % (r, ",".join(bench.EEVEE)))
    for v in a.variants.split(","):
        if v not in VARIANTS:
            p.error("--variants: %s unknown (%s)" % (v, ",".join(VARIANTS)))
    return a


# ---- outside Blender ----------------------------------------------------------------------

def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    t0 = time.time()
    load0 = os.getloadavg()
    tmp = os.path.abspath(args.tmp)
    os.makedirs(tmp, exist_ok=True)
    version = bench.setup(os.path.abspath(args.envlight), os.path.abspath(args.library), tmp)
    maps = args.map or [os.path.join(bench_data(), "latlong_hdri", "potsdamer_platz_1k.hdr")]
    result = dict(command="scripts/blender_eevee_parts.py " + " ".join(
        sys.argv[1:] if argv is None else argv), date=datetime.datetime.now().isoformat(
        timespec="seconds"), load_average=list(load0), host_version=version, rows=[],
        worlds=[], spp=args.spp)
    for m in maps:
        if m == "-":
            path = os.path.join(tmp, "sky.hdr")
            subprocess.run([os.path.abspath(args.envlight), "convert", "-", path], check=True,
                           capture_output=True)
            name = "sky"
        else:
            path, name = os.path.abspath(m), os.path.basename(m).rsplit(".", 1)[0]
        for scene in args.scenes.split(","):
            d = os.path.join(tmp, name)
            os.makedirs(d, exist_ok=True)
            spec = dict(map=path, scene=scene, recipes=args.recipes.split(","),
                        variants=args.variants.split(","), only_full=args.only_full,
                        zip=bench.ZIP, image=bench.IMAGE, ref_spp=bench.REF_SPP, spp=args.spp,
                        dir=d, ref_cache=os.path.join(tmp, "references"),
                        out=os.path.join(d, "parts_%s.json" % scene))
            sp = os.path.join(d, "parts_spec_%s.json" % scene)
            with open(sp, "w") as f:
                json.dump(spec, f)
            t = time.time()
            p = subprocess.run([bench.BLENDER, "-b", "--factory-startup", "--python",
                                os.path.abspath(__file__), "--", sp], capture_output=True,
                               text=True, env=bench._env(tmp, [os.path.dirname(path)]))
            if p.returncode != 0 or not os.path.exists(spec["out"]):
                sys.exit("blender_eevee_parts: Blender failed on %s (%s):\n%s%s" % (
                    name, scene, p.stdout[-3000:], p.stderr[-2000:]))
            with open(spec["out"]) as f:
                res = json.load(f)
            for r in res["rows"]:
                r.update(map=name, scene=scene)
            for w in res["worlds"]:
                w.update(map=name, scene=scene)
            result["rows"] += res["rows"]
            result["worlds"] += res["worlds"]
            print("%s (%s): %.0f s, load %.1f" % (name, scene, time.time() - t,
                                                  os.getloadavg()[0]))
            for line in table(res["rows"], name, scene):
                print(line)
            sys.stdout.flush()
    result["load_average_end"] = list(os.getloadavg())
    result["total_seconds"] = time.time() - t0
    text = json.dumps(result, indent=1)
    if args.json:
        bench_write(args.json, text)
    if args.docs:
        bench_write(os.path.join(args.docs, "blender_scene_parts.json"), text)
        bench_write(os.path.join(args.docs, "blender_scene_parts.md"), "\n".join(report(result)))


def bench_data():
    return os.environ.get("ENVL_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data"))


def bench_write(path, text):
    sys.path.insert(0, HERE)
    from scene_bench import write_atomic
    write_atomic(path, text)


def table(rows, name=None, scene=None):
    """Markdown rows: per recipe, variant and object, E against the reference (error / bias)
    and each term's bias / RMS."""
    L = ["| map | scene | recipe | variant | object | E: error / bias % | " +
         " | ".join(TERMS) + " | EEVEE CPU s |", "|" + "---|" * (7 + len(TERMS))]
    for r in rows:
        if name is not None and (r.get("map", name), r.get("scene", scene)) != (name, scene):
            continue
        for obj, o in r["objects"].items():
            cells = ["%+.1f / %.1f" % (100 * o["terms"][t]["bias"], 100 * o["terms"][t]["rms"])
                     if t in o["terms"] else "-" for t in TERMS]
            L.append("| %s | %s | %s | %s | %s | %.1f / %+.1f | %s | %.0f |" % (
                r.get("map", name), r.get("scene", scene), r["recipe"], r["variant"], obj,
                100 * o["error"], 100 * o["bias"], " | ".join(cells), r["seconds"]))
    return L


def report(result):
    L = ["# EEVEE against Cycles, in parts", "",
         "Written by `scripts/blender_eevee_parts.py` (do not edit by hand); how to read it: "
         "[blender_scenes.md](blender_scenes.md).", "",
         "- command: `%s`" % result["command"],
         "- date: %s; total %.0f s" % (result["date"], result["total_seconds"]),
         "- load average at start / end: %s / %s" % (
             " ".join("%.2f" % v for v in result["load_average"]),
             " ".join("%.2f" % v for v in result["load_average_end"])),
         "- %s; Cycles parts %d samples x 2 seeds; EEVEE %d samples" % (
             result["host_version"], result["spp"], bench.EEVEE_SPP), "",
         "Cells: each term's bias / RMS over the object, in % of the reference's mean "
         "(the terms: the script's help); E: EEVEE's converged error / bias against the "
         "reference.", ""]
    L += table(result["rows"])
    L += ["", "## The worlds EEVEE lights with", "",
          "mu: mean radiance (luminance); m: the first moment / the integral, largest "
          "component over the channels; dering: EEVEE-Next's factor on L1 (1: none); "
          "max: the L1 radiance's maximum (EEVEE-Next scales the SH down to "
          "clamp_surface_indirect, 10 by default, when it is above).", "",
          "| map | scene | recipe | mu | max abs m_i | dering | L1 max |", "|---|---|---|---|---|---|---|"]
    for w in result["worlds"]:
        L.append("| %s | %s | %s | %.4g | %.3f | %.3f | %.4g |" % (
            w["map"], w["scene"], w["recipe"], w["mu"], w["m_max"], w["dering"], w["l1_max"]))
    return L + [""]


# ---- inside Blender ------------------------------------------------------------------------

def world_figures(np, pixels):
    """-> (mu, m, m_max, dering, l1_max) of a lat-long image (row 0 at the top, canonical
    frame): per channel mean radiance mu_c and first moment m_c = sum f d dw / sum f dw;
    m_max the largest |m_c,i|; dering EEVEE-Next's L1 factor min(1, min_c 1 / (3 max_i
    |m_c,i|)); l1_max the order-1 SH radiance's largest value max_c mu_c (1 + 3 |m_c|).
    (The lat-long directions and solid angles of envlight's Envmap.direction: theta from +Z
    (r + 0.5) pi / H, phi = pi - 2 pi (c + 0.5) / W.)"""
    h, w = pixels.shape[:2]
    th0 = np.arange(h) * math.pi / h
    th1 = (np.arange(h) + 1) * math.pi / h
    dw = (np.cos(th0) - np.cos(th1)) * 2 * math.pi / w                # (h,)
    th = (np.arange(h) + 0.5) * math.pi / h
    ph = math.pi - 2 * math.pi * (np.arange(w) + 0.5) / w
    d = np.stack([np.sin(th)[:, None] * np.cos(ph)[None], np.sin(th)[:, None] *
                  np.sin(ph)[None], np.cos(th)[:, None] * np.ones(w)[None]], -1)  # (h, w, 3)
    f = pixels.astype(np.float64) * dw[:, None, None]                 # f dw per channel
    total = f.sum(axis=(0, 1))                                        # (3,)
    mom = np.einsum("hwc,hwi->ci", f, d)                              # (3 channels, 3 axes)
    m = mom / np.maximum(total, 1e-30)[:, None]
    mu = total / (4 * math.pi)
    mx = np.abs(m).max(axis=1)
    dering = float(min(1.0, min(1.0 / (3 * v) if v > 0 else math.inf for v in mx)))
    l1_max = float(max(mu[c] * (1 + 3 * np.linalg.norm(m[c])) for c in range(3)))
    return mu, m, float(mx.max()), dering, l1_max


def _in_blender():
    import bpy
    import numpy as np
    from blender_scene import node_material
    spec = json.load(open(sys.argv[sys.argv.index("--") + 1]))
    b = bench.Bench(spec)
    scene, cy = b.scene, b.cy
    LUM = np.array(bench.LUMINANCE)
    eevee_engine = bench.EEVEE_ENGINE if bpy.app.version >= (4, 2, 0) else "BLENDER_EEVEE"
    r1, r2, _, _ = b.reference()
    yref = 0.5 * (r1 + r2)

    # the shading normals: each object's normal (world space) as an emission, (n + 1) / 2
    saved = [o.data.materials[0] for o in b.objs]
    for o in b.objs:
        m = node_material("PartsNormal", "ShaderNodeEmission")
        nt = m.node_tree
        geo = nt.nodes.new("ShaderNodeNewGeometry")
        half = nt.nodes.new("ShaderNodeVectorMath")
        half.operation = "MULTIPLY_ADD"
        half.inputs[1].default_value = (0.5, 0.5, 0.5)
        half.inputs[2].default_value = (0.5, 0.5, 0.5)
        nt.links.new(geo.outputs["Normal"], half.inputs[0])
        em = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeEmission")
        nt.links.new(half.outputs[0], em.inputs["Color"])
        o.data.materials[0] = m
    scene.world = bpy.data.worlds["BenchBlack"]
    scene.render.engine = "CYCLES"
    cy.samples = 1
    bpy.ops.render.render()
    normals = b.grab("normals") * 2 - 1
    normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-9)
    for o, m in zip(b.objs, saved):
        o.data.materials[0] = m
    albedo = np.zeros(yref.shape)
    for name, mask in b.masks.items():
        albedo[mask] = b.albedo.get(name) or 0.0

    b.install_addon()
    from envlight_addon import core
    pkg = core.shim()
    rows, worlds = [], []
    for recipe in spec["recipes"]:
        scene.render.engine = eevee_engine
        _, picked_as, _ = b.create_lights(bench.RECIPES[recipe])
        lamps = [o for o in bpy.data.objects if core.tagged(o) and o.type == "LIGHT"]
        tree = b.world.node_tree
        lighting = tree.nodes.get(core.NODE_PREFIX + "Lighting")
        strength = lighting.inputs["Strength"].default_value if lighting else None
        # the world's lighting image, what EEVEE lights diffuse with
        img = next((n.image for n in tree.nodes if core.tagged(n) and
                    n.bl_idname == "ShaderNodeTexEnvironment" and n.image is not None and
                    n.name == core.NODE_PREFIX + "Residual"), None)
        X = L1 = L1d = None
        if img is not None:
            wi, hi = img.size
            px = np.empty(wi * hi * 4, dtype=np.float32)
            img.pixels.foreach_get(px)
            f = px.reshape(hi, wi, 4)[::-1, :, :3] * (strength or 1.0)
            mu, m, m_max, dering, l1_max = world_figures(np, f)
            worlds.append(dict(recipe=recipe, mu=float(mu @ LUM), m_max=m_max, dering=dering,
                               l1_max=l1_max, m=m.tolist(), mu_rgb=mu.tolist()))
            sel = b.every
            ns = normals[sel]
            with pkg.from_pixels(np.ascontiguousarray(f, dtype=np.float32),
                                 layout="latlong") as env:
                E = np.asarray(env.irradiance(ns))                   # (n, 3)
            X = np.zeros(yref.shape)
            X[sel] = albedo[sel] * (E @ LUM) / math.pi
            L1, L1d = np.zeros(yref.shape), np.zeros(yref.shape)
            for fac, out in ((1.0, L1), (dering, L1d)):
                rgb = mu[None, :] * (1 + 2 * fac * ns @ m.T)         # (n, 3)
                out[sel] = albedo[sel] * (rgb @ LUM)

        def set_world(on):
            if lighting is not None:
                lighting.inputs["Strength"].default_value = strength if on else 0.0

        mis = {o.name: getattr(o.data.cycles, "use_multiple_importance_sampling", False)
               for o in lamps}

        def set_lamps(visible, shadows=True):
            for o in lamps:
                o.hide_render = not visible
                o.data.use_shadow = shadows
                if hasattr(o.data, "cycles") and hasattr(o.data.cycles, "cast_shadow"):
                    o.data.cycles.cast_shadow = shadows
                # Cycles stops a lamp's BSDF-sampled (MIS) rays at geometry even when the lamp
                # casts no shadow: without shadows the lamps are sampled alone, unoccluded
                if mis[o.name]:
                    o.data.cycles.use_multiple_importance_sampling = shadows

        def cycles(bounces):
            scene.render.engine = "CYCLES"
            cy.max_bounces = bounces
            a, _ = b.render(spec["spp"], 11)
            c, _ = b.render(spec["spp"], 12)
            return 0.5 * (a + c)

        C = {}
        if not spec["only_full"]:
            set_world(True), set_lamps(True)
            C["C4"] = cycles(4)
            set_world(False)
            C["Cl"] = cycles(0)
            set_lamps(True, shadows=False)
            C["Cln"] = cycles(0)
            set_world(True), set_lamps(False)
            C["Cw"] = cycles(0)
            set_lamps(True)
        saved_settings = {}
        for variant in spec["variants"]:
            for what, attr, value in saved_settings.values():   # the previous variant undone
                setattr(what, attr, value)
            saved_settings = {}
            for what, attr, value in VARIANTS[variant]:
                targets = {"eevee": [scene.eevee], "rt": [scene.eevee.ray_tracing_options]
                           if hasattr(scene.eevee, "ray_tracing_options") else [],
                           "lamps": [o.data for o in lamps], "world": [b.world]}[what]
                for t in targets:
                    if hasattr(t, attr):
                        saved_settings[(id(t), attr)] = (t, attr, getattr(t, attr))
                        setattr(t, attr, value)
            scene.render.engine = eevee_engine
            set_world(True), set_lamps(True)
            b.render(1, 1)   # shaders compiled outside the timing
            E_full, seconds = b.render(bench.EEVEE_SPP, 1)
            np.save(os.path.join(b.out_dir, "parts_%s_%s_%s.npy" % (
                spec["scene"], recipe, variant)), E_full.astype(np.float32))
            Ep = {}
            if not spec["only_full"]:
                set_world(False)
                Ep["El"], _ = b.render(bench.EEVEE_SPP, 1)
                set_lamps(True, shadows=False)
                Ep["Eln"], _ = b.render(bench.EEVEE_SPP, 1)
                Ep["Eln0"] = Ep["Eln"]
                if getattr(scene.eevee, "use_raytracing", False):
                    scene.eevee.use_raytracing = False
                    Ep["Eln0"], _ = b.render(bench.EEVEE_SPP, 1)
                    scene.eevee.use_raytracing = True
                set_world(True), set_lamps(False)
                Ep["Ew"], _ = b.render(bench.EEVEE_SPP, 1)
                set_lamps(True)
            for key, img in list(C.items()) + list(Ep.items()):   # each part, for a look
                np.save(os.path.join(b.out_dir, "part_%s_%s_%s_%s.npy" % (
                    spec["scene"], recipe, variant, key)), img.astype(np.float32))
            objects = {}
            for name, mask in b.regions():
                mr = yref[mask].mean()

                def fig(img):
                    return dict(bias=float(img[mask].mean() / mr),
                                rms=float(np.sqrt(np.mean(img[mask] ** 2)) / mr))
                terms = {}
                if C:
                    terms["recipe"] = fig(C["C4"] - yref)
                    terms["shading"] = fig(Ep["Eln0"] - C["Cln"])
                    terms["traced"] = fig(Ep["Eln"] - Ep["Eln0"])
                    terms["shadows"] = fig((Ep["El"] - Ep["Eln"]) - (C["Cl"] - C["Cln"]))
                    diffuse = X is not None and name not in ("glossy", "objects") or (
                        name == "objects" and X is not None and "glossy" not in b.masks)
                    if diffuse:
                        terms["L1"] = fig(L1 - X)
                        terms["dering"] = fig(L1d - L1)
                        terms["world"] = fig(Ep["Ew"] - L1d)
                        terms["occlusion"] = fig(X - C["Cw"])
                    else:
                        terms["world"] = fig(Ep["Ew"] - C["Cw"])
                    terms["bounce"] = fig(C["Cl"] + C["Cw"] - C["C4"])
                    terms["additive"] = fig(E_full - Ep["El"] - Ep["Ew"])
                err = np.sqrt(np.mean((E_full[mask] - yref[mask]) ** 2)) / mr
                objects[name] = dict(error=float(err),
                                     bias=float(E_full[mask].mean() / mr - 1), terms=terms)
            rows.append(dict(recipe=recipe, variant=variant, picked_as=picked_as,
                             seconds=seconds, lamps=len(lamps), objects=objects))
        for what, attr, value in saved_settings.values():
            setattr(what, attr, value)
    with open(spec["out"], "w") as f:
        json.dump(dict(rows=rows, worlds=worlds), f, indent=1)


if __name__ == "__main__" and "--" in sys.argv and "bpy" in sys.modules:
    from blender_scene import run_main
    run_main(_in_blender)
elif __name__ == "__main__":
    main()
