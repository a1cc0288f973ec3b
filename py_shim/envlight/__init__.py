"""envlight: HDR environment images into lights, spherical harmonics and prefiltered maps.

A Pythonic layer over libenvlight (ctypes; see _lib.py for the loader and the one table of
argtypes/restypes). Directions are in the canonical frame: Blender's world frame, right-handed,
+Z up; a light's ``rgb`` is the irradiance it delivers to a surface facing it (sum of L dw).

    import envlight
    with envlight.load("park.hdr") as env:
        with env.lights(4, method="fit") as res:
            res.lights[0].direction, res.summary["diffuse_error"], res.residual

Arrays are numpy arrays when numpy can be imported, else lists of tuples. Handles are released
by close() or at the end of a ``with`` block (and, as a fallback, by the garbage collector).
"""
import ctypes
import math
from ctypes import byref, c_double, c_float, c_int32, c_void_p
from dataclasses import dataclass
from typing import Optional, Tuple

from . import _lib
from ._lib import ABI_VERSION, Error, _check, _str, lib, library_path

try:
    import numpy as _np
except ImportError:  # pragma: no cover - numpy is optional
    _np = None

__all__ = ["Error", "Envmap", "LightsResult", "SHResult", "Light", "load", "sky", "from_pixels",
           "save_image", "fibonacci_directions", "relative_rms_luminance", "sh_basis",
           "cosine_lobe", "brdf_lut", "brdf_eval", "Products", "version", "ABI_VERSION", "library_path", "has_numpy"]

__version__ = "0.1.0"
has_numpy = _np is not None

#: Fallback way to turn an rgb into a Blender sun (energy * color == rgb): see Light.blender_sun.
SUN_ENERGY_MODES = ("max", "luminance")


def version():
    """The library's version string."""
    return _str(lib.envl_version_string())


# ---- small helpers -------------------------------------------------------------------------

def _enum(value, from_name, to_name, what):
    """An enum given as a name ('fit') or an int; returns the int, Error-free ValueError if
    unknown (bad usage, not a library failure)."""
    if isinstance(value, str):
        v = from_name(value.encode())
        if v < 0:
            raise ValueError("unknown %s %r" % (what, value))
        return v
    v = int(value)
    if to_name(v) is None:
        raise ValueError("unknown %s %r" % (what, value))
    return v


def _layout(value):
    if value is None or value == "auto":
        return 0
    return _enum(value, lib.envl_layout_from_name, lib.envl_layout_name, "layout")


def _vectors(values):
    """(N, 3) directions -> (count, ctypes double array)."""
    if _np is not None:
        a = _np.ascontiguousarray(_np.asarray(values, dtype=_np.float64).reshape(-1, 3))
        buf = (c_double * a.size).from_buffer_copy(a.tobytes())
        return len(a), buf
    flat = [float(x) for v in values for x in v]
    if len(flat) % 3:
        raise ValueError("directions must be triples")
    return len(flat) // 3, (c_double * len(flat))(*flat)


def _rows(ptr, n, k, dtype="float64"):
    """n rows of k values from a C pointer: an (n, k) numpy copy, or a list of tuples."""
    if n == 0:
        return _np.zeros((0, k), dtype=dtype) if _np is not None else []
    if _np is not None:
        return _np.ctypeslib.as_array(ptr, shape=(n * k,)).reshape(n, k).astype(dtype, copy=True)
    return [tuple(ptr[i * k + j] for j in range(k)) for i in range(n)]


def _image(ptr, width, height):
    """RGB floats (row 0 at the top) -> (height, width, 3) float32 numpy copy, or a flat list."""
    n = width * height * 3
    if _np is not None:
        return _np.ctypeslib.as_array(ptr, shape=(n,)).reshape(height, width, 3).copy()
    return list(ptr[:n])


def _t(arr):
    return tuple(arr)


def _load_options(layout=None, width=0, rotate=0.0, max_pixels=0, strict=False,
                  apply_exposure=False, exr_part=None, threads=0):
    o = _lib.LoadOptions()
    o.layout = _layout(layout)
    o.width = int(width or 0)
    o.rotate_degrees = float(rotate or 0.0)
    o.max_pixels = int(max_pixels or 0)
    o.strict = 1 if strict else 0
    o.apply_exposure = 1 if apply_exposure else 0
    o.exr_part = exr_part.encode() if exr_part else None
    o.threads = int(threads or 0)
    return o


