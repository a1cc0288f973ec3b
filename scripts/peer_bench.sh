#!/usr/bin/env bash
# envlight against peer tools on the same maps (issues 17 and 29; docs/peer_bench.md): cmft (github
# dariomanesku/cmft), Filament's cmgen (github google/filament, tools/cmgen) and, when present,
# Probulator (github kayru/Probulator). For each map (default
# ../shared/data/latlong_hdri/lebombo_1k.hdr) as it is and upsampled with `envlight convert` to
# 4096 x 2048, 8192 x 4096 and 16384 x 8192 (.hdr, cached), whole processes are timed with
# /usr/bin/time, RUNS times each (default 3; the median; RUNS_LARGE at 16384 and wider): user+sys
# CPU seconds, wall seconds, peak RSS. Tasks: SH order 2 (`envlight sh` / cmft `--filter
# shcoeffs` / cmgen `--sh=3` / Probulator's SHL2), irradiance cubes of face 32 and 128
# (`envlight prefilter --irradiance --layout cube` / cmft `--filter irradiance` / cmgen
# `--size=N --ibl-irradiance`), the radiance chain (envlight's default GGX chain as a 256 cube /
# cmft `--filter radiance --lightingModel phongbrdf`, 256 faces, 9 mips: cmft has no GGX /
# cmgen `--ibl-ld`, GGX, 256 to 16), and `envlight lights --method fit -n 4` alone. envlight
# runs with its error measures (the default) and, where a command's --help lists it, with
# --no-error. Every product of the last run is then measured against an exact reference
# (scripts/peer_bench.py, which states the frames, bases and units read from each peer's
# source): SH coefficients against the exact double-precision projection of the same file;
# irradiance cubes against envlight's exact irradiance and specular levels against its
# brute-force GGX sum (cmft's Phong levels: the script's brute-force Phong sum), at the
# products' texel centres, over the map area-resampled to 1024 x 512. Prints markdown; --docs
# DIR also writes DIR/peer_bench.md with a header (command, date, load before and after,
# machine, the peers' commits).
#
# The peers are not built here: the project commits no recipe that builds fetched code. Put a
# cmft binary built from its public sources at $ENVLIGHT_PEER_CACHE/cmft/cmft (default cache
# /var/cache/envlight/peers, outside the repository) with its git commit in .../cmft/COMMIT,
# cmgen at .../cmgen/cmgen (+ COMMIT, and NOTES for any local change), and optionally
# Probulator's ProbulatorCLI at .../probulator/ProbulatorCLI (+ COMMIT, NOTES); or name them with
# --cmft / --cmgen / --probulator. The sources: github dariomanesku/cmft, google/filament and
# kayru/Probulator; on a machine without internet, snapshots of those repositories are expected
# as bare git directories under $ENVLIGHT_PEER_SRC (default /work/.mirror: dariomanesku+cmft/repo,
# a Filament fork holding upstream's history such as CFeng+filament/repo,
# kayru+Probulator/repo), which this script only reads to say whether a binary's recorded commit
# is the snapshot's or in its history. Not part of CI. Needs the Debian packages time and
# python3-numpy (installed when missing, as root) and the envlight library beside --envlight
# (libenvlight.so, for the exact references through py_shim).
# Options: --runs N, --runs-large N (at widths >= 16384; default: --runs), --sizes LIST
# (lat-long widths; 0 = the map as it is; default 0,4096,8192,16384), --tasks LIST (default
# sh,irr32,irr128,radiance,lights; the SH agreement comes with sh), --envlight PATH (default
# build/envlight), --cmft PATH, --cmgen PATH|none, --probulator PATH|none (none: skip it),
# --docs DIR.
usage="usage: bash scripts/peer_bench.sh [--runs N] [--runs-large N] [--sizes LIST] [--tasks LIST] [--envlight PATH] [--cmft PATH] [--cmgen PATH|none] [--probulator PATH|none] [--docs DIR] [MAP.hdr...]"
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
runs=3 runs_large= sizes=0,4096,8192,16384 tasks=sh,irr32,irr128,radiance,lights docs=
ENVLIGHT=$top/build/envlight CMFT=$cache/cmft/cmft CMGEN=$cache/cmgen/cmgen
PROBULATOR=$cache/probulator/ProbulatorCLI
maps=()
die() { echo "peer_bench: $*" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs=${2:?"$usage"}; shift 2 ;;
    --runs-large) runs_large=${2:?"$usage"}; shift 2 ;;
    --sizes) sizes=${2:?"$usage"}; shift 2 ;;
    --tasks) tasks=${2:?"$usage"}; shift 2 ;;
    --docs) docs=${2:?"$usage"}; shift 2 ;;
    --envlight) ENVLIGHT=${2:?"$usage"}; shift 2 ;;
    --cmft) CMFT=${2:?"$usage"}; shift 2 ;;
    --cmgen) CMGEN=${2:?"$usage"}; shift 2 ;;
    --probulator) PROBULATOR=${2:?"$usage"}; shift 2 ;;
    -*) echo "$usage" >&2; exit 2 ;;
    *) maps+=("$1"); shift ;;
  esac
