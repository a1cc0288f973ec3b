#!/usr/bin/env bash
# prefilter --format ktx2 (issue 16) read by a real consumer: ktx-parse 2.0.0 (the KTX2 reader of
# three.js and glTF-Transform, from scripts/npm_tools.sh; skipped without it) reads
# specular.ktx2 and irradiance.ktx2; its header, level index, data format descriptor and
# KTXwriter must be what the KTX 2.0 spec asks for an RGBA16F (or RGBA32F) cube map, and its
# own writer must reproduce our file byte for byte from what it read (so offsets, padding and
# key/value layout are the spec's as ktx-parse lays them out). The texels, decoded here from
# the level data ktx-parse returns (Python's struct 'e': IEEE binary16), are compared with the
# EXR faces of the same run with --format exr (read by OpenImageIO's oiiotool):
# - levels whose lat-long width is 4 x (face >> k) (--min-size 16): every value within the
#   half-float rounding bound, |h - f| <= 2^-11 |f| (round to nearest: half an ulp, the ulp
#   being 2^-10 of the binade's lower end), or 2^-25 below 2^-14 (half a subnormal step); alpha
#   exactly 1; ktx2-float: bit-identical;
#   the default chain is computed at its mip sizes (no level resampled: before issue 30 the
#   default --min-size kept levels 2 and 3 wider and resampled them);
# - levels clamped by an explicit --min-size (wider than their mip level, area-resampled
#   first): listed in resampled_levels and said on stderr; the other maps as above;
# - directions: a linear map read through OpenGL's cube face table (as cli_gl_cube.sh), and the
#   built-in sky's sun found where the glTF frame puts it.
# And the refusals (--frame blender, a layout other than cube, more levels than the mip chain
# holds), and that the format alone implies --layout cube --frame gltf.
here=$(cd "$(dirname "$0")" && pwd) # tests/: gl_cube.py
. "$here/clitest.sh"

mods=${ENVL_NODE_MODULES:-}
if [ -z "$mods" ] || [ ! -f "$mods/ktx-parse/package.json" ]; then
  echo "SKIP: ktx-parse is not installed (ENVL_NODE_MODULES='$mods'; scripts/npm_tools.sh)"
  exit 77
fi
for tool in node oiiotool; do
  command -v $tool >/dev/null || { echo "SKIP: $tool is not installed"; exit 77; }
done
main=$(cd "$mods/ktx-parse" && node -p 'require("./package.json").exports["."].default')
export KTX_PARSE="$mods/ktx-parse/$main"

# The consumer's view: node check_ktx2.mjs FILE VKFORMAT SIZE LEVELS writes FILE.level<k>.bin
# (each level's data as ktx-parse's level index points to it) and FILE.json (what it read).
cat > check_ktx2.mjs <<'JS'
import { readFileSync, writeFileSync } from "fs";
const k = await import(process.env.KTX_PARSE);
const [file, vk, size, levels] = process.argv.slice(2);
const bytes = new Uint8Array(readFileSync(file));
const c = k.read(bytes);
const fails = [];
const eq = (what, got, want) => { if (got !== want) fails.push(`${what} = ${got}, expected ${want}`); };
const half = +vk === k.VK_FORMAT_R16G16B16A16_SFLOAT;
eq("vkFormat", c.vkFormat, +vk);
eq("typeSize", c.typeSize, half ? 2 : 4);
eq("pixelWidth", c.pixelWidth, +size);
eq("pixelHeight", c.pixelHeight, +size);
eq("pixelDepth", c.pixelDepth, 0);
eq("layerCount", c.layerCount, 0);
eq("faceCount", c.faceCount, 6);
eq("levelCount", c.levelCount, +levels);
eq("supercompressionScheme", c.supercompressionScheme, k.KHR_SUPERCOMPRESSION_NONE);
eq("DFD blocks", c.dataFormatDescriptor.length, 1);
const d = c.dataFormatDescriptor[0];
eq("vendorId", d.vendorId, k.KHR_DF_VENDORID_KHRONOS);
eq("descriptorType", d.descriptorType, k.KHR_DF_KHR_DESCRIPTORTYPE_BASICFORMAT);
eq("versionNumber", d.versionNumber, k.KHR_DF_VERSION);
eq("colorModel", d.colorModel, k.KHR_DF_MODEL_RGBSDA);
eq("colorPrimaries", d.colorPrimaries, k.KHR_DF_PRIMARIES_BT709);
eq("transferFunction", d.transferFunction, k.KHR_DF_TRANSFER_LINEAR);
eq("flags", d.flags, k.KHR_DF_FLAG_ALPHA_STRAIGHT);
eq("texelBlockDimension", d.texelBlockDimension.join(), "0,0,0,0");
eq("bytesPlane", d.bytesPlane.join(), [half ? 8 : 16, 0, 0, 0, 0, 0, 0, 0].join());
eq("samples", d.samples.length, 4);
const channels = [k.KHR_DF_CHANNEL_RGBSDA_RED, k.KHR_DF_CHANNEL_RGBSDA_GREEN,
                  k.KHR_DF_CHANNEL_RGBSDA_BLUE, k.KHR_DF_CHANNEL_RGBSDA_ALPHA];