# ---- constructors --------------------------------------------------------------------------

def load(path, layout="auto", rotate=0.0, width=0, strict=False, apply_exposure=False,
         exr_part=None, max_pixels=0, threads=0):
    """Loads an .hdr/.pic, .exr or .pfm file into the canonical lat-long frame.

    layout: 'auto', 'latlong', 'angular', 'mirrorball', 'cross', 'hcross', 'hstrip', 'vstrip',
    'exr-latlong', 'exr-cube' (or the ENVL_LAYOUT_* int); rotate: degrees about +Z
    (counter-clockwise seen from above); width: canonical map width (0 = default)."""
    o = _load_options(layout, width, rotate, max_pixels, strict, apply_exposure, exr_part, threads)
    h = c_void_p()
    _check(lib.envl_envmap_load(str(path).encode(), byref(o), byref(h)))
    return Envmap(h)


def sky(sun_elevation=35.0, sun_azimuth=0.0, width=1024, sun_irradiance=0.0, zenith_radiance=0.0,
        ground_albedo=0.0):
    """The built-in procedural clear sky (0 = the library's default for the last three)."""
    o = _lib.SkyOptions()
    o.sun_elevation_degrees = float(sun_elevation)
    o.sun_elevation_is_set = 1
    o.sun_azimuth_degrees = float(sun_azimuth)
    o.width = int(width or 0)
    o.sun_irradiance = float(sun_irradiance)
    o.zenith_radiance = float(zenith_radiance)
    o.ground_albedo = float(ground_albedo)
    h = c_void_p()
    _check(lib.envl_envmap_sky(byref(o), byref(h)))
    return Envmap(h)


def _float_buffer(buffer, width, height, channels, flip):
    """Any float pixel source -> (ctypes float array or numpy array, pointer), row 0 at top."""
    n = width * height * channels
    if _np is not None and isinstance(buffer, _np.ndarray):
        a = _np.asarray(buffer, dtype=_np.float32).reshape(-1)
        if a.size < n:
            raise ValueError("pixel buffer holds %d floats, %d x %d x %d needs %d"
                             % (a.size, width, height, channels, n))
        a = a[:n].reshape(height, width * channels)
        if flip:
            a = a[::-1]
        a = _np.ascontiguousarray(a)
        return a, a.ctypes.data_as(ctypes.POINTER(c_float))
    try:
        mv = memoryview(buffer)
    except TypeError:
        mv = None
    if mv is not None:
        if mv.format not in ("f", "B", "b", "c"):
            raise TypeError("pixel buffer of format %r: float32 ('f') expected" % mv.format)
        raw = mv.cast("B")
        row = width * channels * 4
        if len(raw) < n * 4:
            raise ValueError("pixel buffer holds %d bytes, %d x %d x %d floats need %d"
                             % (len(raw), width, height, channels, n * 4))
        if flip:
            data = b"".join(raw[(height - 1 - r) * row:(height - r) * row].tobytes()
                            for r in range(height))
        else:
            data = raw[:n * 4].tobytes()
        arr = (c_float * n).from_buffer_copy(data)
    else:  # a plain sequence of numbers (slow; e.g. a bpy_prop_array without numpy)
        seq = list(buffer)
        if len(seq) < n:
            raise ValueError("pixel sequence holds %d values, %d needed" % (len(seq), n))
        row = width * channels
        if flip:
            seq = [x for r in range(height - 1, -1, -1) for x in seq[r * row:(r + 1) * row]]
        arr = (c_float * n)(*seq[:n])
    return arr, ctypes.cast(arr, ctypes.POINTER(c_float))


