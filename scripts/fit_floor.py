#!/usr/bin/env python3
"""The best a fit of N directional lights + an order-2 SH remainder can do on a map: a global
search for the fit's own objective (relative RMS of luminance over the fit's 1031 Fibonacci
normals, the lights' weights >= 0, the SH free), from the fit's lights and from R random starts
(among the map's brightest pixels and uniform directions), each refined by gradient descent on
the sphere with a backtracking line search. Prints, per map, the library's fit (its lights'
directions, re-solved) and the best found: when the search finds nothing better, the fit sits
at the model's floor. --docs DIR writes DIR/fit_floor.md.

    PYTHONPATH=py_shim ENVLIGHT_LIBRARY=build/libenvlight.so \\
        /usr/bin/python3 scripts/fit_floor.py MAP... [--starts R] [-n N] [--docs DIR]
"""
import argparse
import datetime
import itertools
import math
import os
import sys

FIT_NORMALS = 1031
np = envlight = None  # imported by main(), after --help


def solve(cols, sh, target):
    """min |cols x + sh y - target| with x >= 0 (every subset of lights tried; N <= 6)."""
    k = cols.shape[1]
    best = (np.inf, None, None)
    for size in range(k + 1):
        for sub in itertools.combinations(range(k), size):
            a = np.hstack([cols[:, list(sub)], sh])
            x, *_ = np.linalg.lstsq(a, target, rcond=None)
            if np.all(x[:size] >= 0):
                r = a @ x - target
                if r @ r < best[0]:
                    xl = np.zeros(k)
                    xl[list(sub)] = x[:size]
                    best = (r @ r, xl, r)
    return best


def refine(dirs, normals, sh, target, ymean, steps=150):
    def err(d):
        return math.sqrt(solve(np.maximum(normals @ d.T, 0), sh, target)[0] / len(normals)) / ymean
    cur, step = err(dirs), 0.05
    for _ in range(steps):
        _, x, r = solve(np.maximum(normals @ dirs.T, 0), sh, target)
        g = np.zeros_like(dirs)
        for i in range(len(dirs)):
            lit = normals @ dirs[i] > 0
            gi = 2 * x[i] * (r[lit][:, None] * normals[lit]).sum(0)
            g[i] = gi - (gi @ dirs[i]) * dirs[i]
        norm = np.linalg.norm(g)
        if norm == 0:
            break
        while step > 1e-5:
            nd = dirs - step * g / norm
            nd /= np.linalg.norm(nd, axis=1)[:, None]
            ne = err(nd)
            if ne < cur:
                dirs, cur, step = nd, ne, step * 1.5
                break
            step *= 0.5
        if step <= 1e-5:
            break
    return dirs, cur


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("maps", nargs="+")
    ap.add_argument("--starts", type=int, default=30)
    ap.add_argument("-n", type=int, default=4)
    ap.add_argument("--docs", help="write DIR/fit_floor.md")
    a = ap.parse_args()
    global np, envlight
    import numpy as np
    import envlight
    lum = np.array([0.2126, 0.7152, 0.0722])
    load0, lines = os.getloadavg(), []
    rng = np.random.default_rng(1)
    normals = np.array(envlight.fibonacci_directions(FIT_NORMALS))
    sh = np.array([envlight.sh_basis(2, tuple(n)) for n in normals])
    for path in a.maps:
        with (envlight.sky() if path == "-" else envlight.load(path)) as env:
            target = np.array(env.irradiance(normals)) @ lum
            ymean = np.mean(np.abs(target))
            with env.lights(a.n, residual=False, measure=False) as res:
                fit = np.array([l.direction for l in res.lights])
            px = env.pixels()
            h, w = px.shape[:2]
            theta = math.pi * (0.5 - (np.arange(h) + 0.5) / h)
            phi = math.pi * (1 - 2 * (np.arange(w) + 0.5) / w)
            d = np.stack([np.cos(theta)[:, None] * np.cos(phi)[None, :],
                          np.cos(theta)[:, None] * np.sin(phi)[None, :],
                          np.broadcast_to(np.sin(theta)[:, None], (h, w))], -1).reshape(-1, 3)
            energy = (px @ lum * np.cos(theta)[:, None]).reshape(-1)
            bright = d[np.argsort(-energy)[:3000]]
            uniform = np.array(envlight.fibonacci_directions(1000))
        _, fit_err = refine(fit, normals, sh, target, ymean, steps=0)
        best = fit_err
        for s in range(a.starts):
            pool = bright if s % 2 else uniform
            start = pool[rng.choice(len(pool), len(fit), replace=False)]
            best = min(best, refine(start.copy(), normals, sh, target, ymean)[1])
        best = min(best, refine(fit.copy(), normals, sh, target, ymean)[1])
        line = ("%s: %d lights + SH 2: the fit's lights %.3f %%, best found %.3f %% (%d starts)"
                % (os.path.basename(path), len(fit), 100 * fit_err, 100 * best, a.starts + 1))
        print(line, flush=True)
        lines.append("- " + line)
    if a.docs:
        with open(os.path.join(a.docs, "fit_floor.md"), "w") as f:
            f.write("# The model's floor: the best 4 lights + SH order 2 can do\n\n"
                    "Written by `/usr/bin/python3 scripts/fit_floor.py %s` on %s, load average "
                    "%.1f %.1f %.1f at the start, %.1f %.1f %.1f at the end.\n\n"
                    "The fit's objective (relative RMS of luminance over its 1031 normals, "
                    "without the up row) for the library's lights, re-solved, and the least "
                    "found by gradient descent from them and from random starts "
                    "(scripts/fit_floor.py): where the search finds nothing much better, no "
                    "fit of the model reaches less, and a gate of 1 %% cannot hold there "
                    "(tests/py_fit_gate.py).\n\n%s\n"
                    % (" ".join(sys.argv[1:]), datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
                       *load0, *os.getloadavg(), "\n".join(lines)))


if __name__ == "__main__":
    sys.exit(main())
