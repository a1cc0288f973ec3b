#!/usr/bin/python3
"""The reports of `envlight bench` in docs/bench/, written by this script so that re-running it
updates them. Each report starts with the command, the date, the load average at the start
and the end, and the machine; then what `envlight bench` printed.

  DIR/bench/tables.md   `envlight bench FILE... --only tables`: every lights method at 1..256
                        lights, SH orders 1..8 with each window, the GGX levels against samples
                        and size, the irradiance maps; with DIR/bench/bench.csv (every point)
                        and the plots DIR/bench/*.png (error against seconds, Pareto front)
  DIR/bench/summary.md  from bench.csv: one row per map with the figures README.md's "Which
                        method for which job" quotes, and the lights at a few counts
  DIR/bench/speed.md    `envlight bench - --only speed`: the stages on a large built-in sky
                        against one plain pass over its floats
  DIR/bench/load.md     `envlight bench FILE --only load`: envlight's .hdr reader against
                        OpenImageIO's oiiotool
  DIR/bench/memory.md   `envlight bench - --only memory`: the peak resident memory per stage

  scripts/bench_report.py [--docs DIR] [--only tables|speed|load|memory ...] [--runs N]
                          [--envlight build/envlight] [--speed-width W] [--load-width W]
                          [--memory-width W] [--report-from CSV] [FILE ...]

Run from the repository top. FILE: the maps of the tables and load steps (default: the
built-in sky and the six 1k maps of ../shared/data/latlong_hdri that docs/bench/ shows;
absent ones are left out with a note). Without --only every step runs: about 10 minutes on
two idle cores, most of it the tables. --runs N: runs per measurement (default: 3 for the
tables, 7 for speed and load; the memory step runs once). --report-from CSV: no runs; writes
only summary.md from that CSV (an earlier run's bench.csv).
"""
import argparse
import csv
import datetime
import os
import platform
import shlex
import subprocess
import sys
import time

from scene_bench import write_atomic  # the one atomic writer of the benchmarks

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.environ.get("ENVL_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data"))
MAPS = ["rooitou_park_1k.hdr", "venice_sunset_1k.hdr", "potsdamer_platz_1k.hdr",
        "immenstadter_horn_1k.hdr", "studio_small_03_1k.hdr", "st_fagans_interior_1k.hdr"]
STEPS = ["tables", "speed", "load", "memory"]
RUNS = {"tables": 3, "speed": 7, "load": 7}
TITLES = {"tables": "envlight bench: accuracy against time",
          "speed": "envlight bench: speed against a memory pass",
          "load": "envlight bench: loading against OpenImageIO",
          "memory": "envlight bench: peak memory"}


def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="bench_report.py", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("files", nargs="*", metavar="FILE",
                   help="maps for the tables and load steps ('-': the built-in sky)")
    p.add_argument("--docs", default="docs", metavar="DIR",
                   help="write DIR/bench/*.md (default docs)")
    p.add_argument("--only", action="append", choices=STEPS, metavar="STEP",
                   help="tables, speed, load or memory (repeatable; default: all)")
    p.add_argument("--runs", type=int, metavar="N", help="runs per measurement")
    p.add_argument("--envlight", default=os.path.join("build", "envlight"),
                   help="the envlight CLI (default build/envlight)")
    for w in ("speed", "load", "memory"):
        p.add_argument("--%s-width" % w, type=int, metavar="W",
                       help="passed to envlight bench (default: its own)")
    p.add_argument("--report-from", metavar="CSV",
                   help="no runs: write only DIR/bench/summary.md from this bench.csv")
    a = p.parse_args(argv)
    if a.runs is not None and a.runs < 1:
        p.error("--runs must be at least 1")
    return a


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
        mem = ", %.0f GB" % (kb / 2 ** 20)
    except (OSError, ValueError, IndexError):
        pass
    return "%s, %d cores%s" % (cpu, os.cpu_count() or 1, mem)


