#!/usr/bin/env bash
# Costs on maps whose pixels are far from square (issue 30, 4.4 and 4.5): CPU seconds (user +
# sys, whole process) of `sh` (with its error: the diffuse reference), `lights -n 4` and
# `prefilter --size 64 --levels 3` on lat-long maps 1 x 2048, 1 x 16384, 16384 x 1 and 4 x 4096,
# each as a ratio to the same command on the 1024 x 512 baseline of the same run (ratio 1:
# a map costs what a common 1k map costs). With --before OTHER, the same commands run by a
# second build (say, the code before the fix) in the same run, each killed after --limit
# seconds (default 300: "> 300"). Prints a markdown table; with --docs DIR also writes it to
# DIR/coarse_bench.md after a header (the command, date, load average, machine).
# Usage: scripts/coarse_bench.sh [--docs DIR] [--before ENVLIGHT] [--limit S] ENVLIGHT
usage="usage: bash scripts/coarse_bench.sh [--docs DIR] [--before ENVLIGHT] [--limit S] ENVLIGHT"
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "$usage"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -euo pipefail
command_line="scripts/coarse_bench.sh $*"
docs= before= limit=300
while [ $# -gt 1 ]; do
  case "$1" in
    --docs) docs=$2; shift 2 ;;
    --before) before=$2; shift 2 ;;
    --limit) limit=$2; shift 2 ;;
    *) break ;;
  esac
done
[ $# = 1 ] || { echo "$usage" >&2; exit 2; }
ENVLIGHT=$1
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
date=$(date +%Y-%m-%dT%H:%M:%S); load0=$(cut -d' ' -f1-3 /proc/loadavg)

# The maps: L = 1 + 0.5 z + 0.25 x (z, x of each pixel's centre), RGB, as PFM.
python3 - "$tmp" <<'PY'
import math, struct, sys
def pfm(name, w, h):
    with open("%s/%s" % (sys.argv[1], name), "wb") as o:
        o.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        for r in range(h - 1, -1, -1):
            t = math.pi * (0.5 - (r + 0.5) / h)
            row = []
            for c in range(w):
                p = math.pi * (1 - 2 * (c + 0.5) / w)
                v = 1 + 0.5 * math.sin(t) + 0.25 * math.cos(t) * math.cos(p)
                row += [v, 0.8 * v, 0.6 * v]
            o.write(struct.pack("<%df" % len(row), *row))
for w, h in ((1024, 512), (1, 2048), (1, 16384), (16384, 1), (4, 4096)):
    pfm("m%dx%d.pfm" % (w, h), w, h)
PY

# cpu BIN MAP ARGS...: CPU seconds of `BIN ARGS` on MAP, or "> limit"
cpu() {
  local bin=$1 map=$2; shift 2
  if /usr/bin/time -f "%U %S" -o "$tmp/t" timeout "$limit" "$bin" "$@" "$tmp/$map" \
      --layout-in latlong --quiet >/dev/null 2>"$tmp/err"; then
    awk '{printf "%.3f", $1 + $2}' "$tmp/t"
  else
    echo "> $limit"
  fi
}
commands=("sh --json" "lights -n 4" "prefilter -o $tmp/out --size 64 --levels 3")
names=("sh (error measured)" "lights -n 4" "prefilter 64, 3 levels")
table() {
  local head="| map | command | CPU s | ratio to 1024 x 512 |" rule="|---|---|---|---|"
  [ -z "$before" ] || { head="$head before: CPU s | before: ratio |"; rule="$rule---|---|"; }
  echo "$head"; echo "$rule"
  for i in 0 1 2; do
    read -r -a args <<<"${commands[$i]}"
    base=$(cpu "$ENVLIGHT" m1024x512.pfm "${args[@]}")
    [ -z "$before" ] || base_b=$(cpu "$before" m1024x512.pfm "${args[@]}")
    for m in 1024x512 1x2048 1x16384 16384x1 4x4096; do
      if [ "$m" = 1024x512 ]; then s=$base; else s=$(cpu "$ENVLIGHT" "m$m.pfm" "${args[@]}"); fi
      line="| $m | ${names[$i]} | $s | $(awk -v a="$s" -v b="$base" 'BEGIN { if (a ~ />/) print "-"; else printf "%.1f", a / (b > 0.001 ? b : 0.001) }') |"
      if [ -n "$before" ]; then
        if [ "$m" = 1024x512 ]; then sb=$base_b; else sb=$(cpu "$before" "m$m.pfm" "${args[@]}"); fi
        line="$line $sb | $(awk -v a="$sb" -v b="$base_b" 'BEGIN { if (a ~ />/) print "-"; else printf "%.1f", a / (b > 0.001 ? b : 0.001) }') |"
      fi
      echo "$line"
    done
  done
}
out=$(table)
echo "$out"
if [ -n "$docs" ]; then
  {
    echo "# Costs on maps of far-from-square pixels"
    echo
    echo "Written by \`$command_line\` on $date; load average $load0 before, $(cut -d' ' -f1-3 /proc/loadavg) after;"
    echo "$(nproc) cores, $(uname -m). CPU seconds (user + sys) of the whole process, one run each; the ratio is"
    echo "to the same command on the 1024 x 512 map of the same run. What it shows: [reliability.md](reliability.md),"
    echo "\"Hostile input, round three\" (costs follow pixels)."
    echo
    echo "$out"
  } >"$docs/coarse_bench.md.tmp" && mv "$docs/coarse_bench.md.tmp" "$docs/coarse_bench.md"
fi
