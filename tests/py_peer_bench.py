"""scripts/peer_bench.py's own arithmetic (issue 29), against answers known in closed form: the
cube faces' solid angles, envlight's cube faces read back in the canonical frame (a linear sky,
whose irradiance is exact), the brute-force Phong sum on a linear sky, the m decode of RGBE
and the peers' SH transforms. The peers themselves are not run here (they are not built in
CI); peer_bench.sh checks their mappings on every run."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

SOURCE = os.environ.get("ENVL_SOURCE_DIR", os.path.join(os.path.dirname(__file__), ".."))
ENVLIGHT = os.environ.get("ENVLIGHT", "")
sys.path.insert(0, os.path.join(SOURCE, "scripts"))
import peer_bench as pb  # noqa: E402


def write_pfm(path, img):
    """(H, W, 3) float32, row 0 on top -> a little-endian PFM (rows bottom to top)."""
    h, w = img.shape[:2]
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())


def linear_sky(w, h, a, b):
    """L(d) = a + b.d at each pixel centre (canonical frame, docs/design.md)."""
    t = math.pi * (0.5 - (np.arange(h) + 0.5) / h)
    f = math.pi * (1 - 2 * (np.arange(w) + 0.5) / w)
    d = np.stack([np.outer(np.cos(t), np.cos(f)), np.outer(np.cos(t), np.sin(f)),
                  np.repeat(np.sin(t)[:, None], w, axis=1)], axis=2)
    L = a + d @ np.asarray(b, float)
    return np.repeat(L[..., None], 3, axis=2).astype(np.float32)


@pytest.mark.parametrize("n", [1, 2, 7, 32])
def test_face_solid_angles_sum_to_the_sphere(n):
    for faces in (list(pb.ENVLIGHT_FACES.values()), [f[1:] for f in pb.GL_FACES]):
        total = sum(pb.face_texels(np, n, *f)[1].sum() for f in faces)
        assert abs(total - 4 * math.pi) < 1e-12, total


def test_face_tables_handedness():
    """envlight's faces are views from inside (right x up = -centre, docs/design.md); the
    OpenGL table of cmft and cmgen is the mirror image (right x up = +centre: the faces of an
    OpenGL cube map, s and t as the spec's table gives them, seen from inside are mirrored).
    A table copied with one sign wrong breaks one of these."""
    for faces, sign in ((list(pb.ENVLIGHT_FACES.values()), -1), ([f[1:] for f in pb.GL_FACES], 1)):
        assert sorted(tuple(c) for c, r, u in faces) == sorted(
            tuple(s * np.eye(3)[k]) for k in range(3) for s in (1, -1))
        for c, r, u in faces:
            assert np.array_equal(np.cross(r, u), sign * np.asarray(c)), (c, r, u)


@pytest.mark.skipif(not ENVLIGHT, reason="needs ENVLIGHT (the built CLI)")
def test_envlight_cube_read_back_in_the_canonical_frame(tmp_path):
    """A linear sky L = a + b.d has E(n) = pi a + (2 pi / 3) b.n exactly; envlight's exact
    irradiance cube, read by peer_bench.py's face table, must give that at every texel centre.
    A face read turned or mirrored moves b.n by up to 2 |b| pi / 3 (1.9 here), the map's
    pixels as constants move E by O(pixel^2) (64 x 32: < 1e-3 relative)."""
    a, b = 2.0, (0.6, -0.9, 0.4)
    write_pfm(tmp_path / "sky.pfm", linear_sky(64, 32, a, b))
    (tmp_path / "folder").mkdir()
    subprocess.run([ENVLIGHT, "prefilter", str(tmp_path / "sky.pfm"), "-o",
                    str(tmp_path / "folder" / "maps"), "--irradiance", "--layout", "cube",
                    "--irradiance-size", "8", "--irradiance-method", "exact", "--format", "pfm",
                    "-q", "--no-error"], check=True)
    (p,) = pb.products(np, str(tmp_path / "folder"), "envlight")
    assert p["kind"] == "irradiance" and len(p["dirs"]) == 6 * 64
    exact = math.pi * a + (2 * math.pi / 3) * (p["dirs"] @ np.asarray(b))
    assert np.max(np.abs(p["rgb"][:, 1] / exact - 1)) < 1e-3


def test_phong_reference_on_a_linear_sky():
    """sum L (R.l)^p dw / sum (R.l)^p dw over R.l > 0 for L = a + b.l is a + (p + 1) / (p + 2)
    b.R (the clipped lobe's integrals 2 pi / (p + 1) and 2 pi R / (p + 2)); pixel centres
    on 512 x 256 against a lobe of power 10: within 2e-4."""
    a, b, p = 1.0, np.array([0.3, 0.5, -0.7]), 10.0
    img = linear_sky(512, 256, a, b)
    rng = np.random.default_rng(3)
    R = rng.normal(size=(40, 3))
    R /= np.linalg.norm(R, axis=1)[:, None]
    got = pb.phong_reference(np, img, p, R)[:, 0]
    want = a + (p + 1) / (p + 2) * (R @ b)
    assert np.max(np.abs(got - want)) < 2e-4, np.max(np.abs(got - want))


def test_m_decode_recovered_exactly():
    """(m + 0.5) 2^(e - 136) (envlight's decode) back to m 2^(e - 136) (cmft's), bit for bit,
    over the mantissa's whole range and exponents from tiny to huge."""
    rng = np.random.default_rng(5)
    e = rng.integers(100, 170, size=(64, 64))
    m = rng.integers(0, 256, size=(64, 64, 3))
    m[..., 0] = rng.integers(128, 256, size=(64, 64))   # the largest channel has m >= 128
    scale = np.exp2(e - 136.0)[..., None]
    got = pb.floor_decode(np, ((m + 0.5) * scale).astype(np.float32).astype(np.float64))
    assert np.array_equal(got, m * scale)


@pytest.mark.parametrize("peer", ["cmft", "cmgen"])
def test_peer_frames_and_transforms(peer):
    """each peer's frame has its inverse beside it, and the SH transform from it fits to
    rounding (a rotation or reflection maps each band into itself)."""
    to, back = pb.PEER_FRAMES[peer]
    d = np.random.default_rng(7).normal(size=(50, 3))
    assert np.allclose(back(np, to(np, d)), d)
    T, residual = pb.peer_transform(np, peer)
    assert residual < 1e-12
    # a band-0 function has the same coefficient in every frame and basis
    assert abs(T[0, 0] - 1) < 1e-12
