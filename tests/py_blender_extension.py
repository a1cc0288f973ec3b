"""The add-on as a Blender 4.2+ extension (issue 14), in Debian 13's Blender 4.3 (its own
OpenEXR, libpng and libstdc++): scripts/blender_addon_zip.py builds the zip with
`blender --command extension build` around the add-on's libenvlight.so, `extension validate`
accepts it, `extension install-file -r user_default -e` installs and enables it, the operator
and World.envlight are registered, the library is loaded from the extension's folder, and
Create Lights works (an HDR written by the library inside Blender, the residual world) with a
broken `envlight` package first on sys.path. The same zip also installs the legacy way
in Blender 3.4 (/usr/bin/blender, when present).

The library in the zip is the add-on's build (CMake's envlight_addon target,
<build>/addon-lib/libenvlight.so): without OpenEXR and libpng, so it is self-contained (issue
14): `ldd` lists only the C runtime, checked here name by name, and the build made on Debian 12
loads and runs in Debian 13's Blender 4.3 (a different OpenEXR there).

The Blender 4: $ENVL_BLENDER4, else scripts/blender4.sh's wrapper
/var/cache/envlight/trixie-root/run-blender (needs root). The library: $ENVL_ADDON_LIBRARY
(tests/CMakeLists.txt sets it to the envlight_addon target's file), else
$ENVL_BUILD_DIR/addon-lib/libenvlight.so. Either absent or unusable: the module is skipped
(SKIP: ...)."""
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile

import pytest

SRC = os.environ.get("ENVL_SOURCE_DIR") or os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))
BUILD = os.environ.get("ENVL_BUILD_DIR") or os.path.join(SRC, "build")
TMP = os.path.abspath(os.environ.get("ENVL_TEST_TMP") or
                      os.path.join(BUILD, "tests", "tmp", "py_blender_extension"))
BLENDER4 = os.environ.get("ENVL_BLENDER4") or "/var/cache/envlight/trixie-root/run-blender"
LIBRARY = os.environ.get("ENVL_ADDON_LIBRARY") or os.path.join(BUILD, "addon-lib",
                                                                "libenvlight.so")
MODULE = "bl_ext.user_default.envlight"  # the manifest's id in the user_default repository
# all that `ldd` may list for the add-on's library (x86-64 glibc): the C runtime, no libgcc_s
C_RUNTIME = {"linux-vdso.so.1", "ld-linux-x86-64.so.2", "libc.so.6", "libm.so.6",
             "libpthread.so.0"}

if not os.access(BLENDER4, os.X_OK):
    pytest.skip("SKIP: %s absent (Debian 13's Blender 4.3: `sudo bash scripts/blender4.sh`, "
                "or set ENVL_BLENDER4)" % BLENDER4, allow_module_level=True)
_v = subprocess.run([BLENDER4, "--version"], capture_output=True, text=True)
_m = re.search(r"^Blender (\d+)\.(\d+)", _v.stdout, re.M)
if _v.returncode != 0 or not _m:
    pytest.skip("SKIP: %s does not run (exit status %d: %s)" % (
        BLENDER4, _v.returncode, _v.stderr.strip()[-300:]), allow_module_level=True)
if (int(_m.group(1)), int(_m.group(2))) < (4, 2):
    pytest.skip("SKIP: %s is Blender %s.%s, extensions need 4.2+" % (
        BLENDER4, _m.group(1), _m.group(2)), allow_module_level=True)
if not os.path.exists(LIBRARY):
    pytest.skip("SKIP: %s absent: build the add-on's library first (cmake --build build "
                "--target envlight_addon)" % LIBRARY, allow_module_level=True)

