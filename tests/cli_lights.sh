#!/usr/bin/env bash
# envlight lights: the JSON and CSV contract of docs/design.md, energy bookkeeping through the
# saved residual, the sun method, usage errors.
. "$(dirname "$0")/clitest.sh"

for method in median variance fit; do
  run "$ENVLIGHT" lights - --sky-width 256 -n 8 --method "$method" --json -o "l_$method.json" \
      --residual "res_$method.pfm"
  run "$ENVLIGHT" info "res_$method.pfm" --json --quiet
  cp out.txt "info_$method.json"
  checks=$((checks + 1))
  python3 - "$method" <<'PY' || { fails=$((fails + 1)); echo "FAIL: lights JSON ($method)"; }
import json, math, sys
method = sys.argv[1]
d = json.load(open(f"l_{method}.json"))
for k in ["frame", "method", "count", "power", "lights", "residual_power", "error", "seconds"]:
    assert k in d, k
assert d["frame"] == "blender-z-up" and d["method"] == method
assert d["count"] == len(d["lights"]) and 1 <= d["count"] <= 8
for l in d["lights"]:
    assert abs(sum(x * x for x in l["direction"]) - 1) < 1e-6
    assert all(c >= 0 for c in l["rgb"])
    # angle = 2 acos(1 - omega / 2 pi), capped at pi
    c = max(-1.0, min(1.0, 1 - l["solid_angle"] / (2 * math.pi)))
    assert abs(l["angle"] - min(math.pi, 2 * math.acos(c))) < 1e-6
# lights + residual = power (JSON numbers carry 9 digits: 1e-8 for a sum of a few); the
# residual file's own power agrees (float pixels: 1e-6)
res = json.load(open(f"info_{method}.json"))["power"]
for k in range(3):
    lights = sum(l["rgb"][k] for l in d["lights"])
    assert abs(lights + d["residual_power"][k] - d["power"][k]) <= 1e-8 * d["power"][k]
    assert abs(res[k] - d["residual_power"][k]) <= 1e-6 * d["power"][k] + 1e-12, (res, d)
assert ("remainder" in d) == (method == "fit")
if method == "fit":
    r = d["remainder"]
    assert r["order"] == 2 and len(r["irradiance"]) == 9
assert 0 <= d["error"]["diffuse"] < 1 and d["seconds"] >= 0
PY
done
# CSV: a row per light, each with the set's error (the JSON's, a fraction) and seconds; the
# error empty with --no-error
run "$ENVLIGHT" lights - --sky-width 256 --method median -n 4 --json -o l_csv.json
for e in "" --no-error; do
  run "$ENVLIGHT" lights - --sky-width 256 --method median -n 4 --csv $e
  checks=$((checks + 1))
  python3 - "$e" <<'PY' || { fails=$((fails + 1)); echo "FAIL: CSV $e"; cat out.txt; }
import csv, json, sys
rows = list(csv.DictReader(open("out.txt")))
d = json.load(open("l_csv.json"))
assert open("out.txt").readline().strip() == \
    "x,y,z,r,g,b,solid_angle,angle,diffuse_error,seconds,frame"
assert len(rows) == 4 == len(d["lights"])
for r, l in zip(rows, d["lights"]):
    assert [float(r[k]) for k in "xyz"] == [float("%.9g" % v) for v in l["direction"]]
    assert float(r["seconds"]) >= 0
    if sys.argv[1]:
        assert r["diffuse_error"] == ""
    else:
        assert float(r["diffuse_error"]) == float("%.9g" % d["error"]["diffuse"]), (r, d["error"])
PY
done
run "$ENVLIGHT" lights - --sky-width 256 -n 16 --method fit --order 4 --json
checks=$((checks + 1))
python3 -c 'import json; d = json.load(open("out.txt")); assert d["remainder"]["order"] == 4 and len(d["remainder"]["irradiance"]) == 25' ||
  { fails=$((fails + 1)); echo "FAIL: --order 4"; }
# the sun method on the built-in sky: its one sun as a light, the residual the map less what
# the light took (the saved residual's power agrees), no remainder; the table names it
run "$ENVLIGHT" lights - --method sun --json -o l_sun.json --residual res_sun.pfm
run "$ENVLIGHT" info res_sun.pfm --json --quiet
cp out.txt info_sun.json
checks=$((checks + 1))
python3 - <<'PY2' || { fails=$((fails + 1)); echo "FAIL: lights --method sun --json"; }
import json, math
d = json.load(open("l_sun.json"))
assert d["method"] == "sun" and d["count"] == 1 and len(d["lights"]) == 1, d
l = d["lights"][0]
el = math.radians(35)
dot = l["direction"][0] * math.cos(el) + l["direction"][2] * math.sin(el)
assert math.degrees(math.acos(min(1.0, dot))) < 0.3, l
assert "remainder" not in d and not d["no_light"]
res = json.load(open("info_sun.json"))["power"]
for k in range(3):
    assert abs(l["rgb"][k] + d["residual_power"][k] - d["power"][k]) <= 1e-8 * d["power"][k]
    assert abs(res[k] - d["residual_power"][k]) <= 1e-6 * d["power"][k], (res, d)
assert 0 <= d["error"]["diffuse"] < 1e-3
PY2
run "$ENVLIGHT" lights - --sky-width 256 --method sun
has out.txt "1 lights by sun split"

usage "$ENVLIGHT" lights --method nope
usage "$ENVLIGHT" lights -n 0
usage "$ENVLIGHT" lights --order 9
usage "$ENVLIGHT" lights a.hdr b.hdr

# --no-error, alike on lights, sh and prefilter: nothing measured, and every output says so
run "$ENVLIGHT" lights - --sky-width 256 --no-error
has out.txt "diffuse error not measured"
run "$ENVLIGHT" lights - --sky-width 256 --json
has out.txt '"measured": true'
run "$ENVLIGHT" lights - --sky-width 256 --no-error --json
has out.txt '"measured": false'
has out.txt '"diffuse": null'
run "$ENVLIGHT" sh - --sky-width 256 --no-error
has out.txt "diffuse error not measured"
run "$ENVLIGHT" sh - --sky-width 256 --no-error --json
has out.txt '"measured": false'
run "$ENVLIGHT" sh - --sky-width 256
has out.txt "diffuse error [0-9.]* %"
run "$ENVLIGHT" prefilter - --sky-width 256 --no-error -o pf_noerr
has out.txt "glossy error not measured"
has pf_noerr/prefilter.json '"errors_measured": false'
finish
