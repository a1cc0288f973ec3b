"""The POV-Ray side of scripts/scene_bench.py (--host pov): the scenes, the recipes, the
reference and the measures. scene_bench.py owns the arguments, the JSON and the report.

Scenes (povray_include/examples/, 200 x 150, no anti-aliasing, +FH):
  a  bench_scene.pov: a matte sphere (albedo 0.8), a glossy sphere (0.6, specular 0.5,
     roughness 0.05) on a grey plane (0.5);
  b  bench_occlusion.pov: a matte sphere (0.8) in a corner under an overhang (a wall behind
     it, a slab above it, albedo 0.5) on the same plane.
Each reads "lighting.inc" (written here per recipe and for the reference) and gives every
object its ambient through EnvLight_Add_Ambient (a no-op when no ambient is declared), so one
scene file serves every recipe and the reference. Bench_Pass 2 is an id mask (emission
colours), Bench_Pass 1 (scene a) the glossy sphere's highlights alone.

The reference (per map, per scene; its CPU seconds are the baseline of the speedups): the
canonical map (WIDTH wide) is split at BRIGHT_FACTOR x its mean luminance; the bright pixels
become BRIGHT_LIGHTS hard-shadowed median-cut lights (`envlight pov bright.pfm --method median
-n K --ambient none --shadows hard --no-place`), the rest is EnvLight_Sky() of the residual .hdr
under REFERENCE_RADIOSITY (recursion 2: the floor's bounce). Validation: the same lighting on a
lone white sphere (orthographic, VALIDATION_SIZE px) against the exact E(n) / pi of the whole
map (tests/py_pov.py's exact_irradiance), relative RMS of luminance, tolerance
VALIDATION_TOLERANCE. POV-Ray draws highlights from light sources only, so scene (a)'s glossy
sphere gets a second pass: the residual as SKY_LIGHTS median-cut lights lighting its highlight
alone; its convergence is the change from SKY_LIGHTS / 4 lights.

Measures: POV-Ray CPU seconds (user + system of the process, all threads: RUSAGE_CHILDREN
difference) and wall seconds; per object, error = sqrt(mean((Y - Yref)^2)) / mean(Yref) and
bias = mean(Y) / mean(Yref) - 1 over its pixels (luminance Y).
"""
import math
import os
import re
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
EXAMPLES = os.path.join(ROOT, "povray_include", "examples")

WIDTH = 512                  # the canonical map: recipes, reference, exact irradiance
IMAGE = (200, 150)
QUICK_IMAGE = (100, 75)
FLOOR_ALBEDO = 0.5           # the plane's albedo in both scenes (`--ground`)
SUN_FACTOR = 50.0            # sun_share: the power above 50 x the mean (prefilter's lobes)
# the reference (chosen by measurement, see scene_bench.py's report and docs/pov_scenes.md)
BRIGHT_FACTOR = 1.0          # bright = pixels above this x the mean luminance
BRIGHT_LIGHTS = 1024         # as this many median-cut lights, hard shadows (direct light)
BOUNCE_LIGHTS = 16           # and as this many under radiosity (their bounce)
REFERENCE_RADIOSITY = dict(pretrace_start=0.08, pretrace_end=0.02, count=800,
                           nearest_count=20, error_bound=0.15, recursion_limit=2,
                           low_error_factor=0.5, gray_threshold=0, minimum_reuse=0.005,
                           brightness=1, adc_bailout=0.001)
QUICK_RADIOSITY = dict(REFERENCE_RADIOSITY, count=200, error_bound=0.5, nearest_count=5,
                       pretrace_end=0.04)
QUICK_VALIDATION_SIZE = 64
SKY_LIGHTS = 1024
QUICK_SKY_LIGHTS = 128
VALIDATION_SIZE = 128
VALIDATION_TOLERANCE = 0.005

SCENES = {
    # file, objects (name -> id colour channel), the matte object, the glossy object
    "a": dict(file="bench_scene.pov", objects=(("matte", 0), ("glossy", 1), ("plane", 2)),
              matte="matte", glossy="glossy"),
    "b": dict(file="bench_occlusion.pov", objects=(("object", 0), ("overhang", 1),
                                                   ("plane", 2)),
              matte="object", glossy=None),
}

