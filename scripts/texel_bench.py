#!/usr/bin/env python3
"""The per-texel accuracy of the prefiltered maps on every map (issue 30, item 5;
docs/design.md, "Error measures", the per-texel error), and their seconds against another
build's in the same run.

For each map, `envlight prefilter MAP --json` at the default sizes as cube faces (irradiance
faces of 32, the chain's of 256 .. 16) and as lat-long maps (64 x 32; 512 .. 64): each
product's per-texel RMS and worst (what prefilter.json states) beside its mean-relative
figure. Then, with --baseline OTHER_ENVLIGHT, runs of both builds, alternating, --runs times
each, with and without --no-error: the process's CPU seconds and the products' seconds
(prefilter.json's `seconds`) without the errors, their medians and ratio, and the CPU the
error measures add in each build.

A map argument is a file, '-' (the built-in sky), FILE@W (the map area-resampled to W wide by
`envlight convert`, e.g. 4096: upsampled), or FILE@rD (read with --rotate D).

Usage: texel_bench.py [--docs DIR] [--baseline ENVLIGHT] [--runs N] [--timed N] ENVLIGHT MAP...
With --docs DIR the report goes to DIR/texel_bench.md after a header (the command, date, load
average, machine); it is printed either way.
"""
import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

RMS_BOUND, WORST_BOUND = 0.005, 0.02


def load_average():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def cpu_of_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(envlight, args):
    """(prefilter.json as a dict, CPU seconds of the process)."""
    before = cpu_of_children()
    out = subprocess.run([envlight] + args, check=True, capture_output=True, text=True).stdout
    return json.loads(out), cpu_of_children() - before


def resolve(spec, tmp, envlight):
    """(display name, file, extra input options) of a map argument."""
    if spec == "-":
        return "built-in sky", "-", []
    path, _, variant = spec.partition("@")
    name = os.path.basename(path).rsplit(".", 1)[0]
    if not variant:
        return name, path, []
    if variant.startswith("r"):
        return "%s turned %s deg" % (name, variant[1:]), path, ["--rotate", variant[1:]]
    out = os.path.join(tmp, "%s_%s.exr" % (name, variant))
    if not os.path.exists(out):
        subprocess.run([envlight, "convert", path, out, "--size", variant, "--quiet"],
                       check=True)
    return "%s at %s wide" % (name, variant), out, []


def figures(entry):
    t = entry["texel_error"]
    return t["rms"], t["worst"]


def cell(entry):
    rms, worst = figures(entry)
    flag = "" if rms <= RMS_BOUND and worst <= WORST_BOUND else " **"
    return "%.2f / %.2f%s" % (100 * rms, 100 * worst, flag)


def accuracy(envlight, maps, layout):
    """The table of one layout, and (name, product, rms, worst) of every filtered product."""
    rows, every = [], []
    header = None
    for name, path, extra in maps:
        with tempfile.TemporaryDirectory() as out:
            j, _ = run(envlight, ["prefilter", path, "-o", out, "--json", "--quiet", "--layout",
                                  layout] + extra)
        levels = j["specular"]
        if header is None:
            header = ["map", "irradiance"] + ["r %.1f" % l["roughness"] for l in levels] + \
                     ["irradiance mean-rel.", "r 0.2 mean-rel.", "r 1 mean-rel."]
        irr = j["irradiance"]
        rows.append([name, cell(irr)] + [cell(l) for l in levels] +
                    ["%.3f" % (100 * irr["diffuse_error"]),
                     "%.3f" % (100 * levels[1]["glossy_error"]),
                     "%.3f" % (100 * levels[-1]["glossy_error"])])
        every.append((name, "irradiance", *figures(irr)))
        every += [(name, "r %.1f" % l["roughness"], *figures(l)) for l in levels
                  if l["roughness"] > 0]
        print("  %s %s done (load %s)" % (layout, name, load_average()), file=sys.stderr)
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return lines, every


def timings(envlight, baseline, maps, runs):
    """CPU and the products' seconds of both builds, --no-error, alternating; and the CPU the
    error measures add to each."""
    lines = ["| map | layout | CPU s: this / baseline | ratio | products s: this / baseline "
             "| the errors' CPU s: this / baseline |", "|---|---|---|---|---|---|"]
    ratios = {"cube": [], "latlong": []}
    for name, path, extra in maps:
        for layout in ("cube", "latlong"):
            got = {w: {"s": [], "cpu": [], "measured": []} for w in ("this", "base")}
            for _ in range(runs):
                for who, exe in (("this", envlight), ("base", baseline)):
                    for flag in ("--no-error", None):
                        with tempfile.TemporaryDirectory() as out:
                            j, cpu = run(exe, ["prefilter", path, "-o", out, "--json",
                                               "--quiet", "--layout", layout] + extra +
                                         ([flag] if flag else []))
                        if flag:
                            got[who]["s"].append(j["seconds"])
                            got[who]["cpu"].append(cpu)
                        else:
                            got[who]["measured"].append(cpu)
            med = {w: {k: statistics.median(v) for k, v in got[w].items()} for w in got}
            t, b = med["this"], med["base"]
            ratios[layout].append(t["cpu"] / b["cpu"])
            lines.append("| %s | %s | %.2f / %.2f | %.2f | %.3f / %.3f | %.2f / %.2f |" % (
                name, layout, t["cpu"], b["cpu"], t["cpu"] / b["cpu"], t["s"], b["s"],
                t["measured"] - t["cpu"], b["measured"] - b["cpu"]))
            print("  timing %s %s done (load %s)" % (layout, name, load_average()),
                  file=sys.stderr)
    return lines, ratios


