#!/usr/bin/python3
"""The numbers behind scripts/peer_bench.sh (envlight against the peer tools cmft, Filament's
cmgen and Probulator; docs/peer_bench.md): exact double-precision references of a lat-long
map, every tool's products measured against them, and the markdown tables of the timings.
scripts/peer_bench.sh runs it; by hand:

  peer_bench.py reference MAP.pfm OUT.json   exact SH projection, order 4, of a canonical
                                             lat-long PFM (`envlight convert MAP.hdr MAP.pfm`)
  peer_bench.py errors DIR MAP1024.pfm OUT.json
                                             the errors of the products kept in DIR
                                             (DIR/TASK/TOOL/...) against exact references of
                                             the map area-resampled to 1024 x 512
  peer_bench.py report WORK                  the markdown tables from WORK (times.tsv,
                                             inputs.tsv, sh/*, errors/*), as peer_bench.sh
                                             leaves it

The SH reference. The map is piecewise constant (docs/design.md, "Canonical frame"): pixel
(r, c) covers phi in pi (1 - 2 [c, c + 1] / W) and theta in pi (1/2 - [r, r + 1] / H). The real
SH of envlight's basis (docs/design.md, "Spherical harmonics": no Condon-Shortley phase,
orthonormal) separate into P~_lm(z) times cos(m phi) or sin(m phi), so each coefficient is a sum
over pixels of L times a row factor (the integral of P~_lm(sin theta) cos theta d theta,
16-point Gauss-Legendre in theta: exact to rounding for l <= 4) times a column factor (the
integral of cos or sin (m phi) d phi, closed form), in double.

cmft's coefficients (src/cmft/cubemapfilter.cpp, evalSHBasis5 and cubemapShCoeffs; the
lat-long to cube conversion in src/cmft/image.cpp, imageCubemapFromLatLong with latLongFromVec
in src/cmft/cubemaputils.h) are in another basis and frame: its lat-long pixel (u, v) looks
along d_cmft = (-y, z, x) of our canonical d = (x, y, z) (Y up; a reflection: det -1), its
basis has the Condon-Shortley phase (-1)^m, the same l (l + 1) + m order, and its function 11
(l = 3, m = -1) is sqrt(2) times the unit-norm one (sqrt(21 / 16 pi) where sqrt(21 / 32 pi) is
the norm). The reference in cmft's terms is diag(s) R c, R the SH transform of that reflection
(fitted at 4096 directions, block-diagonal by band; its fit residual is reported), s the signs
and scales. Rotation-invariant band energies sqrt(sum_m c_lm^2) need no frame at all and are
given too. cmft decodes RGBE as m 2^(e - 136) (image.cpp, rgbeToRgba32f), envlight as
(m + 0.5) 2^(e - 136); the reference is computed for both decodes (the m decode recovered
exactly from the (m + 0.5) pixels of the PFM).

cmgen's (Filament, tools/cmgen/src/cmgen.cpp at upstream commit ef9bbece2): the lat-long map
is point-sampled (Hammersley points per texel, libs/ibl/src/CubemapUtils.cpp,
equirectangularToCubemap: column from atan2(s.x, s.z), row from asin(s.y)) onto a cube of
--size (default 256) faces, which cmgen then mirrors by default (mirrorCubemap: s -> (-s.x,
s.y, s.z)); so its cube direction s is (y, z, x) of our d (a rotation). Its basis
(libs/ibl/src/CubemapSH.cpp, computeShBasis, Kml, Ki) is orthonormal with the Condon-Shortley
phase (-1)^m, index l (l + 1) + m, over s with s.z the polar axis; RGBE decodes as
(m + 0.5) 2^(e - 136) (libs/imageio/src/HDRDecoder.cpp), as envlight's.

The cube products. Faces are read in each tool's own layout, their texel centres mapped to the
canonical frame: envlight's table (docs/design.md, "Canonical frame"); cmft's DDS (faces +X -X
+Y -Y +Z -Z of its frame, each with its mips; texel (i, j) looks along u U + v V + F,
u = 2 (i + 1/2) / N - 1, v = 2 (j + 1/2) / N - 1, s_faceUvVectors in src/cmft/cubemaputils.h:
OpenGL's table); cmgen's files FACE.psd (32-bit float, planar; Cubemap::getDirectionFor: the
same OpenGL table, s = 2 (i + 1/2) / N - 1 right, t = 1 - 2 (j + 1/2) / N up). Units: envlight's
irradiance map holds E, cmft's and cmgen's E / pi (cmft: SH of the irradiance divided by pi;
cmgen: CubemapIBL::diffuseIrradiance, the mean of L over cosine-distributed samples).
The exact values, at each product's texel centres: E by envlight's envl_irradiance_exact (every
pixel integrated exactly over the clamped cosine, in double), the GGX levels by envlight's
envl_prefilter_reference (docs/design.md, "Error measures": P(R) over every pixel, in double,
N = V = R, alpha = roughness^2; cmgen's levels are GGX of that same definition,
CubemapIBL::roughnessFilter, weights D(h) N.L), cmft's Phong levels by this script: P(R) =
sum L (R.l)^p dw / sum (R.l)^p dw over every pixel (R.l > 0), in double, p as cmft sets it
(cubemapfilter.cpp, specularPowerFor + applyLightningModel; its cut-off below 1e-5 of the
peak is left out here, as it changes P by less than that). All over the map area-resampled
to 1024 x 512 (envlight's ENVL_REFERENCE_WIDTH: the inputs above 1K here are upsampled 1K maps,
so that copy is the same picture; at most TEXELS_IRRADIANCE / TEXELS_LEVEL texels per product
or level, spread evenly in scan order). Roughness-0 levels (envlight's and cmgen's resampled
mirrors) are left out: a texel's footprint mean is not a filter to check against a point.
The error of a product (or level) is docs/design.md's relative RMS of luminance, over its
measured texels weighted by their solid angle: sqrt(sum w (Y - Y*)^2 / sum w) / (sum w Y* /
sum w); "worst" = max |Y - Y*| / max(Y*, 0.01 mean Y*) (the per-texel measure's dark floor).
The mapping check: each peer's irradiance texels against the order-4 SH irradiance of the same
map (exact projection) under the stated mapping and under each of the other 47 signed
permutations of the axes; the stated mapping must fit best by far.
"""
import argparse
import json
import math
import os
import statistics
import sys