def from_pixels(buffer, width=None, height=None, channels=None, flip=False, layout="auto",
                rotate=0.0, map_width=0, strict=False, threads=0):
    """An envmap from float pixels in memory.

    buffer: a numpy array ((height, width, channels) shapes give the sizes) or any object with
    the buffer protocol holding float32 values (array.array('f'), bytes, memoryview), or a
    sequence of numbers. channels: 1, 3 or 4 (alpha ignored). Rows run top to bottom; pass
    flip=True for bottom-up pixels such as Blender's Image.pixels (RGBA, row 0 at the bottom).
    map_width: width of the canonical map (0 = keep)."""
    if _np is not None and isinstance(buffer, _np.ndarray) and buffer.ndim == 3:
        h, w, c = buffer.shape
        height = h if height is None else height
        width = w if width is None else width
        channels = c if channels is None else channels
    if _np is not None and isinstance(buffer, _np.ndarray) and buffer.ndim == 2:
        h, w = buffer.shape
        height = h if height is None else height
        width = w if width is None else width
        channels = 1 if channels is None else channels
    if width is None or height is None or channels is None:
        raise ValueError("from_pixels: width, height and channels are needed for a flat buffer")
    width, height, channels = int(width), int(height), int(channels)
    if width <= 0 or height <= 0:
        raise ValueError("from_pixels: %d x %d pixels" % (width, height))
    if channels not in (1, 3, 4):
        # the library names the problem; let it (ENVL_ERR_ARGUMENT) - but never read past the
        # buffer: pass a pointer to a small dummy
        dummy = (c_float * 4)()
        o = _load_options(layout, map_width, rotate, 0, strict, False, None, threads)
        _check(lib.envl_envmap_from_pixels(dummy, width, height, channels, byref(o),
                                           byref(c_void_p())))
    keep, ptr = _float_buffer(buffer, width, height, channels, flip)
    o = _load_options(layout, map_width, rotate, 0, strict, False, None, threads)
    h = c_void_p()
    _check(lib.envl_envmap_from_pixels(ptr, width, height, channels, byref(o), byref(h)))
    del keep
    return Envmap(h)


def save_image(path, rgb, width=None, height=None, format=None, half=False):
    """Writes RGB floats (row 0 at the top) as .hdr / .exr / .pfm (by extension or format),
    atomically. rgb: a (height, width, 3) numpy array or a flat float32 buffer/sequence."""
    if _np is not None and isinstance(rgb, _np.ndarray) and rgb.ndim == 3:
        height, width = rgb.shape[0], rgb.shape[1]
        if rgb.shape[2] != 3:
            raise ValueError("save_image: 3 channels expected, got %d" % rgb.shape[2])
    if width is None or height is None:
        raise ValueError("save_image: width and height are needed for a flat buffer")
    keep, ptr = _float_buffer(rgb, int(width), int(height), 3, False)
    o = _lib.SaveOptions()
    o.pixel_type = _lib.ENVL_PIXEL_HALF if half else _lib.ENVL_PIXEL_FLOAT
    o.format = format.encode() if format else None
    _check(lib.envl_image_save(str(path).encode(), ptr, int(width), int(height), byref(o)))
    del keep


def fibonacci_directions(n=_lib.ENVL_ERROR_NORMALS):
    """The n points of the Fibonacci sphere the error measure uses (n = 1024)."""
    d = (c_double * 3)()
    out = []
    for i in range(n):
        lib.envl_fibonacci_direction(i, n, d)
        out.append(tuple(d))
    return _np.array(out) if _np is not None else out


def relative_rms_luminance(approx_rgb, exact_rgb):
    """DESIGN.md's error: sqrt(mean((Ya - Ye)^2)) / mean(|Ye|) over (N, 3) irradiances."""
    na, a = _vectors(approx_rgb)
    ne, e = _vectors(exact_rgb)
    if na != ne:
        raise ValueError("relative_rms_luminance: %d and %d values" % (na, ne))
    return lib.envl_relative_rms_luminance(na, a, e)


def sh_basis(order, direction):
    """Y_lm(direction) for l = 0..order, index l (l + 1) + m."""
    n = (order + 1) ** 2
    y = (c_double * n)()
    lib.envl_sh_basis(int(order), (c_double * 3)(*direction), y)
    return list(y)


def cosine_lobe(l):
    """A_l: irradiance coefficient = A_l x radiance coefficient (pi, 2 pi / 3, pi / 4, 0, ...)."""
    return lib.envl_sh_cosine_lobe(int(l))


# ---- handles ---------------------------------------------------------------------------------

