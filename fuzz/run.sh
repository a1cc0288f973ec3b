#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan + coverage) into build-fuzz (or
# $ENVL_FUZZ_BUILD) and runs each from a seed corpus made of ../shared/data's small files and
# files envlight writes itself (fuzz_writers: small images whose N-th write step fails). A
# crash leaves its input in build-fuzz/crashes/ and fails: add it to tests/fuzz_regressions/
# with a test in tests/test_fuzz_regressions.c once fixed.
#   bash fuzz/run.sh SECONDS   each target for SECONDS with a random seed (exploring)
#   bash fuzz/run.sh ci        each target for a fixed number of runs with seed 1, about a
#                              minute each: the same inputs every time (what CI runs)
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-60}
fz=${ENVL_FUZZ_BUILD:-build-fuzz}
CC=clang CXX=clang++ cmake -S . -B "$fz" -DENVL_FUZZ=ON -DENVL_SANITIZE=ON -DENVL_TESTS=OFF \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$fz" -j"$(nproc)" >/dev/null
corpus=$fz/corpus
rm -rf "$corpus" "$fz/crashes" && mkdir -p "$corpus"/{hdr,exr,pfm,any,cli,pov,writers} "$fz/crashes"
data=${ENVL_SHARED_DATA:-../shared/data}
small() { find "$@" -type f -size -200k 2>/dev/null; }
for f in $(small "$data/radiance_hdr" "$data/synthetic"); do cp "$f" "$corpus/hdr/"; done
for f in $(small "$data/openexr" -name '*.exr'); do cp "$f" "$corpus/exr/"; done
cli=build/envlight
if [ -x "$cli" ]; then
  "$cli" convert - "$corpus/pfm/sky.pfm" --sky-width 16 --quiet
  "$cli" convert - "$corpus/exr/sky.exr" --sky-width 16 --quiet
  "$cli" convert - "$corpus/exr/sky_half.exr" --sky-width 16 --half --quiet
  "$cli" convert - "$corpus/hdr/sky.hdr" --sky-width 64 --quiet
  "$cli" convert - "$corpus/any/cross.pfm" --sky-width 16 --layout-out cross --size 4 --quiet
fi
# DWAA / DWAB (decoded by the OpenEXR C++ library): the test files are over 200 KB, so small
# cuts of them, re-encoded by oiiotool (the same library): scanlines and tiles; a fixed
# DateTime and no Software attribute, so the same bytes every time
dwa=$data/openexr/OpenEXRTest/comp_dwab_v1.exr
if command -v oiiotool >/dev/null && [ -f "$dwa" ]; then
  dwa_cut() { oiiotool --nosoftwareattrib "$dwa" --cut "$1" --attrib DateTime "2026:01:01 00:00:00" "${@:2}"; }
  dwa_cut 24x20+300+300 --origin +0+0 --compression dwaa -o "$corpus/exr/dwaa.exr"
  dwa_cut 24x20+300+300 --compression dwab -o "$corpus/exr/dwab.exr"
  dwa_cut 40x20+300+300 --tile 16 16 --compression dwaa -o "$corpus/exr/dwaa_tiled.exr"
else
  echo "fuzz/run.sh: oiiotool or $dwa absent: no DWA seeds" >&2
fi
printf 'PF\n2 1\n-1.0\n%024d' 0 > "$corpus/pfm/tiny.pfm"
for f in tests/fuzz_regressions/*; do   # inputs that once crashed (tests/test_fuzz_regressions.c)
  case "$f" in *.exr) cp "$f" "$corpus/exr/";; *.hdr|*.pic) cp "$f" "$corpus/hdr/";; *.pfm) cp "$f" "$corpus/pfm/";; esac
done
cp "$corpus"/hdr/* "$corpus"/exr/* "$corpus"/pfm/* "$corpus/any/" 2>/dev/null || true
cp povray_include/examples/*.pov "$corpus/pov/"
printf -- '--rotate\0000\0--width\00064\0--layout-in\0angular' > "$corpus/cli/a"
printf -- '--sun-elevation=10\0-n\0004\0--strict' > "$corpus/cli/b"
# writers: kind (0 exr, 1 exr half, 2 hdr, 3 pfm, 4 png rgbm, 5 png srgb, 6 text), width - 1,
# height - 1, failing step - 1, then pixels as little-endian floats (a NaN, an Inf, negatives)
for k in 0 1 2 3 4 5 6; do
  python3 -c 'import struct, sys; k = int(sys.argv[1]); v = [(i * 0.37) % 7 - (i % 13 == 0) for i in range(94)]
sys.stdout.buffer.write(bytes([k, 9, 3, 3 * k]) + struct.pack("<96f", float("nan"), float("inf"), *v))' $k \
    > "$corpus/writers/$k"
done
# and a .hdr whose pixels RGBE holds (the others it refuses before writing)
python3 -c 'import struct, sys; v = [(i * 0.37) % 7 for i in range(96)]
sys.stdout.buffer.write(bytes([2, 9, 3, 9]) + struct.pack("<96f", *v))' > "$corpus/writers/2ok"
status=0
declare -A ci_runs=([hdr]=60000 [exr]=30000 [pfm]=100000 [any]=30000 [cli]=1000000 [pov]=300000
  [writers]=80000)
for t in hdr exr pfm any cli pov writers; do
  name=fuzz_$t
  [ $t = cli ] && name=fuzz_cli_options
  [ $t = pov ] && name=fuzz_pov_scene
  if [ "$mode" = ci ]; then
    limit=(-seed=1 -runs="${ci_runs[$t]}")
  else
    limit=(-max_total_time="$mode")
  fi
  echo "== $name ${limit[*]}"
  # -close_fd_mask=1: the targets' stdout closed (fuzz_cli_options prints the help text
  # for every --help it is fed: tens of thousands of lines in the CI log)
  if ! "$fz/$name" "${limit[@]}" -rss_limit_mb=4096 -timeout=20 -close_fd_mask=1 \
      -artifact_prefix="$fz/crashes/" "$corpus/$t" 2>"$fz/$name.log"; then
    echo "FAIL: $name found a crash:"; tail -40 "$fz/$name.log"; status=1
  else
    grep -E '^#[0-9]+.*(DONE|pulse)' "$fz/$name.log" | tail -1
  fi
done
exit $status
