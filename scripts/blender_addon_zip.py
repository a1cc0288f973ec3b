#!/usr/bin/env python3
"""Builds the Blender add-on zip: plugin/envlight_addon + the Python shim (py_shim/envlight,
as envlight_addon/envlight) + the library (envlight_addon/lib/libenvlight.so.1).

    python3 scripts/blender_addon_zip.py [--build-dir build] [--library SO] [-o OUT.zip]
                                         [--blender CMD | --no-blender]

The library: --library SO, else <build-dir>/addon-lib/libenvlight.so when it exists (CMake's
envlight_addon target: the library built without OpenEXR and libpng, so `ldd` lists only the
C runtime; issue 14), else <build-dir>/libenvlight.so. A library that links more (the full
build links the system's OpenEXR core, libpng and zlib; Debian 12 ships no static,
position-independent builds of them) gets a note naming what `ldd` lists beyond the C
runtime; Blender's machine must then provide those libraries.

With a Blender >= 4.2 (--blender CMD, else $ENVL_BLENDER4, else scripts/blender4.sh's
/var/cache/envlight/trixie-root/run-blender when it exists and runs), the zip is made by
`blender --command extension build` from a staged folder (plugin + shim + library); Blender
puts those files at the zip's root, where Blender 3.x's Preferences > Add-ons > Install would
spill them into addons/, so they are moved under envlight_addon/ (a single top folder holding
blender_manifest.toml, which 4.2+ accepts too). Without one the zip is written directly, same
layout. Either way, with a 4.2+ Blender the result then goes through
`blender --command extension validate`, and a failure is fatal (exit status 1, the zip is
not left at OUT). Default output: <build-dir>/envlight_addon.zip."""
import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_BLENDER4 = "/var/cache/envlight/trixie-root/run-blender"
TOP = "envlight_addon"  # the zip's top folder = the module name for Blender 3.x
# what ldd may list for a self-contained library: the C runtime
C_RUNTIME = re.compile(r"^(linux-vdso|linux-gate|ld-linux[-\w.]*|libc|libm|libpthread|libdl|"
                       r"librt|libgcc_s)\.so")


def log(msg):
    print("blender_addon_zip: " + msg, file=sys.stderr)


def non_runtime_deps(lib):
    """The libraries `ldd lib` lists beyond the C runtime ([] when ldd is absent)."""
    try:
        out = subprocess.run(["ldd", lib], capture_output=True, text=True).stdout
    except OSError:
        return []
    names = [line.split()[0] for line in out.splitlines() if line.strip()]
    return [n for n in names if not C_RUNTIME.match(os.path.basename(n))]


def default_library(build_dir):
    """<build-dir>/addon-lib/libenvlight.so (no OpenEXR, no libpng) when built, else the
    full <build-dir>/libenvlight.so."""
    minimal = os.path.join(build_dir, "addon-lib", "libenvlight.so")
    return minimal if os.path.exists(minimal) else os.path.join(build_dir, "libenvlight.so")


def blender_version(cmd):
    """(major, minor) of `cmd --version`, or None when it does not run."""
    try:
        p = subprocess.run(cmd + ["--version"], capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired):
        return None
    m = re.search(r"^Blender (\d+)\.(\d+)", p.stdout, re.M)
    return (int(m.group(1)), int(m.group(2))) if p.returncode == 0 and m else None


def find_blender4(a):
    """The Blender >= 4.2 command (a list) to build and validate with, or None."""
    if a.no_blender:
        return None
    explicit = a.blender or os.environ.get("ENVL_BLENDER4")
    if explicit:
        cmd = shlex.split(explicit)
    elif os.access(DEFAULT_BLENDER4, os.X_OK):
        cmd = [DEFAULT_BLENDER4]
    else:
        log("no Blender >= 4.2 (--blender, $ENVL_BLENDER4, %s): zip written directly, "
            "not validated" % DEFAULT_BLENDER4)
        return None
    v = blender_version(cmd)
    if v is None or v < (4, 2):
        what = "does not run" if v is None else "is Blender %d.%d" % v
        if explicit:
            sys.exit("blender_addon_zip: %s %s: a Blender >= 4.2 is needed for "
                     "`--command extension build/validate`" % (" ".join(cmd), what))
        log("%s %s: zip written directly, not validated" % (cmd[0], what))
        return None
    return cmd


