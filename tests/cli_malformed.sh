#!/usr/bin/env bash
# Malformed input and unusable paths through the command line: each case exits 1 (not a crash,
# not a hang: every command runs under `timeout`) with a message on stderr naming the file and
# the cause, and writes nothing. The readers' own tests (test_hdr, test_pfm, test_exr) cover
# every byte prefix and field; this checks that the CLI passes their errors on, for the cases
# docs/design.md lists. cli_basics.sh already covers: a missing file, a directory and an empty file
# given to `info`, an absurd PFM size, a damaged .exr, a bad PFM magic.
. "$(dirname "$0")/clitest.sh"
T="timeout 120"

# bad FILE REGEX DESCRIPTION -- COMMAND...: exit 1, nothing on stdout, stderr matches REGEX
bad() { local file=$1 re=$2 what=$3; shift 4
  expect 1 "$what" -- $T "$@"
  has err.txt "$file: $re"
  empty out.txt; }

# ---- valid small files to cut up
expect 0 "sky as .hdr" -- "$ENVLIGHT" convert - s.hdr --sky-width 16 --quiet
expect 0 "sky as .pfm" -- "$ENVLIGHT" convert - s.pfm --sky-width 16 --quiet
expect 0 "sky as .exr" -- "$ENVLIGHT" convert - s.exr --sky-width 16 --quiet

# ---- truncated at every header boundary (and inside the pixels)
# s.hdr: "#?RADIANCE\n" (11) "FORMAT=32-bit_rle_rgbe\n" (34) "\n" (35) "-Y 8 +X 16\n" (46) pixels
for n in 0 2 11 18 34 35 40 46 47 60 $(($(stat -c %s s.hdr) - 1)); do
  head -c "$n" s.hdr > "t$n.hdr"
  if [ "$n" = 0 ]; then re="file is empty"; else re="truncated"; fi
  bad "t$n.hdr" "$re" ".hdr cut at byte $n" -- "$ENVLIGHT" info "t$n.hdr"
done
# s.pfm: "PF\n" (3) "16 8\n" (8) "-1\n" (11) floats
for n in 2 3 6 8 10 11 12 100 $(($(stat -c %s s.pfm) - 1)); do
  head -c "$n" s.pfm > "t$n.pfm"
  bad "t$n.pfm" "PFM" ".pfm cut at byte $n" -- "$ENVLIGHT" info "t$n.pfm"
done
# s.exr: magic (4), version (8), inside the header attributes, inside the offset table / data
last=$(($(stat -c %s s.exr) - 1))
for n in 3 4 8 40 200 $last; do
  head -c "$n" s.exr > "t$n.exr"
  case $n in
    3) re="not an OpenEXR file (the first 4 bytes are not the magic number" ;;
    "$last") re="cannot read the chunk of scanline 0" ;;
    *) re="not a readable OpenEXR file" ;;
  esac
  bad "t$n.exr" "$re" ".exr cut at byte $n" -- "$ENVLIGHT" info "t$n.exr"
done

# ---- RLE runs and literals past the end of the scanline (adaptive RLE, 10-pixel scanline)
printf '#?RADIANCE\n\n-Y 1 +X 10\n\2\2\0\12\214\1' > run.hdr        # a run of 12
bad run.hdr "RLE run of 12 at byte 27 overruns the 10-pixel scanline 0" "RLE run" -- \
  "$ENVLIGHT" info run.hdr
printf '#?RADIANCE\n\n-Y 1 +X 10\n\2\2\0\12\13abcdefghijk' > lit.hdr # a literal of 11
bad lit.hdr "RLE literal of 11 at byte 27 overruns" "RLE literal" -- "$ENVLIGHT" info lit.hdr
printf '#?RADIANCE\n\n-Y 1 +X 10\n\2\2\0\11\211\1' > claim.hdr      # header says 9 pixels
bad claim.hdr "scanline 0 at byte 23: run-length header claims 9 pixels, the scanline has 10" "RLE length" -- \
  "$ENVLIGHT" info claim.hdr

# ---- absurd and zero dimensions: refused from the header, before allocating
printf '#?RADIANCE\n\n-Y 1000000 +X 1000000\n\1\2\3\4' > huge.hdr
bad huge.hdr "image size 1000000 x 1000000 = 1000000000000 pixels exceeds the limit" \
  "absurd .hdr size" -- "$ENVLIGHT" info huge.hdr
