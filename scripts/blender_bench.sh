#!/bin/sh
# Accuracy against time in Blender (issue 6): runs scripts/blender_bench.py in headless Blender
# for rooitou_park_1k.hdr (../shared/data) and the built-in sky, then prints the Markdown tables.
#   scripts/blender_bench.sh [OUT_DIR] [extra blender_bench.py options]
# Needs ./build (envlight CLI and libenvlight.so); installs the add-on zip into private
# Blender user folders under OUT_DIR. The maps run one after the other (timing).
set -eu
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${1:-/tmp/envlight_bench}; [ $# -gt 0 ] && shift
BUILD=${ENVL_BUILD_DIR:-$ROOT/build}
DATA=${ENVL_SHARED_DATA:-$ROOT/../shared/data}
mkdir -p "$OUT"
[ -x "$BUILD/envlight" ] || { cmake -S "$ROOT" -B "$BUILD" && cmake --build "$BUILD" -j2; }
python3 "$ROOT/scripts/blender_addon_zip.py" --library "$BUILD/libenvlight.so" \
    -o "$OUT/envlight_addon.zip" >/dev/null
"$BUILD/envlight" convert - "$OUT/sky.hdr"
results=""
for map in "$DATA/latlong_hdri/rooitou_park_1k.hdr" "$OUT/sky.hdr"; do
    [ -f "$map" ] || { echo "skip: $map absent" >&2; continue; }
    name=$(basename "$map" .hdr)
    env -u ENVLIGHT_LIBRARY -u PYTHONPATH BLENDER_USER_SCRIPTS="$OUT/user/scripts" \
        BLENDER_USER_CONFIG="$OUT/user/config" \
        blender -b --factory-startup --python "$ROOT/scripts/blender_bench.py" -- \
        --hdr "$map" --zip "$OUT/envlight_addon.zip" --out "$OUT/$name.json" "$@" \
        > "$OUT/$name.log" 2>&1 || { tail -20 "$OUT/$name.log" >&2; exit 1; }
    results="$results $OUT/$name.json"
done
python3 "$ROOT/scripts/blender_bench.py" --report $results | tee "$OUT/report.md"