# Runs inside Blender 4.3 after `extension install-file -e`: first whether the library in the
# extension's folder loads at all (if not: "load_error" and the libraries ldd reports "not
# found"); then the extension must be enabled from the saved preferences; then, with a broken
# `envlight` first on sys.path, it is enabled afresh and Create Lights runs on an HDR written
# through the add-on's own library (built without OpenEXR: .hdr, not .exr).
CHECK = r'''
import ctypes, json, os, subprocess, sys
import addon_utils, bpy
out, broken, work = sys.argv[sys.argv.index("--") + 1:]
mod = %(module)r


def load_error(lib):
    try:
        ctypes.CDLL(lib)
        return None
    except OSError as e:
        try:
            ldd = subprocess.run(["ldd", lib], capture_output=True, text=True).stdout
        except OSError:
            ldd = ""
        return {"library": lib, "load_error": str(e), "missing": [
            line.split()[0] for line in ldd.splitlines() if "not found" in line]}


def check():
    r = {"enabled_at_start": mod in bpy.context.preferences.addons}
    addon_utils.disable(mod)
    for name in [n for n in sys.modules if n == mod or n.startswith(mod + ".")]:
        del sys.modules[name]
    sys.path.insert(0, broken)  # a global `envlight` that must never be imported
    addon_utils.enable(mod, default_set=True)
    r["enabled"] = mod in bpy.context.preferences.addons
    r["world_property"] = hasattr(bpy.types.World, "envlight")
    r["operator"] = hasattr(bpy.types, "ENVLIGHT_OT_create_lights")
    pkg_mod = sys.modules[mod]
    r["extension_dir"] = os.path.dirname(os.path.realpath(pkg_mod.__file__))
    shim = pkg_mod.core.shim()
    r["shim_file"] = os.path.realpath(shim.__file__)
    r["library_path"] = os.path.realpath(shim.library_path)
    # a one-spot HDR, written as Radiance .hdr by the library inside Blender
    import numpy as np
    h, w = 32, 64
    px = np.full((h, w, 3), 0.05, np.float32)
    px[8:11, 20:23] = 200.0
    hdr = os.path.join(work, "spot.hdr")
    shim.save_image(hdr, px)
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("W")
    s = scene.world.envlight
    s.source, s.filepath, s.count = "FILE", hdr, 2
    # the residual world, whatever the scene would pick: its image, made in Blender's memory
    # from the library's remainder, is what once needed OpenEXR in the library
    if hasattr(s, "read_scene"):
        s.read_scene = False
    s.world_mode = "RESIDUAL"
    r["operator_result"] = sorted(bpy.ops.envlight.create_lights())
    r["suns"] = len([o for o in bpy.data.objects if o.type == "LIGHT" and o.get("envlight")])
    r["residual_images"] = [i.name for i in bpy.data.images if i.get("envlight")]
    r["global_envlight_imported"] = "envlight" in sys.modules
    return r


# Preferences > Get Extensions > Install from Disk runs this operator (its file browser
# sets filepath; enable_on_install is the dialog's "Enable Add-on" box)
zip_path = os.environ.get("ENVL_INSTALL_FROM_DISK")
if zip_path:
    installed = sorted(bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True))
# the installed library first: built on Debian 12, it must load in Debian 13 (issue 14)
r = load_error(os.path.join(bpy.utils.user_resource("EXTENSIONS", path="user_default"),
                            "envlight", "lib", "libenvlight.so.1")) or check()
if zip_path:
    r["install_from_disk"] = installed
with open(out, "w") as f:
    json.dump(r, f)
'''

# Blender 3.4: the same zip through Preferences > Add-ons > Install (module envlight_addon).
CHECK_LEGACY = r'''
import json, os, sys
import bpy
out, zip_path = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True)
bpy.ops.preferences.addon_enable(module="envlight_addon")
import envlight_addon
shim = envlight_addon.core.shim()
with open(out, "w") as f:
    json.dump({"enabled": "envlight_addon" in bpy.context.preferences.addons,
               "world_property": hasattr(bpy.types.World, "envlight"),
               "operator": hasattr(bpy.types, "ENVLIGHT_OT_create_lights"),
               "addon_dir": os.path.dirname(os.path.realpath(envlight_addon.__file__)),
               "library_path": os.path.realpath(shim.library_path),
               "version": bpy.app.version_string}, f)
'''


def blender_env(folder):
    """The environment for a Blender with its own user folders and no ENVLIGHT_LIBRARY."""
    env = {k: v for k, v in os.environ.items() if k not in ("ENVLIGHT_LIBRARY", "PYTHONPATH")}
    env.update(BLENDER_USER_RESOURCES=os.path.join(folder, "resources"),
               BLENDER_USER_SCRIPTS=os.path.join(folder, "scripts"),
               BLENDER_USER_CONFIG=os.path.join(folder, "config"))
    return env


