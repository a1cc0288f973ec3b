"""Runs inside Blender for scripts/blender_16k_bench.py: one world image, its memory and time.

    blender -b --factory-startup --python scripts/blender_16k_run.py -- SPEC.json

SPEC (JSON): {"zip": the add-on zip to install, "image": the world's image (a file), "engine":
  the scene's render engine (default: the factory startup's),
  "file_read": also time the library reading the image's file itself (envlight.load),
  "out": RESULT.json}

In order, in one Blender: the add-on installed; the image loaded into the world's Environment
Texture and its pixels made resident (Image.size makes Blender decode the file): Blender's own
footprint; then, each after resetting the process's peak resident memory (VmHWM, by writing 5
to /proc/self/clear_refs): the add-on's reading of the image alone (core.read_source), the
library reading the file (when asked), and Create Lights (the operator, as the button runs
it) with the times its progress callback was called and where the bar was when the sampled
resident memory (every 20 ms) was highest. Memory from /proc/self/status (VmRSS,
VmHWM), in MiB; times from time.perf_counter."""
import json
import os
import sys
import threading
import time

# --help prints the above and ends here, before bpy is imported or anything runs
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_help import exit_on_help  # noqa: E402
if __name__ == "__main__":
    exit_on_help(__doc__, __file__)

import bpy  # noqa: E402

from blender_addon_check import install  # noqa: E402
from blender_scene import run_main, world_with_image  # noqa: E402

MIB = 1024.0 * 1024.0


def memory():
    """(VmRSS, VmHWM) of this process in MiB."""
    out = {}
    with open("/proc/self/status") as f:
        for line in f:
            key, _, rest = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = int(rest.split()[0]) * 1024 / MIB
    return out["VmRSS"], out["VmHWM"]


def reset_peak():
    """VmHWM := VmRSS (Linux >= 4.0: 5 to /proc/PID/clear_refs)."""
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def phase(fn):
    """fn() timed, with the peak resident memory it reached (MiB, VmHWM after a reset)."""
    reset_peak()
    rss0, _ = memory()
    t0 = time.perf_counter()
    value = fn()
    seconds = time.perf_counter() - t0
    rss1, peak = memory()
    return value, {"seconds": seconds, "rss_before": rss0, "rss_after": rss1, "peak": peak}


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    with open(argv[0]) as f:
        spec = json.load(f)
    addon = install(spec["zip"])
    core = addon.core
    pkg = core.shim()
    res = {"blender": bpy.app.version_string, "envlight": pkg.version()}
    res["rss_start"], _ = memory()

    def load():
        world, tex = world_with_image("Bench World", spec["image"])
        return world, tex, tuple(tex.image.size)  # Blender decodes the file here
    (world, tex, size), res["image_load"] = phase(load)
    if spec.get("engine"):  # the scene's engine: what Create Lights computes depends on it
        bpy.context.scene.render.engine = spec["engine"]
    res["engine"] = bpy.context.scene.render.engine
    res["size"] = list(size)
    res["is_float"] = tex.image.is_float
    res["rss_image"], _ = memory()  # Blender's own footprint with the image

    def read():
        env, _src = core.read_source(pkg, world)
        env.close()
    _, res["read"] = phase(read)

    if spec.get("file_read"):
        def file_read():
            try:
                pkg.load(bpy.path.abspath(tex.image.filepath)).close()
            except pkg.Error as e:  # the add-on's library reads no .exr (built without OpenEXR)
                return str(e)
        error, res["file_read"] = phase(file_read)
        if error:
            res["file_read"] = {"error": error}

    # the button, with the times of its progress callback (the values the bar is given)
    calls = []
    original = core.create_lights

    def recorded(context, settings, progress=None, force=False):
        t0 = time.perf_counter()

        def step(v):
            calls.append((time.perf_counter() - t0, v))
            if progress:
                progress(v)
        return original(context, settings, progress=step, force=force)
    core.create_lights = recorded
    samples, done = [], threading.Event()

    def sample():  # VmRSS every 20 ms (while Python runs or a library call has the GIL freed)
        t0 = time.perf_counter()
        while not done.wait(0.02):
            samples.append((time.perf_counter() - t0, memory()[0]))
    sampler = threading.Thread(target=sample)
    sampler.start()
    try:
        status, res["button"] = phase(lambda: bpy.ops.envlight.create_lights())
    finally:
        core.create_lights = original
        done.set()
        sampler.join()
    # the stage of the highest sample: the last progress value reported before it
    t_peak, rss_peak = max(samples, key=lambda x: x[1]) if samples else (0.0, 0.0)
    res["button"]["sampled_peak"] = rss_peak
    res["button"]["sampled_peak_progress"] = max(
        [v for t, v in calls if t <= t_peak], default=0.0)
    res["button"]["status"] = sorted(status)
    res["button"]["progress"] = calls
    res["button"]["lamps"] = world.envlight.result_count
    res["button"]["message"] = world.envlight.result_message
    res["button"]["recipe"] = world.envlight.result_recipe
    with open(spec["out"], "w") as f:
        json.dump(res, f, indent=1)
    print("ENVLIGHT_16K_DONE")


if __name__ == "__main__":
    run_main(main)