class _Handle:
    _free = None

    def __init__(self, handle):
        self._h = handle

    @property
    def closed(self):
        return self._h is None or not self._h.value

    def _handle(self):
        if self.closed:
            raise ValueError("%s is closed" % type(self).__name__)
        return self._h

    def close(self):
        """Releases the library object now (idempotent)."""
        h, self._h = self._h, None
        if h is not None and h.value:
            getattr(lib, self._free)(h)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def __del__(self):
        try:
            self.close()
        except Exception:  # interpreter shutdown
            pass


@dataclass(frozen=True)
class Light:
    """One directional light (canonical frame). rgb: irradiance at normal incidence (sum of
    L dw); solid_angle of its region (sr); angle: angular diameter 2 acos(1 - omega / 2 pi),
    radians, <= pi; rect: the region's pixel rectangle (x0, y0, x1, y1), x1 may pass the seam."""
    direction: Tuple[float, float, float]
    rgb: Tuple[float, float, float]
    solid_angle: float
    angle: float
    rect: Tuple[int, int, int, int]

    def blender_sun(self, mode="max"):
        """(energy, color) of a Blender sun lamp with energy * color == rgb (DESIGN.md).
        mode 'max': energy = the largest channel, colour <= 1; 'luminance': energy = Y."""
        r, g, b = self.rgb
        e = max(r, g, b) if mode == "max" else lib.envl_luminance(r, g, b)
        if e <= 0:
            return 0.0, (1.0, 1.0, 1.0)
        return e, (r / e, g / e, b / e)

    def as_dict(self):
        return {"direction": list(self.direction), "rgb": list(self.rgb),
                "solid_angle": self.solid_angle, "angle": self.angle, "rect": list(self.rect)}


