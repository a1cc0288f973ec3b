"""The Python wheel (issue 16): installed offline into a fresh venv, `import envlight` works
with no environment variable, from a folder outside the source tree, loads the library inside the
package, and gives the build's results (the built-in sky's SH and fitted lights, to the bit).

Each install form in its own fresh venv (Debian's `python3 -m venv`: pip 23.0.1, setuptools 66,
no `wheel` package), with pip's --no-index: the wheel CMake writes (<build>/envlight-*.whl),
`pip install ./py_shim` (build isolation; the in-tree backend needs nothing) and the same with
--no-build-isolation. Skipped (77) only when python3-venv is not installed (no ensurepip).

ctest sets ENVL_BUILD_DIR, ENVL_SOURCE_DIR and ENVL_ADDON_LIBRARY; this process imports
envlight from the source tree with ENVLIGHT_LIBRARY (the full build) for the reference."""
import base64
import glob
import hashlib
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile

import pytest

if importlib.util.find_spec("ensurepip") is None:
    pytest.skip("SKIP: python3-venv is not installed (no ensurepip: `python3 -m venv` cannot "
                "make a venv with pip; apt-get install python3-venv)", allow_module_level=True)

import envlight  # noqa: E402

SRC = os.environ.get("ENVL_SOURCE_DIR") or os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))
BUILD = os.environ.get("ENVL_BUILD_DIR") or os.path.join(SRC, "build")
ADDON_LIBRARY = os.environ.get("ENVL_ADDON_LIBRARY") or os.path.join(BUILD, "addon-lib",
                                                                      "libenvlight.so")
WHEEL = "envlight-%s-py3-none-linux_x86_64.whl" % envlight.__version__
C_RUNTIME = {"linux-vdso.so.1", "ld-linux-x86-64.so.2", "libc.so.6", "libm.so.6",
             "libpthread.so.0"}

# Run in the venv: the sky's SH irradiance and 4 fitted lights, as JSON (the venv has no numpy).
CHILD = r'''
import json, envlight
with envlight.sky(width=256) as s, s.sh(2) as sh, s.lights(4) as res:
    out = {"file": envlight.__file__, "library": envlight.library_path,
           "sh": [[float(v) for v in c] for c in sh.irradiance],
           "lights": [[float(v) for v in list(l.direction) + list(l.rgb) + [l.angle]]
                      for l in res.lights],
           "error": res.summary["diffuse_error"]}
print(json.dumps(out))
'''