ORDER = 4
NCOEF = (ORDER + 1) ** 2


def _np():
    import numpy as np  # imported late: --help needs nothing
    return np


# ---------------------------------------------------------------------------- the basis


def legendre_no_cs(np, z, lmax):
    """P_lm(z) without the Condon-Shortley phase, as dict (l, m) -> array."""
    P = {}
    s = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    pmm = np.ones_like(z)
    for m in range(lmax + 1):
        if m > 0:
            pmm = pmm * (2 * m - 1) * s
        P[(m, m)] = pmm
        if m + 1 <= lmax:
            P[(m + 1, m)] = z * (2 * m + 1) * pmm
        for l in range(m + 2, lmax + 1):
            P[(l, m)] = ((2 * l - 1) * z * P[(l - 1, m)] - (l + m - 1) * P[(l - 2, m)]) / (l - m)
    return P


def k_lm(l, m):
    return math.sqrt((2 * l + 1) / (4 * math.pi) * math.factorial(l - m) / math.factorial(l + m))


def norm_factor(l, m):
    """the factor of P_lm(z) cos/sin(|m| phi) in Y_lm (envlight's basis)."""
    return k_lm(l, abs(m)) * (1.0 if m == 0 else math.sqrt(2.0))


def sh_eval(np, d, lmax=ORDER):
    """envlight's real SH at unit directions d (N, 3): (N, (lmax + 1)^2), index l (l + 1) + m."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    P = legendre_no_cs(np, z, lmax)
    phi = np.arctan2(y, x)
    out = np.zeros((d.shape[0], (lmax + 1) ** 2))
    for l in range(lmax + 1):
        for m in range(-l, l + 1):
            trig = 1.0 if m == 0 else (np.cos(m * phi) if m > 0 else np.sin(-m * phi))
            out[:, l * (l + 1) + m] = norm_factor(l, m) * P[(l, abs(m))] * trig
    return out


# a peer's direction for envlight's canonical d = (x, y, z), (N, 3) -> (N, 3), and back; read
# from the peers' sources (the module's docstring)
PEER_FRAMES = {
    "cmft": (lambda np, d: np.stack([-d[:, 1], d[:, 2], d[:, 0]], axis=1),
             lambda np, v: np.stack([v[:, 2], -v[:, 0], v[:, 1]], axis=1)),
    "cmgen": (lambda np, d: np.stack([d[:, 1], d[:, 2], d[:, 0]], axis=1),
              lambda np, s: np.stack([s[:, 2], s[:, 0], s[:, 1]], axis=1)),
}


def peer_transform(np, peer, lmax=ORDER):
    """(T, residual): the peer's coefficients = T @ envlight's, from its frame, the
    Condon-Shortley phase (-1)^m of both peers' bases and cmft's scale of function 11
    (module docstring); residual = the largest misfit of the band transform at the fitting
    directions (about 1e-15 when the frame is a rotation or reflection)."""
    ncoef = (lmax + 1) ** 2
    rng = np.random.default_rng(17)
    d = rng.normal(size=(4096, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    dp = PEER_FRAMES[peer][0](np, d)
    Yd, Ydp = sh_eval(np, d, lmax), sh_eval(np, dp, lmax)
    R = np.zeros((ncoef, ncoef))
    for l in range(lmax + 1):
        i = slice(l * l, (l + 1) ** 2)
        R[i, i] = np.linalg.lstsq(Yd[:, i], Ydp[:, i], rcond=None)[0].T
    residual = float(np.abs(Yd @ R.T - Ydp).max())
    s = np.array([(-1.0) ** abs(m) for l in range(lmax + 1) for m in range(-l, l + 1)])
    if peer == "cmft" and lmax >= 3:
        s[11] *= math.sqrt(2.0)
    return s[:, None] * R, residual


# ---------------------------------------------------------------------------- the projection


def read_pfm(np, path):
    """a colour PFM as (H, W, 3) float32, row 0 on top, memory-mapped (a 16K map is 1.5 GiB)."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        if kind != b"PF":
            raise SystemExit("%s: not a colour PFM" % path)
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        offset = f.tell()
    data = np.memmap(path, dtype="<f4" if scale < 0 else ">f4", mode="r", offset=offset,
                     shape=(h, w, 3))
    return data[::-1]   # PFM rows run bottom to top; row 0 = top


