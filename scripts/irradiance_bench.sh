#!/usr/bin/env bash
# The irradiance map's methods on every map (docs/accuracy.md, "Irradiance map"): for each map,
# the default `split` and the former default `resampled` at 64 x 32 (diffuse error of
# docs/design.md and seconds, the error measure excluded), and at 512 x 256 (the lat-long a
# 128-face cube is computed from) with --no-error: seconds of split on every map, of resampled
# on the first (about a minute each). Prints a markdown table; with
# --docs DIR also writes it to DIR/irradiance_bench.md after a header (the command, date,
# load average, machine).
# Usage: scripts/irradiance_bench.sh [--docs DIR] ENVLIGHT [MAP...]   (MAP '-' = the built-in
# sky; default: the sky)
usage="usage: bash scripts/irradiance_bench.sh [--docs DIR] ENVLIGHT [MAP...]"
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "$usage"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -euo pipefail
command_line="scripts/irradiance_bench.sh $*"
docs=
if [ "${1:-}" = --docs ]; then
  docs=${2:?"$usage"}; shift 2
fi
[ $# -gt 0 ] || { echo "$usage" >&2; exit 2; }
ENVLIGHT=$1; shift
[ $# -gt 0 ] || set -- -
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
date=$(date +%Y-%m-%dT%H:%M:%S); load0=$(cut -d' ' -f1-3 /proc/loadavg)
# irr FILE METHOD SIZE [--no-error]: "error seconds" of the irradiance line
irr() {
  local f=$1 m=$2 s=$3; shift 3
  "$ENVLIGHT" prefilter "$f" --irradiance --irradiance-method "$m" --irradiance-size "$s" \
      "$@" -o "$tmp/o" --json --quiet >"$tmp/j.json"
  python3 -c 'import json,sys; i=json.load(open(sys.argv[1]))["irradiance"]; e=i["diffuse_error"]
print("%s %.3f" % ("-" if e is None else "%.3f" % (100 * e), i["seconds"]))' "$tmp/j.json"
}
table() {
  echo "| map | split 64: error % | s | resampled 64: error % | s | split 512: s | resampled 512: s |"
  echo "|---|---|---|---|---|---|---|"
  local first=1
  for f in "$@"; do
    if [ "$f" = - ]; then n="built-in sky"; else n=$(basename "$f" .hdr); fi
    read -r e1 s1 <<<"$(irr "$f" split 64)"
    read -r e2 s2 <<<"$(irr "$f" resampled 64)"
    read -r _ s3 <<<"$(irr "$f" split 512 --no-error)"
    s4=-
    [ $first = 0 ] || read -r _ s4 <<<"$(irr "$f" resampled 512 --no-error)"
    first=0
    echo "| $n | $e1 | $s1 | $e2 | $s2 | $s3 | $s4 |"
  done
}
out=$(table "$@")
echo "$out"
if [ -n "$docs" ]; then
  {
    echo "# Irradiance map methods"
    echo
    echo "Written by \`$command_line\` on $date; load average $load0 before, $(cut -d' ' -f1-3 /proc/loadavg) after;"
    echo "$(nproc) cores, $(uname -m). Seconds are the library's (the error measure excluded), one run each."
    echo "How to read it: [accuracy.md](accuracy.md), \"Irradiance map\"."
    echo
    echo "$out"
  } >"$docs/irradiance_bench.md.tmp" && mv "$docs/irradiance_bench.md.tmp" "$docs/irradiance_bench.md"
fi
