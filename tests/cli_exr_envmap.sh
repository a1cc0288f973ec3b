#!/usr/bin/env bash
# `convert --layout-out exr-latlong | exr-cube` writes OpenEXR's envmap attribute (Imf::Envmap:
# ENVMAP_LATLONG 0, ENVMAP_CUBE 1): read back with layout auto, the file is what it was written
# as (a cube was guessed as a vertical strip before), exactly as with --layout-in; and
# OpenImageIO (a real consumer) sees it as its environment texture format.
. "$(dirname "$0")/clitest.sh"

run "$ENVLIGHT" convert - cube.exr --layout-out exr-cube --size 16 --sky-width 64
run "$ENVLIGHT" convert - ll.exr --layout-out exr-latlong --size 64 --sky-width 64
run "$ENVLIGHT" convert - plain.exr --sky-width 64
run "$ENVLIGHT" convert - vstrip.exr --layout-out vstrip --size 16 --sky-width 64

run "$ENVLIGHT" info cube.exr
has out.txt "16 x 96, layout exr-cube (from the file's envmap attribute)"
sed 1d out.txt > auto.txt
run "$ENVLIGHT" info cube.exr --layout-in exr-cube
sed 1d out.txt > chosen.txt
checks=$((checks + 1))
cmp -s <(grep -v '^size:' auto.txt) <(grep -v '^size:' chosen.txt) ||
  { fail "cube.exr: auto and --layout-in exr-cube differ"; diff auto.txt chosen.txt; }
run "$ENVLIGHT" info cube.exr --json
has out.txt '"layout": *"exr-cube"'

run "$ENVLIGHT" info ll.exr
has out.txt "64 x 32, layout exr-latlong (from the file's envmap attribute)"
run "$ENVLIGHT" info plain.exr
has out.txt "layout latlong (guessed from the 2:1 aspect ratio)"
run "$ENVLIGHT" info vstrip.exr   # same 1:6 shape as the cube, no attribute: a vertical strip
has out.txt "16 x 96, layout vstrip"

if command -v oiiotool >/dev/null; then
  run oiiotool --info -v cube.exr
  has out.txt 'textureformat: "CubeFace Environment"'
  run oiiotool --info -v ll.exr
  has out.txt 'textureformat: "LatLong Environment"'
  run oiiotool --info -v plain.exr
  hasnt out.txt 'textureformat'
else
  echo "SKIP: oiiotool absent (Debian: openimageio-tools): OpenImageIO's view not checked"
fi
finish
