#!/usr/bin/python3
"""Scene benchmark: envlight's lighting recipes against a reference, in a host's renderer, on
every map (the reports docs/scene_bench_pov.md and docs/scene_bench_blender.md, which --docs
writes; how to read them: docs/pov_scenes.md, docs/blender_scenes.md). The goal it checks for
POV-Ray: on every map, the picked (default) lighting is at least TARGET_SPEEDUP x faster (CPU)
than the reference at a matte-object error under TARGET_ERROR[scene] (2 % on scene (a), 4 % on
scene (b)).

This file: arguments, the map list, the JSON, the report and the figures. The host's own part
(scenes, recipes, reference, measures) is a module beside it: scene_bench_pov.py for --host
pov; a --host blender part sits beside it the same way (HOSTS below).

  scripts/scene_bench.py --host pov [--map FILE ...] [--json OUT] [--docs DIR] [--quick]
      [--recipes R1,R2] [--scenes a,b] [--envlight build/envlight]
      [--library build/libenvlight.so]

Run from the repository top with /usr/bin/python3 (numpy). No --map: the built-in sky ('-')
and every *.hdr under ../shared/data/latlong_hdri. --quick: the built-in sky only, a small
image, few recipes and a cheaper reference (the script's end-to-end check,
tests/py_scene_bench.py). --docs DIR: DIR/scene_bench_<host>.md, .json, <host>_scene_grid.png
and <host>_scene_error_time.png.
"""
import argparse
import datetime
import importlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)

HOSTS = {"pov": "scene_bench_pov", "blender": "scene_bench_blender"}
TARGET_SPEEDUP = 10.0
TARGET_ERROR = {"a": 0.02, "b": 0.04}
DATA = os.environ.get("ENVL_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data"))


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="scene_bench.py",
        description="Accuracy against time of envlight's lighting recipes in a renderer's "
                    "scenes, against a validated reference, on every map.")
    p.add_argument("--host", required=True, choices=sorted(HOSTS), help="the renderer")
    p.add_argument("--map", action="append", default=[], metavar="FILE",
                   help="a map ('-': the built-in sky); repeatable. Default: the built-in sky "
                        "and every *.hdr under ../shared/data/latlong_hdri")
    p.add_argument("--json", metavar="OUT", help="write the results as JSON (atomically)")
    p.add_argument("--docs", metavar="DIR", help="write DIR/scene_bench_<host>.md, .json and "
                                                 "the figures")
    p.add_argument("--quick", action="store_true",
                   help="the built-in sky only, a small image, few recipes, a cheaper "
                        "reference: an end-to-end check")
    p.add_argument("--recipes", metavar="R1,R2", help="only these recipes")
    p.add_argument("--scenes", metavar="a,b", default=None,
                   help="scenes (default: all of the host's: a,b,still,interior,csg,x for "
                        "pov, a,b,c for blender; --quick: the host's quick set)")
    p.add_argument("--floor", metavar="MAP1,MAP2", default="",
                   help="pov: the maps (by name: sky, rooitou_park_1k...) whose reference is "
                        "rendered again finer, to measure its own noise")
    p.add_argument("--envlight", default=os.path.join("build", "envlight"),
                   help="the envlight CLI (default build/envlight)")
    p.add_argument("--library", default=os.path.join("build", "libenvlight.so"),
                   help="libenvlight (default build/libenvlight.so)")
    p.add_argument("--report-from", metavar="JSON",
                   help="no runs: rescore a run's JSON (the host's own scoring, when it has "
                        "one) and write --docs / --json from it (the picture grid needs the "
                        "run's images: kept from that run)")
    p.add_argument("--resume", action="store_true",
                   help="with --json: keep the maps a partial --json of the same run already "
                        "holds (a run stopped part way) and run the others")
    p.add_argument("--references-from", metavar="JSON",
                   help="pov: take each scene's reference from JSON (a run's or the merged "
                        "docs/scene_bench_pov.json: its CPU seconds) and its image from the "
                        "--tmp folder a run of that map left (images.npz), rendering only the "
                        "options; a scene without both is rendered as usual. Options "
                        "measured on every map at the include's cost")
    p.add_argument("--tmp", default=None,
                   help="work folder (default $ENVL_TEST_TMP or /tmp/envl_scene_bench)")
    return p.parse_args(argv)


