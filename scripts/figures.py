#!/usr/bin/python3
"""The headline figures README.md states, measured: written into README.md and docs/figures.md
by this script, and checked by it in the test suite (ctest's py_figures), so that a figure the
README states is never a hand-copied number that has drifted.

  scripts/figures.py --write [--docs DIR]   measure, then rewrite README.md's generated blocks
                                            (between `<!-- figures:NAME -->` and
                                            `<!-- /figures:NAME -->`) and DIR/figures.md, .json
  scripts/figures.py --check                measure, and fail (exit 1, with a diff) when a
                                            generated block of README.md differs from what the
                                            measurement gives (times excepted: they are the
                                            machine's, not the build's)
  [--envlight build/envlight] [--data ../shared/data] [--tmp DIR] [--readme README.md]

Blocks:
  methods            "Which method for which job": each method's error range over every map
                     (the built-in sky and each ../shared/data/latlong_hdri/*.hdr present)
  pov                the POV-Ray include's in-scene figures, from docs/scene_bench_pov.json
  pov-path-traced    the include and the bench's POV-Ray reference against Cycles, from
                     docs/pov_path_traced.json (scripts/pov_path_traced.py)
  gltf               the glTF file's diffuse error over the same maps, with its suns as
                     lights and with --lights none
  transcript-NAME    a command's output as the README shows it: the block's first line
                     `<!-- figures:transcript-NAME ARGS -->` names the command (`envlight ARGS`,
                     run in a folder where `my.hdr` is potsdamer_platz_1k.hdr) and, after ` | `,
                     which output lines to keep (`1-3,...,-1`: lines 1 to 3, a line "...", the
                     last line)
Host figures: src/export/pov_figures.h (the in-scene error the POV-Ray include's header quotes
per recipe) and plugin/envlight_addon/figures.py (the Blender panel's), made from the scene
benchmarks' JSON (docs/scene_bench_pov.json, docs/scene_bench_blender.json and, for legacy
EEVEE, docs/blender34/scene_bench_blender.json): --write writes them, --check fails when one is
not what its JSON gives.
Errors are deterministic for a build (identical at any thread count), so --check compares them
exactly as printed; a map absent from the data folder is skipped with a `SKIP:` line, and then
the methods block is checked only for ranges that hold every present map's figure.
"""
import argparse
import datetime
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from scene_bench import write_atomic  # noqa: E402  the benchmarks' one atomic writer

TRANSCRIPT_MAP = "potsdamer_platz_1k.hdr"

# The methods table: (job, command shown, what to measure, how to read the figure)
METHODS = [
    ("a few lights and an ambient (an engine's sun + SH probe; POV-Ray's `sh`; "
     "Blender's SH world)",
     "`lights --method fit -n 4`", "fit4"),
    ("lights only, the fewest for an error", "`lights --method variance -n 64`", "variance64"),
    ("lights of equal energy (Debevec's median cut)", "`lights --method median -n 64`",
     "median64"),
    ("ambient only (diffuse probe)", "`sh` (order 2, 9 coefficients)", "sh2"),
    ("an irradiance texture", "`prefilter --irradiance` (64 x 32)", "irradiance"),
    ("glossy reflections, roughness 0.4-1 (the default chain's levels 2-5)",
     "`prefilter --specular`", "specular"),
]


def parse_args(argv):
    p = argparse.ArgumentParser(prog="figures.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", action="store_true", help="measure and rewrite the blocks")
    g.add_argument("--check", action="store_true", help="measure and compare the blocks")
    p.add_argument("--envlight", default=os.path.join(ROOT, "build", "envlight"))
    p.add_argument("--data", default=os.environ.get(
        "ENVL_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data")))
    p.add_argument("--readme", default=os.path.join(ROOT, "README.md"))
    p.add_argument("--docs", default=os.path.join(ROOT, "docs"))
    p.add_argument("--tmp", help="work folder (default: a new temporary one)")
    return p.parse_args(argv)


def run(cmd, cwd=None):
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    if r.returncode != 0:
        raise SystemExit("figures.py: %s failed (exit %d): %s" %
                         (" ".join(cmd), r.returncode, r.stderr.strip()[-2000:]))
    return r.stdout


