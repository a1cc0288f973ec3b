"""The ctypes shim refuses what it cannot pass to C faithfully (issue 19, item 5): every public
function and method, every integer / float / path / name / enum argument. Each refusal is
checked for its exact exception type (envlight.ArgumentError: a ValueError and an envlight.Error
ENVL_ERR_ARGUMENT; TypeError for a wrong type) and for a message that names the function and
the argument. The limits the shim mirrors are checked against the library itself.

Run by ctest as `python3 -m pytest -q tests/py_shim_arguments.py` (tests/CMakeLists.txt gives
ENVLIGHT_LIBRARY, PYTHONPATH, ENVL_TEST_TMP)."""
import ctypes
import os
import signal
from ctypes import byref, c_float, c_int32, c_void_p

import pytest

np = pytest.importorskip("numpy", reason="SKIP: numpy is not installed (python3-numpy)")
import envlight  # noqa: E402
from envlight import _lib  # noqa: E402

TMP = os.environ.get("ENVL_TEST_TMP") or os.path.join(os.path.dirname(__file__), "..", "build",
                                                      "tmp", "py_shim_arguments")
os.makedirs(TMP, exist_ok=True)

#: None before the shim had it: every refusal test then fails on the type
ARG = getattr(envlight, "ArgumentError", None)
BIG = 2 ** 32          # wraps to 0 in an int32_t: 2**32 + k reaches C as k
NAN, INF = float("nan"), float("inf")
SECONDS = 30           # a refusal is immediate; the unchecked shim may loop for hours


class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout("no answer within %d s" % SECONDS)


@pytest.fixture(scope="module")
def hdr():
    path = os.path.join(TMP, "small.hdr")
    img = np.full((16, 32, 3), 0.25, np.float32)
    img[4, 10] = (50.0, 40.0, 30.0)
    envlight.save_image(path, img)
    return path


@pytest.fixture(scope="module")
def env():
    with envlight.sky(width=64) as m:
        yield m


@pytest.fixture(scope="module")
def lights(env):
    with env.lights(2, method="median") as res:
        yield res


@pytest.fixture(scope="module")
def sh(env):
    with env.sh(2) as s:
        yield s


@pytest.fixture(scope="module")
def products(env):
    with env.prefilter(roughness=[0.5], width=16, min_width=8, samples=4) as p:
        yield p


def refused(call, kind, what):
    """call() raises exactly `kind` (ARG or TypeError) and its message starts with `what`
    ("function: argument")."""
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, SECONDS)
    try:
        call()
    except _Timeout:
        pytest.fail("%s: still running after %d s instead of refusing" % (what, SECONDS))
    except Exception as e:  # noqa: BLE001 - the type is the point
        assert kind is not None, "the shim has no ArgumentError (got %r)" % e
        assert type(e) is kind, "%s: %s raised, %s expected: %s" % (
            what, type(e).__name__, kind.__name__, e)
        text = e.message if kind is ARG else str(e)
        assert text.startswith((what + " ", what + ":", unknown(what) + " ")), (what, text)
        if kind is ARG:
            assert isinstance(e, ValueError) and isinstance(e, envlight.Error)
            assert e.code == 1 and e.name == "ENVL_ERR_ARGUMENT"
            assert str(e) == "ENVL_ERR_ARGUMENT: " + e.message
        return e
    else:
        pytest.fail("%s: accepted" % what)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def unknown(what):
    """The enum message: 'function: unknown argument VALUE (names)'."""
    func, _, arg = what.rpartition(": ")
    return "%s: unknown %s" % (func, arg)


# ---- module functions ---------------------------------------------------------------------

LOAD = [
    ("path", dict(path="x\0.hdr"), ARG),
    ("path", dict(path=b"x\0.hdr"), ARG),
    ("path", dict(path=""), ARG),
    ("path", dict(path=7), TypeError),
    ("width", dict(width=0), ARG),
    ("width", dict(width=-1), ARG),
    ("width", dict(width=BIG + 16), ARG),
    ("width", dict(width=16.0), TypeError),
    ("width", dict(width=True), TypeError),
    ("max_pixels", dict(max_pixels=0), ARG),
    ("max_pixels", dict(max_pixels=-1), ARG),
    ("max_pixels", dict(max_pixels=2 ** 64 + 100), ARG),
    ("threads", dict(threads=0), ARG),
    ("threads", dict(threads=-1), ARG),
    ("threads", dict(threads=BIG + 1), ARG),
    ("rotate", dict(rotate=NAN), ARG),
    ("rotate", dict(rotate=INF), ARG),
    ("rotate", dict(rotate="90"), TypeError),
    ("layout", dict(layout=BIG + 1), ARG),
    ("layout", dict(layout="latlong\0x"), ARG),
    ("layout", dict(layout=True), TypeError),
    ("exr_part", dict(exr_part=""), ARG),
    ("exr_part", dict(exr_part="rgb\0x"), ARG),
    ("strict", dict(strict="no"), TypeError),
    ("apply_exposure", dict(apply_exposure=2), TypeError),
]


