"""The EnvLight panel as a user reads it (issue 28), in Blender with a window on Xvfb: Blender's
default startup scene (its 1000 W point light kept), the panel's buttons pressed in order
(scripts/blender_panel_check.py), a screenshot of the Properties editor after each, read back
with Tesseract OCR (Debian's tesseract-ocr): what the user sees, not what the add-on stored.

  eevee   Create Lights in EEVEE: the startup light is named with Hide Them for the Render,
          the recipe and the settings it used (remainder order 1; the panel's own settings,
          Remainder Order 2, not shown), what the diffuse error measures
  hide    Hide Them for the Render: the light is hidden in renders, the panel says EnvLight did
  remove  Remove EnvLight: the light renders again
  cycles  Cycles on a map without a sun: "nothing changed" and why, in the panel, with Create
          Lamps Anyway; nothing about EEVEE's sun extraction
  anyway  Create Lamps Anyway: lamps taken exactly, lamps + world = the map's power
  ball    a square mirror-ball image on Equirectangular: the warning

The Blender: tests/py_blender_addon.py's ($ENVL_BLENDER, else Debian 12's `blender`); the
map: Blender's own courtyard.exr (datafiles/studiolights/world), skipped when absent."""
import difflib
import json
import os
import re
import shutil
import subprocess

import pytest

np = pytest.importorskip("numpy", reason="SKIP: numpy is not installed (python3-numpy)")
import envlight  # noqa: E402
import py_blender_addon as base  # noqa: E402  (skips this module as it skips itself)
from py_blender_addon import addon_zip, blender_in_use  # noqa: E402,F401

TMP = base.TMP
SCRIPT = os.path.join(base.SRC, "scripts", "blender_panel_check.py")
TESSERACT = shutil.which("tesseract")
COURTYARD = next((p for p in ("/usr/share/blender/datafiles/studiolights/world/courtyard.exr",
                              "/usr/share/blender/%s/datafiles/studiolights/world/courtyard.exr"
                              % base.BLENDER_VERSION[:3]) if os.path.exists(p)), None)
#: the window (and the Xvfb screen): tall enough for every World panel with the result
SCREEN = (1280, 2400)
#: an OCR'd phrase is found when a stretch of the text matches it this well (difflib ratio):
#: Tesseract misreads a letter or two of Blender's small UI font (measured: 0.9-1.0 on the
#: phrases below); a phrase that is absent scores under 0.7
MATCH = 0.85

if not base.XVFB_RUN:
    pytest.skip("SKIP: xvfb-run is not installed (Debian package xvfb)", allow_module_level=True)
if not TESSERACT:
    pytest.skip("SKIP: tesseract is not installed (Debian package tesseract-ocr)",
                allow_module_level=True)
if COURTYARD is None:
    pytest.skip("SKIP: Blender's courtyard.exr (blender-data) is absent", allow_module_level=True)


def normalise(text):
    text = text.lower().replace("\u2019", "'").replace("\u2018", "'").replace("|", " ")
    return re.sub(r"\s+", " ", text).strip()


def best_match(phrase, text):
    """The best difflib ratio of `phrase` against any stretch of `text` of its length."""
    p, t = normalise(phrase), normalise(text)
    n = len(p)
    if n > len(t):
        return difflib.SequenceMatcher(None, p, t).ratio()
    sm = difflib.SequenceMatcher(None, p, "")
    best = 0.0
    for i in range(0, len(t) - n + 1):
        sm.set_seq2(t[i:i + n])
        if sm.real_quick_ratio() > best and sm.quick_ratio() > best:
            best = max(best, sm.ratio())
    return best


