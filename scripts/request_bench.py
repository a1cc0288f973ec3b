#!/usr/bin/python3
"""Compute only what a scene calls for (README "Compute only what a scene calls for"): the
time of one envl_compute request for "everything" against a few typical requests, on the
2048 x 1024 built-in sky, with the counters that show the sharing. The map's mip pyramid is
dropped before each request (each starts cold); time = the request's own `seconds` (error
measures excluded), the minimum of RUNS runs. Prints a markdown table.
Usage: PYTHONPATH=py_shim ENVL_LIBRARY=build/libenvlight.so scripts/request_bench.py [RUNS]"""
import argparse


def _runs(v):
    n = int(v)
    if n < 1:
        raise argparse.ArgumentTypeError("RUNS must be at least 1, not %d" % n)
    return n


# the arguments first: --help (or a bad RUNS) ends here, before the library is loaded
_ap = argparse.ArgumentParser(description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
_ap.add_argument("runs", nargs="?", type=_runs, default=3, metavar="RUNS",
                 help="runs of each request; the table shows the fastest (default 3)")
RUNS = _ap.parse_args().runs

import envlight as E  # noqa: E402

REQUESTS = [
    ("everything: diffuse SH + irradiance map + mirror + shadows (16 median-cut lights) + "
     "6-level chain + BRDF table",
     dict(diffuse=True, irradiance=True, mirror=True, chain=True, brdf=True, shadows=16)),
    ("diffuse ambient only (SH order 2)", dict(diffuse=True)),
    ("mirror background only", dict(mirror=True)),
    ("glossy at roughness 0.4 only", dict(roughness=[0.4])),
    ("glossy at 0.25 and 0.5 + diffuse", dict(roughness=[0.25, 0.5], diffuse=True)),
    ("6-level chain only", dict(chain=True)),
    ("6-level chain, the sun as lights", dict(chain=True, sun_lights=True)),
    ("shadows only (16 median-cut lights)", dict(shadows=16)),
]

m = E.sky(width=2048)
print("| request | seconds | levels | SH passes | pyramids |\n|---|---|---|---|---|")
for name, req in REQUESTS:
    best = None
    for _ in range(RUNS):
        E.lib.envl_envmap_drop_mips(m._handle())
        m.drop_caches()
        with m.prefilter(**req) as p:
            s = p.summary
        if best is None or s["seconds"] < best["seconds"]:
            best = s
    print(f"| {name} | {best['seconds']:.3f} | {best['specular_levels']} | "
          f"{best['sh_projections']} | {best['pyramids_built']} |")
