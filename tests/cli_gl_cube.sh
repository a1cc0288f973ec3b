#!/usr/bin/env bash
# prefilter --layout cube --frame gltf: the six faces read the way OpenGL samples a cube map
# (the spec's face selection and (sc, tc, ma) table, s and t from the first texel of the first
# row) give the map's radiance in the glTF frame. The map: L(d) = 1 + 0.5 z + 0.3 x + 0.2 y in
# Blender's frame, i.e. 1 + 0.5 y - 0.2 z + 0.3 x in glTF's; the roughness-0 level's faces of
# 32 texels. Tolerance 5e-3 of L: a face texel is the area mean of a function linear in d and
# is read bilinearly, both off by second-order terms, (2/32)^2 / 8 = 5e-4 of the range; within
# half a texel of a face's edge the read is clamped to the face (as GL without seamless cube
# maps), off by up to |grad L| = 0.62 times half a texel, 1/32 (face units, at most that many
# radians) more. A face flipped, turned or swapped is off by tenths.
here=$(cd "$(dirname "$0")" && pwd) # tests/: gl_cube.py
. "$here/clitest.sh"

PYTHONPATH="$here" python3 -c 'import gl_cube; gl_cube.write_linear_pfm("linear.pfm")'
run "$ENVLIGHT" prefilter linear.pfm -o gl --specular --roughness 0 --layout cube --size 32 \
    --format pfm --frame gltf --no-error
has gl/prefilter.json '"frame": "gltf-y-up"'
has gl/prefilter.json '"cube_faces": "OpenGL'
checks=$((checks + 1))
PYTHONPATH="$here" python3 - <<'PY' || { fails=$((fails + 1)); echo "FAIL: the GL cube faces"; }
import struct
import gl_cube
def face(name):
    with open(f"gl/specular_00_{name}.pfm", "rb") as f:
        assert f.readline() == b"PF\n"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = struct.unpack(("<" if scale < 0 else ">") + "%df" % (3 * w * h), f.read())
    # row 0 = the image's top = the last row in the file
    return w, [[data[3 * ((h - 1 - j) * w + i)] for i in range(w)] for j in range(h)]
faces = {n: face(n) for n in gl_cube.FACES}
worst = gl_cube.worst_linear(faces)
print("GL cube faces: worst difference %.2f of the tolerance inside, %.2f at the edges" %
      tuple(worst))
assert max(worst) <= 1, worst
PY
# the cross is Blender's only
usage "$ENVLIGHT" prefilter linear.pfm -o gl2 --layout cross --frame gltf
has err.txt "cross"
finish