@pytest.mark.parametrize("arg,kw,kind", LOAD, ids=["%s=%r" % (a, kw) for a, kw, _ in LOAD])
def test_load_refuses(hdr, arg, kw, kind):
    kw = dict(kw)
    path = kw.pop("path", hdr)
    what = "load: " + arg
    e = refused(lambda: envlight.load(path, **kw), kind, what)
    if arg == "layout" and kind is ARG:
        assert e.message.startswith("load: unknown layout ")


SKY = [
    ("width", dict(width=BIG + 8), ARG),   # was a map 8 wide
    ("width", dict(width=-1), ARG),        # was the default 1024
    ("width", dict(width=0), ARG),
    ("width", dict(width=23171), ARG),     # 23171 x 11585 > 2^28 pixels
    ("width", dict(width=True), TypeError),
    ("sun_elevation", dict(sun_elevation=NAN), ARG),
    ("sun_elevation", dict(sun_elevation=90.5), ARG),
    ("sun_azimuth", dict(sun_azimuth=INF), ARG),
    ("sun_irradiance", dict(sun_irradiance=0.0), ARG),   # was the default 12
    ("sun_irradiance", dict(sun_irradiance=-5.0), ARG),
    ("sun_irradiance", dict(sun_irradiance=NAN), ARG),
    ("zenith_radiance", dict(zenith_radiance=0.0), ARG),
    ("zenith_radiance", dict(zenith_radiance=INF), ARG),
    ("ground_albedo", dict(ground_albedo=0.0), ARG),
    ("ground_albedo", dict(ground_albedo=1.5), ARG),
    ("ground_albedo", dict(ground_albedo="0.2"), TypeError),
]


@pytest.mark.parametrize("arg,kw,kind", SKY, ids=["%s=%r" % (a, kw) for a, kw, _ in SKY])
def test_sky_refuses(arg, kw, kind):
    refused(lambda: envlight.sky(**kw).close(), kind, "sky: " + arg)


PIX = np.zeros((2, 4, 3), np.float32)
FROM_PIXELS = [
    ("width", dict(width=BIG + 4, height=2, channels=3), ARG),
    ("width", dict(width=0, height=2, channels=3), ARG),
    ("height", dict(width=4, height=-2, channels=3), ARG),
    ("height", dict(width=4, height=2.0, channels=3), TypeError),
    ("channels", dict(width=4, height=2, channels=BIG + 3), ARG),
    ("map_width", dict(map_width=0), ARG),
    ("map_width", dict(map_width=-8), ARG),
    ("map_width", dict(map_width=BIG + 8), ARG),
    ("threads", dict(threads=0), ARG),
    ("rotate", dict(rotate=NAN), ARG),
    ("flip", dict(flip="yes"), TypeError),
    ("layout", dict(layout=BIG + 1), ARG),
]


@pytest.mark.parametrize("arg,kw,kind", FROM_PIXELS,
                         ids=["%s=%r" % (a, kw) for a, kw, _ in FROM_PIXELS])
def test_from_pixels_refuses(arg, kw, kind):
    buf = PIX if "channels" not in kw else PIX.tobytes()
    refused(lambda: envlight.from_pixels(buf, **kw).close(), kind, "from_pixels: " + arg)


def test_from_pixels_channels_checked_by_the_library_is_an_argument_error():
    e = refused(lambda: envlight.from_pixels(np.zeros((4, 8, 2), np.float32)), ARG,
                "envl_envmap_from_pixels")
    assert "2 channels (expected 1, 3 or 4)" in e.message