def maps_of(data):
    """[(name, path)]: the built-in sky, then every lat-long map of the data folder."""
    out = [("built-in sky", "-")]
    folder = os.path.join(data, "latlong_hdri")
    names = sorted(f for f in os.listdir(folder) if f.endswith(".hdr")) \
        if os.path.isdir(folder) else []
    if not names:
        print("SKIP: no maps in %s: only the built-in sky is measured" % folder)
    for f in names:
        out.append((f[:-len(".hdr")], os.path.join(folder, f)))
    return out


def measure_map(envlight, path, tmp):
    """The figures of one map: error fractions and seconds per method."""
    r = {}
    for key, args in (("fit4", ["--method", "fit", "-n", "4"]),
                      ("variance64", ["--method", "variance", "-n", "64"]),
                      ("median64", ["--method", "median", "-n", "64"])):
        j = json.loads(run([envlight, "lights", path, "--json", "--quiet"] + args))
        r[key] = {"error": j["error"]["diffuse"], "seconds": j["seconds"], "count": j["count"]}
    j = json.loads(run([envlight, "sh", path, "--json", "--quiet"]))
    r["sh2"] = {"error": j["error"]["diffuse"], "seconds": j["seconds"]}
    out = os.path.join(tmp, "prefilter")
    shutil.rmtree(out, ignore_errors=True)
    run([envlight, "prefilter", path, "-o", out + "/", "--quiet"])
    with open(os.path.join(out, "prefilter.json")) as f:
        pj = json.load(f)
    irr = pj["irradiance"]
    r["irradiance"] = {"error": irr["diffuse_error"], "seconds": irr["seconds"],
                       "texel_rms": irr["texel_error"]["rms"],
                       "texel_worst": irr["texel_error"]["worst"]}
    levels = [lv for lv in pj["specular"] if lv["roughness"] >= 0.4 - 1e-9]
    r["specular"] = {"error": max(lv["glossy_error"] for lv in levels),
                     "levels": {"%.1f" % lv["roughness"]: lv["glossy_error"] for lv in levels},
                     "texel_rms": max(lv["texel_error"]["rms"] for lv in levels),
                     "texel_worst": max(lv["texel_error"]["worst"] for lv in levels),
                     "seconds": sum(lv["seconds"] for lv in pj["specular"])}
    # glTF: the diffuse error (the punctual lights + the SH irradiance an engine computes) does
    # not depend on the mips' size: measured with 32-pixel faces
    for key, extra in (("gltf", []), ("gltf_none", ["--lights", "none"])):
        glb = os.path.join(tmp, key + ".glb")
        if os.path.exists(glb):
            os.remove(glb)
        j = json.loads(run([envlight, "gltf", path, "-o", glb, "--size", "32", "--json",
                            "--quiet"] + extra))
        r[key] = {"error": j["error"]["diffuse"], "seconds": j["seconds"]}
        os.remove(glb)
    return r


def gltf_block(results):
    """The README's sentence on glTF's diffuse error over the maps."""
    def span(key):
        errs = sorted((v[key]["error"], name) for name, v in results.items())
        return "%s-%s %% (worst: %s)" % (pct(errs[0][0]), pct(errs[-1][0]), errs[-1][1])
    n = len(results)
    return ["On %d maps (the built-in sky and %d of ../shared/data/latlong_hdri), the glTF file's "
            "diffuse error (its punctual lights + its SH irradiance, as an engine adds them) is "
            "%s, against %s when the sun stays in the SH (`--lights none`); `scripts/figures.py` "
            "measures it, `py_figures` holds it." % (n, n - 1, span("gltf"), span("gltf_none"))]


def pct(x):
    """An error fraction as the README prints it: percent, 2 decimals (1 above 10 %)."""
    p = 100.0 * x
    return "%.1f" % p if p >= 10 else "%.2f" % p


def secs(lo, hi):
    def one(s):
        return "%.2g" % s if s < 1 else "%.1f" % s
    return one(lo) if one(lo) == one(hi) else "%s-%s" % (one(lo), one(hi))


