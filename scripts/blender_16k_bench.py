#!/usr/bin/env python3
"""Create Lights on large world images in Blender (issue 29): time and peak memory.

For each width W (default 1024 4096 8192 16384) a W x W/2 lat-long .exr made from MAP by
`envlight convert MAP OUT --size W` (kept in --work, outside the repository, and reused), then
one fresh Blender per image and add-on zip (scripts/blender_16k_run.py, background mode):
Blender's own footprint with the image loaded, then the add-on reading the image alone, the
library reading the image's file itself (envlight.load, for comparison), and the Create Lights
button, each with its seconds and the process's peak resident memory above Blender's own;
for the button also when its progress callback first ran and how far the bar was when the
image had been read. With --baseline-zip OTHER.zip (another add-on, e.g. main's) the two
add-ons run alternately on each image, the ratio of their seconds in the table.

  scripts/blender_16k_bench.py [--blender CMD] [--zip ZIP] [--baseline-zip ZIP] [--runs N]
                               [--sizes W ...] [--engines E ...] [--map MAP] [--format exr|hdr] [--work DIR]
                               [--docs DIR]

Memory is in MiB and, for what the add-on adds, also in copies of the image as Blender holds
it (W x H x 4 float32 = 16 W H bytes). Not in the test suite: 16K needs about 8 GB free and
minutes. With --docs DIR the report goes to DIR/blender_16k.md after a header (the command,
date, load average at the start and end, machine); it is printed either way."""
import argparse
import datetime
import json
import os
import shlex
import shutil
import subprocess
import sys
import time

from bench_report import machine
from scene_bench import write_atomic  # the one atomic writer of the benchmarks

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.environ.get("ENVL_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data"))
BLENDER4 = "/var/cache/envlight/trixie-root/run-blender"
MIB = 1024.0 * 1024.0


def parse_args(argv):
    p = argparse.ArgumentParser(prog="blender_16k_bench.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--blender", default=BLENDER4, help="Blender command (default: 4.3's)")
    p.add_argument("--zip", help="the add-on zip (default: made from this tree and build/)")
    p.add_argument("--baseline-zip", help="another add-on zip run alternately on each image")
    p.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096, 8192, 16384])
    p.add_argument("--engines", nargs="+", default=["BLENDER_EEVEE_NEXT", "CYCLES"],
                   help="render engines, each a scene of its own (default: EEVEE-Next, Cycles)")
    p.add_argument("--runs", type=int, default=1,
                   help="runs of each add-on on each image, alternating (default 1)")
    p.add_argument("--map", default=os.path.join(DATA, "latlong_hdri", "rooitou_park_1k.hdr"))
    p.add_argument("--envlight", default=os.path.join(ROOT, "build", "envlight"))
    p.add_argument("--format", choices=("exr", "hdr"), default="exr",
                   help="the images' format (the add-on's library reads no .exr itself)")
    p.add_argument("--work", default="/var/tmp/envlight_blender_16k")
    p.add_argument("--docs", help="write DIR/blender_16k.md")
    return p.parse_args(argv)


def image_of_width(args, w):
    out = os.path.join(args.work, "%s_%d.%s" % (os.path.splitext(os.path.basename(
        args.map))[0], w, args.format))
    if not os.path.exists(out):
        subprocess.run([args.envlight, "convert", args.map, out, "--size", str(w), "--quiet"],
                       check=True)
    return out


def run(args, zip_path, image, tag, engine):
    folder = os.path.join(args.work, "run_%s_%s_%s" % (tag, engine, os.path.basename(image)))
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    spec = {"zip": zip_path, "image": image, "file_read": True, "engine": engine,
            "out": os.path.join(folder, "result.json")}
    with open(os.path.join(folder, "spec.json"), "w") as f:
        json.dump(spec, f)
    env = {k: v for k, v in os.environ.items() if k not in ("ENVLIGHT_LIBRARY", "PYTHONPATH")}
    env.update(BLENDER_USER_SCRIPTS=os.path.join(folder, "scripts"),
               BLENDER_USER_CONFIG=os.path.join(folder, "config"),
               ENVL_BLENDER4_BINDS="%s:%s" % (ROOT, args.work))
    cmd = shlex.split(args.blender) + ["-b", "--factory-startup", "--python",
                                       os.path.join(HERE, "blender_16k_run.py"), "--",
                                       os.path.join(folder, "spec.json")]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=3600)
    with open(os.path.join(folder, "blender.log"), "w") as f:
        f.write(p.stdout + p.stderr)
    if p.returncode != 0 or "ENVLIGHT_16K_DONE" not in p.stdout:
        sys.exit("blender_16k_bench: %s on %s failed (exit %d); log %s:\n%s"
                 % (tag, image, p.returncode, os.path.join(folder, "blender.log"),
                    (p.stdout + p.stderr)[-3000:]))
    with open(spec["out"]) as f:
        return json.load(f)


def copies(mib, w, h):
    """MiB as copies of the image as Blender holds it (RGBA float32)."""
    return mib * MIB / (16.0 * w * h)


