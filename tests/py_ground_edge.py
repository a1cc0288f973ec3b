"""A ground of finite size (plugin/envlight_addon/ground_edge.py, issue 28): the depression of
the ground's edge seen from the objects against the closed form atan(height / distance), the
band of a lat-long map that passes beyond the edge (rows by their centres' elevation, columns
by their azimuth, turned with the world's Mapping node) and the band's pixels filled.

The module needs only numpy and math: it is loaded from its file, outside Blender."""
import math
import os
import sys

import pytest

np = pytest.importorskip("numpy", reason="SKIP: numpy is not installed (python3-numpy)")

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_modules  # noqa: E402

edge = addon_modules.load("ground_edge")

# the scene bench's ground: 20 x 20 m, its top at z = 0, a sphere of radius 1 on it
LO, HI, CENTRE = (-10.0, -10.0, -0.01), (10.0, 10.0, 0.0), (0.0, 0.0, 1.0)


def test_depression_closed_form():
    # along +x the edge is 10 m away, along the diagonal 10 sqrt 2: atan(h / d)
    assert edge.edge_depression(LO, HI, CENTRE, 0.0) == pytest.approx(math.atan(0.1), abs=1e-15)
    assert edge.edge_depression(LO, HI, CENTRE, math.pi / 4) == pytest.approx(
        math.atan(1 / (10 * math.sqrt(2))), abs=1e-12)
    assert edge.edge_depression(LO, HI, CENTRE, math.pi) == pytest.approx(math.atan(0.1),
                                                                          abs=1e-15)
    # off centre: 2 m from the +x edge, 18 m from the -x edge
    c = (8.0, 0.0, 1.0)
    assert edge.edge_depression(LO, HI, c, 0.0) == pytest.approx(math.atan(0.5), abs=1e-15)
    assert edge.edge_depression(LO, HI, c, math.pi) == pytest.approx(math.atan(1 / 18),
                                                                     abs=1e-15)
    # outside the ground's extent: taken at the nearest point inside (its edge: d = 0 outward)
    assert edge.edge_depression(LO, HI, (30.0, 0.0, 1.0), 0.0) == pytest.approx(math.pi / 2)
    # a centre on or under the ground's top sees no band
    assert edge.edge_depression(LO, HI, (0.0, 0.0, 0.0), 0.0) == 0.0
    least, most = edge.depression_range(LO, HI, CENTRE)
    assert least == pytest.approx(math.atan(1 / (10 * math.sqrt(2))), abs=1e-12)
    assert most == pytest.approx(math.atan(0.1), abs=1e-15)


def full(h, w, band):
    """band()'s rows as a height x width mask."""
    first, rows = band
    mask = np.zeros((h, w), bool)
    mask[first:first + rows.shape[0]] = rows
    return mask


def band_rows_expected(h, depression):
    """Rows whose centre elevation pi (0.5 - (r + 0.5) / h) lies in (-depression, 0)."""
    return [r for r in range(h) if -depression < math.pi * (0.5 - (r + 0.5) / h) < 0]


def test_band_rows_and_columns():
    h, w = 128, 256
    lo, hi = (-10.0, -2.0, -0.01), (10.0, 2.0, 0.0)  # narrow along y: a deeper band there
    b = edge.band(np, h, w, lo, hi, CENTRE)
    mask = full(h, w, b)
    # the rows held: from the first below the horizon to the deepest, no more
    assert b[0] == h // 2 and b[1].any(axis=1).all() and not mask[:h // 2].any()
    for c in (0, 31, 64, 100, 192, 255):
        phi = math.pi - 2 * math.pi * (c + 0.5) / w
        want = band_rows_expected(h, edge.edge_depression(lo, hi, CENTRE, phi))
        assert list(np.nonzero(mask[:, c])[0]) == want
    # a column looking along y (phi = pi/2 at c = w/4 - 0.5) has the deeper band
    assert mask[:, w // 4].sum() > mask[:, 0].sum() >= 1


def test_band_turns_with_the_mapping():
    # the world turned by +90 degrees about Z: map column c looks along phi_c + 90 degrees
    h, w = 64, 128
    lo, hi = (-10.0, -2.0, -0.01), (10.0, 2.0, 0.0)
    t = math.pi / 2
    rot = [[math.cos(t), -math.sin(t), 0.0], [math.sin(t), math.cos(t), 0.0], [0.0, 0.0, 1.0]]
    turned = full(h, w, edge.band(np, h, w, lo, hi, CENTRE, rot))
    for c in range(0, w, 7):
        phi = math.pi - 2 * math.pi * (c + 0.5) / w + t
        want = band_rows_expected(h, edge.edge_depression(lo, hi, CENTRE, phi))
        assert list(np.nonzero(turned[:, c])[0]) == want
    assert not (turned == full(h, w, edge.band(np, h, w, lo, hi, CENTRE))).all()


def test_add_fills_the_band_only():
    h, w = 32, 64
    b = edge.band(np, h, w, LO, HI, (0.0, 0.0, 4.0))
    mask = full(h, w, b)
    image = np.full((h, w, 3), 0.25, np.float32)
    source = np.random.default_rng(3).random((h, w, 3)).astype(np.float32)
    out = edge.add(image, b, source[mask] - 0.25)
    assert out is image  # in place
    # two float32 roundings (the difference, the sum) of values under 1: 2 x 2^-25
    assert mask.any() and np.abs(out[mask] - source[mask]).max() <= 2.0 ** -24
    assert np.all(out[~mask] == 0.25)