def methods_block(results):
    """The README's table: per method the range of the errors over the maps, the map of the
    worst, and the range of the seconds."""
    n = len(results)
    lines = ["Measured on %d maps (the built-in sky and %d of ../shared/data/latlong_hdri) by "
             "`scripts/figures.py --write` ([docs/figures.md](docs/figures.md): per map, and the "
             "load the seconds were measured at); the test `py_figures` measures the errors "
             "again and fails when one changes." % (n, n - 1),
             "",
             "| job | command | error % (worst map) | seconds |",
             "| --- | --- | --- | --- |"]
    for job, cmd, key in METHODS:
        errs = sorted((v[key]["error"], name) for name, v in results.items())
        times = [v[key]["seconds"] for v in results.values()]
        lo, hi = errs[0][0], errs[-1][0]
        texel = ""
        if "texel_rms" in results[errs[0][1]][key]:
            texel = "; per texel RMS <= %s, worst <= %s" % (
                pct(max(v[key]["texel_rms"] for v in results.values())),
                pct(max(v[key]["texel_worst"] for v in results.values())))
        lines.append("| %s | %s | %s-%s (%s)%s | %s |" % (job, cmd, pct(lo), pct(hi),
                                                          errs[-1][1], texel,
                                                          secs(min(times), max(times))))
    return lines


def figures_md(results, load0, load1, seconds, cmd):
    lines = ["# Headline figures, per map", "",
             "Written by `%s` (do not edit by hand)." % cmd, "",
             "- date: %s; %.0f s" % (datetime.datetime.now().isoformat(timespec="seconds"),
                                     seconds),
             "- load average at start / end: %s / %s" % (load0, load1),
             "- machine: %s, %d cores" % (platform.processor() or platform.machine(),
                                          os.cpu_count() or 0),
             "- errors: design.md's diffuse (lights, SH, irradiance map) and glossy (specular "
             "levels, worst of roughness 0.4-1) relative RMS, %; seconds: the command's own "
             "figure (excluding reading and the error measure)", "",
             "| map | " + " | ".join(k for _, _, k in METHODS) + " |",
             "|---|" + "---|" * len(METHODS)]
    for name, v in results.items():
        lines.append("| %s | %s |" % (name, " | ".join(
            "%s / %.3g s" % (pct(v[k]["error"]), v[k]["seconds"]) for _, _, k in METHODS)))
    lines += ["", "Specular levels (glossy error %, roughness 0.4 / 0.6 / 0.8 / 1.0):", ""]
    for name, v in results.items():
        lv = v["specular"]["levels"]
        lines.append("- %s: %s" % (name, " / ".join(pct(lv[k]) for k in sorted(lv))))
    return lines


# ---- the in-scene figures the hosts quote, from the scene benchmarks' JSON ----

POV_JSON = os.path.join("docs", "scene_bench_pov.json")
POV_HEADER = os.path.join("src", "export", "pov_figures.h")
BLENDER_JSON = os.path.join("docs", "scene_bench_blender.json")
# the same bench in Blender 3.4, legacy EEVEE (scripts/scene_bench.py --host blender --docs
# docs/blender34 with ENVL_BLENDER a 3.4 under Xvfb)
BLENDER_LEGACY_JSON = os.path.join("docs", "blender34", "scene_bench_blender.json")
BLENDER_FIGURES = os.path.join("plugin", "envlight_addon", "figures.py")
# pov_recipe.c's recipes and the scene bench's option that measures each as picked
POV_RECIPES = (("DOME", "default"), ("SH", "sh"), ("IMAGE_RADIOSITY", "image-radiosity"),
               ("DOME_AMBIENT", "dome-ambient"))
USER_SCENES = ("still", "interior", "csg")


def median(xs):
    xs = sorted(xs)
    n = len(xs)
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


