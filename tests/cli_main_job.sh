#!/usr/bin/env bash
# The README's first command: scripts/main_job.sh on the built-in sky writes every product, the
# lights' JSON follows the contract, and POV-Ray renders the example scene with the include.
. "$(dirname "$0")/clitest.sh"
command -v povray >/dev/null || { echo "SKIP: povray absent"; exit 77; }

run bash "$(dirname "$0")/../scripts/main_job.sh" job
for f in lights.json lights.csv residual.exr sh.json env.inc envlight.inc render.hdr render.png \
         preview.png; do
  checks=$((checks + 1)); [ -s "job/$f" ] || fail "job/$f missing or empty"
done
has out.txt "diffuse error"
checks=$((checks + 1))
python3 - <<'PY' || fail "lights.json / sh.json contract"
import json
d = json.load(open("job/lights.json"))
assert d["method"] == "fit" and 1 <= d["count"] <= 4 and d["frame"] == "blender-z-up"
assert "remainder" in d and d["error"]["diffuse"] < 0.01
s = json.load(open("job/sh.json"))
assert s["order"] == 2 and len(s["irradiance"]) == 9 and s["min_irradiance"] >= 0
PY
# preview.png: a PNG (signature, IHDR with its CRC) of the default sphere size 96: 88 + 5 (96 + 24)
# = 688 wide, 66 + (688 - 16) / 2 + 4 (96 + 28) = 898 high, 8-bit RGB (docs/methods.md, "Preview")
checks=$((checks + 1))
python3 - <<'PY' || fail "preview.png"
import struct, zlib
b = open("job/preview.png", "rb").read()
assert b[:8] == b"\x89PNG\r\n\x1a\n" and b[12:16] == b"IHDR"
assert zlib.crc32(b[12:29]) == struct.unpack(">I", b[29:33])[0]
assert struct.unpack(">IIBB", b[16:26]) == (688, 898, 8, 2)
PY
# the render holds light (not a black or failed image)
run "$ENVLIGHT" info job/render.hdr --json --layout-in latlong --quiet
checks=$((checks + 1))
python3 -c 'import json; d = json.load(open("out.txt")); assert d["width"] == 480 and min(d["mean"]) > 0' ||
  fail "render.hdr"
finish