def irradiance_cubes(envlight, baseline, name, path, extra, runs):
    """CPU of the irradiance cube alone at 32- and 128-texel faces, both builds, --no-error."""
    lines = ["| map | face | CPU s: this / baseline | ratio |", "|---|---|---|---|"]
    for face in ("32", "128"):
        cpu = {"this": [], "base": []}
        for _ in range(runs):
            for who, exe in (("this", envlight), ("base", baseline)):
                with tempfile.TemporaryDirectory() as out:
                    _, c = run(exe, ["prefilter", path, "-o", out, "--json", "--quiet",
                                     "--no-error", "--irradiance", "--layout", "cube",
                                     "--irradiance-size", face] + extra)
                cpu[who].append(c)
        t, b = statistics.median(cpu["this"]), statistics.median(cpu["base"])
        lines.append("| %s | %s | %.3f / %.3f | %.2f |" % (name, face, t, b, t / b))
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--docs", help="write DIR/texel_bench.md")
    ap.add_argument("--baseline", help="another build's envlight, timed against this one")
    ap.add_argument("--runs", type=int, default=3, help="timed runs of each build (median)")
    ap.add_argument("--timed", type=int, default=0,
                    help="time only the first N maps (default: all)")
    ap.add_argument("envlight")
    ap.add_argument("maps", nargs="+")
    a = ap.parse_args()
    command = "scripts/texel_bench.py " + " ".join(sys.argv[1:])
    date, load0, t0 = time.strftime("%Y-%m-%dT%H:%M:%S"), load_average(), time.time()
    tmp = tempfile.mkdtemp()
    try:
        maps = [resolve(m, tmp, a.envlight) for m in a.maps]
        out = []
        worst = {}
        for layout, title in (("cube", "Cube faces (irradiance 32-texel faces, the chain "
                                       "256 .. 16: `--layout cube`)"),
                              ("latlong", "Lat-long maps (irradiance 64 x 32, the chain "
                                          "512 .. 64: the default layout)")):
            lines, every = accuracy(a.envlight, maps, layout)
            out += ["## " + title, "", "Per-texel RMS / worst, % (** beyond 0.5 / 2); the "
                    "mean-relative figures of design.md, %, at the right.", ""] + lines + [""]
            for kind in ("irradiance", "specular"):
                sel = [e for e in every if (e[1] == "irradiance") == (kind == "irradiance")]
                r, w = max(sel, key=lambda e: e[2]), max(sel, key=lambda e: e[3])
                worst[(layout, kind)] = (r, w)
                out.append("- %s, %s: largest RMS %.3f %% (%s, %s), largest worst %.3f %% "
                           "(%s, %s); %d of %d products within 0.5 %% / 2 %%." % (
                               layout, kind, 100 * r[2], r[0], r[1], 100 * w[3], w[0], w[1],
                               sum(e[2] <= RMS_BOUND and e[3] <= WORST_BOUND for e in sel),
                               len(sel)))
            out.append("")
        if a.baseline:
            lines, ratios = timings(a.envlight, a.baseline, maps[:a.timed or len(maps)],
                                    a.runs)
            out += ["## Seconds against the baseline (`%s`), median of %d runs" % (
                a.baseline, a.runs), "", "CPU: the whole `--no-error` process (user + sys: "
                "reading the map and the products; the machine is shared, so CPU, not wall "
                "time, is compared). Products: prefilter.json's `seconds`, the library's wall "
                "clock (inflated by the load). The errors' CPU: a run with the error measures "
                "less the run without (this build measures every texel's error too).", ""] + \
                lines + [""]
            for layout, r in ratios.items():
                out.append("- %s: CPU %.2f-%.2fx the baseline's (median %.2fx)."
                           % (layout, min(r), max(r), statistics.median(r)))
            out += ["", "The irradiance cube alone (`--irradiance --layout cube`, `--no-error`), "
                    "median of %d runs: the split method's tree costs per texel." % a.runs, ""]
            out += irradiance_cubes(a.envlight, a.baseline, *maps[0], a.runs)
            out.append("")
        minutes = (time.time() - t0) / 60
        head = ["# Per-texel accuracy of the prefiltered maps", "",
                "Written by `%s` on %s; load average %s before, %s after; %d cores, %s; took "
                "%.1f min." % (command, date, load0, load_average(), os.cpu_count(),
                               platform.machine(), minutes),
                "How to read it: [design.md](design.md), \"Error measures\" (the per-texel "
                "error), and [accuracy.md](accuracy.md), \"Per-texel accuracy\".", ""]
        text = "\n".join(head + out)
        print(text)
        if a.docs:
            path = os.path.join(a.docs, "texel_bench.md")
            with open(path + ".tmp", "w") as f:
                f.write(text)
            os.replace(path + ".tmp", path)
    finally:
        shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
