"""Hard cases and bad input for the Blender add-on (issue 14), in a real headless Blender (no
mock of bpy): Create Lights on a world without an Environment Texture, with a missing or an
unreadable image file, a packed image, generated images (float and 8-bit), a texture inside
nested node groups, a mirror-ball projection, an 8-bit PNG, NaN and negative pixels, a black
image. Each gives either sensible lamps (checked against where the image's spot is) or an
ERROR report naming the world or image and what is wrong - never a traceback - and a failing
press leaves the scene exactly as it was (fingerprint before and after). Undo after Create and
after Remove, in Blender with a window on Xvfb.

The cases run in one Blender (scripts/blender_hard_cases.py), the undo sequence in another.
The Blender, the add-on zip and the skips are tests/py_blender_addon.py's (imported: the same
$ENVL_BLENDER or `blender`, skipped the same way when absent)."""
import math
import os

import pytest

np = pytest.importorskip("numpy", reason="SKIP: numpy is not installed (python3-numpy)")
import envlight  # noqa: E402
import py_blender_addon as base  # noqa: E402  (skips this module as it skips itself)
from py_blender_addon import addon_zip, blender_in_use, spot_hdr  # noqa: E402,F401,F811

TMP = base.TMP
SCRIPT = os.path.join(base.SRC, "scripts", "blender_hard_cases.py")
# the panel's own settings (Read Scene off): the cases test reading the image, not the scene
SETTINGS = {"read_scene": False, "suns": False, "count": 4, "method": "fit",
            "world_mode": "RESIDUAL", "shadows": "SOFT"}

# the lat-long images: 128 x 64, a 4 x 4 blob at columns 80..83, rows 20..23 (row 0 at the top)
LL = dict(w=128, h=64, col=80, row=20, size=4)
# the mirror balls: 128 x 128 (and a 192 x 128 one), a 6 x 6 blob centred on x = 90 / 128 of
# the width, 45 / 128 of the height from the top
MB = dict(n=128, cx=90, cy=45, size=6)


def latlong_direction(u, v):
    """Blender's (and the library's) equirectangular frame: u = 0.5 is +X, 0.25 is +Y."""
    phi, theta = math.pi * (1 - 2 * u), math.pi * (0.5 - v)
    return np.array([math.cos(theta) * math.cos(phi), math.cos(theta) * math.sin(phi),
                     math.sin(theta)])


def mirrorball_direction(u, v):
    """The world direction Blender's Environment Texture (projection Mirror Ball) shows at
    texture coordinates (u, v) (v up), written out from Cycles' mirrorball_to_direction: the
    ball's normal n = (2u - 1, -sqrt(1 - x^2 - z^2), 2v - 1), the direction 2 (n.I) n - I with
    I = (0, -1, 0)."""
    x, z = 2 * u - 1, 2 * v - 1
    n = np.array([x, -math.sqrt(max(0.0, 1 - x * x - z * z)), z])
    i = np.array([0.0, -1.0, 0.0])
    return 2 * (n @ i) * n - i


LL_SPOT = latlong_direction((LL["col"] + LL["size"] / 2) / LL["w"],
                            (LL["row"] + LL["size"] / 2) / LL["h"])
MB_SPOT = mirrorball_direction(MB["cx"] / MB["n"], 1 - MB["cy"] / MB["n"])


def blob_image(w, h, c0, r0, cw, rh, bg, spot, alpha=True):
    a = np.zeros((h, w, 4 if alpha else 3), np.float32)
    a[..., :3] = bg
    a[r0:r0 + rh, c0:c0 + cw, :3] = spot
    if alpha:
        a[..., 3] = 1.0
    return a


def latlong_blob(bg, spot):
    return blob_image(LL["w"], LL["h"], LL["col"], LL["row"], LL["size"], LL["size"], bg, spot)


def mirrorball_blob(w, h, bg, spot):
    """The ball fills the image (Blender stretches it over a non-square one): the blob at the
    same fractions of the width and height."""
    cw, rh = round(MB["size"] * w / MB["n"]), MB["size"]
    c0 = round(MB["cx"] * w / MB["n"]) - cw // 2
    r0 = round(MB["cy"] * h / MB["n"]) - rh // 2
    return blob_image(w, h, c0, r0, cw, rh, bg, spot)


def npy(name, a):
    path = os.path.join(TMP, name + ".npy")
    np.save(path, a)
    return path


def srgb_decode(a):
    a = np.asarray(a, np.float64)
    return np.where(a <= 0.04045, a / 12.92, ((a + 0.055) / 1.055) ** 2.4)


