"""Runs inside Blender with a window (under `xvfb-run -a`) for tests/py_blender_panel.py: the
EnvLight panel as a user sees it (issue 28), in Blender's default startup scene (its cube, its
camera and its 1000 W point light kept), one screenshot of the panel per step:

    xvfb-run -a -s "-screen 0 WxHx24 -fbdir DIR" blender --factory-startup \
        --window-geometry 0 0 W H --python scripts/blender_panel_check.py -- SPEC.json

The 3D viewport becomes a Properties editor on the World tab, tall enough for every World
panel; each step presses the panel's buttons as operators in that window, redraws, and saves
the editor (the X screen that Xvfb keeps in DIR, cut to it) as STEP.png, then STEP_ocr.png: grey, inverted
(dark text on light) and 2x larger, for OCR. Steps (SPEC "steps", in order):
  eevee        the default engine (EEVEE), the world's Environment Texture `hdr`: Create Lights
  hide         Hide Them for the Render (the startup light)
  remove       Remove EnvLight (the light renders again)
  cycles       Cycles, `hdr_nosun` (a map without a sun): Create Lights (nothing changes)
  anyway       Create Lamps Anyway (the panel's button: create_lights with force)
  ball         `ball` (a square mirror-ball image) left on Equirectangular: Create Lights
SPEC (JSON): {"zip", "out": RESULT.json, "shots": DIR, "fbdir": Xvfb's -fbdir, "hdr",
"hdr_nosun", "ball", "steps"}.
RESULT: per step the operator's status, the panel's stored result, the lamps and the startup
light's hide_render, the screenshot files."""
import json
import os
import sys
import time

if __name__ == "__main__" and {"-h", "--help"} & set(
        sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]):
    print("usage: blender -b --factory-startup --python %s -- SPEC.json (it needs a window: "
          "run it without -b under xvfb-run, as below)\n\n%s"
          % ("scripts/" + os.path.basename(__file__), __doc__))
    sys.exit(0)

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_addon_check as check  # noqa: E402  (its helpers; it runs nothing when imported)

#: UI scale for the screenshots (bigger text reads better by OCR)
UI_SCALE = 1.5
#: redraws (0.1 s apart) before a screenshot: until two in a row leave the screen as it was
#: (Blender slides panels to their new places over a few draws), at most
SETTLE_MAX = 50


def properties_area():
    """The largest area (the 3D viewport) turned into a Properties editor on the World tab."""
    win = bpy.context.window_manager.windows[0]
    area = max(win.screen.areas, key=lambda a: a.width * a.height)
    area.type = "PROPERTIES"
    with bpy.context.temp_override(window=win, screen=win.screen, area=area):
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)   # its tabs exist once drawn
    area.spaces.active.context = "WORLD"
    return win, area


def read_xwd(path):
    """The X screen as Xvfb keeps it in `path` (its -fbdir file, X Window Dump format: a
    header of 25 big-endian 32-bit fields, the window name, the colour map, then the rows top
    first) -> (H, W, 3) float32 in 0..1, rows top first. 24-bit TrueColor, 32 bits a pixel."""
    raw = open(path, "rb").read()
    f = np.frombuffer(raw[:100], dtype=">u4")
    size, width, height, order, bpp, stride = (int(f[0]), int(f[4]), int(f[5]), int(f[7]),
                                               int(f[11]), int(f[12]))
    masks, ncolors = [int(v) for v in f[14:17]], int(f[19])
    if bpp != 32:
        raise RuntimeError("%s: %d bits a pixel (32 expected)" % (path, bpp))
    start = size + 12 * ncolors
    rows = np.frombuffer(raw[start:start + height * stride], dtype="<u4" if order == 0 else ">u4")
    px = rows.reshape(height, stride // 4)[:, :width]
    out = []
    for m in masks:
        shift = (m & -m).bit_length() - 1
        out.append(((px & m) >> shift).astype(np.float32) / float(m >> shift))
    return np.stack(out, axis=-1)


def shot(win, area, path, fbdir):
    """The Properties editor as shown, saved as `path` and its OCR copy: the X screen as Xvfb
    holds it (`fbdir`: Blender 4.3's own screenshot reads back black under Xvfb here), the
    window at the screen's top left, cut to the editor."""
    # the World tab drawn afresh (another tab, then World again): its panels laid out whole,
    # not grown from their last sizes (a box that had grown kept its old height here, its
    # last lines cut off under the next panel)
    space = area.spaces.active
    for tab in ("SCENE", "WORLD"):
        space.context = tab
        with bpy.context.temp_override(window=win, screen=win.screen, area=area):
            bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
    screen, same = None, 0
    for _ in range(SETTLE_MAX):   # Blender slides panels to their new places over a few draws
        with bpy.context.temp_override(window=win, screen=win.screen, area=area):
            bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=2)
        time.sleep(0.1)
        now = read_xwd(os.path.join(fbdir, "Xvfb_screen0"))
        same = same + 1 if screen is not None and np.array_equal(now, screen) else 0
        screen = now
        if same == 2:
            break
    else:
        print("blender_panel_check: the screen still changed after %d redraws" % SETTLE_MAX)
    top = win.height - (area.y + area.height)
    rgb = screen[top:top + area.height, area.x:area.x + area.width][::-1]   # rows bottom-up
    h, w = rgb.shape[:2]
    cut = bpy.data.images.new("shot", w, h)
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = rgb
    cut.pixels.foreach_set(rgba.ravel())
    cut.filepath_raw = path
    cut.file_format = "PNG"
    cut.save()
    bpy.data.images.remove(cut)
    grey = 1.0 - rgb @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    big = np.repeat(np.repeat(grey, 2, axis=0), 2, axis=1)
    out = bpy.data.images.new("ocr", 2 * w, 2 * h)
    rgba = np.ones((2 * h, 2 * w, 4), np.float32)
    rgba[..., :3] = big[..., None]
    out.pixels.foreach_set(rgba.ravel())
    ocr = path[:-4] + "_ocr.png"
    out.filepath_raw = ocr
    out.file_format = "PNG"
    out.save()
    bpy.data.images.remove(out)
    return path, ocr