GROUND = ["--ground", str(FLOOR_ALBEDO)]


def _dome(n, shadows="hard", method="median"):
    return ["--recipe", "dome", "--method", method, "-n", str(n), *GROUND, "--shadows", shadows]


# name -> (envlight pov flags or None for `default`, POV-Ray text after the include). The
# includes place their own radiosity blocks (dome: EnvLight_Bounce_Settings(),
# image-radiosity: EnvLight_Radiosity_Residual_Settings()).
RECIPES = {
    "sh": (["--recipe", "sh"], ""),
    "sh-ground": (["--recipe", "sh", *GROUND], ""),
    "dome-ambient": (["--recipe", "dome-ambient", *GROUND], ""),
    "dome-64": (_dome(64), ""),
    "vdome-16-soft": (_dome(16, "soft", method="variance"), ""),
    "vdome-32": (_dome(32, method="variance"), ""),
    "vdome-64": (_dome(64, method="variance"), ""),
    "image-radiosity": (["--recipe", "image-radiosity"], ""),
    "image-radiosity-50": (["--recipe", "image-radiosity"],
                           "global_settings { radiosity { count 50 } }\n"),
    "default": (None, ""),
}
QUICK_RECIPES = ["sh", "vdome-32", "image-radiosity-50", "default"]


def family(recipe):
    """The plot's colour groups."""
    if recipe.startswith("sh"):
        return recipe
    if recipe.startswith("dome-ambient"):
        return "dome-ambient"
    if recipe.startswith("dome"):
        return "dome-soft" if recipe.endswith("soft") else "dome"
    if recipe.startswith("image-radiosity"):
        return "image-radiosity"
    return recipe


P = None   # tests/py_pov.py
E = None   # py_shim's envlight


def setup(envlight, library, tmp):
    """Imports tests/py_pov.py and the ctypes shim with this envlight and library."""
    global P, E
    os.environ["ENVLIGHT"] = envlight
    os.environ["ENVLIGHT_LIBRARY"] = library
    os.environ.setdefault("ENVL_SOURCE_DIR", ROOT)
    os.environ["ENVL_TEST_TMP"] = tmp
    for p in (os.path.join(ROOT, "py_shim"), os.path.join(ROOT, "tests")):
        if p not in sys.path:
            sys.path.insert(0, p)
    import envlight as e_mod
    import py_pov as p_mod
    P, E = p_mod, e_mod
    P.ENVLIGHT, P.LIBRARY, P.TMP = envlight, library, tmp
    if not P.POVRAY:
        sys.exit("scene_bench: povray not found")
    r = subprocess.run([P.POVRAY, "--version"], capture_output=True, text=True)
    lines = [x for x in (r.stdout + r.stderr).splitlines() if x.startswith("POV-Ray")]
    return lines[0].strip() if lines else "POV-Ray (unknown version)"


def default_maps(data_dir):
    """[(name, path)]: the built-in sky ('-') and every *.hdr in data_dir."""
    maps = [("sky", "-")]
    if os.path.isdir(data_dir):
        maps += [(f[:-4], os.path.join(data_dir, f)) for f in sorted(os.listdir(data_dir))
                 if f.endswith(".hdr")]
    else:
        print("SKIP: %s absent: only the built-in sky" % data_dir)
    return maps


# ---- rendering ----

def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def render(d, scene, lighting, size, prefix=""):
    """(image, wall s, CPU s) of scene ('a'/'b') under the lighting text, in d."""
    with open(os.path.join(d, "lighting.inc"), "w") as f:
        f.write(prefix + lighting)
    text = open(os.path.join(EXAMPLES, SCENES[scene]["file"])).read()
    t0, c0 = time.time(), cpu_seconds()
    img, _ = P.render(text, d, size=size[0], extra=("+H%d" % size[1],))
    return img, time.time() - t0, cpu_seconds() - c0


def rel_rms(a, ref):
    ya, yr = P.lum(a), P.lum(ref)
    return math.sqrt(np.mean((ya - yr) ** 2)) / np.mean(yr)