def pov_figure(bench, option):
    """The header's sentence for the recipe the bench measured as `option`, or None."""
    # a run's option (the recipe as picked: "default"); before options, the picked row
    runs = [r for r in bench["runs"]
            if r.get("option", "default" if r.get("picked") else r["recipe"]) == option]
    ab = [r for r in runs if r["scene"] in ("a", "b")]
    if not ab:
        return None
    maps = sorted({r["map"] for r in ab})
    # an object with no pixel off the sun's edges has no error (null): not counted
    objs = [max(v for k, v in r["errors"].items() if k != "plane" and v is not None)
            for r in ab]
    plane = [r["plane"] if r.get("plane") is not None else r["errors"]["plane"]
             for r in ab if r.get("plane") is not None or "plane" in r["errors"]]

    def mw(xs):
        return "%.1f %% median, %.1f %% worst" % (100 * median(xs), 100 * max(xs))
    parts = ["scenes (a), (b) on %d map%s: objects %s" % (len(maps), "s" * (len(maps) != 1),
                                                         mw(objs))]
    if plane:
        parts.append("plane %s" % mw(plane))
    band = [r["banding"] for r in runs if r["scene"] == "x" and r.get("banding") is not None]
    if band:
        parts.append("banding %.2f %% median, %.2f %% worst" % (100 * median(band),
                                                              100 * max(band)))
    user = [r for r in runs if r["scene"] in USER_SCENES and r["error"] is not None]
    if user:
        n = len({r["map"] for r in user})
        parts.append("a user's still life, room and CSG scene on %d map%s: worst object %s"
                     % (n, "s" * (n != 1), mw([r["error"] for r in user])))
    speed = [r["speedup"] for r in runs if r["scene"] == "a" and r.get("speedup")]
    if speed:
        parts.append("%.0f-%.0fx less POV-Ray CPU than the reference" % (min(speed), max(speed)))
    # rows merged from a later run carry their own date (as the Blender bench's do)
    date = max(r.get("date", bench["date"])[:10] for r in runs)
    return "; ".join(parts) + " (scene bench of %s)" % date


POV_PATH_TRACED_JSON = os.path.join("docs", "pov_path_traced.json")


def pov_path_traced_bounds(pt):
    """(lowest, highest) bias of the picked include against Cycles over every map and object
    of docs/pov_path_traced.json, and the same of the scene bench's POV-Ray reference."""
    picked, ref = [], []
    for m in pt["maps"].values():
        for scene in m.values():
            for o in scene["objects"].values():
                picked.append(o["picked_bias"])
                ref.append(o["reference_bias"])
    return (min(picked), max(picked)), (min(ref), max(ref))


def pov_path_traced_text(pt):
    """The README's sentence on the POV-Ray include against a path tracer."""
    (p0, p1), (r0, r1) = pov_path_traced_bounds(pt)
    worst = max(((o["reference_bias"], name, s) for name, m in pt["maps"].items()
                 for s, scene in m.items() for o in scene["objects"].values()))
    return ("Against Cycles path tracing of the same scenes (a) and (b) "
            "([docs/pov_path_traced.md](docs/pov_path_traced.md), %d maps, %s), the default "
            "include is %+.1f to %+.1f %% off on average over each object and the plane; the "
            "POV-Ray reference the figures above are measured against is itself %+.1f to "
            "%+.1f %% off (%s's scene (%s)), and that is in them." % (
                len(pt["maps"]), pt["date"], 100 * p0, 100 * p1, 100 * r0, 100 * r1,
                worst[1], worst[2]))


def c_string(text, indent):
    """A C string literal of text, broken into pieces of at most 80 columns."""
    words, lines, line = text.split(" "), [], ""
    for w in words:
        if line and len(indent) + len(line) + len(w) + 4 > 98:
            lines.append(line + " ")
            line = w
        else:
            line = w if not line else line + " " + w
    lines.append(line)
    return (" \\\n" + indent).join('"%s"' % x.replace('"', '\\"') for x in lines)


def pov_path_traced_header(pt):
    """The header's sentence on the default include against Cycles (docs/pov_path_traced.json)."""
    (p0, p1), (r0, r1) = pov_path_traced_bounds(pt)
    return ("against Cycles path tracing of scenes (a), (b) on %d maps: %+.1f to %+.1f %% on "
            "average per object and plane; the reference of the figure above is itself %+.1f to "
            "%+.1f %% off, and that is in it (docs/pov_path_traced.md, %s)" % (
                len(pt["maps"]), 100 * p0, 100 * p1, 100 * r0, 100 * r1, pt["date"]))


