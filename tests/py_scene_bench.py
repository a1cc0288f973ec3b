"""scripts/scene_bench.py --quick end to end, with the real POV-Ray 3.7 and Blender: the JSON's
shape, every number finite, errors >= 0, the reference validated, the report and figures."""
import json
import math
import os
import shutil
import subprocess
import sys

import pytest

ENVLIGHT = os.environ.get("ENVLIGHT", "")
LIBRARY = os.environ.get("ENVLIGHT_LIBRARY", "")
SOURCE = os.environ.get("ENVL_SOURCE_DIR", os.path.join(os.path.dirname(__file__), ".."))
TMP = os.environ.get("ENVL_TEST_TMP", "/tmp/envl_py_scene_bench")
SCRIPT = os.path.join(SOURCE, "scripts", "scene_bench.py")

pytestmark = pytest.mark.skipif(not shutil.which("povray") or not ENVLIGHT or not LIBRARY,
                                reason="needs povray, ENVLIGHT and ENVLIGHT_LIBRARY")


def numbers(x, path="$"):
    """Every number in x with its path (bool excluded)."""
    if isinstance(x, bool):
        return
    if isinstance(x, (int, float)):
        yield path, x
    elif isinstance(x, dict):
        for k, v in x.items():
            yield from numbers(v, "%s.%s" % (path, k))
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from numbers(v, "%s[%d]" % (path, i))


def test_help():
    r = subprocess.run([sys.executable, SCRIPT, "--help"], capture_output=True, text=True,
                       cwd=SOURCE)
    assert r.returncode == 0 and "--host" in r.stdout and "--quick" in r.stdout


@pytest.fixture(scope="module")
def quick_pov():
    """One --host pov --quick run: (its JSON's path, its work folder, its docs folder)."""
    os.makedirs(TMP, exist_ok=True)
    out = os.path.join(TMP, "quick.json")
    docs = os.path.join(TMP, "docs")
    for f in (out, os.path.join(docs, "scene_bench_pov.md")):
        if os.path.exists(f):
            os.unlink(f)
    work = os.path.join(TMP, "work")
    r = subprocess.run([sys.executable, SCRIPT, "--host", "pov", "--quick", "--json", out,
                        "--docs", docs, "--envlight", ENVLIGHT, "--library", LIBRARY,
                        "--tmp", work],
                       capture_output=True, text=True, cwd=SOURCE)
    print(r.stdout[-4000:])
    assert r.returncode == 0, r.stderr[-3000:]
    return out, work, docs


