#!/usr/bin/python3
"""Negative pixels on lossy and resized EXR files (docs/dwa_bench.md; how the loader treats them:
docs/methods.md, "Negative pixels"). Makes the files (sunny 512 x 256 maps written as DWAA and
DWAB by OpenEXR's C++ library at the default level 45 and a high 300, before and after a
resize by oiiotool, whose Lanczos-type filter rings; a point sun on black; an angular probe, a
cube cross and a 2048-wide upsampling resized alike) and takes Blender's world HDRIs as
shipped. Per file: the pixels negative as read, the power (luminance, sum of L dw) of the file
signed, with the negative values set to 0, and as loaded (filled from the light around them),
and the power of every product against the signed sum: lights (fit 4 and sun: lights +
residual), SH (2 sqrt(pi) L00), the irradiance map (its integral / pi), a specular level, the
glTF (lights + the IBL's SH) and the POV-Ray include (sh recipe: lights + ambient; dome: the
lights). For the resized park, the diffuse error (docs/design.md) of the zeroed and of the
filled map against the map before the resize. With --renders: Cycles (Blender 3.4 `blender`
and Blender 4.3) and POV-Ray 3.7 light a white plane facing the sun with that file as the
world, against the irradiance of the signed, zeroed and filled maps.
Prints markdown; with --docs DIR writes DIR/dwa_bench.md after a header (the command, date,
load average, machine).
Usage: /usr/bin/python3 scripts/dwa_bench.py [--build DIR] [--data DIR] [--docs DIR] [--renders]"""
import argparse
import datetime
import glob
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ap = argparse.ArgumentParser(description=__doc__,
                             formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--build", default=os.path.join(ROOT, "build"), metavar="DIR",
                help="the build folder: envlight, libenvlight.so, tests/dwa_write (default build)")
ap.add_argument("--data", default=os.path.join(ROOT, "..", "shared", "data"), metavar="DIR",
                help="../shared/data (rooitou_park_1k, grace_probe); absent maps are skipped")
ap.add_argument("--docs", metavar="DIR", help="also write DIR/dwa_bench.md")
ap.add_argument("--renders", action="store_true",
                help="also render with Cycles (Blender 3.4 and 4.3) and POV-Ray")
ap.add_argument("--blender4", default="/var/cache/envlight/trixie-root/run-blender",
                help="Blender 4.3 (scripts/blender4.sh's run-blender)")
args = ap.parse_args()

sys.path.insert(0, os.path.join(ROOT, "py_shim"))
os.environ.setdefault("ENVLIGHT_LIBRARY", os.path.join(args.build, "libenvlight.so"))
import envlight as E  # noqa: E402
import numpy as np  # noqa: E402

ENVLIGHT = os.path.join(args.build, "envlight")
DWA_WRITE = os.path.join(args.build, "tests", "dwa_write")
BLENDER_WORLDS = "/usr/share/blender/datafiles/studiolights/world"
PI = math.pi
tmp = tempfile.mkdtemp(prefix="dwa_bench.")


def lum(v):
    return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]


def sh(*cmd, **kw):
    return subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True, **kw).stdout


def cli_json(*cmd):
    out = sh(ENVLIGHT, *cmd, "--quiet")
    return json.loads(out)


def path(name):
    return os.path.join(tmp, name)


# ---- the files -------------------------------------------------------------------------------

def boosted(src, width, out, peak=3e4):
    """src at `width` (area-resampled), its sun (pixels above 50 x the mean luminance) scaled so
    that its peak luminance is `peak`; written as float EXR."""
    with E.load(src, width=width) as env:
        px = np.array(env.pixels(), dtype=np.float32).reshape(env.height, env.width, 3)
    y = 0.2126 * px[..., 0] + 0.7152 * px[..., 1] + 0.0722 * px[..., 2]
    sun = y > 50 * y.mean()
    px[sun] *= peak / y.max()
    E.save_image(out, px)
    return out


def dwa(src, comp, level, name):
    sh(DWA_WRITE, path(name), comp, str(level), src)
    return path(name)


