#!/usr/bin/env bash
# The main job: from an environment (default: the built-in sky) to everything a scene needs,
# in one folder: 4 fitted lights + SH remainder (JSON, CSV) and the residual environment, SH
# coefficients with the artist forms, a POV-Ray include for the example scene (its recipe picked
# from the scene), POV-Ray renders of that scene (PNG at the include's auto exposure, and HDR),
# and preview.png (the map with its lights, spheres lit by the exact reference and by each
# approximation, errors and times).
#   bash scripts/main_job.sh [OUTDIR] [FILE]      (OUTDIR default: envlight-out; FILE default: -)
case "${1:-}" in  # --help: the usage and the header above, nothing run
  -h|--help) echo "usage: bash scripts/main_job.sh [OUTDIR] [FILE]"; sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
esac
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
file=${2:--}
cli=${ENVLIGHT:-$here/build/envlight}
mkdir -p "${1:-envlight-out}"
# absolute: the include names its sky image by this path, and POV-Ray runs inside the folder
out=$(cd "${1:-envlight-out}" && pwd)
"$cli" lights "$file" --method fit -n 4 --json -o "$out/lights.json" --residual "$out/residual.exr"
"$cli" lights "$file" --method fit -n 4 --csv -o "$out/lights.csv" --quiet
"$cli" sh "$file" --order 2 --window auto --json -o "$out/sh.json" --quiet
cp "$here/povray_include/envlight.inc" "$here/povray_include/examples/sphere_on_plane.pov" "$out/"
"$cli" pov "$file" --scene "$out/sphere_on_plane.pov" --sky --exposure auto --scene-radius 10 \
  -o "$out/env.inc" --quiet
"$cli" preview "$file" -o "$out/preview.png" --quiet
# render.png at the include's exposure; render.hdr in the map's radiometry
# povray ARGS... in $out, its messages added to povray.log; once more only when POV-Ray 3.7
# gave up starting its worker threads (it does on a heavily loaded machine)
pov() {
  (cd "$out" && povray "$@" 2>>povray.log) && return 0
  grep -q "Timed out waiting for worker thread startup" "$out/povray.log" || return 1
  echo "envlight: povray timed out starting its threads: trying again" >&2
  (cd "$out" && povray "$@" 2>>povray.log)
}
: >"$out/povray.log"
if ! { pov +Isphere_on_plane.pov +Orender.png +W480 +H360 +A0.1 -D &&
       pov +Isphere_on_plane.pov +Orender.hdr +FH +W480 +H360 +A0.1 -D \
         Declare=EnvLight_Exposure=1; }; then
  echo "envlight: povray failed on $out/sphere_on_plane.pov (see $out/povray.log)" >&2
  exit 1
fi
"$cli" lights "$file" --method fit -n 4 --quiet
echo "wrote: $(cd "$out" && ls | tr '\n' ' ')"
echo "into:  $out"
