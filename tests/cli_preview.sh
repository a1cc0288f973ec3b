#!/usr/bin/env bash
# envlight preview: the PNG decodes (python3 zlib: IHDR, IDAT, every row's filter byte) at the
# documented size, the shading options run, stderr's notes carry the picture's texts and the
# counts the methods returned, usage errors exit 2, bad input exits 1 naming the file, and a
# failed run leaves an existing output untouched.
. "$(dirname "$0")/clitest.sh"

# png FILE SPHERE: a valid 8-bit RGB PNG of 88 + 5 (S + 24) x 66 + (W - 16) / 2 + 4 (S + 28)
png() { checks=$((checks + 1)); python3 - "$1" "$2" <<'PY' || fail "$1 is not the expected PNG"
import struct, sys, zlib
data, s = open(sys.argv[1], "rb").read(), int(sys.argv[2])
assert data[:8] == b"\x89PNG\r\n\x1a\n"
pos, idat, ihdr = 8, b"", None
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    assert zlib.crc32(kind + body) == struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0]
    if kind == b"IHDR":
        ihdr = struct.unpack(">IIBBBBB", body)
    elif kind == b"IDAT":
        idat += body
    pos += 12 + n
w, h, depth, ctype = ihdr[:4]
W = 88 + 5 * (s + 24)
assert (w, h, depth, ctype) == (W, 66 + (W - 16) // 2 + 4 * (s + 28), 8, 2), ihdr
raw = zlib.decompress(idat)
assert len(raw) == h * (1 + 3 * w)
assert all(raw[r * (1 + 3 * w)] <= 4 for r in range(h))
PY
}

S="--sky-width 128 --reference-width 64 --quiet"
run "$ENVLIGHT" preview --help
has out.txt "--tonemap T .*aces"
has out.txt "--sphere-size"
run "$ENVLIGHT" preview - -o a.png $S --sphere-size 48
png a.png 48
empty out.txt
run "$ENVLIGHT" preview - -o b.png $S --sphere-size 64 --tonemap reinhard --exposure -1 \
  --diffuse oren-nayar --specular blinn-phong --roughness 0.3,0.7 -n 8 -k 2
png b.png 64
# Notes on stderr without --quiet, printed once all is computed: one line per approximation
# with the picture's texts (the count the method returned, "err X%" under each sphere it
# serves) and docs/design.md's diffuse error, which is the number `lights --json` reports. The fit
# returns 5 lights on this sky where -k asks 6 (docs/methods.md, "Lights"); --diffuse oren-nayar once
# printed the irradiance map's error as -100 % before it was set.
json_count_error() { "$ENVLIGHT" lights - --sky-width 128 --quiet --json "$@" | python3 -c '
import json, sys; j = json.load(sys.stdin); print(j["count"], "%.3f" % (100 * j["error"]["diffuse"]))'; }
read -r fit_n fit_e <<<"$(json_count_error --method fit -n 6)"
read -r med_n med_e <<<"$(json_count_error --method median -n 16)"
checks=$((checks + 1)); [ "${fit_n:-6}" -lt 6 ] || fail "the fit returned ${fit_n:-?} lights: no test of the count"
run "$ENVLIGHT" preview - -o c.png --sky-width 128 --reference-width 64 --sphere-size 48 \
  --diffuse oren-nayar -k 6
has err.txt "^envlight preview: median cut $med_n lights: diffuse err [0-9.]*% .*, glossy 0.50 err [0-9.]*% [^,]*, docs/design.md diffuse error $med_e %$"
has err.txt "^envlight preview: fit $fit_n lights + SH order 2: diffuse err [0-9.]*% .*, docs/design.md diffuse error $fit_e %$"
has err.txt "^envlight preview: SH order 2: diffuse err [0-9.]*% [^,]*, docs/design.md diffuse error [0-9.]* %$"
has err.txt "^envlight preview: prefiltered maps: diffuse err [0-9.]*% .*, mirror err [0-9.]*% [^,]*, docs/design.md"
hasnt err.txt "lights.*mirror err"
hasnt err.txt "^envlight preview: SH order 2:.*glossy"
hasnt err.txt "error *-"
hasnt err.txt "n/a"
has err.txt "wrote c.png"

# Usage errors: exit 2.
usage "$ENVLIGHT" preview -
usage "$ENVLIGHT" preview - -o x.png --tonemap filmic
usage "$ENVLIGHT" preview - -o x.png --roughness 0.5
usage "$ENVLIGHT" preview - -o x.png --roughness 0.01,0.5
usage "$ENVLIGHT" preview - -o x.png --sphere-size 10
usage "$ENVLIGHT" preview - -o x.png --diffuse phong
usage "$ENVLIGHT" preview - -o x.png -k 0
usage "$ENVLIGHT" preview - -o x.png --bogus
checks=$((checks + 1)); [ ! -e x.png ] || fail "x.png written by a usage error"

# Bad input: exit 1, the message names the file; the existing output is untouched.
cp a.png keep.png
expect 1 "missing file" -- "$ENVLIGHT" preview nonexistent.hdr -o a.png
has err.txt "nonexistent.hdr"
printf '#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n' > truncated.hdr
expect 1 "truncated file" -- "$ENVLIGHT" preview truncated.hdr -o a.png
has err.txt "truncated.hdr"
checks=$((checks + 1)); cmp -s keep.png a.png || fail "a.png changed by a failed run"
expect 1 "unwritable output" -- "$ENVLIGHT" preview - -o no/such/dir/p.png $S --sphere-size 48
has err.txt "no/such/dir/p.png"
finish