SAVE_IMAGE = [
    ("path", dict(path=os.path.join(TMP, "a\0.pfm")), ARG),
    ("path", dict(path=None), TypeError),
    ("width", dict(width=BIG + 4, height=2), ARG),
    ("height", dict(width=4, height=0), ARG),
    ("format", dict(format=""), ARG),
    ("format", dict(format="pfm\0"), ARG),
    ("format", dict(format=3), TypeError),
    ("half", dict(half="no"), TypeError),
]


@pytest.mark.parametrize("arg,kw,kind", SAVE_IMAGE,
                         ids=["%s=%r" % (a, kw) for a, kw, _ in SAVE_IMAGE])
def test_save_image_refuses(arg, kw, kind):
    kw = dict(kw)
    path = kw.pop("path", os.path.join(TMP, "out.pfm"))
    rgb = PIX if "width" not in kw else PIX.tobytes()
    refused(lambda: envlight.save_image(path, rgb, **kw), kind, "save_image: " + arg)


@pytest.mark.parametrize("n,kind", [(BIG + 3, ARG), (0, ARG), (-1, ARG), (2 ** 24 + 1, ARG),
                                    (True, TypeError), (4.0, TypeError)])
def test_fibonacci_directions_refuses(n, kind):
    refused(lambda: envlight.fibonacci_directions(n), kind, "fibonacci_directions: n")


@pytest.mark.parametrize("a,e,arg", [
    ([], [], "approx_rgb"),                            # the mean over no values
    ([(1, 1, 1)], [(1, 1, 1), (1, 1, 1)], "approx_rgb"),
    ([(NAN, 1, 1)], [(1, 1, 1)], "approx_rgb"),
    ([(1, 1, 1)], [(1, INF, 1)], "exact_rgb"),
    ([1, 1, 1, 1], [(1, 1, 1)], "approx_rgb"),         # not N x 3
    ([(1, 1), (1, 1, 1)], [(1, 1, 1)], "approx_rgb"),  # ragged
])
def test_relative_rms_luminance_refuses(a, e, arg):
    refused(lambda: envlight.relative_rms_luminance(a, e), ARG,
            "relative_rms_luminance: " + arg)


@pytest.mark.parametrize("order,direction,arg,kind", [
    (33, (0, 0, 1), "order", ARG),        # beyond the library's SH order 32
    (-1, (0, 0, 1), "order", ARG),
    (BIG + 2, (0, 0, 1), "order", ARG),   # reached C as order 2 with a 2^64-double buffer
    (2.0, (0, 0, 1), "order", TypeError),
    (2, (0, 1), "direction", ARG),        # the third component was read as 0
    (2, (0, 0, 1, 0), "direction", ARG),
    (2, (0, NAN, 1), "direction", ARG),
])
def test_sh_basis_refuses(order, direction, arg, kind):
    refused(lambda: envlight.sh_basis(order, direction), kind, "sh_basis: " + arg)


@pytest.mark.parametrize("l,kind", [(-2, ARG), (BIG + 2, ARG), (True, TypeError)])
def test_cosine_lobe_refuses(l, kind):
    refused(lambda: envlight.cosine_lobe(l), kind, "cosine_lobe: l")


BRDF_LUT = [
    ("size", dict(size=0), ARG), ("size", dict(size=-1), ARG), ("size", dict(size=4097), ARG),
    ("size", dict(size=BIG + 8), ARG), ("samples", dict(samples=0), ARG),
    ("samples", dict(samples=2 ** 24 + 1), ARG), ("threads", dict(threads=-1), ARG),
    ("threads", dict(threads=0), ARG), ("multiscatter", dict(multiscatter="yes"), TypeError),
]


@pytest.mark.parametrize("arg,kw,kind", BRDF_LUT, ids=["%s=%r" % (a, kw) for a, kw, _ in BRDF_LUT])
def test_brdf_lut_refuses(arg, kw, kind):
    refused(lambda: envlight.brdf_lut(**kw), kind, "brdf_lut: " + arg)


@pytest.mark.parametrize("args,arg,kind", [
    ((NAN, 0.5), "nov", ARG), ((1.5, 0.5), "nov", ARG), ((0.5, -0.1), "roughness", ARG),
    ((0.5, 0.5, 0), "samples", ARG), ((0.5, 0.5, -1), "samples", ARG),
    ((0.5, 0.5, BIG + 1), "samples", ARG), ((0.5, 0.5, 1.5), "samples", TypeError),
])
def test_brdf_eval_refuses(args, arg, kind):
    refused(lambda: envlight.brdf_eval(*args), kind, "brdf_eval: " + arg)