printf '#?RADIANCE\n\n-Y 99999999999999999999 +X 1\n\1\2\3\4' > huge2.hdr
bad huge2.hdr "image size 1 x .* exceeds the limit" "20-digit .hdr size" -- "$ENVLIGHT" info huge2.hdr
printf '#?RADIANCE\n\n-Y 16000 +X 16000\n\1\2\3\4' > short.hdr       # 4 bytes for 16000 rows
bad short.hdr "truncated: 16000 scanlines need at least 64000 bytes" "size beyond the data" -- \
  "$ENVLIGHT" info short.hdr
bad s.hdr "image size 16 x 8 = 128 pixels exceeds the limit of 100 pixels" "--max-pixels" -- \
  "$ENVLIGHT" info s.hdr --max-pixels 100
printf '#?RADIANCE\n\n-Y 0 +X 3\n\1\2\3\4' > zero.hdr
bad zero.hdr "resolution line at byte 12 gives 3 x 0 pixels: both must be at least 1" "zero .hdr height" -- \
  "$ENVLIGHT" info zero.hdr
printf 'PF\n0 1\n-1\n' > zero.pfm
bad zero.pfm "PFM size 0 x 1: both must be at least 1" "zero .pfm width" -- "$ENVLIGHT" info zero.pfm
printf 'PF\n-3 1\n-1\n' > neg.pfm
bad neg.pfm "PFM" "negative .pfm width" -- "$ENVLIGHT" info neg.pfm

# ---- negative, NaN and Inf floats: replaced with a warning, refused with --strict
python3 - <<'PY'
import struct
v = [float("nan"), 1, 1, float("inf"), 1, 1, -1, 1, 1, 1, 1, 1]  # 2 x 2: NaN, Inf, negative
open("odd.pfm", "wb").write(b"PF\n2 2\n-1\n" + struct.pack("<12f", *v))
PY
expect 0 "non-finite pixels replaced" -- $T "$ENVLIGHT" info odd.pfm --json
has err.txt "odd.pfm: 2 pixels with NaN or Inf: NaN and -Inf set to 0, +Inf to 1 (the largest finite value)"
# the -1 beside 1s and a 0 (the NaN): too little light around it to fill it from (4 x its deficit)
has err.txt "odd.pfm: 1 pixels with negative values (down to -1): 1 values with too little light around them set to 0"
checks=$((checks + 1))
python3 -c 'import json; d = json.load(open("out.txt")); r = d["repair"]; assert d["nonfinite_pixels"] == 2 and d["negative_pixels"] == 1 and all(x == x for x in d["max"]) and r["infinity_value"] == 1 and r["negative_min"] == -1 and r["unfilled_values"] == 1 and r["fill_window"] == 0 and r["filled_energy"] == [0, 0, 0] and r["added_energy"][0] > 0' ||
  fail "odd.pfm: counts, repair or a NaN in the JSON"
bad odd.pfm "2 pixels with NaN or Inf and 1 with negative values (--strict)" "--strict" -- \
  "$ENVLIGHT" info odd.pfm --strict
expect 1 "--strict on lights" -- $T "$ENVLIGHT" lights odd.pfm --strict
has err.txt "odd.pfm: 2 pixels with NaN or Inf"

# ---- wrong magic: content decides the format, whatever the name
head -c 300 /dev/urandom | tr '#' 'x' > rnd.hdr
bad rnd.hdr "not a Radiance file" "random bytes" -- "$ENVLIGHT" info rnd.hdr
printf '\211PNG\r\n\032\n\0\0\0\rIHDR' > png.hdr
bad png.hdr "not a Radiance file" "a PNG signature" -- "$ENVLIGHT" info png.hdr
printf 'P6\n1 1\n255\nabc' > ppm.pfm
bad ppm.pfm "not a PFM file" "a PPM" -- "$ENVLIGHT" info ppm.pfm
printf 'v/1\001\2\0\0\0junkjunkjunkjunk' > junk.exr
bad junk.exr "not a readable OpenEXR file" "EXR magic, junk header" -- "$ENVLIGHT" info junk.exr

# ---- directories and empty files given to every command that reads an environment
mkdir -p adir.hdr
: > empty.hdr
rm -rf pre x.inc x.pfm
for cmd in "lights" "sh" "pov -o x.inc" "prefilter -o pre" "convert"; do
  set -- $cmd
  c=$1; shift
  extra=("$@")
  [ "$c" = convert ] && extra=(x.pfm)
  bad adir.hdr "not a regular file" "$c on a directory" -- "$ENVLIGHT" "$c" adir.hdr "${extra[@]}"
  bad empty.hdr "file is empty" "$c on an empty file" -- "$ENVLIGHT" "$c" empty.hdr "${extra[@]}"