def ocr(path):
    p = subprocess.run([TESSERACT, path, "-", "--psm", "4"], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    return p.stdout


@pytest.fixture(scope="module")
def panel(addon_zip):
    inputs = os.path.join(TMP, "panel_inputs")
    shutil.rmtree(inputs, ignore_errors=True)
    fbdir = os.path.join(inputs, "fb")
    os.makedirs(fbdir)
    ball = os.path.join(inputs, "ball.hdr")   # a mirror ball, as a camera would photograph it
    subprocess.run([os.environ.get("ENVLIGHT", os.path.join(base.BUILD, "envlight")),
                    "convert", COURTYARD, ball, "--layout-out", "mirrorball", "--size", "256",
                    "--quiet"], check=True)
    spec = {"fbdir": fbdir, "shots": os.path.join(inputs, "shots"), "hdr": COURTYARD,
            "hdr_nosun": COURTYARD, "ball": ball,
            "steps": ["eevee", "hide", "remove", "cycles", "anyway", "ball"]}
    res, log = base.run_blender("panel", spec, addon_zip, window=True, script=SCRIPT,
                                screen=SCREEN, fbdir=fbdir)
    res["log"] = log
    res["text"] = {k: ocr(v["ocr"]) for k, v in res["steps"].items()}
    with open(os.path.join(inputs, "ocr.json"), "w") as f:
        json.dump(res["text"], f, indent=1)
    return res


def seen(panel, step, phrase):
    return best_match(phrase, panel["text"][step])


def check_seen(panel, step, *phrases):
    for ph in phrases:
        r = seen(panel, step, ph)
        assert r >= MATCH, "%s: %r read with ratio %.2f in:\n%s" % (step, ph, r,
                                                                   panel["text"][step])


def check_not_seen(panel, step, *phrases):
    for ph in phrases:
        r = seen(panel, step, ph)
        assert r < 0.7, "%s: %r read (ratio %.2f) in:\n%s" % (step, ph, r, panel["text"][step])


def test_eevee_names_the_startup_light_and_what_it_used(panel):
    st = panel["steps"]["eevee"]
    assert st["rc"] == ["FINISHED"] and st["outcome"] == "made"
    assert st["startup_light_hide_render"] is False
    check_seen(panel, "eevee", "Also lighting the render: 'Light' (Point, 1000 W)",
               "Hide Them for the Render", "chosen from the scene",
               "EEVEE: recipe eevee-residual", "remainder order 1", "shadows: soft",
               "(unoccluded: the lamps + an order-1 SH of what they leave")
    # Read Scene: the panel's own settings (the labels Remainder Order, Method, Lights...) are
    # not shown (a fuzzy match cannot tell "Remainder Order 2" from "remainder order 1": the
    # labels' capitals are read exactly)
    for label in ("Remainder Order", "Method", "Sun Lamps"):
        assert label not in panel["text"]["eevee"], (label, panel["text"]["eevee"])
    # the settings line that holds "; " is one item, not two
    assert any("; camera rays: the map" in s for s in st["settings"]), st["settings"]
    assert any(w.startswith("the scene has 1 other light that renders: 'Light' (Point, "
                            "1000 W)") for w in st["message"].split("\n")), st["message"]


def test_hide_them_for_the_render_and_remove_shows_them(panel):
    hide, remove = panel["steps"]["hide"], panel["steps"]["remove"]
    assert hide["rc"] == ["FINISHED"] and hide["startup_light_hide_render"] is True
    check_seen(panel, "hide", "Hidden for the render by EnvLight: 'Light'")
    # (close to "Hidden for the render" for a fuzzy match: its capitals read exactly)
    assert "Hide Them" not in panel["text"]["hide"], panel["text"]["hide"]
    assert remove["rc"] == ["FINISHED"] and remove["startup_light_hide_render"] is False
    assert not [l for l in remove["lamps"] if l["tagged"]]
    check_seen(panel, "remove", "Also lighting the render: 'Light' (Point, 1000 W)")


def test_cycles_says_it_changed_nothing_and_why(panel):
    st = panel["steps"]["cycles"]
    assert st["rc"] == ["CANCELLED"] and st["outcome"] == "unchanged"
    assert not [l for l in st["lamps"] if l["tagged"]]
    check_seen(panel, "cycles", "Cycles: nothing changed", "suns hold 0 % of its light",
               "Create Lamps Anyway")
    check_not_seen(panel, "cycles", "sun extraction")
    assert "sun extraction" not in st["message"]


def test_create_lamps_anyway_is_unbiased(panel):
    """Lamps taken exactly: the lamps' power plus the residual world's is the map's (as
    Blender read it), to float32's rounding."""
    st = panel["steps"]["anyway"]
    assert st["rc"] == ["FINISHED"] and st["recipe"] == "lamps-residual"
    lamps = [l for l in st["lamps"] if l["tagged"]]
    assert lamps
    check_seen(panel, "anyway", "recipe lamps-residual", "taken exactly")
    check_not_seen(panel, "anyway", "sun extraction")
    # one item with its "; " kept (it used to become two orphan lines)
    assert any("; the world is the map less exactly them" in r for r in st["reasons"])
    # Create Lamps Anyway is Cycles' (the step's engine): the lamps' strength is their light
    total = base.lamps_power({"lamps": lamps, "engine": "CYCLES"}) + \
        np.array(st["world"]["residual_image"]["power"])
    with envlight.load(COURTYARD) as env:
        power = np.array(env.info()["power"])
    # Blender's EXR decode and the library's agree on half floats; the add-on set the 1188
    # negative pixels to 0, as the library does
    assert np.allclose(total, power, rtol=1e-4), (total, power)


def test_the_panel_shows_its_last_line(panel):
    """The result box is drawn whole in every screenshot: the last line of its message (the
    last line the panel draws) is read, not hidden under the next panel's header (4.3's
    mirror-ball shot once showed the box cut before it, its panels still sliding into place)."""
    for step, st in panel["steps"].items():
        if st["message"]:
            last = " ".join(st["message"].split("\n")[-1].split()[-5:])
            check_seen(panel, step, last)


def test_a_mirror_ball_on_equirectangular_is_warned_about(panel):
    st = panel["steps"]["ball"]
    assert any("is 256 x 256, not 2:1, on an Equirectangular projection" in w
               for w in st["message"].split("\n")), st["message"]
    check_seen(panel, "ball", "not 2:1, on an Equirectangular projection", "Mirror Ball")
