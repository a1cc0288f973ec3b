#!/usr/bin/python3
"""Accuracy against time in POV-Ray 3.7 (README.md, "Accuracy against time in POV-Ray"):
bench_scene.pov (a matte sphere and a glossy sphere on a grey plane) lit by `envlight pov`
(fit and median lights, with and without the SH ambient, hard and soft shadows), against a
reference rendered once per map.

The reference. Radiosity of the raw HDR as a sky_sphere misses a 0.5-degree sun (a few hundred
samples per point), so the map is split (DESIGN.md's canonical map at WIDTH):
  sun      = the pixels brighter than 50 x the map's mean luminance (the prefilter's threshold
             for point lobes), as SUN_LIGHTS median-cut lights (`envlight pov`, hard shadows:
             the lights are spread over the sun's own pixels, so they draw its penumbra);
  residual = everything else, as a sky_sphere (EnvLight_Sky() on the residual .hdr) under
             high-quality radiosity (RADIOSITY: count 1600, error_bound 0.1, recursion 2 for
             the plane's bounce onto the spheres).
It is validated on a white sphere alone (orthographic, no plane): relative RMS of luminance
over its pixels against the exact E(n) / pi (the library's brute-force integrator).
POV-Ray highlights come from light sources only, so the glossy reference adds a second pass:
the residual as SKY_LIGHTS median-cut lights lighting only the glossy sphere's highlight
(Bench_Pass 1; the sun's highlight is in the first pass). Its convergence is reported as the
change from SKY_LIGHTS / 4 to SKY_LIGHTS lights.

Errors: relative RMS of luminance, sqrt(mean((Y - Y_ref)^2)) / mean(Y_ref) (DESIGN.md's
measure applied to pixels), over the matte sphere's, the plane's and the glossy sphere's
pixels (an id-mask render). Times: POV-Ray wall time of the whole run, and the start-up
(the same size, an empty scene) stated separately.

Usage (from the build folder; not run in CI; a few minutes on 2 cores):
  ENVLIGHT=./envlight ENVLIGHT_LIBRARY=./libenvlight.so PYTHONPATH=../py_shim \\
      /usr/bin/python3 ../povray_include/examples/bench_scene.py [--quick] [--plot DIR]
          [--map NAME] [--ambient A[,A...]]
--quick: one map, a few cases (the script's own check); --plot DIR: write
DIR/pov_error_time.png (gnuplot) and DIR/pov_renders.png (oiiotool) for the README;
--map NAME: only the map whose file name starts with NAME (its reference is still rendered);
--ambient A,B: only the fit cases with these ambients (no median cases): a partial run.
"""
import math
import os
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests"))
os.environ.setdefault("ENVL_SOURCE_DIR", os.path.join(HERE, "..", ".."))
import numpy as np  # noqa: E402
import envlight as E  # noqa: E402  (py_shim: map pixels, solid angles, .pfm/.hdr writer)
import py_pov as P  # noqa: E402  (envlight runner, POV-Ray runner, .hdr reader, exact E(n))

WIDTH = 512                    # canonical map width for everything (lights, sky, exact)
IMAGE = (200, 150)             # render size
SUN_FACTOR = 50.0              # sun = pixels above 50 x mean luminance
SUN_LIGHTS = 16
SKY_LIGHTS = 1024
VALIDATION_SIZE = 128
VALIDATION_TOLERANCE = 0.01    # the reference must match the exact E(n) / pi to 1 % RMS
FLOOR_ALBEDO = 0.5             # bench_scene.pov's Bench_Floor_Albedo: `envlight pov --ground`
MAPS = [("rooitou_park (strong sun)", "rooitou_park_1k.hdr"),
        ("potsdamer_platz (overcast)", "potsdamer_platz_1k.hdr")]
TMP = os.environ.get("ENVL_TEST_TMP", "/tmp/envl_pov_bench")

RADIOSITY = """global_settings { radiosity {
  pretrace_start 0.08 pretrace_end 0.01 count 1600 nearest_count 20 error_bound 0.1
  recursion_limit 2 low_error_factor 0.5 gray_threshold 0 minimum_reuse 0.005
  brightness 1 adc_bailout 0.001 normal off media off always_sample off } }
"""


def lum(c):
    return P.lum(c)


