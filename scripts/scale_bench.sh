#!/usr/bin/env bash
# Every envlight command from 1K to 16K (issue 29; docs/scale_bench.md): a map with a sun
# (default $ENVL_SHARED_DATA/latlong_hdri/rooitou_park_1k.hdr, ENVL_SHARED_DATA by default
# ../shared/data) and one without (default lebombo_1k.hdr), each upsampled with `envlight convert MAP OUT --width W` to every width of
# --sizes (default 1024,2048,4096,8192,16384; W x W/2 pixels) as .hdr and .exr (--formats),
# cached in --cache DIR (default /var/tmp/envlight_scale: never the repository; a 16384 x 8192
# map's floats are 1.5 GiB). Each command is one whole process timed with /usr/bin/time
# (scripts/timed_run.sh, as scripts/peer_bench.sh), RUNS times (default 1; the median): CPU
# (user + sys) seconds, wall seconds, peak RSS. The commands, with their defaults (error
# measures on):
#   info, sh, lights --method fit|median|variance|sun, prefilter --irradiance,
#   prefilter --specular, gltf, pov, preview, convert (to the input's format)
# and, as the read that the others are compared with, `oiiotool -i:now=1 FILE` (OpenImageIO)
# and one memory pass over the map's floats (numpy, in-process, the least of 5: the
# floor any reader meets), and one fresh write of them (a new process allocating and writing
# them once, the median of 5: what the kernel's fresh pages cost any reader that makes a new
# map). brdf-lut reads no map: timed once. `bench` (minutes per map: the
# accuracy benchmark) and `version` are left out. envlight's read is `info` (decode into the
# canonical float map + one statistics pass). scripts/scale_bench.py writes the tables and
# the gnuplot figure; --docs DIR writes DIR/scale_bench.md and DIR/scale_bench.png with a header
# (command, date, load before and after, machine). Not part of CI. Needs the Debian packages
# time, python3-numpy, openimageio-tools and gnuplot-nox (scripts/build.sh installs them).
# Options: --runs N, --sizes LIST, --formats LIST (hdr,exr), --commands LIST (default all; the
# names as in the report), --cache DIR, --envlight PATH (default build/envlight), --docs DIR,
# --name NAME (the report's file name in DIR, default scale_bench: NAME.md, NAME.png).
usage="usage: bash scripts/scale_bench.sh [--runs N] [--sizes LIST] [--formats LIST] [--commands LIST] [--cache DIR] [--envlight PATH] [--docs DIR] [--name NAME] [SUN_MAP FREE_MAP]"
for a in "$@"; do
  case "$a" in  # --help: the usage and the header above, nothing run
    -h|--help) echo "$usage"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
  esac
done
set -euo pipefail
command_line="scripts/scale_bench.sh $*"
top=$(cd "$(dirname "$0")/.." && pwd)
source "$top/scripts/timed_run.sh"
PYTHON=${PYTHON:-/usr/bin/python3}
all_commands=info,sh,lights_fit,lights_median,lights_variance,lights_sun,irradiance,specular,gltf,pov,preview,convert,brdf_lut
runs=1 sizes=1024,2048,4096,8192,16384 formats=hdr,exr commands=$all_commands docs= report=scale_bench
cache=/var/tmp/envlight_scale ENVLIGHT=$top/build/envlight
maps=()
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs=${2:?"$usage"}; shift 2 ;;
    --sizes) sizes=${2:?"$usage"}; shift 2 ;;
    --formats) formats=${2:?"$usage"}; shift 2 ;;
    --commands) commands=${2:?"$usage"}; shift 2 ;;
    --cache) cache=${2:?"$usage"}; shift 2 ;;
    --envlight) ENVLIGHT=${2:?"$usage"}; shift 2 ;;
    --docs) docs=${2:?"$usage"}; shift 2 ;;
    --name) report=${2:?"$usage"}; shift 2 ;;
    -*) echo "$usage" >&2; exit 2 ;;
    *) maps+=("$1"); shift ;;
  esac
done
die() { echo "scale_bench: $*" >&2; exit 1; }
[[ $report =~ ^[A-Za-z0-9_.-]+$ ]] || { echo "scale_bench: --name wants a plain file name, not '$report'" >&2; exit 2; }
[[ $runs =~ ^[1-9][0-9]*$ ]] || { echo "scale_bench: --runs wants a count >= 1, not '$runs'" >&2; exit 2; }
[[ $sizes =~ ^[1-9][0-9]*(,[1-9][0-9]*)*$ ]] || { echo "scale_bench: --sizes wants widths like 1024,4096, not '$sizes'" >&2; exit 2; }
[[ ,$formats, =~ ^(,(hdr|exr))+,$ ]] || { echo "scale_bench: --formats wants some of hdr,exr, not '$formats'" >&2; exit 2; }
for c in ${commands//,/ }; do
  [[ ,$all_commands, == *,$c,* ]] || { echo "scale_bench: unknown command '$c' (of $all_commands)" >&2; exit 2; }
done
case ${#maps[@]} in
  0) data=${ENVL_SHARED_DATA:-$top/../shared/data}
     maps=("$data/latlong_hdri/rooitou_park_1k.hdr" "$data/latlong_hdri/lebombo_1k.hdr") ;;
  2) ;;
  *) echo "$usage" >&2; exit 2 ;;