def version(envlight):
    try:
        return subprocess.run([envlight, "--version"], capture_output=True, text=True,
                              timeout=30).stdout.strip()
    except OSError:
        return "envlight (version unknown)"


def header(title, script_cmd, bench_cmd, date, seconds, load0, load1, envlight):
    return ["# " + title, "",
            "Written by `%s` (do not edit by hand; run it again to update this file)."
            % script_cmd, "",
            "- command: `%s`" % bench_cmd,
            "- date: %s; took %.0f s" % (date, seconds),
            "- load average at start / end: %s / %s" % (
                " ".join("%.2f" % v for v in load0), " ".join("%.2f" % v for v in load1)),
            "- machine: %s; %s" % (machine(), version(envlight)), ""]


def default_files():
    files = ["-"]
    for m in MAPS:
        path = os.path.join(DATA, "latlong_hdri", m)
        if os.path.exists(path):
            files.append(os.path.relpath(path))
        else:
            print("bench_report: %s is absent: left out" % path, file=sys.stderr)
    return files


def run_step(step, args, files, script_cmd):
    bench = os.path.join(args.docs, "bench")
    os.makedirs(bench, exist_ok=True)
    cmd = [args.envlight, "bench"]
    if step in ("tables", "load"):
        cmd += files if step == "tables" else files[:2]
    else:
        cmd += ["-"]
    runs = args.runs or RUNS.get(step)
    if runs:
        cmd += ["--runs", str(runs)]
    cmd += ["--only", step]
    if step == "tables":
        cmd += ["--csv", os.path.join(bench, "bench.csv"), "--plots", bench]
    w = getattr(args, "%s_width" % step, None)
    if w is not None:
        cmd += ["--%s-width" % step, str(w)]
    date = datetime.datetime.now().isoformat(timespec="seconds")
    load0, t0 = os.getloadavg(), time.time()
    print("bench_report: %s" % " ".join(shlex.quote(c) for c in cmd), file=sys.stderr)
    r = subprocess.run(cmd, stdout=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit("bench_report: envlight bench --only %s failed (exit %d): %s not written"
                 % (step, r.returncode, os.path.join(bench, step + ".md")))
    L = header(TITLES[step], script_cmd, " ".join(shlex.quote(c) for c in cmd), date,
               time.time() - t0, load0, os.getloadavg(), args.envlight)
    if step == "tables":
        L += ["Every point: [bench.csv](bench.csv); one row per map: [summary.md](summary.md); "
              "plots: the PNGs beside this file.", ""]
    text = "\n".join(L) + "\n" + r.stdout + ("" if r.stdout.endswith("\n") else "\n")
    write_atomic(os.path.join(bench, step + ".md"), text)
    if step == "tables":  # gnuplot's inputs beside each plot: the CSV holds the same points
        for f in os.listdir(bench):
            stem, ext = os.path.splitext(f)
            if ext in (".dat", ".gp") and os.path.exists(os.path.join(bench, stem + ".png")):
                os.unlink(os.path.join(bench, f))
    print("bench_report: wrote %s" % os.path.join(bench, step + ".md"), file=sys.stderr)


# summary.md: (column title, measure, series, param) picked from bench.csv
SUMMARY = [("median 16", "diffuse", "median", "16"),
           ("median 64", "diffuse", "median", "64"),
           ("variance 16", "diffuse", "variance", "16"),
           ("variance 64", "diffuse", "variance", "64"),
           ("fit 4 + SH 2", "diffuse", "fit", "4"),
           ("SH 2 (auto)", "diffuse", "sh-auto", "2"),
           ("irradiance map", "diffuse", "irradiance-resampled", "0"),
           ("GGX 0.5, M = 16 (128 smp)", "glossy", "ggx-r0.50-samples", "128"),
           ("GGX 0.5, M = 64 (512 smp)", "glossy", "ggx-r0.50-samples", "512")]
LIGHTS = [("median %s" % n, "median", n) for n in ("4", "16", "64", "256")] + \
         [("variance %s" % n, "variance", n) for n in ("16", "64")] + \
         [("fit %s" % n, "fit", n) for n in ("1", "4", "16")]


def map_name(m):
    for ext in (".hdr", ".exr", ".pfm"):
        if m.endswith(ext):
            m = m[:-len(ext)]
    return m[:-3] if m.endswith("_1k") else m


def summary(csv_path, out, script_cmd):
    rows, maps = {}, []
    with open(csv_path, newline="") as f:
        for r in csv.DictReader(f):
            if r["map"] not in maps:
                maps.append(r["map"])
            rows[(r["map"], r["measure"], r["series"], r["param"])] = r
    def cell(key, seconds=True):
        r = rows.get(key)
        if r is None:
            return ""
        e, s = "%.2f" % (100 * float(r["error"])), float(r["seconds"])
        return "%s / %s" % (e, "%.2f" % s if s >= 0.1 else "%.2g" % s) if seconds else e
    L = ["# envlight bench: one row per map", "",
         "Written by `%s` from [%s](%s) (do not edit by hand; run it again to update this "
         "file). The run that wrote the CSV: [tables.md](tables.md)."
         % (script_cmd, os.path.basename(csv_path), os.path.basename(csv_path)), "",
         "Error % / seconds. Diffuse error: relative RMS irradiance error over 1024 normals "
         "against the exact integrator (docs/design.md); GGX: glossy error of the roughness-0.5 "
         "level, 128 x 64, the sun baked in, `--samples M` giving that level 8 M samples per "
         "texel. fit 4 + SH 2: 4 fitted lights and their order-2 SH remainder; SH 2 (auto): "
         "`envlight sh`'s default window; irradiance map: `prefilter`'s default (resampled), "
         "64 x 32.", "",
         "| map | " + " | ".join(c[0] for c in SUMMARY) + " |",
         "|---|" + "---|" * len(SUMMARY)]
    for m in maps:
        L.append("| %s | %s |" % (map_name(m), " | ".join(
            cell((m, c[1], c[2], c[3])) for c in SUMMARY)))
    L += ["", "## Lights", "",
          "Diffuse error %; fit: (lights it used of those asked), order-2 remainder.", "",
          "| map | " + " | ".join(c[0] for c in LIGHTS) + " |",
          "|---|" + "---|" * len(LIGHTS)]
    for m in maps:
        cells = []
        for title, series, n in LIGHTS:
            r = rows.get((m, "diffuse", series, n))
            if r is None:
                cells.append("")
            elif series == "fit":
                cells.append("%.3g (%s)" % (100 * float(r["error"]), r["count"]))
            else:
                cells.append("%.3g" % (100 * float(r["error"])))
        L.append("| %s | %s |" % (map_name(m), " | ".join(cells)))
    secs = {}
    for (m, measure, series, param), r in rows.items():
        if measure == "diffuse" and series in ("median", "variance", "fit"):
            secs.setdefault(series, []).append(float(r["seconds"]))
    if secs:
        L += ["", "Seconds over every map and count: " + "; ".join(
            "%s %.2g-%.2g" % (s, min(v), max(v)) for s, v in sorted(secs.items())) + "."]
    write_atomic(out, "\n".join(L) + "\n")
    print("bench_report: wrote %s" % out, file=sys.stderr)


def main(argv):
    args = parse_args(argv)
    script_cmd = " ".join(["scripts/bench_report.py"] + [shlex.quote(a) for a in argv])
    bench = os.path.join(args.docs, "bench")
    if args.report_from:
        summary(args.report_from, os.path.join(bench, "summary.md"), script_cmd)
        return 0
    files = args.files or default_files()
    for step in args.only or STEPS:
        run_step(step, args, files, script_cmd)
        if step == "tables":
            summary(os.path.join(bench, "bench.csv"), os.path.join(bench, "summary.md"),
                    script_cmd)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