done
# (prefilter makes its output folder only once the input is read: not even that)
[ ! -e x.inc ] && [ ! -e x.pfm ] && [ ! -e pre ] || fail "an output was written from bad input"
checks=$((checks + 1))

# ---- unreadable input and unwritable outputs. As root, permissions do not deny anything:
# those two cases then run as the unprivileged user nobody (setpriv), or are skipped.
as_user=()
if [ "$(id -u)" = 0 ]; then
  if command -v setpriv >/dev/null &&
     setpriv --reuid=65534 --regid=65534 --clear-groups "$ENVLIGHT" info --help >/dev/null 2>&1; then
    as_user=(setpriv --reuid=65534 --regid=65534 --clear-groups)
  else
    as_user=(none)
  fi
fi
if [ "${as_user[0]:-}" = none ]; then
  echo "SKIP: unreadable and read-only cases: running as root and setpriv cannot run $ENVLIGHT as nobody"
else
  cp s.hdr noread.hdr && chmod 000 noread.hdr
  bad noread.hdr "cannot open: Permission denied" "unreadable input" -- \
    "${as_user[@]}" "$ENVLIGHT" info noread.hdr
  mkdir -p ro && chmod 555 ro
  bad ro/x.pfm "cannot create a file there: Permission denied" "read-only folder" -- \
    "${as_user[@]}" "$ENVLIGHT" convert s.hdr ro/x.pfm --quiet
  bad ro/l.json "cannot create a file there: Permission denied" "read-only folder (lights)" -- \
    "${as_user[@]}" "$ENVLIGHT" lights s.hdr -o ro/l.json --quiet
  [ -z "$(ls -A ro)" ] || fail "ro/ holds files: $(ls -A ro)"
  checks=$((checks + 1))
fi
# Paths that cannot be written by anyone: a missing folder, a regular file used as a folder,
# a folder where the file should go.
for out in /nonexistent-envl/o s.hdr/o; do
  case $out in /nonexistent-envl/o) why="No such file or directory" ;; *) why="Not a directory" ;; esac
  bad "$out.pfm" "cannot create a file there: $why" "convert to $out.pfm" -- \
    "$ENVLIGHT" convert s.hdr "$out.pfm" --quiet
  bad "$out.json" "cannot create a file there: $why" "lights -o $out.json" -- \
    "$ENVLIGHT" lights s.hdr -o "$out.json" --quiet
  bad "$out.exr" "cannot create a file there: $why" "lights --residual $out.exr" -- \
    "$ENVLIGHT" lights s.hdr -n 2 --residual "$out.exr" -o l.json --quiet
  bad "$out.json" "cannot create a file there: $why" "sh -o $out.json" -- \
    "$ENVLIGHT" sh s.hdr -o "$out.json" --quiet
  bad "$out.inc" "cannot create a file there: $why" "pov -o $out.inc" -- \
    "$ENVLIGHT" pov s.hdr -o "$out.inc" --quiet
done
mkdir -p dir.pfm dir.json
bad dir.pfm "cannot replace: Is a directory" "convert onto a folder" -- \
  "$ENVLIGHT" convert s.hdr dir.pfm --quiet
bad dir.json "cannot replace: Is a directory" "lights -o onto a folder" -- \
  "$ENVLIGHT" lights s.hdr -o dir.json --quiet
bad /nonexistent-envl/pre "cannot create the directory" "prefilter into a missing folder" -- \
  "$ENVLIGHT" prefilter s.hdr -o /nonexistent-envl/pre --size 32 --quiet
# said before the map is read and the products computed (seconds of work): with a missing
# input too, the folder is what it names
bad /nonexistent-envl/pre "cannot create the directory: No such file or directory" \
  "prefilter into a missing folder, before reading" -- \
  "$ENVLIGHT" prefilter no-such-map.hdr -o /nonexistent-envl/pre --size 32 --quiet
bad s.hdr/pre "cannot create the directory: Not a directory" "prefilter under a regular file" -- \
  "$ENVLIGHT" prefilter s.hdr -o s.hdr/pre --size 32 --quiet
bad s.hdr/irradiance.exr ".*cannot create a file there: Not a directory" "prefilter into a regular file" -- \
  "$ENVLIGHT" prefilter s.hdr -o s.hdr --size 32 --quiet
[ ! -e l.json ] || fail "lights wrote l.json although its residual failed"
checks=$((checks + 1))
ls -A . dir.pfm dir.json | grep -q 'tmp-\|\.envl-' && fail "temporary file left behind: $(ls -A)"
checks=$((checks + 1))

finish
