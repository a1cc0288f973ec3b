"""The in-tree PEP 517 build backend of the envlight package: it needs nothing from PyPI, so
`pip install ./py_shim` works offline (pyproject.toml: requires = [], backend-path).

It writes one platform wheel, envlight-VERSION-py3-none-linux_ARCH.whl: the ctypes package
(envlight/*.py) and the library inside it (envlight/libenvlight.so.1), which the package loads
before anything else but $ENVLIGHT_LIBRARY. The library, first found of:

1. config setting `library=SO` or $ENVLIGHT_WHEEL_LIBRARY: that file, as it is;
2. config setting `build-dir=DIR` or $ENVLIGHT_BUILD_DIR, else <repo>/build, when it holds a
   CMake build: `cmake --build DIR --target envlight_addon`, then DIR/addon-lib/libenvlight.so;
3. else a CMake build of envlight_addon in a temporary folder (cmake, a C compiler, pkg-config).

envlight_addon is the library built without OpenEXR and libpng (as the Blender add-on ships
it): `ldd` lists only the C runtime, so the wheel needs nothing else on the machine, and the
tag linux_ARCH is true of it; it reads .hdr and .pfm and refuses .exr and PNG output. A full
libenvlight.so given by 1. works too, but then needs that machine's OpenEXR and libpng.

Also a command, which CMake's envlight_wheel target runs (py_shim/CMakeLists.txt):
    python3 envlight_wheel.py --library SO --out DIR/NAME.whl
"""
import base64
import ctypes
import hashlib
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile

SHIM = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # py_shim/
REPO = os.path.dirname(SHIM)
LIB_NAME = "libenvlight.so.1"
ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed: the same inputs give the same wheel


def log(msg):
    print("envlight_wheel: " + msg, file=sys.stderr)


# ---- metadata from pyproject.toml ----------------------------------------------------------

def project():
    """pyproject.toml's [project] table (tomllib; a line reader for Python < 3.11)."""
    path = os.path.join(SHIM, "pyproject.toml")
    try:
        import tomllib
        with open(path, "rb") as f:
            return tomllib.load(f)["project"]
    except ImportError:
        table, section = {}, None
        with open(path, encoding="utf-8") as f:
            for line in f:
                m = re.match(r'\s*\[(.*)\]\s*$', line)
                if m:
                    section = m.group(1)
                elif section == "project":
                    m = re.match(r'\s*([\w-]+)\s*=\s*"(.*)"\s*$', line)
                    if m:
                        table[m.group(1)] = m.group(2)
        return table


def metadata(p):
    lines = ["Metadata-Version: 2.1", "Name: " + p["name"], "Version: " + p["version"],
             "Summary: " + p.get("description", "")]
    if "requires-python" in p:
        lines.append("Requires-Python: " + p["requires-python"])
    if isinstance(p.get("license"), dict) and "text" in p["license"]:
        lines.append("License: " + p["license"]["text"])
    for extra, reqs in sorted(p.get("optional-dependencies", {}).items()):
        lines.append("Provides-Extra: " + extra)
        lines += ['Requires-Dist: %s ; extra == "%s"' % (r, extra) for r in reqs]
    text = ""
    if p.get("readme"):
        lines.append("Description-Content-Type: text/markdown")
        with open(os.path.join(SHIM, p["readme"]), encoding="utf-8") as f:
            text = f.read()
    return "\n".join(lines) + "\n\n" + text


def platform_tag():
    return re.sub(r"[-.]", "_", sysconfig.get_platform())  # linux-x86_64 -> linux_x86_64


def wheel_name(p):
    return "%s-%s-py3-none-%s.whl" % (p["name"], p["version"], platform_tag())


# ---- the library ---------------------------------------------------------------------------

def check_library(path, version):
    """Loads the library here (so it suits this machine) and checks that its version and ABI are
    the package's."""
    with open(os.path.join(SHIM, "envlight", "_lib.py"), encoding="utf-8") as f:
        abi = int(re.search(r"^ABI_VERSION = (\d+)", f.read(), re.M).group(1))
    lib = ctypes.CDLL(os.path.abspath(path))
    lib.envl_version_string.restype = ctypes.c_char_p
    got_version = lib.envl_version_string().decode()
    got_abi = lib.envl_abi_version()
    if got_version != version or got_abi != abi:
        raise RuntimeError("%s is version %s ABI %d; the package is %s ABI %d"
                           % (path, got_version, got_abi, version, abi))


def cmake_build(build_dir):
    subprocess.run(["cmake", "--build", build_dir, "--target", "envlight_addon", "-j",
                    str(os.cpu_count() or 2)], check=True, stdout=sys.stderr)
    return os.path.join(build_dir, "addon-lib", "libenvlight.so")