def rel_rms(a, ref):
    ya, yr = lum(a), lum(ref)
    return math.sqrt(np.mean((ya - yr) ** 2)) / np.mean(np.abs(yr))


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def pov(scene_text, d, size, extra=()):
    """(image, wall seconds, CPU seconds): one POV-Ray run, the whole process (CPU time, all
    threads, is less disturbed than wall time when other work shares the cores)."""
    t0, c0 = time.time(), cpu_seconds()
    img, _ = P.render(scene_text, d, size=size[0], extra=("+H%d" % size[1], *extra))
    return img, time.time() - t0, cpu_seconds() - c0


def bench_pov(d, lighting, size=IMAGE):
    with open(os.path.join(d, "lighting.inc"), "w") as f:
        f.write(lighting)
    return pov(open(os.path.join(HERE, "bench_scene.pov")).read(), d, size)


def split(path, d):
    """full.pfm (canonical map), sun.pfm and residual.hdr/.pfm in d; the sun's fraction."""
    with E.load(path, width=WIDTH) as env:
        px = env.pixels().astype(np.float64)
        dw = np.array([env.solid_angle(r) for r in range(env.height)])[:, None]
        env.save(os.path.join(d, "full.pfm"))
    y = lum(px)
    sun = y > SUN_FACTOR * (y * dw).sum() / (4 * math.pi)
    E.save_image(os.path.join(d, "sun.pfm"), (px * sun[..., None]).astype(np.float32))
    res = (px * ~sun[..., None]).astype(np.float32)
    E.save_image(os.path.join(d, "residual.pfm"), res)
    E.save_image(os.path.join(d, "residual.hdr"), res)
    return int(sun.sum()), (y * dw * sun).sum() / (y * dw).sum()


def reference_lighting(d, has_sun):
    """lighting.inc of the reference's first pass: sun lights + residual sky under radiosity."""
    s = "#declare Bench_Ambient = 0;\n" + RADIOSITY
    if has_sun:
        P.envlight("pov", "sun.pfm", "-n", str(SUN_LIGHTS), "--method", "median",
                   "--ambient", "none", "--shadows", "hard", "--no-place", "-o", "sun.inc",
                   "--quiet", cwd=d)
        s += '#include "sun.inc"\nEnvLight_Place_Lights()\n'
    else:
        s += '#include "envlight.inc"\n'
    return s + ('#declare EnvLight_Sky_File = "residual.hdr";\n'
                '#declare EnvLight_Sky_Rotate = 0;\nEnvLight_Sky()\n')


def highlight_pass(d, n):
    """The residual sky's highlights on the glossy sphere, from n median-cut lights."""
    P.envlight("pov", "residual.pfm", "-n", str(n), "--method", "median", "--ambient", "none",
               "--shadows", "hard", "-o", "sky_lights.inc", "--quiet", cwd=d)
    return bench_pov(d, '#declare Bench_Pass = 1;\n#include "sky_lights.inc"\n')


VALIDATION = """#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0 }
#include "lighting.inc"
camera { orthographic location <0, 0, -10> look_at <0, 0, 0> right x * 2.2 up y * 2.2 }
sphere { 0, 1 pigment { rgb 1 } finish { diffuse 1 ambient 0 emission 0 } }
"""


def validate(d):
    """The reference lighting on a white sphere alone against the exact E(n) / pi."""
    img, t, _ = pov(VALIDATION, d, (VALIDATION_SIZE, VALIDATION_SIZE))
    mask, n = P.sphere_normals(VALIDATION_SIZE)
    exact = P.exact_irradiance(os.path.join(d, "full.pfm"), WIDTH, n[mask]) / math.pi
    return rel_rms(img[mask], exact), t


def cases(quick, ambients=None):
    """(method, N, ambient, shadows): fit up to 16 lights (its greedy fit stops adding lights
    that no longer help), median 1..256; median's residual is zero, so its SH ambient adds
    nothing and is not rendered. Ambient "sh": the slope-pattern SH ambient (no radiosity);
    "sh-radiosity": the same SH as EnvLight_Radiosity_Sky() under EnvLight_Radiosity_Settings()
    with recursion 2 (POV-Ray radiosity of the smooth remainder: occlusion and bounces);
    "sh-ground", "sh-ground-radiosity": the same from `envlight pov --ground FLOOR_ALBEDO`
    (the map's lower hemisphere replaced by the floor's bounce before lights and SH);
    "image-radiosity": no SH: the residual image (`envlight pov --sky-residual`, the map minus
    what the fit's lights took, so lights + sky = the map) as EnvLight_Sky() under
    EnvLight_Radiosity_Residual_Settings() (count 150, recursion 2). ambients: only these
    (a partial run: fit cases only)."""
    fit = (1, 4) if quick else (1, 4, 16)
    median = (4, 16) if quick else (1, 4, 16, 64, 256)
    out = []
    for shadows in ("hard", "soft"):
        out += [("fit", n, a, shadows) for n in fit for a in AMBIENTS
                if ambients is None or a in ambients]
        if ambients is None:
            out += [("median", n, "none", shadows) for n in median]
    return out


