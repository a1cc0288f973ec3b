"""The EEVEE dome's world share (plugin/envlight_addon/eevee_dome.py, issue 28): the first
moments of a lat-long image against their closed forms, and the least share k of the sky
kept in a world of the ground's bounce so that EEVEE-Next does not dering its order-1 light.

The module needs only numpy and math: it is loaded from its file, outside Blender."""
import math
import os
import sys

import pytest

np = pytest.importorskip("numpy", reason="SKIP: numpy is not installed (python3-numpy)")

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_modules  # noqa: E402

dome = addon_modules.load("eevee_dome")

H, W = 256, 512


def halves(upper, lower):
    """A lat-long image of radiance `upper` (rgb) above the horizon, `lower` below."""
    px = np.zeros((H, W, 3), np.float32)
    px[:H // 2] = upper
    px[H // 2:] = lower
    return px


def test_moments_of_uniform_and_half_spheres():
    # sum L dw over the sphere = 4 pi L (the rows' solid angles are exact); sum L d dw = 0
    I, M = dome.moments(np, halves((1, 2, 3), (1, 2, 3)))
    assert np.allclose(I, 4 * math.pi * np.array([1, 2, 3]), rtol=1e-6)
    assert np.allclose(M, 0, atol=1e-5)
    # the upper half: sum L dw = 2 pi L, sum L z dw = pi L, x and y 0 (the columns' phi are
    # symmetric); the lower half the same with z negated
    I, M = dome.moments(np, halves((2, 2, 2), (0, 0, 0)))
    assert np.allclose(I, 4 * math.pi, rtol=1e-6)
    assert np.allclose(M[:, 2], 2 * math.pi, rtol=1e-4)
    assert np.allclose(M[:, :2], 0, atol=1e-4)
    I, M = dome.moments(np, halves((0, 0, 0), (1, 1, 1)))
    assert np.allclose(M[:, 2], -math.pi, rtol=1e-4)


def test_moments_follow_the_canonical_azimuth():
    # one column lit: its direction is (sin th cos phi, sin th sin phi, cos th) with
    # phi = pi - 2 pi (c + 0.5) / W, the library's Envmap.direction
    px = np.zeros((H, W, 3), np.float32)
    c = W // 8
    px[:, c] = 1.0
    I, M = dome.moments(np, px)
    phi = math.pi - 2 * math.pi * (c + 0.5) / W
    m = M[0] / I[0]
    # sum sin(th) dw / sum dw over a column = (pi / 4) (the mean of sin th over the sphere)
    assert m[0] == pytest.approx(math.pi / 4 * math.cos(phi), rel=1e-3)
    assert m[1] == pytest.approx(math.pi / 4 * math.sin(phi), rel=1e-3)
    assert abs(m[2]) < 1e-6


def test_world_share_is_the_closed_form_least_share():
    # ground G below, sky U above, uniform: m_z(k) = (k U - G) / (2 (k U + G)); |m_z| <= b
    # first at k = G (1 - 2 b) / (U (1 + 2 b)), rounded up to the steps of 1/200
    G, U = 0.3, 2.0
    b = dome.DERING_BOUND
    k_exact = G * (1 - 2 * b) / (U * (1 + 2 * b))
    k, after, before = dome.world_share(np, halves(0, G), halves(U, 0))
    assert before == pytest.approx(0.5, rel=1e-4)         # the bounce alone: |m_z| = 1/2
    assert k_exact <= k < k_exact + 1 / 200 + 1e-9
    assert after <= b
    # one step less derings
    Ig, Mg = dome.moments(np, halves(0, G))
    Is, Ms = dome.moments(np, halves(U, 0))
    k1 = k - 1 / 200
    assert dome.dering_measure(np, Ig + k1 * Is, Mg + k1 * Ms) > b


def test_world_share_is_zero_when_nothing_is_deringed_and_takes_the_worst_channel():
    # a bright ground (G = U): |m_z| = 0 at k = 1, but 1/2 at k = 0 -> a share
    k, _, _ = dome.world_share(np, halves(0, 1.0), halves(1.0, 0))
    assert 0 < k < 1
    # a world of its own balanced (light above and below): no share
    ground = halves(0.2, 0.3)   # not only below: 0.2 above too
    k, after, before = dome.world_share(np, ground, halves(1.0, 0))
    assert k == 0 and after == before <= dome.DERING_BOUND
    # the blue channel's ground alone is dark: its share decides (red balanced, blue not)
    ground = halves((0.25, 0.25, 0.0), (0.3, 0.3, 0.3))
    k, after, _ = dome.world_share(np, ground, halves(1.0, 0))
    kb = 0.3 * (1 - 2 * dome.DERING_BOUND) / (1 + 2 * dome.DERING_BOUND)
    assert kb <= k < kb + 1 / 200 + 1e-9


def test_world_share_turned_about_z_stays_under_the_bound():
    # a lit sky cell off the axis: the bound holds for max(|m_z|, |m_xy|), whatever the
    # world's Mapping turns about Z, so every turn's max_i |m_i| stays under it
    sky = np.zeros((H, W, 3), np.float32)
    sky[20:60, 40:120] = 5.0
    ground = halves(0, 0.2)
    k, after, _ = dome.world_share(np, ground, sky)
    I, M = dome.moments(np, ground + k * sky)
    for turn in np.linspace(0, 2 * math.pi, 13):
        c, s = math.cos(turn), math.sin(turn)
        for ch in range(3):
            m = M[ch] / I[ch]
            mx = (c * m[0] - s * m[1], s * m[0] + c * m[1], m[2])
            assert max(abs(v) for v in mx) <= dome.DERING_BOUND + 1e-9