def absolute(path):
    """pip runs the backend in py_shim/, not the user's folder: a relative path is refused."""
    if path and not os.path.isabs(path):
        raise RuntimeError("envlight_wheel: %s: give an absolute path (pip builds in %s)"
                           % (path, SHIM))
    return path


def find_library(settings, tmp):
    """The library for the wheel (the module's docstring: 1., 2., 3.)."""
    lib = absolute(settings.get("library") or os.environ.get("ENVLIGHT_WHEEL_LIBRARY"))
    if lib:
        if not os.path.isfile(lib):
            raise RuntimeError("envlight_wheel: the library %s does not exist" % lib)
        return lib
    in_repo = os.path.exists(os.path.join(REPO, "src", "envlight.h"))
    build = absolute(settings.get("build-dir") or os.environ.get("ENVLIGHT_BUILD_DIR")) or (
        os.path.join(REPO, "build") if in_repo else None)
    if build and os.path.exists(os.path.join(build, "CMakeCache.txt")):
        log("the library from the CMake build " + build)
        return cmake_build(build)
    if not in_repo:
        raise RuntimeError("envlight_wheel: %s is not inside the envlight repository: name the "
                           "library with ENVLIGHT_WHEEL_LIBRARY=SO or --config-settings "
                           "library=SO" % SHIM)
    log("no CMake build in %s: building envlight_addon in %s" % (build, tmp))
    subprocess.run(["cmake", "-S", REPO, "-B", tmp, "-DCMAKE_BUILD_TYPE=Release",
                    "-DENVL_TESTS=OFF", "-DENVL_OPENEXR=OFF", "-DENVL_PNG=OFF",
                    "-DENVL_WHEEL=OFF"], check=True, stdout=sys.stderr)
    return cmake_build(tmp)


# ---- the wheel -----------------------------------------------------------------------------

def record_line(arcname, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return "%s,sha256=%s,%d" % (arcname, digest, len(data))


def write_wheel(path, library, p):
    """Writes the wheel at `path` (a temporary name, then renamed)."""
    info = "%s-%s.dist-info" % (p["name"], p["version"])
    files = []  # (arcname, bytes, mode)
    pkg = os.path.join(SHIM, "envlight")
    for name in sorted(os.listdir(pkg)):
        if name.endswith(".py"):
            with open(os.path.join(pkg, name), "rb") as f:
                files.append(("envlight/" + name, f.read(), 0o644))
    with open(library, "rb") as f:
        files.append(("envlight/" + LIB_NAME, f.read(), 0o755))
    wheel = ("Wheel-Version: 1.0\nGenerator: envlight_wheel\nRoot-Is-Purelib: false\n"
             "Tag: py3-none-%s\n" % platform_tag())
    files += [(info + "/METADATA", metadata(p).encode(), 0o644),
              (info + "/WHEEL", wheel.encode(), 0o644),
              (info + "/top_level.txt", b"envlight\n", 0o644)]
    record = [record_line(a, d) for a, d, _ in files] + [info + "/RECORD,,"]
    files.append((info + "/RECORD", ("\n".join(record) + "\n").encode(), 0o644))
    part = path + ".part"
    with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
        for arcname, data, mode in files:
            zi = zipfile.ZipInfo(arcname, ZIP_TIME)
            zi.external_attr = (0o100000 | mode) << 16
            zi.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(zi, data)
    os.replace(part, path)


def build(wheel_directory, library, p):
    check_library(library, p["version"])
    name = wheel_name(p)
    write_wheel(os.path.join(wheel_directory, name), library, p)
    log("%s with %s" % (name, library))
    return name


# ---- PEP 517 hooks -------------------------------------------------------------------------

def get_requires_for_build_wheel(config_settings=None):
    return []


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    p = project()
    tmp = tempfile.mkdtemp(prefix="envlight-cmake-")
    try:
        return build(wheel_directory, find_library(config_settings or {}, tmp), p)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main(argv):
    import argparse
    ap = argparse.ArgumentParser(description="Writes the envlight wheel around a library.")
    ap.add_argument("--library", required=True, help="the libenvlight.so to ship")
    ap.add_argument("--out", required=True, help="the wheel's path; its name must be the one "
                    "the package's version and this platform give")
    a = ap.parse_args(argv)
    p = project()
    if os.path.basename(a.out) != wheel_name(p):
        sys.exit("envlight_wheel: %s: the wheel's name is %s (pyproject.toml's version, this "
                 "platform)" % (a.out, wheel_name(p)))
    build(os.path.dirname(os.path.abspath(a.out)), a.library, p)


if __name__ == "__main__":
    main(sys.argv[1:])
