#!/usr/bin/env python3
"""Draws the house: which source file (room) calls which, floor by floor.

usage: scripts/house.py BUILD_DIR [--svg OUT.svg] [--md OUT.md] [--title TEXT]

Reads the object files of the library, its format objects and the CLI under BUILD_DIR (`nm`):
an arrow A -> B when A uses a symbol B defines, plus an arrow to a header-only room (a .h under
src/ with no .c of its own that defines something) when A includes it. A room's floor is its
folder's layer (LAYERS, bottom first) when the sources live in folders; in a flat src/ it is its
height in the graph (0: calls nothing of ours). An arrow "back up" goes to a higher floor, or
within a circle (rooms that reach one another). Prints the counts (rooms, floors, arrows, arrows
back up, circles, the longest functions); --svg draws the house, --md writes the counts.
"""
import argparse
import collections
import glob
import os
import re
import subprocess
import sys

# Bottom first: a room may call its own floor and the floors below.
LAYERS = ["core", "io", "envmap", "products", "export", "cli", "lab"]
OBJECT_DIRS = ["envlight_objects.dir", "envlight_formats.dir", "envlight_cli.dir"]
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def rooms_and_arrows(build):
    """{room: set(rooms it calls)}; rooms are paths under src/."""
    defs, uses, rooms = {}, collections.defaultdict(set), set()
    for d in OBJECT_DIRS:
        for o in glob.glob(os.path.join(build, "CMakeFiles", d, "src", "**", "*.o"), recursive=True):
            rel = os.path.relpath(o, os.path.join(build, "CMakeFiles", d))[:-2]  # src/x/y.c
            if not os.path.exists(os.path.join(ROOT, rel)):
                continue  # an object left in the build folder by a source since moved
            rooms.add(rel)
            out = subprocess.run(["nm", o], capture_output=True, text=True, check=True).stdout
            for line in out.splitlines():
                p = line.split()
                if len(p) == 3 and p[1] in "TDBRC":
                    defs[p[2]] = rel
                elif len(p) == 2 and p[0] == "U":
                    uses[rel].add(p[1])
    arrows = collections.defaultdict(set)
    for room, symbols in uses.items():
        for s in symbols:
            if s in defs and defs[s] != room:
                arrows[room].add(defs[s])
    # Header-only rooms: a header whose functions are all static inline (no .c of its own).
    headers = {}
    for h in glob.glob(os.path.join(ROOT, "src", "**", "*.h"), recursive=True):
        rel = os.path.relpath(h, ROOT)
        if not os.path.exists(rel[:-2] + ".c") and re.search(r"static inline", open(h).read()):
            headers[os.path.basename(rel)] = rel
    for room in list(rooms):
        text = open(os.path.join(ROOT, room)).read()
        for inc in re.findall(r'#include\s+"(?:[^"]*/)?([^"/]+\.h)"', text):
            if inc in headers:
                rooms.add(headers[inc])
                arrows[room].add(headers[inc])
    for r in rooms:
        arrows.setdefault(r, set())
    return arrows


