#!/usr/bin/env bash
# No output may replace an input or another output of the same run (issue 30, 4.1 and 4.6):
# every command refuses, before it computes anything, an output that is the same file as an
# input (the map, a POV-Ray scene) or as another of its outputs: the same device and inode
# when the file exists (hard and symbolic links), else the same normalised path (./, ../,
# //). Exit 1, stderr names both, the input keeps its bytes and no output is written. The
# library does the same for the writers it owns (tests/test_same_file.c).
. "$(dirname "$0")/clitest.sh"

rm -rf same && mkdir same && cd same || exit 1
S=(--sky-width 64 --quiet)
"$ENVLIGHT" convert - m.hdr "${S[@]}" || exit 1
"$ENVLIGHT" convert - probe.hdr --layout-out angular --size 32 "${S[@]}" || exit 1
cp m.hdr env_sky.hdr
cp probe.hdr p_sky.hdr
printf '#version 3.7;\n#include "e.inc"\nsphere { <0, 1, 0>, 1 }\n' >s.pov
md5sum m.hdr probe.hdr env_sky.hdr p_sky.hdr s.pov >sums.txt

# refused FILE COMMAND...: COMMAND must exit 1 naming FILE and "the same file", and leave
# every input as it was and no output or temporary behind
refused() {
  local named=$1; shift
  checks=$((checks + 1))
  "$@" >out.txt 2>err.txt
  local rc=$?
  [ $rc = 1 ] || { fail "exit $rc, expected 1: $*"; cat err.txt; }
  has err.txt "$named"
  has err.txt "the same file as"
  checks=$((checks + 1))
  md5sum -c --quiet sums.txt || fail "an input changed: $*"
  checks=$((checks + 1))
  local left
  left=$(ls -A | grep -v -x -e m.hdr -e probe.hdr -e env_sky.hdr -e p_sky.hdr -e s.pov \
           -e sums.txt -e out.txt -e err.txt -e d -e hl.hdr -e sl.hdr -e m.glb -e m.png)
  [ -z "$left" ] || { fail "left behind by $*: $left"; rm -rf $left; }
}

# the probe's cases: the default sky image (OUT without .inc + _sky.hdr) is the input
refused "p_sky.hdr" "$ENVLIGHT" pov p_sky.hdr -o p.inc --sky --quiet
refused "env_sky.hdr" "$ENVLIGHT" pov env_sky.hdr -o env.inc --sky --sky-residual --quiet
refused "m.hdr" "$ENVLIGHT" pov m.hdr -o m.hdr --sky --quiet
refused "e.inc" "$ENVLIGHT" pov - -o e.inc --sky-image e.inc "${S[@]}"
refused "m.hdr" "$ENVLIGHT" pov m.hdr -o e.inc --sky-image m.hdr --sky --rotate 90 --quiet
refused "s.pov" "$ENVLIGHT" pov m.hdr -o s.pov --scene s.pov --quiet
refused "s.pov" "$ENVLIGHT" pov m.hdr -o e.inc --scene s.pov --sky-image ./s.pov --sky --quiet
# lights: -o and --residual, each other and the input
refused "x.exr" "$ENVLIGHT" lights - -o x.exr --residual x.exr "${S[@]}"
refused "new.json" "$ENVLIGHT" lights - -o new.json --residual ./new.json "${S[@]}"
refused "m.hdr" "$ENVLIGHT" lights m.hdr -o m.hdr --quiet
refused "m.hdr" "$ENVLIGHT" lights m.hdr --residual m.hdr --quiet
refused "m.hdr" "$ENVLIGHT" sh m.hdr --json -o m.hdr --quiet
refused "m.hdr" "$ENVLIGHT" convert m.hdr m.hdr --quiet
refused "m.hdr" "$ENVLIGHT" convert m.hdr "$PWD//d/../m.hdr" --quiet
# hard and symbolic links: the same file by device and inode
ln m.hdr hl.hdr
refused "hl.hdr" "$ENVLIGHT" convert m.hdr hl.hdr --rotate 90 --quiet
ln -s m.hdr sl.hdr
refused "m.hdr" "$ENVLIGHT" convert sl.hdr m.hdr --rotate 90 --quiet
# gltf and preview take their input by content, whatever its name
cp m.hdr m.glb
md5sum m.glb >>sums.txt
refused "m.glb" "$ENVLIGHT" gltf m.glb -o m.glb --size 16 --mips 2 --quiet
cp m.hdr m.png
md5sum m.png >>sums.txt
refused "m.png" "$ENVLIGHT" preview m.png -o m.png --quiet
# prefilter: a file of the set it writes is the input
mkdir d && cp m.hdr d/irradiance.hdr
md5sum d/irradiance.hdr >>sums.txt
refused "d/irradiance.hdr" "$ENVLIGHT" prefilter d/irradiance.hdr -o d --format hdr \
  --size 16 --levels 2 --samples 8 --quiet
checks=$((checks + 1))
[ "$(ls -A d)" = irradiance.hdr ] || fail "d/ holds more than before: $(ls -A d)"
# bench: its CSV
refused "m.hdr" "$ENVLIGHT" bench m.hdr --only load --runs 1 --csv m.hdr

# not refused: other names, and stdout
run "$ENVLIGHT" convert m.hdr m2.hdr --quiet
run "$ENVLIGHT" lights m.hdr -o l.json --json --residual r.exr --quiet
run "$ENVLIGHT" pov m.hdr -o m.inc --sky --quiet
has m.inc "EnvLight_Sky_File = \"$PWD/m.hdr\""
run "$ENVLIGHT" pov probe.hdr -o probe.inc --sky --quiet
has probe.inc "EnvLight_Sky_File = \"$PWD/probe_sky.hdr\""
run "$ENVLIGHT" sh m.hdr -o - --quiet
rm -f m2.hdr l.json r.exr m.inc probe.inc probe_sky.hdr
finish
