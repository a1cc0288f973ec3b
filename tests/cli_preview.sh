#!/usr/bin/env bash
# envlight preview: the PNG decodes (python3 zlib: IHDR, IDAT, every row's filter byte) at the
# documented size, the shading options run, usage errors exit 2, bad input exits 1 naming the
# file, and a failed run leaves an existing output untouched.
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
# notes on stderr without --quiet: one line per approximation with its error and seconds
run "$ENVLIGHT" preview - -o c.png --sky-width 128 --reference-width 64 --sphere-size 48
has err.txt "median cut lights .*error .*%"
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