def bias(a, ref):
    return float(np.mean(P.lum(a)) / np.mean(P.lum(ref)) - 1)


# ---- the map and the reference ----

def prepare_map(path, d):
    """d/full.pfm (canonical, WIDTH wide), its pixels and per-row solid angles."""
    full = os.path.join(d, "full.pfm")
    if path == "-":
        P.envlight("convert", "-", full, "--sky-width", str(WIDTH), "--quiet")
    else:
        P.envlight("convert", path, full, "--width", str(WIDTH), "--quiet")
    px = P.load_pixels(full, WIDTH).astype(np.float64)
    h = px.shape[0]
    t = math.pi * (0.5 - np.arange(h + 1) / h)          # row edges, top to bottom
    dw = ((2 * math.pi / WIDTH) * (np.sin(t[:-1]) - np.sin(t[1:])))[:, None]
    return px, dw


def radiosity_block(settings):
    return ("global_settings { radiosity { %s normal off media off always_sample off } }\n"
            % " ".join("%s %g" % kv for kv in settings.items()))


def reference_lighting(d, px, dw, factor, lights, bounce_lights, radiosity):
    """The reference's lighting texts, in passes whose images add up (a render is linear in its
    lights): {"radiosity": the bright pixels as bounce_lights median-cut lights + the residual
    as EnvLight_Sky() under radiosity, "minus": the same bounce_lights alone (no radiosity),
    "plus": the bright pixels as `lights` median-cut lights alone}: the reference = radiosity -
    minus + plus, i.e. the direct light of `lights` lights, their bounce from bounce_lights
    (smooth: few lights do), the residual's direct and bounced light by radiosity. Hard
    shadows, deterministic: the direct light of the bounce lights cancels exactly. Also the
    bright pixels' share of the power and their number."""
    y = P.lum(px)
    bright = y > factor * (y * dw).sum() / (4 * math.pi)
    share = float((y * dw * bright).sum() / (y * dw).sum())
    E.save_image(os.path.join(d, "bright.pfm"), (px * bright[..., None]).astype(np.float32))
    res = (px * ~bright[..., None]).astype(np.float32)
    E.save_image(os.path.join(d, "residual.pfm"), res)
    E.save_image(os.path.join(d, "residual.hdr"), res)
    s = radiosity_block(radiosity)
    out = {}
    if bright.any():
        for inc, n in (("bright.inc", lights), ("bounce.inc", bounce_lights)):
            P.envlight("pov", "bright.pfm", "--method", "median", "-n", str(n), "--ambient",
                       "none", "--shadows", "hard", "--no-place", "-o", inc, "--quiet", cwd=d)
        s += '#include "bounce.inc"\nEnvLight_Place_Lights()\n'
        out["minus"] = '#include "bounce.inc"\nEnvLight_Place_Lights()\n'
        out["plus"] = '#include "bright.inc"\nEnvLight_Place_Lights()\n'
    out["radiosity"] = s + ('#declare EnvLight_Sky_File = "residual.hdr";\n'
                            '#declare EnvLight_Sky_Rotate = 0;\nEnvLight_Sky()\n')
    return out, share, int(bright.sum())


def reference_render(lighting, render_one):
    """(image, wall s, CPU s, CPU s of the radiosity pass) of the reference's passes;
    render_one(lighting text) -> (image, wall s, CPU s)."""
    img, wall, cpu = render_one(lighting["radiosity"])
    cpu_rad = cpu
    for key, sign in (("minus", -1), ("plus", 1)):
        if key in lighting:
            i, w, c = render_one(lighting[key])
            img, wall, cpu = img + sign * i, wall + w, cpu + c
    return img, wall, cpu, cpu_rad


VALIDATION_SCENE = """#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0 }
#include "lighting.inc"
#include "envlight.inc"
camera { orthographic location <0, 0, -10> look_at <0, 0, 0> right x * 2.2 up y * 2.2 }
sphere { 0, 1 pigment { rgb 1 } finish { diffuse 1 ambient 0 emission 0 } }
"""


