"""Per-texel accuracy of the prefiltered maps (issue 30, item 5; docs/design.md, "Error
measures", the per-texel error): every texel that `envlight prefilter` writes, read back from
its PFM files, against the brute force at the texel's centre, in double over every pixel of
the map (envl_irradiance_exact, envl_prefilter_reference, through the Python package).

Maps (reduced: `--width 256`, read the same way here, so the brute force sums 32768 pixels a
texel): the built-in sky (a 0.53-degree sun), a hard synthetic case (a sun of 1e5 over a dark
sky and a darker ground, where a normal facing down is lit by almost nothing but the sun's
horizon), and rooitou_park_1k and studio_small_03_1k from ../shared/data (a strong sun; studio
lamps beside dark walls), SKIP when absent.

For the irradiance map and every level of roughness > 0, as cube faces (Blender's frame and
OpenGL's of the glTF frame), the vertical cross and lat-long:
  * the per-texel error, e = (Y - Y_exact) / max(Y_exact, 0.01 x the mean of Y_exact over the
    sphere), has an RMS (weighted by solid angle) of at most 0.5 % and a worst |e| of at most
    2 % (the issue's target). Before the fix (the faces resampled from lat-long maps, across
    the sun's horizon) the cube faces here were off by up to 15 % (the sky's irradiance), 92 %
    (rooitou_park's), 505 % (the hard case's) and 36-160 % at roughness 0.2-1;
  * prefilter.json states the figures the brute force gives here, within the references'
    stated accuracy: the irradiance's is within 1e-3 of max(E, the floor) at every texel (so an
    e within 1e-3 (1 + |e|)); the glossy reference's 1e-3 relative RMS (ENVL_GLOSSY_REFERENCE_
    TOLERANCE), its worst texel measured within 3e-3 of the brute force (docs/design.md): the
    RMS within 2e-3, the worst within 4e-3;
  * the cross holds the cube faces' texels, the same values.
The roughness-0 level (the map's mean over each texel, not a filtered value) is only checked
to state a figure.
"""
import ctypes
import json
import math
import os
import subprocess

import numpy as np
import pytest

import envlight
from envlight import _lib

ENVLIGHT = os.environ.get("ENVLIGHT", "")
SOURCE = os.environ.get("ENVL_SOURCE_DIR", os.path.join(os.path.dirname(__file__), ".."))
DATA = os.environ.get("ENVL_SHARED_DATA", os.path.join(SOURCE, "..", "shared", "data"))
TMP = os.environ.get("ENVL_TEST_TMP", "/tmp/envl_py_texel")
WIDTH = 256
DARK = 0.01
LUM = np.array([0.2126, 0.7152, 0.0722])

if not ENVLIGHT or not os.access(ENVLIGHT, os.X_OK):
    pytest.skip("SKIP: ENVLIGHT (the built envlight) is not set", allow_module_level=True)

# Blender's faces (docs/design.md, "Canonical frame"): centre, right, up
BLENDER = {"px": ((1, 0, 0), (0, -1, 0), (0, 0, 1)), "nx": ((-1, 0, 0), (0, 1, 0), (0, 0, 1)),
           "py": ((0, 1, 0), (1, 0, 0), (0, 0, 1)), "ny": ((0, -1, 0), (-1, 0, 0), (0, 0, 1)),
           "pz": ((0, 0, 1), (0, -1, 0), (-1, 0, 0)), "nz": ((0, 0, -1), (0, -1, 0), (1, 0, 0))}


def gl_direction(face, s, t):
    """OpenGL's cube face table inverted (s, t in [0, 1], t down the rows), glTF's frame,
    turned back to Blender's: glTF (x, y, z) is Blender (x, -z, y)."""
    sc, tc = 2 * s - 1, 2 * t - 1
    x, y, z = {"px": (1, -tc, -sc), "nx": (-1, -tc, sc), "py": (sc, 1, tc),
               "ny": (sc, -1, -tc), "pz": (sc, -tc, 1), "nz": (-sc, -tc, -1)}[face]
    return np.stack(np.broadcast_arrays(x, -z, y), -1)