def test_quick(quick_pov):
    """--host pov --quick: the built-in sky in scenes a, b, still (a user's scene) and x (the
    banding scene), the options default, dome-hard and sh: the JSON's shape, every number
    finite, the reference validated, what --scene picks per scene, the sun's edges counted,
    and the report and figures written."""
    out, _, docs = quick_pov
    res = json.load(open(out))
    assert res["host"] == "pov" and res["host_version"].startswith("POV-Ray")
    assert len(res["load_average"]) == 3
    assert list(res["maps"]) == ["sky"] and res["scenes"] == ["a", "b", "still", "x"]
    m = res["maps"]["sky"]
    assert 0 <= m["sun_share"] <= 1
    ref = m["reference"]
    assert ref["validated"] and 0 <= ref["validation_error"] <= ref["validation_tolerance"]
    for scene in ("a", "b", "still"):
        s = ref["scenes"][scene]
        assert s["cpu_seconds"] > 0 and s["seconds"] > 0
        assert all(0 <= s["sun_edge_pixels"][o] <= s["pixels"][o] for o in s["pixels"])
    assert 0 <= ref["scenes"]["a"]["highlight"]["convergence"]
    assert ref["scenes"]["x"]["plane_pixels"] > ref["scenes"]["x"]["sun_edge_pixels"] > 0
    runs = res["runs"]
    keys = {"map", "scene", "recipe", "option", "picked", "engine", "seconds", "wall_seconds",
            "error", "worst", "errors", "bias", "biases", "plane", "speedup",
            "envlight_seconds"}
    objects = {"a": {"matte", "glossy", "plane"}, "b": {"object", "overhang", "plane"},
               "still": {"floor", "walls", "white", "cylinder", "box", "shelf", "glossy",
                         "gold"},
               "x": {"plane"}}
    for row in runs:
        assert keys <= set(row), keys - set(row)
        assert row["map"] == "sky" and row["engine"] == "povray"
        assert isinstance(row["picked"], bool)
        assert set(row["errors"]) == objects[row["scene"]] == set(row["biases"])
        assert row["error"] == row["errors"][row["worst"]] >= 0
        assert all(v >= 0 for v in row["errors"].values())
        assert row["seconds"] > 0 and row["wall_seconds"] > 0
        assert (row["speedup"] is None) == (row["scene"] == "x")
        if row["scene"] == "x":
            assert 0 <= row["banding"] <= row["error"] * 10
    options = {(r["scene"], r["option"]) for r in runs}
    assert {("a", "sh"), ("b", "sh"), ("x", "dome-hard"), ("still", "dome-hard")} <= options
    assert ("still", "sh") not in options   # its ambient needs EnvLight_Add_Ambient textures
    picked = {r["scene"]: r["recipe"] for r in runs if r["picked"]}
    assert picked == {"a": "dome", "b": "dome", "still": "dome", "x": "dome"}
    for path, v in numbers(res):
        assert math.isfinite(v), path
    report = open(os.path.join(docs, "scene_bench_pov.md")).read()
    assert "## The picked include, per map" in report and "## Every option" in report
    for fig in ("grid", "banding", "users", "error_time"):
        assert os.path.getsize(os.path.join(docs, "pov_scene_%s.png" % fig)) > 1000


def test_references_from_an_earlier_run(quick_pov, tmp_path):
    """--references-from: each scene's reference is the earlier run's (its entry as that JSON
    has it, its image from the work folder), not rendered again; the speedup is its CPU over
    the option's; a scene whose image is gone is rendered as usual."""
    import numpy as np
    out, work, _ = quick_pov
    old = json.load(open(out))["maps"]["sky"]["reference"]["scenes"]
    shutil.copytree(work, tmp_path / "work")
    f = tmp_path / "work" / "sky" / "images.npz"
    with np.load(f) as z:
        kept = {k: z[k] for k in z.files if k != "reference|b"}
    np.savez(f, **kept)
    again = tmp_path / "again.json"
    r = subprocess.run([sys.executable, SCRIPT, "--host", "pov", "--quick", "--scenes", "a,b",
                        "--recipes", "default", "--references-from", out, "--json",
                        str(again), "--envlight", ENVLIGHT, "--library", LIBRARY,
                        "--tmp", str(tmp_path / "work")],
                       capture_output=True, text=True, cwd=SOURCE)
    print(r.stdout[-3000:])
    assert r.returncode == 0, r.stderr[-3000:]
    assert "(a) reference (an earlier run's):" in r.stdout
    assert "(b) reference:" in r.stdout and "(b) reference (an" not in r.stdout
    res = json.load(open(again))
    ref = res["maps"]["sky"]["reference"]
    assert ref["scenes"]["a"] == old["a"]
    assert ref["scenes"]["b"]["cpu_seconds"] > 0
    rows = {r["scene"]: r for r in res["runs"]}
    assert set(rows) == {"a", "b"} and all(r["picked"] for r in rows.values())
    assert rows["a"]["speedup"] == pytest.approx(old["a"]["cpu_seconds"] / rows["a"]["seconds"],
                                                 rel=1e-12)
    for row in rows.values():
        assert all(0 <= v < 1 for v in row["errors"].values())


BLENDER4 = "/var/cache/envlight/trixie-root/run-blender"


