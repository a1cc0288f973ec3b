#!/usr/bin/env bash
# --frame gltf (issue 16): every direction and coefficient written in the Y-up frame, and the
# frame stated. Vectors: (x, y, z) -> (x, z, -y) exactly (to the JSON's 9 digits). SH: band 0
# unchanged, band 1 (c_y, c_z, c_x) -> (c_z, -c_y, c_x), and each band's energy sum_m c_lm^2
# unchanged (a rotation); the library's turn at every order is checked in test_sh.
. "$(dirname "$0")/clitest.sh"

for f in blender gltf; do
  run "$ENVLIGHT" lights - --sky-width 256 -n 3 --json -o "l_$f.json" --frame "$f"
  run "$ENVLIGHT" sh - --sky-width 256 --order 3 --json -o "sh_$f.json" --frame "$f"
done
checks=$((checks + 1))
python3 - <<'PY' || { fails=$((fails + 1)); echo "FAIL: --frame gltf"; }
import json
def T(v):
    return [v[0], v[2], -v[1]]
def close(a, b, tol):
    assert all(abs(x - y) <= tol * (1 + abs(y)) for x, y in zip(a, b)), (a, b)
def same_sh(cb, cg):
    close(cg[0], cb[0], 1e-8)
    for ch in range(3):  # band 1: index 1 = y, 2 = z, 3 = x
        close([cg[1][ch], cg[2][ch], cg[3][ch]], [cb[2][ch], -cb[1][ch], cb[3][ch]], 1e-7)
    l = 0
    while (l + 1) ** 2 <= len(cb):
        band = range(l * l, (l + 1) ** 2)
        for ch in range(3):
            eb = sum(cb[i][ch] ** 2 for i in band)
            eg = sum(cg[i][ch] ** 2 for i in band)
            assert abs(eb - eg) <= 1e-7 * (eb + 1e-30) + 1e-12, (l, eb, eg)
        l += 1
b, g = json.load(open("l_blender.json")), json.load(open("l_gltf.json"))
assert b["frame"] == "blender-z-up" and g["frame"] == "gltf-y-up"
for lb, lg in zip(b["lights"], g["lights"]):
    close(lg["direction"], T(lb["direction"]), 1e-8)
    assert lg["rgb"] == lb["rgb"]
same_sh(b["remainder"]["irradiance"], g["remainder"]["irradiance"])
b, g = json.load(open("sh_blender.json")), json.load(open("sh_gltf.json"))
assert b["frame"] == "blender-z-up" and g["frame"] == "gltf-y-up"
same_sh(b["radiance"], g["radiance"])
same_sh(b["irradiance"], g["irradiance"])
ab, ag = b["ambient_deltas"], g["ambient_deltas"]
for ch in range(3):
    close([ag["dx"][ch], ag["dy"][ch], ag["dz"][ch]], T([ab["dx"][ch], ab["dy"][ch], ab["dz"][ch]]), 1e-8)
close(g["hemispheric"]["axis"], T(b["hemispheric"]["axis"]), 1e-8)
assert g["hemispheric"]["sky"] == b["hemispheric"]["sky"]
PY
# the table and the CSV say the frame; an unknown frame is a usage error
run "$ENVLIGHT" lights - --sky-width 256 -n 2 --frame gltf
has out.txt "frame gltf-y-up"
run "$ENVLIGHT" lights - --sky-width 256 -n 2 --frame gltf --csv
has out.txt ",gltf-y-up$"
run "$ENVLIGHT" sh - --sky-width 256 --frame gltf
has out.txt "frame gltf-y-up"
usage "$ENVLIGHT" lights - --sky-width 256 --frame unity
has err.txt "blender or gltf"
finish
