"""EnvLight: turn the world's HDR into sun lamps plus a residual or SH world (libenvlight).

Properties > World > EnvLight: pick the source (the world's Environment Texture, also one
inside a node group, or a file), the number of lights, the method, shadows and the world mode,
then press Create Lights. Everything the add-on creates is tagged and replaced on the next run;
the user's own lamps and nodes are never touched.
"""

bl_info = {
    "name": "EnvLight",
    "author": "envlight developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > World > EnvLight",
    "description": "Turn the world's HDR into sun lamps plus a residual or SH world",
    "category": "Lighting",
}

import bpy  # noqa: E402
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty,  # noqa
                       IntProperty, PointerProperty, StringProperty)

import textwrap  # noqa: E402

from . import core, other_lights  # noqa: E402
from . import scene as scene_reader  # noqa: E402

METHODS = [
    ("fit", "Fit", "Fitted lights + a low-order SH remainder: the best accuracy for a few lights"),
    ("median", "Median Cut", "Debevec's median cut: many cheap lights (64+)"),
    ("variance", "Variance Cut", "Variance-minimising cut: fewer lights than median cut"),
]
SHADOWS = [
    ("SOFT", "Soft", "Sun angle = the light's angular diameter"),
    ("SHARP", "Sharp", "Sun angle 0"),
    ("NONE", "None", "Suns cast no shadows"),
]
MODES = [
    ("RESIDUAL", "Residual",
     "Camera and glossy rays see the HDR; other rays see what the lights did not take"),
    ("SH", "SH World", "The world's lighting is a smooth SH node tree (no image, noise-free)"),
    ("LIGHTS", "Lights Only", "The lamps carry all the light (camera and glossy rays see the HDR)"),
]


GROUND = [
    ("AUTO", "Auto", "Look for a ground in the scene: a large flat object under the others "
     "(its material's colour is the albedo)"),
    ("ON", "Albedo", "The scene stands on a ground plane (z = 0) of the albedo below"),
    ("NONE", "None", "No ground treatment: the map's lower half lights the scene as it is"),
]


class EnvLightSettings(bpy.types.PropertyGroup):
    read_scene: BoolProperty(
        name="Read Scene", default=True,
        description="Choose the world, the lamps' shadows and the ground treatment from the "
        "scene (render engine, materials, shadow casters, a ground); off: the settings below")
    source: EnumProperty(name="Source", items=[
        ("WORLD", "World Texture", "The image of the world's Environment Texture (also inside "
         "a node group), with its Mapping rotation"),
        ("FILE", "File", "An HDR file (.hdr, .exr, .pfm)")], default="WORLD")
    filepath: StringProperty(name="File", subtype="FILE_PATH")
    count: IntProperty(name="Lights", default=4, min=1, max=1024,
                       description="Number of lights (fit may return fewer)")
    method: EnumProperty(name="Method", items=METHODS, default="fit")
    order: IntProperty(name="Remainder Order", default=2, min=0, max=2,
                       description="Fit: SH order of the remainder (the SH world evaluates up "
                       "to order 2)")
    shadows: EnumProperty(name="Shadows", items=SHADOWS, default="SOFT")
    world_mode: EnumProperty(name="World", items=MODES, default="RESIDUAL")
    keep_background: BoolProperty(name="Keep Background", default=True,
                                  description="SH world: camera rays still see the HDR")
    glossy_hdr: BoolProperty(
        name="Glossy Rays See HDR", default=False,
        description="SH world: glossy rays see the HDR itself (the lamps then light no "
        "glossy reflection) instead of the smooth SH world")
    suns: BoolProperty(
        name="Sun Lamps", default=True,
        description="Split the map's suns off first as lamps of their own size (sharp "
        "shadows, exact highlights); the other lamps and the world take the rest")
    ground_mode: EnumProperty(name="Ground", items=GROUND, default="AUTO")
    ground_albedo: FloatProperty(name="Ground Albedo", default=0.5, min=0.0, max=1.0,
                                 subtype="FACTOR")
    volume_probe: BoolProperty(
        name="Bake Volume Probe", default=False,
        description="EEVEE-Next (4.2+): bake a volume light probe around the objects (not the "
        "ground): the light they bounce onto one another and the sky they hide; with or "
        "without Read Scene. Nearer Cycles on some maps, further on others (docs/blender_scenes.md)")
    eevee_dome: IntProperty(
        name="EEVEE Dome", default=64, min=0, max=1024,
        description="Read Scene in EEVEE-Next, objects casting shadows on a ground: the sky "
        "as this many soft-shadowed lamps, so the objects hide its light (0: 4 fitted lamps "
        "and the residual world)")
    # results, shown by the panel; list-valued ones hold one item a line ("\n"-joined: an
    # item may itself contain "; ", issue 28's orphan lines)
    has_result: BoolProperty(default=False)
    result_outcome: StringProperty()      # "made", "unchanged" (nothing to do) or "failed"
    result_count: IntProperty(name="Lamps")
    result_error: FloatProperty(name="Diffuse Error", subtype="PERCENTAGE")
    result_error_label: StringProperty()
    result_seconds: FloatProperty(name="Time", unit="TIME_ABSOLUTE")
    result_power: FloatVectorProperty(name="Power", size=3)
    result_residual_power: FloatVectorProperty(name="Residual Power", size=3)
    result_message: StringProperty()
    result_recipe: StringProperty(name="Recipe")
    result_engine: StringProperty()
    result_reasons: StringProperty()
    result_skipped: StringProperty()
    result_settings: StringProperty()
    result_expected: StringProperty()


