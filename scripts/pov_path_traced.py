#!/usr/bin/env python3
"""The POV-Ray scene bench's reference and picked renders against a path tracer (Cycles).

The scene bench (scripts/scene_bench.py --host pov) scores every recipe against a POV-Ray
reference: radiosity at count 800 for the map's dim part plus 1024 lights for its bright part,
validated on a lone sphere (docs/pov_scenes.md). That validation sees no occlusion. This script
renders scenes (a) and (b) of a bench run again in Cycles (scripts/pov_cycles_scene.py: the same
.pov file read into Blender, Lambertian surfaces of the same albedos, 64 diffuse bounces, no
denoising) and states, per object, how far the reference and the picked recipe's render are
from it:
  bias  = mean(Y) / mean(Y_cycles) - 1 over the object's pixels (luminance Y; the id masks of
          the bench, less their edge pixels);
  error = relative RMS of Y - Y_cycles over them, with Cycles' own noise taken out in
          quadrature (the noise of the mean of two renders of different seeds: (c1 - c2)^2 / 4
          per pixel) and that noise stated. The report gives it as the range one standard
          deviation of that estimate leaves (error_range): where Cycles' noise is larger than
          the error, Cycles cannot tell an RMS error of 0.5 % from one of 2 %.
A glossy object's highlights are POV-Ray's own (its finish's specular, from light sources: the
reference's bright lights give them too), which Cycles' Lambertian surface has not: the glossy
sphere of scene (a) is left out.
Before any figure, the geometry is checked: Cycles' id pass (each object an emission of one
channel) against the bench's POV-Ray id pass, the share of the object's pixels that agree.

  scripts/pov_path_traced.py --tmp DIR [--tmp DIR2 ...] [--maps m1,m2] [--samples N]
                             [--json OUT] [--docs DIR]

--tmp: a bench run's work folder (its --tmp), holding per map full.hdr and images.npz.
"""
import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import scene_bench_pov as S  # noqa: E402
from scene_bench import write_atomic  # noqa: E402

SCENES = ("a", "b")
SIZE = S.IMAGE


def erode(m):
    """The mask less its edge pixels (4-neighbourhood): on an object's outline Cycles' sphere, a
    mesh of 256 x 128 faces, is not quite POV-Ray's."""
    k = m.copy()
    k[1:] &= m[:-1]
    k[:-1] &= m[1:]
    k[:, 1:] &= m[:, :-1]
    k[:, :-1] &= m[:, 1:]
    return k


def cycles(blender, scene, hdr, out, samples=0, seed=0, ids=False):
    """Renders a bench scene in Cycles -> the image (H, W, 3) and the CPU seconds."""
    import numpy as np
    pov = os.path.join(S.EXAMPLES, S.SCENES[scene]["file"])
    args = [blender, "-b", "--factory-startup", "-P", os.path.join(HERE, "pov_cycles_scene.py"),
            "--", "--pov", pov, "--map", hdr, "--out", out, "--seed", str(seed),
            "--samples", str(max(samples, 1)), "--size", str(SIZE[0]), str(SIZE[1])]
    if ids:
        args.append("--ids")
    c0 = S.cpu_seconds()
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0 or not os.path.exists(out):
        sys.exit("pov_path_traced: Cycles failed on %s:\n%s" % (hdr, (r.stdout + r.stderr)[-3000:]))
    return np.load(out), S.cpu_seconds() - c0


def compare(img, c1, c2, mask):
    """(bias, error with the noise taken out, noise) of img against (c1 + c2) / 2 over mask."""
    import numpy as np
    y, a, b = S.P.lum(img)[mask], S.P.lum(c1)[mask], S.P.lum(c2)[mask]
    c = 0.5 * (a + b)
    mean = c.mean()
    noise2 = np.mean((a - b) ** 2) / 4
    rms2 = np.mean((y - c) ** 2)
    return (float(y.mean() / mean - 1), float(math.sqrt(max(0.0, rms2 - noise2)) / mean),
            float(math.sqrt(noise2) / mean))


def error_range(r, key):
    """(low, high) of an error with the noise taken out, one standard deviation apart: the
    estimate e^2 = mean(d^2) - mean(n^2) over N pixels of independent noise of variance s^2
    (relative to the mean) has a standard deviation of about 2 s^2 / sqrt(N) (each mean of
    squares of a Gaussian: var(x^2) = 2 s^4, and d^2 holds the noise once more)."""
    e2, u = r[key] ** 2, 2 * r["noise"] ** 2 / math.sqrt(r["pixels"])
    return math.sqrt(max(0.0, e2 - u)), math.sqrt(e2 + u)


