#!/usr/bin/python3
"""Render time and diffuse error of the generated includes in POV-Ray 3.7, as in
README.md (section POV-Ray): a white diffuse sphere (orthographic, SIZE x SIZE, no anti-aliasing, +FH)
lit by `envlight pov` with lights only, lights + SH ambient and lights + hemispheric
ambient; error = relative RMS of luminance over the sphere's pixels against the exact
irradiance E(n) / pi (the library's brute-force integrator). Also the reference: the HDR
itself as a sky_sphere under POV-Ray radiosity (EnvLight_Sky() with --order -1 --no-place).

Usage (from the build folder):
  ENVLIGHT=./envlight ENVLIGHT_LIBRARY=./libenvlight.so /usr/bin/python3 \
      ../povray_include/examples/measure.py [MAP.hdr ...]      ('-' = the built-in sky)
"""
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests"))
os.environ.setdefault("ENVL_SOURCE_DIR", os.path.join(HERE, "..", ".."))
import numpy as np  # noqa: E402
import py_pov as P  # noqa: E402

SIZE = 256
WIDTH = 512
TMP = os.environ.get("ENVL_TEST_TMP", "/tmp/envl_pov_measure")

RADIOSITY = """#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0
  radiosity { pretrace_start 0.08 pretrace_end 0.004 count %d nearest_count 20
              error_bound 0.3 recursion_limit 1 brightness 1 always_sample off } }
#include "env.inc"
camera { orthographic location <0, 0, -10> look_at <0, 0, 0> right x * 2.2 up y * 2.2 }
sphere { 0, 1 pigment { rgb 1 } finish { diffuse 1 ambient 0 emission 0 } }
"""


def one(src, exact_path, opts, texture, scene=None):
    d = P.tmpdir("measure")
    t0 = time.time()
    P.envlight("pov", *src, *opts, "-o", "env.inc", "--quiet", cwd=d)
    t_gen = time.time() - t0
    inc = P.parse_include(os.path.join(d, "env.inc"))
    t0 = time.time()
    img, _ = P.render(scene or P.SPHERE_SCENE % ('"env.inc"', texture), d, size=SIZE)
    t_pov = time.time() - t0
    mask, n = P.sphere_normals(SIZE)
    exact = P.exact_irradiance(exact_path, WIDTH, n[mask]) / math.pi
    y = P.lum(img[mask])
    ye = P.lum(exact)
    err = math.sqrt(np.mean((y - ye) ** 2)) / ye.mean()
    return inc["error"], err, t_gen, t_pov


def main():
    maps = sys.argv[1:] or ["-", P.ROOITOU]
    os.makedirs(TMP, exist_ok=True)
    P.TMP = TMP
    P.ENVLIGHT = os.path.abspath(P.ENVLIGHT)  # envlight runs inside the work folders
    plain = "pigment { rgb 1 } finish { diffuse 1 ambient 0 emission 0 }"
    amb = "EnvLight_Diffuse_Texture(<1, 1, 1>)"
    print("| map | method | N | ambient | reported error % | sphere error % | envlight s | POV-Ray s |")
    print("|---|---|---|---|---|---|---|---|")
    for m in maps:
        if m == "-":
            name = "built-in sky"
            exact_path = os.path.join(TMP, "sky.pfm")
            P.envlight("convert", "-", exact_path, "--sky-width", str(WIDTH))
            src = [exact_path]
        else:
            if not os.path.exists(m):
                print("SKIP: %s absent" % m)
                continue
            name = os.path.basename(m)
            exact_path = m
            src = [m, "--width", str(WIDTH)]
        for method, counts in (("fit", (1, 4, 16)), ("median", (16, 64)), ("variance", (16,))):
            for n in counts:
                for ambient in ("none", "sh", "hemi"):
                    if method != "fit" and ambient == "hemi":
                        continue
                    opts = ["-n", str(n), "--method", method, "--ambient", ambient]
                    r = one(src, exact_path, opts, plain if ambient == "none" else amb)
                    print("| %s | %s | %d | %s | %.3f | %.3f | %.2f | %.2f |"
                          % (name, method, n, ambient, 100 * r[0], 100 * r[1], r[2], r[3]))
                    sys.stdout.flush()
        for count in (100, 400):
            r = one(src, exact_path, ["-n", "1", "--ambient", "none", "--sky", "--no-place",
                                      "--sky-image", os.path.join(TMP, "measure", "sky.hdr")],
                    None, scene=RADIOSITY.replace('#include "env.inc"',
                                                  '#include "env.inc"\nEnvLight_Sky()') % count)
            print("| %s | radiosity of the HDR sky (count %d) | - | - | - | %.3f | - | %.2f |"
                  % (name, count, 100 * r[1], r[3]))


if __name__ == "__main__":
    main()