def _lines(items):
    """One panel item a line (newlines inside an item become spaces)."""
    return "\n".join(str(i).replace("\n", " ") for i in items)


class ENVLIGHT_OT_create_lights(bpy.types.Operator):
    """Create sun lamps (and world nodes) from the world's HDR"""
    bl_idname = "envlight.create_lights"
    bl_label = "Create Lights"
    bl_options = {"REGISTER", "UNDO"}

    force: BoolProperty(
        name="Lamps Anyway", default=False, options={"SKIP_SAVE"},
        description="Cycles: make lamps even where the plain HDR world is as fast (the suns; "
        "on a map without one, lamps taken exactly from its brightest areas): still unbiased")

    @classmethod
    def poll(cls, context):
        return context.scene is not None and context.scene.world is not None

    def execute(self, context):
        world = context.scene.world
        settings = world.envlight
        wm = context.window_manager
        wm.progress_begin(0, 100)
        try:
            result = core.create_lights(context, settings, force=self.force,
                                        progress=lambda v: wm.progress_update(int(v * 100)))
        except core.NothingToDo as e:
            return self.unchanged(context, settings, e)
        except ImportError as e:
            self.report({"ERROR"}, "EnvLight: the envlight library cannot be loaded: %s" % e)
            return {"CANCELLED"}
        except Exception as e:  # envlight.Error, RuntimeError, bad files: a report, no traceback
            self.report({"ERROR"}, "EnvLight: %s" % e)
            settings.result_message = str(e)
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        settings.has_result = True
        settings.result_outcome = "made"
        settings.result_engine = context.scene.render.engine
        settings.result_count = result["count"]
        settings.result_error = 100.0 * result["diffuse_error"]
        settings.result_error_label = result["diffuse_label"]
        settings.result_seconds = result["seconds"]
        settings.result_power = result["power"]
        settings.result_residual_power = result["residual_power"]
        settings.result_message = _lines(result["warnings"])
        settings.result_recipe = result["recipe"]
        settings.result_reasons = _lines(result["reasons"])
        settings.result_skipped = _lines(result["skipped"])
        settings.result_settings = _lines(result["settings"])
        settings.result_expected = result.get("expected") or ""
        for w in result["warnings"]:
            self.report({"WARNING"}, "EnvLight: " + w)
        for n in result.get("notes", ()):
            self.report({"INFO"}, "EnvLight: " + n)
        self.report({"INFO"}, "EnvLight: recipe %s: %s" % (result["recipe"],
                                                          "; ".join(result["reasons"])))
        if result["skipped"]:
            self.report({"INFO"}, "EnvLight: skipped: " + "; ".join(result["skipped"]))
        self.report({"INFO"}, "EnvLight: %d lamps, diffuse error %.3f %% (unoccluded: %s), "
                    "%.2f s" % (result["count"], 100.0 * result["diffuse_error"],
                                result["diffuse_label"], result["seconds"]))
        if result.get("expected"):
            self.report({"INFO"}, "EnvLight: " + result["expected"])
        return {"FINISHED"}

    def unchanged(self, context, settings, e):
        """Nothing to compute for this scene: the panel says so and why (issue 28: it used to
        say it in the status bar only); a previous EnvLight result is removed, since the
        plain world is the pick. FINISHED (an undo step) when that removed something."""
        removed = core.remove_created(context.scene.world)
        settings.has_result = True
        settings.result_outcome = "unchanged"
        settings.result_engine = context.scene.render.engine
        settings.result_recipe = "unchanged"
        settings.result_count = 0
        settings.result_reasons = _lines([str(e)])
        settings.result_skipped = _lines([k for k in e.plan.skipped if k != str(e)])
        settings.result_settings = ""
        settings.result_expected = ""
        settings.result_message = _lines(["nothing computed: %s" % e] + e.warnings)
        if removed:
            settings.result_message += "\nremoved the previous EnvLight result (%d lamps)" \
                % removed
        self.report({"WARNING"}, "EnvLight: nothing computed: %s" % e)
        for w in e.warnings:
            self.report({"WARNING"}, "EnvLight: " + w)
        return {"FINISHED"} if removed else {"CANCELLED"}