AMBIENTS = ("none", "sh", "sh-radiosity", "sh-ground", "sh-ground-radiosity", "image-radiosity")


def run_map(label, path, quick, rows, images, ambients=None):
    d = P.tmpdir(os.path.basename(path).split(".")[0])
    n_sun, frac = split(path, d)
    # id mask
    ids, _, _ = bench_pov(d, "#declare Bench_Pass = 2;\n")
    masks = {"matte": ids[..., 0] > 0.5, "plane": ids[..., 2] > 0.5, "glossy": ids[..., 1] > 0.5}
    assert all(m.sum() > 1000 for m in masks.values()), "id mask: an object is missing"
    # start-up: an empty scene of the same size (parse of envlight.inc included)
    empty = '#version 3.7;\n#include "envlight.inc"\ncamera { location -z look_at 0 }\n'
    _, t_start, _ = pov(empty, d, IMAGE)
    # reference and its validation
    lighting = reference_lighting(d, n_sun > 0)
    with open(os.path.join(d, "lighting.inc"), "w") as f:
        f.write(lighting)
    v_err, v_time = validate(d)
    ref, t_ref, c_ref = bench_pov(d, lighting)
    hi_coarse, _, _ = highlight_pass(d, SKY_LIGHTS // 4)
    hi, t_hi, _ = highlight_pass(d, SKY_LIGHTS)
    ref_glossy = ref + hi
    m = masks["glossy"]
    hi_conv = math.sqrt(np.mean((lum(hi_coarse[m]) - lum(hi[m])) ** 2)) / lum(ref_glossy[m]).mean()
    print("%s: sun = %d pixels, %.1f %% of the power; start-up %.2f s" %
          (label, n_sun, 100 * frac, t_start))
    print("  reference: %.2f s, CPU %.2f s (radiosity + %d sun lights), glossy highlight pass "
          "%.2f s "
          "(%d lights; change from %d lights: %.3f %% of the glossy sphere's mean)"
          % (t_ref, c_ref, SUN_LIGHTS if n_sun else 0, t_hi, SKY_LIGHTS, SKY_LIGHTS // 4,
             100 * hi_conv))
    print("  validation (white sphere alone vs exact E/pi, %dx%d): %.3f %% RMS, %.2f s"
          % (VALIDATION_SIZE, VALIDATION_SIZE, 100 * v_err, v_time))
    sys.stdout.flush()
    if v_err > VALIDATION_TOLERANCE:
        sys.exit("%s: the reference is off by %.2f %% on the white sphere (tolerance %.0f %%)"
                 % (path, 100 * v_err, 100 * VALIDATION_TOLERANCE))
    images[(label, "reference")] = ref_glossy * 1  # full scene as seen (+ sky highlights)
    rows.append((label, "reference", 0, "-", "-", t_ref, 0.0, 0.0, 0.0, v_err, c_ref))
    print("  load average %.2f %.2f %.2f" % os.getloadavg())
    for method, n, ambient, shadows in cases(quick, ambients):
        ground = ("--ground", str(FLOOR_ALBEDO)) if "ground" in ambient else ()
        image = ambient == "image-radiosity"
        P.envlight("pov", "full.pfm", "-n", str(n), "--method", method, "--ambient",
                   "sh" if image else ambient.split("-")[0], "--shadows", shadows, *ground,
                   *(("--sky-residual",) if image else ()), "-o", "env.inc", "--quiet", cwd=d)
        radiosity = ambient.endswith("radiosity")
        lighting = "#declare Bench_Ambient = %d;\n#include \"env.inc\"\n" % (
            ambient != "none" and not radiosity)
        if image:
            # the include placed the lights and EnvLight_Sky() (the residual); the SH
            # remainder it declares is not used
            lighting += "global_settings { EnvLight_Radiosity_Residual_Settings() }\n"
        elif radiosity:
            # the include's settings, with the reference's recursion (the plane's bounce of
            # the sky onto the spheres; a later radiosity block changes only what it names)
            lighting += ("global_settings { EnvLight_Radiosity_Settings() }\n"
                         "global_settings { radiosity { recursion_limit 2 } }\n"
                         "EnvLight_Radiosity_Sky()\n")
        img, t, c = bench_pov(d, lighting)
        e = [rel_rms(img[masks[k]], (ref_glossy if k == "glossy" else ref)[masks[k]])
             for k in ("matte", "plane", "glossy")]
        rows.append((label, method, n, ambient, shadows, t, *e, None, c))
        images[(label, method, n, ambient, shadows)] = img
        print("  %s %d %s %s: %.2f s, matte %.2f %%, plane %.2f %%, glossy %.2f %%"
              % (method, n, ambient, shadows, t, 100 * e[0], 100 * e[1], 100 * e[2]))
        sys.stdout.flush()
    print("  load average %.2f %.2f %.2f" % os.getloadavg())
    return t_start, (t_ref, c_ref)


def table(rows, starts):
    print("\n| map | method | N | ambient | shadows | POV-Ray s | CPU s | matte sphere % | "
          "plane % | glossy sphere % |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        label, method = r[0], r[1]
        if method == "reference":
            print("| %s | reference (start-up %.2f s) | - | - | - | %.1f | %.1f | (validation "
                  "%.2f) | - | - |" % (label, starts[label], r[5], r[10], 100 * r[9]))
            continue
        print("| %s | %s | %d | %s | %s | %.2f | %.2f | %.2f | %.2f | %.2f |"
              % (label, method, r[2], r[3], r[4], r[5], r[10], 100 * r[6], 100 * r[7],
                 100 * r[8]))


def goal(rows, refs):
    """The issue's goal: fit, 4 lights + SH ambient, >= 10x faster than the reference with a
    matte-sphere error below 2 %."""
    print()
    for r in rows:
        if r[1] == "fit" and r[2] == 4 and r[3] != "none":
            ratio, cpu_ratio = refs[r[0]][0] / r[5], refs[r[0]][1] / r[10]
            on = [k for k, q in (("wall", ratio), ("CPU", cpu_ratio)) if q >= 10]
            ok = "met (%s)" % " and ".join(on) if on and r[6] < 0.02 else "NOT met"
            print("goal %s fit 4 + %s, %s shadows: %.1fx faster than the reference (CPU time "
                  "%.1fx), matte error %.2f %% -> %s" % (r[0], r[3], r[4], ratio, cpu_ratio,
                                                         100 * r[6], ok))


COLOURS = {"fit": "#999999", "fit + SH": "#e69f00", "fit + SH radiosity": "#0072b2",
           "fit + SH ground": "#009e73", "fit + SH ground radiosity": "#cc79a7",
           "fit + image radiosity": "#56b4e9",
           "median": "#d55e00"}


def plot(rows, out_dir, images):
    """Error against seconds (log axes) and a strip of renders, as PNG."""
    d = P.tmpdir("plot")
    os.makedirs(out_dir, exist_ok=True)
    series = {}
    for r in rows:
        if r[1] == "reference":
            continue
        amb = {"sh": " + SH", "sh-radiosity": " + SH radiosity", "sh-ground": " + SH ground",
               "sh-ground-radiosity": " + SH ground radiosity",
               "image-radiosity": " + image radiosity"}.get(r[3], "")
        key = "%s, %s%s, %s" % (r[0].split(" ")[0], r[1], amb, r[4])
        series.setdefault(key, []).append((r[5], 100 * r[6], r[2]))
    plots = []
    for i, (key, pts) in enumerate(sorted(series.items())):
        fn = os.path.join(d, "s%d.dat" % i)
        with open(fn, "w") as f:
            for t, e, n in pts:
                f.write("%g %g %d\n" % (t, e, n))
        # colour: method + ambient; point: map (square: the first, circle: the second);
        # line: shadows (dashed: soft)
        kind = key.split(", ", 1)[1].rsplit(", ", 1)[0]
        colour = COLOURS.get(kind, "black")
        dt = "dashtype 2" if key.endswith("soft") else "dashtype 1"
        pt = 5 if key.startswith(MAPS[0][0].split(" ")[0]) else 7
        plots.append("'%s' using 1:2 with linespoints lc rgb '%s' %s pt %d title '%s', "
                     "'%s' using 1:2:3 with labels offset 0.6,0.6 font ',7' notitle"
                     % (fn, colour, dt, pt, key, fn))
    refs = [(r[0], r[5]) for r in rows if r[1] == "reference"]
    arrows = "".join("set arrow from %g, graph 0 to %g, graph 1 nohead dt 3 lc rgb 'gray40'\n"
                     "set label '%s reference' at %g, graph 0.97 right rotate by 90 font ',8'\n"
                     % (t, t, lab.split(" ")[0], t) for lab, t in refs)
    png = os.path.join(out_dir, "pov_error_time.png")
    script = ("set terminal pngcairo size 900,600 font ',9'\nset output '%s.tmp'\n"
              "set termoption noenhanced\nset logscale xy\nset xrange [0.3:300]\nset grid\n"
              "set xlabel 'POV-Ray wall time, s (start-up included)'\n"
              "set ylabel 'matte-sphere error vs reference, %% (rel. RMS luminance)'\n"
              "set title 'bench_scene.pov %dx%d: error against time (labels: number of lights)'\n"
              "set key outside right font ',8'\nset arrow from graph 0, first 2 to graph 1, first 2 "
              "nohead dt 2 lc rgb 'red'\n%splot %s\n"
              % (png, IMAGE[0], IMAGE[1], arrows, ", ".join(plots)))
    subprocess.run(["gnuplot"], input=script, text=True, check=True)
    os.replace(png + ".tmp", png)
    # renders: reference, fit 4 + SH, + SH radiosity, + SH ground (hard), median 256 (soft)
    strip = []
    for label in [m[0] for m in MAPS]:
        keys = [(label, "reference"), (label, "fit", 4, "sh", "hard"),
                (label, "fit", 4, "sh-radiosity", "hard"), (label, "fit", 4, "sh-ground", "hard"),
                (label, "median", 256, "none", "soft")]
        ref = images.get(keys[0])
        if ref is None:
            continue
        scale = 0.8 / np.percentile(lum(ref), 99)   # the same exposure for a map's renders
        for k in keys:
            if k in images:
                fn = os.path.join(d, "r%d.pfm" % len(strip))
                E.save_image(fn, (images[k] * scale).astype(np.float32))
                strip.append(fn)
    if strip:
        tiles = "%dx%d" % (len(keys), (len(strip) + len(keys) - 1) // len(keys))
        out = os.path.join(out_dir, "pov_renders.png")
        subprocess.run(["oiiotool", *strip, "--mosaic:pad=2", tiles, "--clamp:min=0:max=1",
                        "--colorconvert", "linear", "sRGB", "-d", "uint8", "-o", out + ".tmp.png"],
                       check=True)
        os.replace(out + ".tmp.png", out)


def main():
    quick = "--quick" in sys.argv
    out_dir = sys.argv[sys.argv.index("--plot") + 1] if "--plot" in sys.argv else None
    only_map = sys.argv[sys.argv.index("--map") + 1] if "--map" in sys.argv else None
    ambients = (sys.argv[sys.argv.index("--ambient") + 1].split(",")
                if "--ambient" in sys.argv else None)
    if ambients and not set(ambients) <= set(AMBIENTS):
        sys.exit("--ambient: one of %s" % ", ".join(AMBIENTS))
    os.makedirs(TMP, exist_ok=True)
    P.TMP = TMP
    P.ENVLIGHT = os.path.abspath(P.ENVLIGHT)  # envlight runs inside the work folders
    data = os.path.join(P.DATA, "latlong_hdri")
    rows, starts, refs, images = [], {}, {}, {}
    for label, name in MAPS[:1] if quick and not only_map else MAPS:
        if only_map and not name.startswith(only_map):
            continue
        path = os.path.join(data, name)
        if not os.path.exists(path):
            print("SKIP: %s absent" % path)
            continue
        starts[label], refs[label] = run_map(label, path, quick, rows, images, ambients)
    if not rows:
        return
    table(rows, starts)
    goal(rows, refs)
    if out_dir:
        plot(rows, out_dir, images)


if __name__ == "__main__":
    main()