def write_atomic(path, text, mode="w"):
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".%s." % os.path.basename(path))
    try:
        with os.fdopen(fd, mode) as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def finite(x):
    """JSON has no inf / nan: None instead."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [finite(v) for v in x]
    return x


# ---- the report ----

def pct(x, digits=2):
    return "-" if x is None else "%.*f" % (digits, 100 * x)


def target_check(result, host=None):
    """Per map: the picked rows against the goal. -> {map: (met, text)}. A host module with
    its own goal (target_row: one picked row -> (met, text)) judges its rows."""
    out = {}
    if host is not None and hasattr(host, "target_row"):
        for name in result["maps"]:
            rows = [r for r in result["runs"] if r["map"] == name and r["picked"]]
            if not rows:
                out[name] = (None, "no picked row")
                continue
            checks = [host.target_row(r) for r in rows]
            out[name] = (all(c[0] for c in checks), "; ".join(c[1] for c in checks))
        return out
    for name in result["maps"]:
        rows = {r["scene"]: r for r in result["runs"] if r["map"] == name and r["picked"]}
        if not rows:
            out[name] = (None, "no picked row (the `default` recipe was not run)")
            continue
        parts, met = [], True
        for scene in sorted(rows):
            r = rows[scene]
            lim = TARGET_ERROR[scene]
            ok_s, ok_e = r["speedup"] >= TARGET_SPEEDUP, r["error"] < lim
            met = met and ok_s and ok_e
            parts.append("(%s) %s: %.1fx %s, %.2f %% %s" % (
                scene, r["recipe"], r["speedup"],
                "ok" if ok_s else "short by %.1fx" % (TARGET_SPEEDUP / r["speedup"]),
                100 * r["error"],
                "ok" if ok_e else "over by %.2f points" % (100 * (r["error"] - lim))))
        missing = [s for s in result["scenes"] if s not in rows]
        if missing:
            met = False
            parts.append("scene %s not run" % ",".join(missing))
        out[name] = (met, "; ".join(parts))
    return out


def header(result, host, image_note=""):
    """The report's first lines: the command, date, load, versions, image size."""
    return ["# Scene benchmark, host %s" % host, "",
            "Written by `scripts/scene_bench.py` (do not edit by hand).", "",
            "- command: `%s`" % result["command"],
            "- date: %s; total %.0f s" % (result["date"], result["total_seconds"]),
            "- load average at start / end: %s / %s" % (
                " ".join("%.2f" % v for v in result["load_average"]),
                " ".join("%.2f" % v for v in result["load_average_end"])),
            "- %s; %s; image %dx%d%s" % (result["host_version"], result["envlight_version"],
                                         result["image"][0], result["image"][1], image_note)]


