#!/usr/bin/python3
"""The numbers behind scripts/peer_bench.sh (envlight against the peer tools cmft and
Probulator; docs/peer_bench.md): an exact double-precision SH projection of a lat-long map, the
agreement of envlight's and cmft's SH coefficients with it, and the markdown tables of the
timings. scripts/peer_bench.sh runs it; by hand:

  peer_bench.py reference MAP.pfm OUT.json   exact projection, order 4, of a canonical lat-long
                                             PFM (`envlight convert MAP.hdr MAP.pfm`)
  peer_bench.py report WORK                  the markdown tables from WORK (times.tsv,
                                             inputs.tsv, sh/*), as peer_bench.sh leaves it

The reference. The map is piecewise constant (docs/design.md, "Canonical frame"): pixel
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


def cmft_transform(np):
    """(T, residual): cmft's coefficients = T @ envlight's, from the frame, phase and scales
    described in the module's docstring; residual = the largest misfit of the band transform
    at the fitting directions (about 1e-15 when the model is right)."""
    rng = np.random.default_rng(17)
    d = rng.normal(size=(4096, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    dc = np.stack([-d[:, 1], d[:, 2], d[:, 0]], axis=1)   # cmft's vector for canonical d
    Yd, Ydc = sh_eval(np, d), sh_eval(np, dc)
    R = np.zeros((NCOEF, NCOEF))
    for l in range(ORDER + 1):
        i = slice(l * l, (l + 1) ** 2)
        R[i, i] = np.linalg.lstsq(Yd[:, i], Ydc[:, i], rcond=None)[0].T
    residual = float(np.abs(Yd @ R.T - Ydc).max())
    s = np.array([(-1.0) ** abs(m) for l in range(ORDER + 1) for m in range(-l, l + 1)])
    s[11] *= math.sqrt(2.0)
    return s[:, None] * R, residual


# ---------------------------------------------------------------------------- the projection


def read_pfm(np, path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        if kind != b"PF":
            raise SystemExit("%s: not a colour PFM" % path)
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4", count=w * h * 3)
    return data.reshape(h, w, 3)[::-1]   # PFM rows run bottom to top; row 0 = top


def project(np, img, lmax=ORDER):
    """exact projection of the piecewise-constant lat-long map img (H, W, 3), row 0 on top:
    ((lmax + 1)^2, 3) in double."""
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
        blk = img[r0:r0 + 256].astype(np.float64)
        acc[r0:r0 + 256] = np.einsum("rwc,wk->rck", blk, C)
    out = np.zeros(((lmax + 1) ** 2, 3))
    for l in range(lmax + 1):
        for m in range(-l, l + 1):
            k = 0 if m == 0 else (m if m > 0 else lmax - m)
            out[l * (l + 1) + m] = norm_factor(l, m) * (row[(l, abs(m))][:, None] * acc[:, :, k]).sum(0)
    return out


def floor_decode(np, img):
    """the map as cmft decodes the same .hdr: m 2^(e-136) where envlight has (m + 0.5)
    2^(e-136). The pixel's exponent is recovered from its largest channel, whose mantissa
    m + 0.5 lies in [128.5, 255.5]."""
    out = np.empty_like(img)
    for r0 in range(0, img.shape[0], 256):
        blk = img[r0:r0 + 256].astype(np.float64)
        v = blk.max(axis=2)
        k = np.zeros_like(v)
        lit = v > 0
        k[lit] = np.floor(np.log2(v[lit] / 128.5))
        # guard the floor's rounding at the interval ends
        q = np.where(lit, v / np.exp2(k), 0)
        k = np.where(lit & (q >= 256.0), k + 1, np.where(lit & (q < 128.0), k - 1, k))
        out[r0:r0 + 256] = np.where(lit[..., None], blk - 0.5 * np.exp2(k)[..., None], 0)
    return out


def cmd_reference(a):
    np = _np()
    img = read_pfm(np, a.pfm)
    H, W = img.shape[:2]
    ref = project(np, img)
    ref_floor = project(np, floor_decode(np, img))
    T, resid = cmft_transform(np)
    json.dump({"map": a.pfm, "width": W, "height": H, "order": ORDER,
               "basis": "envlight (real, no Condon-Shortley phase), canonical frame",
               "radiance": ref.tolist(),
               "radiance_m_decode": ref_floor.tolist(),
               "cmft_radiance_m_decode": (T @ ref_floor).tolist(),
               "cmft_radiance": (T @ ref).tolist(),
               "cmft_transform_residual": resid}, open(a.out, "w"), indent=1)


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


def cmd_report(a):
    work = a.work
    inputs = {r["size"]: r for r in read_tsv(os.path.join(work, "inputs.tsv"))}
    rows = read_tsv(os.path.join(work, "times.tsv"))
    runs = {}
    for r in rows:
        runs.setdefault((r["task"], r["size"], r["tool"], r["variant"]), []).append(r)

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

    print("| task | size | envlight | CPU s | wall s | peer | CPU s | wall s | CPU ratio "
          "envlight/peer | RSS MiB envlight | RSS MiB peer | RSS / map floats envlight | peer |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    sizes = list(inputs)
    for task, title in TASKS:
        for size in sizes:
            floats = int(inputs[size]["width"]) * int(inputs[size]["height"]) * 12 / 2.0 ** 20
            # in the order they ran: envlight's default first, cmft before Probulator
            variants = list(dict.fromkeys(k[3] for k in runs if k[:3] == (task, size, "envlight")))
            peers = list(dict.fromkeys(k[2] for k in runs if k[:2] == (task, size)
                                       and k[2] != "envlight")) or [None]
            first = True
            for peer in peers:
                p = med((task, size, peer, "")) if peer else None
                for var in variants:
                    e = med((task, size, "envlight", var))
                    cells = [title if first else "", size if first else ""]
                    first = False
                    cells.append("default" if var == "default" else "`%s`" % var)
                    cells += ["%.2f" % e["cpu"], "%.2f" % e["wall"]] if isinstance(e, dict) \
                        else [e or "", ""]
                    cells.append(peer or "(none)")
                    cells += ["%.2f" % p["cpu"], "%.2f" % p["wall"]] if isinstance(p, dict) \
                        else [p or "", ""]
                    both = isinstance(e, dict) and isinstance(p, dict)
                    cells.append("%.2f" % (e["cpu"] / p["cpu"]) if both and p["cpu"] > 0 else "")
                    cells.append("%.0f" % e["rss"] if isinstance(e, dict) else "")
                    cells.append("%.0f" % p["rss"] if isinstance(p, dict) else "")
                    cells.append("%.2f" % (e["rss"] / floats) if isinstance(e, dict) else "")
                    cells.append("%.2f" % (p["rss"] / floats) if isinstance(p, dict) else "")
                    print("| " + " | ".join(cells) + " |")
    print()
    print("Map floats: width x height x 3 x 4 bytes = " + ", ".join(
        "%s %.0f MiB" % (s, int(inputs[s]["width"]) * int(inputs[s]["height"]) * 12 / 2.0 ** 20)
        for s in sizes) + ". Medians of %s run(s)." % ", ".join(
        sorted({str(len(v)) for v in runs.values()})))

    np = _np()
    print()
    print("SH agreement with the exact double-precision projection of the same map "
          "(scripts/peer_bench.py): coefficient error = |c - ref| / |ref| over l <= L and the "
          "three channels; worst = max |c - ref| / |ref_00| per channel; band energy = max over "
          "channels of the relative error of sqrt(sum_m c_lm^2), l = 0, 1, ... (frame-free).")
    print()
    print("| size | result | reference | coefficient error | worst | band energy l = 0, 1, 2, ... |")
    print("|---|---|---|---|---|---|")
    notes = set()
    for size in sizes:
        d = os.path.join(work, "sh", size)
        refp = os.path.join(d, "reference.json")
        if not os.path.exists(refp):
            continue
        ref = json.load(open(refp))
        notes.add(ref["cmft_transform_residual"])
        cases = []
        ep = os.path.join(d, "envlight.json")
        if os.path.exists(ep):
            ej = json.load(open(ep))
            cases.append(("envlight `sh --order 2 --window none`", ej["radiance"], ref["radiance"],
                          "(m + 0.5) decode, envlight's basis", 2))
        cp = os.path.join(d, "cmft.c")
        if os.path.exists(cp):
            cc = read_cmft_c(cp)
            cases.append(("cmft `--filter shcoeffs`", cc, ref["cmft_radiance_m_decode"],
                          "m decode (cmft's), cmft's basis and frame", 4))
            cases.append(("cmft `--filter shcoeffs`", cc, ref["cmft_radiance"],
                          "(m + 0.5) decode, cmft's basis and frame", 4))
        for name, c, r, what, L in cases:
            rel, worst, bands = agreement(np, c, r, L)
            print("| %s | %s | %s, l <= %d | %s | %s | %s |" % (
                size, name, what, L, pct(rel), pct(worst), ", ".join(pct(b) for b in bands)))
    if notes:
        print()
        print("cmft's basis mapped from envlight's (frame d_cmft = (-y, z, x), phase (-1)^m, "
              "function 11 times sqrt 2): fit residual %.1e." % max(notes))


def main():
    ap = argparse.ArgumentParser(
        usage="python3 scripts/peer_bench.py {reference PFM OUT.json | report WORK}",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("reference", help="exact SH projection of a canonical lat-long PFM")
    r.add_argument("pfm")
    r.add_argument("out")
    r.set_defaults(fn=cmd_reference)
    p = sub.add_parser("report", help="markdown tables from peer_bench.sh's work folder")
    p.add_argument("work")
    p.set_defaults(fn=cmd_report)
    a = ap.parse_args()
    a.fn(a)


if __name__ == "__main__":
    main()