# float pixels: a spot like spot.hdr's; 8-bit (stored, sRGB-encoded) values: a white blob on a
# dark ground (0.05 encoded, 0.0039 linear)
FLOAT_BG, FLOAT_SPOT = 0.05, (1000.0, 500.0, 250.0)
BYTE_BG, BYTE_SPOT = 0.05, (1.0, 0.8, 0.6)


def copy_file(src, name):
    dst = os.path.join(TMP, name)
    with open(src, "rb") as f, open(dst, "wb") as g:
        g.write(f.read())
    return dst


@pytest.fixture(scope="module")
def cases(request, addon_zip, spot_hdr):
    """All cases in one Blender run -> {name: case result}."""
    spot, _, _ = spot_hdr
    corrupt = os.path.join(TMP, "corrupt.hdr")
    with open(corrupt, "wb") as f:
        f.write(b"this is not an image\n" * 20)
    truncated = os.path.join(TMP, "truncated.hdr")
    with open(spot, "rb") as f:
        data = f.read()
    with open(truncated, "wb") as f:
        f.write(data[:len(data) // 3])
    nan = latlong_blob(FLOAT_BG, FLOAT_SPOT)
    nan[2, 5, 0] = nan[40, 7, 1] = nan[60, 100, 2] = np.nan
    nan[10, 10, :3] = -1.0
    nan[50, 20, 1] = -0.5
    mb = mirrorball_blob(MB["n"], MB["n"], FLOAT_BG, FLOAT_SPOT)
    wide = mirrorball_blob(192, 128, FLOAT_BG, FLOAT_SPOT)
    texture = lambda **image: {"image": image}  # noqa: E731
    specs = [
        {"name": "no_nodes", "world": "none"},
        {"name": "no_texture", "world": "background"},
        {"name": "no_image"},
        {"name": "missing", **texture(file=copy_file(spot, "missing.hdr"), missing=True)},
        {"name": "missing_after_success", "first": {"file": spot},
         **texture(file=copy_file(spot, "missing2.hdr"), missing=True)},
        {"name": "corrupt", **texture(file=corrupt)},
        {"name": "truncated", **texture(file=truncated)},
        {"name": "packed", **texture(file=copy_file(spot, "packed.hdr"), pack=True)},
        {"name": "generated_float", **texture(generated=npy("gen_float", latlong_blob(
            FLOAT_BG, FLOAT_SPOT)), float=True, size=[LL["w"], LL["h"]])},
        {"name": "generated_byte", **texture(generated=npy("gen_byte", latlong_blob(
            BYTE_BG, BYTE_SPOT)), float=False, size=[LL["w"], LL["h"]])},
        {"name": "generated_blank", **texture(generated=None, float=True, size=[64, 32])},
        {"name": "nan_negative", **texture(generated=npy("nan", nan), float=True,
                                           size=[LL["w"], LL["h"]])},
        {"name": "png_8bit", **texture(file=os.path.join(TMP, "spot8.png"),
                                       png_from=npy("png", latlong_blob(BYTE_BG, BYTE_SPOT)))},
        {"name": "nested_groups", "group_depth": 2, **texture(file=spot)},
        {"name": "mirror_ball", "projection": "MIRROR_BALL",
         "panorama": os.path.join(TMP, "mirror_ball_pano.exr"),
         **texture(generated=npy("mb", mb), float=True, size=[MB["n"], MB["n"]])},
        {"name": "mirror_ball_wide", "projection": "MIRROR_BALL",
         "panorama": os.path.join(TMP, "mirror_ball_wide_pano.exr"),
         **texture(generated=npy("mb_wide", wide), float=True, size=[192, 128])},
    ]
    res, log = base.run_blender("hard_cases", {"cases": specs, "settings": SETTINGS}, addon_zip,
                                script=SCRIPT)
    out = {c["name"]: c for c in res["cases"]}
    for c in res["cases"]:
        base.report(request, "%-22s %s" % (c["name"], "FINISHED, %d lamps%s" % (
            len(c["lamps"]), "; warnings: " + " | ".join(c["warnings"]) if c["warnings"] else "")
            if c["rc"] else c["report"].strip()))
    out["_log"] = log
    out["_inputs"] = {"nan": nan, "mb": mb, "wide": wide}
    return out


def check_error(case, *words):
    """An ERROR report (bpy.ops: "Error: EnvLight: ..."), no traceback, naming `words`, and the
    scene exactly as it was."""
    assert case["rc"] is None, case
    rep = case["report"]
    assert rep.startswith("Error: EnvLight: "), rep
    assert "Traceback" not in rep and "Python:" not in rep, rep
    for w in words:
        assert w in rep, (w, rep)
    assert case["message"] == rep[len("Error: EnvLight: "):].strip()
    assert case["after"] == case["before"]


def check_spot(case, want, tol=1.0, blob=6.0):
    """Sensible lamps for a one-spot image: the spot takes most of the lamps' power, and the
    lamps on it (within 20 degrees; the fit may split a blob of a few pixels into several)
    are centred on it within `tol` degrees, the strongest within the blob (`blob` degrees)."""
    assert case["rc"] == ["FINISHED"], case["report"]
    lamps = case["lamps"]
    assert lamps
    power = [l["energy"] * sum(l["color"]) for l in lamps]
    near = [(p, np.array(l["direction"])) for p, l in zip(power, lamps)
            if base.angle_deg(l["direction"], want) < 20]
    assert sum(p for p, _ in near) > 0.8 * sum(power), (power, want)
    centre = sum(p * d for p, d in near)
    assert base.angle_deg(centre, want) < tol, (centre, want)
    best = lamps[int(np.argmax(power))]
    assert base.angle_deg(best["direction"], want) < blob, (best["direction"], want)
    return centre


def test_world_without_nodes(cases):
    check_error(cases["no_nodes"], "world 'Case no_nodes'", "does not use nodes")


def test_world_without_environment_texture(cases):
    check_error(cases["no_texture"], "no Environment Texture", "world 'Case no_texture'")


def test_texture_without_image(cases):
    check_error(cases["no_image"], "world 'Case no_image'", "'UserEnvTexture'", "no image")


def test_missing_file(cases):
    c = cases["missing"]
    assert c["image"]["file_exists"] is False and c["image"]["size"] == [0, 0]
    check_error(c, "world 'Case missing'", "image 'UserImage'", "missing.hdr", "is missing")


def test_missing_file_after_a_run_keeps_the_previous_lamps(cases):
    c = cases["missing_after_success"]
    assert c["first"]["rc"] == ["FINISHED"]
    check_error(c, "image 'UserImage'", "missing2.hdr", "is missing")
    assert len(c["lamps"]) >= 1  # the first run's, untouched (fingerprint)
    assert c["before"]["worlds"]["Case missing_after_success"]["props"]  # its saved output


def test_unreadable_file(cases):
    c = cases["corrupt"]
    assert c["image"]["file_exists"] and c["image"]["size"] == [0, 0]
    check_error(c, "world 'Case corrupt'", "image 'UserImage'", "corrupt.hdr", "cannot read")


def test_truncated_file_is_lamps_or_a_report(cases):
    """A third of spot.hdr: Blender 3.4's own reader decodes what is there (the rest black),
    4.x's OpenImageIO refuses it. Either lamps from those pixels or a report, never a
    traceback nor a change on failure."""
    c = cases["truncated"]
    if c["rc"] is None:
        check_error(c, "image 'UserImage'", "truncated.hdr")
    else:
        assert c["rc"] == ["FINISHED"] and c["image"]["size"][0] > 0


def test_packed_image_without_its_file(cases):
    c = cases["packed"]
    assert c["image"]["packed"] and c["image"]["file_exists"] is False
    check_spot(c, cases_spot_direction())


def cases_spot_direction():
    with envlight.load(os.path.join(TMP, "spot.hdr")) as env:
        return np.array(env.direction(base.SPOT["col"], base.SPOT["row"]))


def expected_power(pixels_top_down, layout="latlong"):
    with envlight.from_pixels(np.ascontiguousarray(pixels_top_down[..., :3], np.float32),
                              layout=layout) as env:
        return np.array(env.info()["power"])


def test_generated_float_image(cases):
    c = cases["generated_float"]
    assert c["image"]["source"] == "GENERATED" and c["image"]["is_float"]
    check_spot(c, LL_SPOT)
    assert np.allclose(c["power"], expected_power(latlong_blob(FLOAT_BG, FLOAT_SPOT)),
                       rtol=1e-6)
    assert not [w for w in c["warnings"] if "image 'UserImage'" in w], c["warnings"]


def check_8bit(c, name):
    """An 8-bit image: Blender hands its stored (sRGB-encoded) values; the add-on decodes them
    as Cycles does, says the image is low dynamic range, and the blob gives the strongest lamp."""
    assert not c["image"]["is_float"] and c["image"]["colorspace"] == "sRGB"
    check_spot(c, LL_SPOT)
    stored = np.round(latlong_blob(BYTE_BG, BYTE_SPOT) * 255) / 255  # what 8 bits hold
    want = expected_power(srgb_decode(stored))
    assert np.allclose(c["power"], want, rtol=1e-5), (c["power"], want)
    assert not np.allclose(c["power"], expected_power(stored), rtol=0.1)  # not read as linear
    assert any("8-bit" in w and "'%s'" % name in w for w in c["warnings"]), c["warnings"]
    assert "8-bit" in c["message"]


def test_generated_byte_image(cases):
    c = cases["generated_byte"]
    assert c["image"]["source"] == "GENERATED"
    check_8bit(c, "UserImage")


def test_8bit_png_file(cases):
    c = cases["png_8bit"]
    assert c["image"]["source"] == "FILE" and c["image"]["depth"] in (24, 32)
    check_8bit(c, "UserImage")


def test_blank_generated_image_has_no_light(cases):
    check_error(cases["generated_blank"], "image 'UserImage'", "has no light", "black")


def test_nan_and_negative_pixels_are_reported(cases):
    c = cases["nan_negative"]
    check_spot(c, LL_SPOT)
    assert any("3 pixels with NaN or infinite values: NaN set to 0" in w
               for w in c["warnings"]), c["warnings"]
    assert any("2 negative pixels" in w and ("filled from the light around them" in w or
                                             "set to 0, adding" in w)
               for w in c["warnings"]), c["warnings"]
    # the library's repair of Blender's pixels as they are: NaN to 0, the negative values filled
    # from the light around them (the power keeps their signed sum; docs/methods.md)
    clean = np.nan_to_num(cases["_inputs"]["nan"], nan=0.0)
    assert np.allclose(c["power"], expected_power(clean), rtol=1e-6)


def test_texture_in_nested_node_groups(cases):
    check_spot(cases["nested_groups"], cases_spot_direction(), tol=0.5)


@pytest.mark.parametrize("name,inputs", [("mirror_ball", "mb"), ("mirror_ball_wide", "wide")])
def test_mirror_ball(cases, name, inputs):
    """The spot of a mirror-ball image gives the strongest lamp where Blender shows it: the
    direction from Cycles' mirror-ball formula, and the spot of a panorama render of the world
    (256 x 128, 1.4 degrees a pixel; the blob is about 6 degrees wide)."""
    c = cases[name]
    lit = check_spot(c, MB_SPOT)
    seen = base.panorama_spot(os.path.join(TMP, name + "_pano.exr"))
    assert base.angle_deg(seen, MB_SPOT) < 1.5, (seen, MB_SPOT)
    assert base.angle_deg(seen, lit) < 1.5, (seen, lit)
    # the lamps and the residual hold the ball's power (a turn about +Z does not change it)
    a = cases["_inputs"][inputs]
    if a.shape[0] != a.shape[1]:  # the add-on's nearest resampling to a square
        n = max(a.shape[:2])
        rows = ((np.arange(n) + 0.5) * a.shape[0] / n).astype(int)
        cols = ((np.arange(n) + 0.5) * a.shape[1] / n).astype(int)
        a = a[rows][:, cols]
        assert any("not square" in w for w in c["warnings"]), c["warnings"]
    want = expected_power(a, layout="mirrorball")
    assert np.allclose(c["power"], want, rtol=1e-5), (c["power"], want)


def test_no_traceback_in_blender_output(cases):
    assert "Traceback" not in cases["_log"]


# ---- undo, in Blender with a window ---------------------------------------------------------

def test_undo_after_create_and_after_remove(addon_zip, spot_hdr):
    """Create Lights and Remove as button presses (one undo step each), then Edit > Undo twice
    and Redo twice, in Blender with a window on Xvfb (bpy.ops.ed.undo needs one)."""
    if not base.XVFB_RUN:
        pytest.skip("SKIP: xvfb-run is not installed (Debian package xvfb)")
    path, _, _ = spot_hdr
    res, _ = base.run_blender("undo_remove", {"undo": {"hdr": path, "settings": SETTINGS}},
                              addon_zip, window=True, script=SCRIPT)
    u = res["undo"]
    st = u["states"]
    assert u["undo_poll"] and u["create"] == ["FINISHED"] and u["remove"] == ["FINISHED"]
    assert all(u[k + "_rc"] == ["FINISHED"] for k in ("undo_remove", "undo_create",
                                                        "redo_create", "redo_remove"))
    made = [o["name"] for o in st["created"]["objects"] if "envlight" in o["keys"]]
    assert made and not [o for o in st["before"]["objects"] if "envlight" in o["keys"]]
    assert st["created"] != st["before"] and st["removed"] != st["created"]
    assert st["removed"]["objects"] == st["before"]["objects"]
    assert st["undo_remove"] == st["created"]  # the lamps, nodes and image back
    assert st["undo_create"] == st["before"]  # nothing of EnvLight left
    assert st["redo_create"] == st["created"]
    assert st["redo_remove"] == st["removed"]
