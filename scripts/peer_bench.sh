#!/usr/bin/env bash
# envlight against peer tools on the same maps (issue 17; docs/peer_bench.md): cmft (github
# dariomanesku/cmft) and, when present, Probulator (github kayru/Probulator). For each map (default
# ../shared/data/latlong_hdri/lebombo_1k.hdr) as it is and upsampled with `envlight convert` to
# 4096 x 2048 and 8192 x 4096 (.hdr, cached), whole processes are timed with /usr/bin/time, RUNS
# times each (default 3; the median): user+sys CPU seconds, wall seconds, peak RSS. Tasks: SH
# order 2 (`envlight sh` / cmft `--filter shcoeffs` / Probulator's SHL2), irradiance cubes of
# face 32 and 128 (`envlight prefilter --irradiance --layout cube` / cmft `--filter irradiance`),
# the radiance chain (envlight's default GGX chain as a 256 cube / cmft `--filter radiance
# --lightingModel phongbrdf`, 256 faces, 9 mips: cmft has no GGX), and `envlight lights --method
# fit -n 4` alone. envlight runs with its error measures (the default) and, where a command's
# --help lists it, with --no-error. Then the SH coefficients of envlight and cmft are compared
# with an exact double-precision projection of the same map (scripts/peer_bench.py: frames,
# bases and decodes stated there). Prints markdown; --docs DIR also writes DIR/peer_bench.md
# with a header (command, date, load before and after, machine, the peers' commits).
#
# The peers are not built here: the project commits no recipe that builds fetched code. Put a
# cmft binary built from its public sources at $ENVLIGHT_PEER_CACHE/cmft/cmft (default cache
# /var/cache/envlight/peers, outside the repository) with its git commit in .../cmft/COMMIT,
# and optionally Probulator's ProbulatorCLI at .../probulator/ProbulatorCLI (+ COMMIT, and NOTES
# for any local change); or name them with --cmft / --probulator. The sources: github
# dariomanesku/cmft and kayru/Probulator; on a machine without internet, snapshots of those
# repositories are expected as bare git directories under $ENVLIGHT_PEER_SRC (default
# /work/.mirror: dariomanesku+cmft/repo, kayru+Probulator/repo), which this script only reads to
# say whether a binary's recorded commit is the snapshot's. Not part of CI. Needs the Debian
# packages time and python3-numpy (installed when missing, as root).
# Options: --runs N, --sizes LIST (lat-long widths; 0 = the map as it is; default 0,4096,8192),
# --tasks LIST (default sh,irr32,irr128,radiance,lights; the SH agreement comes with sh),
# --envlight PATH (default build/envlight), --cmft PATH, --probulator PATH (none: skip it),
# --docs DIR.
usage="usage: bash scripts/peer_bench.sh [--runs N] [--sizes LIST] [--tasks LIST] [--envlight PATH] [--cmft PATH] [--probulator PATH|none] [--docs DIR] [MAP.hdr...]"
for a in "$@"; do
  case "$a" in  # --help: the usage and the header above, nothing run
    -h|--help) echo "$usage"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
  esac
done
set -euo pipefail
command_line="scripts/peer_bench.sh $*"
top=$(cd "$(dirname "$0")/.." && pwd)
cache=${ENVLIGHT_PEER_CACHE:-/var/cache/envlight/peers}
src=${ENVLIGHT_PEER_SRC:-/work/.mirror}
PYTHON=${PYTHON:-/usr/bin/python3}
runs=3 sizes=0,4096,8192 tasks=sh,irr32,irr128,radiance,lights docs= ENVLIGHT=$top/build/envlight
CMFT=$cache/cmft/cmft PROBULATOR=$cache/probulator/ProbulatorCLI
maps=()
die() { echo "peer_bench: $*" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs=${2:?"$usage"}; shift 2 ;;
    --sizes) sizes=${2:?"$usage"}; shift 2 ;;
    --tasks) tasks=${2:?"$usage"}; shift 2 ;;
    --docs) docs=${2:?"$usage"}; shift 2 ;;
    --envlight) ENVLIGHT=${2:?"$usage"}; shift 2 ;;
    --cmft) CMFT=${2:?"$usage"}; shift 2 ;;
    --probulator) PROBULATOR=${2:?"$usage"}; shift 2 ;;
    -*) echo "$usage" >&2; exit 2 ;;
    *) maps+=("$1"); shift ;;
  esac
