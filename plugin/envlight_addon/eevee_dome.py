"""EEVEE's dome (issue 28): the sky as many soft-shadowed sun lamps, so that the objects
occlude its light as they hide the sky.

EEVEE lights diffuse and glossy from one capture of the world, and its diffuse from the world
is the world's order-1 SH irradiance, never occluded by an object (issue 14). Lamps with
shadows are what EEVEE occludes: the sky half (the map less its suns; over a ground, the
ground's bounce stays in the world below the horizon, where a lamp would be hidden by the
ground itself) is cut into DOME cells by the library's variance cut, each a sun lamp of its
cell's power and angle. (Lamps of negative energy, which could have taken the sky's diffuse
out of a world kept whole for the reflections, are ignored by EEVEE-Next: measured, a world's
diffuse unchanged by them.)
"""
import math

#: lamps in the dome (the variance cut of the sky)
DOME = 64
#: the dome lamps' finest shadow texel, as a share of the largest extent of the scene's
#: objects (the ground left out): their shadows are soft, wider than this
SHADOW_TEXEL = 0.01


def upper_half(np, pixels):
    """The map's rows above the horizon only (a ground hides the rest), as a copy."""
    px = np.array(pixels)
    px[px.shape[0] // 2:] = 0.0
    return px


def dome_angle_degrees(lights):
    """The dome lamps' angles, smallest and largest (degrees), for the report."""
    a = [math.degrees(l.angle) for l in lights]
    return (min(a), max(a)) if a else (0.0, 0.0)


def shadow_resolution(scene):
    """The dome lamps' Light.shadow_maximum_resolution (m): SHADOW_TEXEL x the largest extent
    of the visible objects other than a ground (find_ground), or None without any."""
    from . import scene as reader
    objs = reader._visible_meshes(scene)
    ground = reader.find_ground(objs)
    boxes = [reader._world_box(o) for o in objs if o is not ground]
    if not boxes:
        return None
    ext = max(max(hi[i] - lo[i] for i in range(3)) for lo, hi in boxes)
    return SHADOW_TEXEL * ext if ext > 0 else None