def ldd_names(lib):
    """The libraries `ldd lib` lists (basenames; the sonames when not found)."""
    out = run(["ldd", lib]).stdout
    names = [line.split()[0] for line in out.splitlines() if line.strip()]
    assert names, out
    return [os.path.basename(n) for n in names]


def run(cmd, **kw):
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300, **kw)
    assert p.returncode == 0, "%s: exit status %d\n%s\n%s" % (
        " ".join(cmd), p.returncode, p.stdout[-3000:], p.stderr[-3000:])
    return p


@pytest.fixture(scope="module")
def addon_zip():
    shutil.rmtree(TMP, ignore_errors=True)
    os.makedirs(TMP)
    out = os.path.join(TMP, "envlight_addon.zip")
    p = run([sys.executable, os.path.join(SRC, "scripts", "blender_addon_zip.py"),
             "--library", LIBRARY, "--blender", BLENDER4, "-o", out])
    return out, p.stderr


def test_zip_is_built_by_blender_and_validated(addon_zip):
    path, log = addon_zip
    assert "extension build: building: envlight-" in log, log
    assert "extension validate: Success" in log, log
    # the script names what the library needs beyond the C runtime: nothing here
    assert "note: the bundled library needs" not in log, log
    with zipfile.ZipFile(path) as z:
        names = sorted(z.namelist())
    # one top folder (Blender 3.x installs it as the module envlight_addon; 4.2+ accepts it)
    # holding the add-on's modules, the manifest, the shim and the library
    addon = [n for n in os.listdir(os.path.join(SRC, "plugin", "envlight_addon"))
             if n.endswith(".py")]
    shim = ["envlight/" + n for n in os.listdir(os.path.join(SRC, "py_shim", "envlight"))
            if n.endswith(".py")]
    assert {"__init__.py", "core.py"} <= set(addon) and "envlight/_lib.py" in shim
    assert names == sorted("envlight_addon/" + n for n in addon + shim + [
        "blender_manifest.toml", "lib/libenvlight.so.1"]), names
    p = run([BLENDER4, "--command", "extension", "validate", path])
    assert "Success" in p.stdout + p.stderr and "FATAL_ERROR" not in p.stdout + p.stderr


def test_zip_script_fails_loudly_on_an_invalid_extension(addon_zip):
    """What the script relies on: validate fails (exit status != 0) on a manifest Blender
    rejects, e.g. the 79-character permission reason this manifest once had."""
    path, _ = addon_zip
    bad = os.path.join(TMP, "invalid.zip")
    with zipfile.ZipFile(path) as zin, zipfile.ZipFile(bad, "w") as zout:
        for info in zin.infolist():
            data = zin.read(info)
            if info.filename.endswith("blender_manifest.toml"):
                data = re.sub(rb'files = "[^"]*"', b'files = "' + b"x" * 79 + b'"', data)
            zout.writestr(info, data)
    p = subprocess.run([BLENDER4, "--command", "extension", "validate", bad],
                       capture_output=True, text=True)
    assert p.returncode != 0 and "64 characters" in p.stdout + p.stderr, p.stdout + p.stderr


def test_no_fallback_to_a_global_envlight():
    """The add-on imports only its own copy of the shim (relative imports), never `envlight`
    from sys.path, which could be another version with another library."""
    import ast
    for name in ("__init__.py", "core.py"):
        with open(os.path.join(SRC, "plugin", "envlight_addon", name)) as f:
            tree = ast.parse(f.read())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                assert not [a for a in node.names if a.name.split(".")[0] == "envlight"], name
            if isinstance(node, ast.ImportFrom) and node.level == 0:
                assert (node.module or "").split(".")[0] != "envlight", name


def test_library_needs_only_the_c_runtime(addon_zip):
    path, _ = addon_zip
    folder = os.path.join(TMP, "unpacked")
    with zipfile.ZipFile(path) as z:
        z.extractall(folder)
    lib = os.path.join(folder, "envlight_addon", "lib", "libenvlight.so.1")
    with open(lib, "rb") as f, open(LIBRARY, "rb") as g:
        assert f.read() == g.read()
    names = ldd_names(lib)
    print("ldd:", names)
    assert set(names) <= C_RUNTIME and "libc.so.6" in names, names
    # only envl_* is exported
    if shutil.which("nm"):
        syms = run(["nm", "-D", "--defined-only", lib]).stdout.split()[2::3]
        assert syms and not [s for s in syms if not s.startswith(("envl_", "_init", "_fini"))]


