"""Lamps taken exactly out of a map that has no sun (issue 28, Create Lamps Anyway in Cycles).

A Blender sun lamp of angle a shines a cone of half-angle a/2 with one radiance L. Taking from
the map, in that cone, exactly L per unit solid angle (per channel; each pixel's share of its
area inside the cone, `coverage`), with L the largest value that leaves no pixel negative,

    L = min over the cone's pixels of residual / coverage,   residual -= L coverage,

leaves lamp + residual world equal to the map: the render converges to the plain HDR world's.
The lamp's solid angle is w = sum coverage dw, its power rgb = L w (the add-on gives Blender
rgb (1 - w / 4 pi), the cone's irradiance at normal incidence). A lamp takes only the floor of
its cone: on a map without a sun that is a part of the light, which the panel says.
"""
import math

#: sub-pixels a side for the coverage of a pixel crossed by a cone's rim
SUBPIXELS = 4


class DiscLight:
    """A lamp taken exactly: direction (unit), rgb (L w), solid_angle w, angle (the cone of
    solid angle w: 2 acos(1 - w / 2 pi))."""

    def __init__(self, direction, rgb, solid_angle):
        self.direction = tuple(direction)
        self.rgb = tuple(rgb)
        self.solid_angle = solid_angle
        self.angle = 2.0 * math.acos(max(-1.0, 1.0 - solid_angle / (2.0 * math.pi)))


def _directions(np, u, v):
    """The canonical frame's directions at image coordinates u, v (docs/design.md)."""
    phi, theta = np.broadcast_arrays(np.pi * (1.0 - 2.0 * u), np.pi * (0.5 - v))
    return np.stack([np.cos(theta) * np.cos(phi), np.cos(theta) * np.sin(phi),
                     np.sin(theta)], axis=-1)


def coverage(np, h, w, centre, half_angle):
    """(h, w) share of each lat-long pixel's solid angle inside the cone: 0 or 1 away from its
    rim, SUBPIXELS^2 sub-pixels (weighted by their solid angle) along it."""
    c = np.asarray(centre, dtype=np.float64)
    rows, cols = np.arange(h), np.arange(w)
    d = _directions(np, (cols[None, :] + 0.5) / w, (rows[:, None] + 0.5) / h)
    ang = np.arccos(np.clip(d @ c, -1.0, 1.0))
    # a pixel's half diagonal, as an angle: its rows' height and its width at its widest
    half = 0.5 * math.hypot(math.pi / h, 2.0 * math.pi / w)
    cov = (ang <= half_angle).astype(np.float64)
    rim = np.abs(ang - half_angle) < half
    rr, cc = np.nonzero(rim)
    if rr.size:
        s = (np.arange(SUBPIXELS) + 0.5) / SUBPIXELS
        su = (cc[:, None, None] + s[None, None, :]) / w                  # (n, 1, S)
        sv = (rr[:, None, None] + s[None, :, None]) / h                  # (n, S, 1)
        sub = _directions(np, su, sv)                                    # (n, S, S, 3)
        inside = np.arccos(np.clip(sub @ c, -1.0, 1.0)) <= half_angle
        weight = np.cos(np.pi * (0.5 - sv)) + 0.0 * su                   # dw ~ cos(elevation)
        cov[rr, cc] = (inside * weight).sum(axis=(1, 2)) / weight.sum(axis=(1, 2))
    return cov


#: the half angles (degrees) tried around each direction: the one whose lamp takes the most
#: light (luminance) is kept (a wide cone holds darker pixels, so its floor is lower)
HALF_ANGLES = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0)


def _floor(np, res, cov):
    m = cov > 0
    return (res[m] / cov[m][:, None]).min(axis=0) if m.any() else np.zeros(3)


def take(np, pixels, solid_angles, directions, luminance=(0.2126, 0.7152, 0.0722)):
    """Lamps taken exactly from `pixels` (h, w, 3, row 0 at the top; not changed) around
    `directions` (the first first), each cone of the HALF_ANGLES that takes the most light:
    -> ([DiscLight], the residual). A direction whose every cone holds a black pixel gives
    no lamp."""
    res = np.array(pixels, dtype=np.float64)
    h, w = res.shape[:2]
    dw = np.asarray(solid_angles, dtype=np.float64)[:, None]             # per row
    lum = np.asarray(luminance)
    lamps = []
    d = _directions(np, (np.arange(w)[None, :] + 0.5) / w, (np.arange(h)[:, None] + 0.5) / h)
    for direction in directions:
        # the cone by the pixels' centres to choose its size, then its exact coverage
        ang = np.arccos(np.clip(d @ np.asarray(direction, dtype=np.float64), -1.0, 1.0))
        best = None
        for a in HALF_ANGLES:
            inside = ang <= math.radians(a)
            if not inside.any():
                continue
            taken = float(res[inside].min(axis=0) @ lum) * float((inside * dw).sum())
            if best is None or taken > best[0]:
                best = (taken, math.radians(a))
        if best is None:
            continue
        cov = coverage(np, h, w, direction, best[1])
        L = _floor(np, res, cov)
        if not L.max() > 0:
            continue
        res -= L[None, None, :] * cov[..., None]
        np.maximum(res, 0.0, out=res)     # rounding only: L is the minimum of res / cov
        wsum = float((cov * dw).sum())
        lamps.append(DiscLight(direction, [float(v) * wsum for v in L], wsum))
    return lamps, res.astype(np.float32)
