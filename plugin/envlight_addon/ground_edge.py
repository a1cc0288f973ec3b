"""A ground of finite size (issue 28).

Over a ground the add-on gives the world's lower half the ground's bounce: the map as a scene
on an endless plane sees it (envlight.Envmap.ground_plane). A real ground ends. Seen from the
objects, the directions between the horizon and the ground's edge pass beyond it and meet the
map itself: from a point at height h above a ground whose edge lies at distance d along an
azimuth, every direction down to atan(h / d) below the horizon (the scene bench's 20 m
ground around a sphere of 1 m: 5.7 degrees, a tenth of the side normals' light). With the
bounce there the scene's matte sphere was lit by what the map does not show: in Cycles, with
the same lamps and world that EEVEE gets, -10.4 % on lebombo, +4.5 % on potsdamer_platz
(scripts/blender_eevee_parts.py, the recipe term). So that band keeps the map's own pixels in
the world, per column, seen from the centre of the objects' bounding box.

The map's frame is the library's (docs/design.md): row r's centre at elevation
pi (0.5 - (r + 0.5) / H), column c's at azimuth phi = pi - 2 pi (c + 0.5) / W, and the world's
Mapping node turns it by `rot` (about Z only: a tilted world gets no ground treatment).
"""
import math


def edge_depression(lo, hi, centre, azimuth):
    """The angle below the horizon (radians, 0 .. pi/2) of the edge of the ground box
    lo..hi (x, y; its top at hi[2]) seen from `centre` along `azimuth` (radians, scene frame):
    atan(height / distance to the edge). A centre outside the box's x-y extent is taken at
    the nearest point inside it; a centre on or under the ground top sees no band (0)."""
    height = centre[2] - hi[2]
    if not height > 0:
        return 0.0
    x = min(max(centre[0], lo[0]), hi[0])
    y = min(max(centre[1], lo[1]), hi[1])
    dx, dy = math.cos(azimuth), math.sin(azimuth)
    dist = math.inf
    if dx > 1e-12:
        dist = min(dist, (hi[0] - x) / dx)
    elif dx < -1e-12:
        dist = min(dist, (lo[0] - x) / dx)
    if dy > 1e-12:
        dist = min(dist, (hi[1] - y) / dy)
    elif dy < -1e-12:
        dist = min(dist, (lo[1] - y) / dy)
    return math.atan2(height, max(dist, 0.0))


def depression_range(lo, hi, centre):
    """The least and the largest depression of the ground's edge over 360 azimuths."""
    d = [edge_depression(lo, hi, centre, math.radians(a)) for a in range(360)]
    return min(d), max(d)


def band(np, height, width, lo, hi, centre, rot=None):
    """The pixels of a lat-long map whose directions, seen from `centre`, pass beyond the
    ground box's edge below the horizon: the rows whose centre lies between the horizon and
    the edge's depression in that column. -> (first row, a boolean array of the rows from it
    that hold any, by width): a band, not a map's worth of flags (a 16K map's would be 128
    MiB). rot: the world's turn (3 x 3, rows; a turn about Z), None for none."""
    elev = math.pi * (0.5 - (np.arange(height) + 0.5) / height)
    depression = np.empty(width)
    for c in range(width):
        phi = math.pi - 2.0 * math.pi * (c + 0.5) / width
        d = (math.cos(phi), math.sin(phi), 0.0)
        if rot is not None:
            d = tuple(sum(rot[i][k] * d[k] for k in range(3)) for i in range(3))
        depression[c] = edge_depression(lo, hi, centre, math.atan2(d[1], d[0]))
    rows = np.nonzero((elev < 0.0) & (elev > -depression.max()))[0]
    first = int(rows[0]) if len(rows) else height
    last = int(rows[-1]) + 1 if len(rows) else height
    e = elev[first:last, None]
    return first, (e < 0.0) & (e > -depression[None, :])


def add(image, band, delta):
    """Adds `delta` to the pixels of image (height x width x 3, a numpy array) in `band`
    (band()'s), in place (no second copy of a 16K map): the band's map pixels less what the
    image's source held there (core.band_pixels). Returns image."""
    first, mask = band
    image[first:first + mask.shape[0]][mask] += delta
    return image
