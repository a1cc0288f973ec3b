"""What tests/cli_gl_cube.sh and tests/cli_ktx2.sh share: the linear test map and OpenGL's cube
sampling (imported by their Python parts, PYTHONPATH = tests/).

The map: L(d) = 1 + 0.5 z + 0.3 x + 0.2 y in Blender's frame, i.e. 1 + 0.5 y - 0.2 z + 0.3 x in
glTF's. Read through the faces as OpenGL samples a cube map (OpenGL 4.6, table 8.19: the face
and (sc, tc, ma); s and t from the first texel of the first row; bilinear, clamped to the face
as GL without seamless cube maps), it is within 5e-3 of L inside a face (a texel is the area
mean of a function linear in d, read bilinearly: both off by second-order terms, (2/32)^2 / 8
= 5e-4 of the range, at 32 texels), and within |grad L| = 0.62 times half a texel more near a
face's edge."""
import math
import struct

FACES = ("px", "nx", "py", "ny", "pz", "nz")


def write_linear_pfm(path, w=256, h=128):
    """The linear map as a lat-long PFM (bottom row first, little-endian: scale -1)."""
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        for r in range(h - 1, -1, -1):
            th = math.pi * (0.5 - (r + 0.5) / h)
            for c in range(w):
                ph = math.pi * (1 - 2 * (c + 0.5) / w)
                x, y, z = math.cos(th) * math.cos(ph), math.cos(th) * math.sin(ph), math.sin(th)
                f.write(struct.pack("<3f", *[1 + 0.5 * z + 0.3 * x + 0.2 * y] * 3))


def gl_sample(faces, d):
    """faces: name -> (N, rows of N values, row 0 first). (near an edge?, the value)."""
    x, y, z = d
    ax, ay, az = abs(x), abs(y), abs(z)
    if ax >= ay and ax >= az:
        n, sc, tc, ma = ("px", -z, -y, ax) if x > 0 else ("nx", z, -y, ax)
    elif ay >= az:
        n, sc, tc, ma = ("py", x, z, ay) if y > 0 else ("ny", x, -z, ay)
    else:
        n, sc, tc, ma = ("pz", x, -y, az) if z > 0 else ("nz", -x, -y, az)
    s, t = (sc / ma + 1) / 2, (tc / ma + 1) / 2
    size, img = faces[n]
    gx, gy = s * size - 0.5, t * size - 0.5
    edge = not (0 <= gx <= size - 1 and 0 <= gy <= size - 1)
    fx, fy = min(max(gx, 0), size - 1), min(max(gy, 0), size - 1)
    i0, j0 = min(int(fx), size - 2), min(int(fy), size - 2)
    a, b = fx - i0, fy - j0
    return edge, ((1 - a) * (1 - b) * img[j0][i0] + a * (1 - b) * img[j0][i0 + 1] +
                  (1 - a) * b * img[j0 + 1][i0] + a * b * img[j0 + 1][i0 + 1])


def worst_linear(faces, rounding=0.0, n=600):
    """The largest |read - L| over n Fibonacci directions (glTF's frame), as a fraction of the
    tolerance above (plus `rounding` x the value read), inside the faces and at their edges."""
    worst = [0.0, 0.0]
    for k in range(n):
        y = 1 - (2 * k + 1) / n
        r, ph = math.sqrt(1 - y * y), k * math.pi * (3 - math.sqrt(5))
        d = (r * math.cos(ph), y, r * math.sin(ph))
        want = 1 + 0.5 * d[1] - 0.2 * d[2] + 0.3 * d[0]
        edge, got = gl_sample(faces, d)
        size = faces["px"][0]
        allowed = 5e-3 * want + rounding * abs(got) + (0.62 / size if edge else 0)
        worst[edge] = max(worst[edge], abs(got - want) / allowed)
    return worst