const bits = half ? 16 : 32;
d.samples.forEach((s, i) => {
  eq(`sample ${i} bitOffset`, s.bitOffset, bits * i);
  eq(`sample ${i} bitLength`, s.bitLength, bits - 1);
  eq(`sample ${i} channelType`, s.channelType,
     channels[i] | k.KHR_DF_SAMPLE_DATATYPE_FLOAT | k.KHR_DF_SAMPLE_DATATYPE_SIGNED);
  const f = new Float32Array(new Int32Array([s.sampleLower, s.sampleUpper]).buffer);
  eq(`sample ${i} sampleLower`, f[0], -1);
  eq(`sample ${i} sampleUpper`, f[1], 1);
});
if (!/^envlight \d+\.\d+\.\d+$/.test(c.keyValue.KTXwriter || ""))
  fails.push(`KTXwriter = '${c.keyValue.KTXwriter}'`);
eq("keys", Object.keys(c.keyValue).join(), "KTXwriter");
c.levels.forEach((l, i) => {
  const s = Math.max(1, size >> i);
  eq(`level ${i} bytes`, l.levelData.byteLength, 6 * s * s * 4 * (half ? 2 : 4));
  eq(`level ${i} uncompressed bytes`, l.uncompressedByteLength, l.levelData.byteLength);
  eq(`level ${i} alignment`, l.levelData.byteOffset % (half ? 8 : 16), 0);
  writeFileSync(`${file}.level${i}.bin`, l.levelData);
});
const again = k.write(c, { keepWriter: true });
if (again.length !== bytes.length || again.some((b, i) => b !== bytes[i]))
  fails.push(`ktx-parse's write() of what it read differs from the file (${again.length} ` +
             `against ${bytes.length} bytes)`);
if (fails.length) { console.log(`${file}: ` + fails.join("; ")); process.exit(1); }
console.log(`${file}: ktx-parse: vkFormat ${c.vkFormat}, ${c.pixelWidth}x${c.pixelHeight} x 6 ` +
            `faces, ${c.levelCount} levels, KTXwriter '${c.keyValue.KTXwriter}'`);
JS
# consumer FILE VKFORMAT SIZE LEVELS
consumer() { checks=$((checks + 1)); node check_ktx2.mjs "$@" || fail "ktx-parse on $1"; }

# The texel comparison: compare.py KTXDIR EXRDIR [float]
cat > compare.py <<'PY'
import json, math, struct, subprocess, sys
kdir, edir, exact = sys.argv[1], sys.argv[2], sys.argv[3:] == ["float"]
names = ["px", "nx", "py", "ny", "pz", "nz"]
meta = json.load(open(f"{kdir}/prefilter.json"))

def exr_faces(stems, edir):  # {stem_face: (size, [[(r, g, b)] rows from the top])}, oiiotool
    files = [f"{edir}/{s}_{n}.exr" for s in stems for n in names]
    out = subprocess.run(["oiiotool", "--dumpdata"] + files, capture_output=True, text=True,
                         check=True).stdout
    faces, cur = {}, None
    for line in out.splitlines():
        if not line.startswith(" "):
            name, dims = line.split(" : ")
            w = int(dims.split("x")[0])
            cur = [[None] * w for _ in range(w)]
            faces[name.split("/")[-1][:-4]] = (w, cur)
        elif "Pixel (" in line:
            xy, vals = line.split("):")
            x, y = map(int, xy.split("(")[1].split(","))
            cur[y][x] = struct.unpack("3f", struct.pack("3f", *map(float, vals.split())))
    return faces