def median_run(runs):
    """The run of median button seconds (the lower middle one of an even count)."""
    return sorted(runs, key=lambda r: r["button"]["seconds"])[(len(runs) - 1) // 2]


def row(tag, runs, ratios=None):
    r = median_run(runs)
    w, h = r["size"]
    own = r["rss_image"] - r["rss_start"]
    read = r["read"]["peak"] - r["rss_image"]
    f = r["file_read"]
    file_cell = "%.2f s, +%.0f (%.2f)" % (f["seconds"], f["peak"] - r["rss_image"], copies(
        f["peak"] - r["rss_image"], w, h)) if "peak" in f else "cannot (no OpenEXR)"
    button = r["button"]["peak"] - r["rss_image"]
    prog = r["button"]["progress"]
    first = prog[0][0] if prog else float("nan")
    ratio = "%.2f" % sorted(ratios)[(len(ratios) - 1) // 2] if ratios else "1"
    if len(runs) > 1:
        ratio += "; runs %s s" % " ".join("%.1f" % x["button"]["seconds"] for x in runs)
    return ("| %d x %d | %s | %.0f | %.2f s, +%.0f (%.2f) | %s | "
            "%.2f s (%s), +%.0f (%.2f) | %.2f | %.3f s | %s |"
            % (w, h, tag, own, r["read"]["seconds"], read, copies(read, w, h),
               file_cell, r["button"]["seconds"],
               ratio, button, copies(button, w, h), r["button"]["sampled_peak_progress"], first,
               " ".join("%.2f@%.1fs" % (v, t) for t, v in prog[:3])))


def main(argv):
    args = parse_args(argv)
    os.makedirs(args.work, exist_ok=True)
    t0 = time.time()
    load0 = os.getloadavg()
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    zip_path = args.zip
    if not zip_path:
        zip_path = os.path.join(args.work, "envlight_addon.zip")
        subprocess.run([sys.executable, os.path.join(HERE, "blender_addon_zip.py"),
                        "--build-dir", os.path.join(ROOT, "build"), "-o", zip_path],
                       check=True, capture_output=True)
    results = []
    for engine in args.engines:
        for w in args.sizes:
            image = image_of_width(args, w)
            pairs = []
            for k in range(args.runs):  # alternating: both add-ons see the same load
                base = run(args, args.baseline_zip, image, "baseline%d" % k, engine) \
                    if args.baseline_zip else None
                pairs.append((base, run(args, zip_path, image, "addon%d" % k, engine)))
            results.append((engine, pairs))
            print("blender_16k_bench: %s %d done (load %.2f)"
                  % (engine, w, os.getloadavg()[0]), file=sys.stderr)
    load1 = os.getloadavg()
    lines = ["# Create Lights on large world images in Blender", "",
             "Written by `scripts/blender_16k_bench.py` (do not edit by hand; run it again to "
             "update this file).", "",
             "- command: `%s`" % " ".join(shlex.quote(a) for a in ["scripts/blender_16k_bench.py"]
                                          + argv),
             "- date: %s; took %.0f s" % (date, time.time() - t0),
             "- load average at start / end: %s / %s" % (
                 " ".join("%.2f" % v for v in load0), " ".join("%.2f" % v for v in load1)),
             "- machine: %s; Blender %s (background), envlight %s" % (
                 machine(), results[0][1][0][1]["blender"], results[0][1][0][1]["envlight"]),
             "- image: %s resampled by `envlight convert --size W` (float .%s)"
             % (os.path.basename(args.map), args.format), "",
             "Memory in MiB of resident memory (VmRSS / VmHWM); in brackets as copies of the "
             "image as Blender holds it (W x H RGBA float32). *Blender's own*: the process "
             "with the image loaded less Blender started with the add-on. The other columns: "
             "seconds, and the peak above Blender's own: *read* the add-on reading the world "
             "image into the library (core.read_source), *file* the library reading the "
             "image's file itself (envlight.load), *button* the whole Create Lights (with the "
             "ratio of its seconds to the baseline add-on's on the same image, the median of the "
             "ratios of the pairs run one after the other; the row is the run of median "
             "seconds, all runs' seconds beside the ratio). *Bar at the "
             "peak*: the progress value when the button's resident memory, sampled every "
             "20 ms, was highest (up to 0.2 the reading; 0.2-0.35 the suns; to 0.6 the fit; "
             "0.6-0.75 its results; then the lamps, images and nodes in Blender). *First "
             "progress*: seconds from the button's start to its first progress call; then the "
             "first calls as value@seconds.", "",
             "| engine | image | add-on | Blender's own | read | file | button | "
             "bar at the peak | first progress | progress |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for engine, pairs in results:
        news = [n for _, n in pairs]
        if pairs[0][0]:
            lines.append("| %s %s" % (engine, row("baseline", [b for b, _ in pairs])))
            lines.append("| %s %s" % (engine, row("this", news, [
                n["button"]["seconds"] / b["button"]["seconds"] for b, n in pairs])))
        else:
            lines.append("| %s %s" % (engine, row("this", news)))
    lines += ["", "Recipes: " + "; ".join("%s %d: %s, %d lamps" % (
        e, p[0][1]["size"][0], p[0][1]["button"]["recipe"], p[0][1]["button"]["lamps"])
        for e, p in results)]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.docs:
        write_atomic(os.path.join(args.docs, "blender_16k.md"), text)
        with open(os.path.join(args.work, "results.json"), "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1:])
