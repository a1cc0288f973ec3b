#!/usr/bin/env python3
"""What the specular chain's accuracy costs in width (issue 29, the chain at roughness 0.1):
the glossy error and the seconds of one level against its cube-face width, for roughness
0.05 .. 0.4, on every map given; and how well the width `prefilter` states for 1 % (its
"target_width", docs/design.md) holds.

For each map and roughness R, `envlight prefilter MAP --levels 1 --roughness R --layout cube
--size F --json` at F = 32, 64 (and 128 for the first --wide maps): the level's glossy
error, its seconds, and the width it states for 1 % with the time it estimates. Then, from the
64-face run's statement, the level rendered at the stated width when it is at most --verify
faces: its measured error (must be within 1 %), its seconds against the estimate, and the
level at the stated width / 1.1 (the search brackets within 5 %: there the error is expected
above 1 %, unless the curve is not monotonic). The local slope of log error against log
width between ladder steps tests the model the search starts from (error ~ width^-2).

A map argument is a file, '-' (the built-in sky), FILE@W (the map area-resampled to W wide by
`envlight convert`) or FILE@rD (read with --rotate D).

Usage: specular_width.py [--docs DIR] [--wide N] [--verify F] ENVLIGHT MAP...
       specular_width.py --docs DIR --report-from PART1.json PART2.json ...
With --docs DIR: DIR/specular_width.md (after a header: the command, date, load average,
machine), DIR/specular_width.json (every run) and DIR/specular_width.png (gnuplot: error and
seconds against width). Not in CI: it takes about half an hour on the 25 maps of the report.
"""
import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from texel_bench import load_average, resolve  # noqa: E402  (the maps' arguments, as there)

ROUGHNESS = [0.05, 0.1, 0.2, 0.4]
LADDER = [32, 64]
WIDE = 128
TARGET = 0.01


def level(envlight, path, extra, r, face):
    """The one level of roughness r at `face`-texel faces, as prefilter.json gives it."""
    with tempfile.TemporaryDirectory() as out:
        res = subprocess.run([envlight, "prefilter", path, "-o", out, "--json", "--quiet",
                              "--levels", "1", "--roughness", "%g" % r, "--layout", "cube",
                              "--size", str(face)] + extra,
                             check=True, capture_output=True, text=True)
    lv = json.loads(res.stdout)["specular"][0]
    t = lv["target_width"]
    return {"face": face, "error": lv["glossy_error"], "seconds": lv["seconds"],
            "state": t["state"], "stated_face": t["height"], "stated_error": t["glossy_error"],
            "stated_seconds": t["seconds_estimated"], "search_seconds": t["seconds_spent"],
            "directions": t["directions_read"], "load": load_average()}


def chain_overhead(envlight, name, path, extra):
    """The default chain as cube faces (`prefilter MAP --specular --layout cube`): the products'
    seconds, and the width search's (the sum over its levels) with how many levels it ran on."""
    with tempfile.TemporaryDirectory() as out:
        res = subprocess.run([envlight, "prefilter", path, "-o", out, "--json", "--quiet",
                              "--specular", "--layout", "cube"] + extra,
                             check=True, capture_output=True, text=True)
    j = json.loads(res.stdout)
    levels = j["specular"]
    searched = [lv["target_width"] for lv in levels
                if lv["target_width"]["state"] in ("found", "beyond")]
    return {"map": name, "seconds": j["seconds"],
            "levels_seconds": sum(lv["seconds"] for lv in levels),
            "search_seconds": sum(t["seconds_spent"] for t in searched),
            "searched": len(searched),
            "stated": ["%s: %s" % (lv["roughness"], lv["target_width"]["height"]) for lv in levels
                       if lv["target_width"]["state"] in ("found", "beyond")]}


def pct(x):
    return "-" if x is None else "%.2f" % (100 * x)


