"""The Blender add-on's copy of libenvlight (CMake's envlight_addon target, issue 14), built
without OpenEXR and libpng: `ldd` lists only the C runtime; through the Python shim it refuses
.exr / .png (reading, writing, exporting) with ENVL_ERR_UNSUPPORTED and a message that says
why, without crashing, and still reads and writes .hdr / .pfm; scripts/blender_addon_zip.py
ships it by default.

The library: $ENVL_ADDON_LIBRARY (tests/CMakeLists.txt sets it), else
$ENVL_BUILD_DIR/addon-lib/libenvlight.so; absent: skipped. The shim runs in a child Python
with ENVLIGHT_LIBRARY pointing at it (this process may hold the full library)."""
import json
import os
import subprocess
import sys
import zipfile

import pytest

pytest.importorskip("numpy", reason="SKIP: numpy is not installed (python3-numpy)")

SRC = os.environ.get("ENVL_SOURCE_DIR") or os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))
BUILD = os.environ.get("ENVL_BUILD_DIR") or os.path.join(SRC, "build")
LIBRARY = os.environ.get("ENVL_ADDON_LIBRARY") or os.path.join(BUILD, "addon-lib",
                                                                "libenvlight.so")
# all that `ldd` may list (x86-64 glibc): the C runtime, no libgcc_s
C_RUNTIME = {"linux-vdso.so.1", "ld-linux-x86-64.so.2", "libc.so.6", "libm.so.6",
             "libpthread.so.0"}
NO_EXR = "this libenvlight was built without OpenEXR (the Blender add-on's build); use .hdr or .pfm"
NO_PNG = "this libenvlight was built without libpng (the Blender add-on's build); use .hdr or .pfm"

if not os.path.exists(LIBRARY):
    pytest.skip("SKIP: %s absent: build the add-on's library first (cmake --build build "
                "--target envlight_addon)" % LIBRARY, allow_module_level=True)

# Each call's outcome: "ok" or [error name, message]; written as JSON to argv[2].
CHILD = r'''
import json, os, sys
import numpy as np
import envlight
from envlight import _lib
work, out = sys.argv[1:3]
px = np.full((8, 16, 3), 0.5, np.float32)
px[2, 3] = (50.0, 40.0, 30.0)
r = {}


def attempt(key, fn):
    try:
        fn()
        r[key] = "ok"
    except envlight.Error as e:
        r[key] = [e.name, e.message]


p = lambda name: os.path.join(work, name)
attempt("save_exr", lambda: envlight.save_image(p("a.exr"), px))
attempt("save_exr_by_format", lambda: envlight.save_image(p("b.img"), px, format="exr"))
attempt("save_hdr", lambda: envlight.save_image(p("a.hdr"), px))
attempt("save_pfm", lambda: envlight.save_image(p("a.pfm"), px))
with open(p("fake.exr"), "wb") as f:  # OpenEXR's magic number, then anything
    f.write(b"\x76\x2f\x31\x01" + bytes(400))
attempt("load_exr", lambda: envlight.load(p("fake.exr")).close())
attempt("load_hdr", lambda: envlight.load(p("a.hdr")).close())
attempt("load_pfm", lambda: envlight.load(p("a.pfm")).close())
pf = _lib.FUNCTIONS["envl_png_save_srgb"][1][1]
buf = np.ascontiguousarray(px.ravel())
ptr = buf.ctypes.data_as(pf)


def png(rc):
    if rc:
        raise envlight.Error(rc, _lib._str(_lib.lib.envl_result_name(rc)),
                             _lib._str(_lib.lib.envl_last_error()))


attempt("png_srgb", lambda: png(_lib.lib.envl_png_save_srgb(p("a.png").encode(), ptr, 16, 8)))
attempt("png_rgbm", lambda: png(_lib.lib.envl_png_save_rgbm(p("b.png").encode(), ptr, 16, 8,
                                                            6.0)))
with envlight.load(p("a.hdr")) as env, env.prefilter(irradiance=True) as prod:
    for fmt in ("exr", "rgbm-png", "hdr"):
        d = p("export-" + fmt)
        os.makedirs(d)
        attempt("export_" + fmt, lambda: prod.export(d, format=fmt))
        r["files_" + fmt] = sorted(os.listdir(d))
r["library"] = _lib.library_path
r["files"] = sorted(os.listdir(work))
with open(out, "w") as f:
    json.dump(r, f)
'''


def test_only_the_c_runtime():
    out = subprocess.run(["ldd", LIBRARY], capture_output=True, text=True, check=True).stdout
    names = [os.path.basename(line.split()[0]) for line in out.splitlines() if line.strip()]
    print(out)
    assert set(names) <= C_RUNTIME and "libc.so.6" in names, out


def test_refuses_exr_and_png_with_a_clear_message(tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    out = tmp_path / "result.json"
    env = dict(os.environ, ENVLIGHT_LIBRARY=LIBRARY,
               PYTHONPATH=os.path.join(SRC, "py_shim"))
    p = subprocess.run([sys.executable, "-c", CHILD, str(work), str(out)], env=env,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr  # no crash, every failure an envlight.Error
    r = json.loads(out.read_text())
    assert os.path.realpath(r["library"]) == os.path.realpath(LIBRARY), r
    unsupported = lambda path, text: ["ENVL_ERR_UNSUPPORTED", "%s: %s" % (path, text)]
    assert r["save_exr"] == unsupported(work / "a.exr", NO_EXR), r
    assert r["save_exr_by_format"] == unsupported(work / "b.img", NO_EXR), r
    assert r["load_exr"] == unsupported(work / "fake.exr", NO_EXR), r
    assert r["png_srgb"] == unsupported(work / "a.png", NO_PNG), r
    assert r["png_rgbm"] == unsupported(work / "b.png", NO_PNG), r
    assert r["export_exr"] == unsupported(work / "export-exr", NO_EXR), r
    assert r["export_rgbm-png"] == unsupported(work / "export-rgbm-png", NO_PNG), r
    # refused before anything is written: no file, no temporary left behind
    assert r["files"] == ["a.hdr", "a.pfm", "export-exr", "export-hdr", "export-rgbm-png",
                          "fake.exr"], r
    assert r["files_exr"] == [] and r["files_rgbm-png"] == [], r
    # the other formats work
    for key in ("save_hdr", "save_pfm", "load_hdr", "load_pfm", "export_hdr"):
        assert r[key] == "ok", (key, r)
    assert "irradiance.hdr" in r["files_hdr"], r


def test_the_zip_ships_it_by_default(tmp_path):
    """scripts/blender_addon_zip.py without --library: <build-dir>/addon-lib/libenvlight.so."""
    build = tmp_path / "build"
    (build / "addon-lib").mkdir(parents=True)
    os.symlink(os.path.realpath(LIBRARY), build / "addon-lib" / "libenvlight.so")
    out = tmp_path / "addon.zip"
    p = subprocess.run([sys.executable, os.path.join(SRC, "scripts", "blender_addon_zip.py"),
                        "--build-dir", str(build), "--no-blender", "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "note:" not in p.stderr, p.stderr  # nothing beyond the C runtime to name
    with zipfile.ZipFile(out) as z, open(LIBRARY, "rb") as f:
        assert z.read("envlight_addon/lib/libenvlight.so.1") == f.read()