class Envmap(_Handle):
    """The canonical lat-long map (float RGB, row 0 at the top) with its cached tables."""
    _free = "envl_envmap_free"

    @property
    def width(self):
        return lib.envl_envmap_width(self._handle())

    @property
    def height(self):
        return lib.envl_envmap_height(self._handle())

    def info(self):
        """What was read and what the map holds, as a dict (envl_info's fields)."""
        i = _lib.Info()
        _check(lib.envl_envmap_info(self._handle(), byref(i)))
        return {
            "file": _str(i.file), "format": _str(i.format),
            "layout": _str(lib.envl_layout_name(i.layout)), "layout_guessed": bool(i.layout_guessed),
            "source_width": i.source_width, "source_height": i.source_height,
            "channels": i.channels, "width": i.width, "height": i.height,
            "mean": _t(i.mean), "power": _t(i.power), "max": _t(i.max),
            "brightest_direction": _t(i.brightest_direction),
            "nonfinite_pixels": i.nonfinite_pixels, "negative_pixels": i.negative_pixels,
            "exposure": i.exposure,
            "primaries": _t(i.primaries) if i.has_primaries else None,
            "rotate_degrees": i.rotate_degrees,
        }

    def pixels(self):
        """A copy of the map: (height, width, 3) float32 numpy array (flat list without numpy)."""
        h = self._handle()
        return _image(lib.envl_envmap_pixels(h), lib.envl_envmap_width(h),
                      lib.envl_envmap_height(h))

    def solid_angle(self, row):
        return lib.envl_envmap_solid_angle(self._handle(), int(row))

    def direction(self, column, row):
        d = (c_double * 3)()
        lib.envl_envmap_direction(self._handle(), int(column), int(row), d)
        return tuple(d)

    def pixel_of(self, direction):
        """Continuous (column, row) of a direction in this map."""
        c, r = c_double(), c_double()
        lib.envl_latlong_pixel(self.width, self.height, (c_double * 3)(*direction), byref(c),
                               byref(r))
        return c.value, r.value

    def irradiance(self, normals):
        """Exact irradiance E(n) = sum L dw max(0, n.d) for (N, 3) normals -> (N, 3)."""
        n, buf = _vectors(normals)
        out = (c_double * (3 * n))()
        _check(lib.envl_irradiance_exact(self._handle(), n, buf, out))
        return _rows(out, n, 3)

    def reference_irradiance(self):
        """Exact irradiance at the error measure's 1024 Fibonacci normals (cached)."""
        p = ctypes.POINTER(c_double)()
        _check(lib.envl_envmap_reference_irradiance(self._handle(), byref(p)))
        return _rows(p, _lib.ENVL_ERROR_NORMALS, 3)

    def drop_caches(self, which=_lib.ENVL_CACHE_SAT | _lib.ENVL_CACHE_REFERENCE):
        lib.envl_envmap_drop_caches(self._handle(), int(which))

    def save(self, path, format=None, half=False):
        """Writes the canonical map (.hdr, .exr, .pfm by extension or format), atomically."""
        o = _lib.SaveOptions()
        o.pixel_type = _lib.ENVL_PIXEL_HALF if half else _lib.ENVL_PIXEL_FLOAT
        o.format = format.encode() if format else None
        _check(lib.envl_envmap_save(self._handle(), str(path).encode(), byref(o)))

    def ground_plane(self, albedo):
        """The map as a scene on a ground plane (canonical z = 0) of this albedo sees it: a new
        Envmap whose lower hemisphere is the plane's radiance albedo E_up / pi (E_up: the exact
        irradiance at +Z), and that radiance (rgb). -> (Envmap, [r, g, b])"""
        h, rgb = c_void_p(), (c_double * 3)()
        _check(lib.envl_ground_plane_map(self._handle(), float(albedo), 0, byref(h), rgb))
        return Envmap(h), list(rgb)

    def sky_hemisphere(self):
        """A new Envmap with the lower hemisphere black (the sky over a ground plane)."""
        h = c_void_p()
        _check(lib.envl_sky_hemisphere_map(self._handle(), 0, byref(h)))
        return Envmap(h)

    def to_layout(self, layout, size=0):
        """The map rendered into another layout -> (height, width, 3) array (or flat list)."""
        p = ctypes.POINTER(c_float)()
        w, h = c_int32(), c_int32()
        _check(lib.envl_envmap_to_layout(self._handle(), _layout(layout), int(size), byref(p),
                                         byref(w), byref(h)))
        try:
            return _image(p, w.value, h.value)
        finally:
            lib.envl_free(p)

    def lights(self, n=0, method="fit", order=2):
        """Directional lights standing in for the map.

        n: number of lights (0 = the library's default: 16, fit 4; sun: at most n, 4); method:
        'median', 'variance', 'fit' or 'sun' (the suns split off exactly; the residual is the
        map less their excess); order: fit's SH remainder order (0..8), None for lights only
        (ignored by the cuts and sun). Returns a LightsResult (a context manager)."""
        o = _lib.LightsOptions()
        o.method = _enum(method, lib.envl_method_from_name, lib.envl_method_name, "method")
        o.count = int(n or 0)
        o.remainder_bands = _lib.ENVL_REMAINDER_NONE if order is None else int(order) + 1
        h = c_void_p()
        m = self._handle()
        _check(lib.envl_lights_compute(m, byref(o), byref(h)))
        # the residual has the map's size (the lights object does not export it)
        return LightsResult(h, lib.envl_envmap_width(m), lib.envl_envmap_height(m))

    def sh(self, order=2, window="none"):
        """Real SH projection of the map (order 0..32; window 'none', 'hann', 'lanczos',
        'auto'). Returns an SHResult (a context manager)."""
        o = _lib.SHOptions()
        o.bands = int(order) + 1
        o.window = _enum(window, lib.envl_window_from_name, lib.envl_window_name, "window")
        h = c_void_p()
        _check(lib.envl_sh_compute(self._handle(), byref(o), byref(h)))
        return SHResult(h)


    def _prefilter_options(self, levels=0, width=0, min_width=0, samples=0, unfiltered=False,
                           irradiance_method="resampled", irradiance_width=0,
                           irradiance_order=2, threads=0, sun_lights=False):
        o = _lib.PrefilterOptions()
        o.levels, o.width, o.min_width, o.samples = int(levels), int(width), int(min_width), \
            int(samples)
        o.unfiltered = 1 if unfiltered else 0
        o.irradiance_method = _enum(irradiance_method, lib.envl_irradiance_method_from_name,
                                    lib.envl_irradiance_method_name, "irradiance method")
        o.irradiance_width, o.irradiance_order = int(irradiance_width), int(irradiance_order)
        o.threads = int(threads)
        o.sun_lights = 1 if sun_lights else 0
        return o

    def prefilter(self, roughness=None, chain=False, mirror=False, irradiance=False,
                  diffuse=False, brdf=False, measure=False, sh_order=2, brdf_size=0,
                  multiscatter=False, shadows=0, shadows_method="median", **options):
        """Prefiltered maps (one envl_compute request; only what is asked is computed):
        roughness: GGX roughness values (one specular level each); chain: all K levels
        (options: levels, width, min_width, samples, unfiltered, irradiance_method
        'resampled'|'sh'|'exact', irradiance_width, irradiance_order, threads, sun_lights: the
        sun as lights, left out of the irradiance map and glossy levels); mirror: the
        roughness-0 level; irradiance: an irradiance map; diffuse: SH irradiance of sh_order;
        brdf: the split-sum table; shadows: that many lights for shadows (shadows_method
        'median'|'variance'|'fit'|'sun'); measure: also the glossy / diffuse errors (slow).
        Returns Products (a context manager)."""
        req = _lib.Request()
        rough = [float(r) for r in (roughness or [])]
        keep = (c_double * max(1, len(rough)))(*rough)
        req.n_roughness = len(rough)
        req.roughness = keep
        req.specular_chain = 1 if chain else 0
        req.mirror = 1 if mirror else 0
        req.irradiance_map = 1 if irradiance else 0
        req.diffuse = 1 if diffuse else 0
        req.brdf_lut = 1 if brdf else 0
        req.measure = 1 if measure else 0
        req.sh_order = int(sh_order)
        req.prefilter = self._prefilter_options(**options)
        req.shadows = 1 if shadows else 0
        req.lights.count = int(shadows or 0)
        req.lights.method = _enum(shadows_method, lib.envl_method_from_name, lib.envl_method_name,
                                  "method")
        req.brdf.size = int(brdf_size)
        req.brdf.multiscatter = 1 if multiscatter else 0
        h = c_void_p()
        _check(lib.envl_compute(self._handle(), byref(req), byref(h)))
        return Products(h)

    def specular(self, roughness, width=0, **options):
        """One prefiltered GGX specular level -> ((height, width, 3) array, stats dict)."""
        o = self._prefilter_options(**options)
        p = ctypes.POINTER(c_float)()
        st = _lib.Level()
        _check(lib.envl_prefilter_specular(self._handle(), float(roughness), int(width), byref(o),
                                           byref(p), byref(st)))
        try:
            return _image(p, st.width, st.height), _level_dict(st, with_rgb=False)
        finally:
            lib.envl_free(p)


