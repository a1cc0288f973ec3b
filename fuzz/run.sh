#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan + coverage) into build-fuzz and runs
# each from a seed corpus made of ../shared/data's small files and
# files envlight writes itself. A crash leaves its input in build-fuzz/crashes/ and fails: add it
# to tests/fuzz_regressions/ with a test in tests/test_fuzz_regressions.c once fixed.
#   bash fuzz/run.sh SECONDS   each target for SECONDS with a random seed (exploring)
#   bash fuzz/run.sh ci        each target for a fixed number of runs with seed 1, about a
#                              minute each: the same inputs every time (what CI runs)
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-60}
CC=clang cmake -S . -B build-fuzz -DENVL_FUZZ=ON -DENVL_SANITIZE=ON -DENVL_TESTS=OFF \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build-fuzz -j"$(nproc)" >/dev/null
corpus=build-fuzz/corpus
rm -rf "$corpus" build-fuzz/crashes && mkdir -p "$corpus"/{hdr,exr,pfm,any,cli,pov} build-fuzz/crashes
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
printf 'PF\n2 1\n-1.0\n%024d' 0 > "$corpus/pfm/tiny.pfm"
for f in tests/fuzz_regressions/*; do   # inputs that once crashed (tests/test_fuzz_regressions.c)
  case "$f" in *.exr) cp "$f" "$corpus/exr/";; *.hdr|*.pic) cp "$f" "$corpus/hdr/";; *.pfm) cp "$f" "$corpus/pfm/";; esac
done
cp "$corpus"/hdr/* "$corpus"/exr/* "$corpus"/pfm/* "$corpus/any/" 2>/dev/null || true
cp povray_include/examples/*.pov "$corpus/pov/"
printf -- '--rotate\0000\0--width\00064\0--layout-in\0angular' > "$corpus/cli/a"
printf -- '--sun-elevation=10\0-n\0004\0--strict' > "$corpus/cli/b"
status=0
declare -A ci_runs=([hdr]=60000 [exr]=30000 [pfm]=100000 [any]=30000 [cli]=1000000 [pov]=300000)
for t in hdr exr pfm any cli pov; do
  name=fuzz_$t
  [ $t = cli ] && name=fuzz_cli_options
  [ $t = pov ] && name=fuzz_pov_scene
  if [ "$mode" = ci ]; then
    limit=(-seed=1 -runs="${ci_runs[$t]}")
  else
    limit=(-max_total_time="$mode")
  fi
  echo "== $name ${limit[*]}"
  if ! "build-fuzz/$name" "${limit[@]}" -rss_limit_mb=4096 -timeout=20 \
      -artifact_prefix=build-fuzz/crashes/ "$corpus/$t" 2>build-fuzz/$name.log; then
    echo "FAIL: $name found a crash:"; tail -40 build-fuzz/$name.log; status=1
  else
    grep -E '^#[0-9]+.*(DONE|pulse)' build-fuzz/$name.log | tail -1
  fi
done
exit $status