cases = []  # (label, file, source float file or None, layout)
park = os.path.join(args.data, "latlong_hdri", "rooitou_park_1k.hdr")
grace = os.path.join(args.data, "debevec_probes", "grace_probe.hdr")
sh(ENVLIGHT, "convert", "-", path("sky512.exr"), "--sky-width", "512", "--quiet")
sources = [("built-in sky 512", path("sky512.exr"))]
if os.path.exists(park):
    boosted(park, 512, path("park512.exr"))
    boosted(park, 1024, path("park1k.exr"))
    sh("oiiotool", path("park1k.exr"), "--resize", "512x256", "-d", "float", "-o",
       path("park512_resized.exr"))
    sources += [("rooitou_park, sun 3e4, 512 (area)", path("park512.exr")),
                ("rooitou_park, sun 3e4, resized to 512 by oiiotool", path("park512_resized.exr"))]
else:
    print("SKIP: %s absent" % park, file=sys.stderr)
for label, src in sources:
    tag = os.path.splitext(os.path.basename(src))[0]
    for level in (45, 300):
        for comp in ("dwaa", "dwab"):
            cases.append(("%s, %s %d" % (label, comp.upper(), level),
                          dwa(src, comp, level, "%s_%s%d.exr" % (tag, comp, level)), src))
sh(DWA_WRITE, path("point.exr"), "dwab", "10000", "--sun", "512", "256", "0", "300", "100",
   "10000")
cases.append(("point sun 1e4 on black, 512, DWAB 10000", path("point.exr"), None))
if os.path.exists(park):
    sh("oiiotool", path("park1k.exr"), "--resize:filter=lanczos3", "2048x1024", "-d", "float",
       "-o", path("park2k.exr"))
    cases.append(("rooitou_park, sun 3e4, upsampled to 2048 by oiiotool (Lanczos-3), DWAB 45",
                  dwa(path("park2k.exr"), "dwab", 45, "park2k_dwab45.exr"), path("park2k.exr")))
    sh(ENVLIGHT, "convert", path("park1k.exr"), path("park_cross.exr"), "--layout-out", "cross",
       "--size", "256", "--quiet")
    sh("oiiotool", path("park_cross.exr"), "--resize", "384x512", "-d", "float", "-o",
       path("park_cross_resized.exr"))
    cases.append(("rooitou_park, sun 3e4, cross 256 resized to 128 faces, DWAB 45",
                  dwa(path("park_cross_resized.exr"), "dwab", 45, "park_cross_dwab45.exr"),
                  path("park_cross_resized.exr")))
if os.path.exists(grace):
    sh(ENVLIGHT, "convert", grace, path("grace.exr"), "--layout-out", "angular", "--size",
       "1000", "--quiet")
    sh("oiiotool", path("grace.exr"), "--resize", "500x500", "-d", "float", "-o",
       path("grace_resized.exr"))
    cases.append(("grace_probe (angular) resized to 500, DWAB 45",
                  dwa(path("grace_resized.exr"), "dwab", 45, "grace_dwab45.exr"),
                  path("grace_resized.exr")))
else:
    print("SKIP: %s absent" % grace, file=sys.stderr)
for f in sorted(glob.glob(os.path.join(BLENDER_WORLDS, "*.exr"))):
    cases.append(("Blender %s (DWAB 300, as shipped)" % os.path.basename(f), f, None))
cases = [(label, f, src, None) for label, f, src in cases]


# ---- per file: powers ------------------------------------------------------------------------