def validate(d, lighting, size=VALIDATION_SIZE):
    """The reference lighting on a lone white sphere against the exact E(n) / pi of full.pfm:
    (relative RMS, bias, CPU s)."""
    def one(text):
        with open(os.path.join(d, "lighting.inc"), "w") as f:
            f.write(text)
        t0, c0 = time.time(), cpu_seconds()
        img, _ = P.render(VALIDATION_SCENE, d, size=size)
        return img, time.time() - t0, cpu_seconds() - c0
    img, _, cpu, _ = reference_render(lighting, one)
    mask, n = P.sphere_normals(size)
    exact = P.exact_irradiance(os.path.join(d, "full.pfm"), WIDTH, n[mask]) / math.pi
    return rel_rms(img[mask], exact), bias(img[mask], exact), cpu


def highlight_pass(d, n, size):
    """Scene (a)'s glossy highlights of the residual, from n median-cut lights."""
    P.envlight("pov", "residual.pfm", "-n", str(n), "--method", "median", "--ambient", "none",
               "--shadows", "hard", "-o", "sky_lights.inc", "--quiet", cwd=d)
    return render(d, "a", '#include "sky_lights.inc"\n', size, "#declare Bench_Pass = 1;\n")


# ---- recipes ----

def run_recipe(d, name, scene, size):
    """Writes env.inc for the recipe (scene: for `default`, what `envlight pov --scene` picks),
    renders. -> (image, wall s, CPU s, envlight seconds, recipe name as reported)."""
    flags, after = RECIPES[name]
    if flags is None:
        scene_path = os.path.join(d, "scene_%s.pov" % scene)
        with open(scene_path, "w") as f:
            f.write(open(os.path.join(EXAMPLES, SCENES[scene]["file"])).read())
        with open(os.path.join(d, "lighting.inc"), "w") as f:
            f.write('#include "env.inc"\n')
        P.envlight("pov", "full.pfm", "--scene", scene_path, "-o", "env.inc", "--quiet", cwd=d)
    else:
        P.envlight("pov", "full.pfm", *flags, "-o", "env.inc", "--quiet", cwd=d)
    text = open(os.path.join(d, "env.inc"), encoding="utf-8", errors="replace").read()
    m = re.search(r"^// recipe: ([^\s:]+)", text, re.M)
    reported = m.group(1) if m else None
    m = re.search(r"#declare EnvLight_Seconds = ([^;]*);", text)
    seconds = float(m.group(1)) if m else None
    img, wall, cpu = render(d, scene, '#include "env.inc"\n' + after, size)
    return img, wall, cpu, seconds, reported


# ---- one map ----

np = None


def _log(*a):
    print(*a)
    sys.stdout.flush()


