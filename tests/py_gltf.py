"""envlight gltf, checked by real consumers: the Khronos glTF validator (npm gltf-validator),
Babylon.js's own code for what it renders from irradianceCoefficients (npm @babylonjs/core;
tests/npm/babylon_sh.mjs), and an independent decode of the file here (GLB chunks, PNG through
zlib, RGBD by the extension's formula) against the products envlight writes as floats.

Expectations and their tolerances:
  * the validator: no error, no warning; its only notes are that it cannot check
    EXT_lights_image_based and so sees the images that extension references as unused;
  * the faces: specularImages[k][f], decoded (rgb = (png.rgb / 255)^2.2 / (png.a / 255), times
    the light's intensity), equals `envlight prefilter --frame gltf --layout cube --format pfm`'s
    face SLOT[f] of level k of the same residual map (+Y and -Y swapped) turned half a turn:
    OpenGL's face f of the frame (x, -y, z), mirrored left to right (the extension's "flipped
    about its vertical axis"), which is what Babylon.js renders right in its default
    left-handed scene (tests/py_gltf_babylon.py), within RGBD's quantisation: a byte y = round(255 (v D)^(1/2.2))
    is within 0.5 / 255 of its value, so the decoded v is within 2.2 (y + 0.5/255)^1.2 (0.5/255)
    / D (the derivative of y^2.2), plus float32 rounding (2^-22 relative);
  * the SH: Babylon's result pi x (E / pi) at its world normal n equals `envlight sh --order 2
    --frame gltf` of the same residual, evaluated here in docs/design.md's basis at glTF's
    (-n_x, n_y, n_z) (its default left-handed scene's frame; tests/py_gltf_babylon.py renders
    it), to 1e-8 of the terms' magnitudes (the file's 9 significant digits);
  * the lights: each node's rotation takes -Z (where a glTF directional light shines) to -d, d
    the sun's direction from `envlight lights --method sun --frame gltf`, to 1e-8; colour x
    intensity = its rgb (1 - w / 4 pi), w its solid angle (envl_light_over_residual).
"""
import json
import math
import os
import struct
import subprocess
import zlib

import numpy as np
import pytest

ENVLIGHT = os.environ.get("ENVLIGHT", "")
SOURCE = os.environ.get("ENVL_SOURCE_DIR", os.path.join(os.path.dirname(__file__), ".."))
DATA = os.environ.get("ENVL_SHARED_DATA", os.path.join(SOURCE, "..", "shared", "data"))
TMP = os.environ.get("ENVL_TEST_TMP", "/tmp/envl_py_gltf")
MODULES = os.environ.get("ENVL_NODE_MODULES", "")
NPM = os.path.join(SOURCE, "tests", "npm")

pytestmark = pytest.mark.skipif(
    not ENVLIGHT or not MODULES or not os.path.isdir(MODULES),
    reason="needs ENVLIGHT and ENVL_NODE_MODULES (scripts/npm_tools.sh: the glTF validator and "
           "Babylon.js from npm)")

SIZE, MIPS = 32, 3  # faces 32, 16, 8: small and quick
SLOT = [0, 1, 3, 2, 4, 5]  # specularImages[k][f] comes from prefilter's GL face SLOT[f]


def run(*args, check=True):
    r = subprocess.run([ENVLIGHT, *args], capture_output=True, text=True)
    if check:
        assert r.returncode == 0, r.stderr
    return r


def node(script, *args, stdin=None):
    r = subprocess.run(["node", os.path.join(NPM, script), *args], input=stdin,
                       capture_output=True, text=True, env={**os.environ, "ENVL_NODE_MODULES": MODULES})
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def path(name):
    os.makedirs(TMP, exist_ok=True)
    return os.path.join(TMP, name)


# ---- readers ----

def read_glb(p):
    data = open(p, "rb").read()
    magic, version, length = struct.unpack_from("<III", data, 0)
    assert (magic, version, length) == (0x46546C67, 2, len(data))
    jlen, jtype = struct.unpack_from("<II", data, 12)
    assert jtype == 0x4E4F534A and jlen % 4 == 0
    doc = json.loads(data[20:20 + jlen])
    blen, btype = struct.unpack_from("<II", data, 20 + jlen)
    assert btype == 0x004E4942 and 28 + jlen + blen == len(data)
    return doc, data[28 + jlen:]


def image_bytes(doc, binary, i):
    img = doc["images"][i]
    if "uri" in img:
        head = "data:image/png;base64,"
        assert img["uri"].startswith(head)
        import base64
        return base64.b64decode(img["uri"][len(head):])
    view = doc["bufferViews"][img["bufferView"]]
    assert img["mimeType"] == "image/png"
    return binary[view["byteOffset"]:view["byteOffset"] + view["byteLength"]]


