#!/usr/bin/python3
"""Compute only what a scene calls for (docs/request_bench.md; how to read it: docs/accuracy.md,
"Compute only what a scene calls for"): the time of one envl_compute request for "everything"
against a few typical requests, on the 2048 x 1024 built-in sky, with the counters that show
the sharing. The map's mip pyramid is dropped before each request (each starts cold); time =
the request's own `seconds` (error measures excluded), the minimum of RUNS runs. Prints a
markdown table; with --docs DIR also writes it to DIR/request_bench.md after a header (the
command, date, load average, machine).
Usage: PYTHONPATH=py_shim ENVLIGHT_LIBRARY=build/libenvlight.so scripts/request_bench.py
       [--docs DIR] [RUNS]"""
import argparse
import datetime
import os
import sys
import tempfile
import time


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
_ap.add_argument("--docs", metavar="DIR",
                 help="also write the table to DIR/request_bench.md, after a header")
_args = _ap.parse_args()
RUNS = _args.runs

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

date = datetime.datetime.now().isoformat(timespec="seconds")
t0, load0 = time.time(), os.getloadavg()
m = E.sky(width=2048)
lines = ["| request | seconds | levels | SH passes | pyramids |", "|---|---|---|---|---|"]
print("\n".join(lines))
for name, req in REQUESTS:
    best = None
    for _ in range(RUNS):
        with m._use() as h:
            E.lib.envl_envmap_drop_mips(h)
        m.drop_caches()
        with m.prefilter(**req) as p:
            s = p.summary
        if best is None or s["seconds"] < best["seconds"]:
            best = s
    lines.append(f"| {name} | {best['seconds']:.3f} | {best['specular_levels']} | "
                 f"{best['sh_projections']} | {best['pyramids_built']} |")
    print(lines[-1])


def machine():
    cpu = ""
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "")
    except OSError:
        pass
    return "%s, %d cores" % (cpu or os.uname().machine, os.cpu_count() or 1)


if _args.docs:
    load1 = os.getloadavg()
    text = "\n".join([
        "# Compute only what a scene calls for", "",
        "Written by `PYTHONPATH=py_shim ENVLIGHT_LIBRARY=build/libenvlight.so "
        "scripts/request_bench.py %s` (do not edit by hand; run it again to update this file)."
        % " ".join(sys.argv[1:]), "",
        "- date: %s; took %.0f s" % (date, time.time() - t0),
        "- load average at start / end: %s / %s" % (" ".join("%.2f" % v for v in load0),
                                                    " ".join("%.2f" % v for v in load1)),
        "- machine: %s; libenvlight ABI %d" % (machine(), E.lib.envl_abi_version()),
        "- the 2048 x 1024 built-in sky; one `envl_compute` request per row, the map's mip "
        "pyramid and cached tables dropped before each; seconds: the request's own (error "
        "measures excluded), the fastest of %d runs; levels, SH passes, pyramids: "
        "`envl_products_summary`'s counters" % RUNS, ""] + lines) + "\n"
    os.makedirs(_args.docs, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=_args.docs, prefix=".request_bench.md.")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    out = os.path.join(_args.docs, "request_bench.md")
    os.replace(tmp, out)
    print("request_bench: wrote %s" % out, file=sys.stderr)