# ---- Envmap methods -------------------------------------------------------------------------

def test_envmap_pixel_arguments_refused(env):
    w, h = env.width, env.height
    for row in (-1, h, BIG):
        refused(lambda: env.solid_angle(row), ARG, "Envmap.solid_angle: row")
    for col, row, arg in ((w, 0, "column"), (-1, 0, "column"), (BIG, 0, "column"),
                          (0, h, "row"), (0, -1, "row")):
        refused(lambda: env.direction(col, row), ARG, "Envmap.direction: " + arg)
    refused(lambda: env.direction(1.0, 2), TypeError, "Envmap.direction: column")
    refused(lambda: env.pixel_of((0, NAN, 1)), ARG, "Envmap.pixel_of: direction")
    refused(lambda: env.pixel_of((0, 1)), ARG, "Envmap.pixel_of: direction")
    for first, end, arg in ((-1, None, "first_row"), (h + 1, None, "first_row"),
                            (BIG, None, "first_row"), (2, 1, "end_row"), (0, h + 1, "end_row")):
        refused(lambda: env.pixels(first, end), ARG, "Envmap.pixels: " + arg)
    refused(lambda: env.pixels(0.5), TypeError, "Envmap.pixels: first_row")
    # a band of rows is those rows of the whole copy (the pointer arithmetic: 3 floats a pixel)
    whole = env.pixels()
    assert np.array_equal(env.pixels(1, h - 1), whole[1:h - 1])
    assert np.array_equal(env.pixels(h - 1), whole[h - 1:]) and env.pixels(h).shape[0] == 0


def test_envmap_irradiance_refuses_bad_normals(env):
    for normals in ([(0, 0, NAN)], [(0, 0, 1, 0)], [("a", "b", "c")]):
        kind = TypeError if isinstance(normals[0][0], str) else ARG
        refused(lambda: env.irradiance(normals), kind, "Envmap.irradiance: normals")


def test_envmap_drop_caches_save_ground_plane_refused(env):
    for which in (4, -1, BIG + 1):
        refused(lambda: env.drop_caches(which), ARG, "Envmap.drop_caches: which")
    refused(lambda: env.save(os.path.join(TMP, "m\0.pfm")), ARG, "Envmap.save: path")
    refused(lambda: env.save(os.path.join(TMP, "m.pfm"), format=""), ARG, "Envmap.save: format")
    refused(lambda: env.save(os.path.join(TMP, "m.pfm"), half=None), TypeError,
            "Envmap.save: half")
    for albedo in (1.5, -0.1, NAN):
        # the library returns ENVL_ERR_ARGUMENT without a message of its own: checked here
        refused(lambda: env.ground_plane(albedo), ARG, "Envmap.ground_plane: albedo")


def test_envmap_to_layout_refuses(env):
    e = refused(lambda: env.to_layout("auto", 8), ARG, "Envmap.to_layout: layout")
    assert e.message.startswith("Envmap.to_layout: unknown layout 'auto'")
    refused(lambda: env.to_layout(BIG + 4, 8), ARG, "Envmap.to_layout: layout")
    for size in (0, -1, BIG + 8):
        refused(lambda: env.to_layout("cross", size), ARG, "Envmap.to_layout: size")



def test_envmap_to_layout_sides_beyond_32_bits(env):
    """Issue 30, 4.9: sizes 2^30 .. 2^31 - 1 pass the shim's int32 check; the library took the
    cross's 3 x size in 32 bits (signed overflow: a negative width, ENVL_ERR_FORMAT). A side
    that does not fit 32 bits is a bad argument; sides that fit but too many pixels, the size
    limit."""
    for layout in ("cross", "hcross", "hstrip", "vstrip", "exr-cube"):
        for size in (2 ** 30, 2 ** 31 - 1):
            with pytest.raises(envlight.ArgumentError, match="a side does not fit 32 bits"):
                env.to_layout(layout, size)
    for layout in ("latlong", "angular", "mirrorball", "exr-latlong", "cross"):
        with pytest.raises(envlight.Error) as e:
            env.to_layout(layout, 2 ** 20)
        assert e.value.name == "ENVL_ERR_LIMIT" and "more than the limit" in e.value.message