def decode_png_rgba8(data):
    """8-bit RGBA, non-interlaced (what the extension's RGBD faces are): PNG spec, filters 0-4."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, chunks = 8, b"", []
    while pos < len(data):
        n, kind = struct.unpack_from(">I4s", data, pos)
        body = data[pos + 8:pos + 8 + n]
        chunks.append(kind)
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert (depth, ctype, interlace) == (8, 6, 0)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    assert not {b"gAMA", b"sRGB", b"iCCP", b"cHRM"} & set(chunks), "RGBD bytes carry no colour"
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + 4 * w)
    out = np.zeros((h, 4 * w), np.int32)
    for r in range(h):
        f, line = raw[r, 0], raw[r, 1:].astype(np.int32)
        prev = out[r - 1] if r else np.zeros(4 * w, np.int32)
        cur = np.zeros(4 * w, np.int32)
        for i in range(4 * w):
            a = cur[i - 4] if i >= 4 else 0
            c = prev[i - 4] if i >= 4 else 0
            b = prev[i]
            if f == 0:
                pred = 0
            elif f == 1:
                pred = a
            elif f == 2:
                pred = b
            elif f == 3:
                pred = (a + b) // 2
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else b if pb <= pc else c
            cur[i] = (line[i] + pred) & 255
        out[r] = cur
    return out.reshape(h, w, 4)


def read_pfm(p):
    data = open(p, "rb").read()
    parts = data.split(b"\n", 3)
    assert parts[0] == b"PF"
    w, h = map(int, parts[1].split())
    scale = float(parts[2])
    px = np.frombuffer(parts[3], "<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return px[::-1].astype(np.float64)  # PFM rows go bottom to top


# ---- the exports, made once ----

@pytest.fixture(scope="module")
def sky():
    glb, gltf = path("sky.glb"), path("sky.gltf")
    out = run("gltf", "-", "-o", glb, "--size", str(SIZE), "--mips", str(MIPS)).stdout
    run("gltf", "-", "-o", gltf, "--size", str(SIZE), "--mips", str(MIPS))
    residual = path("sky_residual.pfm")
    lights = json.loads(run("lights", "-", "--method", "sun", "--frame", "gltf", "--json",
                            "--residual", residual).stdout)
    return {"glb": glb, "gltf": gltf, "summary": out, "residual": residual, "lights": lights}


def test_the_validator_finds_no_error_nor_warning(sky):
    for p, images in ((sky["glb"], "buffer-view"), (sky["gltf"], "data-uri")):
        report = node("gltf_validate.mjs", p)
        issues = report["issues"]
        assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
        doc = read_glb(p)[0] if p.endswith(".glb") else json.load(open(p))
        ext = doc["extensionsUsed"].index("EXT_lights_image_based")
        for m in issues["messages"]:
            assert (m["code"], m["pointer"]) == ("UNSUPPORTED_EXTENSION", f"/extensionsUsed/{ext}") \
                or (m["code"] == "UNUSED_OBJECT" and m["pointer"].startswith("/images/")), m
        assert set(report["info"]["extensionsUsed"]) == {"KHR_lights_punctual",
                                                         "EXT_lights_image_based"}
        pngs = [r for r in report["info"]["resources"] if r["pointer"].startswith("/images/")]
        assert len(pngs) == 6 * MIPS
        for r in pngs:
            k = int(r["pointer"].split("/")[2]) // 6
            assert r["storage"] == images and r["mimeType"] == "image/png"
            assert (r["image"]["width"], r["image"]["height"]) == (SIZE >> k, SIZE >> k)
            assert (r["image"]["format"], r["image"]["bits"]) == ("rgba", 8)


def test_the_image_based_light_is_what_the_extension_defines(sky):
    doc, _ = read_glb(sky["glb"])
    (light,) = doc["extensions"]["EXT_lights_image_based"]["lights"]
    assert doc["scenes"][doc["scene"]]["extensions"]["EXT_lights_image_based"] == {"light": 0}
    assert light["specularImageSize"] == SIZE and light["rotation"] == [0, 0, 0, 1]
    assert light["intensity"] > 0  # Babylon multiplies by it: written, never left out
    c = np.array(light["irradianceCoefficients"])
    assert c.shape == (9, 3) and np.all(np.isfinite(c))
    faces = np.array(light["specularImages"])
    assert faces.shape == (MIPS, 6)
    assert sorted(faces.ravel().tolist()) == list(range(6 * MIPS)) == list(range(len(doc["images"])))
    assert json.load(open(sky["gltf"]))["extensions"]["EXT_lights_image_based"]["lights"][0][
        "irradianceCoefficients"] == light["irradianceCoefficients"]


def test_the_faces_decode_to_the_prefiltered_chain(sky):
    """Every texel of every face of every mip, in .glb and .gltf."""
    folder = path("chain")
    run("prefilter", sky["residual"], "-o", folder, "--frame", "gltf", "--layout", "cube",
        "--format", "pfm", "--specular", "--size", str(SIZE), "--levels", str(MIPS),
        "--min-size", str(4 * (SIZE >> (MIPS - 1))), "--no-error")
    side = json.load(open(os.path.join(folder, "prefilter.json")))
    assert side["frame"] == "gltf-y-up"
    for p in (sky["glb"], sky["gltf"]):
        doc, binary = read_glb(p) if p.endswith(".glb") else (json.load(open(p)), b"")
        light = doc["extensions"]["EXT_lights_image_based"]["lights"][0]
        s = light["intensity"]
        for k in range(MIPS):
            level = side["specular"][k]
            assert level["roughness"] == pytest.approx(k / (MIPS - 1), abs=1e-12)
            assert doc["asset"]["extras"]["mip_roughness"][k] == pytest.approx(level["roughness"])
            for f in range(6):
                # glTF's GL face f turned half a turn, +Y and -Y swapped (Babylon's frame)
                want = read_pfm(os.path.join(folder, level["files"][SLOT[f]]))[::-1, ::-1]
                px = decode_png_rgba8(image_bytes(doc, binary, light["specularImages"][k][f]))
                n = SIZE >> k
                assert want.shape == (n, n, 3) and px.shape == (n, n, 4)
                d = px[..., 3:4] / 255.0
                y = px[..., :3] / 255.0
                got = y ** 2.2 / d * s
                bound = 2.2 * np.minimum(y + 0.5 / 255, 1) ** 1.2 * (0.5 / 255) / d * s \
                    + 2.0 ** -22 * np.abs(want) + 1e-30
                excess = np.abs(got - want) / bound
                assert excess.max() <= 1, (p, k, f, excess.max())


def sh_irradiance(coeffs, d):
    """docs/design.md's basis (Ramamoorthi & Hanrahan 2001, no Condon-Shortley phase)."""
    x, y, z = d
    k0, k1, k2 = math.sqrt(1 / (4 * math.pi)), math.sqrt(3 / (4 * math.pi)), math.sqrt(15 / (4 * math.pi))
    k20, k22 = math.sqrt(5 / (16 * math.pi)), math.sqrt(15 / (16 * math.pi))
    basis = [k0, k1 * y, k1 * z, k1 * x, k2 * x * y, k2 * y * z, k20 * (3 * z * z - 1),
             k2 * x * z, k22 * (x * x - y * y)]
    return np.array(basis) @ np.array(coeffs), np.abs(np.array(basis)) @ np.abs(np.array(coeffs))