def run_map(name, d, blender, samples, log):
    """The map's scenes against Cycles; its files (the id pass, Cycles' renders) go in
    d/path_traced, the bench run's own files are only read."""
    import numpy as np
    hdr = os.path.join(d, "full.hdr")
    images = np.load(os.path.join(d, "images.npz"))
    work = os.path.join(d, "path_traced")
    os.makedirs(work, exist_ok=True)
    out = {}
    for scene in SCENES:
        if "picked|%s" % scene not in images:
            continue
        spec = S.SCENES[scene]
        masks = S.object_masks(work, scene, SIZE)
        ids, _ = cycles(blender, scene, hdr, os.path.join(work, "ids_%s.npy" % scene), ids=True)
        agree = {o: float(np.mean(ids[..., ch][masks[o]] > 0.5)) for o, ch in spec["objects"]}
        c1, t1 = cycles(blender, scene, hdr, os.path.join(work, "cycles_%s_1.npy" % scene),
                        samples // 2, seed=1)
        c2, t2 = cycles(blender, scene, hdr, os.path.join(work, "cycles_%s_2.npy" % scene),
                        samples // 2, seed=2)
        ref = images["reference-no-highlights|%s" % scene]
        picked = images["picked|%s" % scene]
        objs = {}
        for o, _ in spec["objects"]:
            if o in spec["glossy"]:
                continue
            k = erode(masks[o])
            rb, re_, noise = compare(ref, c1, c2, k)
            pb, pe, _ = compare(picked, c1, c2, k)
            objs[o] = dict(pixels=int(k.sum()), id_agreement=agree[o], noise=noise,
                           reference_bias=rb, reference_error=re_, picked_bias=pb,
                           picked_error=pe)
        out[scene] = dict(objects=objs, cycles_cpu_seconds=t1 + t2, samples=samples)
        log("%s (%s): Cycles %d spp, %.0f s CPU; %s" % (name, scene, samples, t1 + t2, "  ".join(
            "%s: reference %+.2f %% (%.2f), picked %+.2f %% (%.2f); noise %.2f %%, ids %.1f %%"
            % (o, 100 * v["reference_bias"], 100 * v["reference_error"], 100 * v["picked_bias"],
               100 * v["picked_error"], 100 * v["noise"], 100 * v["id_agreement"])
            for o, v in objs.items())))
    return out


def report(result):
    """docs/pov_path_traced.md."""
    L = ["# POV-Ray scene bench: the reference and the picked recipe against a path tracer",
         "", "Written by `scripts/pov_path_traced.py` (its docstring has the method) on %s; "
         "command: `%s`; %s, Cycles at %d samples a pixel (two seeds), load %s." % (
             result["date"], result["command"], result["blender"], result["samples"],
             result["load_average"]),
         "", "Cells: bias % (mean over the object against Cycles), in brackets the relative "
         "RMS error % with Cycles' noise taken out, as the range one standard deviation of that "
         "estimate leaves (where Cycles' noise is above the error, a wide range: the bias is "
         "the measure there). `reference`: the scene bench's POV-Ray "
         "reference (its radiosity and lights, no highlights); `picked`: what `envlight pov "
         "--scene` picks (the scene bench's default row).", ""]
    for scene in SCENES:
        objs = [o for o, _ in S.SCENES[scene]["objects"] if o not in S.SCENES[scene]["glossy"]]
        L += ["## Scene (%s)" % scene, "",
              "| map | " + " | ".join("%s: reference | %s: picked" % (o, o) for o in objs)
              + " | Cycles noise % | ids agree % |",
              "|---|" + "---|---|" * len(objs) + "---|---|"]
        rows = []
        for m, v in result["maps"].items():
            if scene not in v:
                continue
            ob = v[scene]["objects"]
            cells = []
            for o in objs:
                r = ob[o]
                for who in ("reference", "picked"):
                    lo, hi = error_range(r, who + "_error")
                    cells.append("%+.2f (%.1f-%.1f)" % (100 * r[who + "_bias"], 100 * lo,
                                                        100 * hi))
            L.append("| %s | %s | %.2f | %.1f |" % (
                m, " | ".join(cells), 100 * max(r["noise"] for r in ob.values()),
                100 * min(r["id_agreement"] for r in ob.values())))
            rows.append(ob)
        if rows:
            L += ["", "Median over the maps:", ""]
            for o in objs:
                def med(key):
                    vals = sorted(r[o][key] for r in rows)
                    return vals[len(vals) // 2]
                L.append("- %s: reference bias %+.2f %%, error %.2f %%; picked bias %+.2f %%, "
                         "error %.2f %%" % (o, 100 * med("reference_bias"),
                                            100 * med("reference_error"),
                                            100 * med("picked_bias"), 100 * med("picked_error")))
            L.append("")
    return "\n".join(L) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tmp", action="append", required=True,
                   help="a scene bench run's work folder (repeatable)")
    p.add_argument("--maps", default="", help="only these maps (by name)")
    p.add_argument("--samples", type=int, default=512, help="Cycles samples a pixel, in all")
    p.add_argument("--blender", default="blender")
    p.add_argument("--envlight", default=os.path.join(ROOT, "build", "envlight"))
    p.add_argument("--library", default=os.path.join(ROOT, "build", "libenvlight.so"))
    p.add_argument("--json", help="write the results as JSON")
    p.add_argument("--docs", help="write DIR/pov_path_traced.md (and .json)")
    args = p.parse_args()
    S.setup(os.path.abspath(args.envlight), os.path.abspath(args.library),
            os.path.abspath(args.tmp[0]))
    want = [m for m in args.maps.split(",") if m]
    r = subprocess.run([args.blender, "--version"], capture_output=True, text=True)
    result = dict(command="scripts/pov_path_traced.py " + " ".join(sys.argv[1:]),
                  date=datetime.date.today().isoformat(),
                  blender=(r.stdout.splitlines() or ["Blender"])[0].strip(),
                  samples=args.samples, load_average="%.1f" % os.getloadavg()[0], maps={})
    t0 = time.time()
    for tmp in args.tmp:
        for name in sorted(os.listdir(tmp)):
            d = os.path.join(tmp, name)
            if (want and name not in want) or not os.path.exists(os.path.join(d, "images.npz")):
                continue
            result["maps"][name] = run_map(name, d, args.blender, args.samples, S._log)
    result["load_average"] += "-%.1f" % os.getloadavg()[0]
    result["seconds"] = time.time() - t0
    text = json.dumps(result, indent=1) + "\n"
    for path in ([args.json] if args.json else []) + (
            [os.path.join(args.docs, "pov_path_traced.json")] if args.docs else []):
        write_atomic(path, text)
    if args.docs:
        write_atomic(os.path.join(args.docs, "pov_path_traced.md"), report(result))


if __name__ == "__main__":
    main()
