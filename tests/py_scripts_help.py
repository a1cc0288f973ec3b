"""Every Python script of the repository that has a command line (issue 19, item 8: a
benchmark's --help once started the benchmark) answers --help with its usage, exit status 0,
at once, having run nothing: under python3, and the scripts that run inside Blender also as
Blender runs them (`blender -b --python SCRIPT -- --help`). Every scripts/*.py but the modules
the others import is a command; plugin/, py_shim/ and povray_include/ have none (checked) but
py_shim/backend/envlight_wheel.py (ELSEWHERE)."""
import glob
import os
import shutil
import subprocess
import sys
import time

import pytest

SOURCE = os.environ.get("ENVL_SOURCE_DIR", os.path.join(os.path.dirname(__file__), ".."))
TMP = os.environ.get("ENVL_TEST_TMP", "/tmp/envl_py_scripts_help")
# Generous for a loaded machine; the work these scripts do takes minutes.
TIMEOUT = 60
BLENDER_TIMEOUT = 300


def has_main(path):
    with open(path) as f:
        return 'if __name__ == "__main__"' in f.read()


def runs_in_blender(path):
    with open(path) as f:
        return "import bpy" in f.read()


# Modules the scripts import, with no command line of their own; every other scripts/*.py is a
# command (a new one joins the test by itself).
MODULES = {"blender_scene.py", "scene_bench_pov.py", "blender_help.py"}
# Commands outside scripts/: the Python package's build backend (CMake runs it to write the
# wheel).
ELSEWHERE = [os.path.join(SOURCE, "py_shim", "backend", "envlight_wheel.py")]
SCRIPTS = sorted(p for p in glob.glob(os.path.join(SOURCE, "scripts", "*.py"))
                 if os.path.basename(p) not in MODULES) + ELSEWHERE
BLENDER_SCRIPTS = [p for p in SCRIPTS if runs_in_blender(p)]
SHELL_SCRIPTS = sorted(glob.glob(os.path.join(SOURCE, "scripts", "*.sh")))


def test_the_scripts_are_found():
    assert {"build.sh", "main_job.sh", "valgrind.sh"} <= {
        os.path.basename(p) for p in SHELL_SCRIPTS}
    names = {os.path.basename(p) for p in SCRIPTS}
    assert {"request_bench.py", "scene_bench.py", "blender_addon_zip.py",
            "blender_addon_check.py", "blender_hard_cases.py",
            "scene_bench_blender.py"} <= names, names
    assert {"blender_addon_check.py", "blender_hard_cases.py", "scene_bench_blender.py"} <= {
        os.path.basename(p) for p in BLENDER_SCRIPTS}
    modules = [os.path.join(SOURCE, "scripts", m) for m in MODULES]
    others = glob.glob(os.path.join(SOURCE, "plugin", "**", "*.py"), recursive=True) + \
        glob.glob(os.path.join(SOURCE, "py_shim", "**", "*.py"), recursive=True) + \
        glob.glob(os.path.join(SOURCE, "povray_include", "**", "*.py"), recursive=True)
    assert all(has_main(p) for p in ELSEWHERE)
    assert not [p for p in modules + others if os.path.exists(p) and has_main(p)
                and p not in ELSEWHERE], \
        "a command line in a module: add it to the scripts this test runs"


def workdir(name):
    d = os.path.join(TMP, name)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    return d


@pytest.mark.parametrize("script", SCRIPTS, ids=os.path.basename)
def test_help_under_python(script):
    cwd = workdir(os.path.basename(script) + ".python")
    env = dict(os.environ, ENVL_LIBRARY="/nonexistent/libenvlight.so",
               ENVLIGHT_LIBRARY="/nonexistent/libenvlight.so", ENVLIGHT="/nonexistent/envlight")
    t = time.monotonic()
    r = subprocess.run([sys.executable, script, "--help"], capture_output=True, text=True,
                       cwd=cwd, env=env, timeout=TIMEOUT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.lower().startswith("usage:"), r.stdout[:200]
    assert time.monotonic() - t < TIMEOUT
    assert os.listdir(cwd) == [], "--help wrote files"


@pytest.mark.parametrize("script", SHELL_SCRIPTS, ids=os.path.basename)
def test_help_of_shell_scripts(script):
    """build.sh, main_job.sh, valgrind.sh took --help for a folder name and started work."""
    cwd = workdir(os.path.basename(script) + ".bash")
    r = subprocess.run(["bash", script, "--help"], capture_output=True, text=True, cwd=cwd,
                       timeout=TIMEOUT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("usage: bash scripts/%s" % os.path.basename(script)), r.stdout
    assert len(r.stdout.splitlines()) > 2   # and the header that says what it does
    assert os.listdir(cwd) == [], "--help wrote files"


@pytest.mark.skipif(not shutil.which("blender"), reason="blender absent")
def test_help_under_blender():
    """Started together (Blender takes seconds to start); each exits 0 with its usage."""
    procs = {}
    for script in BLENDER_SCRIPTS:
        cwd = workdir(os.path.basename(script) + ".blender")
        procs[script] = (cwd, subprocess.Popen(
            ["blender", "-b", "--factory-startup", "--python", script, "--", "--help"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=cwd))
    for script, (cwd, p) in procs.items():
        out, _ = p.communicate(timeout=BLENDER_TIMEOUT)
        assert p.returncode == 0, out[-2000:]
        assert "usage: blender -b --factory-startup --python scripts/%s -- " % (
            os.path.basename(script)) in out, out[-2000:]
        assert os.listdir(cwd) == [], "--help wrote files"