def test_quick_blender():
    """--host blender --quick (the built-in sky, scenes a, b, c; the plain HDR world and what
    the add-on picks) in Debian 13's Blender 4.3 (scripts/blender4.sh), else `blender`: the
    JSON's shape, the picked recipe per scene, every number finite."""
    blender = os.environ.get("ENVL_BLENDER") or (BLENDER4 if os.path.exists(BLENDER4)
                                                 else shutil.which("blender"))
    if not blender:
        pytest.skip("SKIP: no Blender (Debian's blender, or scripts/blender4.sh)")
    os.makedirs(TMP, exist_ok=True)
    out = os.path.join(TMP, "quick_blender.json")
    if os.path.exists(out):
        os.unlink(out)
    env = dict(os.environ, ENVL_BLENDER=blender)
    r = subprocess.run([sys.executable, SCRIPT, "--host", "blender", "--quick", "--json", out,
                        "--envlight", ENVLIGHT, "--library", LIBRARY,
                        "--tmp", os.path.join(TMP, "work_blender")],
                       capture_output=True, text=True, cwd=SOURCE, env=env)
    print(r.stdout[-4000:])
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.load(open(out))
    assert res["host"] == "blender" and res["host_version"].startswith("Blender ")
    assert list(res["maps"]) == ["sky"] and res["scenes"] == ["a", "b", "c"]
    keys = {"map", "scene", "recipe", "picked", "engine", "seconds", "samples", "error",
            "noise", "floor", "bias", "biases", "errors", "speedup", "picked_as", "report"}
    objects = {"a": {"ground", "matte"}, "b": {"ground", "matte", "glossy"},
               "c": {"ground", "matte", "wall", "overhang"}}
    for row in res["runs"]:
        assert keys <= set(row), keys - set(row)
        assert row["engine"] == "cycles" and row["recipe"] in ("hdr", "picked")
        assert set(row["biases"]) == objects[row["scene"]]
        assert set(row["errors"]) == objects[row["scene"]] | {"objects"}
        assert row["error"] == row["errors"]["objects"] >= 0 and row["noise"] >= 0
        assert row["seconds"] > 0
        if row["recipe"] == "hdr":
            assert row["speedup"] == 1.0 and not row["picked"]
    picked = {r["scene"]: r["picked_as"] for r in res["runs"] if r["picked"]}
    # the add-on's pick in Cycles: the exact recipe in every scene
    assert picked == {"a": "sun-residual", "b": "sun-residual", "c": "sun-residual"}
    for path, v in numbers(res):
        assert math.isfinite(v), path


@pytest.mark.parametrize("scene", ["a", "b"])
def test_pov_scene_in_cycles(scene):
    """scripts/pov_cycles_scene.py builds the POV-Ray bench scene in Cycles from the .pov file
    (the path-traced check of the POV-Ray reference, scripts/pov_path_traced.py): Cycles' id
    pass (an emission of one channel per object, 16 samples a pixel) is POV-Ray's own id pass,
    pixel for pixel: at most 5 of the 30,000 pixels differ (with a square pixel where POV-Ray's
    default `right 1.33` makes it 0.25 % taller, 52 did in scene (b): the outlines of its top
    rows moved by up to 0.2 pixels); under 0.2 % of the pixels are a mix of two objects (each
    pixel sampled at its centre, as POV-Ray's -A does: Cycles' box filter mixed 1.8 %); and
    mirrored left to right, the ids of the objects on the floor agree on less than 90 % (the
    check can tell a mirrored frame)."""
    blender = shutil.which("blender")
    if not blender:
        pytest.skip("SKIP: no Debian blender (Cycles)")
    sys.path.insert(0, os.path.join(SOURCE, "scripts"))
    import numpy as np
    import scene_bench_pov as S
    import pov_path_traced as T
    d = os.path.join(TMP, "cycles_%s" % scene)
    os.makedirs(d, exist_ok=True)
    S.setup(ENVLIGHT, LIBRARY, d)
    hdr = os.path.join(d, "sky.hdr")
    subprocess.run([ENVLIGHT, "convert", "-", hdr, "--sky-width", "64", "--quiet"], check=True)
    masks = S.object_masks(d, scene, T.SIZE)
    ids, _ = T.cycles(blender, scene, hdr, os.path.join(d, "ids.npy"), ids=True)
    assert ids.shape == (T.SIZE[1], T.SIZE[0], 3)
    mixed = np.mean(((ids > 0.02) & (ids < 0.98)).any(-1))
    assert mixed < 0.002, mixed
    differ = 0
    for obj, ch in S.SCENES[scene]["objects"]:
        assert masks[obj].sum() > 500, (obj, masks[obj].sum())
        mine = ids[..., ch] > 0.5
        differ += int((mine != masks[obj]).sum())
        mirrored = np.mean(mine[:, ::-1][masks[obj]])
        print("scene %s, %s: %d pixels differ (mirrored: %.4f agree)" % (
            scene, obj, (mine != masks[obj]).sum(), mirrored))
        if obj != S.SCENES[scene]["floor"]:
            assert mirrored < 0.9, (obj, mirrored)
    assert differ <= 5, differ