def staged_files(lib):
    """(source path, path inside the add-on folder) of everything the add-on ships."""
    files = []
    addon = os.path.join(ROOT, "plugin", "envlight_addon")
    for name in sorted(os.listdir(addon)):
        if name.endswith(".py") or name == "blender_manifest.toml":
            files.append((os.path.join(addon, name), name))
    shim = os.path.join(ROOT, "py_shim", "envlight")
    for name in sorted(os.listdir(shim)):
        if name.endswith(".py"):
            files.append((os.path.join(shim, name), "envlight/" + name))
    files.append((os.path.realpath(lib), "lib/libenvlight.so.1"))
    return files


def run_blender(cmd, args, what):
    p = subprocess.run(cmd + args, capture_output=True, text=True)
    out = (p.stdout + p.stderr).strip()
    if p.returncode != 0 or "FATAL_ERROR" in out or re.search(r"^Error", out, re.M):
        sys.exit("blender_addon_zip: `blender %s` failed (exit status %d):\n%s"
                 % (" ".join(args), p.returncode, out))
    log("%s: %s" % (what, out.replace("\n", " | ")))
    return out


def build_with_blender(cmd, files, tmp_zip, work):
    """`extension build` of a staged folder, then its files moved under TOP/ in tmp_zip."""
    stage = os.path.join(work, "stage")
    outdir = os.path.join(work, "out")
    os.makedirs(outdir)  # `extension build --output-dir` needs it to exist
    for src, rel in files:
        dst = os.path.join(stage, rel)
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        shutil.copy2(src, dst)
    run_blender(cmd, ["--command", "extension", "build", "--source-dir", stage,
                      "--output-dir", outdir], "extension build")
    built = [f for f in os.listdir(outdir) if f.endswith(".zip")]
    if len(built) != 1:
        sys.exit("blender_addon_zip: extension build left %r in %s" % (built, outdir))
    with zipfile.ZipFile(os.path.join(outdir, built[0])) as zin, \
            zipfile.ZipFile(tmp_zip, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            if info.is_dir():
                continue
            moved = zipfile.ZipInfo(TOP + "/" + info.filename, info.date_time)
            moved.external_attr = info.external_attr
            moved.compress_type = zipfile.ZIP_DEFLATED
            zout.writestr(moved, zin.read(info))


def write_zip(files, tmp_zip):
    with zipfile.ZipFile(tmp_zip, "w", zipfile.ZIP_DEFLATED) as z:
        for src, rel in files:
            z.write(src, TOP + "/" + rel)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,  # the whole docstring, as written
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build-dir", default=os.path.join(ROOT, "build"))
    ap.add_argument("--library", help="libenvlight.so to ship (default: <build-dir>/addon-lib/"
                    "libenvlight.so, the self-contained build, else <build-dir>/libenvlight.so)")
    ap.add_argument("-o", "--output")
    ap.add_argument("--blender", help="Blender >= 4.2 command to build and validate with "
                    "(default: $ENVL_BLENDER4, else %s when present)" % DEFAULT_BLENDER4)
    ap.add_argument("--no-blender", action="store_true",
                    help="write the zip directly, no extension build/validate")
    a = ap.parse_args(argv)
    lib = a.library or default_library(a.build_dir)
    if not os.path.exists(lib):
        sys.exit("blender_addon_zip: %s not found: build the library first" % lib)
    extra = non_runtime_deps(lib)
    if extra:  # a note, not a failure: Blender's system must provide them
        log("note: the bundled library needs %s from the system (not self-contained; "
            "issue 14)" % ", ".join(os.path.basename(n) for n in extra))
    out = a.output or os.path.join(a.build_dir, "envlight_addon.zip")
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    files = staged_files(lib)
    blender = find_blender4(a)
    tmp_out = out + ".tmp-%d" % os.getpid()
    try:
        # under /tmp, which scripts/blender4.sh's chrooted Blender sees at the same path
        with tempfile.TemporaryDirectory(prefix="envlight-addon-zip-", dir="/tmp") as work:
            made = os.path.join(work, "envlight_addon.zip")
            if blender:
                build_with_blender(blender, files, made, work)
                run_blender(blender, ["--command", "extension", "validate", made],
                            "extension validate")
            else:
                write_zip(files, made)
            shutil.copyfile(made, tmp_out)
        os.replace(tmp_out, out)
    finally:
        if os.path.exists(tmp_out):
            os.unlink(tmp_out)
    print(out)
    return out


if __name__ == "__main__":
    main()
