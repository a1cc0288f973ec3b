"""envlight gltf as Babylon.js (the EXT_lights_image_based reference implementation) RENDERS it:
Babylon's UMD bundles (npm babylonjs, babylonjs-loaders) in Debian's headless Chromium on
SwiftShader's WebGL 2, driven by tests/npm/babylon_render.html, which posts its measures back to
a server on 127.0.0.1 here.

The built-in sky with its sun in a generic direction (azimuth 60, elevation 35 degrees: any
single-axis mirror or swapped face pair moves it) is exported twice, with the sun as a
KHR_lights_punctual light (sun.glb) and with it inside the image-based light (--lights none,
env.glb). In Babylon's default left-handed scene (its sandbox's), where the loader's __root__
node maps glTF's (x, y, z) to (-x, y, z):
  * the sun in the skybox of mip 0 (createDefaultSkybox(env, true, 1000, 0)) lies where the
    light comes from (-its world direction as Babylon computes it) within 1 degree (the view:
    0.3 degrees a pixel; mip 0 of 64 pixels: 1.4 degrees a texel);
  * the glint on a mirror sphere (PBR, metal, roughness 0) seen from the sun's side is at the
    view's centre within 2 pixels and reflects the sun's direction within 1 degree.
In a right-handed scene (scene.useRightHandedSystem) Babylon's loader leaves glTF's frame as
is, but its shaders negate z of every cube lookup (REFLECTIONMAP_OPPOSITEZ): the environment
shows turned half a turn about +Y, the sun at (-x, y, -z) of the light's; this test records
that (Babylon's behaviour, not the file's: no file is right in both scenes).
The SH irradiance: a white diffuse sphere lit by env.glb alone, its centre pixel seen from the
sun's side, is brighter than seen from that side mirrored in x, in y or in z (left-handed); in
the right-handed scene the brightest of those five views is the sun's turned half a turn about
+Y, as the sky.
"""
import http.server
import json
import math
import os
import shutil
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

ENVLIGHT = os.environ.get("ENVLIGHT", "")
SOURCE = os.environ.get("ENVL_SOURCE_DIR", os.path.join(os.path.dirname(__file__), ".."))
TMP = os.environ.get("ENVL_TEST_TMP", "/tmp/envl_py_gltf_babylon")
MODULES = os.environ.get("ENVL_NODE_MODULES", "")
PAGE = os.path.join(SOURCE, "tests", "npm", "babylon_render.html")
CHROMIUM = shutil.which("chromium")
BUNDLES = [("babylonjs", "babylon.js"), ("babylonjs-loaders", "babylonjs.loaders.min.js")]


def skip_reason():
    if not ENVLIGHT:
        return "SKIP: ENVLIGHT is not set"
    if not CHROMIUM:
        return "SKIP: no chromium (Debian's chromium package: scripts/build.sh installs it)"
    if not MODULES or not all(os.path.isfile(os.path.join(MODULES, *b)) for b in BUNDLES):
        return "SKIP: Babylon.js's UMD bundles are absent (ENVL_NODE_MODULES from scripts/npm_tools.sh)"
    return None


pytestmark = pytest.mark.skipif(skip_reason() is not None, reason=str(skip_reason()))