def clean_env(**extra):
    """os.environ without ENVLIGHT_*, ENVL_* and Python path variables; offline pip."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ENVLIGHT", "ENVL_"))
           and k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env.update(PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", **extra)
    return env


def run(cmd, cwd, env):
    r = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    assert r.returncode == 0, "%s\n%s%s" % (cmd, r.stdout, r.stderr)
    return r.stdout


def reference():
    with envlight.sky(width=256) as s, s.sh(2) as sh, s.lights(4) as res:
        return {"sh": [[float(v) for v in c] for c in sh.irradiance],
                "lights": [[float(v) for v in list(l.direction) + list(l.rgb) + [l.angle]]
                           for l in res.lights],
                "error": res.summary["diffuse_error"]}


@pytest.fixture
def venv():
    """A fresh venv in a temporary folder outside the source tree (and the build folder, which
    may be inside it): (python, folder)."""
    d = os.path.realpath(tempfile.mkdtemp(prefix="envl-venv-"))
    assert not d.startswith(os.path.realpath(SRC) + os.sep)
    try:
        run(["/usr/bin/python3", "-m", "venv", os.path.join(d, "venv")], d, clean_env())
        yield os.path.join(d, "venv", "bin", "python"), d
    finally:
        shutil.rmtree(d, ignore_errors=True)


def test_the_built_wheel():
    path = os.path.join(BUILD, WHEEL)
    assert os.path.exists(path), "%s: not written by the build (envlight_wheel)" % path
    info = "envlight-%s.dist-info/" % envlight.__version__
    with zipfile.ZipFile(path) as z:
        names = sorted(z.namelist())
        assert names == sorted(["envlight/__init__.py", "envlight/_args.py", "envlight/_lib.py",
                                "envlight/libenvlight.so.1"] +
                               [info + n for n in ("METADATA", "WHEEL", "RECORD",
                                                   "top_level.txt")])
        wheel = z.read(info + "WHEEL").decode()
        assert "Root-Is-Purelib: false\n" in wheel and "Tag: py3-none-linux_x86_64\n" in wheel
        meta = z.read(info + "METADATA").decode()
        assert "Name: envlight\n" in meta and "Version: %s\n" % envlight.__version__ in meta
        record = z.read(info + "RECORD").decode().splitlines()
        assert len(record) == len(names) and info + "RECORD,," in record
        for line in record:
            name, digest, size = line.rsplit(",", 2)
            if name == info + "RECORD":
                continue
            data = z.read(name)
            want = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=")
            assert digest == "sha256=" + want.decode() and int(size) == len(data), name
        lib = z.read("envlight/libenvlight.so.1")
    # the add-on's library (no OpenEXR, no libpng), which needs only the C runtime
    with open(ADDON_LIBRARY, "rb") as f:
        assert lib == f.read()
    ldd = subprocess.run(["ldd", ADDON_LIBRARY], capture_output=True, text=True).stdout
    assert {os.path.basename(line.split()[0]) for line in ldd.splitlines() if line.strip()} \
        <= C_RUNTIME, ldd


@pytest.mark.parametrize("form", ["wheel", "source", "source-no-isolation"])
def test_install_in_a_fresh_venv(venv, form):
    python, folder = venv
    if form == "wheel":
        args, env = [os.path.join(BUILD, WHEEL)], clean_env()
    else:
        # the backend takes this build's add-on library (cmake --build: up to date, a no-op)
        args, env = [os.path.join(SRC, "py_shim")], clean_env(ENVLIGHT_BUILD_DIR=BUILD)
        if form == "source-no-isolation":
            args.insert(0, "--no-build-isolation")
    run([python, "-m", "pip", "install", "--no-index"] + args, folder, env)
    out = json.loads(run([python, "-c", CHILD], folder, clean_env()))
    package = os.path.dirname(out["file"])
    assert package.startswith(os.path.join(folder, "venv", "lib")), out["file"]
    assert out["library"] == os.path.join(package, "libenvlight.so.1")
    with open(out["library"], "rb") as a, open(ADDON_LIBRARY, "rb") as b:
        assert a.read() == b.read()
    ref = reference()
    assert len(ref["sh"]) == 9 and len(ref["lights"]) == 4  # the fit takes all 4 on this sky
    assert out["sh"] == ref["sh"] and out["lights"] == ref["lights"]
    assert out["error"] == ref["error"]


def test_source_outside_the_repository_needs_the_library(venv):
    """A copy of py_shim away from the repository: pip fails, naming how to give the library."""
    python, folder = venv
    copy = os.path.join(folder, "py_shim")
    shutil.copytree(os.path.join(SRC, "py_shim"), copy,
                    ignore=shutil.ignore_patterns("__pycache__"))
    r = subprocess.run([python, "-m", "pip", "install", "--no-index", copy], cwd=folder,
                       env=clean_env(), capture_output=True, text=True)
    assert r.returncode != 0
    assert re.search(r"not inside the envlight repository: name the library with "
                     r"ENVLIGHT_WHEEL_LIBRARY=SO", r.stdout + r.stderr), r.stdout + r.stderr
    # pip runs the backend in py_shim/: a relative path is refused, not read from there
    r = subprocess.run([python, "-m", "pip", "install", "--no-index", copy], cwd=folder,
                       env=clean_env(ENVLIGHT_WHEEL_LIBRARY="libenvlight.so"),
                       capture_output=True, text=True)
    assert r.returncode != 0
    assert "libenvlight.so: give an absolute path" in r.stdout + r.stderr, r.stdout + r.stderr
    run([python, "-m", "pip", "install", "--no-index", copy], folder,
        clean_env(ENVLIGHT_WHEEL_LIBRARY=ADDON_LIBRARY))
    out = json.loads(run([python, "-c", CHILD], folder, clean_env()))
    assert out["sh"] == reference()["sh"]
    assert not glob.glob(os.path.join(copy, "envlight", "*.so*"))  # nothing written in the tree