def ktx_level(path, k, size):  # [face][row][col] = (r, g, b, a)
    data = open(f"{path}.level{k}.bin", "rb").read()
    s = max(1, size >> k)
    fmt, width = ("<%de" if not exact else "<%df"), (2 if not exact else 4)
    v = struct.unpack(fmt % (len(data) // width), data)
    return [[[tuple(v[4 * ((f * s + j) * s + i):][:4]) for i in range(s)] for j in range(s)]
            for f in range(6)]

def bound(f):  # the half rounding bound of a value f (binary32)
    return 0.0 if exact else max(abs(f) * 2.0 ** -11, 2.0 ** -25)

worst, fails, counted = 0.0, [], 0
specular = meta["specular"]
F = meta["specular_ktx2"]["face_size"]
resampled = set(meta["specular_ktx2"]["resampled_levels"])
stems = ["specular_%02d" % k for k in range(len(specular))] + ["irradiance"]
faces = exr_faces(stems, edir)
maps = [("specular", k, "specular_%02d" % k, F) for k in range(len(specular))]
maps.append(("irradiance", 0, "irradiance", meta["irradiance"]["face_size"]))
for kfile, k, stem, size in maps:
    lv = ktx_level(f"{kdir}/{kfile}.ktx2", k, size)
    s = max(1, size >> k)
    for f, n in enumerate(names):
        w, e = faces[f"{stem}_{n}"]
        for j in range(s):
            for i in range(s):
                t = lv[f][j][i]
                if t[3] != 1.0:
                    fails.append(f"{kfile} level {k} face {n} ({i}, {j}): alpha {t[3]}")
                if kfile == "specular" and k in resampled:
                    break  # not the EXR's texels: resampled to the mip's size
                if w != s:
                    fails.append(f"{stem}_{n}: {w} texels, the KTX2 level {s}")
                    break
                for c in range(3):
                    ref = e[j][i][c]
                    d = abs(t[c] - ref)
                    counted += 1
                    if d > bound(ref):
                        fails.append(f"{kfile} level {k} face {n} ({i}, {j}) channel {c}: "
                                     f"{t[c]} against {ref}")
                    elif bound(ref) > 0:
                        worst = max(worst, d / bound(ref))
print(f"{kdir} against {edir}: {counted} values, worst {worst:.3f} of the rounding bound"
      + (f" (levels {sorted(resampled)}: resampled, not compared)" if resampled else ""))
for m in fails[:10]:
    print("FAIL:", m)
sys.exit(1 if fails else 0)
PY
# compare KTXDIR EXRDIR [float]
compare() { checks=$((checks + 1)); python3 compare.py "$@" || fail "texels of $1 against $2"; }

rm -rf big a_ktx a_exr c_ktx c_exr b_ktx b_exr b_flt lin imp1 imp2 r1 r2 r3 r4 r5
# The issue's command (the default --min-size 64 no longer keeps levels 2 and 3 wider than
# their mip level: KTX2's chain is computed at its mip sizes), the same chain with --min-size
# 16, and with --min-size 64 given (levels 2 and 3 wider, then resampled).
run "$ENVLIGHT" prefilter - -o a_ktx --format ktx2 --layout cube --size 32 --levels 4
run "$ENVLIGHT" prefilter - -o a_exr --format exr --layout cube --frame gltf --size 32 --levels 4 \
    --min-size 16
run "$ENVLIGHT" prefilter - -o b_ktx --format ktx2 --layout cube --size 32 --levels 4 \
    --min-size 16 --no-error
run "$ENVLIGHT" prefilter - -o b_exr --format exr --layout cube --frame gltf --size 32 \
    --levels 4 --min-size 16 --no-error
"$ENVLIGHT" prefilter - -o c_ktx --format ktx2 --layout cube --size 32 --levels 4 \
    --min-size 64 --no-error 2>c_ktx.err >/dev/null || fail "prefilter -o c_ktx"
run "$ENVLIGHT" prefilter - -o c_exr --format exr --layout cube --frame gltf --size 32 \
    --levels 4 --min-size 64 --no-error
run "$ENVLIGHT" prefilter - -o b_flt --format ktx2-float --size 32 --levels 4 --min-size 16 \
    --no-error
for d in a_ktx b_ktx c_ktx; do
  consumer $d/specular.ktx2 97 32 4
  consumer $d/irradiance.ktx2 97 32 1
  has $d/prefilter.json '"vk_format": 97'
  has $d/prefilter.json '"vk_format_name": "VK_FORMAT_R16G16B16A16_SFLOAT"'
  has $d/prefilter.json '"cube_faces": "OpenGL'
  has $d/prefilter.json '"file": "specular.ktx2"'
  has $d/prefilter.json '"file": "irradiance.ktx2"'
  has $d/prefilter.json '"clamped_values": 0'
  hasnt $d/prefilter.json '\.exr'
done
consumer b_flt/specular.ktx2 109 32 4
consumer b_flt/irradiance.ktx2 109 32 1
has b_flt/prefilter.json '"vk_format_name": "VK_FORMAT_R32G32B32A32_SFLOAT"'
checks=$((checks + 1))
python3 - <<'PY' || fail "prefilter.json's specular_ktx2"
import json
for d, resampled in (("a_ktx", []), ("b_ktx", []), ("c_ktx", [2, 3])):
    m = json.load(open(d + "/prefilter.json"))
    k = m["specular_ktx2"]
    assert (k["file"], k["vk_format"], k["face_size"], k["levels"]) == ("specular.ktx2", 97, 32, 4), k
    assert k["roughness"] == [0, 0.333333333, 0.666666667, 1] and k["resampled_levels"] == resampled, k
    assert [(l["mip_level"], l["face_size"]) for l in m["specular"]] == [(0, 32), (1, 16), (2, 8), (3, 4)]
    assert (m["frame"], m["layout"], m["ktx2"]["vk_format"]) == ("gltf-y-up", "cube", 97), m
    assert m["irradiance"]["resampled"] is False, m["irradiance"]
PY
compare a_ktx a_exr
compare b_ktx b_exr
compare c_ktx c_exr
has c_ktx.err "levels 2, 3 were computed at another size than their KTX2 mip"
compare b_flt b_exr float

# The sun of the built-in sky (elevation 35 degrees, azimuth 0: Blender's (cos 35, 0, sin 35),
# glTF's (cos 35, sin 35, 0)) is in the brightest texel of the roughness-0 level: the texel's
# centre is within half its diagonal of the sun's centre, plus the sun's radius (under half a
# degree). A texel spans at most 2/32 of the face plane (at the face centre), atan(1/16) = 3.58
# degrees, half its diagonal 2.53 degrees: 3.0 degrees in all. A face swapped or flipped puts
# the brightest texel tens of degrees away.
checks=$((checks + 1))
python3 - <<'PY' || fail "the sun's texel in specular.ktx2"
import math, struct
s = 32
data = open("b_ktx/specular.ktx2.level0.bin", "rb").read()
v = struct.unpack("<%de" % (len(data) // 2), data)
def direction(f, i, j):  # texel centre -> direction, inverting OpenGL's cube face table
    sc, tc = 2 * (i + 0.5) / s - 1, 2 * (j + 0.5) / s - 1
    d = [(1, -tc, -sc), (-1, -tc, sc), (sc, 1, tc), (sc, -1, -tc), (sc, -tc, 1), (-sc, -tc, -1)][f]
    n = math.sqrt(sum(x * x for x in d))
    return [x / n for x in d]
best = max(range(6 * s * s), key=lambda t: sum(v[4 * t:4 * t + 3]))
f, j, i = best // (s * s), best % (s * s) // s, best % s
d = direction(f, i, j)
sun = (math.cos(math.radians(35)), math.sin(math.radians(35)), 0.0)
angle = math.degrees(math.acos(min(1, sum(a * b for a, b in zip(d, sun)))))
print("brightest texel: face %d (%d, %d), %.2f degrees from the sun" % (f, i, j, angle))
assert angle <= 3.0, angle
PY

# OpenGL's cube sampling of a linear map (cli_gl_cube.sh's map and tolerance; plus the half
# rounding, 2^-11 of the value).
PYTHONPATH="$here" python3 -c 'import gl_cube; gl_cube.write_linear_pfm("linear.pfm")'
run "$ENVLIGHT" prefilter linear.pfm -o lin --specular --roughness 0 --format ktx2 --size 32 \
    --no-error
consumer lin/specular.ktx2 97 32 1
checks=$((checks + 1))
PYTHONPATH="$here" python3 - <<'PY' || fail "the KTX2 cube faces sampled as OpenGL does"
import struct
import gl_cube
N = 32
data = open("lin/specular.ktx2.level0.bin", "rb").read()
v = struct.unpack("<%de" % (len(data) // 2), data)
faces = {n: (N, [[v[4 * ((f * N + j) * N + i)] for i in range(N)] for j in range(N)])
         for f, n in enumerate(gl_cube.FACES)}
worst = gl_cube.worst_linear(faces, rounding=2.0 ** -11)
print("KTX2 cube faces: worst difference %.2f of the tolerance inside, %.2f at the edges" %
      tuple(worst))
assert max(worst) <= 1, worst
PY

# Beyond the half range: a uniform map of 1e5 (above 65504) is written as 65504 everywhere,
# never inf, and prefilter.json counts every such value: 3 x 6 x (4^2 + 2^2 + 1) in the chain,
# 3 x 6 x 4^2 in the irradiance map (pi 1e5).
python3 -c 'import struct,sys; sys.stdout.buffer.write(b"PF\n16 8\n-1.0\n" + struct.pack("<384f", *[1e5] * 384))' > big.pfm
run "$ENVLIGHT" prefilter big.pfm -o big --format ktx2 --size 4 --levels 3 --irradiance-size 4 \
    --min-size 2 --no-error
consumer big/specular.ktx2 97 4 3
consumer big/irradiance.ktx2 97 4 1
checks=$((checks + 1))
python3 - <<'PY' || fail "values above the half range"
import json, struct
m = json.load(open("big/prefilter.json"))
assert m["specular_ktx2"]["clamped_values"] == 3 * 6 * (16 + 4 + 1), m["specular_ktx2"]
assert m["irradiance"]["clamped_values"] == 3 * 6 * 16, m["irradiance"]
for f, n in (("specular", 3), ("irradiance", 1)):
    for k in range(n):
        d = open("big/%s.ktx2.level%d.bin" % (f, k), "rb").read()
        v = struct.unpack("<%dH" % (len(d) // 2), d)
        assert all(h == (0x3C00 if i % 4 == 3 else 0x7BFF) for i, h in enumerate(v)), (f, k)
PY

# The format alone implies --layout cube --frame gltf: the same files as with them.
run "$ENVLIGHT" prefilter - -o imp1 --format ktx2 --size 8 --levels 4 --no-error
run "$ENVLIGHT" prefilter - -o imp2 --format ktx2 --size 8 --levels 4 --no-error \
    --layout cube --frame gltf
for f in specular.ktx2 irradiance.ktx2; do
  checks=$((checks + 1)); cmp -s imp1/$f imp2/$f || fail "$f differs with --layout cube --frame gltf"
done
has imp1/prefilter.json '"frame": "gltf-y-up"'
has imp1/prefilter.json '"layout": "cube"'

# Refusals: bad usage (exit 2), a message naming the cause, no folder made.
usage "$ENVLIGHT" prefilter - -o r1 --format ktx2 --frame blender
has err.txt "glTF frame"
usage "$ENVLIGHT" prefilter - -o r2 --format ktx2 --layout latlong
has err.txt "writes cube maps"
usage "$ENVLIGHT" prefilter - -o r3 --format ktx2-float --layout cross
has err.txt "writes cube maps"
usage "$ENVLIGHT" prefilter - -o r4 --format ktx2 --size 8 --levels 5
has err.txt "5 specular levels do not fit the mip chain of 8-texel cube faces (at most 4"
usage "$ENVLIGHT" prefilter - -o r5 --format ktx2 --size 8 --roughness 0,0.2,0.4,0.6,0.8
has err.txt "give --levels 4 or less"
checks=$((checks + 1))
for d in r1 r2 r3 r4 r5; do [ ! -e $d ] || fail "$d was created"; done
finish