def secs(x):
    return "-" if x is None else "%.2f" % x


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("envlight", nargs="?")
    ap.add_argument("maps", nargs="*")
    ap.add_argument("--docs")
    ap.add_argument("--wide", type=int, default=6,
                    help="the first N maps also at 128-texel faces (default 6)")
    ap.add_argument("--report-from", metavar="JSON", nargs="+",
                    help="write the report and plot (--docs) from the JSON of runs over parts "
                         "of the maps (their commands, dates and loads in the header)")
    ap.add_argument("--overhead", type=int, default=3,
                    help="the default chain's cost of the statement on the first N maps "
                         "(default 3)")
    ap.add_argument("--verify", type=int, default=320,
                    help="render the stated width when it is at most F faces (default 320)")
    a = ap.parse_args()
    if a.report_from:
        report_from(a)
        return
    command = " ".join([os.path.relpath(sys.argv[0])] + sys.argv[1:])
    started, load0, t0 = time.strftime("%Y-%m-%dT%H:%M:%S"), load_average(), time.time()
    runs, overhead = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for n, spec in enumerate(a.maps):
            name, path, extra = resolve(spec, tmp, a.envlight)
            for r in ROUGHNESS:
                ladder = LADDER + ([WIDE] if n < a.wide else [])
                rows = [level(a.envlight, path, extra, r, f) for f in ladder]
                entry = {"map": name, "roughness": r, "ladder": rows}
                start = rows[1]
                if start["state"] == "found" and start["stated_face"] <= a.verify:
                    f = int(start["stated_face"])
                    entry["at_stated"] = level(a.envlight, path, extra, r, f)
                    below = max(int(f / 1.1), 2)
                    if below < f:
                        entry["below_stated"] = level(a.envlight, path, extra, r, below)
                runs.append(entry)
                print("%s r %g: %s" % (name, r, " ".join(
                    "%d:%s%%" % (x["face"], pct(x["error"])) for x in rows)), file=sys.stderr)
            if n < a.overhead:
                overhead.append(chain_overhead(a.envlight, name, path, extra))
            if a.docs:  # after every map: a run stopped early still has its maps so far
                save_json(a, command, started, load0, time.time() - t0, runs, overhead)
    took = time.time() - t0
    report = write_report(a, runs, overhead, command, started, load0, took)
    print(report)
    if a.docs:
        with open(os.path.join(a.docs, "specular_width.md"), "w") as f:
            f.write(report)
        save_json(a, command, started, load0, took, runs, overhead)
        plot(runs, a.docs)


def save_json(a, command, started, load0, took, runs, overhead):
    with open(os.path.join(a.docs, "specular_width.json"), "w") as f:
        json.dump({"command": command, "date": started, "took": took,
                   "load": [load0, load_average()], "runs": runs, "overhead": overhead}, f,
                  indent=1)


def report_from(a):
    """One report from several runs' JSON (parts of the maps run side by side)."""
    parts = []
    for fn in a.report_from:
        with open(fn) as f:
            parts.append(json.load(f))
    runs = [r for p in parts for r in p["runs"]]
    overhead = [o for p in parts for o in p["overhead"]]
    command = " ; ".join(p["command"] for p in parts) + " ; then " + " ".join(
        [os.path.relpath(sys.argv[0])] + sys.argv[1:])
    started = " / ".join(sorted(set(p["date"] for p in parts)))
    load0 = "; ".join(p["load"][0] for p in parts)
    took = max(p["took"] for p in parts)  # the parts ran side by side
    report = write_report(a, runs, overhead, command, started, load0,
                          took).replace("- load average at start / end: %s / %s" % (
                              load0, load_average()), "- load average at start / end, each "
                              "part: %s" % "; ".join("%s / %s" % tuple(p["load"])
                                                     for p in parts))
    print(report)
    if a.docs:
        with open(os.path.join(a.docs, "specular_width.md"), "w") as f:
            f.write(report)
        with open(os.path.join(a.docs, "specular_width.json"), "w") as f:
            json.dump({"command": command, "parts": parts}, f, indent=1)
        plot(runs, a.docs)


def slopes(rows):
    """-d log(error) / d log(width) between consecutive ladder widths."""
    out = []
    for x, y in zip(rows, rows[1:]):
        if x["error"] > 0 and y["error"] > 0:
            out.append(-math.log(y["error"] / x["error"]) / math.log(y["face"] / x["face"]))
    return out