def read_pfm(path):
    """(h, w, 3) float64, row 0 the top (PFM stores the bottom row first)."""
    with open(path, "rb") as f:
        assert f.readline() == b"PF\n"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        a = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return a[::-1].astype(np.float64)


def face_directions(n, face, frame):
    u = (np.arange(n) + 0.5) / n
    if frame == "gltf":
        s, t = np.meshgrid(u, u)
        d = gl_direction(face, s, t)
    else:
        c, rt, up = (np.array(v, float) for v in BLENDER[face])
        s, t = np.meshgrid(2 * u - 1, 1 - 2 * u)
        d = c + s[..., None] * rt + t[..., None] * up
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def face_solid_angles(n):
    """Exact: the alternating sum of atan2(s t, sqrt(1 + s^2 + t^2)) over a texel's corners."""
    e = 2 * np.arange(n + 1) / n - 1
    s, t = np.meshgrid(e, e)
    f = np.arctan2(s * t, np.sqrt(1 + s * s + t * t))
    return np.abs(f[1:, 1:] - f[1:, :-1] - f[:-1, 1:] + f[:-1, :-1])


def latlong_directions(w, h):
    u, v = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    phi, th = np.pi * (1 - 2 * u), np.pi * (0.5 - v)
    return np.stack([np.cos(th) * np.cos(phi), np.cos(th) * np.sin(phi), np.sin(th)], -1)


def latlong_solid_angles(w, h):
    z = np.sin(np.pi * (0.5 - np.arange(h + 1) / h))
    return np.repeat(((z[:-1] - z[1:]) * 2 * np.pi / w)[:, None], w, 1)


def brute_force(env, roughness, dirs):
    """The brute force at every direction: E (roughness None) or P(R)."""
    d = np.ascontiguousarray(dirs.reshape(-1, 3), dtype=np.float64)
    if roughness is None:
        return np.asarray(env.irradiance(d)).reshape(dirs.shape)
    out = np.zeros_like(d)
    pd = ctypes.POINTER(ctypes.c_double)
    with env._use() as handle:
        assert _lib.lib.envl_prefilter_reference(handle, roughness, len(d),
                                                d.ctypes.data_as(pd), out.ctypes.data_as(pd)) == 0
    return out.reshape(dirs.shape)


def texel_error(values, exact, omega, mean):
    """docs/design.md's per-texel error: (RMS weighted by solid angle, worst |e|)."""
    ya, ye = values @ LUM, exact @ LUM
    e = (ya - ye) / np.maximum(ye, DARK * mean)
    return math.sqrt(float((omega * e * e).sum() / omega.sum())), float(np.abs(e).max())


def write_hard_case(path):
    """A sun of 1e5 (0.5 degrees across, elevation 20 degrees) over a sky of 0.05 and a ground
    of 0.005: the sun holds almost all the light."""
    w, h = 1024, 512
    d = latlong_directions(w, h)
    sun = np.array([math.cos(math.radians(20)), 0.0, math.sin(math.radians(20))])
    img = np.where(d[..., 2:] > 0, 0.05, 0.005) * np.ones(3)
    img[d @ sun > math.cos(math.radians(0.25))] = (1e5, 0.9e5, 0.8e5)
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())


def maps():
    os.makedirs(TMP, exist_ok=True)
    hard = os.path.join(TMP, "hard_sun.pfm")
    write_hard_case(hard)
    found = [("sky", "-"), ("hard_sun", hard)]
    for name in ("rooitou_park_1k.hdr", "studio_small_03_1k.hdr"):
        path = os.path.join(DATA, "latlong_hdri", name)
        if os.path.exists(path):
            found.append((name, path))
        else:
            print("SKIP: %s is absent" % path)
    return found