def products(f):
    """Luminance power of each product of f, as a dict name -> power."""
    out = {}
    d = cli_json("lights", f, "-n", "4", "--json", "--no-error")
    out["lights fit"] = lum([a + b for a, b in zip(d["lights_power"], d["residual_power"])])
    d = cli_json("lights", f, "--method", "sun", "--json", "--no-error")
    out["lights sun"] = lum([a + b for a, b in zip(d["lights_power"], d["residual_power"])])
    d = cli_json("sh", f, "--json", "--no-error")
    out["SH"] = lum([c * 2 * math.sqrt(PI) for c in d["radiance"][0]])
    maps = path("maps")
    shutil.rmtree(maps, ignore_errors=True)
    sh(ENVLIGHT, "prefilter", f, "-o", maps, "--irradiance", "--specular", "--levels", "3",
       "--no-error", "--quiet")
    out["irradiance map"] = lum(cli_json("info", os.path.join(maps, "irradiance.exr"),
                                         "--json")["power"]) / PI
    out["specular r 0.5"] = lum(cli_json("info", os.path.join(maps, "specular_01.exr"),
                                         "--json")["power"])
    g = path("env.gltf")
    sh(ENVLIGHT, "gltf", f, "-o", g, "--no-error", "--quiet")
    gj = json.load(open(g))
    ext = gj.get("extensions", {})
    lights = ext.get("KHR_lights_punctual", {}).get("lights", [])
    ibl = ext["EXT_lights_image_based"]["lights"][0]
    out["glTF"] = lum([sum(l["color"][c] * l["intensity"] for l in lights) +
                       4 * ibl["intensity"] * ibl["irradianceCoefficients"][0][c] * 0.28209479177387814
                       for c in range(3)])
    for recipe in ("sh", "dome"):
        inc = path("env.inc")
        sh(ENVLIGHT, "pov", f, "-o", inc, "--recipe", recipe, "--quiet")
        text = open(inc).read()

        def block(name):
            m = re.search(r"#declare %s = array\[\d+\] \{[^\n]*\n(.*?)\};" % name, text, re.S)
            return [[float(v) for v in t]
                    for t in re.findall(r"<([^,>]+), ([^,>]+), ([^,>]+)>", m.group(1))] if m else []
        rgb = [sum(l[c] for l in block("EnvLight_Irradiance")) for c in range(3)]
        amb = block("EnvLight_Ambient_SH")
        if amb:
            rgb = [rgb[c] + amb[0][c] * 2 / math.sqrt(PI) for c in range(3)]
        out["POV-Ray %s" % recipe] = lum(rgb)
    return out


def pct(a, b):
    return 100.0 * (a / b - 1.0) if b else float("nan")


rows, details = [], []
t_start, load0 = time.time(), os.getloadavg()
date = datetime.datetime.now().isoformat(timespec="seconds")
for label, f, src, _ in cases:
    info = cli_json("info", f, "--json")
    r = info["repair"]
    signed = lum(r["signed_power"])
    zeroed = signed + lum(r["filled_energy"]) + lum(r["added_energy"])
    after = lum(info["power"])
    source = lum(cli_json("info", src, "--json")["power"]) if src else None
    prods = products(f)
    worst = max(prods.items(), key=lambda kv: abs(pct(kv[1], signed)))
    rows.append("| %s | %d (%.4g) | %s | %+.3f | %+.2g | %d | %d (%+.2g) | %+.3f (%s) |" % (
        label, info["negative_pixels"], r["negative_min"],
        "%+.3f" % pct(signed, source) if source else "-", pct(zeroed, signed), pct(after, signed),
        r["fill_window"], r["unfilled_values"], 100 * lum(r["added_energy"]) / signed,
        pct(worst[1], signed), worst[0]))
    details.append((label, signed, prods))
    print(rows[-1], file=sys.stderr)

