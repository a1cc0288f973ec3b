"""The fit's figures beyond its diffuse error (docs/methods.md, "The fit's take"), shared by
tests/py_fit_gate.py and scripts/fit_bench.py:

- up_error: what the lights + remainder give the normal +Z (a ground) against the exact
  irradiance there (envl_irradiance_exact), relative, luminance;
- lamps_errors: the lights as Blender lamps over the residual map (a sun of irradiance
  rgb (1 - w / 4 pi) at normal incidence along each light, plus the residual's exact
  irradiance): the relative RMS over the error measure's 1024 normals, and at +Z;
- residual_structure: what the residual shows that the map did not: the largest change of a
  pixel's chromaticity, and the largest local contrast added between neighbouring pixels, per
  degree."""
import math

import numpy as np

import envlight

LUM = np.array([0.2126, 0.7152, 0.0722])
UP = [(0.0, 0.0, 1.0)]
FLOOR = 1e-3    # luminances below this x the map's mean luminance count as this (log of 0)


def up_error(env, res):
    """(lights + remainder)(+Z) / E_exact(+Z) - 1, luminance."""
    exact = np.array(env.irradiance(UP))[0] @ LUM
    model = np.array(res.irradiance(UP))[0] @ LUM
    return model / exact - 1.0


def lamps_errors(env, res):
    """-> (rms, up): the lights as point lamps of irradiance rgb (1 - w / 4 pi) at normal
    incidence, plus the residual map's exact irradiance, against the map's: the relative RMS
    of luminance over the 1024 normals (design.md's measure) and the relative error at +Z."""
    normals = np.array(envlight.fibonacci_directions())
    ref = np.array(env.reference_irradiance())
    exact_up = np.array(env.irradiance(UP))[0]
    with envlight.from_pixels(res.residual, layout="latlong") as r:
        rest = np.array(r.reference_irradiance())
        rest_up = np.array(r.irradiance(UP))[0]
    lamps = np.zeros_like(ref)
    lamps_up = np.zeros(3)
    for l in res.lights:
        e = np.array(l.rgb) * (1 - l.solid_angle / (4 * math.pi))
        d = np.array(l.direction)
        lamps += np.maximum(normals @ d, 0)[:, None] * e[None, :]
        lamps_up += e * max(0.0, d[2])
    rms = envlight.relative_rms_luminance(lamps + rest, ref)
    return rms, (lamps_up + rest_up) @ LUM / (exact_up @ LUM) - 1.0


def _neighbour_angles(h, w):
    """Angles (degrees) between horizontally neighbouring pixel centres of each row (the seam
    included) and between vertically neighbouring rows, of a w x h lat-long map."""
    theta = math.pi * (0.5 - (np.arange(h) + 0.5) / h)
    across = np.degrees(2 * np.arcsin(np.cos(theta) * math.sin(math.pi / w)))
    return across, math.degrees(math.pi / h)


def residual_structure(map_px, res_px):
    """-> (colour, contrast). colour: the largest difference of chromaticity (r, g, b over their
    sum) between a residual pixel and the map's, over pixels where both are above FLOOR x the
    map's mean luminance. contrast: the largest (|step of log Y| of the residual - |step of
    log Y| of the map) between neighbouring pixels (along a row, the seam included, and along a
    column), divided by their angular distance in degrees; Y floored at FLOOR x the mean."""
    map_px = np.asarray(map_px, dtype=np.float64)
    res_px = np.asarray(res_px, dtype=np.float64)
    h, w = map_px.shape[:2]
    ym, yr = map_px @ LUM, res_px @ LUM
    omega = np.cos(math.pi * (0.5 - (np.arange(h) + 0.5) / h))
    mean = (ym * omega[:, None]).sum() / (omega.sum() * w)
    floor = FLOOR * mean if mean > 0 else 1e-30
    ok = (ym > floor) & (yr > floor)
    colour = 0.0
    if ok.any():
        sm = map_px[ok].sum(-1, keepdims=True)
        sr = res_px[ok].sum(-1, keepdims=True)
        colour = float(np.abs(map_px[ok] / sm - res_px[ok] / sr).max())
    lm, lr = np.log(np.maximum(ym, floor)), np.log(np.maximum(yr, floor))
    across, down = _neighbour_angles(h, w)
    wrap_m, wrap_r = np.roll(lm, -1, axis=1), np.roll(lr, -1, axis=1)
    step_row = (np.abs(wrap_r - lr) - np.abs(wrap_m - lm)) / np.maximum(across, 1e-12)[:, None]
    step_col = (np.abs(np.diff(lr, axis=0)) - np.abs(np.diff(lm, axis=0))) / down
    contrast = max(float(step_row.max()), float(step_col.max()) if h > 1 else 0.0, 0.0)
    return colour, contrast