def project(np, img, lmax=ORDER, decode=None):
    """exact projection of the piecewise-constant lat-long map img (H, W, 3), row 0 on top:
    ((lmax + 1)^2, 3) in double; decode (a block of rows in float64 -> the same) when given."""
    H, W = img.shape[:2]
    # row factors: the integral of norm * P_lm(sin t) cos t dt over each row, 16-point GL
    gx, gw = np.polynomial.legendre.leggauss(16)
    t0 = math.pi * (0.5 - (np.arange(H) + 1.0) / H)
    t1 = math.pi * (0.5 - np.arange(H) / H)
    half = (t1 - t0) / 2
    t = (t0 + t1)[:, None] / 2 + half[:, None] * gx[None, :]
    P = legendre_no_cs(np, np.sin(t), lmax)
    row = {}
    for l in range(lmax + 1):
        for m in range(l + 1):
            row[(l, m)] = (P[(l, m)] * np.cos(t) * gw[None, :]).sum(axis=1) * half
    # column factors: the integral of cos(m phi) or sin(m phi) over each column, closed form
    pa = math.pi * (1 - 2 * (np.arange(W) + 1.0) / W)
    pb = math.pi * (1 - 2 * np.arange(W) / W)
    cols = [pb - pa]
    for m in range(1, lmax + 1):
        cols.append((np.sin(m * pb) - np.sin(m * pa)) / m)      # cos(m phi)
    for m in range(1, lmax + 1):
        cols.append((np.cos(m * pa) - np.cos(m * pb)) / m)      # sin(m phi)
    C = np.stack(cols, axis=1)                                  # (W, 2 lmax + 1)
    acc = np.zeros((H, 3, C.shape[1]))
    for r0 in range(0, H, 256):                                 # blocks: 8K maps in float64
        blk = np.array(img[r0:r0 + 256], dtype=np.float64)
        if decode:
            blk = decode(np, blk)
        acc[r0:r0 + 256] = np.einsum("rwc,wk->rck", blk, C)
    out = np.zeros(((lmax + 1) ** 2, 3))
    for l in range(lmax + 1):
        for m in range(-l, l + 1):
            k = 0 if m == 0 else (m if m > 0 else lmax - m)
            out[l * (l + 1) + m] = norm_factor(l, m) * (row[(l, abs(m))][:, None] * acc[:, :, k]).sum(0)
    return out


def floor_decode(np, blk):
    """a block of the map as cmft decodes the same .hdr: m 2^(e-136) where envlight has
    (m + 0.5) 2^(e-136). The pixel's exponent is recovered from its largest channel, whose
    mantissa m + 0.5 lies in [128.5, 255.5]."""
    v = blk.max(axis=2)
    k = np.zeros_like(v)
    lit = v > 0
    k[lit] = np.floor(np.log2(v[lit] / 128.5))
    # guard the floor's rounding at the interval ends
    q = np.where(lit, v / np.exp2(k), 0)
    k = np.where(lit & (q >= 256.0), k + 1, np.where(lit & (q < 128.0), k - 1, k))
    return np.where(lit[..., None], blk - 0.5 * np.exp2(k)[..., None], 0)


def cmd_reference(a):
    np = _np()
    img = read_pfm(np, a.pfm)
    H, W = img.shape[:2]
    ref = project(np, img)
    ref_floor = project(np, img, decode=floor_decode)
    T, resid = peer_transform(np, "cmft")
    Tg, resid_g = peer_transform(np, "cmgen")
    json.dump({"map": a.pfm, "width": W, "height": H, "order": ORDER,
               "basis": "envlight (real, no Condon-Shortley phase), canonical frame",
               "radiance": ref.tolist(),
               "radiance_m_decode": ref_floor.tolist(),
               "cmft_radiance_m_decode": (T @ ref_floor).tolist(),
               "cmft_radiance": (T @ ref).tolist(),
               "cmft_transform_residual": resid,
               "cmgen_radiance": (Tg @ ref).tolist(),
               "cmgen_transform_residual": resid_g}, open(a.out, "w"), indent=1)


# ---------------------------------------------------------------------------- the cube products

TEXELS_IRRADIANCE = 1024   # texels measured per irradiance cube (all when it has fewer)
TEXELS_LEVEL = 512         # per specular level
DARK = 0.01                # the per-texel measure's dark floor (docs/design.md, ENVL_TEXEL_DARK)
CMFT_GLOSS = (10.0, 1.0)   # peer_bench.sh's cmft --glossScale, --glossBias