def test_csg_scene_needs_the_standard_includes(tmp_path, monkeypatch):
    """The csg scene includes colors.inc: without POV-Ray's standard includes (Debian's
    povray-includes) the bench says so and which package, before rendering anything (it
    crashed after the first map's other scenes); with them, or without the csg scene, it says
    nothing. The includes themselves are what scripts/build.sh installs."""
    sys.path.insert(0, os.path.join(SOURCE, "scripts"))
    import scene_bench_pov as S
    assert os.path.exists(os.path.join(S.POV_STANDARD_INCLUDES, "colors.inc")), \
        "POV-Ray's standard includes missing: scripts/build.sh installs povray-includes"
    assert S.check_scenes(["a", "b", "still", "interior", "csg", "x"]) is None
    monkeypatch.setattr(S, "POV_STANDARD_INCLUDES", str(tmp_path))
    said = S.check_scenes(["a", "csg"])
    assert said and "colors.inc" in said and "povray-includes" in said
    assert S.check_scenes(["a", "b", "still", "interior", "x"]) is None
    r = subprocess.run([sys.executable, "-c",
                        "import sys; sys.argv[1:] = %r; sys.path.insert(0, %r); "
                        "import scene_bench_pov as S; S.POV_STANDARD_INCLUDES = %r; "
                        "import scene_bench; scene_bench.main()"
                        % (["--host", "pov", "--scenes", "csg", "--map", "-",
                            "--tmp", str(tmp_path / "run")],
                           os.path.join(SOURCE, "scripts"), str(tmp_path))],
                       capture_output=True, text=True, cwd=SOURCE, timeout=120)
    assert r.returncode != 0 and "povray-includes" in r.stderr
    assert not os.path.exists(tmp_path / "run" / "sky"), "rendered before saying it"


def test_a_run_of_other_scenes_keeps_the_images(tmp_path):
    """A map's images.npz gathers its runs: a run of the user scenes alone keeps the images an
    earlier run of (a) and (b) saved there (the figures of the merged JSON are drawn from them:
    overwritten, their rows were lost), and a run of the same scene replaces its images."""
    sys.path.insert(0, os.path.join(SOURCE, "scripts"))
    import numpy as np
    import scene_bench_pov as S
    S.setup(ENVLIGHT, LIBRARY, str(tmp_path))
    d = tmp_path / "map"
    d.mkdir()
    a, b, still, again = (np.full((2, 3, 3), v, np.float32) for v in (1, 2, 3, 4))
    S.save_images(str(d), {("reference", "a"): a, ("picked", "b"): b, ("header", "a"): "text"})
    S.save_images(str(d), {("reference", "still"): still})
    got = S.load_images("map", dict(tmp=str(tmp_path)))
    assert set(got) == {("reference", "a"), ("picked", "b"), ("reference", "still")}
    assert (got[("reference", "a")] == 1).all() and (got[("reference", "still")] == 3).all()
    S.save_images(str(d), {("reference", "a"): again})
    got = S.load_images("map", dict(tmp=str(tmp_path)))
    assert (got[("reference", "a")] == 4).all() and (got[("picked", "b")] == 2).all()
    assert not [f for f in os.listdir(d) if f != "images.npz"], "a temporary left behind"