def _level_dict(st, with_rgb=True):
    d = {"roughness": st.roughness, "alpha": st.alpha, "width": st.width, "height": st.height,
         "samples": st.samples, "filtered": bool(st.filtered), "energy_scale": st.energy_scale,
         "glossy_error": st.glossy_error if st.glossy_error >= 0 else None,
         "seconds": st.seconds}
    if with_rgb:
        d["rgb"] = _image(st.rgb, st.width, st.height)
    return d


def brdf_lut(size=0, samples=0, multiscatter=False, threads=0):
    """The split-sum BRDF table: (size, size, 2) float32 array (row j = roughness (j+0.5)/S,
    column i = NoV (i+0.5)/S); channels (A, B), or (DFG1, DFG2) with multiscatter."""
    o = _lib.BrdfOptions()
    o.size, o.samples, o.multiscatter, o.threads = int(size), int(samples), \
        1 if multiscatter else 0, int(threads)
    p = ctypes.POINTER(c_float)()
    n = c_int32()
    _check(lib.envl_brdf_lut(byref(o), byref(p), byref(n)))
    try:
        return _rows(p, n.value * n.value, 2, "float32").reshape(n.value, n.value, 2) \
            if _np is not None else list(p[:n.value * n.value * 2])
    finally:
        lib.envl_free(p)


def brdf_eval(nov, roughness, samples=0):
    """Single-scatter (A, B) of the split sum at (NoV, roughness)."""
    ab = (c_double * 2)()
    _check(lib.envl_brdf_eval(float(nov), float(roughness), int(samples), ab))
    return ab[0], ab[1]