LIGHTS = [
    ("n", dict(n=BIG + 3, method="median"), ARG),   # gave 3 lights
    ("n", dict(n=0, method="median"), ARG),         # gave the default 16
    ("n", dict(n=-1, method="median"), ARG),
    ("n", dict(n=True, method="median"), TypeError),
    ("n", dict(n=33, method="fit"), ARG),
    ("n", dict(n=2 ** 24 + 1, method="median"), ARG),
    ("order", dict(n=2, method="fit", order=9), ARG),
    ("order", dict(n=2, method="fit", order=-1), ARG),
    ("order", dict(n=2, method="fit", order=BIG + 2), ARG),
    ("method", dict(n=2, method=BIG + 2), ARG),
    ("method", dict(n=2, method="fit\0"), ARG),
    ("method", dict(n=2, method=2.0), TypeError),
]


@pytest.mark.parametrize("arg,kw,kind", LIGHTS, ids=["%s=%r" % (a, kw) for a, kw, _ in LIGHTS])
def test_lights_refuses(env, arg, kw, kind):
    def call():
        env.lights(**kw).close()
    e = refused(call, kind, "Envmap.lights: " + arg)
    if arg == "method" and kind is ARG:
        assert e.message.startswith("Envmap.lights: unknown method")


@pytest.mark.parametrize("kw,arg,kind", [
    (dict(order=-1), "order", ARG),          # gave the default order 2
    (dict(order=33), "order", ARG),
    (dict(order=BIG + 2), "order", ARG),
    (dict(order=None), "order", TypeError),
    (dict(window=BIG + 1), "window", ARG),
    (dict(window="hann\0"), "window", ARG),
])
def test_sh_refuses(env, kw, arg, kind):
    refused(lambda: env.sh(**kw).close(), kind, "Envmap.sh: " + arg)


POV = [
    ("n", dict(n=0), ARG),                      # would be the recipe's default
    ("n", dict(n=BIG + 3), ARG),
    ("n", dict(n=True), TypeError),
    ("order", dict(order=9), ARG),
    ("order", dict(order=-2), ARG),
    ("ground", dict(ground=1.5), ARG),
    ("ground", dict(ground=NAN), ARG),
    ("recipe", dict(recipe="nope"), ARG),
    ("recipe", dict(recipe=BIG), ARG),
    ("method", dict(method="sun"), ARG),
    ("ambient", dict(ambient="nope"), ARG),
    ("shadows", dict(shadows=1), TypeError),
    ("exposure", dict(exposure=0), ARG),        # would be "not declared"
    ("exposure", dict(exposure="bright"), TypeError),
    ("scene_radius", dict(scene_radius=-1), ARG),
    ("scene", dict(scene=""), ARG),
    ("source", dict(source="a\0b"), ARG),
    ("path", dict(path="a\0b"), ARG),
]


@pytest.mark.parametrize("arg,kw,kind", POV, ids=["%s=%r" % (a, kw) for a, kw, _ in POV])
def test_pov_include_refuses(env, arg, kw, kind):
    refused(lambda: env.pov_include(**kw), kind, "Envmap.pov_include: " + arg)


PREFILTER = [
    ("sh_order", dict(diffuse=True, sh_order=-1), ARG),
    ("sh_order", dict(diffuse=True, sh_order=33), ARG),
    ("sh_order", dict(diffuse=True, sh_order=BIG + 1), ARG),
    ("brdf_size", dict(brdf=True, brdf_size=0), ARG),
    ("brdf_size", dict(brdf=True, brdf_size=BIG + 8), ARG),
    ("shadows", dict(shadows=-1), ARG),
    ("shadows", dict(shadows=True), TypeError),
    ("shadows", dict(shadows=BIG + 2), ARG),
    ("shadows", dict(shadows=33, shadows_method="fit"), ARG),
    ("shadows_method", dict(shadows=2, shadows_method=BIG), ARG),
    ("roughness", dict(roughness=[NAN]), ARG),
    ("roughness", dict(roughness=[1.5]), ARG),
    ("roughness", dict(roughness=0.5), TypeError),
    ("levels", dict(chain=True, levels=0), ARG),
    ("levels", dict(chain=True, levels=17), ARG),
    ("width", dict(mirror=True, width=0), ARG),
    ("width", dict(mirror=True, width=1), ARG),
    ("width", dict(mirror=True, width=BIG + 64), ARG),
    ("min_width", dict(chain=True, min_width=0), ARG),
    ("samples", dict(chain=True, samples=0), ARG),
    ("samples", dict(chain=True, samples=2 ** 20 + 1), ARG),
    ("irradiance_width", dict(irradiance=True, irradiance_width=0), ARG),
    ("irradiance_order", dict(irradiance=True, irradiance_method="sh", irradiance_order=-1), ARG),
    ("irradiance_method", dict(irradiance=True, irradiance_method=BIG + 1), ARG),
    ("threads", dict(mirror=True, threads=0), ARG),
    ("threads", dict(mirror=True, threads=-1), ARG),
    ("chain", dict(chain="yes"), TypeError),
    ("sun_lights", dict(chain=True, sun_lights="yes"), TypeError),
]