def state(scene):
    s = scene.world.envlight
    light = bpy.data.objects.get("Light")
    return {"outcome": s.result_outcome, "has_result": s.has_result,
            "recipe": s.result_recipe, "count": s.result_count,
            "reasons": s.result_reasons.split("\n") if s.result_reasons else [],
            "skipped": s.result_skipped.split("\n") if s.result_skipped else [],
            "settings": s.result_settings.split("\n") if s.result_settings else [],
            "message": s.result_message, "error_label": s.result_error_label,
            "lamps": check.lamps(), "startup_light_hide_render":
            None if light is None else light.hide_render,
            "world": check.world_state(scene.world)}


def set_image(env, path):
    old = env.image
    env.image = bpy.data.images.load(path)
    if old is not None and old.users == 0:
        bpy.data.images.remove(old)


def close_splash(folder):
    """Blender's splash (its first-start Quick Setup, over the editor) closed: the default
    startup scene saved and opened again as a file (opening a file closes it), unchanged."""
    path = os.path.join(folder, "startup.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)


def main():
    spec = check.spec_from_argv()
    os.makedirs(spec["shots"], exist_ok=True)
    close_splash(spec["shots"])
    bpy.context.preferences.view.ui_scale = UI_SCALE
    check.install(spec["zip"])
    scene = bpy.context.scene
    world, env = check.setup_world({"hdr": spec["hdr"]})
    win, area = properties_area()
    result = {"blender": bpy.app.version_string, "engine_default": scene.render.engine,
              "steps": {}}

    def op(fn, **kw):
        with bpy.context.temp_override(window=win, screen=win.screen, area=area):
            try:
                return list(fn("EXEC_DEFAULT", **kw))
            except RuntimeError as e:   # an ERROR report
                return ["ERROR: %s" % e]

    for step in spec["steps"]:
        if step == "eevee":
            rc = op(bpy.ops.envlight.create_lights)
        elif step == "hide":
            rc = op(bpy.ops.envlight.hide_other_lights)
        elif step == "remove":
            rc = op(bpy.ops.envlight.remove)
        elif step == "cycles":
            scene.render.engine = "CYCLES"
            set_image(env, spec["hdr_nosun"])
            rc = op(bpy.ops.envlight.create_lights)
        elif step == "anyway":
            rc = op(bpy.ops.envlight.create_lights, force=True)
        elif step == "ball":
            set_image(env, spec["ball"])
            rc = op(bpy.ops.envlight.create_lights)
        else:
            raise ValueError("unknown step %r" % step)
        st = state(scene)
        st["rc"] = rc
        st["shot"], st["ocr"] = shot(win, area, os.path.join(spec["shots"], step + ".png"),
                                     spec["fbdir"])
        result["steps"][step] = st
    with open(spec["out"], "w") as f:
        json.dump(result, f, indent=1)
    print("ENVLIGHT_CHECK_DONE", spec["out"])


if __name__ == "__main__":
    if bpy.app.background:
        sys.exit("blender_panel_check.py needs a window (run it under xvfb-run, without -b)")
    bpy.app.timers.register(lambda: check.main_in_window(main), first_interval=1.0)
