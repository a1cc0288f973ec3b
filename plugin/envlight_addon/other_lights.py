"""The scene's own lights beside EnvLight's (issue 28): the default startup scene's 1000 W point
light renders on top of the map's light unless it is hidden. Create Lights says which lights
render besides its own; the panel's Hide Them for the Render (the operator Hide Other
Lights) hides them in renders (Object.hide_render, the
camera icon), marking each with HIDDEN so that Remove EnvLight shows them again; nothing else
about them changes.
"""
from .scene import _ours

#: object custom property: EnvLight hid this light for the render (Remove shows it again)
HIDDEN = "envlight_hidden"
#: the most lights named in a line of the panel or the report
NAMED = 3


def rendering(scene):
    """The scene's lights that are not EnvLight's and render (hide_render off)."""
    return [o for o in scene.objects if o.type == "LIGHT" and not _ours(o) and not o.hide_render]


def hidden(scene):
    """The lights EnvLight hid for the render."""
    return [o for o in scene.objects if o.type == "LIGHT" and o.get(HIDDEN)]


def describe(obj):
    """'Light' (Point, 1000 W); a sun's strength is an irradiance (W/m^2)."""
    d = obj.data
    return "'%s' (%s, %g %s)" % (obj.name, d.type.title(), d.energy,
                                 "W/m\u00b2" if d.type == "SUN" else "W")


def names(objs):
    """The first NAMED descriptions, then how many more."""
    text = ", ".join(describe(o) for o in objs[:NAMED])
    return text + (" and %d more" % (len(objs) - NAMED) if len(objs) > NAMED else "")


def warning(scene):
    """The report's line about the scene's other lights, or None when there are none."""
    objs = rendering(scene)
    if not objs:
        return None
    return ("the scene has %d other light%s that render%s: %s; %s light adds to the map's "
            "(the panel's button hides %s in renders; Remove EnvLight shows %s again)"
            % (len(objs), "s" if len(objs) > 1 else "", "" if len(objs) > 1 else "s",
               names(objs), "their" if len(objs) > 1 else "its",
               "them" if len(objs) > 1 else "it", "them" if len(objs) > 1 else "it"))


def hide(scene):
    """Hides the other rendering lights in renders, marked HIDDEN. -> the lights hidden."""
    objs = rendering(scene)
    for o in objs:
        o.hide_render = True
        o[HIDDEN] = True
    return objs


def restore(scene):
    """Shows again what hide() hid (Remove EnvLight). -> the lights shown."""
    objs = hidden(scene)
    for o in objs:
        o.hide_render = False
        del o[HIDDEN]
    return objs
