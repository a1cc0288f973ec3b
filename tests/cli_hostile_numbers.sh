#!/usr/bin/env bash
# Issue 19: finite input whose results overflow (pixels of 3e38, below FLT_MAX) and negative
# light. Nothing non-finite is ever written: sh sums in a scaled range and prints finite
# coefficients; an irradiance map beyond the float range is an error naming the file, with
# nothing written. sh's default window (auto) keeps the irradiance non-negative; window none
# says so on stderr; the hemispheric pair is never negative (and says when it clamped); the
# POV-Ray include states the ambient's least value.
. "$(dirname "$0")/clitest.sh"

python3 - <<'PY'
import struct
def pfm(name, w, h, f):
    with open(name, "wb") as o:
        o.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        for y in range(h):
            for x in range(w):
                o.write(struct.pack("<3f", *f(x, y)))
pfm("big.pfm", 256, 128, lambda x, y: (3e38,) * 3)
pfm("few.pfm", 64, 32, lambda x, y: (3e38,) * 3 if (x, y) in [(10, 5), (40, 20), (3, 3)] else (1, .5, .25))
pfm("bright.pfm", 64, 32, lambda x, y: (1e5,) * 3 if (x, y) == (20, 10) else (.1, .1, .1))
PY

# sh on 3e38 everywhere: finite, L00 = 2 sqrt(pi) 3e38 = 1.0634723e39 (float rounding of the
# lane sums: 7 x 2^-24 relative, so 7 digits agree)
run "$ENVLIGHT" sh big.pfm --json --quiet
hasnt out.txt "null"
python3 - <<'PY' || fail "sh big.pfm: coefficients"
import json, math
s = json.load(open("out.txt"))
assert all(math.isfinite(v) for c in s["radiance"] + s["irradiance"] for v in c)
l00 = 2 * math.sqrt(math.pi) * 3.0000000054977558e38  # 3e38 as a float
assert abs(s["radiance"][0][0] / l00 - 1) <= 7 * 2 ** -24, s["radiance"][0]
assert math.isfinite(s["error"]["diffuse"]) and s["error"]["diffuse"] < 14 * 2 ** -24
PY
run "$ENVLIGHT" sh big.pfm --quiet
hasnt out.txt "nan\|inf"
# prefilter: the irradiance (pi x 3e38) does not fit a float: exit 1, the file and the cause
# named, no folder made; the specular levels alone fit
rm -rf pre few
expect 1 "prefilter big.pfm" -- "$ENVLIGHT" prefilter big.pfm -o pre --quiet --no-error
has err.txt "big.pfm: the irradiance map overflows the float range"
checks=$((checks + 1)); [ ! -e pre ] || fail "prefilter left pre/ behind"
run "$ENVLIGHT" prefilter big.pfm -o pre --specular --levels 2 --size 64 --quiet --no-error
# a few 3e38 pixels over a normal map: every product finite
for cmd in "sh few.pfm --json" "lights few.pfm --json" "lights few.pfm --method fit --json" \
           "lights few.pfm --method variance --json"; do
  run "$ENVLIGHT" $cmd --quiet
  hasnt out.txt "null"
done
run "$ENVLIGHT" prefilter few.pfm -o few --irradiance --quiet --no-error

# negative light: the default window is auto (reported with its width), non-negative
run "$ENVLIGHT" sh bright.pfm
has out.txt "window auto (Hann width [0-9.]*), diffuse error"
hasnt err.txt "warning"
has err.txt "hemispheric ground: the plain linear fit gives -0.13"
run "$ENVLIGHT" sh bright.pfm --window none
has err.txt "warning: the SH irradiance (window none) is negative over part of the sphere"
run "$ENVLIGHT" sh bright.pfm --window none --json --quiet
empty err.txt
python3 - <<'PY' || fail "sh bright.pfm: hemispheric pair"
import json
s = json.load(open("out.txt"))
h = s["hemispheric"]
assert min(h["sky"] + h["ground"]) >= 0, h
assert s["min_irradiance"] < 0  # window none as asked: the expansion rings
PY
# the built-in sky: its plain hemispheric ground (-1.13, -0.93, -0.61) is clamped to 0
run "$ENVLIGHT" sh - --sky-width 64 --json
python3 - <<'PY' || fail "sh built-in sky: hemispheric ground"
import json
h = json.load(open("out.txt"))["hemispheric"]
assert h["ground"] == [0, 0, 0] and min(h["sky"]) > 0 and h["clamped"] == "ground", h
PY
has err.txt "hemispheric ground: the plain linear fit gives -1.13"

# POV-Ray: the include states the ambient's least value
run "$ENVLIGHT" pov bright.pfm --method median -n 4 -o med.inc
has med.inc "^// ambient (SH window auto: never negative): least irradiance "
run "$ENVLIGHT" pov bright.pfm --ambient hemi -o hemi.inc
has hemi.inc "^// ambient (sky/ground: the best fit with both >= 0): least irradiance "
hasnt hemi.inc "NEGATIVE"
finish