class Products(_Handle):
    """What Envmap.prefilter computed: .levels (list of dicts with an 'rgb' array), .irradiance
    (dict with 'rgb', or None), .sh_irradiance (coefficients or None), .brdf (array or None),
    .summary (the sharing counters and times); export(dir) writes files."""
    _free = "envl_products_free"

    def __init__(self, handle):
        super().__init__(handle)
        s = _lib.ProductsSummary()
        _check(lib.envl_products_get_summary(handle, byref(s)))
        self.summary = {name: getattr(s, name) for name, _ in s._fields_}
        self.levels = []
        st = _lib.Level()
        for i in range(lib.envl_products_level_count(handle)):
            _check(lib.envl_products_level(handle, i, byref(st)))
            self.levels.append(_level_dict(st))
        im = _lib.IrradianceMap()
        self.irradiance = None
        if s.irradiance_maps and lib.envl_products_irradiance(handle, byref(im)) == 0:
            self.irradiance = {"method": _str(lib.envl_irradiance_method_name(im.method)),
                               "width": im.width, "height": im.height,
                               "rgb": _image(im.rgb, im.width, im.height),
                               "diffuse_error": im.diffuse_error if im.diffuse_error >= 0
                               else None, "seconds": im.seconds}
        shp = lib.envl_products_sh(handle)
        self.sh_irradiance = None
        if shp:
            sm = _lib.SHSummary()
            _check(lib.envl_sh_get_summary(shp, byref(sm)))
            self.sh_irradiance = _rows(lib.envl_sh_irradiance(shp), (sm.order + 1) ** 2, 3)
        n_sun = c_int32()
        sp = lib.envl_products_sun_lights(handle, byref(n_sun))
        #: with sun_lights: the split-off sun as a list of Light (rect unused), else []
        self.sun_lights = [Light(_t(sp[i].direction), _t(sp[i].rgb), sp[i].solid_angle,
                                 sp[i].angle, _t(sp[i].rect)) for i in range(n_sun.value)]
        size, ms = c_int32(), c_int32()
        bp = lib.envl_products_brdf(handle, byref(size), byref(ms))
        self.brdf = None
        if bp:
            n = size.value
            self.brdf = _rows(bp, n * n, 2, "float32")
            if _np is not None:
                self.brdf = self.brdf.reshape(n, n, 2)

    def find_level(self, roughness):
        i = lib.envl_products_find_level(self._handle(), float(roughness))
        return self.levels[i] if i >= 0 else None

    def export(self, directory, format="exr", layout="latlong"):
        """Writes the products into `directory` (with prefilter.json), all-or-nothing."""
        o = _lib.ExportOptions()
        o.format = format.encode() if format else None
        o.layout = _enum(layout, lib.envl_export_layout_from_name, lib.envl_export_layout_name,
                         "export layout")
        _check(lib.envl_products_export(self._handle(), str(directory).encode(), byref(o)))