def test_an_object_all_on_a_suns_edge_keeps_its_pixels(tmp_path):
    """sun_edges leaves out an object's pixels on a sun's hard shadow edge; an object whose
    every pixel steps (Blender's interior map: the gold torus's 640 of 640) keeps them all, so
    its error is a number (it was the mean of nothing: NaN in the run, None in the JSON)."""
    sys.path.insert(0, os.path.join(SOURCE, "scripts"))
    import numpy as np
    import scene_bench_pov as S
    S.setup(ENVLIGHT, LIBRARY, str(tmp_path))
    h, w = 12, 24
    torus, plane = np.zeros((h, w), bool), np.zeros((h, w), bool)
    torus[:, :12], plane[:, 12:] = True, True
    occluded = np.zeros((h, w, 3), np.float32)
    occluded[::2, :12] = 1.0                      # the torus: steps on every row
    occluded[:, 12:18] = 1.0                      # the plane: one edge at column 18
    ref = np.ones((h, w, 3), np.float32)
    edges = S.sun_edges(occluded, ref, {"torus": torus, "plane": plane})
    assert not edges["torus"].any()
    # the plane's step: columns 17 and 18 differ from their 3 x 3 mean over the plane by 1/3
    # (> SUN_EDGE), the others by 0; with their neighbours, columns 16-19 on every row
    cols = np.flatnonzero(edges["plane"].any(0))
    assert list(cols) == [16, 17, 18, 19] and edges["plane"].sum() == 4 * h
    img = ref * 1.02    # float32: 1.02 to 1e-7, the 2 % to 1e-5 of itself
    errors, biases = S.measure(img, {"torus": ref, "plane": ref},
                               {"torus": torus, "plane": plane}, edges)
    assert errors["torus"] == pytest.approx(0.02, rel=1e-5)
    assert biases["plane"] == pytest.approx(0.02, rel=1e-5)


def test_blender_reference_of_a_map_with_infinite_pixels(tmp_path):
    """The Blender bench's reference renders a map with NaN or Inf pixels as the library reads
    it (Cycles renders those pixels black, packed or from a DWA EXR's file): reference_map_of
    counts them as the library does (a half EXR with a 2 x 2 +Inf patch: 4) and writes the
    map with the patch at the image's largest finite value (1000 here), every other pixel as
    the file has it; a map without such pixels (the built-in sky) is its own reference."""
    if not shutil.which("oiiotool"):
        pytest.skip("SKIP: needs oiiotool (Debian's openimageio-tools)")
    sys.path.insert(0, os.path.join(SOURCE, "scripts"))
    import numpy as np
    import envlight
    import scene_bench_blender as B
    inf = str(tmp_path / "inf.exr")
    subprocess.run(["oiiotool", "--pattern", "constant:color=1,0.9,0.8", "64x32", "3",
                    "--box:color=1e6,1e6,1e6:fill=1", "30,8,31,9",
                    "--box:color=1000,900,800:fill=1", "10,20,10,20", "-d", "half", "-o", inf],
                   check=True)
    sky = str(tmp_path / "sky.hdr")
    subprocess.run([ENVLIGHT, "convert", "-", sky, "--sky-width", "64"], check=True)
    assert B.reference_map_of(sky, str(tmp_path)) == (sky, 0)
    out, count = B.reference_map_of(inf, str(tmp_path))
    assert count == 4 and out != inf
    with envlight.load(inf) as m:
        original = m.pixels()
    with envlight.load(out) as m:
        assert m.info()["nonfinite_pixels"] == 0
        px = m.pixels()
    assert px.shape == original.shape == (32, 64, 3)
    assert (px[8:10, 30:32] == 1000).all()
    patch = np.zeros(px.shape[:2], bool)
    patch[8:10, 30:32] = True
    assert (px[~patch] == original[~patch]).all()