def pov_header_text(bench, pt):
    out = ["/* The in-scene error each POV-Ray recipe's header quotes (pov_recipe.c): written by",
           " * scripts/figures.py --write from %s (scripts/scene_bench.py --host pov)," % POV_JSON,
           " * checked against it by the test py_figures. Do not edit by hand. */",
           "#ifndef ENVL_POV_FIGURES_H", "#define ENVL_POV_FIGURES_H", ""]
    for name, option in POV_RECIPES:
        fig = pov_figure(bench, option)
        if fig is None:
            out.append("#define POV_FIGURE_%s NULL /* not in the scene bench */" % name)
        else:
            out.append("#define POV_FIGURE_%s \\\n    %s" % (name, c_string(fig, "    ")))
    out.append("/* from %s (scripts/pov_path_traced.py) */" % POV_PATH_TRACED_JSON)
    out.append("#define POV_FIGURE_DOME_PATH_TRACED \\\n    %s" %
               c_string(pov_path_traced_header(pt), "    "))
    out += ["", "#endif"]
    return "\n".join(out) + "\n"


def blender_errors(bench):
    """-> ({recipe: (median, worst)}, dates): per recipe the add-on picked in a Blender scene
    bench, the median and worst over the scenes and maps where it picked it of the converged
    error (floor) against Cycles."""
    by, dates = {}, set()
    for r in bench["runs"]:
        # fitted-eevee: Read Scene with EEVEE Dome 0, what EEVEE picks without the dome
        if r.get("picked_as") and r.get("floor") is not None and \
                r["recipe"] in ("picked", "picked-eevee", "probe-eevee", "fitted-eevee"):
            key = r["picked_as"] + ("-probe" if r["recipe"] == "probe-eevee" and
                                    not r["picked_as"].endswith("-probe") else "")
            by.setdefault(key, []).append(r["floor"])
            # rows merged from a later run carry their own date (scene_bench_merge)
            dates.add(r.get("date", bench["date"])[:10])
    return {k: (median(v), max(v)) for k, v in by.items() if k != "unchanged"}, dates


def blender_figures_text(bench, legacy):
    """plugin/envlight_addon/figures.py: EXPECTED_ERROR from the Blender 4.3 bench (`bench`),
    EXPECTED_ERROR_LEGACY from the legacy EEVEE one (`legacy`, Blender 3.4: its EEVEE rows;
    the panel quotes those in legacy EEVEE)."""
    errors, dates = blender_errors(bench)
    old, old_dates = blender_errors(legacy)
    old = {k: v for k, v in old.items() if k.startswith("eevee")}
    lines = ['"""The in-scene error the panel quotes per recipe: written by scripts/figures.py '
             '--write from',
             "%s (scripts/scene_bench.py --host blender, %s; %s) and" %
             (BLENDER_JSON, ", ".join(sorted(dates)) or bench["date"][:10],
              bench.get("host_version", "Blender ?")),
             "%s (legacy EEVEE, %s, %s), checked against them by the test" %
             (BLENDER_LEGACY_JSON, legacy.get("host_version", "Blender ?"),
              ", ".join(sorted(old_dates)) or legacy["date"][:10]),
             "py_figures. Do not edit by hand: the median and worst, over the scenes and maps "
             "where the add-on",
             "picked the recipe, of the converged error against Cycles path tracing (relative "
             'RMS)."""',
             "", "BENCH_DATE = %r" % (max(dates) if dates else bench["date"][:10]),
             "BENCH_DATE_LEGACY = %r" % (max(old_dates) if old_dates else legacy["date"][:10]),
             ""]
    for name, figs in (("EXPECTED_ERROR", errors), ("EXPECTED_ERROR_LEGACY", old)):
        lines.append("%s = {" % name)
        for key in sorted(figs):
            lines.append("    %r: (%.4f, %.4f)," % (key, figs[key][0], figs[key][1]))
        lines.append("}")
    return "\n".join(lines) + "\n"


def host_files():
    """[(path, text as generated)] of the hosts' figure files whose bench JSON is present."""
    out = []
    with open(os.path.join(ROOT, POV_PATH_TRACED_JSON)) as f:
        pt = json.load(f)
    with open(os.path.join(ROOT, BLENDER_LEGACY_JSON)) as f:
        legacy = json.load(f)
    for js, path, make in ((POV_JSON, POV_HEADER, lambda b: pov_header_text(b, pt)),
                           (BLENDER_JSON, BLENDER_FIGURES,
                            lambda b: blender_figures_text(b, legacy))):
        with open(os.path.join(ROOT, js)) as f:
            out.append((path, make(json.load(f))))
    return out