# faces as (name, centre, right, up) in the tool's own frame: right = the growing column, up =
# towards row 0. envlight's (docs/design.md, "Canonical frame") are canonical; cmft's and
# cmgen's are OpenGL's, in their frames (PEER_FRAMES), in their file order +X -X +Y -Y +Z -Z.
ENVLIGHT_FACES = {"px": ((1, 0, 0), (0, -1, 0), (0, 0, 1)), "nx": ((-1, 0, 0), (0, 1, 0), (0, 0, 1)),
                  "py": ((0, 1, 0), (1, 0, 0), (0, 0, 1)), "ny": ((0, -1, 0), (-1, 0, 0), (0, 0, 1)),
                  "pz": ((0, 0, 1), (0, -1, 0), (-1, 0, 0)), "nz": ((0, 0, -1), (0, -1, 0), (1, 0, 0))}
GL_FACES = [("px", (1, 0, 0), (0, 0, -1), (0, 1, 0)), ("nx", (-1, 0, 0), (0, 0, 1), (0, 1, 0)),
            ("py", (0, 1, 0), (1, 0, 0), (0, 0, -1)), ("ny", (0, -1, 0), (1, 0, 0), (0, 0, 1)),
            ("pz", (0, 0, 1), (1, 0, 0), (0, 1, 0)), ("nz", (0, 0, -1), (-1, 0, 0), (0, 1, 0))]


def face_texels(np, n, centre, right, up):
    """directions (n^2, 3) of an n x n face's texel centres, row 0 first, and their exact
    solid angles (the corner formula atan2(s t, sqrt(1 + s^2 + t^2)))."""
    e = np.linspace(-1.0, 1.0, n + 1)
    mid = (e[:-1] + e[1:]) / 2
    s = np.tile(mid, n)                  # column: s grows to the right
    t = np.repeat(-mid, n)               # row 0 on top: t = 1 - 2 (j + 1/2) / n
    d = np.asarray(centre, float)[None] + s[:, None] * np.asarray(right, float)[None] \
        + t[:, None] * np.asarray(up, float)[None]
    d /= np.linalg.norm(d, axis=1)[:, None]
    A = np.arctan2(e[:, None] * e[None, :], np.sqrt(1 + e[:, None] ** 2 + e[None, :] ** 2))
    om = np.abs(A[1:, 1:] - A[:-1, 1:] - A[1:, :-1] + A[:-1, :-1])
    return d, om.reshape(-1)


def read_psd32(np, path):
    """cmgen's 32-bit PSD (libs/imageio ImageEncoder.cpp, PSDEncoder): raw planar big-endian
    floats R, G, B at the end of the file -> (H, W, 3)."""
    import struct
    with open(path, "rb") as f:
        head = f.read(26)
        if head[:4] != b"8BPS" or struct.unpack(">H", head[22:24])[0] != 32:
            raise SystemExit("%s: not a 32-bit PSD" % path)
        h, w = struct.unpack(">II", head[14:22])
        f.seek(-3 * w * h * 4, 2)
        data = np.frombuffer(f.read(), dtype=">f4")
    return data.reshape(3, h, w).transpose(1, 2, 0).astype(np.float32)


def read_dds_cube(np, path):
    """cmft's rgba32f DDS cube: faces +X -X +Y -Y +Z -Z, each with its mips, after the header
    (128 bytes, + 20 for a DX10 one) -> [mip][face] (N, N, 3)."""
    import struct
    raw = open(path, "rb").read()
    h, w, _, _, mips = struct.unpack("<5I", raw[12:32])
    mips = max(mips, 1)
    sizes = [max(w >> m, 1) for m in range(mips)]
    total = 6 * sum(n * n for n in sizes) * 4
    data = np.frombuffer(raw[len(raw) - 4 * total:], dtype="<f4")
    out, at = [[None] * 6 for _ in sizes], 0
    for f in range(6):
        for m, n in enumerate(sizes):
            out[m][f] = data[at:at + n * n * 4].reshape(n, n, 4)[:, :, :3]
            at += n * n * 4
    return out


def peer_cube(np, peer, faces):
    """[(name, (N, N, 3))] in the peer's file order -> (dirs, weights, rgb) canonical."""
    back = PEER_FRAMES[peer][1]
    D, W, V = [], [], []
    for (name, c, r, u), img in zip(GL_FACES, faces):
        d, w = face_texels(np, img.shape[0], c, r, u)
        D.append(back(np, d)), W.append(w), V.append(img.reshape(-1, 3))
    return np.concatenate(D), np.concatenate(W), np.concatenate(V).astype(np.float64)


def envlight_cube(np, folder, files):
    D, W, V = [], [], []
    for f in files:
        img = read_pfm(np, os.path.join(folder, f))
        c, r, u = ENVLIGHT_FACES[f[-6:-4]]
        d, w = face_texels(np, img.shape[0], c, r, u)
        D.append(d), W.append(w), V.append(np.array(img, dtype=np.float64).reshape(-1, 3))
    return np.concatenate(D), np.concatenate(W), np.concatenate(V)