done
[[ $runs =~ ^[1-9][0-9]*$ ]] || { echo "peer_bench: --runs wants a count >= 1, not '$runs'" >&2; exit 2; }
[[ ,$tasks, =~ ^(,(sh|irr32|irr128|radiance|lights))+,$ ]] || { echo "peer_bench: --tasks wants some of sh,irr32,irr128,radiance,lights, not '$tasks'" >&2; exit 2; }
[[ $sizes =~ ^[0-9]+(,[0-9]+)*$ ]] || { echo "peer_bench: --sizes wants widths like 0,4096, not '$sizes'" >&2; exit 2; }
((${#maps[@]})) || maps=("$top/../shared/data/latlong_hdri/lebombo_1k.hdr")

# Debian packages, when missing (as scripts/build.sh does)
missing=()
for p in time python3-numpy; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if ((${#missing[@]})); then
  [ "$(id -u)" = 0 ] || die "missing Debian packages: ${missing[*]} (run as root to install them)"
  echo "peer_bench: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

[ -x "$ENVLIGHT" ] || die "no envlight at $ENVLIGHT (bash scripts/build.sh, or --envlight PATH)"
for m in "${maps[@]}"; do [ -f "$m" ] || die "$m: no such map"; done

# the peers: found, never built here (see the header)
commit_of() {  # BINARY SNAPSHOT_NAME -> "hash" or "unknown", with a note when it is not the snapshot's
  local c=unknown
  [ -f "$(dirname "$1")/COMMIT" ] && c=$(head -c 40 "$(dirname "$1")/COMMIT")
  local snap=$src/$2/repo
  if [ -d "$snap" ]; then
    local head; head=$(git --git-dir="$snap" rev-parse HEAD 2>/dev/null || echo "?")
    [ "$c" = "$head" ] || echo "peer_bench: note: $1 records commit $c, the snapshot $snap is at $head" >&2
  fi
  echo "$c"
}
if [ ! -x "$CMFT" ]; then
  die "no cmft at $CMFT. This script does not build it: build cmft from its public sources
  (github dariomanesku/cmft, as its README says for Linux; on a machine without internet a
  snapshot is expected as a bare git directory at $src/dariomanesku+cmft/repo, ENVLIGHT_PEER_SRC),
  outside the repository, then put the binary at $cache/cmft/cmft (ENVLIGHT_PEER_CACHE) with its
  commit hash in $cache/cmft/COMMIT, or pass --cmft PATH"
fi
cmft_commit=$(commit_of "$CMFT" dariomanesku+cmft)
if [ "$PROBULATOR" = none ] || [ ! -x "$PROBULATOR" ]; then
  [ "$PROBULATOR" = none ] || echo "peer_bench: no Probulator at $PROBULATOR (github kayru/Probulator;" \
    "its ProbulatorCLI there, or --probulator PATH): skipped" >&2
  PROBULATOR=
else
  prob_commit=$(commit_of "$PROBULATOR" kayru+Probulator)
fi

tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
work=$tmp/work; mkdir -p "$work/sh"
date=$(date +%Y-%m-%dT%H:%M:%S); start=$(date +%s)
load0=$(uptime | sed 's/.*load average: //')

# inputs: each map as it is (a .hdr: cmft and Probulator read Radiance files) and upsampled,
# cached in $cache/inputs (made again when the map is newer)
mkdir -p "$cache/inputs" 2>/dev/null || die "cannot create $cache/inputs (ENVLIGHT_PEER_CACHE)"
printf 'size\tfile\twidth\theight\n' >"$work/inputs.tsv"
labels=() files=()
for m in "${maps[@]}"; do
  name=$(basename "$m"); name=${name%.*}
  IFS=, read -ra ws <<<"$sizes"
  for w in "${ws[@]}"; do
    if [ "$w" = 0 ] && [[ $m == *.hdr || $m == *.pic ]]; then
      f=$m
    else
      f=$cache/inputs/${name}_${w}.hdr
      [ "$w" = 0 ] && f=$cache/inputs/${name}.hdr
      if [ ! -s "$f" ] || [ "$m" -nt "$f" ]; then
        wopt=(); [ "$w" = 0 ] || wopt=(--width "$w")
        echo "peer_bench: making $f" >&2
        "$ENVLIGHT" convert "$m" "$f" "${wopt[@]}" -q
      fi
    fi
    read -r W H < <("$ENVLIGHT" info "$f" --json -q | "$PYTHON" -c \
      'import json,sys; d=json.load(sys.stdin); print(d["width"], d["height"])')
    label="${name} ${W}x${H}"
    labels+=("$label"); files+=("$f")
    printf '%s\t%s\t%s\t%s\n' "$label" "$f" "$W" "$H" >>"$work/inputs.tsv"
  done
done

# one timed whole process: TASK LABEL TOOL VARIANT CMD... (run in an empty folder)
printf 'task\tsize\ttool\tvariant\trun\twall\tuser\tsys\trss_kb\trc\n' >"$work/times.tsv"
source "$top/scripts/timed_run.sh"
measure() {
  local task=$1 label=$2 tool=$3 variant=$4 run=$5; shift 5
  timed_run "$tmp/out" "$tmp/stdout" "$tmp/stderr" "$@"
  if [ "$TIMED_RC" != 0 ]; then
    echo "peer_bench: $task $label $tool $variant failed ($TIMED_RC): $*" >&2
    tail -3 "$tmp/stderr" >&2
  fi
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$task" "$label" "$tool" "$variant" "$run" \
    "$TIMED_WALL" "$TIMED_USER" "$TIMED_SYS" "$TIMED_RSS" "$TIMED_RC" >>"$work/times.tsv"
}
# envlight with its error measures, and with --no-error where the command's --help lists it;
# VARIANTS (a global array) adds runs with those extra arguments (each a word list)
has_no_error() { "$ENVLIGHT" "$1" --help | grep -q -- '--no-error'; }
envlight_task() {  # TASK LABEL RUN COMMAND ARGS...
  local task=$1 label=$2 run=$3; shift 3
  local v ne=(); has_no_error "$1" && ne=(--no-error)
  for v in "" "${VARIANTS[@]}"; do
    local extra; read -ra extra <<<"$v"
    measure "$task" "$label" envlight "${v:-default}" "$run" "$ENVLIGHT" "$@" "${extra[@]}"
    if ((${#ne[@]})); then
      measure "$task" "$label" envlight "${v:+$v }--no-error" "$run" "$ENVLIGHT" "$@" "${extra[@]}" \
        --no-error
    fi
  done
}
VARIANTS=()
threads=$(nproc)
CMFT_RAD=(--filter radiance --srcFaceSize 256 --dstFaceSize 256 --mipCount 9 --glossScale 10
  --glossBias 1 --lightingModel phongbrdf --excludeBase false --edgeFixup none
  --numCpuProcessingThreads $((threads + 1)) --useOpenCL false)
for i in "${!labels[@]}"; do
  label=${labels[$i]} f=${files[$i]}
  echo "peer_bench: $label: $runs run(s)" >&2
  for ((run = 1; run <= runs; run++)); do
    want() { [[ ,$tasks, == *,$1,* ]]; }
    if want sh; then
    envlight_task sh "$label" "$run" sh "$f" --order 2 --json -o sh.json -q
    measure sh "$label" cmft "" "$run" "$CMFT" --input "$f" --filter shcoeffs --outputNum 1 \
      --output0 sh --silent
    mkdir -p "$work/sh/$label"; cp "$tmp/out/sh.c" "$work/sh/$label/cmft.c" 2>/dev/null || true
    [ -z "$PROBULATOR" ] || measure sh "$label" Probulator "" "$run" "$PROBULATOR" "$f" SHL2
    fi
    for n in 32 128; do
      want "irr$n" || continue  # also envlight's SH irradiance (cmft's is SH of order 4, unwindowed)
      VARIANTS=("--irradiance-method sh --irradiance-order 4")
      envlight_task "irr$n" "$label" "$run" prefilter "$f" -o maps --irradiance --layout cube \
        --irradiance-size "$n" --format pfm -q
      VARIANTS=()
      measure "irr$n" "$label" cmft "" "$run" "$CMFT" --input "$f" --filter irradiance \
        --dstFaceSize "$n" --outputNum 1 --output0 irr --output0params dds,rgba32f,cubemap --silent
    done
    if want radiance; then
    envlight_task radiance "$label" "$run" prefilter "$f" -o maps --specular --layout cube \
      --format pfm -q
    measure radiance "$label" cmft "" "$run" "$CMFT" --input "$f" "${CMFT_RAD[@]}" --outputNum 1 \
      --output0 rad --output0params dds,rgba32f,cubemap --silent
    fi
    want lights && envlight_task lights "$label" "$run" lights "$f" --method fit -n 4 --json \
      -o lights.json -q
  done
  want sh || continue
  # the SH agreement (untimed): envlight without a window, the exact projection of the same file
  "$ENVLIGHT" sh "$f" --order 2 --window none --json -q -o "$work/sh/$label/envlight.json"
  "$ENVLIGHT" convert "$f" "$tmp/map.pfm" -q
  "$PYTHON" "$top/scripts/peer_bench.py" reference "$tmp/map.pfm" "$work/sh/$label/reference.json"
  rm -f "$tmp/map.pfm"
done
load1=$(uptime | sed 's/.*load average: //')

"$PYTHON" "$top/scripts/peer_bench.py" report "$work" >"$tmp/table.md"
{ echo "Load average (1, 5, 15 min) before: $load0; after: $load1."; echo; cat "$tmp/table.md"; } \
  | tee "$tmp/shown.md"

[ -n "$docs" ] || exit 0
mkdir -p "$docs"
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
peer_line() {  # NAME BINARY COMMIT
  local notes=; [ -f "$(dirname "$2")/NOTES" ] && notes="; local changes: $(head -1 "$(dirname "$2")/NOTES")"
  echo "- $1: commit \`$3\`$notes"
}
{
  echo "# envlight against peer tools: CPU, memory and SH agreement"
  echo
  echo "Written by \`$command_line\` (do not edit by hand; run it again to update this file)."
  echo
  echo "- date: $date; took $(( $(date +%s) - start )) s"
  echo "- load average (1, 5, 15 min) before: $load0; after: $load1 (a shared machine: the"
  echo "  timings are noisy, read the ratios rather than the seconds)"
  echo "- machine: ${cpu:-$(uname -m)}, $threads cores; $("$ENVLIGHT" --version 2>/dev/null | head -1)"
  peer_line cmft "$CMFT" "$cmft_commit"
  if [ -n "$PROBULATOR" ]; then peer_line Probulator "$PROBULATOR" "$prob_commit"; else echo "- Probulator: not run"; fi
  echo "- whole processes (reading the .hdr, converting, computing, writing), /usr/bin/time, the"
  echo "  median of $runs run(s); CPU = user + sys seconds; RSS = peak resident set"
  echo "- envlight: \`sh MAP --order 2 --json\`; \`prefilter MAP --irradiance --layout cube"
  echo "  --irradiance-size N --format pfm\`; \`prefilter MAP --specular --layout cube --format pfm\`"
  echo "  (6 GGX levels, faces 256 to 8, level 0 a resampled mirror); \`lights MAP --method fit -n 4"
  echo "  --json\`; \"default\" = with the error measure, \`--no-error\` = without (only where the"
  echo "  command has the flag); all cores (\`--threads\` default)"
  echo "- cmft: \`--filter shcoeffs\` (always order 4, 25 coefficients, on a cube of face H/2"
  echo "  point-sampled from the lat-long map); \`--filter irradiance --dstFaceSize N\` (SH-based);"
  echo "  \`${CMFT_RAD[*]}\`"
  echo "  (Phong lobes of specular power 2^(10 g + 1), + 1 for phongbrdf, g = 1 at mip 0 falling"
  echo "  to 0 at mip 8; no GGX; the input first resampled to 256 faces); outputs DDS rgba32f;"
  echo "  cmft starts N - 1 worker threads for N = $((threads + 1)), i.e. $threads"
  [ -z "$PROBULATOR" ] || {
  echo "- Probulator: \`ProbulatorCLI MAP SHL2\`: resizes the map to 256 x 128, projects order 2"
  echo "  there, renders 256 x 128 radiance and irradiance pictures and writes PNGs and an HTML"
  echo "  report; it prints no coefficients, so it has no agreement row"; }
  echo "- inputs: the map as it is, and \`envlight convert MAP OUT.hdr --width W\` (area-weighted"
  echo "  upsampling: the same picture, more pixels)"
  echo
  echo "How to read it:"
  echo
  echo "- A CPU ratio below 1: envlight used less CPU than the peer. Wall above CPU is waiting on"
  echo "  a loaded machine (see the load); envlight and cmft's radiance filter use both cores."
  echo "- envlight's \"default\" rows include its error measures against exact references: the"
  echo "  irradiance at 1024 normals, and for the GGX chain a brute-force sum over every pixel for"
  echo "  1024 directions per level, which grows with the map (most of the 8K default row). The"
  echo "  \`--no-error\` rows are the products alone; \`sh\` and \`lights\` have no \`--no-error\`"
  echo "  in this build, so their rows include the measure."
  echo "- Not the same filters. Irradiance: envlight's default is the exact integral of the map"
  echo "  area-averaged to 256 x 128, a cost per output texel; cmft's is an SH expansion of order 4"
  echo "  (E / pi, no window). The \`--irradiance-method sh --irradiance-order 4\` rows are the"
  echo "  like-for-like ones. Radiance: envlight's GGX chain, filtered importance sampling of the"
  echo "  full-resolution map, against cmft's Phong-BRDF cone filter of the map first resampled to"
  echo "  256 faces: kernels, levels and input resolution differ, so the rows give what each tool's"
  echo "  own chain costs, not which is more accurate."
  echo "- SH agreement: envlight's coefficients are compared in its own basis and frame; cmft's in"
  echo "  its basis and frame (scripts/peer_bench.py says how they were read from cmft's source;"
  echo "  the fit residual checks the mapping), and the band energies need no frame at all. cmft"
  echo "  point-samples the lat-long map onto a cube of face H / 2, so its error falls as the map"
  echo "  grows; it decodes RGBE without envlight's + 0.5, hence two reference rows."
  echo
  cat "$tmp/shown.md"
} >"$tmp/report.md"
out=$docs/peer_bench.md
cp "$tmp/report.md" "$out.tmp-$$" && mv -f "$out.tmp-$$" "$out"
echo "peer_bench: wrote $out" >&2
