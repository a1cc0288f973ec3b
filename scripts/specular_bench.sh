#!/usr/bin/env bash
# The specular chain against the issue's targets (README "Accuracy against time (specular)"):
# for each 2048 x 1024 map, the levels of roughness 0.1, 0.25, 0.5, 0.75, 1 with default sizes
# and samples, (a) the sun baked into the levels, (b) --sun-lights, (c) plain GGX importance
# sampling with 1024 samples per texel; glossy error (docs/design.md) and seconds of each level, and
# the ratio of (c)'s total time to (b)'s, all measured in the same run. Prints a markdown table.
# Usage: scripts/specular_bench.sh ENVLIGHT [MAP...]   (MAP '-' = the built-in sky at 2048)
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "usage: bash scripts/specular_bench.sh ENVLIGHT [MAP...]"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -eu
ENVLIGHT=$1; shift
[ $# -gt 0 ] || set -- -
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
R=0.1,0.25,0.5,0.75,1
echo "| map | roughness | baked: error % | s | sun lights: error % | s | plain 1024: error % | s |"
echo "|---|---|---|---|---|---|---|---|"
for map in "$@"; do
  if [ "$map" = - ]; then in=(- --sky-width 2048); name="built-in sky"
  else in=("$map" --width 2048); name=$(basename "$map" .hdr); fi
  "$ENVLIGHT" prefilter "${in[@]}" -o "$tmp/a" --roughness $R --json --quiet >"$tmp/a.json"
  "$ENVLIGHT" prefilter "${in[@]}" -o "$tmp/b" --roughness $R --json --quiet --sun-lights >"$tmp/b.json"
  "$ENVLIGHT" prefilter "${in[@]}" -o "$tmp/c" --roughness $R --json --quiet --unfiltered --samples 1024 >"$tmp/c.json"
  python3 - "$name" "$tmp" <<'PY'
import json, sys
name, tmp = sys.argv[1], sys.argv[2]
a, b, c = (json.load(open(f"{tmp}/{k}.json")) for k in "abc")
for i, (x, y, z) in enumerate(zip(a["specular"], b["specular"], c["specular"])):
    print(f"| {name if i == 0 else ''} | {x['roughness']:g} | {100 * x['glossy_error']:.2f} | "
          f"{x['seconds']:.3f} | {100 * y['glossy_error']:.2f} | {y['seconds']:.3f} | "
          f"{100 * z['glossy_error']:.1f} | {z['seconds']:.2f} |")
ta, tb, tc = (sum(l["seconds"] for l in d["specular"]) for d in (a, b, c))
n = b.get("sun_lights", {}).get("count", 0)
print(f"| | all five | | {ta:.2f} | ({n} light{'s' if n != 1 else ''}) | {tb:.2f} | "
      f"| {tc:.2f} ({tc / tb:.1f}x the sun-light chain) |")
PY
done