def products(np, folder, tool):
    """the maps a tool left in folder, as a list of dicts: kind (irradiance, ggx with its
    roughness, phong with its power), label, dirs, weights, rgb (E for irradiance)."""
    import glob
    out = []
    pj = os.path.join(folder, "maps", "prefilter.json")
    if tool.startswith("envlight") and os.path.exists(pj):
        j = json.load(open(pj))
        if "irradiance" in j:
            d, w, v = envlight_cube(np, os.path.join(folder, "maps"), j["irradiance"]["files"])
            out.append(dict(kind="irradiance", param=None, label="E", dirs=d, weights=w, rgb=v))
        for lv in j.get("specular", []):
            if lv["roughness"] > 0:
                d, w, v = envlight_cube(np, os.path.join(folder, "maps"), lv["files"])
                out.append(dict(kind="ggx", param=lv["roughness"], dirs=d, weights=w, rgb=v,
                                label="r %.3g, %d" % (lv["roughness"], lv["face_size"])))
    elif tool == "cmft":
        for name in ("irr.dds", "rad.dds"):
            p = os.path.join(folder, name)
            if not os.path.exists(p):
                continue
            mips = read_dds_cube(np, p)
            if name == "irr.dds":
                d, w, v = peer_cube(np, "cmft", mips[0])
                out.append(dict(kind="irradiance", param=None, label="E", dirs=d, weights=w,
                                rgb=v * math.pi))   # cmft holds E / pi
                continue
            for m, faces in enumerate(mips):
                g = max(0.0, 1.0 - m / (len(mips) - (1.0 + 1e-7)))   # specularPowerFor
                power = 2.0 ** (CMFT_GLOSS[0] * g + CMFT_GLOSS[1]) + 1.0  # + 1: phongbrdf
                d, w, v = peer_cube(np, "cmft", faces)
                out.append(dict(kind="phong", param=power, dirs=d, weights=w, rgb=v,
                                label="p %.4g, %d" % (power, faces[0].shape[0])))
    elif tool == "cmgen":
        irr = sorted(glob.glob(os.path.join(folder, "irr", "*", "i_px.psd")))
        if irr:
            base = os.path.dirname(irr[0])
            faces = [read_psd32(np, os.path.join(base, "i_%s.psd" % f[0])) for f in GL_FACES]
            d, w, v = peer_cube(np, "cmgen", faces)
            out.append(dict(kind="irradiance", param=None, label="E", dirs=d, weights=w,
                            rgb=v * math.pi))   # cmgen holds E / pi
        lvl = sorted(glob.glob(os.path.join(folder, "rad", "*", "m*_px.psd")))
        for p in lvl:
            k = int(os.path.basename(p)[1:-7])
            if k == 0:
                continue   # roughness 0: the resampled mirror
            # lodToPerceptualRoughness(k / (levels - 1)) = 1 - sqrt(1 - lod) (cmgen.cpp)
            r = 1.0 - math.sqrt(1.0 - k / (len(lvl) - 1.0))
            faces = [read_psd32(np, p[:-6] + f[0] + ".psd") for f in GL_FACES]
            d, w, v = peer_cube(np, "cmgen", faces)
            out.append(dict(kind="ggx", param=r, dirs=d, weights=w, rgb=v,
                            label="r %.3g, %d" % (r, faces[0].shape[0])))
    return out


def luminance(np, rgb):
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def rel_errors(np, y, yref, w):
    """(docs/design.md's relative RMS over the texels, solid-angle weighted; the worst texel
    against max(Y*, DARK mean))."""
    mean = float((w * yref).sum() / w.sum())
    rms = math.sqrt(float((w * (y - yref) ** 2).sum() / w.sum())) / mean
    worst = float(np.max(np.abs(y - yref) / np.maximum(yref, DARK * mean)))
    return rms, worst


def phong_reference(np, img, power, dirs):
    """P(R) = sum L (R.l)^p dw / sum (R.l)^p dw over every pixel centre with R.l > 0, double."""
    H, W = img.shape[:2]
    t = math.pi * (0.5 - (np.arange(H) + 0.5) / H)
    f = math.pi * (1 - 2 * (np.arange(W) + 0.5) / W)
    P = np.stack([np.outer(np.cos(t), np.cos(f)), np.outer(np.cos(t), np.sin(f)),
                  np.repeat(np.sin(t)[:, None], W, axis=1)], axis=2).reshape(-1, 3)
    edge = math.pi * (0.5 - np.arange(H + 1) / H)
    dw = np.repeat((2 * math.pi / W) * (np.sin(edge[:-1]) - np.sin(edge[1:])), W)
    L = np.array(img, dtype=np.float64).reshape(-1, 3)
    out = np.zeros((len(dirs), 3))
    for i in range(0, len(dirs), 16):
        u = P @ dirs[i:i + 16].T                                    # (pixels, 16)
        k = np.where(u > 0, np.exp(power * np.log(np.maximum(u, 1e-300))), 0.0) * dw[:, None]
        out[i:i + 16] = (k.T @ L) / k.sum(axis=0)[:, None]
    return out


def pick(n, total):
    """n indices spread evenly in scan order over total (all when total <= n)."""
    import numpy as np
    if total <= n:
        return np.arange(total)
    return ((np.arange(n) + 0.5) * total / n).astype(np.int64)


SIGNED_PERMUTATIONS = [(p, s) for p in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1),
                                        (2, 1, 0)) for s in range(8)]