class ENVLIGHT_OT_remove(bpy.types.Operator):
    """Remove the lamps and world nodes EnvLight created, and show again the lights it hid
    (nothing else)"""
    bl_idname = "envlight.remove"
    bl_label = "Remove EnvLight"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            n = core.remove_created(context.scene.world)
            shown = other_lights.restore(context.scene)
        except Exception as e:
            self.report({"ERROR"}, "EnvLight: %s" % e)
            return {"CANCELLED"}
        if context.scene.world:
            context.scene.world.envlight.has_result = False
            context.scene.world.envlight.result_message = ""
        self.report({"INFO"}, "EnvLight: removed %d lamps%s" % (
            n, "; shown again: %s" % other_lights.names(shown) if shown else ""))
        return {"FINISHED"}


class ENVLIGHT_OT_hide_other_lights(bpy.types.Operator):
    """Hide the scene's other lights in renders (the map carries the light); Remove EnvLight
    shows them again"""
    bl_idname = "envlight.hide_other_lights"
    bl_label = "Hide Other Lights"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.scene is not None and bool(other_lights.rendering(context.scene))

    def execute(self, context):
        objs = other_lights.hide(context.scene)
        self.report({"INFO"}, "EnvLight: hidden for the render: %s (Remove EnvLight shows "
                    "them again)" % other_lights.names(objs))
        return {"FINISHED"}


def wrapped(layout, text, context, icon="NONE", indent=False):
    """`text` as labels that fit the panel's width (Blender cuts a long label short): lines of
    as many characters as the region holds (about 7 px each at UI scale 1), the icon on the
    first, later lines indented by a blank icon."""
    width = context.region.width if context.region else 300
    scale = context.preferences.system.ui_scale if context.preferences else 1.0
    chars = max(24, int((width - 40) / (7.0 * scale)))
    for i, line in enumerate(textwrap.wrap(text, chars) or [""]):
        first = i == 0 and not indent
        layout.label(text=line, icon=icon if first else "BLANK1")


