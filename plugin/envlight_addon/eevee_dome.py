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

EEVEE-Next "derings" its world's order-1 light: with mu the mean radiance and m the first
moment (sum L d dw / sum L dw), it shades a normal n with mu (1 + 2 m.n) after scaling m by
min(1, 1 / (3 max_i |m_i|)) (the least over the channels; Blender's
spherical_harmonics_dering). A world that is only the ground's bounce below the horizon has
|m_z| near 1/2: EEVEE scales it by about 2/3, and open ground facing up gets light from below
(measured on a matte sphere on a ground, potsdamer_platz: the ground +9 %, scripts/
blender_eevee_parts.py). So a share k of the sky stays in the world, the least that keeps
every |m_i| under 1/3 (for any turn of the world about Z: max(|m_z|, |m_xy|)), and the lamps
take the rest.
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


#: the deringing bound on |m_i| (1/3), with a margin for the world's capture
DERING_BOUND = 0.97 / 3


def moments(np, pixels):
    """-> (I, M): per channel sum L dw (3,) and sum L d dw (3 channels, 3 axes) of a lat-long
    image in the canonical frame (envlight's Envmap.direction: theta from +Z (r + 0.5) pi / H,
    phi = pi - 2 pi (c + 0.5) / W; pixel solid angles exact per row)."""
    h, w = pixels.shape[:2]
    rows = np.arange(h)
    dw = (np.cos(rows * math.pi / h) - np.cos((rows + 1) * math.pi / h)) * 2 * math.pi / w
    th = (rows + 0.5) * math.pi / h
    ph = math.pi - 2 * math.pi * (np.arange(w) + 0.5) / w
    px = np.asarray(pixels[..., :3], dtype=np.float32)
    # one pass over the image: per row and channel the sums of L, L cos phi, L sin phi
    basis = np.stack([np.ones(w), np.cos(ph), np.sin(ph)], axis=1)       # (w, 3)
    rows_k = np.einsum("hwc,wk->hkc", px, basis, dtype=np.float64)        # (h, 3, 3)
    row_sum, row_cos, row_sin = rows_k[:, 0], rows_k[:, 1], rows_k[:, 2]
    I = (row_sum * dw[:, None]).sum(axis=0)
    M = np.stack([(row_cos * (dw * np.sin(th))[:, None]).sum(axis=0),
                  (row_sin * (dw * np.sin(th))[:, None]).sum(axis=0),
                  (row_sum * (dw * np.cos(th))[:, None]).sum(axis=0)], axis=1)
    return I, M


def dering_measure(np, I, M):
    """The largest of max(|m_z|, |m_xy|) over the channels with light (0 without any)."""
    worst = 0.0
    for c in range(3):
        if I[c] > 0:
            m = M[c] / I[c]
            worst = max(worst, abs(m[2]), math.hypot(m[0], m[1]))
    return worst


def world_share(np, ground, sky, steps=200):
    """The least share k of the sky (0..1) that, kept in a world whose other part is
    `ground` (the bounce below the horizon), keeps EEVEE-Next from deringing it
    (DERING_BOUND); where no share does, the one that comes nearest. -> (k, measure at k,
    measure at 0)."""
    Ig, Mg = moments(np, ground)
    Is, Ms = moments(np, sky)
    best = None
    for i in range(steps + 1):
        k = i / steps
        v = dering_measure(np, Ig + k * Is, Mg + k * Ms)
        if i == 0:
            v0 = v
        if v <= DERING_BOUND:
            return k, v, v0
        if best is None or v < best[1]:
            best = (k, v)
    return best[0], best[1], v0


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