# ---- README blocks ----

BLOCK = re.compile(r"^<!-- figures:(\S+)(.*?)-->\n(.*?)^<!-- /figures:\1 -->\n", re.S | re.M)


def transcript(envlight, spec, data, tmp):
    """The block for `<!-- figures:transcript-NAME ARGS | KEEP -->`: the output of `envlight
    ARGS` (the lines KEEP names) as a code block (the command stands above it, in the text)."""
    args, _, keep = spec.partition("|")
    work = os.path.join(tmp, "transcript")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(os.path.join(work, "build"))
    os.symlink(os.path.abspath(envlight), os.path.join(work, "build", "envlight"))
    argv = args.split()
    src = os.path.join(data, "latlong_hdri", TRANSCRIPT_MAP)
    if "my.hdr" in argv:
        if not os.path.exists(src):
            return None
        os.symlink(src, os.path.join(work, "my.hdr"))
    r = subprocess.run(["build/envlight"] + argv, capture_output=True, text=True, cwd=work)
    if r.returncode != 0:
        raise SystemExit("figures.py: envlight %s failed: %s" % (args, r.stderr[-2000:]))
    out = r.stdout.rstrip("\n").split("\n")
    kept = []
    for part in keep.split(","):
        part = part.strip()
        if part == "...":
            kept.append("...")
        elif "-" in part[1:]:
            a, b = part.split("-", 1)
            kept += out[int(a) - 1:int(b)]
        elif part:
            i = int(part)
            kept.append(out[i - 1] if i > 0 else out[i])
    return ["```"] + kept + ["```"]


def timeless(text):
    """The text with the machine's times taken out: `1.234 s` -> `# s`, and a table row's
    last cell (the methods table's seconds) -> `#`."""
    text = re.sub(r"\d+(\.\d+)? s\b", "# s", text)
    return re.sub(r"\| [0-9.e-]+ \|$", "| # |", text, flags=re.M)


# A written file's size in a transcript is compared within this fraction: a glb carries its
# run's seconds as text and compressed PNGs in 4-byte aligned chunks, and a fresh CI machine
# wrote the sky's glb 4 bytes smaller (147216 against 147220) with every figure alike (cause
# not found: not the thread count, libm's FMA variants, libpng's update, nor an uninitialised
# byte under Valgrind). A change of structure (a mip level, a face size, a PNG's encoding)
# moves it by kilobytes; a change of a few bytes passes unseen.
SIZE_SLACK = 0.001


def sizes_alike(old, new):
    """`new` with each `(N bytes)` that lies within SIZE_SLACK of the same place's in `old`
    written as `old` has it (a size further off is left, so the texts differ)."""
    sizes = [int(s) for s in re.findall(r"\((\d+) bytes\)", old)]
    it = iter(sizes)

    def same(m):
        b = int(m.group(1))
        a = next(it, None)
        return "(%d bytes)" % (a if a is not None and abs(a - b) <= SIZE_SLACK * a else b)
    return re.sub(r"\((\d+) bytes\)", same, new)


def render(readme, envlight, data, tmp, results, skipped):
    """README.md's text with every generated block made anew (those that cannot be made, as
    they were, their names added to `skipped`)."""
    def block(m):
        name, spec = m.group(1), m.group(2).strip()
        if name == "methods":
            body = methods_block(results)
        elif name == "gltf":
            body = gltf_block(results)
        elif name == "pov":
            with open(os.path.join(ROOT, POV_JSON)) as f:
                body = ["In the scene benchmark ([docs/scene_bench_pov.md](docs/scene_bench_pov.md)"
                        ", [docs/pov_scenes.md](docs/pov_scenes.md)), the default include: %s." %
                        pov_figure(json.load(f), "default")]
        elif name == "pov-path-traced":
            with open(os.path.join(ROOT, POV_PATH_TRACED_JSON)) as f:
                body = [pov_path_traced_text(json.load(f))]
        elif name.startswith("transcript-"):
            body = transcript(envlight, spec, data, tmp)
            if body is None:
                print("SKIP: %s: %s absent" % (name, TRANSCRIPT_MAP))
                skipped.add(name)
                return m.group(0)
        else:
            raise SystemExit("figures.py: unknown block figures:%s" % name)
        head = "<!-- figures:%s%s-->\n" % (name, m.group(2))
        return head + "\n".join(body) + "\n<!-- /figures:%s -->\n" % name
    return BLOCK.sub(block, readme)