def load(path):
    """The map as the command reads it below: 256 wide (the sky made at that width)."""
    return envlight.load(path, width=WIDTH) if path != "-" else envlight.sky(width=WIDTH)


def prefilter(path, out, *args):
    size = ["--width", str(WIDTH)] if path != "-" else ["--sky-width", str(WIDTH)]
    subprocess.run([ENVLIGHT, "prefilter", path, "-o", out, "--format", "pfm", "--quiet",
                    "--json"] + size + list(args), check=True, stdout=subprocess.DEVNULL)
    with open(os.path.join(out, "prefilter.json")) as f:
        return json.load(f)


def products(meta):
    """(name, roughness or None, its prefilter.json entry) of every map product."""
    out = [("irradiance", None, meta["irradiance"])] if "irradiance" in meta else []
    return out + [("specular r %.1f" % s["roughness"], s["roughness"], s)
                  for s in meta.get("specular", [])]


def check_product(env, out, name, roughness, entry, frame, fails):
    files = entry["files"]
    if entry["layout"] == "cube":
        vals, dirs, omega = [], [], []
        for fn in files:
            img = read_pfm(os.path.join(out, fn))
            face = fn.rsplit("_", 1)[1].split(".")[0]
            vals.append(img)
            dirs.append(face_directions(img.shape[0], face, frame))
            omega.append(face_solid_angles(img.shape[0]))
        vals, dirs, omega = np.stack(vals), np.stack(dirs), np.stack(omega)
    else:
        vals = read_pfm(os.path.join(out, files[0]))
        dirs = latlong_directions(vals.shape[1], vals.shape[0])
        omega = latlong_solid_angles(vals.shape[1], vals.shape[0])
    info = env.info()
    power = float(np.array(info["power"]) @ LUM)
    stated = entry["texel_error"]
    if roughness == 0:
        if not (stated["rms"] >= 0 and stated["worst"] >= 0):
            fails.append("%s: no per-texel figure stated: %s" % (name, stated))
        return
    exact = brute_force(env, roughness, dirs)
    mean = power / 4 if roughness is None else power / (4 * math.pi)
    rms, worst = texel_error(vals, exact, omega, mean)
    print("  %-16s %-6s rms %.3f %% worst %.3f %%   stated %.3f %% / %.3f %% (%d of %d texels)"
          % (name, entry["layout"], 100 * rms, 100 * worst, 100 * stated["rms"],
             100 * stated["worst"], stated["texels_measured"], stated["texels"]))
    if rms > 0.005 or worst > 0.02:
        fails.append("%s (%s): per-texel RMS %.3f %%, worst %.3f %% (at most 0.5 %%, 2 %%)"
                     % (name, entry["layout"], 100 * rms, 100 * worst))
    tol_rms, tol_worst = (1e-3 * (1 + rms), 1e-3 * (1 + worst)) if roughness is None \
        else (2e-3, 4e-3)
    if stated["texels_measured"] == stated["texels"] and (
            abs(stated["rms"] - rms) > tol_rms or abs(stated["worst"] - worst) > tol_worst):
        fails.append("%s (%s): stated %.4f / %.4f, the brute force %.4f / %.4f"
                     % (name, entry["layout"], stated["rms"], stated["worst"], rms, worst))


@pytest.mark.parametrize("name,path", maps())
def test_cube_faces_hold_the_exact_values(name, path):
    """Cube faces (Blender's frame), irradiance and the chain: the bound, and the figures."""
    out = os.path.join(TMP, name + "_cube")
    meta = prefilter(path, out, "--layout", "cube", "--size", "32", "--min-size", "32",
                     "--irradiance-size", "8")
    with load(path) as env:
        fails = []
        print(name)
        for pname, rough, entry in products(meta):
            assert entry["layout"] == "cube" and entry["resampled"] is False, entry
            check_product(env, out, pname, rough, entry, "blender", fails)
    assert not fails, fails


