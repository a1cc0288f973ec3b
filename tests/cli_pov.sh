#!/usr/bin/env bash
# envlight pov: what the include holds for each option (only what the scene asks for),
# escaping of names, atomic output, usage errors. Renders are in tests/py_pov.py.
. "$(dirname "$0")/clitest.sh"

S="--sky-width 128"
run "$ENVLIGHT" pov - $S -o default.inc
for k in "EnvLight_Generated_Inc_Temp" "#declare EnvLight_Count" "EnvLight_Colour" \
         "EnvLight_Ambient_Coef" "#declare EnvLight_Shadows = 1" "diffuse error" \
         "EnvLight_Place_Lights()" '#include "envlight.inc"' "POV-Ray vector <x, z, y>"; do
  has default.inc "$k"
done
hasnt default.inc "EnvLight_Sky_File"
hasnt default.inc "^EnvLight_Sky()"
run "$ENVLIGHT" pov - $S --ambient none -o none.inc
hasnt none.inc "#declare EnvLight_Ambient"
run "$ENVLIGHT" pov - $S --ambient hemi -o hemi.inc
has hemi.inc "EnvLight_Hemi_Sky"
has hemi.inc "#declare EnvLight_Ambient_Terms = 1;"
run "$ENVLIGHT" pov - $S --shadows soft -o soft.inc
has soft.inc "#declare EnvLight_Shadows = 2"
run "$ENVLIGHT" pov - $S --shadows none -o shadowless.inc
has shadowless.inc "#declare EnvLight_Shadows = 0"
run "$ENVLIGHT" pov - $S --no-place -o noplace.inc
hasnt noplace.inc "EnvLight_Place_Lights()"
run "$ENVLIGHT" pov - $S --sky -o sky.inc
has sky.inc '#declare EnvLight_Sky_File = "sky_sky.hdr";'
has sky.inc "EnvLight_Sky()"
checks=$((checks + 1)); [ -s sky_sky.hdr ] || { fails=$((fails + 1)); echo "FAIL: sky_sky.hdr not written"; }
run "$ENVLIGHT" pov - $S --sky-residual --sky-image res.hdr -o res.inc
has res.inc '#declare EnvLight_Sky_File = "res.hdr";'
# --order: SH order of the fit's remainder (25 coefficients for 4)
run "$ENVLIGHT" pov - $S --order 4 -o order4.inc
has order4.inc "#declare EnvLight_Ambient_SH = array\[25\]"
# median cut: the lights take everything, the residual SH is zero
run "$ENVLIGHT" pov - $S --method median -n 8 -o median.inc
has median.inc "8 lights by median"

# --ground: the plane's albedo and radiance declared, the header says so; without it, nothing
run "$ENVLIGHT" pov - $S --ground 0.5 -o ground.inc
has ground.inc "#declare EnvLight_Ground_Albedo = 0.5;"
has ground.inc "#declare EnvLight_Ground_Radiance = <"
has ground.inc "^// ground plane (canonical z = 0, POV-Ray y = 0), albedo 0.5"
hasnt default.inc "EnvLight_Ground"
run "$ENVLIGHT" pov - $S --ground 0 --ambient none -o ground0.inc
has ground0.inc "#declare EnvLight_Ground_Radiance = <0, 0, 0>;"
for bad in 1.5 -0.1 abc nan inf ""; do
  usage "$ENVLIGHT" pov - $S --ground "$bad" -o bad.inc
  has err.txt "ground takes the plane's albedo, a number within \[0, 1\]"
done
usage "$ENVLIGHT" pov - $S --ground
checks=$((checks + 1)); [ ! -e bad.inc ] || { fails=$((fails + 1)); echo "FAIL: bad --ground wrote bad.inc"; }

# names: quotes, backslashes and '#' escaped; control characters refused, nothing written
run "$ENVLIGHT" convert - 'a"b\c#d.hdr' $S
run "$ENVLIGHT" pov 'a"b\c#d.hdr' --sky -o q.inc
has q.inc '#declare EnvLight_Source = "a\\"b\\\\c#d.hdr";'
has q.inc '#declare EnvLight_Sky_File = "a\\"b\\\\c#d.hdr";'
cp q.inc q.before
checks=$((checks + 1))
"$ENVLIGHT" pov - $S --sky --sky-image "$(printf 'x\ny.hdr')" -o q.inc >out.txt 2>err.txt
rc=$?; { [ $rc = 1 ] && cmp -s q.inc q.before && grep -q "control characters" err.txt; } ||
  { fails=$((fails + 1)); echo "FAIL: control character in a name: exit $rc"; cat err.txt; }

# atomic: a failing run leaves the old include as it was
cp default.inc keep.inc
checks=$((checks + 1))
"$ENVLIGHT" pov no_such_file.hdr -o keep.inc >out.txt 2>err.txt
rc=$?; { [ $rc = 1 ] && cmp -s keep.inc default.inc; } ||
  { fails=$((fails + 1)); echo "FAIL: failed run changed the include (exit $rc)"; }

usage "$ENVLIGHT" pov - --ambient nope
usage "$ENVLIGHT" pov - --shadows nope
usage "$ENVLIGHT" pov - --order 9
usage "$ENVLIGHT" pov - --scene-radius 0
usage "$ENVLIGHT" pov - --sky
usage "$ENVLIGHT" pov a.hdr b.hdr

# POV-Ray parses the generated include with every option (no render: +W8 +H8 -F)
if command -v povray >/dev/null; then
  src=$(cd "$(dirname "$0")/.." && pwd)
  for inc in default none hemi soft shadowless sky res order4 median q ground ground0; do
    printf '#version 3.7;\nglobal_settings { assumed_gamma 1 }\n#include "%s.inc"\ncamera { location <0,0,-5> look_at 0 }\nsphere { 0, 1 EnvLight_Diffuse_Texture(<1,1,1>) }\n' "$inc" > p_$inc.pov
    checks=$((checks + 1))
    povray +Ip_$inc.pov -F +W8 +H8 -D -P +L"$src/povray_include" >pov.txt 2>&1 ||
      { fails=$((fails + 1)); echo "FAIL: POV-Ray could not use $inc.inc"; grep -A3 "Error" pov.txt; }
  done
else
  echo "SKIP: povray absent: the includes are not parsed"
fi

finish
