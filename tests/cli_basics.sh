#!/usr/bin/env bash
# The command-line contract (docs/design.md): exit statuses 0 / 1 / 2, errors on stderr naming the
# file and the cause, stdout carries only the requested output, outputs written atomically.
. "$(dirname "$0")/clitest.sh"

expect 0 "info on the built-in sky" -- "$ENVLIGHT" info
has out.txt "built-in sky" "info names the sky"
expect 0 "info --json" -- "$ENVLIGHT" info - --json
python3 - <<'PY' || { fails=$((fails + 1)); echo "FAIL: info JSON contract"; }
import json, math
d = json.load(open("out.txt"))
for k in ["file", "format", "layout", "width", "height", "channels", "mean", "power", "max",
          "brightest_direction", "nonfinite_pixels", "negative_pixels"]:
    assert k in d, k
assert d["width"] == 1024 and d["height"] == 512 and d["layout"] == "latlong"
assert abs(sum(x * x for x in d["brightest_direction"]) - 1) < 1e-6
# mean radiance over the sphere is power / 4 pi
assert all(abs(m - p / (4 * math.pi)) <= 1e-6 * p for m, p in zip(d["mean"], d["power"]))
PY
checks=$((checks + 1))
empty err.txt "info writes nothing on stderr for the sky"

expect 2 "no command" -- "$ENVLIGHT"
expect 2 "unknown command" -- "$ENVLIGHT" frobnicate
expect 2 "unknown option" -- "$ENVLIGHT" info --bogus
has err.txt "unknown option '--bogus'" "usage error names the option"
expect 2 "bad number" -- "$ENVLIGHT" info --rotate abc
expect 2 "missing value" -- "$ENVLIGHT" info --rotate
expect 0 "help" -- "$ENVLIGHT" info --help
has out.txt "Usage: envlight info" "help on stdout"
expect 0 "convert help" -- "$ENVLIGHT" convert --help
# One option table per command (src/cli/cli_options.c) is both what is parsed and what --help
# prints: every command's help lists its options and, where it reads a map, the input options;
# a value outside the table's range names the option, the range and the value (exit 2).
for cmd in info convert lights sh prefilter brdf-lut pov preview bench; do
  expect 0 "$cmd help" -- "$ENVLIGHT" "$cmd" --help
  has out.txt "^Usage: envlight $cmd" "$cmd: help on stdout"
  [ "$cmd" = brdf-lut ] || has out.txt "^  --layout-in L" "$cmd: the input options listed"
done
expect 0 "main help" -- "$ENVLIGHT" --help
for cmd in info convert lights sh prefilter brdf-lut pov preview bench version; do
  has out.txt "^  $cmd " "envlight --help lists $cmd"
done
expect 2 "order out of range" -- "$ENVLIGHT" sh - --order=33
has err.txt "envlight sh: --order takes 0..32, not '33'" "range and value named"
expect 2 "choice unknown" -- "$ENVLIGHT" lights - --method nope
has err.txt "--method takes fit, median, variance or sun, not 'nope'" "choices listed"
expect 2 "flag with a value" -- "$ENVLIGHT" info --json=1
has err.txt "--json takes no value" "a flag takes no value"
expect 2 "two files" -- "$ENVLIGHT" sh a.hdr b.hdr
has err.txt "one FILE only" "one FILE only"

expect 1 "missing file" -- "$ENVLIGHT" info does-not-exist.hdr
has err.txt "does-not-exist.hdr: cannot open" "error names the file and the cause"
empty out.txt "nothing on stdout on error"
mkdir -p adir
expect 1 "directory as input" -- "$ENVLIGHT" info adir
has err.txt "adir: not a regular file" "directory refused"
: > empty.hdr
expect 1 "empty file" -- "$ENVLIGHT" info empty.hdr
has err.txt "empty.hdr: file is empty" "empty file refused"
printf 'PF\n1000000 1000000\n-1\n' > huge.pfm
expect 1 "absurd size refused before allocation" -- "$ENVLIGHT" info huge.pfm
has err.txt "exceeds the limit" "limit message"

# A damaged file named .exr is reported as not being OpenEXR (when the data is present).
if [ -f "$ENVL_SHARED_DATA/openexr/OpenEXRTest/invalid.exr" ]; then
  expect 1 "invalid.exr" -- "$ENVLIGHT" info "$ENVL_SHARED_DATA/openexr/OpenEXRTest/invalid.exr"
  has err.txt "invalid.exr: not an OpenEXR file" "bad magic named"
else
  echo "SKIP: $ENVL_SHARED_DATA/openexr/OpenEXRTest/invalid.exr absent"
fi
printf 'garbage!' > bad.pfm
expect 1 "bad pfm" -- "$ENVLIGHT" info bad.pfm
has err.txt "bad.pfm: not a PFM file" "bad pfm named"

# convert: the sky to PFM, then back through info; sizes and power agree.
expect 0 "convert sky to pfm" -- "$ENVLIGHT" convert - sky.pfm --sky-width 256
expect 0 "info on the converted file" -- "$ENVLIGHT" info sky.pfm --json
has out.txt '"width": 256' "converted size"
# A failed convert leaves an existing output as it was, and no temporary file behind.
cp sky.pfm keep.pfm
expect 1 "convert from a missing file" -- "$ENVLIGHT" convert nothing.hdr keep.pfm
cmp -s sky.pfm keep.pfm || { fails=$((fails + 1)); echo "FAIL: output changed by a failed convert"; }
checks=$((checks + 1))
expect 1 "unknown output extension" -- "$ENVLIGHT" convert - out.xyz
ls -A | grep -q '\.envl-\|tmp-' && { fails=$((fails + 1)); echo "FAIL: temporary file left behind"; ls; }
checks=$((checks + 1))
# A map narrower than 4 pixels gets faces of one pixel by default (its width / 4 was 0 and the
# conversion failed with "bad arguments"): a 2 x 1 map to a vertical cross of 3 x 4.
python3 - <<'PY'
import struct
with open("tiny.pfm", "wb") as f:
    f.write(b"PF\n2 1\n-1.0\n" + struct.pack("<6f", 1, 2, 3, 4, 5, 6))
PY
expect 0 "convert a 2 x 1 map to a cross" -- "$ENVLIGHT" convert tiny.pfm tiny_cross.pfm --layout-out cross
expect 0 "info on the cross" -- "$ENVLIGHT" info tiny_cross.pfm --layout-in cross --json
has out.txt '"width": 3' "a cross of one-pixel faces"

finish