def angle(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    c = a @ b / np.linalg.norm(a) / np.linalg.norm(b)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def render(www, timeout=90):
    """Serve www on 127.0.0.1, open the page in headless Chromium, return what it posts."""
    posted, done = {}, threading.Event()

    class Handler(http.server.SimpleHTTPRequestHandler):
        def __init__(self, *a, **k):
            super().__init__(*a, directory=www, **k)

        def log_message(self, *a):
            pass

        def do_POST(self):
            posted["body"] = self.rfile.read(int(self.headers["Content-Length"]))
            self.send_response(204)
            self.end_headers()
            done.set()

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    profile = os.path.join(www, "profile")
    shutil.rmtree(profile, ignore_errors=True)
    log = open(os.path.join(www, "chromium.log"), "w")
    proc = subprocess.Popen(
        [CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
         "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-quic",
         f"--user-data-dir={profile}", "--window-size=200,200",
         f"http://127.0.0.1:{server.server_address[1]}/index.html"],
        stdout=subprocess.DEVNULL, stderr=log, start_new_session=True)
    try:
        finished = done.wait(timeout)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        proc.wait(10)
        server.shutdown()
        log.close()
    assert finished, f"the page posted nothing in {timeout} s (see {www}/chromium.log)"
    result = json.loads(posted["body"])
    assert "error" not in result, result["error"]
    return result


@pytest.fixture(scope="module")
def seen():
    www = os.path.join(TMP, "www")
    os.makedirs(www, exist_ok=True)
    sky = ["-", "--sun-azimuth", "60", "--sun-elevation", "35", "--size", "64"]
    for name, extra in (("sun.glb", []), ("env.glb", ["--lights", "none"])):
        r = subprocess.run([ENVLIGHT, "gltf", *sky, *extra, "-o", os.path.join(www, name)],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
    for package, bundle in BUNDLES:
        shutil.copy(os.path.join(MODULES, package, bundle), www)
    shutil.copy(PAGE, os.path.join(www, "index.html"))
    start = time.time()
    result = render(www)
    result["seconds"] = time.time() - start
    with open(os.path.join(TMP, "seen.json"), "w") as f:
        json.dump(result, f, indent=1)
    return result


@pytest.mark.parametrize("scene", ["lh", "rh"])
def test_the_readback_and_picking_agree(seen, scene):
    probe = seen[scene]["probe"]
    assert angle(probe["box"], probe["seen"]) < 1, probe


def test_the_light_is_the_suns_in_babylons_frame(seen):
    # glTF: the sun at azimuth 60, elevation 35 of the canonical frame, (x, z, -y) there
    az, el = math.radians(60), math.radians(35)
    d = np.array([math.cos(el) * math.cos(az), math.sin(el), -math.cos(el) * math.sin(az)])
    assert seen["lh"]["light"]["root"] == [1, 1, -1]  # the loader's __root__: z scaled by -1
    # (envlight's sun is its pixels' centroid: within 0.01 degree of the sky's parameter)
    assert angle(-np.array(seen["lh"]["light"]["direction"]), d * [-1, 1, 1]) < 0.05
    assert angle(-np.array(seen["rh"]["light"]["direction"]), d) < 0.05


def test_left_handed_the_sky_shows_the_sun_where_the_light_comes_from(seen):
    s = seen["lh"]
    sun = -np.array(s["light"]["direction"])
    assert angle(s["skybox"]["direction"], sun) < 1, (s["skybox"], sun)


def test_left_handed_the_mirror_glint_reflects_the_sun(seen):
    s = seen["lh"]
    sun = -np.array(s["light"]["direction"])
    m = s["mirror"]
    assert abs(m["x"] - m["centre"]) <= 2 and abs(m["y"] - m["centre"]) <= 2, m
    assert angle(m["reflected"], sun) < 1, (m, sun)


def test_right_handed_babylon_turns_the_environment_half_a_turn_about_y(seen):
    s = seen["rh"]
    sun = -np.array(s["light"]["direction"])
    assert angle(s["skybox"]["direction"], sun * [-1, 1, -1]) < 1, (s["skybox"], sun)
    # the glint then lies near the sphere's rim, where the reflection turns fast: 5 degrees
    assert angle(s["mirror"]["reflected"], sun * [-1, 1, -1]) < 5, (s["mirror"], sun)


def test_left_handed_the_diffuse_sphere_is_brightest_facing_the_sun(seen):
    d = seen["lh"]["diffuse"]
    assert all(d["sun"] > d[k] for k in ("mirror_x", "mirror_y", "mirror_z", "turned_y")), d


def test_right_handed_the_diffuse_sphere_turns_with_the_sky(seen):
    d = seen["rh"]["diffuse"]
    assert all(d["turned_y"] > d[k] for k in ("sun", "mirror_x", "mirror_y", "mirror_z")), d


def test_it_is_quick(seen):
    assert seen["seconds"] < 60
