#!/usr/bin/env bash
# What users are told (issue 19, items 4 and 6): every JSON output is valid UTF-8 whatever the
# bytes of a file name (invalid UTF-8 becomes U+FFFD, one per maximal invalid subpart, as
# Python's bytes.decode('utf-8', 'replace') does; control characters are \u escapes); bad option
# combinations are usage errors (exit 2) that say what to do; a failure names the file; a
# malformed header is echoed only as printable text; the "read as layout" note appears only
# when the layout is a real guess (square or unusual aspect), and `info` always shows it.
. "$(dirname "$0")/clitest.sh"
T="timeout 120"

# pfm FILE W H: a W x H PFM of radiance 1 (little-endian)
pfm() { python3 -c 'import struct, sys
w, h = int(sys.argv[2]), int(sys.argv[3])
open(sys.argv[1], "wb").write(b"PF\n%d %d\n-1.0\n" % (w, h) + struct.pack("<f", 1.0) * (3 * w * h))' "$@"; }

# ---- item 4: file names that are not UTF-8, or hold control characters, in every JSON output
BAD=$'\xff\xfe.hdr'                                                      # invalid bytes only
MIX=$'m\x01\x1b\x7f\t\xc3\xa9\xe2\x82x\xed\xa0\x80\xf4\x90\x80\x80\xc0\xaf\xc2\x85\xe2\x80\xa8.hdr'
expect 0 "sky under a non-UTF-8 name" -- $T "$ENVLIGHT" convert - "$BAD" --sky-width 64 --quiet
cp -- "$BAD" "$MIX"
# valid NAME JSONFILE KEY...: JSONFILE is strict UTF-8 JSON whose KEY path holds NAME decoded
# with U+FFFD replacement (the name as given on the command line)
valid() { checks=$((checks + 1))
  python3 - "$@" <<'PY' || fail "JSON of '$1' in $2 (${*:3})"
import json, os, sys
name, path, keys = os.fsencode(sys.argv[1]), sys.argv[2], sys.argv[3:]
raw = open(path, "rb").read()
d = json.loads(raw.decode("utf-8"))  # strict: raises on invalid UTF-8 or raw control bytes
for k in keys:
    d = d[k]
want = name.decode("utf-8", "replace")
assert d == want, (d, want)
assert not any(c in raw for c in b"\x00\x01\x1b\x7f"), "raw control bytes"
PY
}
for n in "$BAD" "$MIX"; do
  expect 0 "info --json" -- $T "$ENVLIGHT" info "$n" --json --quiet
  valid "$n" out.txt file
  expect 0 "lights --json" -- $T "$ENVLIGHT" lights "$n" --json -n 2 --quiet
  valid "$n" out.txt file
  expect 0 "lights --json -o" -- $T "$ENVLIGHT" lights "$n" --json -o lights.json --quiet
  valid "$n" lights.json file
  expect 0 "sh --json" -- $T "$ENVLIGHT" sh "$n" --json --quiet
  valid "$n" out.txt file
  rm -rf pf
  expect 0 "prefilter" -- $T "$ENVLIGHT" prefilter "$n" -o pf --size 16 --levels 2 --quiet
  valid "$n" pf/prefilter.json source
  out=${n%.hdr}.exr
  expect 0 "brdf-lut" -- $T "$ENVLIGHT" brdf-lut -o "$out" --size 8
  valid "$out" "$out.json" file
done

# ---- item 6: usage errors
S=(--sky-width 64 --quiet)
for args in "-n 64 --method fit" "--method fit -n 33" "--method=fit --count 40"; do
  expect 2 "lights $args" -- $T "$ENVLIGHT" lights - $args "${S[@]}"
  has err.txt "fit takes 1..32 lights"
  empty out.txt
done
# pov: the method given, or the custom recipe's fit (its default when -n alone is given)
for args in "-n 64 --method fit" "-n 40"; do
  rm -f p.inc
  expect 2 "pov $args" -- $T "$ENVLIGHT" pov - $args -o p.inc "${S[@]}"
  has err.txt "fit takes 1..32 lights"
  [ ! -e p.inc ] || fail "pov $args wrote p.inc"
done
expect 0 "pov median with 64 lights" -- $T "$ENVLIGHT" pov - -n 64 --method median -o p.inc "${S[@]}"
expect 0 "fit with 32 lights" -- $T "$ENVLIGHT" lights - -n 32 --method fit "${S[@]}"
expect 0 "median with 64 lights" -- $T "$ENVLIGHT" lights - -n 64 --method median "${S[@]}"

# --width (and --sky-width) make a map of W x W/2 pixels: checked against --max-pixels (default
# 268435456 = 2^28), in either order, before anything is read or allocated
pfm p16.pfm 16 8
expect 2 "--width 40000" -- $T "$ENVLIGHT" info p16.pfm --width 40000
has err.txt "info: --width 40000 makes a 40000 x 20000 map: more than --max-pixels 268435456"
empty out.txt
expect 2 "--width 40000 on the sky" -- $T "$ENVLIGHT" sh - --width 40000 "${S[@]}"
has err.txt "more than --max-pixels"
expect 2 "--width then --max-pixels" -- $T "$ENVLIGHT" info p16.pfm --width 64 --max-pixels 2047
has err.txt "info: --width 64 makes a 64 x 32 map: more than --max-pixels 2047"
expect 2 "--max-pixels then --width" -- $T "$ENVLIGHT" lights p16.pfm --max-pixels 2047 --width 64
has err.txt "lights: --width 64 makes a 64 x 32 map: more than --max-pixels 2047"
expect 0 "--width at --max-pixels" -- $T "$ENVLIGHT" info p16.pfm --width 64 --max-pixels 2048
has out.txt "envmap:      64 x 32"
expect 2 "--sky-width over --max-pixels" -- $T "$ENVLIGHT" info - --sky-width 64 --max-pixels 2047
has err.txt "info: --sky-width 64 makes a 64 x 32 map: more than --max-pixels 2047"
expect 0 "--sky-width at --max-pixels" -- $T "$ENVLIGHT" info - --sky-width 64 --max-pixels 2048

# a failure while reading FILE names FILE: out of memory in the resampling (an address-space
# limit; skipped where one cannot be set, e.g. under AddressSanitizer)
checks=$((checks + 1))
if (ulimit -v 300000 && "$ENVLIGHT" version) >/dev/null 2>&1; then
  (ulimit -v 300000 && exec "$ENVLIGHT" info p16.pfm --width 16384) >out.txt 2>err.txt
  [ $? = 1 ] || fail "out of memory: exit status"
  has err.txt "^envlight: p16.pfm: resample: cannot allocate 16384 x 8192"
else
  echo "SKIP: out-of-memory message: 'ulimit -v' unusable here"
fi

# the PFM scale is echoed printable: other bytes as \xHH, a long token cut short
printf 'PF\n1 1\n\033[31mEVIL\007\n' > esc.pfm && head -c 12 /dev/zero >> esc.pfm
expect 1 "PFM scale with escapes" -- $T "$ENVLIGHT" info esc.pfm
has err.txt 'esc.pfm: PFM scale '"'"'\\x1b\[31mEVIL\\x07'"'"' must be a non-zero number'
checks=$((checks + 1))
! LC_ALL=C grep -q $'[\x01-\x09\x0b-\x1f\x7f-\xff]' err.txt || fail "raw bytes on stderr"
printf 'PF\n1 1\n%s\n' "$(printf 'x%.0s' $(seq 60))" > long.pfm && head -c 12 /dev/zero >> long.pfm
expect 1 "PFM scale, long" -- $T "$ENVLIGHT" info long.pfm
has err.txt "PFM scale 'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx...' must be a non-zero number"
# every message shows control characters as \xHH: a file name's (the library's message and the
# command line's own), a .hdr FORMAT line's
ESC=$'e\x1b[2Jx\ny.hdr'
expect 1 "a file name with an escape sequence" -- $T "$ENVLIGHT" info "$ESC"
has err.txt 'e\\x1b\[2Jx\\x0ay.hdr'
checks=$((checks + 1))
! LC_ALL=C grep -q $'[\x01-\x09\x0b-\x1f\x7f]' err.txt || fail "raw control bytes on stderr"
expect 2 "a usage error naming an escape sequence" -- $T "$ENVLIGHT" info --layout-in "$ESC"
checks=$((checks + 1))
! LC_ALL=C grep -q $'[\x01-\x09\x0b-\x1f\x7f]' err.txt || fail "raw control bytes on stderr"
printf '#?RADIANCE\nFORMAT=\033[2J\007\n\n-Y 1 +X 1\n' > fmt.hdr && head -c 4 /dev/zero >> fmt.hdr
expect 1 ".hdr FORMAT with escapes" -- $T "$ENVLIGHT" info fmt.hdr
has err.txt "header line 2 contains the binary byte 0x1b"
checks=$((checks + 1))
! LC_ALL=C grep -q $'[\x01-\x09\x0b-\x1f\x7f]' err.txt || fail "raw control bytes on stderr"

# ---- the "read as layout" note: only when the guess is uncertain
note="read as layout"
expect 0 "2:1 PFM" -- $T "$ENVLIGHT" info p16.pfm
empty err.txt
has out.txt "layout latlong (guessed from the 2:1 aspect ratio)"
pfm p12.pfm 12 16    # 3:4: a vertical cross
expect 0 "3:4 PFM" -- $T "$ENVLIGHT" sh p12.pfm
hasnt err.txt "$note"
expect 0 "3:4 PFM, info" -- $T "$ENVLIGHT" info p12.pfm
has out.txt "layout cross (guessed from the 3:4 aspect ratio)"
pfm sq.pfm 16 16     # square: an angular probe or a mirror ball?
expect 0 "square PFM" -- $T "$ENVLIGHT" sh sq.pfm
has err.txt "sq.pfm: 16 x 16 read as layout 'angular' (--layout-in to choose)"
expect 0 "square PFM, info" -- $T "$ENVLIGHT" info sq.pfm
has out.txt "layout angular (a guess: --layout-in to choose)"
expect 0 "square PFM, --quiet" -- $T "$ENVLIGHT" sh sq.pfm --quiet
empty err.txt
expect 0 "square PFM, --layout-in" -- $T "$ENVLIGHT" sh sq.pfm --layout-in mirrorball
hasnt err.txt "$note"
pfm odd.pfm 24 8     # 3:1: no layout has that shape, read as a lat-long
expect 0 "3:1 PFM" -- $T "$ENVLIGHT" lights odd.pfm -n 2
has err.txt "odd.pfm: 24 x 8 read as layout 'latlong' (--layout-in to choose)"
expect 0 "3:1 PFM, --json" -- $T "$ENVLIGHT" info odd.pfm --json
python3 -c 'import json; d = json.load(open("out.txt")); assert d["layout_guessed"] and not d["layout_evident"], d' \
  || fail "info --json: layout_evident"
checks=$((checks + 1))
expect 0 "2:1 PFM, --json" -- $T "$ENVLIGHT" info p16.pfm --json
python3 -c 'import json; d = json.load(open("out.txt")); assert d["layout_guessed"] and d["layout_evident"], d' \
  || fail "info --json: layout_evident"
checks=$((checks + 1))

finish