@pytest.mark.parametrize("name,path", maps()[:2])
def test_gl_faces_latlong_and_cross(name, path):
    """OpenGL's faces of the glTF frame and lat-long maps meet the same bound; the cross holds
    the cube faces' texels."""
    fails = []
    with load(path) as env:
        for layout, frame, extra in (("cube", "gltf", ["--frame", "gltf"]),
                                     ("latlong", "blender", ["--size", "64",
                                                             "--irradiance-size", "32"])):
            out = os.path.join(TMP, "%s_%s_%s" % (name, layout, frame))
            args = ["--layout", layout, "--roughness", "0.6,1"] + extra
            if layout == "cube":
                args += ["--size", "16", "--irradiance", "--irradiance-size", "8"]
            else:
                args += ["--irradiance"]
            meta = prefilter(path, out, *args)
            print(name, layout, frame)
            for pname, rough, entry in products(meta):
                check_product(env, out, pname, rough, entry, frame, fails)
    cube, cross = os.path.join(TMP, name + "_cube2"), os.path.join(TMP, name + "_cross")
    for layout, out in (("cube", cube), ("cross", cross)):
        prefilter(path, out, "--layout", layout, "--irradiance", "--irradiance-size", "8",
                  "--no-error")
    img = read_pfm(os.path.join(cross, "irradiance.pfm"))
    n = img.shape[1] // 3
    # the vertical cross: top; left, front, right; bottom; back turned half a turn
    cells = {"pz": (0, 1), "py": (1, 0), "px": (1, 1), "ny": (1, 2), "nz": (2, 1)}
    for face, (r, c) in cells.items():
        want = read_pfm(os.path.join(cube, "irradiance_%s.pfm" % face))
        if not np.array_equal(img[r * n:(r + 1) * n, c * n:(c + 1) * n], want):
            fails.append("the cross's %s is not the cube face's texels" % face)
    back = read_pfm(os.path.join(cube, "irradiance_nx.pfm"))[::-1, ::-1]
    if not np.array_equal(img[3 * n:, n:2 * n], back):
        fails.append("the cross's back face is not the cube face's texels turned")
    assert not fails, fails


def test_python_products_hold_the_layout_and_their_figures():
    """Envmap.prefilter(layout='cube'): the maps as a strip of six faces (F, 6 F, 3), each
    texel the same value the command writes into its face file (the same computation), and
    each product's texel_error as prefilter.json states it."""
    out = os.path.join(TMP, "python_cube")
    meta = prefilter("-", out, "--layout", "cube", "--size", "8", "--min-size", "32",
                     "--irradiance", "--irradiance-size", "8", "--roughness", "0.5")
    with load("-") as env, env.prefilter(roughness=[0.5], irradiance=True, measure=True,
                                         layout="cube", width=32, min_width=32,
                                         irradiance_width=32, irradiance_method="split") as p:
        for got, entry, stem in ((p.irradiance, meta["irradiance"], "irradiance"),
                                 (p.levels[0], meta["specular"][0], "specular_00")):
            assert got["layout"] == "hstrip" and (got["width"], got["height"]) == (48, 8)
            rgb = np.asarray(got["rgb"])
            assert rgb.shape == (8, 48, 3)
            for k, face in enumerate(("px", "nx", "py", "ny", "pz", "nz")):
                want = read_pfm(os.path.join(out, "%s_%s.pfm" % (stem, face)))
                assert np.array_equal(rgb[:, 8 * k:8 * k + 8], want), (stem, face)
            t = got["texel_error"]
            assert (t["texels_measured"], t["texels"]) == (384, 384)
            assert t["rms"] == pytest.approx(entry["texel_error"]["rms"], rel=1e-6)
            assert t["worst"] == pytest.approx(entry["texel_error"]["worst"], rel=1e-6)