class WORLD_PT_envlight(bpy.types.Panel):
    bl_label = "EnvLight"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return context.world is not None

    def draw(self, context):
        layout = self.layout
        s = context.world.envlight
        layout.use_property_split = True
        layout.prop(s, "source")
        if s.source == "FILE":
            layout.prop(s, "filepath")
        else:
            src = core.find_environment_texture(context.world)
            if src is None or src.node.image is None:
                layout.label(text="No Environment Texture with an image", icon="ERROR")
            else:
                layout.label(text=src.node.image.name, icon="IMAGE_DATA")
        layout.prop(s, "read_scene")
        if s.read_scene:
            # the settings below are not used: not shown (issue 28: greyed-out values that
            # were not the recipe's); the result lists what was used
            layout.label(text="Lamps, shadows, world and ground: chosen from the scene")
        else:
            col = layout.column()
            col.prop(s, "count")
            col.prop(s, "method")
            if s.method == "fit":
                col.prop(s, "order")
            col.prop(s, "suns")
            col.prop(s, "shadows")
            col.prop(s, "world_mode")
            if s.world_mode == "SH":
                col.prop(s, "glossy_hdr")
                col.prop(s, "keep_background")
            col.prop(s, "ground_mode")
            if s.ground_mode == "ON":
                col.prop(s, "ground_albedo")
        if context.scene.render.engine == "BLENDER_EEVEE_NEXT":
            if s.read_scene:   # Read Scene's dome (with Read Scene off: the fitted lamps)
                layout.prop(s, "eevee_dome")
            layout.prop(s, "volume_probe")
        row = layout.row(align=True)
        row.operator(ENVLIGHT_OT_create_lights.bl_idname, icon="LIGHT_SUN")
        row.operator(ENVLIGHT_OT_remove.bl_idname, text="", icon="TRASH")
        self.draw_other_lights(context)
        if s.has_result:
            self.draw_result(context, s)
        elif s.result_message:
            box = layout.box()
            wrapped(box, s.result_message, context, icon="ERROR")

    def draw_other_lights(self, context):
        others = other_lights.rendering(context.scene)
        hid = other_lights.hidden(context.scene)
        if not others and not hid:
            return
        box = self.layout.box()
        if others:
            wrapped(box, "Also lighting the render: %s" % other_lights.names(others), context,
                    icon="LIGHT")
            box.operator(ENVLIGHT_OT_hide_other_lights.bl_idname,
                         text="Hide Them for the Render", icon="HIDE_ON")
        if hid:
            wrapped(box, "Hidden for the render by EnvLight: %s (Remove EnvLight shows them)"
                    % other_lights.names(hid), context, icon="HIDE_ON")

    def draw_result(self, context, s):
        box = self.layout.box()
        engine = scene_reader.ENGINES.get(s.result_engine, s.result_engine)
        if s.result_outcome == "unchanged":
            wrapped(box, "%s: nothing changed" % engine, context,
                    icon="CHECKMARK")
        else:
            wrapped(box, "%s: recipe %s, %d lamps" % (engine, s.result_recipe, s.result_count),
                    context, icon="CHECKMARK")
        for part in s.result_reasons.split("\n"):
            if part:
                wrapped(box, part, context, icon="DOT")
        for part in s.result_settings.split("\n"):
            if part:
                wrapped(box, part, context, icon="PROPERTIES")
        for part in s.result_skipped.split("\n"):
            if part:
                wrapped(box, "skipped: " + part, context, icon="REMOVE")
        if s.result_outcome == "made":
            wrapped(box, "diffuse error %.3f %% (unoccluded: %s)"
                    % (s.result_error, s.result_error_label), context, icon="INFO")
            if s.result_expected:
                wrapped(box, s.result_expected, context, icon="INFO")
            box.label(text="time %.2f s" % s.result_seconds, icon="TIME")
        for part in s.result_message.split("\n"):
            if part and not part.startswith("nothing computed"):
                wrapped(box, part, context, icon="ERROR")
        if s.result_outcome == "unchanged" and s.result_engine == "CYCLES":
            op = box.operator(ENVLIGHT_OT_create_lights.bl_idname,
                              text="Create Lamps Anyway", icon="LIGHT_SUN")
            op.force = True


classes = (EnvLightSettings, ENVLIGHT_OT_create_lights, ENVLIGHT_OT_remove,
           ENVLIGHT_OT_hide_other_lights, WORLD_PT_envlight)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.World.envlight = PointerProperty(type=EnvLightSettings)


def unregister():
    del bpy.types.World.envlight
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