def report(result, out_dir, host, module=None):
    if module is not None and hasattr(module, "report_lines"):
        L = header(result, host) + module.describe(result) + [""]
        if result.get("notes"):
            L += ["Notes: " + " ".join(result["notes"]), ""]
        L += module.report_lines(result, target_check(result, module))
        if not hasattr(module, "figures"):   # a host with its own figures names them itself
            caption = module.grid_caption(result) if hasattr(module, "grid_caption") else \
                getattr(module, "GRID_CAPTION", GRID_CAPTION)
            L += ["", "![grid](%s_scene_grid.png)" % host, "", caption, "",
                  "![error against time](%s_scene_error_time.png)" % host, ""]
        write_atomic(os.path.join(out_dir, "scene_bench_%s.md" % host), "\n".join(L))
        return
    maps = list(result["maps"])
    recipes = []
    for r in result["runs"]:
        key = "default" if r["picked"] else r["recipe"]
        if key not in recipes:
            recipes.append(key)
    by = {}
    for r in result["runs"]:
        by[(r["map"], r["scene"], "default" if r["picked"] else r["recipe"])] = r
    L = header(result, host, ", no anti-aliasing, +FH") + [
         "- reference: bright pixels (> %g x the mean luminance) as %d hard-shadowed "
         "median-cut lights (direct light; their bounce from %d of them under radiosity: "
         "passes radiosity - %d lights + %d lights, CPU s summed), the rest as EnvLight_Sky() "
         "of the residual under `%s`; validated on a lone white sphere against the exact "
         "E(n)/pi (tolerance %.1f %%)"
         % (result["reference_settings"]["bright_factor"],
            result["reference_settings"]["bright_lights"],
            result["reference_settings"]["bounce_lights"],
            result["reference_settings"]["bounce_lights"],
            result["reference_settings"]["bright_lights"],
            result["reference_settings"]["radiosity"],
            100 * result["reference_settings"]["validation_tolerance"]),
         "- error: relative RMS of luminance against the reference over the object's pixels; "
         "bias: mean / reference mean - 1; speedup: reference CPU s / recipe CPU s (POV-Ray "
         "process, user + system, all threads); `default` = `envlight pov MAP --scene "
         "SCENE.pov` (what envlight picks; its reported recipe in brackets)",
         "- goal: on every map the picked row >= %gx CPU at < %.0f %% matte error on (a), "
         "< %.0f %% on (b)" % (TARGET_SPEEDUP, 100 * TARGET_ERROR["a"],
                                100 * TARGET_ERROR["b"]), ""]
    if result.get("notes"):
        L += ["Notes: " + " ".join(result["notes"]), ""]
    # summary
    head = ["map", "sun share %", "ref CPU s (a / b)", "validation %"]
    head += ["%s: a / b / glossy %% / speedup a" % k for k in recipes]
    L += ["## Per map (matte error % on (a) / on (b) / glossy % on (a) / speedup on (a))", "",
          "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for m in maps:
        e = result["maps"][m]
        ref = e["reference"]
        cells = [m, "%.1f" % (100 * e["sun_share"]),
                 " / ".join("%.1f" % ref["cpu_seconds"][s] for s in result["scenes"]),
                 "%.2f%s" % (100 * ref["validation_error"], "" if ref["validated"] else " (!)")]
        for k in recipes:
            a, b = by.get((m, "a", k)), by.get((m, "b", k))
            name = ""
            if k == "default" and (a or b):
                name = " [%s]" % (a or b)["recipe"]
            cells.append("%s / %s / %s / %s%s" % (
                pct(a and a["error"]), pct(b and b["error"]),
                pct(a and a["errors"].get("glossy")),
                "%.1fx" % a["speedup"] if a else "-", name))
        L.append("| " + " | ".join(cells) + " |")
    # target
    L += ["", "## Goal check (picked row)", "", "| map | met | detail |", "|---|---|---|"]
    checks = target_check(result)
    for m in maps:
        met, text = checks[m]
        L.append("| %s | %s | %s |" % (m, {True: "**met**", False: "not met",
                                            None: "-"}[met], text))
    # reference details
    L += ["", "## References", "",
          "| map | bright share % | bright lights | validation % | validation bias % | "
          "ref a wall / CPU s | ref b wall / CPU s | highlight pass (a): change from 1/4 "
          "the lights, % of the glossy mean |", "|---|---|---|---|---|---|---|---|"]
    for m in maps:
        ref = result["maps"][m]["reference"]
        hi = ref["highlight"].get("a")
        L.append("| %s | %.1f | %d | %.3f | %+.3f | %s | %s | %s |" % (
            m, 100 * ref["bright_share"], ref["bright_lights"],
            100 * ref["validation_error"], 100 * ref["validation_bias"],
            *("%.1f / %.1f" % (ref["seconds"][s], ref["cpu_seconds"][s])
              if s in ref["seconds"] else "-" for s in ("a", "b")),
            "%.3f (%d -> %d lights)" % (100 * hi["convergence"], hi["coarse_lights"],
                                        hi["lights"]) if hi else "-"))
    # full table
    L += ["", "## All runs", "",
          "| map | scene | recipe | CPU s | wall s | envlight s | speedup | errors % (bias %) |",
          "|---|---|---|---|---|---|---|---|"]
    for r in result["runs"]:
        L.append("| %s | %s | %s%s | %.2f | %.2f | %s | %.1fx | %s |" % (
            r["map"], r["scene"], r["recipe"], " (picked)" if r["picked"] else "",
            r["seconds"], r["wall_seconds"],
            "-" if r["envlight_seconds"] is None else "%.2f" % r["envlight_seconds"],
            r["speedup"], ", ".join("%s %.2f (%+.2f)" % (o, 100 * v, 100 * r["biases"][o])
                                    for o, v in r["errors"].items())))
    L += ["", "![grid](%s_scene_grid.png)" % host, "",
          "Rows: maps; columns: reference (a), picked (a), reference (b), picked (b); one "
          "exposure per map, sRGB.", "",
          "![error against time](%s_scene_error_time.png)" % host, ""]
    write_atomic(os.path.join(out_dir, "scene_bench_%s.md" % host), "\n".join(L))


def plot(result, out_dir, host, family):
    """Matte error on (a) against CPU seconds, log axes, one colour per recipe family."""
    d = tempfile.mkdtemp(prefix="scene_bench_plot")
    series = {}
    for r in result["runs"]:
        if r["scene"] != "a" or r["error"] is None or r["seconds"] <= 0:
            continue
        fam = "default (picked)" if r["picked"] else family(r["recipe"])
        if fam is None:   # not a lighting (the host's family says)
            continue
        series.setdefault(fam, []).append((r["seconds"], max(100 * r["error"], 1e-3)))
    refs = [(m, e["reference"]["cpu_seconds"]["a"]) for m, e in result["maps"].items()
            if "a" in e["reference"].get("cpu_seconds", {})]
    if not series:
        return
    colours = ["#999999", "#e69f00", "#0072b2", "#009e73", "#cc79a7", "#56b4e9", "#d55e00",
               "#000000", "#f0e442"]
    plots = []
    for i, (fam, pts) in enumerate(sorted(series.items())):
        fn = os.path.join(d, "s%d.dat" % i)
        with open(fn, "w") as f:
            f.write("".join("%g %g\n" % p for p in pts))
        plots.append("'%s' using 1:2 with points pt 7 ps 0.8 lc rgb '%s' title '%s'"
                     % (fn, colours[i % len(colours)], fam))
    rf = os.path.join(d, "ref.dat")
    with open(rf, "w") as f:
        f.write("".join("%g 0.5\n" % t for _, t in refs))
    plots.append("'%s' using 1:2 with points pt 2 ps 1.2 lc rgb 'black' title 'references "
                 "(CPU s; drawn at 0.5 %%)'" % rf)
    png = os.path.join(out_dir, "%s_scene_error_time.png" % host)
    script = ("set terminal pngcairo size 900,600 font ',9'\nset output '%s.tmp'\n"
              "set termoption noenhanced\nset logscale xy\nset grid\n"
              "set xlabel '%s CPU seconds (user + system, whole process)'\n"
              "set ylabel 'matte-sphere error on scene (a) vs reference, %% (rel. RMS lum.)'\n"
              "set title 'scene (a), every map and recipe: error against CPU time'\n"
              "set key outside right\nset arrow from graph 0, first 2 to graph 1, first 2 "
              "nohead dt 2 lc rgb 'red'\nplot %s\n"
              % (png, result["host_version"].split()[0], ", ".join(plots)))
    r = subprocess.run(["gnuplot"], input=script, text=True, capture_output=True)
    if r.returncode != 0:
        print("NOTE: gnuplot failed: %s" % r.stderr.strip()[-300:])
        return
    os.replace(png + ".tmp", png)


#: the picture grid's columns, (scene, image) per map; a host module's GRID_COLUMNS (and its
#: GRID_CAPTION) replace them
GRID_COLUMNS = [("a", "reference"), ("a", "picked"), ("b", "reference"), ("b", "picked")]
GRID_CAPTION = ("Rows: maps; columns: reference (a), picked (a), reference (b), picked (b); "
                "one exposure per map, sRGB.")


def grid(images, result, out_dir, host, cols=GRID_COLUMNS):
    """oiiotool mosaic: per map the images of `cols` (default: reference (a), picked (a),
    reference (b), picked (b)) that some map has."""
    import numpy as np
    import envlight as E
    # the columns some map has (a run without a recipe of `cols` draws no blank column of it)
    cols = [k for k in cols if any(k in images.get(m, {}) for m in result["maps"])]
    d = tempfile.mkdtemp(prefix="scene_bench_grid")
    tiles, rows = [], 0
    blank = None
    for m in result["maps"]:
        imgs = images.get(m, {})
        refs = [imgs[k] for k in cols if k in imgs and k[1] == "reference"]
        if not refs:
            continue
        ys = np.concatenate([(0.2126 * i[..., 0] + 0.7152 * i[..., 1] + 0.0722 * i[..., 2])
                             .ravel() for i in refs])
        scale = 0.8 / max(np.percentile(ys, 99), 1e-12)   # one exposure per map
        for k in cols:
            img = imgs.get(k)
            if img is None:
                if blank is None:
                    blank = np.zeros_like(refs[0], dtype=np.float32)
                img = blank
            fn = os.path.join(d, "t%d.pfm" % len(tiles))
            E.save_image(fn, (img * scale).astype(np.float32))
            tiles.append(fn)
        rows += 1
    if not tiles:
        return
    out = os.path.join(out_dir, "%s_scene_grid.png" % host)
    r = subprocess.run(["oiiotool", *tiles, "--mosaic:pad=2", "%dx%d" % (len(cols), rows),
                        "--clamp:min=0:max=1", "--colorconvert", "linear", "sRGB",
                        "-d", "uint8", "-o", out + ".tmp.png"], capture_output=True, text=True)
    if r.returncode != 0:
        print("NOTE: oiiotool failed: %s" % r.stderr.strip()[-300:])
        return
    os.replace(out + ".tmp.png", out)


def report_from(args):
    host = importlib.import_module(HOSTS[args.host])
    with open(args.report_from) as f:
        result = json.load(f)
    images = None
    if hasattr(host, "load_images"):   # a host that keeps its run's images draws from them
        tmp = os.path.abspath(args.tmp or os.environ.get("ENVL_TEST_TMP")
                              or "/tmp/envl_scene_bench")
        host.setup(os.path.abspath(args.envlight), os.path.abspath(args.library), tmp)
        images = {m: host.load_images(m, dict(tmp=tmp)) for m in result["maps"]}
    if hasattr(host, "rescore"):
        host.rescore(result)
    write_out(args, host, result, images)


def write_out(args, host, result, images=None):
    """The JSON (--json, --docs), the report and the figures (--docs; the picture grid when
    there are images), and the goal per map on stdout."""
    text = json.dumps(finite(result), indent=1)
    if args.json:
        write_atomic(args.json, text)
    if args.docs:
        write_atomic(os.path.join(args.docs, "scene_bench_%s.json" % args.host), text)
        report(result, args.docs, args.host, host)
        if images is not None:
            if hasattr(host, "figures"):
                host.figures(result, images, args.docs)
            else:
                grid(images, result, args.docs, args.host,
                     getattr(host, "GRID_COLUMNS", GRID_COLUMNS))
        plot(result, args.docs, args.host, host.family)
    print()
    for m, (met, text_) in target_check(result, host).items():
        print("goal %s: %s: %s" % (m, {True: "met", False: "NOT met", None: "-"}[met], text_))


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if args.report_from:
        return report_from(args)
    t0 = time.time()
    load0 = list(os.getloadavg())
    host = importlib.import_module(HOSTS[args.host])
    tmp = os.path.abspath(args.tmp or os.environ.get("ENVL_TEST_TMP")
                          or "/tmp/envl_scene_bench")
    os.makedirs(tmp, exist_ok=True)
    envlight, library = os.path.abspath(args.envlight), os.path.abspath(args.library)
    for f in (envlight, library):
        if not os.path.exists(f):
            sys.exit("scene_bench: %s not found (build it, or pass --envlight / --library)" % f)
    host_version = host.setup(envlight, library, tmp)
    r = subprocess.run([envlight, "--version"], capture_output=True, text=True)
    envlight_version = (r.stdout or r.stderr).strip().splitlines()[0] if r.returncode == 0 \
        else "envlight"
    scenes = [s for s in args.scenes.split(",") if s] if args.scenes else \
        list(getattr(host, "QUICK_SCENES", host.SCENES) if args.quick else host.SCENES)
    bad = [s for s in scenes if s not in host.SCENES]
    if bad:
        sys.exit("--scenes: %s unknown (known: %s)" % (",".join(bad), ",".join(host.SCENES)))
    cannot = getattr(host, "check_scenes", lambda scenes: None)(scenes)
    if cannot:
        sys.exit(cannot)
    if args.recipes:
        recipes = [r for r in args.recipes.split(",") if r]
        bad = [r for r in recipes if r not in host.RECIPES]
        if bad:
            sys.exit("--recipes: %s unknown (known: %s)" % (",".join(bad),
                                                            ",".join(host.RECIPES)))
    else:
        recipes = host.QUICK_RECIPES if args.quick else list(host.RECIPES)
    if args.map:
        maps = []
        for m in args.map:
            if m == "-":
                maps.append(("sky", "-"))
            elif not os.path.exists(m):
                sys.exit("--map: %s not found" % m)
            else:
                maps.append((os.path.basename(m).rsplit(".", 1)[0], os.path.abspath(m)))
    elif args.quick:
        maps = [("sky", "-")]
    else:
        maps = host.default_maps(os.path.join(DATA, "latlong_hdri"))
    print("scene_bench --host %s: %d maps, scenes %s, recipes %s; %s; load average %.2f %.2f "
          "%.2f" % (args.host, len(maps), ",".join(scenes), ",".join(recipes), host_version,
                    *load0))
    sys.stdout.flush()
    result = dict(host=args.host, host_version=host_version, envlight_version=envlight_version,
                  command="scripts/scene_bench.py " + " ".join(sys.argv[1:] if argv is None
                                                               else argv),
                  date=datetime.datetime.now().isoformat(timespec="seconds"),
                  load_average=load0, quick=args.quick, scenes=scenes, recipes=recipes,
                  image=list(host.QUICK_IMAGE if args.quick else host.IMAGE),
                  reference_settings=host.reference_settings(args.quick)
                  if hasattr(host, "reference_settings") else dict(
                      bright_factor=host.BRIGHT_FACTOR, bright_lights=host.BRIGHT_LIGHTS,
                      bounce_lights=host.BOUNCE_LIGHTS,
                      radiosity=host.radiosity_block(
                          host.QUICK_RADIOSITY if args.quick
                          else host.REFERENCE_RADIOSITY).strip(),
                      validation_tolerance=host.VALIDATION_TOLERANCE),
                  maps={}, runs=[], notes=[])
    images = {}
    opts = dict(quick=args.quick, recipes=recipes, scenes=scenes, tmp=tmp, envlight=envlight,
                library=library, floor=[m for m in args.floor.split(",") if m],
                references={})
    if args.references_from:
        with open(args.references_from) as f:
            opts["references"] = json.load(f)["maps"]
    done = {}
    if args.resume and args.json and os.path.exists(args.json):
        with open(args.json) as f:
            done = json.load(f)
        print("resume: %d maps from %s" % (len(done["maps"]), args.json))
    for name, path in maps:
        if name in done.get("maps", {}):   # kept as that run measured it
            result["maps"][name] = done["maps"][name]
            result["runs"] += [r for r in done["runs"] if r["map"] == name]
            if hasattr(host, "load_images"):
                images[name] = host.load_images(name, opts)
            continue
        entry, runs, imgs = host.run_map(name, path, opts)
        result["maps"][name] = entry
        result["runs"] += runs
        images[name] = imgs
        if args.json:   # progress: the maps so far (the final write replaces it)
            write_atomic(args.json, json.dumps(finite(dict(result, partial=True)), indent=1))
    result["load_average_end"] = list(os.getloadavg())
    result["total_seconds"] = time.time() - t0
    write_out(args, host, result, images)
    print("total %.0f s; load average %.2f %.2f %.2f" % (time.time() - t0, *os.getloadavg()))


if __name__ == "__main__":
    main()
