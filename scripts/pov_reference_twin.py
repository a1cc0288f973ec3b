#!/usr/bin/env python3
"""The POV-Ray scene bench's reference against itself: its own noise, and the picked recipe's
error with that noise taken out.

The scene bench (scripts/scene_bench.py --host pov) scores the picked include against a POV-Ray
reference whose bounce is radiosity at count 800: a noisy estimate. This script renders that
reference again for scenes (a) and (b) of a bench run with the radiosity's count one less (799;
same lights, same bias: another draw of its noise. POV-Ray takes each sample's directions from
a table at a running index, in the order the render threads make the samples: the same settings
twice already draw afresh, as much as another count or pool, docs/pov_scenes.md) and states,
per object (the bench's id masks less the pixels on a sun's shadow edge, as the bench scores):
  twin  = relative RMS of Y_twin - Y_ref (luminance, relative to the reference's mean), and the
          twin's bias (mean Y_twin / mean Y_ref - 1: near 0 when the two differ by noise only);
  noise = twin / sqrt(2): the reference's own RMS noise (two independent draws of equal noise
          s differ by s sqrt(2));
  error = the picked include's relative RMS error against the reference, as the bench measures
          it (its stored images), and net = sqrt(max(0, error^2 - noise^2)): the include's
          error against the noise-free reference, since the reference's noise adds to it in
          quadrature (it is independent of the include's).
A glossy object is scored with the reference's highlight pass added (deterministic lights: no
noise of its own), as the bench does.

  scripts/pov_reference_twin.py --tmp DIR [--maps m1,m2] [--json OUT] [--docs DIR]
  scripts/pov_reference_twin.py --report-from JSON --docs DIR   (the report again, no render)

--tmp: a bench run's work folder (its --tmp), holding per map full.pfm, sun.inc and images.npz;
the twin's files go in each map's folder `twin`, the bench run's own files are only read.
"""
import argparse
import datetime
import json
import math
import os
import shutil
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import scene_bench_pov as S  # noqa: E402
from scene_bench import write_atomic  # noqa: E402

SCENES = ("a", "b")
TWIN_COUNT = S.REFERENCE_RADIOSITY["count"] - 1


def run_map(name, d, log):
    """{scene: {"objects": {object: figures}, "cpu_seconds": the twin's}} for one map."""
    import numpy as np
    images = np.load(os.path.join(d, "images.npz"))
    work = os.path.join(d, "twin")
    os.makedirs(work, exist_ok=True)
    px, dw = S.map_pixels(d)
    radiosity = dict(S.REFERENCE_RADIOSITY, count=TWIN_COUNT)
    sun_light = None
    if os.path.exists(os.path.join(d, "sun.inc")):
        shutil.copy(os.path.join(d, "sun.inc"), work)
        sun_light = '#include "sun.inc"\nEnvLight_Place_Lights()\n'
    out = {}
    for scene in SCENES:
        if "picked|%s" % scene not in images:
            continue
        spec = S.SCENES[scene]
        lighting, _, _ = S.reference_lighting(work, px, dw, S.BRIGHT_LIGHTS, S.BOUNCE_LIGHTS,
                                              radiosity, spec["sky"])
        twin, _, cpu, _ = S.reference_render(lighting, lambda text: S.render(
            work, scene, text, S.IMAGE, S.reference_textures(scene)))
        ref = images["reference-no-highlights|%s" % scene]
        scored = images["reference|%s" % scene]
        picked = images["picked|%s" % scene]
        masks = S.object_masks(work, scene, S.IMAGE)
        edges = S.sun_edges(S.sun_occluded(work, scene, sun_light, S.IMAGE), scored, masks)
        objs = {}
        for o, m in masks.items():
            k = m & ~edges[o]
            t = S.rel_rms(twin[k], ref[k])
            e = S.rel_rms(picked[k], scored[k])
            noise = t / math.sqrt(2)
            objs[o] = dict(pixels=int(k.sum()), twin=float(t), twin_bias=float(
                S.bias(twin[k], ref[k])), noise=float(noise), error=float(e),
                net=float(math.sqrt(max(0.0, e * e - noise * noise))))
        out[scene] = dict(objects=objs, cpu_seconds=cpu)
        log("%s (%s): twin %.0f s CPU; %s" % (name, scene, cpu, "  ".join(
            "%s: noise %.2f %% (twin bias %+.2f), picked %.2f -> net %.2f %%" % (
                o, 100 * v["noise"], 100 * v["twin_bias"], 100 * v["error"], 100 * v["net"])
            for o, v in objs.items())))
    return out