def run_map(name, path, opts, log=_log):
    """Everything for one map: (map entry for the JSON, runs, images for the grid).
    opts: quick, recipes, scenes, tmp."""
    global np
    import numpy
    np = numpy
    quick = opts["quick"]
    size = QUICK_IMAGE if quick else IMAGE
    radiosity = QUICK_RADIOSITY if quick else REFERENCE_RADIOSITY
    sky_lights = QUICK_SKY_LIGHTS if quick else SKY_LIGHTS
    d = os.path.join(opts["tmp"], name)
    os.makedirs(d, exist_ok=True)
    t_map = time.time()
    px, dw = prepare_map(path, d)
    y = P.lum(px)
    mean = (y * dw).sum() / (4 * math.pi)
    sun_share = float((y * dw * (y > SUN_FACTOR * mean)).sum() / (y * dw).sum())
    lighting, bright_share, n_bright = reference_lighting(d, px, dw, BRIGHT_FACTOR,
                                                          BRIGHT_LIGHTS, BOUNCE_LIGHTS,
                                                          radiosity)
    v_err, v_bias, v_cpu = validate(d, lighting, QUICK_VALIDATION_SIZE if quick
                                    else VALIDATION_SIZE)
    ref = dict(validation_error=v_err, validation_bias=v_bias, validation_cpu_seconds=v_cpu,
               validation_tolerance=VALIDATION_TOLERANCE,
               validated=bool(v_err <= VALIDATION_TOLERANCE),
               bright_factor=BRIGHT_FACTOR, bright_lights=BRIGHT_LIGHTS if n_bright else 0,
               bounce_lights=BOUNCE_LIGHTS if n_bright else 0,
               bright_pixels=n_bright, bright_share=bright_share,
               radiosity=radiosity_block(radiosity).strip(),
               seconds={}, cpu_seconds={}, highlight={})
    log("%s: sun share %.1f %% (> %g x mean), bright share %.1f %% (%d pixels > %g x mean, %d "
        "lights); validation %.3f %% RMS (bias %+.3f %%, %.1f s CPU)%s"
        % (name, 100 * sun_share, SUN_FACTOR, 100 * bright_share, n_bright, BRIGHT_FACTOR,
           ref["bright_lights"], 100 * v_err, 100 * v_bias, v_cpu,
           "" if ref["validated"] else "  ** above the %.1f %% tolerance **"
           % (100 * VALIDATION_TOLERANCE)))
    runs, images = [], {}
    for scene in opts["scenes"]:
        spec = SCENES[scene]
        ids, _, _ = render(d, scene, "", size, "#declare Bench_Pass = 2;\n")
        masks = {obj: ids[..., ch] > 0.5 for obj, ch in spec["objects"]}
        small = [o for o, m in masks.items() if m.sum() < (50 if quick else 300)]
        assert not small, "scene %s: id mask: too few pixels of %s" % (scene, small)
        img_ref, t_ref, c_ref, c_rad = reference_render(
            lighting, lambda text: render(d, scene, text, size))
        refs = {obj: img_ref for obj in masks}
        if spec["glossy"]:
            coarse, _, _ = highlight_pass(d, sky_lights // 4, size)
            hi, t_hi, c_hi = highlight_pass(d, sky_lights, size)
            g = masks[spec["glossy"]]
            ref_glossy = img_ref + hi
            conv = math.sqrt(np.mean((P.lum(coarse[g]) - P.lum(hi[g])) ** 2)) \
                / np.mean(P.lum(ref_glossy[g]))
            refs[spec["glossy"]] = ref_glossy
            img_ref = ref_glossy
            ref["highlight"][scene] = dict(lights=sky_lights, coarse_lights=sky_lights // 4,
                                           convergence=float(conv), seconds=t_hi,
                                           cpu_seconds=c_hi)
            log("  (%s) highlight pass: %d lights, %.2f s CPU; change from %d lights %.3f %% "
                "of the glossy sphere's mean" % (scene, sky_lights, c_hi, sky_lights // 4,
                                                   100 * conv))
        ref["seconds"][scene], ref["cpu_seconds"][scene] = t_ref, c_ref
        ref.setdefault("radiosity_pass_cpu_seconds", {})[scene] = c_rad
        images[(scene, "reference")] = img_ref
        log("  (%s) reference: %.2f s wall, %.2f s CPU (radiosity pass %.2f s); load average "
            "%.2f %.2f %.2f" % ((scene, t_ref, c_ref, c_rad) + os.getloadavg()))
        for recipe in opts["recipes"]:
            img, wall, cpu, env_s, reported = run_recipe(d, recipe, scene, size)
            errors = {o: float(rel_rms(img[m], refs[o][m])) for o, m in masks.items()}
            biases = {o: bias(img[m], refs[o][m]) for o, m in masks.items()}
            picked = recipe == "default"
            row = dict(map=name, scene=scene,
                       recipe=(reported or "default") if picked else recipe,
                       picked=picked, engine="povray", seconds=cpu, wall_seconds=wall,
                       error=errors[spec["matte"]], errors=errors,
                       bias=biases[spec["matte"]], biases=biases,
                       speedup=c_ref / cpu if cpu > 0 else float("inf"),
                       envlight_seconds=env_s)
            runs.append(row)
            if picked:
                images[(scene, "picked")] = img
            log("  (%s) %-18s %6.2f s CPU %6.2f s wall %6.1fx  %s" % (
                scene, row["recipe"] + ("*" if picked else ""), cpu, wall, row["speedup"],
                "  ".join("%s %.2f %% (%+.2f)" % (o, 100 * errors[o], 100 * biases[o])
                          for o in errors)))
            sys.stdout.flush()
    ref["map_seconds"] = time.time() - t_map
    return dict(path=path, sun_share=sun_share, reference=ref), runs, images