def check_installed(name, install=None, from_disk=None):
    """Blender 4 with the user folders TMP/name, after `install` (a command run there first):
    the CHECK script (from_disk: the zip it first installs as Install from Disk does), with a
    broken global `envlight` first on sys.path. -> (CHECK's result, the Blender process),
    having asserted what every install must give: the library built on Debian 12 loads in
    Debian 13's Blender (self-contained), the extension in user_default, enabled, its own
    shim and library, Create Lights working, the global `envlight` never imported."""
    folder = os.path.join(TMP, name)
    work = os.path.join(folder, "work")
    broken = os.path.join(folder, "broken")
    os.makedirs(os.path.join(broken, "envlight"))
    os.makedirs(work)
    with open(os.path.join(broken, "envlight", "__init__.py"), "w") as f:
        f.write('raise ImportError("the global envlight package must not be used")\n')
    script = os.path.join(folder, "check.py")
    with open(script, "w") as f:
        f.write(CHECK % {"module": MODULE})
    env = blender_env(folder)
    if install:
        run([BLENDER4] + install, env=env)
    if from_disk:
        env["ENVL_INSTALL_FROM_DISK"] = from_disk
    out = os.path.join(folder, "result.json")
    p = run([BLENDER4, "-b", "--python-exit-code", "1", "--python", script, "--", out, broken,
             work], env=env)
    with open(out) as f:
        r = json.load(f)
    print(json.dumps(r, indent=1))
    assert "load_error" not in r, r
    ext = r["extension_dir"]
    assert ext.endswith("/extensions/user_default/envlight"), r
    assert r["enabled_at_start"] and r["enabled"], r
    assert r["world_property"] and r["operator"], r
    assert r["shim_file"] == os.path.join(ext, "envlight", "__init__.py"), r
    assert r["library_path"] == os.path.join(ext, "lib", "libenvlight.so.1"), r
    assert r["operator_result"] == ["FINISHED"], (r, p.stderr[-2000:])
    assert r["suns"] >= 1 and r["residual_images"], r
    assert not r["global_envlight_imported"], r
    return r, p


def test_install_file_enable_and_run_in_blender_4(addon_zip):
    """`blender --command extension install-file -r user_default -e`: enabled at start
    (install-file -e saves it enabled), and all check_installed asks."""
    path, _ = addon_zip
    check_installed("b4", install=["--command", "extension", "install-file", "-r",
                                   "user_default", "-e", path])


def test_install_from_disk_in_blender_4(addon_zip):
    """Preferences > Get Extensions > Install from Disk (the operator its button runs,
    extensions.package_install_files, with "Enable Add-on" ticked) in a fresh user folder:
    installed into user_default, enabled at once, and all check_installed asks."""
    path, _ = addon_zip
    r, p = check_installed("b4_disk", from_disk=path)
    assert r["install_from_disk"] == ["FINISHED"], (r, p.stdout[-2000:])


def test_same_zip_installs_the_legacy_way_in_blender_3(addon_zip):
    blender3 = "/usr/bin/blender"
    if not os.access(blender3, os.X_OK):
        pytest.skip("SKIP: %s absent (Debian 12's Blender 3.4)" % blender3)
    path, _ = addon_zip
    folder = os.path.join(TMP, "b3")
    os.makedirs(folder, exist_ok=True)
    script = os.path.join(folder, "check.py")
    with open(script, "w") as f:
        f.write(CHECK_LEGACY)
    out = os.path.join(folder, "result.json")
    run([blender3, "-b", "--factory-startup", "--python-exit-code", "1", "--python", script,
         "--", out, path], env=blender_env(folder))
    with open(out) as f:
        r = json.load(f)
    assert r["enabled"] and r["world_property"] and r["operator"], r
    assert r["library_path"] == os.path.join(r["addon_dir"], "lib", "libenvlight.so.1"), r