def check_ranges(block, results):
    """For a partial data folder: every measured figure within its README range (as printed)."""
    rows = [line for line in block.split("\n") if line.startswith("| ") and "%" not in line
            and "---" not in line and not line.startswith("| job")]
    failed = 0
    for (job, cmd, key), row in zip(METHODS, rows):
        m = re.search(r"\| ([0-9.]+)-([0-9.]+) \(", row)
        lo, hi = float(m.group(1)), float(m.group(2))
        for name, v in results.items():
            if not lo <= float(pct(v[key]["error"])) <= hi:
                print("FAIL: %s on %s: %s %% outside the README's %s-%s" %
                      (key, name, pct(v[key]["error"]), m.group(1), m.group(2)))
                failed += 1
    return failed


def main(argv):
    a = parse_args(argv)
    envlight = os.path.abspath(a.envlight)
    if not os.access(envlight, os.X_OK):
        raise SystemExit("figures.py: %s is not an executable (build first)" % envlight)
    tmp = a.tmp or tempfile.mkdtemp(prefix="envl_figures_")
    os.makedirs(tmp, exist_ok=True)
    load0 = " ".join("%.2f" % x for x in os.getloadavg())
    t0 = datetime.datetime.now()
    hosts = host_files()
    maps = maps_of(a.data)
    results = {}
    for name, path in maps:
        results[name] = measure_map(envlight, path, tmp)
    with open(a.readme) as f:
        readme = f.read()
    if not BLOCK.search(readme):
        raise SystemExit("figures.py: %s has no generated block" % a.readme)
    skipped = set()
    new = render(readme, envlight, a.data, tmp, results, skipped)
    if a.write:
        write_atomic(a.readme, new)
        seconds = (datetime.datetime.now() - t0).total_seconds()
        load1 = " ".join("%.2f" % x for x in os.getloadavg())
        cmd = "scripts/figures.py --write"
        write_atomic(os.path.join(a.docs, "figures.md"),
                     "\n".join(figures_md(results, load0, load1, seconds, cmd)) + "\n")
        write_atomic(os.path.join(a.docs, "figures.json"),
                     json.dumps({"maps": results}, indent=1, sort_keys=True) + "\n")
        for path, text in hosts:
            write_atomic(os.path.join(ROOT, path), text)
        print("figures.py: README.md, %s/figures.md, %s and %s written (%d maps, %.0f s)" %
              (a.docs, POV_HEADER, BLENDER_FIGURES, len(maps), seconds))
        return 0
    # --check: every block as measured now, times aside
    old_blocks = {m.group(1): m.group(0) for m in BLOCK.finditer(readme)}
    new_blocks = {m.group(1): m.group(0) for m in BLOCK.finditer(new)}
    failed = 0
    full = len(maps) == 1 + len(os.listdir(os.path.join(a.data, "latlong_hdri"))) \
        if os.path.isdir(os.path.join(a.data, "latlong_hdri")) else False
    for name, old in old_blocks.items():
        if name in skipped:
            continue
        if name in ("methods", "gltf") and not full:
            print("SKIP: %s: not every map is present: each present map's figure is "
                  "checked to lie within the README's range (a table's)" % name)
            failed += check_ranges(old, results)
            continue
        measured = sizes_alike(old, new_blocks[name])
        if timeless(old) != timeless(measured):
            failed += 1
            print("FAIL: README.md's block %s differs from the measurement:" % name)
            import difflib
            for line in difflib.unified_diff(timeless(old).split("\n"),
                                             timeless(measured).split("\n"),
                                             "README.md", "measured", lineterm=""):
                print("  " + line)
        else:
            print("ok: %s" % name)
    for path, text in hosts:
        with open(os.path.join(ROOT, path)) as f:
            if f.read() != text:
                failed += 1
                print("FAIL: %s is not what its scene bench's JSON gives" % path)
            else:
                print("ok: %s" % path)
    if failed:
        print("figures.py: %d block(s) drifted: if the change is meant, run "
              "scripts/figures.py --write and commit README.md and docs/figures.*" % failed)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