@pytest.mark.parametrize("arg,kw,kind", PREFILTER,
                         ids=["%s=%r" % (a, kw) for a, kw, _ in PREFILTER])
def test_prefilter_refuses(env, arg, kw, kind):
    refused(lambda: env.prefilter(**kw).close(), kind, "Envmap.prefilter: " + arg)


@pytest.mark.parametrize("args,kw,arg,kind", [
    ((NAN,), {}, "roughness", ARG), ((1.5,), {}, "roughness", ARG),
    ((0.5, 0), {}, "width", ARG), ((0.5, 1), {}, "width", ARG),
    ((0.5, 65538), {}, "width", ARG), ((0.5, BIG + 32), {}, "width", ARG),
    ((0.5, 32), dict(samples=0), "samples", ARG), ((0.5, 32), dict(threads=-1), "threads", ARG),
])
def test_specular_refuses(env, args, kw, arg, kind):
    refused(lambda: env.specular(*args, **kw), kind, "Envmap.specular: " + arg)


# ---- result objects -------------------------------------------------------------------------

def test_products_refuse(products):
    refused(lambda: products.find_level(NAN), ARG, "Products.find_level: roughness")
    refused(lambda: products.export(os.path.join(TMP, "d\0ir")), ARG,
            "Products.export: directory")
    refused(lambda: products.export(TMP, format=""), ARG, "Products.export: format")
    e = refused(lambda: products.export(TMP, layout=BIG), ARG, "Products.export: layout")
    assert e.message.startswith("Products.export: unknown layout")


def test_lights_result_refuses(lights):
    refused(lambda: lights.irradiance([(NAN, 0, 1)]), ARG, "LightsResult.irradiance: normals")
    refused(lambda: lights.save_residual(os.path.join(TMP, "r\0.pfm")), ARG,
            "LightsResult.save_residual: path")
    refused(lambda: lights.save_residual(os.path.join(TMP, "r.pfm"), format=""), ARG,
            "LightsResult.save_residual: format")
    e = refused(lambda: lights.lights[0].blender_sun("nope"), ARG, "Light.blender_sun")
    assert "mode 'nope'" in e.message


def test_sh_result_refuses(sh):
    refused(lambda: sh.eval_radiance([(0, 0, INF)]), ARG, "SHResult.eval_radiance: directions")
    refused(lambda: sh.eval_irradiance([(0, NAN, 1)]), ARG, "SHResult.eval_irradiance: normals")


# ---- what is accepted: None is the default, paths are file-system bytes ----------------------

def test_none_asks_for_the_library_default(hdr, env):
    with envlight.sky(width=None) as s:
        assert s.width == 1024
    with envlight.sky(width=32, sun_irradiance=None, zenith_radiance=None,
                      ground_albedo=None) as a, \
            envlight.sky(width=32, sun_irradiance=12.0, zenith_radiance=0.6,
                         ground_albedo=0.2) as b:
        assert np.array_equal(a.pixels(), b.pixels())
    with envlight.load(hdr, width=None, max_pixels=None, threads=None) as m:
        assert m.width == 32
    with env.lights(None, method="median") as res:
        assert len(res.lights) == 16
    with env.lights(method="fit", order=None) as res:
        assert res.remainder is None
    assert envlight.brdf_lut(None, samples=16).shape == (128, 128, 2)
    with env.prefilter(shadows=0) as p:           # 0 shadows is a real value: none
        assert p.summary["lights_computed"] == 0