done
[[ $runs =~ ^[1-9][0-9]*$ ]] || { echo "peer_bench: --runs wants a count >= 1, not '$runs'" >&2; exit 2; }
runs_large=${runs_large:-$runs}
[[ $runs_large =~ ^[1-9][0-9]*$ ]] || { echo "peer_bench: --runs-large wants a count >= 1, not '$runs_large'" >&2; exit 2; }
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
export ENVLIGHT_LIBRARY=${ENVLIGHT_LIBRARY:-$(dirname "$ENVLIGHT")/libenvlight.so}
[ -f "$ENVLIGHT_LIBRARY" ] || die "no $ENVLIGHT_LIBRARY beside $ENVLIGHT (the exact references use it; or set ENVLIGHT_LIBRARY)"
for m in "${maps[@]}"; do [ -f "$m" ] || die "$m: no such map"; done

# the peers: found, never built here (see the header)
commit_of() {  # BINARY SNAPSHOT_NAME -> "hash" or "unknown", with a note when it is not the snapshot's
  local c=unknown
  [ -f "$(dirname "$1")/COMMIT" ] && c=$(head -c 40 "$(dirname "$1")/COMMIT")
  local snap=$src/$2/repo
  if [ -d "$snap" ]; then
    local head; head=$(git --git-dir="$snap" rev-parse HEAD 2>/dev/null || echo "?")
    if [ "$c" != "$head" ]; then
      if git --git-dir="$snap" merge-base --is-ancestor "$c" "$head" 2>/dev/null; then
        echo "peer_bench: note: $1 records commit $c, in the history of the snapshot $snap (at $head)" >&2
      else
        echo "peer_bench: note: $1 records commit $c, the snapshot $snap is at $head" >&2
      fi
    fi
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
# an optional peer: NAME VARIABLE COMMIT_VARIABLE SNAPSHOT WHERE -> VARIABLE emptied (with a
# note unless it was "none") when there is no binary, else COMMIT_VARIABLE set
optional_peer() {
  local bin=${!2}
  if [ "$bin" = none ] || [ ! -x "$bin" ]; then
    [ "$bin" = none ] || echo "peer_bench: no $1 at $bin ($5): skipped" >&2
    printf -v "$2" '%s' ""
  else
    printf -v "$3" '%s' "$(commit_of "$bin" "$4")"
  fi
}
optional_peer cmgen CMGEN cmgen_commit CFeng+filament \
  "Filament's tools/cmgen built from github google/filament, outside the repository; or --cmgen PATH"
optional_peer Probulator PROBULATOR prob_commit kayru+Probulator \
  "github kayru/Probulator; its ProbulatorCLI there, or --probulator PATH"

tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
work=$tmp/work; mkdir -p "$work/sh"
date=$(date +%Y-%m-%dT%H:%M:%S); start=$(date +%s)
load0=$(uptime | sed 's/.*load average: //')

# inputs: each map as it is (a .hdr: cmft and Probulator read Radiance files) and upsampled,
# cached in $cache/inputs (made again when the map is newer)
mkdir -p "$cache/inputs" 2>/dev/null || die "cannot create $cache/inputs (ENVLIGHT_PEER_CACHE)"
printf 'size\tfile\twidth\theight\n' >"$work/inputs.tsv"
labels=() files=() widths=()
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
    labels+=("$label"); files+=("$f"); widths+=("$W")
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
# the products of the last run, kept for their error measures: TASK LABEL TOOL (a folder name)
keep() {
  local d=$work/products/$2/$1/$3
  mkdir -p "$d" && cp -r "$tmp/out/." "$d/"
}
# envlight with its error measures, and with --no-error where the command's --help lists it;
# VARIANTS (a global array) adds runs with those extra arguments (each a word list); the last
# run's products are kept as envlight, envlight_VARIANT_WORDS (spaces as _)
has_no_error() { "$ENVLIGHT" "$1" --help | grep -q -- '--no-error'; }
envlight_task() {  # TASK LABEL RUN LAST COMMAND ARGS...
  local task=$1 label=$2 run=$3 last=$4; shift 4
  local v ne=(); has_no_error "$1" && ne=(--no-error)
  for v in "" "${VARIANTS[@]}"; do
    local extra; read -ra extra <<<"$v"
    measure "$task" "$label" envlight "${v:-default}" "$run" "$ENVLIGHT" "$@" "${extra[@]}"
    [ "$last" = 0 ] || keep "$task" "$label" "envlight${v:+_${v// /_}}"
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
# cmgen: 32-bit float PSD faces (its EXR is half float, its 32-bit DDS writes no pixels)
CMGEN_OUT=(--format=psd --compression=32)
mkdir -p "$work/errors"
for i in "${!labels[@]}"; do
  label=${labels[$i]} f=${files[$i]}
  n_runs=$runs; ((widths[i] < 16384)) || n_runs=$runs_large
  echo "peer_bench: $label: $n_runs run(s)" >&2
  for ((run = 1; run <= n_runs; run++)); do
    last=0; ((run < n_runs)) || last=1
    want() { [[ ,$tasks, == *,$1,* ]]; }
    if want sh; then
    envlight_task sh "$label" "$run" 0 sh "$f" --order 2 --json -o sh.json -q
    measure sh "$label" cmft "" "$run" "$CMFT" --input "$f" --filter shcoeffs --outputNum 1 \
      --output0 sh --silent
    mkdir -p "$work/sh/$label"; cp "$tmp/out/sh.c" "$work/sh/$label/cmft.c" 2>/dev/null || true
    if [ -n "$CMGEN" ]; then
      measure sh "$label" cmgen "" "$run" "$CMGEN" -q --sh=3 --sh-window=no --sh-output=sh.txt "$f"
      cp "$tmp/out/sh.txt" "$work/sh/$label/cmgen.txt" 2>/dev/null || true
    fi
    [ -z "$PROBULATOR" ] || measure sh "$label" Probulator "" "$run" "$PROBULATOR" "$f" SHL2
    fi
    for n in 32 128; do
      want "irr$n" || continue
      # also envlight's faster methods, what the default's accuracy costs: SH of order 4 (cmft's
      # is SH of order 4, unwindowed) and 8, and the exact sum over the map area-averaged to 256
      VARIANTS=("--irradiance-method sh --irradiance-order 4" "--irradiance-method sh --irradiance-order 8"
        "--irradiance-method resampled")
      envlight_task "irr$n" "$label" "$run" "$last" prefilter "$f" -o maps --irradiance \
        --layout cube --irradiance-size "$n" --format pfm -q
      VARIANTS=()
      measure "irr$n" "$label" cmft "" "$run" "$CMFT" --input "$f" --filter irradiance \
        --dstFaceSize "$n" --outputNum 1 --output0 irr --output0params dds,rgba32f,cubemap --silent
      [ "$last" = 0 ] || keep "irr$n" "$label" cmft
      if [ -n "$CMGEN" ]; then
        measure "irr$n" "$label" cmgen "" "$run" "$CMGEN" -q --size="$n" "${CMGEN_OUT[@]}" \
          --ibl-irradiance=irr/ "$f"
        [ "$last" = 0 ] || keep "irr$n" "$label" cmgen
      fi
    done
    if want radiance; then
    envlight_task radiance "$label" "$run" "$last" prefilter "$f" -o maps --specular --layout cube \
      --format pfm -q
    measure radiance "$label" cmft "" "$run" "$CMFT" --input "$f" "${CMFT_RAD[@]}" --outputNum 1 \
      --output0 rad --output0params dds,rgba32f,cubemap --silent
    [ "$last" = 0 ] || keep radiance "$label" cmft
    if [ -n "$CMGEN" ]; then
      measure radiance "$label" cmgen "" "$run" "$CMGEN" -q --size=256 "${CMGEN_OUT[@]}" \
        --ibl-ld=rad/ "$f"
      [ "$last" = 0 ] || keep radiance "$label" cmgen
    fi
    fi
    want lights && envlight_task lights "$label" "$run" 0 lights "$f" --method fit -n 4 --json \
      -o lights.json -q
  done
  # the errors of the kept products (untimed), against the map area-resampled to 1024 x 512
  if [ -d "$work/products/$label" ]; then
    echo "peer_bench: $label: measuring the products" >&2
    "$ENVLIGHT" convert "$f" "$tmp/map1024.pfm" --width 1024 -q
    "$PYTHON" "$top/scripts/peer_bench.py" errors "$work/products/$label" "$tmp/map1024.pfm" \
      "$work/errors/$label.json"
    rm -rf "$tmp/map1024.pfm" "$work/products/$label"
  fi
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
  echo "# envlight against peer tools: CPU, memory and errors against exact references"
  echo
  echo "Written by \`$command_line\` (do not edit by hand; run it again to update this file)."
  echo
  echo "- date: $date; took $(( $(date +%s) - start )) s"
  echo "- load average (1, 5, 15 min) before: $load0; after: $load1 (a shared machine: the"
  echo "  timings are noisy, read the ratios rather than the seconds)"
  echo "- machine: ${cpu:-$(uname -m)}, $threads cores; $("$ENVLIGHT" --version 2>/dev/null | head -1)"
  peer_line cmft "$CMFT" "$cmft_commit"
  if [ -n "$CMGEN" ]; then peer_line "cmgen (Filament)" "$CMGEN" "$cmgen_commit"; else echo "- cmgen: not run"; fi
  if [ -n "$PROBULATOR" ]; then peer_line Probulator "$PROBULATOR" "$prob_commit"; else echo "- Probulator: not run"; fi
  echo "- whole processes (reading the .hdr, converting, computing, writing), /usr/bin/time, the"
  echo "  median of $runs run(s) ($runs_large at 16384 and wider); CPU = user + sys seconds; RSS ="
  echo "  peak resident set"
  echo "- envlight: \`sh MAP --order 2 --json\`; \`prefilter MAP --irradiance --layout cube"
  echo "  --irradiance-size N --format pfm\`; \`prefilter MAP --specular --layout cube --format pfm\`"
  echo "  (6 GGX levels, faces 256 to 16, level 0 a resampled mirror); \`lights MAP --method fit -n 4"
  echo "  --json\`; \"default\" = with the error measure, \`--no-error\` = without (only where the"
  echo "  command has the flag); all cores (\`--threads\` default)"
  echo "- cmft: \`--filter shcoeffs\` (always order 4, 25 coefficients, on a cube of face H/2"
  echo "  point-sampled from the lat-long map); \`--filter irradiance --dstFaceSize N\` (SH-based);"
  echo "  \`${CMFT_RAD[*]}\`"
  echo "  (Phong lobes of specular power 2^(10 g + 1), + 1 for phongbrdf, g = 1 at mip 0 falling"
  echo "  to 0 at mip 8; no GGX; the input first resampled to 256 faces); outputs DDS rgba32f;"
  echo "  cmft starts N - 1 worker threads for N = $((threads + 1)), i.e. $threads"
  [ -z "$CMGEN" ] || {
  echo "- cmgen: \`-q --sh=3 --sh-window=no --sh-output=sh.txt\` (order 2, no window);"
  echo "  \`-q --size=N ${CMGEN_OUT[*]} --ibl-irradiance=DIR\` (1024 cosine samples of the"
  echo "  input's cube mips); \`-q --size=256 ${CMGEN_OUT[*]} --ibl-ld=DIR\` (GGX, 5 levels, faces"
  echo "  256 to 16, perceptual roughness 1 - sqrt(1 - k / 4), level 0 a resampled mirror, 1024"
  echo "  samples doubling from level 2). Every cmgen command first point-samples the lat-long map"
  echo "  onto a cube of --size faces (Hammersley points per texel, as many as the texel covers"
  echo "  pixels), so its SH and irradiance come from that cube, not from the map; all cores (its"
  echo "  job system)"; }
  [ -z "$PROBULATOR" ] || {
  echo "- Probulator: \`ProbulatorCLI MAP SHL2\`: resizes the map to 256 x 128, projects order 2"
  echo "  there, renders 256 x 128 radiance and irradiance pictures and writes PNGs and an HTML"
  echo "  report; it prints no coefficients, so it has no error"; }
  echo "- inputs: the map as it is, and \`envlight convert MAP OUT.hdr --width W\` (area-weighted"
  echo "  upsampling: the same picture, more pixels)"
  echo "- errors (untimed, scripts/peer_bench.py states how each peer's frame, basis, faces and"
  echo "  units were read from its source): SH against the exact double-precision projection of"
  echo "  the same file; the irradiance cube against envlight's exact irradiance"
  echo "  (envl_irradiance_exact: every pixel over the clamped cosine, in double) and each GGX"
  echo "  level against envlight's brute-force sum (envl_prefilter_reference), cmft's Phong levels"
  echo "  against the script's brute-force Phong sum, at the products' own texel centres (at most"
  echo "  1024 of an irradiance cube, 512 of a level), over the map area-resampled to 1024 x 512"
  echo
  echo "How to read it:"
  echo
  echo "- A CPU ratio below 1: envlight used less CPU than the peer (its \"default\" run; then its"
  echo "  \`--no-error\` run). Wall above CPU is waiting on a loaded machine (see the load)."
  echo "- envlight's \"default\" rows include its error measures against exact references: the"
  echo "  irradiance at 1024 normals, and for the GGX chain a finer cut of the levels' own cell"
  echo "  pyramid, 1024 directions per level. The \`--no-error\` rows are the products alone."
  echo "- Not the same filters. Irradiance: envlight's default is exact up to 0.5 % a texel;"
  echo "  cmft's is an SH expansion of order 4 (E / pi, no window), as is envlight's"
  echo "  \`--irradiance-method sh --irradiance-order 4\` row; cmgen's a Monte Carlo sum over its"
  echo "  cube's mips. Radiance: envlight's and cmgen's chains are GGX (different roughness"
  echo "  steps), cmft's are Phong lobes: each level is measured against the exact version of its"
  echo "  own kernel, so the errors compare how well each tool makes what it says it makes."
  echo "- SH: cmft decodes RGBE without envlight's + 0.5, hence two reference rows for it; cmft and"
  echo "  cmgen sample the map onto a cube first (cmft of face H / 2, its error falls as the map"
  echo "  grows; cmgen of 256, point samples that alias a small sun)."
  echo
  cat "$tmp/shown.md"
} >"$tmp/report.md"
out=$docs/peer_bench.md
cp "$tmp/report.md" "$out.tmp-$$" && mv -f "$out.tmp-$$" "$out"
echo "peer_bench: wrote $out" >&2