# the resized park: diffuse error of zeroed and filled maps against the map before the resize
quality = []
if os.path.exists(park):
    with E.load(path("park1k.exr"), width=512) as env:  # area-resampled: exact
        truth = env.reference_irradiance()
    for tag in ("park512_resized", "park512_resized_dwab45"):
        f = path(tag + ".exr")
        sh("oiiotool", f, "--clamp:min=0", "-d", "float", "-o", path("zeroed.exr"))
        with E.load(path("zeroed.exr")) as z, E.load(f) as m:
            quality.append("| %s | %.3f | %.3f |" % (
                tag, 100 * E.relative_rms_luminance(z.reference_irradiance(), truth),
                100 * E.relative_rms_luminance(m.reference_irradiance(), truth)))
    # the loader's time on the 2048-wide file against the same file with no negative value
    sh("oiiotool", path("park2k_dwab45.exr"), "--clamp:min=0", "--compression", "dwab:45",
       "-d", "half", "-o", path("park2k_clamped.exr"))

    def best(f, runs=5):
        ts = []
        for _ in range(runs):
            t = time.perf_counter()
            sh(ENVLIGHT, "info", f, "--quiet")
            ts.append(time.perf_counter() - t)
        return min(ts)
    t_fill, t_plain = best(path("park2k_dwab45.exr")), best(path("park2k_clamped.exr"))
    timing = ("`envlight info` on the 2048 x 1024 upsampled park (DWAB 45, its negative values "
              "filled) against the same file with them clamped by oiiotool: %.3f s / %.3f s = "
              "%.2fx (fastest of 5, whole process, load %.1f)" % (
                  t_fill, t_plain, t_fill / t_plain, os.getloadavg()[0]))
else:
    timing = ""


# ---- renders: Cycles and POV-Ray on the resized park's DWAB 45 ---------------------------------