def directions(n=64):
    g = (1 + 5 ** 0.5) / 2
    out = []
    for i in range(n):
        z = 1 - (2 * i + 1) / n
        r = math.sqrt(1 - z * z)
        out.append([r * math.cos(2 * math.pi * i / g), r * math.sin(2 * math.pi * i / g), z])
    return out


def check_sh_through_babylon(glb, reference_map):
    doc, _ = read_glb(glb)
    light = doc["extensions"]["EXT_lights_image_based"]["lights"][0]
    ref = json.loads(run("sh", reference_map, "--order", "2", "--frame", "gltf", "--json").stdout)
    dirs = directions()
    got = node("babylon_sh.mjs", stdin=json.dumps({
        "coefficients": light["irradianceCoefficients"], "intensity": light["intensity"],
        "directions": dirs}))
    assert "vSphericalL1_1*(normal.y)" in got["expression"]
    for d, lambert in zip(dirs, got["radiance"]):
        # d is Babylon's world normal: glTF's (-x, y, z) in its default left-handed scene
        e, magnitude = sh_irradiance(ref["irradiance"], [-d[0], d[1], d[2]])
        assert np.all(np.abs(math.pi * np.array(lambert) - e) <= 1e-8 * magnitude + 1e-300), d


def test_babylon_renders_the_residuals_sh_irradiance(sky):
    check_sh_through_babylon(sky["glb"], sky["residual"])