def circles(arrows):
    """Strongly connected components of more than one room (Tarjan)."""
    index, low, stack, on, out, n = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = n[0]
        n[0] += 1
        stack.append(v)
        on.add(v)
        for w in arrows[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(arrows):
        if v not in index:
            visit(v)
    return [c for c in out if len(c) > 1]


def floors(arrows, circ):
    """{room: floor}: the folder's layer, or (flat) the height over what the room calls."""
    folders = {r: r.split("/")[1] if r.count("/") >= 2 else None for r in arrows}
    if all(f in LAYERS for f in folders.values()):
        return {r: LAYERS.index(f) for r, f in folders.items()}, True
    comp = {r: i for i, c in enumerate(circ) for r in c}
    height = {}

    def h(r, seen=()):
        if r in height:
            return height[r]
        below = [h(w, seen + (r,)) + 1 for w in arrows[r]
                 if w not in seen and not (r in comp and comp.get(w) == comp[r])]
        height[r] = max(below, default=0)
        return height[r]

    for r in arrows:
        h(r)
    return height, False


def functions(paths):
    """(lines, name, file) of every function: from a line `{` at column 0 to `}` at column 0."""
    out = []
    for p in paths:
        if not p.endswith(".c"):
            continue
        lines = open(os.path.join(ROOT, p)).read().split("\n")
        start = None
        for i, line in enumerate(lines):
            if line.startswith("{") and i > 0:
                start = i
            elif line.startswith("}") and start is not None:
                head = " ".join(lines[max(0, start - 3):start])
                m = re.findall(r"(\w+)\s*\(", head)
                out.append((i - start + 2, m[0] if m else "?", p))
                start = None
    return sorted(out, reverse=True)


def svg(arrows, floor, up, title):
    by_floor = collections.defaultdict(list)
    for r in sorted(arrows):
        by_floor[floor[r]].append(r)
    top = max(by_floor)
    bw, bh, gx, gy = 128, 22, 10, 46
    width = max(len(v) for v in by_floor.values()) * (bw + gx) + 2 * gx
    height = (top + 1) * (bh + gy) + 40
    pos = {}
    for f, rs in by_floor.items():
        y = 40 + (top - f) * (bh + gy)
        for i, r in enumerate(rs):
            pos[r] = (gx + i * (bw + gx), y)
    parts = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="monospace" '
             'font-size="10">' % (width, height),
             '<defs><marker id="h" viewBox="0 0 6 6" refX="6" refY="3" markerWidth="5" markerHeight="5" '
             'orient="auto"><path d="M0,0 L6,3 L0,6 z" fill="#777"/></marker></defs>',
             '<rect width="100%" height="100%" fill="white"/>',
             '<text x="10" y="18" font-size="13">%s</text>' % title]
    for a in sorted(arrows):
        for b in sorted(arrows[a]):
            (x1, y1), (x2, y2) = pos[a], pos[b]
            colour = "#d62728" if (a, b) in up else "#9aa"
            parts.append('<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="%s" stroke-width="%s" marker-end="url(#h)"/>' % (
                x1 + bw / 2, y1 + (bh if y2 > y1 else 0), x2 + bw / 2, y2 + (0 if y2 > y1 else bh),
                colour, "1.5" if (a, b) in up else "0.5"))
    for r, (x, y) in pos.items():
        parts.append('<rect x="%d" y="%d" width="%d" height="%d" fill="#f4f1e8" stroke="#555"/>' % (
            x, y, bw, bh))
        parts.append('<text x="%d" y="%d">%s</text>' % (x + 4, y + 15, r[len("src/"):]))
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("build", help="a build folder of this tree (scripts/build.sh BUILD)")
    ap.add_argument("--svg", help="write the drawing here")
    ap.add_argument("--md", help="write the counts here (Markdown)")
    ap.add_argument("--title", default="envlight: who calls whom")
    a = ap.parse_args()
    arrows = rooms_and_arrows(a.build)
    if not arrows:
        sys.exit("house.py: no object files under %s (build it first)" % a.build)
    circ = circles(arrows)
    floor, by_folder = floors(arrows, circ)
    comp = {r: i for i, c in enumerate(circ) for r in c}
    up = {(x, y) for x in arrows for y in arrows[x]
          if floor[y] > floor[x] or (x in comp and comp.get(y) == comp[x])}
    funcs = functions(arrows)
    report = ["rooms: %d" % len(arrows),
              "floors: %d (%s)" % (len(set(floor.values())), "folders, bottom first: " + ", ".join(
                  l for l in LAYERS if l in {r.split('/')[1] for r in arrows}) if by_folder
                  else "heights in the call graph"),
              "arrows: %d" % sum(len(v) for v in arrows.values()),
              "arrows back up: %d%s" % (len(up), "".join("\n  %s -> %s" % e for e in sorted(up))),
              "circles: %d%s" % (len(circ), "".join("\n  " + " <-> ".join(c) for c in circ)),
              "longest functions (lines): " + ", ".join("%s %d (%s)" % (n, l, p) for l, n, p in funcs[:5])]
    print("\n".join(report))
    if a.svg:
        with open(a.svg, "w") as f:
            f.write(svg(arrows, floor, up, a.title))
    if a.md:
        with open(a.md, "w") as f:
            f.write("# %s\n\nWritten by `scripts/house.py` (do not edit by hand).\n\n```\n%s\n```\n"
                    % (a.title, "\n".join(report)))


if __name__ == "__main__":
    main()
