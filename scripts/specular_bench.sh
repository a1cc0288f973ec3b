#!/usr/bin/env bash
# The specular chain against the issue's targets (docs/specular_bench.md; how to read it:
# docs/accuracy.md, "The specular chain"): for each 2048 x 1024 map, the levels of roughness
# 0.1, 0.25, 0.5, 0.75, 1 with default sizes and samples, (a) the sun baked into the levels,
# (b) --sun-lights, (c) plain GGX importance sampling with 1024 samples per texel; glossy error
# (docs/design.md) and seconds of each level, and the ratio of (c)'s total time to (b)'s, all
# measured in the same run. Prints a markdown table; with --docs DIR also writes it to
# DIR/specular_bench.md after a header (the command, date, load average, machine).
# Usage: scripts/specular_bench.sh [--docs DIR] ENVLIGHT [MAP...]   (MAP '-' = the built-in
# sky at 2048)
usage="usage: bash scripts/specular_bench.sh [--docs DIR] ENVLIGHT [MAP...]"
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "$usage"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -euo pipefail
command_line="scripts/specular_bench.sh $*"
docs=
if [ "${1:-}" = --docs ]; then
  docs=${2:?"$usage"}; shift 2
fi
[ $# -gt 0 ] || { echo "$usage" >&2; exit 2; }
ENVLIGHT=$1; shift
[ $# -gt 0 ] || set -- -
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
date=$(date +%Y-%m-%dT%H:%M:%S); start=$(date +%s); load0=$(cut -d' ' -f1-3 /proc/loadavg)
R=0.1,0.25,0.5,0.75,1
table() {
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
}
table "$@" | tee "$tmp/table.md"

[ -n "$docs" ] || exit 0
mkdir -p "$docs"
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
{
  echo "# The specular chain: accuracy against time"
  echo
  echo "Written by \`$command_line\` (do not edit by hand; run it again to update this file)."
  echo
  echo "- date: $date; took $(( $(date +%s) - start )) s"
  echo "- load average at start / end: $load0 / $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "- machine: ${cpu:-$(uname -m)}, $(nproc) cores; $("$ENVLIGHT" --version)"
  echo "- each map at 2048 x 1024; \`--roughness $R\` with the default sizes and samples"
  echo "  (levels 512, 256, 128, 64, 64 wide, each summing the cell pyramid per texel);"
  echo "  baked = the sun as point lobes in the levels; sun lights = \`--sun-lights\`;"
  echo "  plain 1024 = \`--unfiltered --samples 1024\`. Glossy error: docs/design.md's, the"
  echo "  level read bilinearly plus the sun lights, against the glossy reference (within 0.1 %"
  echo "  RMS of the sum over every pixel) at 1024 Fibonacci directions; seconds per level, the"
  echo "  error measure excluded"
  echo "- what a level's width costs in accuracy (the width each level would need for 1 %, its"
  echo "  time, and the curve against width at roughness 0.05-0.4):"
  echo "  [specular_width.md](specular_width.md)"
  echo
  cat "$tmp/table.md"
} >"$tmp/report.md"
# atomically: a temporary file in the same folder, renamed over the report
out=$docs/specular_bench.md
cp "$tmp/report.md" "$out.tmp-$$" && mv -f "$out.tmp-$$" "$out"
echo "specular_bench: wrote $out" >&2