def mapping_check(np, prod, c4):
    """misfit of an irradiance product against the order-4 SH irradiance (exact projection c4)
    at its texels as stated and under the other 47 signed axis permutations."""
    A = [math.pi, 2 * math.pi / 3, math.pi / 4, 0.0, -math.pi / 24]
    a = np.array([A[l] for l in range(ORDER + 1) for m in range(-l, l + 1)])
    sel = pick(TEXELS_IRRADIANCE, len(prod["dirs"]))
    d, w, y = prod["dirs"][sel], prod["weights"][sel], luminance(np, prod["rgb"][sel])
    fits = []
    for perm, signs in SIGNED_PERMUTATIONS:
        sg = np.array([-1.0 if signs >> k & 1 else 1.0 for k in range(3)])
        dp = d[:, perm] * sg[None]
        e = luminance(np, sh_eval(np, dp) @ (a[:, None] * c4))
        fits.append(rel_errors(np, y, e, w)[0])
    return {"stated": fits[0], "best_other": min(fits[1:])}


def cmd_errors(a):
    np = _np()
    top = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    sys.path.insert(0, os.path.join(top, "py_shim"))
    import ctypes
    import envlight
    from envlight import _lib
    m = envlight.load(a.map1024)
    img = read_pfm(np, a.map1024)
    c4 = project(np, img)
    cache, result = {}, {}

    def exact(kind, param, dirs):
        key = (kind, param, dirs.tobytes())
        if key not in cache:
            if kind == "irradiance":
                cache[key] = np.asarray(m.irradiance(dirs))
            elif kind == "ggx":   # envlight's brute force (no public shim method)
                out = (ctypes.c_double * (3 * len(dirs)))()
                buf = (ctypes.c_double * (3 * len(dirs))).from_buffer_copy(
                    np.ascontiguousarray(dirs, dtype=np.float64).tobytes())
                with m._use() as h:
                    rc = _lib.lib.envl_prefilter_reference(h, float(param), len(dirs), buf, out)
                if rc:
                    raise SystemExit("envl_prefilter_reference failed (%d)" % rc)
                cache[key] = np.ctypeslib.as_array(out).reshape(-1, 3).copy()
            else:
                cache[key] = phong_reference(np, img, param, dirs)
        return cache[key]

    for task in sorted(os.listdir(a.dir)):
        for tool in sorted(os.listdir(os.path.join(a.dir, task))):
            levels = []
            prods = products(np, os.path.join(a.dir, task, tool), tool)
            for p in prods:
                n = TEXELS_IRRADIANCE if p["kind"] == "irradiance" else TEXELS_LEVEL
                sel = pick(n, len(p["dirs"]))
                ref = exact(p["kind"], p["param"], p["dirs"][sel])
                rms, worst = rel_errors(np, luminance(np, p["rgb"][sel]), luminance(np, ref),
                                        p["weights"][sel])
                levels.append({"kind": p["kind"], "param": p["param"], "label": p["label"],
                               "face": int(round(math.sqrt(len(p["dirs"]) / 6))),
                               "texels": int(len(sel)), "of": int(len(p["dirs"])),
                               "error": rms, "worst": worst})
            entry = {"levels": levels}
            if tool in PEER_FRAMES and prods and prods[0]["kind"] == "irradiance":
                entry["mapping"] = mapping_check(np, prods[0], c4)
            result.setdefault(task, {})[tool] = entry
    json.dump(result, open(a.out, "w"), indent=1)


# ---------------------------------------------------------------------------- the report


def read_cmft_c(path):
    """the 25 RGB triples of cmft's --filter shcoeffs output (a C header)."""
    import re
    text = open(path).read()
    text = text[text.index("{"):]
    nums = [float(v) for v in re.findall(r"[-+]?\d+\.\d+(?:[eE][-+]?\d+)?", text)]
    if len(nums) != 75:
        raise SystemExit("%s: %d numbers, not 75" % (path, len(nums)))
    return [nums[3 * i:3 * i + 3] for i in range(25)]


def agreement(np, c, ref, lmax):
    c, ref = np.asarray(c)[:(lmax + 1) ** 2], np.asarray(ref)[:(lmax + 1) ** 2]
    rel = np.linalg.norm(c - ref) / np.linalg.norm(ref)
    worst = np.max(np.abs(c - ref) / np.abs(ref[0])[None, :])
    bands = []
    for l in range(lmax + 1):
        i = slice(l * l, (l + 1) ** 2)
        e, er = np.sqrt((c[i] ** 2).sum(0)), np.sqrt((ref[i] ** 2).sum(0))
        bands.append(float(np.max(np.abs(e - er) / er)))
    return rel, worst, bands


def pct(x):
    return "%.2g %%" % (100 * x) if x >= 1e-4 else "%.1e" % x


def read_tsv(path):
    with open(path) as f:
        head = f.readline().rstrip("\n").split("\t")
        return [dict(zip(head, line.rstrip("\n").split("\t"))) for line in f if line.strip()]


TASKS = [("sh", "SH order 2"), ("irr32", "irradiance cube, 32 face"),
         ("irr128", "irradiance cube, 128 face"), ("radiance", "specular / radiance chain"),
         ("lights", "lights --method fit -n 4")]


def read_cmgen_txt(path):
    """the RGB triples of cmgen's --sh-output FILE.txt: lines "(r, g, b); // Llm"."""
    import re
    rows = re.findall(r"\(\s*([-+0-9.eE]+),\s*([-+0-9.eE]+),\s*([-+0-9.eE]+)\)", open(path).read())
    if len(rows) not in (1, 4, 9, 16, 25):
        raise SystemExit("%s: %d coefficients" % (path, len(rows)))
    return [[float(v) for v in r] for r in rows]