def report(result):
    """docs/pov_reference_twin.md."""
    L = ["# POV-Ray scene bench: the reference's own noise",
         "", "Written by `scripts/pov_reference_twin.py` (its docstring has the method) on %s; "
         "command: `%s`; load %s, %.0f s." % (result["date"], result["command"],
                                              result["load_average"], result["seconds"]),
         "", "Cells: the reference's RMS noise %% (its twin at radiosity count %d against it, "
         "over sqrt 2) / the picked include's error %% against the reference as the bench "
         "measured it / the same with the reference's noise taken out (net). Objects: the "
         "bench's, the glossy sphere with its highlights." % TWIN_COUNT, ""]
    target = 100 * S.TARGET_ERROR
    for scene in SCENES:
        objs = [o for o, _ in S.SCENES[scene]["objects"]]
        rows = [(m, v[scene]["objects"]) for m, v in result["maps"].items() if scene in v]
        if not rows:
            continue
        L += ["## Scene (%s)" % scene, "",
              "| map | " + " | ".join(objs) + " | twin bias % (worst) |",
              "|---|" + "---|" * len(objs) + "---|"]
        for m, ob in rows:
            L.append("| %s | %s | %+.2f |" % (m, " | ".join(
                "%.2f / %.2f / %.2f" % (100 * ob[o]["noise"], 100 * ob[o]["error"],
                                        100 * ob[o]["net"]) for o in objs),
                100 * max((ob[o]["twin_bias"] for o in objs), key=abs)))

        def med(o, key):
            return 100 * S._median(ob[o][key] for _, ob in rows)
        L += ["", "Median over the %d maps: %s." % (len(rows), "; ".join(
            "%s noise %.2f %%, error %.2f %%, net %.2f %%" % (o, med(o, "noise"),
                                                             med(o, "error"), med(o, "net"))
            for o in objs)),
              "Every object and the plane within %.0f %%: %d of %d maps as measured, %d net of the "
              "reference's noise." % (target, sum(all(ob[o]["error"] <= S.TARGET_ERROR
                                                      for o in objs) for _, ob in rows),
                                      len(rows), sum(all(ob[o]["net"] <= S.TARGET_ERROR
                                                         for o in objs) for _, ob in rows)),
              ""]
    return "\n".join(L) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tmp", help="a scene bench run's work folder")
    p.add_argument("--report-from", metavar="JSON", help="write the report of an earlier run")
    p.add_argument("--maps", default="", help="only these maps (by name)")
    p.add_argument("--envlight", default=os.path.join(ROOT, "build", "envlight"))
    p.add_argument("--library", default=os.path.join(ROOT, "build", "libenvlight.so"))
    p.add_argument("--json", help="write the results as JSON")
    p.add_argument("--docs", help="write DIR/pov_reference_twin.md (and .json)")
    args = p.parse_args()
    if args.report_from:
        if not args.docs:
            p.error("--report-from needs --docs")
        with open(args.report_from) as f:
            write_report(json.load(f), args.docs)
        return
    if not args.tmp:
        p.error("--tmp is required")
    S.setup(os.path.abspath(args.envlight), os.path.abspath(args.library),
            os.path.abspath(args.tmp))
    want = [m for m in args.maps.split(",") if m]
    result = dict(command="scripts/pov_reference_twin.py " + " ".join(sys.argv[1:]),
                  date=datetime.date.today().isoformat(), twin_count=TWIN_COUNT,
                  load_average="%.1f" % os.getloadavg()[0], maps={})
    t0 = time.time()
    for name in sorted(os.listdir(args.tmp)):
        d = os.path.join(args.tmp, name)
        if (want and name not in want) or not os.path.exists(os.path.join(d, "images.npz")):
            continue
        result["maps"][name] = run_map(name, d, S._log)
    result["load_average"] += "-%.1f" % os.getloadavg()[0]
    result["seconds"] = time.time() - t0
    text = json.dumps(result, indent=1) + "\n"
    for path in ([args.json] if args.json else []) + (
            [os.path.join(args.docs, "pov_reference_twin.json")] if args.docs else []):
        write_atomic(path, text)
    if args.docs:
        write_report(result, args.docs)


def write_report(result, docs):
    write_atomic(os.path.join(docs, "pov_reference_twin.md"), report(result))


if __name__ == "__main__":
    main()
