#!/usr/bin/env python3
"""Builds the Blender add-on zip: plugin/envlight_addon + the Python shim (py_shim/envlight,
as envlight_addon/envlight) + the built library (envlight_addon/lib/libenvlight.so.1).

    python3 scripts/blender_addon_zip.py [--build-dir build] [--library PATH] [-o OUT.zip]

Default output: <build-dir>/envlight_addon.zip. Install it with Blender's Preferences >
Add-ons > Install (3.x), or as an extension from disk (4.2+: blender_manifest.toml inside)."""
import argparse
import os
import sys
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build-dir", default=os.path.join(ROOT, "build"))
    ap.add_argument("--library", help="libenvlight.so to ship (default: <build-dir>/libenvlight.so)")
    ap.add_argument("-o", "--output")
    a = ap.parse_args(argv)
    lib = a.library or os.path.join(a.build_dir, "libenvlight.so")
    if not os.path.exists(lib):
        sys.exit("blender_addon_zip: %s not found: build the library first" % lib)
    out = a.output or os.path.join(a.build_dir, "envlight_addon.zip")
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    tmp = out + ".tmp-%d" % os.getpid()
    files = []
    addon = os.path.join(ROOT, "plugin", "envlight_addon")
    for name in sorted(os.listdir(addon)):
        if name.endswith(".py") or name == "blender_manifest.toml":
            files.append((os.path.join(addon, name), "envlight_addon/" + name))
    shim = os.path.join(ROOT, "py_shim", "envlight")
    for name in sorted(os.listdir(shim)):
        if name.endswith(".py"):
            files.append((os.path.join(shim, name), "envlight_addon/envlight/" + name))
    files.append((os.path.realpath(lib), "envlight_addon/lib/libenvlight.so.1"))
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for src, arc in files:
            z.write(src, arc)
    os.replace(tmp, out)
    print(out)
    return out


if __name__ == "__main__":
    main()