def blender_run(cmd, exr, n):
    """Cycles' irradiance on a white plane facing n, the file as the world (scripts/
    dwa_bench_cycles.py, run by the Blender `cmd`)."""
    script = os.path.join(ROOT, "scripts", "dwa_bench_cycles.py")
    out = path("cycles_%d.exr" % len(glob.glob(path("cycles_*.exr"))))
    res = subprocess.run(cmd + ["-b", "--factory-startup", "--python", script, "--", exr, out,
                                *map(str, n)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True)
    for line in res.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError("Blender failed:\n" + res.stdout[-3000:])


POV_SCENE = r'''
#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0
  radiosity { count 1600 error_bound 0.05 recursion_limit 1 nearest_count 20 pretrace_start 0.08
              pretrace_end 0.005 low_error_factor 0.5 always_sample off brightness 1 } }
// the canonical lat-long as a sky: map_type 1 mirrored (docs/design.md, "Canonical frame")
sky_sphere { pigment { image_map { exr "%(exr)s" map_type 1 } } scale <-1, 1, 1> }
#declare N = <%(px)s, %(py)s, %(pz)s>;  // POV-Ray <x, z, y> of the canonical normal
plane { N, 0 pigment { rgb 1 } finish { ambient 0 emission 0 diffuse 1 specular 0 } }
camera { orthographic location N * 0.01 look_at <0, 0, 0> right 0.1 * x up 0.1 * y }
'''


def pov_run(exr, n, what):
    scene = path("plane_%s.pov" % what)
    open(scene, "w").write(POV_SCENE % dict(exr=exr, px=n[0], py=n[2], pz=n[1]))
    out = path("plane_%s.exr" % what)
    subprocess.run(["povray", scene, "+W16", "+H16", "-D", "-GA", "+FE", "+O" + out,
                    "+L" + tmp], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, cwd=tmp)
    sh(DWA_WRITE, path("plane.pfm"), "pfm", "0", out)
    return list(read_pfm(path("plane.pfm")).reshape(-1, 3).mean(0) * PI)


def irradiance_midpoint(px, n):
    """E(n) = sum of L max(0, n.d) dw over a canonical lat-long (H, W, 3) array, each pixel at its
    centre (docs/design.md's d and dw)."""
    h, w = px.shape[:2]
    r = np.arange(h)
    dw = 2 * PI / w * (np.sin(PI * (0.5 - r / h)) - np.sin(PI * (0.5 - (r + 1) / h)))
    th = PI * (0.5 - (r + 0.5) / h)
    ph = PI * (1 - 2 * (np.arange(w) + 0.5) / w)
    d = np.stack([np.cos(th)[:, None] * np.cos(ph)[None, :],
                  np.cos(th)[:, None] * np.sin(ph)[None, :], np.repeat(np.sin(th)[:, None], w, 1)],
                 -1)
    weight = np.maximum(0.0, d @ np.asarray(n)) * dw[:, None]
    return list((px * weight[..., None]).sum((0, 1)))


def read_pfm(f):
    with open(f, "rb") as fh:
        assert fh.readline().strip() == b"PF"
        w, h = map(int, fh.readline().split())
        fh.readline()
        data = np.fromfile(fh, dtype="<f4").reshape(h, w, 3)
    return data[::-1].astype(np.float64)  # top row first


POV_SKY = r'''
#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0 }
sky_sphere { pigment { image_map { exr "%(exr)s" map_type 1 } } scale <-1, 1, 1> }
camera { location <0, 0, 0> look_at <%(px)s, %(py)s, %(pz)s> angle 12 right x up y }
'''


def pov_sky_lowest(exr, n):
    """The lowest value of a 64 x 64 EXR render of the sky around n: what POV-Ray reads."""
    scene, out = path("sky_view.pov"), path("sky_view.exr")
    open(scene, "w").write(POV_SKY % dict(exr=exr, px=n[0], py=n[2], pz=n[1]))
    subprocess.run(["povray", scene, "+W64", "+H64", "-D", "+FE", "+O" + out], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp)
    sh(DWA_WRITE, path("sky_view.pfm"), "pfm", "0", out)
    return float(read_pfm(path("sky_view.pfm")).min())


def band_map():
    """128 x 64: 1 everywhere but a band of -0.5 (elevation 20..60 degrees, azimuth within 60 of
    +X): broad negative light that radiosity and path tracing can integrate (no sun)."""
    w, h = 128, 64
    th = 90 - (np.arange(h) + 0.5) * 180 / h
    ph = 180 * (1 - 2 * (np.arange(w) + 0.5) / w)
    px = np.ones((h, w, 3), np.float32)
    px[((th > 20) & (th < 60))[:, None] & (np.abs(ph) < 60)[None, :]] = -0.5
    E.save_image(path("band.exr"), px)
    return path("band.exr"), px.astype(np.float64)


renders = []
if args.renders and os.path.exists(park):
    f = path("park512_resized_dwab45.exr")
    sh(DWA_WRITE, path("raw.pfm"), "pfm", "0", f)
    raw = read_pfm(path("raw.pfm"))
    with E.load(f) as env:
        sun_n = np.array(env.info()["brightest_direction"])
        filled = np.array(env.pixels(), dtype=np.float64).reshape(env.height, env.width, 3)
    band, band_px = band_map()
    with E.load(band) as env:
        band_filled = np.array(env.pixels(), dtype=np.float64).reshape(env.height, env.width, 3)
    band_n = np.array([0.6, 0.0, 0.8])
    filled_file = path("park_filled.exr")  # the park as envlight loads it
    sh(ENVLIGHT, "convert", f, filled_file, "--quiet")
    maps = {"park": (f, sun_n, raw, filled), "band": (band, band_n, band_px, band_filled)}
    expect = {k: [lum(irradiance_midpoint(p, n)) for p in (signed, np.maximum(signed, 0.0), fill)]
              for k, (_, n, signed, fill) in maps.items()}

    def row(name, key, e):
        s_, z_, f_ = expect[key]
        return "| %s | %.4g | %+.2f | %+.2f | %s |" % (
            name, e, pct(e, s_), pct(e, z_), "%+.2f" % pct(e, f_) if key == "park" else "-")
    for name, cmd in (("Cycles, Blender 3.4", ["blender"]),
                      ("Cycles, Blender 4.3", [args.blender4])):
        if not shutil.which(cmd[0]) and not os.path.exists(cmd[0]):
            renders.append("| %s | (absent) | | | |" % name)
            continue
        runs = [(key, exr, n) for key, (exr, n, _, _) in maps.items()]
        runs.insert(1, ("park", filled_file, sun_n))
        for key, exr, n in runs:
            what = key if exr != filled_file else "park as envlight loads it (filled)"
            try:
                r = blender_run(cmd, exr, n)
                renders.append(row("%s (%s): %s" % (name, r["blender"].split()[0], what), key,
                                   lum(r["cycles"])))
            except RuntimeError as e:
                print(e, file=sys.stderr)
                renders.append("| %s: %s | (failed) | | | |" % (name, key))
    renders.append(row("POV-Ray 3.7 radiosity: band", "band", lum(pov_run(band, band_n, "band"))))
    lowest = pov_sky_lowest(f, sun_n)
    render_head = (
        "A white diffuse plane facing n, lit by the file as the world (Cycles: the Environment "
        "Texture, no bounce, 1024 samples; POV-Ray: a sky_sphere image_map under radiosity), "
        "read from a 16 x 16 render as pi x its mean radiance (luminance), against the "
        "irradiance E(n) of the map (pixel centres) signed, with its negative values set to 0 "
        "(zeroed) and as envlight fills them. park: the rooitou_park file resized by oiiotool, "
        "DWAB 45, n its sun (%.3f, %.3f, %.3f): E = %.4g signed, %.4g zeroed, %.4g filled. "
        "band: 1 everywhere but a band of -0.5 (elevation 20-60 degrees, azimuth within 60 of "
        "+X), no sun, which radiosity can integrate, n = (0.6, 0, 0.8): E = %.4g signed, %.4g "
        "zeroed (%.4g filled: a broad negative region is not ringing; the filling spreads it "
        "over 72-pixel windows, most of this 128-wide map). POV-Ray's radiosity cannot find a 0.7-degree sun (park); its "
        "render of the park's sky around the sun (EXR output) shows the file's values as they "
        "are, down to %.5g (the file: %.5g)." % (
            *sun_n, *expect["park"], *expect["band"], lowest, raw.min()))

# ---- the report -----------------------------------------------------------------------------
out = ["Power: the luminance of the sum of L dw, in the file's layout (signed, zeroed) or of the "
       "canonical map (loaded, products); the codec column compares the signed sums of the DWA "
       "file and its float source (what the codec itself lost); a layout other than lat-long "
       "adds its conversion's own error to `loaded` (the cross: about +1.4 %, zeroed or filled).",
       "",
       "| file | negative pixels (lowest) | codec: signed vs the float source, % | zeroed vs "
       "signed, % | loaded vs signed, % | fill window, px | unfilled values (added, %) | "
       "products: worst vs signed, % |",
       "|---|---|---|---|---|---|---|---|"] + rows
out += ["", "Every product against the signed sum (luminance power), %:", "",
        "| file | " + " | ".join(details[0][2].keys()) + " |",
        "|---|" + "---|" * len(details[0][2])]
for label, signed, prods in details:
    out.append("| %s | " % label + " | ".join("%+.3f" % pct(v, signed) for v in prods.values())
               + " |")
if quality:
    out += ["", "Diffuse error (docs/design.md) of the resized park (float, and DWAB 45), its "
            "negative values set to 0 or filled, against the park before the resize (the 1024 "
            "map area-resampled to 512: exact), %:", "", "| file | zeroed | filled |",
            "|---|---|---|"]
    out += quality
if timing:
    out += ["", timing]
if renders:
    out += ["", render_head, "", "| renderer | E | vs signed, % | vs zeroed, % | vs filled, % |",
            "|---|---|---|---|---|"] + renders
text = "\n".join(out)
print(text)
if args.docs:
    load1 = os.getloadavg()
    head = ["# Negative pixels: lossy and resized EXR files", "",
            "Written by `/usr/bin/python3 scripts/dwa_bench.py %s` on %s; load average %.2f %.2f "
            "%.2f before, %.2f %.2f %.2f after; %d cores, %s; %.0f s. How the loader treats "
            "negative pixels and what these figures show: [methods.md](methods.md), \"Negative "
            "pixels\"." % (" ".join(sys.argv[1:]), date, *load0, *load1, os.cpu_count(),
                           os.uname().machine, time.time() - t_start), ""]
    with open(os.path.join(args.docs, "dwa_bench.md.tmp"), "w") as fh:
        fh.write("\n".join(head) + "\n" + text + "\n")
    os.replace(os.path.join(args.docs, "dwa_bench.md.tmp"), os.path.join(args.docs, "dwa_bench.md"))
shutil.rmtree(tmp, ignore_errors=True)
