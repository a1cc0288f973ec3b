#!/usr/bin/env python3
"""`envlight lights MAP -n 4` (fit + order-2 remainder) before and after a change, in one run:
per map the diffuse error (design.md's measure), the error at the up normal +Z against the
brute force, the lights as Blender lamps over the residual (RMS over the 1024 normals, and at
+Z), the residual's structure (largest chromaticity change, largest contrast added per degree:
tests/fit_measures.py) and the fit's seconds on one thread (the least of --runs runs, the two
libraries alternating), with their ratio. Writes docs/fit_bench.md with --docs DIR.

    nice -n 10 /usr/bin/python3 scripts/fit_bench.py --before OLD/libenvlight.so \\
        --after build/libenvlight.so [--docs docs] [--runs 3] MAP...   (MAP '-': the sky)
"""
import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def worker(lib, path, runs):
    """In a process of its own (one library per process): the figures of one map, as JSON."""
    os.environ["ENVLIGHT_LIBRARY"] = lib
    sys.path[:0] = [os.path.join(ROOT, "py_shim"), os.path.join(ROOT, "tests")]
    import envlight
    import fit_measures as fm
    opts = {}
    if "@" in path:  # MAP@rotate=90, MAP@width=2048
        path, spec = path.split("@")
        key, value = spec.split("=")
        opts[key] = float(value) if key == "rotate" else int(value)
    env = envlight.sky() if path == "-" else envlight.load(path, threads=1, **opts)
    with env:
        seconds = []
        for _ in range(runs):
            with env.lights(4, measure=False, residual=False) as res:
                seconds.append(res.summary["seconds"])
        with env.lights(4) as res:
            lamps_rms, lamps_up = fm.lamps_errors(env, res)
            colour, contrast = fm.residual_structure(env.pixels(), res.residual)
            return {"diffuse": res.summary["diffuse_error"], "up": fm.up_error(env, res),
                    "lamps_rms": lamps_rms, "lamps_up": lamps_up, "colour": colour,
                    "contrast": contrast, "seconds": min(seconds),
                    "angle": max([math.degrees(l.angle) for l in res.lights] or [0.0])}


def run(lib, path, runs):
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", lib,
                          "--runs", str(runs), path], capture_output=True, text=True)
    if out.returncode:
        raise SystemExit("%s on %s: %s" % (lib, path, out.stderr.strip()))
    return json.loads(out.stdout.strip().splitlines()[-1])


def name_of(path):
    return "built-in sky" if path == "-" else os.path.basename(path).replace("@", " ")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="+")
    ap.add_argument("--before", help="the baseline libenvlight.so")
    ap.add_argument("--after", default=os.path.join(ROOT, "build", "libenvlight.so"))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--docs", help="write DIR/fit_bench.md")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        print(json.dumps(worker(a.worker, a.maps[0], a.runs)))
        return 0
    load0 = os.getloadavg()
    rows = []
    for path in a.maps:
        before = run(a.before, path, a.runs) if a.before else None
        after = run(a.after, path, a.runs)
        rows.append((name_of(path), before, after))
        b = before or {}
        print("%-40s diffuse %s -> %.3f %%  up %s -> %+.3f %%  s %s -> %.3f"
              % (name_of(path), "%.3f" % (100 * b["diffuse"]) if before else "-",
                 100 * after["diffuse"], "%+.3f" % (100 * b["up"]) if before else "-",
                 100 * after["up"], "%.3f" % b["seconds"] if before else "-", after["seconds"]),
              flush=True)
    load1 = os.getloadavg()
    if not a.docs:
        return 0

    def pct(v, signed=False):
        return ("%+.3f" if signed else "%.3f") % (100 * v)

    lines = ["# The fit: before and after, every map", "",
             "Written by `%s` on %s, load average %.1f %.1f %.1f at the start and %.1f %.1f %.1f "
             "at the end, %s (%s, %d cores shared with other jobs)." % (
                 " ".join(["/usr/bin/python3", "scripts/fit_bench.py"] + sys.argv[1:]),
                 datetime.datetime.now().strftime("%Y-%m-%d %H:%M"), *load0, *load1,
                 platform.machine(), platform.processor() or "cpu", os.cpu_count()), "",
             "`envlight lights MAP -n 4` (fit + order-2 SH remainder). *diffuse*: design.md's "
             "relative RMS error; *up*: the lights + remainder at the normal +Z against "
             "envl_irradiance_exact; *lamps*: each light a lamp of irradiance rgb (1 - w / 4 pi) "
             "at normal incidence along it (a Blender sun) over the residual map's exact "
             "irradiance, relative RMS over the 1024 normals / at +Z; *colour*: the residual's "
             "largest change of a pixel's chromaticity; *contrast*: its largest local contrast "
             "added per degree (docs/methods.md, \"The fit's take\"); *s*: the fit's seconds on "
             "one thread, the least of %d runs, the libraries alternating; *ratio*: after / "
             "before." % a.runs, "",
             "| map | diffuse % before | after | up % before | after | lamps RMS % before "
             "| after | lamps up % before | after | colour before | after | contrast before "
             "| after | s before | after | ratio |",
             "|---|" + "---|" * 16]
    for name, b, f in rows:
        b = b or {k: float("nan") for k in f}
        lines.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %.2g | %.2g | %.2f | %.2f "
                     "| %.3f | %.3f | %.2f |" % (
                         name, pct(b["diffuse"]), pct(f["diffuse"]), pct(b["up"], 1),
                         pct(f["up"], 1), pct(b["lamps_rms"]), pct(f["lamps_rms"]),
                         pct(b["lamps_up"], 1), pct(f["lamps_up"], 1), b["colour"], f["colour"],
                         b["contrast"], f["contrast"], b["seconds"], f["seconds"],
                         f["seconds"] / b["seconds"]))
    worst = max(rows, key=lambda r: r[2]["diffuse"])
    ratios = sorted(f["seconds"] / b["seconds"] for _, b, f in rows if b)
    lines += ["", "After: diffuse error %.3f-%.3f %% (worst %s), |up| at most %.3f %%; "
              "seconds after / before: median %.2f (%.2f-%.2f)." % (
                  100 * min(r[2]["diffuse"] for r in rows), 100 * worst[2]["diffuse"], worst[0],
                  100 * max(abs(r[2]["up"]) for r in rows),
                  ratios[len(ratios) // 2] if ratios else float("nan"),
                  ratios[0] if ratios else float("nan"), ratios[-1] if ratios else float("nan"))]
    os.makedirs(a.docs, exist_ok=True)
    with open(os.path.join(a.docs, "fit_bench.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