def test_numpy_integers_and_bytes_paths_are_accepted(hdr, env):
    with env.lights(np.int64(3), method="median") as res:
        assert len(res.lights) == 3
    raw = os.path.join(os.fsencode(TMP), b"caf\xe9-\xff.hdr")  # not UTF-8
    envlight.save_image(raw, np.full((8, 16, 3), 0.5, np.float32))
    assert os.path.exists(raw)
    for p in (raw, os.fsdecode(raw)):  # bytes, and str with surrogate escapes
        with envlight.load(p) as m:
            assert m.width == 16


# ---- the limits the shim mirrors are the library's ----------------------------------------

def _raw_map():
    m = c_void_p()
    px = (c_float * (3 * 16 * 8))(*([0.5] * (3 * 16 * 8)))
    assert envlight.lib.envl_envmap_from_pixels(px, 16, 8, 3, None, byref(m)) == 0
    return m


def test_mirrored_limits_match_the_library():
    from envlight import _args as A
    lib = envlight.lib
    m = _raw_map()
    try:
        def lights_rc(method, count, order=0):
            o = _lib.LightsOptions(method, count, order)
            h = c_void_p()
            rc = lib.envl_lights_compute(m, byref(o), byref(h))
            lib.envl_lights_free(h)
            return rc
        fit = lib.envl_method_from_name(b"fit")
        med = lib.envl_method_from_name(b"median")
        assert lights_rc(fit, A.LIGHTS_MAX_FIT) == 0 and lights_rc(fit, A.LIGHTS_MAX_FIT + 1) == 1
        assert lights_rc(med, A.LIGHTS_MAX + 1) == 1
        assert lights_rc(fit, 1, A.REMAINDER_MAX_ORDER) == 0
        assert lights_rc(fit, 1, A.REMAINDER_MAX_ORDER + 1) == 1
        assert lights_rc(fit, 1, _lib.ENVL_ORDER_0) == 0

        def sh_rc(order):
            o = _lib.SHOptions(order, 0)
            h = c_void_p()
            rc = lib.envl_sh_compute(m, byref(o), byref(h))
            lib.envl_sh_free(h)
            return rc
        assert sh_rc(A.SH_MAX_ORDER) == 0 and sh_rc(A.SH_MAX_ORDER + 1) == 1
        assert sh_rc(_lib.ENVL_ORDER_0) == 0 and sh_rc(-1) == 1

        def compute_rc(**fields):
            q = _lib.Request()
            for k, v in fields.items():
                if k == "sh_order":
                    q.sh_order = v
                else:
                    setattr(q.prefilter, k, v)
            h = c_void_p()
            rc = lib.envl_compute(m, byref(q), byref(h))
            lib.envl_products_free(h)
            return rc
        for field, top in (("levels", A.PREFILTER_MAX_LEVELS), ("width", A.PREFILTER_MAX_WIDTH),
                           ("samples", A.PREFILTER_MAX_SAMPLES),
                           ("irradiance_width", A.PREFILTER_MAX_WIDTH),
                           ("irradiance_order", A.SH_MAX_ORDER), ("sh_order", A.SH_MAX_ORDER)):
            assert compute_rc(**{field: top}) == 0, field
            assert compute_rc(**{field: top + 1}) == 1, field
        assert compute_rc(width=2) == 0 and compute_rc(width=1) == 1
        assert compute_rc(min_width=2) == 0 and compute_rc(min_width=1) == 1
    finally:
        lib.envl_envmap_free(m)

    def brdf_rc(size, samples):
        o = _lib.BrdfOptions(size, samples, 0, 0)
        p, n = ctypes.POINTER(c_float)(), c_int32()
        rc = lib.envl_brdf_lut(byref(o), byref(p), byref(n))
        lib.envl_free(p)
        return rc
    assert brdf_rc(A.BRDF_MAX_SIZE + 1, 1) == 1 and brdf_rc(1, A.BRDF_MAX_SAMPLES + 1) == 1
    assert brdf_rc(1, A.BRDF_MAX_SAMPLES) == 0

    # the sky: the largest width whose width x width/2 pixels fit the library's 2^28
    w = A.SKY_MAX_WIDTH
    assert w * (w // 2) <= 1 << 28 < (w + 1) * ((w + 1) // 2)
    o = _lib.SkyOptions(35.0, 0.0, w + 1, 0.0, 0.0, 0.0, 1)
    h = c_void_p()
    assert lib.envl_envmap_sky(byref(o), byref(h)) == 5  # ENVL_ERR_LIMIT
