#!/usr/bin/env bash
# Half floats say what they cost (issue 30, 4.7): prefilter --format ktx2 writes IEEE half
# floats, which hold at most 65504; a uniform map of 70000 had every irradiance texel 70 % low
# (pi 70000 written as 65504) while the summary said "diffuse error 0.000 %", and nothing on
# stderr; convert --half clamped as silently. Now stderr says how many values were clamped and
# by how much, and every stated error is that of the values as written: rounded to half,
# clamped at 65504. On the uniform map the errors are known exactly: the irradiance map
# 1 - 65504 / (70000 pi) = 70.2135 %, every specular level 1 - 65504 / 70000 = 6.4229 % (the
# float products are exact to 1e-6 there, with the exact irradiance method); ktx2-float and
# EXR keep 0. The maps are cube faces (6 x 32^2 irradiance texels, 6 x 4^2 at level 2), and
# no note on stderr sends the user to a finer sum for an error that is the clamp's.
. "$(dirname "$0")/clitest.sh"

python3 -c 'import struct,sys; sys.stdout.buffer.write(b"PF\n64 32\n-1.0\n" + struct.pack("<6144f", *[7e4] * 6144))' >u70k.pfm
rm -rf k kf
run "$ENVLIGHT" prefilter u70k.pfm -o k --format ktx2 --size 16 --levels 3 --irradiance-method exact
has err.txt "warning: u70k.pfm: the irradiance map: 18432 values above 65504 (the largest half float) written as 65504: the largest was 219911 (70.2 % lower)"
has err.txt "warning: u70k.pfm: specular level 2 (r 1.000): 288 values above 65504 (the largest half float) written as 65504: the largest was 70000 (6.4 % lower)"
has out.txt "diffuse error 70.213 %"
has out.txt "glossy error 6.423 %"
hasnt out.txt "error 0.000 %"
hasnt err.txt "is beyond RMS"
checks=$((checks + 1))
python3 - <<'PY' || fail "prefilter.json: the errors of the half floats written"
import json, math
m = json.load(open("k/prefilter.json"))
irr = 1 - 65504 / (7e4 * math.pi)
glossy = 1 - 65504 / 7e4
assert abs(m["irradiance"]["diffuse_error"] - irr) <= 1e-6, m["irradiance"]
for l in m["specular"]:
    assert abs(l["glossy_error"] - glossy) <= 1e-6, l
assert m["errors_of"].startswith("the maps as written: rounded to half floats"), m["errors_of"]
PY
# 32-bit floats: nothing clamped, nothing said, the errors of the float maps
run "$ENVLIGHT" prefilter u70k.pfm -o kf --format ktx2-float --size 16 --levels 3 --irradiance-method exact
empty err.txt
has out.txt "diffuse error 0.000 %"
hasnt out.txt "glossy error [1-9]"
# within the half range: the stated error is that of the values rounded to half. On a uniform
# map of 0.3 the float products are exact to 1e-6 and each value rounds to the same half h
# (struct's 'e': binary16, nearest even), so the stated errors are |h(E) - E| / E, E = 0.3 pi
# for the irradiance map, 0.3 for every level (1.0e-4 and 1.6e-4): within 2e-6.
python3 -c 'import struct,sys; sys.stdout.buffer.write(b"PF\n64 32\n-1.0\n" + struct.pack("<6144f", *[0.3] * 6144))' >u03.pfm
rm -rf s sf
run "$ENVLIGHT" prefilter u03.pfm -o s --format ktx2 --size 16 --levels 3 --irradiance-method exact --quiet
run "$ENVLIGHT" prefilter u03.pfm -o sf --format ktx2-float --size 16 --levels 3 --irradiance-method exact --quiet
checks=$((checks + 1))
python3 - <<'PY' || fail "the half rounding in the stated errors"
import json, math, struct
h, f = (json.load(open(d + "/prefilter.json")) for d in ("s", "sf"))
def rounded(x):
    x = struct.unpack("<f", struct.pack("<f", x))[0]
    return struct.unpack("<e", struct.pack("<e", x))[0]
e_irr = 0.3 * math.pi
want = abs(rounded(e_irr) - e_irr) / e_irr
assert abs(h["irradiance"]["diffuse_error"] - want) <= 2e-6, (h["irradiance"], want)
assert f["irradiance"]["diffuse_error"] <= 2e-6, f["irradiance"]
want = abs(rounded(0.3) - 0.3) / 0.3
for a, b in zip(h["specular"], f["specular"]):
    assert abs(a["glossy_error"] - want) <= 2e-6 and b["glossy_error"] <= 2e-6, (a, b, want)
assert f["errors_of"].startswith("the maps as written: 32-bit floats"), f["errors_of"]
PY

# convert --half: the same warning for the file it writes; without --half, nothing
run "$ENVLIGHT" convert u70k.pfm h.exr --half
has err.txt "warning: h.exr: 6144 values above 65504 (the largest half float) written as 65504: the largest was 70000 (6.4 % lower)"
run "$ENVLIGHT" convert u70k.pfm h.exr --half --quiet
empty err.txt
run "$ENVLIGHT" convert u70k.pfm f.exr
empty err.txt
finish
