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
. "$(dirname "$0")/clitest.sh"

python3 - <<'PY'
import math, struct
W, H = 256, 128
rows = []
for r in range(H):
    th = math.pi * (0.5 - (r + 0.5) / H)
    for c in range(W):
        ph = math.pi * (1 - 2 * (c + 0.5) / W)
        x, y, z = math.cos(th) * math.cos(ph), math.cos(th) * math.sin(ph), math.sin(th)
        v = 1 + 0.5 * z + 0.3 * x + 0.2 * y
        rows.append((r, (v, v, v)))
with open("linear.pfm", "wb") as f:  # PFM: bottom row first, little-endian (scale -1)
    f.write(b"PF\n%d %d\n-1.0\n" % (W, H))
    for r in range(H - 1, -1, -1):
        for c in range(W):
            f.write(struct.pack("<3f", *rows[r * W + c][1]))
PY
run "$ENVLIGHT" prefilter linear.pfm -o gl --specular --roughness 0 --layout cube --size 32 \
    --format pfm --frame gltf --no-error
has gl/prefilter.json '"frame": "gltf-y-up"'
has gl/prefilter.json '"cube_faces": "OpenGL'
checks=$((checks + 1))
python3 - <<'PY' || { fails=$((fails + 1)); echo "FAIL: the GL cube faces"; }
import math, struct
def face(name):
    with open(f"gl/specular_00_{name}.pfm", "rb") as f:
        assert f.readline() == b"PF\n"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = struct.unpack(("<" if scale < 0 else ">") + "%df" % (3 * w * h), f.read())
    # row 0 = the image's top = the last row in the file
    return w, [[data[3 * ((h - 1 - j) * w + i)] for i in range(w)] for j in range(h)]
faces = {n: face(n) for n in ("px", "nx", "py", "ny", "pz", "nz")}
def gl_sample(d):  # OpenGL 4.6 spec, table 8.19: face and (sc, tc, ma)
    x, y, z = d
    ax, ay, az = abs(x), abs(y), abs(z)
    if ax >= ay and ax >= az:
        n, sc, tc, ma = ("px", -z, -y, ax) if x > 0 else ("nx", z, -y, ax)
    elif ay >= az:
        n, sc, tc, ma = ("py", x, z, ay) if y > 0 else ("ny", x, -z, ay)
    else:
        n, sc, tc, ma = ("pz", x, -y, az) if z > 0 else ("nz", -x, -y, az)
    s, t = (sc / ma + 1) / 2, (tc / ma + 1) / 2
    N, img = faces[n]
    gx, gy = s * N - 0.5, t * N - 0.5
    edge = not (0 <= gx <= N - 1 and 0 <= gy <= N - 1)
    fx, fy = min(max(gx, 0), N - 1), min(max(gy, 0), N - 1)
    i0, j0 = min(int(fx), N - 2), min(int(fy), N - 2)
    a, b = fx - i0, fy - j0
    return edge, ((1 - a) * (1 - b) * img[j0][i0] + a * (1 - b) * img[j0][i0 + 1] +
                  (1 - a) * b * img[j0 + 1][i0] + a * b * img[j0 + 1][i0 + 1])
worst = [0, 0]
n = 600
for k in range(n):  # Fibonacci directions in the glTF frame
    y = 1 - (2 * k + 1) / n
    r, ph = math.sqrt(1 - y * y), k * math.pi * (3 - math.sqrt(5))
    d = (r * math.cos(ph), y, r * math.sin(ph))
    want = 1 + 0.5 * d[1] - 0.2 * d[2] + 0.3 * d[0]
    edge, got = gl_sample(d)
    allowed = 5e-3 * want + (0.62 / 32 if edge else 0)
    worst[edge] = max(worst[edge], abs(got - want) / allowed)
print("GL cube faces: worst difference %.2f of the tolerance inside, %.2f at the edges" %
      tuple(worst))
assert max(worst) <= 1, worst
PY
# the cross is Blender's only
usage "$ENVLIGHT" prefilter linear.pfm -o gl2 --layout cross --frame gltf
has err.txt "cross"
finish
