"""Runs inside Blender (headless) for tests/py_blender_addon.py's test of how the add-on reads
the world's image (issue 29): the copies it makes and when the progress bar first moves.

    blender -b --factory-startup --python scripts/blender_read_check.py -- SPEC.json

SPEC (JSON): {"zip": the add-on zip, "images": [{"path": image file, "projection":
  "EQUIRECTANGULAR" | "MIRROR_BALL"}, ...], "out": RESULT.json}

For each image, in the world's Environment Texture, its pixels made resident first
(Image.size): the add-on's reading (core.read_source) under tracemalloc, which counts every
allocation of Python and numpy (not the library's malloc: the one copy allowed): `peak` is
the most Python memory held at once during the reading, above what was held before; then
the map it made against the library's map of a plain copy of Image.pixels (from_pixels,
flip=True): `same_pixels`. Then Create Lights' function (core.create_lights) with a progress
callback, and sys.setprofile noting each Image.pixels.foreach_get (the copy of the pixels):
`events`, in order, ("progress", value) and ("foreach_get", 0)."""
import json
import os
import sys
import tracemalloc

# --help prints the above and ends here, before bpy is imported or anything runs
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_help import exit_on_help  # noqa: E402
if __name__ == "__main__":
    exit_on_help(__doc__, __file__)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from blender_addon_check import install  # noqa: E402
from blender_scene import run_main, world_with_image  # noqa: E402


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    with open(argv[0]) as f:
        spec = json.load(f)
    core = install(spec["zip"]).core
    pkg = core.shim()
    out = {"blender": bpy.app.version_string, "images": []}
    for item in spec["images"]:
        world, tex = world_with_image("Read World", item["path"], item["projection"])
        image = tex.image
        w, h = image.size  # Blender decodes the file: its own memory, before the reading
        ch = image.channels
        tracemalloc.start()
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        env, src = core.read_source(pkg, world)
        peak = tracemalloc.get_traced_memory()[1] - before
        tracemalloc.stop()
        with env:
            got = env.pixels()
        # the reference: a plain copy of Blender's pixels, as the add-on read them before
        buf = np.empty(w * h * ch, dtype=np.float32)
        image.pixels.foreach_get(buf)
        if not image.is_float and image.colorspace_settings.name == "sRGB":
            rgb = buf.reshape(-1, ch)[:, :3] if ch == 4 else buf
            rgb[...] = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
        if item["projection"] == "EQUIRECTANGULAR":
            with pkg.from_pixels(buf, w, h, ch, flip=True, layout="latlong") as ref:
                want = ref.pixels()
        else:
            with pkg.from_pixels(buf, w, h, ch, flip=True, layout="mirrorball",
                                 map_width=4 * ((w + 1) // 2)) as ball:
                want = ball.pixels()
            want = np.roll(want, -(want.shape[1] // 4), axis=1)
        del buf

        # the button's function: the order of its first progress call and the pixels' reading
        events = []

        def profile(frame, event, arg):
            if event == "c_call" and getattr(arg, "__name__", "") == "foreach_get" and \
                    isinstance(getattr(arg, "__self__", None), bpy.types.bpy_prop_array):
                events.append(("foreach_get", 0))

        sys.setprofile(profile)
        try:
            core.create_lights(bpy.context, world.envlight,
                               progress=lambda v: events.append(("progress", v)))
        except core.NothingToDo:
            pass
        finally:
            sys.setprofile(None)
        out["images"].append({
            "path": item["path"], "projection": item["projection"], "size": [w, h],
            "channels": ch, "is_float": image.is_float, "peak": peak,
            "same_pixels": bool(np.array_equal(got, want)), "shape": list(got.shape),
            "events": events, "warnings": src.warnings})
        bpy.data.worlds.remove(world)
    with open(spec["out"], "w") as f:
        json.dump(out, f, indent=1)
    print("ENVLIGHT_CHECK_DONE")


if __name__ == "__main__":
    run_main(main)