def write_report(a, runs, overhead, command, started, load0, took):
    L = ["# What the specular levels' accuracy costs in width", "",
         "Written by `%s` (do not edit by hand; run it again to update this file)." % command,
         "",
         "- date: %s; took %.0f s" % (started, took),
         "- load average at start / end: %s / %s" % (load0, load_average()),
         "- machine: %s, %d cores (shared: the seconds are wall seconds of a loaded machine; "
         "compare them within a row)" % (platform.processor() or platform.machine(),
                                         os.cpu_count()),
         "- each level: `prefilter MAP --levels 1 --roughness R --layout cube --size F` (one "
         "level F texels square per face, the chain's default density); glossy error as "
         "docs/design.md's; \"stated\": the width `prefilter` states for 1 %% from the 64-face "
         "level (`target_width`), its error as read there and its estimated seconds; "
         "\"at stated\": the level rendered at that width (when at most %d faces) and "
         "measured, and at the width / 1.1" % a.verify,
         "", "![glossy error and seconds against the face width](specular_width.png)", ""]
    # the model: slopes per roughness
    L += ["## The model: how the error falls with the width", "",
          "-d log(error) / d log(width) between ladder steps (32 -> 64 -> 128), over "
          "every map; the search's first step assumes 2 (bilinear interpolation of a P "
          "smooth on the texels' scale).", "",
          "| roughness | steps | median slope | 10 % | 90 % |", "|---|---|---|---|---|"]
    for r in ROUGHNESS:
        s = sorted(x for e in runs if e["roughness"] == r for x in slopes(e["ladder"]))
        if s:
            q = lambda p: s[min(len(s) - 1, int(p * len(s)))]
            L.append("| %g | %d | %.2f | %.2f | %.2f |" % (r, len(s), statistics.median(s),
                                                          q(0.1), q(0.9)))
    # the statements checked
    checked = [e for e in runs if "at_stated" in e]
    met = [e for e in checked if e["at_stated"]["error"] <= TARGET]
    agree = [abs(e["at_stated"]["error"] - e["ladder"][1]["stated_error"]) for e in checked]
    below = [e for e in checked if "below_stated" in e]
    above = [e for e in below if e["below_stated"]["error"] > TARGET]
    tr = [e["at_stated"]["seconds"] / e["ladder"][1]["stated_seconds"] for e in checked
          if e["ladder"][1]["stated_seconds"]]
    search = [e["ladder"][1]["search_seconds"] / e["ladder"][1]["seconds"] for e in runs
              if e["ladder"][1]["state"] in ("found", "beyond")]
    L += ["", "## The stated width, checked", ""]
    if checked:
        L += ["- rendered at the stated width (%d cases of %d at most %d faces): the error "
              "within 1 %% in %d; |measured - stated error| median %.3f %%, largest %.3f %% "
              "(points of error)" % (len(checked), len(runs), a.verify, len(met),
                                     100 * statistics.median(agree), 100 * max(agree)),
              "- at the stated width / 1.1: above 1 %% in %d of %d (where the error falls "
              "steadily with the width, the stated width is then within 10 %% of the "
              "narrowest meeting 1 %%)" % (len(above), len(below))]
    if tr:
        L.append("- seconds measured at the stated width / estimated: median %.2f, range "
                 "%.2f - %.2f (same run, same load)" % (statistics.median(tr), min(tr), max(tr)))
    if search:
        L.append("- the search's own seconds / the 64-face level's: median %.3f, largest %.3f"
                 % (statistics.median(search), max(search)))
    if overhead:
        r = [o["search_seconds"] / o["seconds"] for o in overhead]
        L += ["", "## What the statement costs in the default chain", "",
              "`prefilter MAP --specular --layout cube` (6 levels, faces 256 .. 16): the width "
              "search's seconds (all its levels) against the products' (`seconds`, the error "
              "measure excluded; the search runs in the measure, after them), over %d maps: "
              "median %.3f, largest %.3f (%s)." % (
                  len(r), statistics.median(r), max(r),
                  max(overhead, key=lambda o: o["search_seconds"] / o["seconds"])["map"]), "",
              "| map | products s | search s | levels searched (roughness: face width stated) |",
              "|---|---|---|---|"]
        for o in overhead:
            L.append("| %s | %.3f | %.4f | %d (%s) |" % (o["map"], o["seconds"],
                                                       o["search_seconds"], o["searched"],
                                                       ", ".join(o["stated"])))
    L += ["", "## Every map", "",
          "Error % at each face width (seconds in brackets); the width stated for 1 % from the "
          "64-face level (its error there, estimated seconds); that width rendered.", "",
          "| map | roughness | 32 | 64 | 128 | stated for 1 % | est. s | at stated: error % "
          "(s) | at stated / 1.1 |", "|---|---|---|---|---|---|---|---|---|"]
    for e in runs:
        by = {x["face"]: x for x in e["ladder"]}
        cells = ["%s (%s)" % (pct(by[f]["error"]), secs(by[f]["seconds"])) if f in by else ""
                 for f in LADDER + [WIDE]]
        s = e["ladder"][1]
        stated = ("6 x %d^2 (%s)" % (s["stated_face"], pct(s["stated_error"]))
                  if s["state"] in ("found", "beyond") else s["state"])
        if s["state"] == "beyond":
            stated = "not met up to " + stated
        at = e.get("at_stated")
        bl = e.get("below_stated")
        L.append("| %s | %g | %s | %s | %s | %s | %s |" % (
            e["map"], e["roughness"], " | ".join(cells), stated,
            secs(s["stated_seconds"]) if s["state"] in ("found", "beyond") else "",
            "%s (%s)" % (pct(at["error"]), secs(at["seconds"])) if at else "",
            "%d: %s" % (bl["face"], pct(bl["error"])) if bl else ""))
    return "\n".join(L) + "\n"