class LightsResult(_Handle):
    """Lights, their summary, the fit remainder and the residual environment."""
    _free = "envl_lights_free"

    def __init__(self, handle, width, height):
        super().__init__(handle)
        self._wh = (width, height)
        s = _lib.LightsSummary()
        _check(lib.envl_lights_get_summary(handle, byref(s)))
        self.summary = {
            "method": _str(lib.envl_method_name(s.method)), "count": s.count,
            "power": _t(s.power), "lights_power": _t(s.lights_power),
            "residual_power": _t(s.residual_power),
            "remainder_order": s.remainder_order if s.remainder_order >= 0 else None,
            "diffuse_error": s.diffuse_error, "seconds": s.seconds, "no_light": bool(s.no_light),
        }
        lights = []
        one = _lib.Light()
        for i in range(lib.envl_lights_count(handle)):
            _check(lib.envl_lights_get(handle, i, byref(one)))
            lights.append(Light(_t(one.direction), _t(one.rgb), one.solid_angle, one.angle,
                                _t(one.rect)))
        #: list of Light, strongest first as the library orders them
        self.lights = lights
        order = c_int32(-1)
        p = lib.envl_lights_remainder(handle, byref(order))
        #: fit remainder: irradiance SH coefficients ((order+1)^2, 3), or None
        self.remainder = _rows(p, (order.value + 1) ** 2, 3) if p and order.value >= 0 else None
        self.remainder_order = order.value if self.remainder is not None else None
        self._residual = None

    def __len__(self):
        return len(self.lights)

    def __iter__(self):
        return iter(self.lights)

    @property
    def remainder_radiance(self):
        """The remainder as radiance SH coefficients: irradiance coefficient / A_l (bands
        whose A_l is 0 become 0)."""
        if self.remainder is None:
            return None
        out = []
        for l in range(self.remainder_order + 1):
            a = lib.envl_sh_cosine_lobe(l)
            for _ in range(2 * l + 1):
                i = len(out)
                out.append(tuple((v / a if a != 0 else 0.0) for v in self.remainder[i]))
        return _np.array(out) if _np is not None else out

    @property
    def residual(self):
        """The residual environment (what the lights did not take): (height, width, 3) float32
        numpy array (flat list without numpy), row 0 at the top. A copy, valid after close()."""
        if self._residual is None:
            h = self._handle()
            p = lib.envl_lights_residual(h)
            if not p:
                raise Error(6, "ENVL_ERR_MEMORY", "envl_lights_residual: out of memory")
            self._residual = _image(p, *self._wh)
        return self._residual

    def irradiance(self, normals):
        """Irradiance the lights (+ remainder) predict for (N, 3) normals -> (N, 3)."""
        n, buf = _vectors(normals)
        out = (c_double * (3 * n))()
        _check(lib.envl_lights_irradiance(self._handle(), n, buf, out))
        return _rows(out, n, 3)

    def save_residual(self, path, format=None, half=False):
        """Writes the residual environment (.hdr, .exr, .pfm), atomically."""
        r = self.residual
        w, h = self._wh
        save_image(path, r, w, h, format=format, half=half)


class SHResult(_Handle):
    """Real SH of a map: windowed radiance and irradiance coefficients ((order+1)^2, 3), the
    window factors, the summary with the artist forms (irradiance units)."""
    _free = "envl_sh_free"

    def __init__(self, handle):
        super().__init__(handle)
        s = _lib.SHSummary()
        _check(lib.envl_sh_get_summary(handle, byref(s)))
        self.order = s.order
        n = (s.order + 1) ** 2
        self.summary = {
            "order": s.order, "window": _str(lib.envl_window_name(s.window)),
            "window_width": s.window_width, "min_irradiance": s.min_irradiance,
            "diffuse_error": s.diffuse_error, "seconds": s.seconds,
            "ambient": _t(s.ambient),
            "deltas": {"x": _t(s.deltas[0]), "y": _t(s.deltas[1]), "z": _t(s.deltas[2])},
            "hemispheric": {"axis": _t(s.hemi_axis), "sky": _t(s.hemi_sky),
                            "ground": _t(s.hemi_ground)},
        }
        #: windowed radiance coefficients, ((order+1)^2, 3)
        self.radiance = _rows(lib.envl_sh_radiance(handle), n, 3)
        #: irradiance coefficients = A_l x radiance, ((order+1)^2, 3)
        self.irradiance = _rows(lib.envl_sh_irradiance(handle), n, 3)
        p = lib.envl_sh_window_factors(handle)
        self.window_factors = [p[i] for i in range(s.order + 1)] if p else None

    # the artist forms under the names the CLI's JSON uses
    @property
    def ambient_deltas(self):
        return {"ambient": self.summary["ambient"], **self.summary["deltas"]}

    @property
    def hemispheric(self):
        return self.summary["hemispheric"]

    def eval_radiance(self, directions):
        """Radiance of the (windowed) expansion in (N, 3) directions -> (N, 3)."""
        n, buf = _vectors(directions)
        out = (c_double * (3 * n))()
        _check(lib.envl_sh_eval_radiance(self._handle(), n, buf, out))
        return _rows(out, n, 3)

    def eval_irradiance(self, normals):
        """Irradiance of the (windowed) expansion for (N, 3) normals -> (N, 3)."""
        n, buf = _vectors(normals)
        out = (c_double * (3 * n))()
        _check(lib.envl_sh_eval_irradiance(self._handle(), n, buf, out))
        return _rows(out, n, 3)
