#!/usr/bin/env bash
# Maps whose pixels are coarse or far from square (issue 30, 4.4 and 4.5).
# - prefilter: a constant map one pixel wide and under 16 tall prefiltered to texels 0 and 2
#   (exit 0, nothing said); now every texel of every level is the constant (a 1 x 8 map of 1
#   within 2e-6), and stderr says the map was prefiltered from a finer copy and which.
. "$(dirname "$0")/clitest.sh"

python3 - <<'PY'
import struct
def pfm(name, w, h, f):
    with open(name, "wb") as o:
        o.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        for r in range(h - 1, -1, -1):  # PFM rows bottom to top
            for c in range(w):
                o.write(struct.pack("<3f", *f(c, r)))
pfm("one_8.pfm", 1, 8, lambda c, r: (1, 1, 1))
PY

rm -rf one
run "$ENVLIGHT" prefilter one_8.pfm -o one --format pfm --layout-in latlong --size 64 --levels 4
has err.txt "one_8.pfm: 1 x 8 pixels are too coarse for the GGX levels, which sum each pixel at its centre: prefiltered from a 64 x 32 copy (each pixel split into 64 x 4, the same map)"
checks=$((checks + 1))
python3 - <<'PY' || fail "the levels of a constant 1 x 8 map are not the constant"
import glob, struct
files = sorted(glob.glob("one/specular_*.pfm")) + ["one/irradiance.pfm"]
assert len(files) == 5, files
for fn in files:
    d = open(fn, "rb").read()
    head, rest = d.split(b"\n", 1)
    size, rest = rest.split(b"\n", 1)
    scale, rest = rest.split(b"\n", 1)
    w, h = map(int, size.split())
    v = struct.unpack("<%df" % (3 * w * h), rest[:12 * w * h])
    want = 3.14159265 if "irradiance" in fn else 1.0
    worst = max(abs(x - want) / want for x in v)
    assert worst <= 2e-6, (fn, worst, min(v), max(v))
PY
hasnt out.txt "glossy error [1-9]"
hasnt out.txt "glossy error 0.[0-9][1-9]"
finish