def product_folder(tool, variant):
    """the folder peer_bench.sh kept a run's products in (envlight's variants by their words)."""
    if tool != "envlight":
        return tool
    v = variant.replace("--no-error", "").strip()
    return "envlight" if v in ("", "default") else "envlight_" + v.replace(" ", "_")


def cmd_report(a):
    np = _np()
    work = a.work
    inputs = {r["size"]: r for r in read_tsv(os.path.join(work, "inputs.tsv"))}
    rows = read_tsv(os.path.join(work, "times.tsv"))
    runs = {}
    for r in rows:
        runs.setdefault((r["task"], r["size"], r["tool"], r["variant"]), []).append(r)
    sizes = list(inputs)

    def med(key):
        rs = runs.get(key)
        if not rs:
            return None
        if any(r["rc"] != "0" for r in rs):
            return "failed"
        return {"cpu": statistics.median(float(r["user"]) + float(r["sys"]) for r in rs),
                "wall": statistics.median(float(r["wall"]) for r in rs),
                "rss": statistics.median(float(r["rss_kb"]) for r in rs) / 1024.0,
                "n": len(rs)}

    # the SH agreements (l <= 2 for the main table; the detail table below)
    sh_rows, notes = {}, {}
    for size in sizes:
        d = os.path.join(work, "sh", size)
        refp = os.path.join(d, "reference.json")
        if not os.path.exists(refp):
            continue
        ref = json.load(open(refp))
        for k in ("cmft", "cmgen"):
            if k + "_transform_residual" in ref:
                notes.setdefault(k, []).append(ref[k + "_transform_residual"])
        cases = []
        ep = os.path.join(d, "envlight.json")
        if os.path.exists(ep):
            cases.append(("envlight", "envlight `sh --order 2 --window none`",
                          json.load(open(ep))["radiance"], ref["radiance"],
                          "(m + 0.5) decode, envlight's basis", 2))
        cp = os.path.join(d, "cmft.c")
        if os.path.exists(cp):
            cc = read_cmft_c(cp)
            cases.append(("cmft", "cmft `--filter shcoeffs`", cc, ref["cmft_radiance_m_decode"],
                          "m decode (cmft's), cmft's basis and frame", 4))
            cases.append((None, "cmft `--filter shcoeffs`", cc, ref["cmft_radiance"],
                          "(m + 0.5) decode, cmft's basis and frame", 4))
        gp = os.path.join(d, "cmgen.txt")
        if os.path.exists(gp) and "cmgen_radiance" in ref:
            cases.append(("cmgen", "cmgen `--sh=3 --sh-window=no`", read_cmgen_txt(gp),
                          ref["cmgen_radiance"], "(m + 0.5) decode (cmgen's), cmgen's basis and "
                          "frame", 2))
        sh_rows[size] = []
        for tool, name, c, r, what, L in cases:
            rel, worst, bands = agreement(np, c, r, L)
            sh_rows[size].append((name, what, L, rel, worst, bands))
            if tool:
                rel2, worst2, _ = agreement(np, c, r, 2)
                notes.setdefault("main", {})[(size, tool)] = (rel2, worst2)
    errors = {}
    for size in sizes:
        ep = os.path.join(work, "errors", size + ".json")
        if os.path.exists(ep):
            errors[size] = json.load(open(ep))

    def error_cells(task, size, tool, variant):
        if task == "sh":
            e = notes.get("main", {}).get((size, tool))
            return [pct(e[0]), pct(e[1])] if e else ["", ""]
        lv = errors.get(size, {}).get(task, {}).get(product_folder(tool, variant), {})
        lv = lv.get("levels") if lv else None
        lv = [x for x in lv or [] if x["face"] >= 8]   # cmft's 4-, 2- and 1-texel mips: below
        if not lv:
            return ["", ""]
        return [pct(max(x["error"] for x in lv)), pct(max(x["worst"] for x in lv))]

    print("| task | size | tool | variant | CPU s | wall s | RSS MiB | RSS / map floats | CPU "
          "envlight / this (default; `--no-error`) | error | worst |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for task, title in TASKS:
        for size in sizes:
            floats = int(inputs[size]["width"]) * int(inputs[size]["height"]) * 12 / 2.0 ** 20
            keys = list(dict.fromkeys((k[2], k[3]) for k in runs if k[:2] == (task, size)))
            if not keys:
                continue
            e_def = med((task, size, "envlight", "default"))
            e_ne = med((task, size, "envlight", "--no-error"))
            first = True
            for tool, var in keys:
                m = med((task, size, tool, var))
                cells = [title if first else "", size if first else "", tool,
                         "default" if var in ("default", "") else "`%s`" % var]
                first = False
                if isinstance(m, dict):
                    cells += ["%.2f" % m["cpu"], "%.2f" % m["wall"], "%.0f" % m["rss"],
                              "%.2f" % (m["rss"] / floats)]
                else:
                    cells += [m or "", "", "", ""]
                ratio = ""
                if tool != "envlight" and isinstance(m, dict) and m["cpu"] > 0:
                    parts = ["%.2f" % (x["cpu"] / m["cpu"]) for x in (e_def, e_ne)
                             if isinstance(x, dict)]
                    ratio = "; ".join(parts)
                cells.append(ratio)
                cells += error_cells(task, size, tool, var) if "--no-error" not in var \
                    else ["", ""]
                print("| " + " | ".join(cells) + " |")
    print()
    print("Map floats: width x height x 3 x 4 bytes = " + ", ".join(
        "%s %.0f MiB" % (s, int(inputs[s]["width"]) * int(inputs[s]["height"]) * 12 / 2.0 ** 20)
        for s in sizes) + ". Medians of %s run(s)." % ", ".join(
        sorted({str(len(v)) for v in runs.values()})))
    print()
    print("Error and worst: SH order 2: coefficient error |c - ref| / |ref| over l <= 2 and the "
          "three channels, and the worst coefficient |c - ref| / |ref_00|, against the exact "
          "projection of the same file in the tool's own basis, frame and RGBE decode "
          "(envlight's row: its untimed `--window none` run of the same command; the timed "
          "default windows). Cubes: the relative RMS of luminance over the texels against the "
          "exact value at each texel centre (solid-angle weighted), and the worst texel "
          "(relative to max(exact, 1 % of the mean)); the specular chain: the largest over its "
          "levels of roughness > 0 with faces of 8 texels or more (every level in the table "
          "below, cmft's 4-, 2- and 1-texel mips included). A `--no-error` row makes "
          "the same product as the row above it.")

    print()
    print("SH agreement with the exact double-precision projection of the same map "
          "(scripts/peer_bench.py): coefficient error = |c - ref| / |ref| over l <= L and the "
          "three channels; worst = max |c - ref| / |ref_00| per channel; band energy = max over "
          "channels of the relative error of sqrt(sum_m c_lm^2), l = 0, 1, ... (frame-free).")
    print()
    print("| size | result | reference | coefficient error | worst | band energy l = 0, 1, 2, ... |")
    print("|---|---|---|---|---|---|")
    for size in sizes:
        for name, what, L, rel, worst, bands in sh_rows.get(size, []):
            print("| %s | %s | %s, l <= %d | %s | %s | %s |" % (
                size, name, what, L, pct(rel), pct(worst), ", ".join(pct(b) for b in bands)))
    for k, what in (("cmft", "frame d_cmft = (-y, z, x), phase (-1)^m, function 11 times "
                     "sqrt 2"), ("cmgen", "frame s = (y, z, x), phase (-1)^m")):
        if notes.get(k):
            print()
            print("%s's basis mapped from envlight's (%s): fit residual %.1e." % (
                k, what, max(notes[k])))

    if errors:
        print()
        print("Products against exact values at their texel centres (scripts/peer_bench.py "
              "errors: irradiance E by envlight's envl_irradiance_exact, GGX levels by its "
              "brute-force envl_prefilter_reference, cmft's Phong levels by the script's "
              "brute-force sum, all in double over the map area-resampled to 1024 x 512). Level: "
              "GGX roughness r (alpha = r^2) or Phong power p, face size.")
        print()
        print("| task | size | tool | level | texels measured | error | worst |")
        print("|---|---|---|---|---|---|---|")
        for task, title in TASKS:
            for size in sizes:
                for tool, entry in sorted(errors.get(size, {}).get(task, {}).items()):
                    name = tool.replace("_", " ")
                    for x in entry["levels"]:
                        print("| %s | %s | %s | %s | %d of %d | %s | %s |" % (
                            title, size, name, x["label"], x["texels"], x["of"], pct(x["error"]),
                            pct(x["worst"])))
        checks = [(size, task, tool, e["mapping"]) for size in sizes
                  for task, tools in sorted(errors.get(size, {}).items())
                  for tool, e in sorted(tools.items()) if "mapping" in e]
        if checks:
            print()
            print("Mapping check: each peer's irradiance texels against the order-4 SH "
                  "irradiance of the map (exact projection) with the stated frame, units and "
                  "faces, and under the best of the other 47 signed axis permutations "
                  "(relative RMS): " + "; ".join(
                      "%s %s %s %s vs %s" % (t, size, task, pct(m["stated"]),
                                             pct(m["best_other"]))
                      for size, task, t, m in checks) + ".")


def main():
    ap = argparse.ArgumentParser(
        usage="python3 scripts/peer_bench.py {reference PFM OUT.json | errors DIR MAP1024.pfm OUT.json | report WORK}",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("reference", help="exact SH projection of a canonical lat-long PFM")
    r.add_argument("pfm")
    r.add_argument("out")
    r.set_defaults(fn=cmd_reference)
    e = sub.add_parser("errors", help="errors of the products kept in DIR (DIR/TASK/TOOL)")
    e.add_argument("dir")
    e.add_argument("map1024")
    e.add_argument("out")
    e.set_defaults(fn=cmd_errors)
    p = sub.add_parser("report", help="markdown tables from peer_bench.sh's work folder")
    p.add_argument("work")
    p.set_defaults(fn=cmd_report)
    a = ap.parse_args()
    a.fn(a)


if __name__ == "__main__":
    main()