esac
[ -x "$ENVLIGHT" ] || die "no envlight at $ENVLIGHT (bash scripts/build.sh, or --envlight PATH)"
for m in "${maps[@]}"; do [ -f "$m" ] || die "$m: no such map"; done
for t in /usr/bin/time oiiotool gnuplot; do
  command -v "$t" >/dev/null || die "no $t (Debian packages time, openimageio-tools, gnuplot-nox)"
done
"$PYTHON" -c 'import numpy' 2>/dev/null || die "no numpy for $PYTHON (Debian: python3-numpy)"
case "$(realpath -m "$cache")/" in "$top"/*) die "--cache $cache is inside the repository" ;; esac
mkdir -p "$cache" || die "cannot create $cache"

tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
work=$tmp/work; mkdir -p "$work"
date=$(date +%Y-%m-%dT%H:%M:%S); start=$(date +%s)
load0=$(uptime | sed 's/.*load average: //')

# inputs: made once, again when the map is newer than the cached file
printf 'map\tkind\tformat\twidth\theight\tfile\tbytes\n' >"$work/inputs.tsv"
kinds=(sun sun-free)
IFS=, read -ra widths <<<"$sizes"
IFS=, read -ra fmts <<<"$formats"
for i in 0 1; do
  m=${maps[$i]} name=$(basename "${maps[$i]}"); name=${name%.*}
  for w in "${widths[@]}"; do
    for x in "${fmts[@]}"; do
      f=$cache/${name}_${w}.$x
      if [ ! -s "$f" ] || [ "$m" -nt "$f" ]; then
        echo "scale_bench: making $f" >&2
        "$ENVLIGHT" convert "$m" "$f" --width "$w" -q
      fi
      printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "${kinds[$i]}" "$x" "$w" $((w / 2)) "$f" \
        "$(stat -c %s "$f")" >>"$work/inputs.tsv"
    done
  done
done

# one memory pass over W x W/2 x 3 floats, the least of 5 (after one warm-up: the floor; a
# median was 2.3 s instead of 0.2 s at 16K once, under load 30)
printf 'width\tseconds\n' >"$work/memory_pass.tsv"
for w in "${widths[@]}"; do
  "$PYTHON" - "$w" >>"$work/memory_pass.tsv" <<'PY'
import sys, time
import numpy as np
w = int(sys.argv[1])
a = np.ones(w * (w // 2) * 3, dtype=np.float32)
a.sum()
t = []
for _ in range(5):
    t0 = time.perf_counter(); a.sum(); t.append(time.perf_counter() - t0)
print(f"{w}\t{min(t):.6f}")
PY
done

# one fresh write of the same floats: a new process allocates them and writes each once, CPU (user
# + sys) of that alone, the median of 5 processes. The kernel backs fresh memory with zeroed pages
# (2 MiB ones: numpy asks for them, as envlight does), which a pass over memory already touched
# does not pay: the floor under any reader that makes a new map.
printf 'width\tseconds\n' >"$work/fresh_write.tsv"
for w in "${widths[@]}"; do
  for _ in 1 2 3 4 5; do
    "$PYTHON" - "$w" <<'PY'
import resource, sys
import numpy as np
w = int(sys.argv[1])
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
t0 = cpu()
a = np.empty(w * (w // 2) * 3, dtype=np.float32)
a.fill(1.0)
print(f"{cpu() - t0:.6f}")
PY
  done | sort -n | sed -n 3p | sed "s/^/$w\t/" >>"$work/fresh_write.tsv"
done

# the commands: NAME -> arguments after FILE (the output in the process's own empty folder)
cmd_args() {  # NAME FILE EXT -> the command line, one word a line
  local f=$2 x=$3
  case $1 in
    read_oiiotool) printf '%s\n' oiiotool -i:now=1 "$f" ;;
    info) printf '%s\n' "$ENVLIGHT" info "$f" ;;
    sh) printf '%s\n' "$ENVLIGHT" sh "$f" ;;
    lights_*) printf '%s\n' "$ENVLIGHT" lights "$f" --method "${1#lights_}" ;;
    irradiance) printf '%s\n' "$ENVLIGHT" prefilter "$f" -o maps --irradiance ;;
    specular) printf '%s\n' "$ENVLIGHT" prefilter "$f" -o maps --specular ;;
    gltf) printf '%s\n' "$ENVLIGHT" gltf "$f" -o env.glb ;;
    pov) printf '%s\n' "$ENVLIGHT" pov "$f" -o env.inc ;;
    preview) printf '%s\n' "$ENVLIGHT" preview "$f" -o preview.png ;;
    convert) printf '%s\n' "$ENVLIGHT" convert "$f" "out.$x" ;;
    brdf_lut) printf '%s\n' "$ENVLIGHT" brdf-lut -o lut.exr ;;
  esac
}
printf 'command\tmap\tkind\tformat\twidth\trun\twall\tuser\tsys\trss_kb\trc\n' >"$work/times.tsv"
measure() {  # NAME MAP KIND EXT WIDTH RUN FILE
  local args=(); mapfile -t args < <(cmd_args "$1" "$7" "$4")
  timed_run "$tmp/out" "$tmp/stdout" "$tmp/stderr" "${args[@]}"
  if [ "$TIMED_RC" != 0 ]; then
    echo "scale_bench: $1 on $7 failed ($TIMED_RC): ${args[*]}" >&2
    tail -3 "$tmp/stderr" >&2
  fi
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$1" "$2" "$3" "$4" "$5" "$6" \
    "$TIMED_WALL" "$TIMED_USER" "$TIMED_SYS" "$TIMED_RSS" "$TIMED_RC" >>"$work/times.tsv"
}
for ((run = 1; run <= runs; run++)); do
  [[ ,$commands, == *,brdf_lut,* ]] && measure brdf_lut - - - 0 "$run" -
  while IFS=$'\t' read -r name kind x w h f bytes; do
    echo "scale_bench: run $run: $kind $x $w x $h" >&2
    for c in read_oiiotool ${commands//,/ }; do
      [ "$c" = brdf_lut ] && continue
      measure "$c" "$name" "$kind" "$x" "$w" "$run" "$f"
    done
  done < <(tail -n +2 "$work/inputs.tsv" | sort -t $'\t' -s -k4,4n -k3,3)  # by size, sun then sun-free
done
load1=$(uptime | sed 's/.*load average: //')

figure=$tmp/$report.png
"$PYTHON" "$top/scripts/scale_bench.py" "$work" --plot "$figure" >"$tmp/table.md"
{ echo "Load average (1, 5, 15 min) before: $load0; after: $load1."; echo; cat "$tmp/table.md"; } \
  | tee "$tmp/shown.md"

[ -n "$docs" ] || exit 0
mkdir -p "$docs"
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
mem=$(awk '/^MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)
{
  echo "# Every command from 1K to 16K: CPU, wall, peak memory, sun against sun-free"
  echo
  echo "Written by \`$command_line\` (do not edit by hand; run it again to update this file)."
  echo
  echo "- date: $date; took $(( $(date +%s) - start )) s"
  echo "- load average (1, 5, 15 min) before: $load0; after: $load1 (a shared machine: read the"
  echo "  ratios, each measured in this run, rather than the seconds)"
  echo "- machine: ${cpu:-$(uname -m)}, $(nproc) cores, $mem; $("$ENVLIGHT" --version 2>/dev/null | head -1)"
  echo "  ($(oiiotool --version 2>/dev/null | head -1 || echo "oiiotool"))"
  echo "- maps: $(basename "${maps[0]}") (a sun) and $(basename "${maps[1]}") (no sun), each made"
  echo "  W x W/2 by \`envlight convert MAP OUT.hdr|OUT.exr --width W\` (area-weighted: the same"
  echo "  picture, more pixels; the .exr as convert writes it)"
  echo "- whole processes, /usr/bin/time, the median of $runs run(s); CPU = user + sys seconds"
  echo "  (both cores: CPU can exceed wall); RSS = peak resident set; \"floats\" = the canonical"
  echo "  map's W x W/2 x 3 x 4 bytes"
  echo
  cat "$tmp/shown.md"
  echo
  echo "![CPU seconds against pixels, log-log]($report.png)"
} >"$tmp/report.md"
out=$docs/$report.md
cp "$figure" "$docs/$report.png.tmp-$$" && mv -f "$docs/$report.png.tmp-$$" "$docs/$report.png"
cp "$tmp/report.md" "$out.tmp-$$" && mv -f "$out.tmp-$$" "$out"
echo "scale_bench: wrote $out and $docs/$report.png" >&2