def test_the_lights_are_the_suns(sky):
    doc, _ = read_glb(sky["glb"])
    suns = sky["lights"]["lights"]
    assert len(suns) >= 1
    lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
    assert len(lights) == len(suns) == len(doc["nodes"]) == len(doc["scenes"][0]["nodes"])
    for node_, sun in zip(doc["nodes"], suns):
        light = lights[node_["extensions"]["KHR_lights_punctual"]["light"]]
        assert light["type"] == "directional"
        assert max(light["color"]) == pytest.approx(1, abs=1e-8)
        # the light over the residual the IBL holds (envl_light_over_residual): a sun's take is
        # the sun itself (take_direction = direction), its disc of solid angle w delivering
        # rgb (1 - w / 4 pi) at normal incidence
        assert sun["take_direction"] == sun["direction"]
        keep = 1 - sun["take_solid_angle"] / (4 * np.pi)
        assert np.allclose(np.array(light["color"]) * light["intensity"],
                           np.array(sun["rgb"]) * keep, rtol=1e-8)
        qx, qy, qz, qw = node_["rotation"]
        assert qx * qx + qy * qy + qz * qz + qw * qw == pytest.approx(1, abs=1e-8)
        # the rotated -Z: R v for v = (0, 0, -1)
        rz = -np.array([2 * (qx * qz + qw * qy), 2 * (qy * qz - qw * qx), 1 - 2 * (qx * qx + qy * qy)])
        assert np.allclose(rz, -np.array(sun["direction"]), atol=1e-8), (rz, sun["direction"])


def test_the_summary_states_errors_and_time(sky):
    lines = sky["summary"].splitlines()
    assert " s" in lines[0] and "bytes" in lines[0]
    assert any(l.startswith("diffuse") and "diffuse error" in l and "%" in l for l in lines)
    assert sum(l.startswith("mip ") and "glossy error" in l for l in lines) == MIPS


def test_no_lights_puts_the_whole_map_in_the_environment():
    glb = path("none.glb")
    run("gltf", "-", "-o", glb, "--size", "16", "--mips", "2", "--lights", "none")
    doc, _ = read_glb(glb)
    assert doc["extensionsUsed"] == ["EXT_lights_image_based"] and "nodes" not in doc
    check_sh_through_babylon(glb, "-")


def write_pfm(p, rgb):
    """rgb: (H, W, 3), row 0 at the top."""
    h, w, _ = rgb.shape
    with open(p, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(np.ascontiguousarray(rgb[::-1], dtype="<f4").tobytes())


def test_without_a_punctual_light_the_file_is_valid():
    """Issue 30, 4.2: no light (--lights none, or a map without a sun under the default
    --lights sun) made scenes[0].nodes an empty array, an error (EMPTY_ENTITY) for the
    validator; the scene then has no "nodes" at all (glTF 2.0: optional, at least one item
    when present)."""
    overcast = path("overcast.pfm")  # a soft sky with no sun: 2 at the zenith, 0.5 below
    rows = np.linspace(2.0, 0.5, 32)[:, None, None] * np.ones((32, 64, 3))
    write_pfm(overcast, rows)
    for name, args in (("none_lights.glb", ["-", "--lights", "none"]),
                       ("none_lights.gltf", ["-", "--lights", "none"]),
                       ("no_sun.glb", [overcast])):
        out = path(name)
        r = run("gltf", *args, "-o", out, "--size", "16", "--mips", "2")
        assert "lights       0 directional" in r.stdout
        doc = read_glb(out)[0] if out.endswith(".glb") else json.load(open(out))
        assert "nodes" not in doc["scenes"][0] and "nodes" not in doc, doc["scenes"]
        report = node("gltf_validate.mjs", out)
        issues = report["issues"]
        assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]


def test_a_real_map():
    hdr = os.path.join(DATA, "latlong_hdri", "rooitou_park_1k.hdr")
    if not os.path.exists(hdr):
        pytest.skip(f"SKIP: {hdr} absent (../shared/data)")
    glb, residual = path("rooitou.glb"), path("rooitou_residual.pfm")
    run("gltf", hdr, "-o", glb, "--size", "32", "--mips", "3")
    run("lights", hdr, "--method", "sun", "--residual", residual)
    report = node("gltf_validate.mjs", glb)
    assert report["issues"]["numErrors"] == 0 and report["issues"]["numWarnings"] == 0
    check_sh_through_babylon(glb, residual)


def test_bad_requests_are_refused_and_leave_the_file():
    glb = path("kept.glb")
    run("gltf", "-", "-o", glb, "--size", "16", "--mips", "2")
    before = open(glb, "rb").read()
    for args, code, says in (
            (["-o", path("x.obj")], 2, ".glb or .gltf"),
            (["-o", glb, "--size", "48"], 2, "power of two"),
            (["-o", glb, "--size", "16", "--mips", "6"], 2, "mips"),
            (["-o", glb, "--lights", "fit", "-n", "33"], 2, "1..32"),
            (["/nonexistent/map.hdr", "-o", glb], 1, "/nonexistent/map.hdr")):
        r = run("gltf", *(args if args[0].startswith("/") else ["-", *args]), check=False)
        assert r.returncode == code and says in r.stderr, (args, r.returncode, r.stderr)
        assert open(glb, "rb").read() == before
