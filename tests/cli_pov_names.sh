#!/usr/bin/env bash
# POV-Ray 3.7 and file names with bytes outside ASCII (issue 30, 4.10): `pov --sky` named the
# sky image by its absolute path, and POV-Ray 3.7 cannot open such a name ("Cannot open
# file"). What it can open, tried here first with POV-Ray itself (Debian's 3.7.0.10): no image
# named with such bytes, absolute or relative, nor found through +L; an ASCII name relative to
# a working folder that has them, yes. So the include names the sky image relative to its own
# folder when only that is ASCII (a comment and a warning say to render from there), a map whose
# own name POV-Ray cannot open gets a sky image next to the include instead, and a name that
# cannot be given in ASCII at all is refused (exit 1, nothing written). Each include is then
# rendered by POV-Ray from its folder: the sky must show (a camera looking at the horizon).
. "$(dirname "$0")/clitest.sh"

command -v povray >/dev/null || { echo "SKIP: povray is not installed"; exit 77; }
rm -rf names && mkdir names && cd names || exit 1
S=(--sky-width 64 --quiet)
"$ENVLIGHT" convert - sky.hdr "${S[@]}" || exit 1
scene() { # scene FOLDER: a camera looking at the sky, under the include
  printf '#version 3.7;\nglobal_settings { assumed_gamma 1 }\n#include "env.inc"\n%s\n' \
    'camera { location <0, 1, 0> look_at <1, 1.2, 0> angle 60 }' >"$1/scene.pov"
}
# rendered FOLDER: POV-Ray renders FOLDER/scene.pov from FOLDER; exit 0 and a sky that is not
# black (the mean of the 8 x 8 PPM's bytes above 10)
rendered() {
  checks=$((checks + 1))
  (cd "$1" && povray scene.pov +W8 +H8 -D -GA +FP +Oout.ppm >pov.txt 2>&1) ||
    { fail "$1: POV-Ray failed: $(grep -i 'error' "$1/pov.txt" | head -2)"; return; }
  python3 - "$1/out.ppm" <<'PY' || fail "$1: the sky did not show"
import sys
d = open(sys.argv[1], "rb").read()
px = d.split(b"\n", 3)[3]
assert sum(px) / len(px) > 10, sum(px) / len(px)
PY
}

# What POV-Ray 3.7 itself opens.
mkdir -p "café" plain
cp sky.hdr "café/s.hdr"; cp sky.hdr "s_café.hdr"; cp sky.hdr plain/s.hdr
probe() { # probe FOLDER IMAGE-NAME [+L...]: 0 when POV-Ray opens the image
  local dir=$1 name=$2; shift 2
  printf '#version 3.7;\ncamera { location 0 look_at z }\nsky_sphere { pigment { image_map { hdr "%s" map_type 1 } } }\n' \
    "$name" >"$dir/probe.pov"
  (cd "$dir" && povray probe.pov +W4 +H4 -D -GA +FP +Oprobe.ppm "$@" >/dev/null 2>&1)
}
expect_pov() { checks=$((checks + 1)); [ "$1" = "$2" ] || fail "POV-Ray 3.7: $3 (got $1)"; }
probe . "$PWD/café/s.hdr"; expect_pov $? 1 "opened an absolute name with UTF-8 bytes"
probe . "s_café.hdr"; expect_pov $? 1 "opened a relative name with UTF-8 bytes"
probe . s.hdr "+L$PWD/café"; expect_pov $? 1 "found an image through a +L folder with UTF-8 bytes"
probe "café" s.hdr; expect_pov $? 0 "could not open an ASCII name from a folder with UTF-8 bytes"
probe . "$PWD/plain/s.hdr"; expect_pov $? 0 "could not open an ASCII absolute name"

# 1. The map and the include in a folder with UTF-8 bytes: the map (a lat-long .hdr, its own
#    sky) named relative to the include's folder, with a warning; rendered from there.
cp sky.hdr "café/m.hdr"
scene "café"
run "$ENVLIGHT" pov "café/m.hdr" -o "café/env.inc" --sky --recipe sh
has err.txt "warning: POV-Ray 3.7 cannot open a file name with bytes outside ASCII: the include names the sky image"
has "café/env.inc" '^#declare EnvLight_Sky_File = "m.hdr";'
has "café/env.inc" "^// relative to this include's folder; render from there"
rendered "café"
# 2. The same with the residual as the sky (written next to the include, env_sky.hdr)
run "$ENVLIGHT" pov "café/m.hdr" -o "café/env.inc" --sky-residual --recipe sh
has "café/env.inc" '^#declare EnvLight_Sky_File = "env_sky.hdr";'
rendered "café"
# 3. A map whose own name POV-Ray cannot open, the include in an ASCII folder: the sky is a
#    copy next to the include, named by its absolute (ASCII) path: no warning needed
scene plain
run "$ENVLIGHT" pov "s_café.hdr" -o plain/env.inc --sky --recipe sh
hasnt err.txt "warning"
has plain/env.inc "^#declare EnvLight_Sky_File = \"$PWD/plain/env_sky.hdr\";"
rendered plain
# 4. An include whose own name has UTF-8 bytes: its default sky image (env_é_sky.hdr) cannot
#    be named in ASCII: refused, nothing written; --sky-image with an ASCII name works
expect 1 "a sky image POV-Ray cannot open" -- "$ENVLIGHT" pov - -o "plain/env_é.inc" --sky \
  "${S[@]}"
has err.txt "POV-Ray 3.7 cannot open a file name with bytes outside ASCII"
checks=$((checks + 1))
[ -z "$(ls plain | grep 'é')" ] || fail "written: $(ls plain)"
run "$ENVLIGHT" pov - -o "plain/env_é.inc" --sky --sky-image plain/ascii_sky.hdr "${S[@]}"
has "plain/env_é.inc" "^#declare EnvLight_Sky_File = \"$PWD/plain/ascii_sky.hdr\";"
cp "plain/env_é.inc" plain/env.inc
rendered plain
finish