def plot(runs, docs):
    """docs/specular_width.png: error (top) and seconds (bottom) against the face width, one
    panel per roughness, a line per map; the 1 % target dashed."""
    with tempfile.TemporaryDirectory() as tmp:
        cmds = ["set terminal pngcairo size 1500,800 font ',9'",
                "set output '%s'" % os.path.join(docs, "specular_width.png"),
                "set multiplot layout 2,%d title 'glossy error and seconds against the cube "
                "face width (a line per map, measured; x: the width stated for 1 %%, its error "
                "as read there and its estimated seconds; dashed: 1 %%, dotted: error ~ 1 / width^2; red o: the stated width rendered)'"
                % len(ROUGHNESS),
                "set termoption noenhanced", "set logscale xy", "set key off", "set grid",
                "set xrange [24:*]"]
        for row in ("error", "seconds"):
            for r in ROUGHNESS:
                files = []
                for i, e in enumerate(x for x in runs if x["roughness"] == r):
                    fn = os.path.join(tmp, "%s_%g_%d.dat" % (row, r, i))
                    with open(fn, "w") as f:
                        for x in e["ladder"]:
                            v = 100 * x["error"] if row == "error" else x["seconds"]
                            f.write("%d %g\n" % (x["face"], max(v, 1e-3)))
                    files.append(fn)
                stated = os.path.join(tmp, "stated_%s_%g.dat" % (row, r))
                with open(stated, "w") as f:
                    for e in runs:
                        s = e["ladder"][1]
                        if e["roughness"] == r and s["state"] == "found":
                            v = 100 * s["stated_error"] if row == "error" else s["stated_seconds"]
                            f.write("%d %g\n" % (s["stated_face"], v))
                cmds.append("set title 'roughness %g'" % r)
                cmds.append("set yrange [%s]" % ("0.1:*" if row == "error" else "0.001:*"))
                cmds.append("set xlabel 'face width (texels)'")
                cmds.append("set ylabel '%s'" % ("glossy error %" if row == "error"
                                                 else "seconds (wall)"))
                parts = ["'%s' with linespoints lc %d pt 7 ps 0.4" % (fn, k % 8 + 1)
                         for k, fn in enumerate(files)]
                parts.append("'%s' with points pt 2 ps 1 lc rgb 'black'" % stated)
                rendered = os.path.join(tmp, "rendered_%s_%g.dat" % (row, r))
                with open(rendered, "w") as f:
                    for e in runs:
                        at = e.get("at_stated")
                        if e["roughness"] == r and at:
                            v = 100 * at["error"] if row == "error" else at["seconds"]
                            f.write("%d %g\n" % (at["face"], max(v, 1e-3)))
                if os.path.getsize(rendered):
                    parts.append("'%s' with points pt 6 ps 1.2 lc rgb 'red'" % rendered)
                if row == "error":
                    parts.append("1 with lines dt 2 lw 2 lc rgb 'black'")
                    parts.append("100 * (64 / x)**2 with lines dt 3 lc rgb 'gray'")
                cmds.append("plot " + ", ".join(parts))
        cmds.append("unset multiplot")
        script = os.path.join(tmp, "plot.gp")
        with open(script, "w") as f:
            f.write("\n".join(cmds) + "\n")
        subprocess.run(["gnuplot", script], check=True)


if __name__ == "__main__":
    main()
