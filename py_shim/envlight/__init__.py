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
import contextlib
import ctypes
import math
import numbers
import threading
import warnings
from ctypes import byref, c_double, c_float, c_int32, c_void_p, pointer
from dataclasses import dataclass
from typing import Optional, Tuple

from . import _args as A
from . import _lib
from ._lib import ABI_VERSION, ArgumentError, Error, _check, _str, lib, library_path

try:
    import numpy as _np
except ImportError:  # pragma: no cover - numpy is optional
    _np = None

__all__ = ["Error", "ArgumentError", "Envmap", "LightsResult", "SHResult", "Light", "load", "sky",
           "from_pixels", "from_pixels_in_place", "save_image", "fibonacci_directions",
           "relative_rms_luminance", "sh_basis", "cosine_lobe", "brdf_lut", "brdf_eval",
           "Products", "version", "ABI_VERSION", "library_path", "has_numpy", "progress"]

__version__ = "0.1.0"
has_numpy = _np is not None

#: Fallback way to turn an rgb into a Blender sun (energy * color == rgb): see Light.blender_sun.
SUN_ENERGY_MODES = ("max", "luminance")


def version():
    """The library's version string."""
    return _str(lib.envl_version_string())


@contextlib.contextmanager
def progress(callback):
    """Within the block, the library's long calls made from this thread (prefilter, lights,
    export...) call callback(fraction, stage) between their steps, fraction rising from 0 to 1;
    a true return (or an exception in the callback) cancels the call, which then raises
    envlight.Error ENVL_ERR_CANCELLED having returned and written nothing. Not nested."""
    def trampoline(_user, fraction, stage):
        try:
            return 1 if callback(fraction, _str(stage)) else 0
        except Exception:  # noqa: BLE001 - a failing callback cancels the call
            return 1
    fn = _lib.PROGRESS_FN(trampoline)  # kept alive by this frame while the block runs
    lib.envl_set_progress(fn, None)
    try:
        yield
    finally:
        lib.envl_set_progress(_lib.PROGRESS_FN(), None)


# ---- small helpers -------------------------------------------------------------------------

# Every argument goes through _args (A) before it becomes a C value: see _args.py.

def _layout(value, what, lo=0):
    """A layout name or ENVL_LAYOUT_* (None: auto); lo=1 refuses 'auto'."""
    if value is None and lo == 0:
        return 0
    return A.enum(value, what, lib.envl_layout_from_name, lib.envl_layout_name, lo)


def _method(value, what):
    """A lights method by name or value; None: the library's default (fit, value 0)."""
    if value is None:
        return 0
    return A.enum(value, what, lib.envl_method_from_name, lib.envl_method_name)


def _vectors(values, what):
    """(N, 3) finite directions -> (count, ctypes double array)."""
    n, flat = A.vectors(values, what)
    if _np is not None:
        return n, (c_double * len(flat)).from_buffer_copy(_np.ascontiguousarray(flat).tobytes())
    return n, (c_double * len(flat))(*flat)


_FIT = lib.envl_method_from_name(b"fit")


def _count(value, method, what, none_ok=True, lo=1):
    """A number of lights for `method`: lo..32 for fit, else lo..2^24 (the library's limits);
    None (if none_ok) = the library's default."""
    hi = A.LIGHTS_MAX_FIT if method == _FIT else A.LIGHTS_MAX
    if not none_ok:
        return A.integer(value, what, lo, hi)
    return A.integer(value, what, lo, hi, 0, "the library's default: fit and sun 4, the cuts 16")


def _order(value, what, hi, none=None):
    """An SH order option: the order itself (0 asks for ENVL_ORDER_0, as the library's 0 is its
    default); None: `none` when given (ENVL_REMAINDER_NONE), else the default 2."""
    if value is None:
        return none if none is not None else 0
    v = A.integer(value, what, 0, hi)
    return v if v else _lib.ENVL_ORDER_0


def _threads(value, what):
    return A.integer(value, what, 1, A.INT32_MAX, 0, "all cores (the library uses at most 256)")


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


def _load_options(f, layout=None, width=None, rotate=0.0, max_pixels=None, strict=False,
                  apply_exposure=False, exr_part=None, threads=None, width_name="width"):
    """envl_load_options for function f (its name, for the messages)."""
    o = _lib.LoadOptions()
    o.layout = _layout(layout, f + ": layout")
    o.width = A.integer(width, "%s: %s" % (f, width_name), 1, A.INT32_MAX, 0,
                        "the source's own size")
    o.rotate_degrees = A.real(rotate, f + ": rotate", default=0.0, note="no rotation")
    o.max_pixels = A.integer(max_pixels, f + ": max_pixels", 1, A.INT64_MAX, 0,
                             "the library's 2^28")
    o.strict = A.flag(strict, f + ": strict")
    o.apply_exposure = A.flag(apply_exposure, f + ": apply_exposure")
    o.exr_part = A.text(exr_part, f + ": exr_part", None)
    o.threads = _threads(threads, f + ": threads")
    return o


# ---- constructors --------------------------------------------------------------------------

def load(path, layout="auto", rotate=0.0, width=None, strict=False, apply_exposure=False,
         exr_part=None, max_pixels=None, threads=None):
    """Loads an .hdr/.pic, .exr or .pfm file into the canonical lat-long frame.

    layout: 'auto', 'latlong', 'angular', 'mirrorball', 'cross', 'hcross', 'hstrip', 'vstrip',
    'exr-latlong', 'exr-cube' (or the ENVL_LAYOUT_* int); rotate: degrees about +Z
    (counter-clockwise seen from above); width: canonical map width (None = default);
    max_pixels: refuse larger files (None = 2^28); threads: None = all cores."""
    p = A.path(path, "load: path")
    o = _load_options("load", layout, width, rotate, max_pixels, strict, apply_exposure,
                      exr_part, threads)
    h = c_void_p()
    _check(lib.envl_envmap_load(p, byref(o), byref(h)))
    env = Envmap(h)
    env._source = p  # the file, which no output of its products may replace
    return env


def sky(sun_elevation=35.0, sun_azimuth=0.0, width=1024, sun_irradiance=None,
        zenith_radiance=None, ground_albedo=None):
    """The built-in procedural clear sky. sun_elevation in [-90, 90] degrees; width 1..23170
    (the map's pixels within the library's 2^28); sun_irradiance and zenith_radiance > 0,
    ground_albedo in (0, 1]; None: the library's default (35, 1024, 12, 0.6, 0.2)."""
    o = _lib.SkyOptions()
    o.sun_elevation_degrees = A.real(sun_elevation, "sky: sun_elevation", -90.0, 90.0,
                                     default=0.0, note="the default 35")
    o.sun_elevation_is_set = 0 if sun_elevation is None else 1
    o.sun_azimuth_degrees = A.real(sun_azimuth, "sky: sun_azimuth", default=0.0, note="0")
    o.width = A.integer(width, "sky: width", 1, A.SKY_MAX_WIDTH, 0, "the default 1024")
    o.sun_irradiance = A.real(sun_irradiance, "sky: sun_irradiance", above=0.0, default=0.0,
                              note="the default 12")
    o.zenith_radiance = A.real(zenith_radiance, "sky: zenith_radiance", above=0.0, default=0.0,
                               note="the default 0.6")
    o.ground_albedo = A.real(ground_albedo, "sky: ground_albedo", above=0.0, hi=1.0,
                             default=0.0, note="the default 0.2")
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
                rotate=0.0, map_width=None, strict=False, threads=None):
    """An envmap from float pixels in memory.

    buffer: a numpy array ((height, width, channels) shapes give the sizes) or any object with
    the buffer protocol holding float32 values (array.array('f'), bytes, memoryview), or a
    sequence of numbers. channels: 1, 3 or 4 (alpha ignored). Rows run top to bottom; pass
    flip=True for bottom-up pixels such as Blender's Image.pixels (RGBA, row 0 at the bottom).
    map_width: width of the canonical map (None = keep)."""
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
        raise ArgumentError("from_pixels: width, height and channels are needed for a flat "
                            "buffer")
    width = A.integer(width, "from_pixels: width", 1, A.INT32_MAX)
    height = A.integer(height, "from_pixels: height", 1, A.INT32_MAX)
    channels = A.integer(channels, "from_pixels: channels", -A.INT32_MAX - 1, A.INT32_MAX)
    flip = A.flag(flip, "from_pixels: flip")
    o = _load_options("from_pixels", layout, map_width, rotate, None, strict, False, None,
                      threads, "map_width")
    if channels not in (1, 3, 4):
        # the library names the problem; let it (ENVL_ERR_ARGUMENT) - but never read past the
        # buffer: pass a pointer to a small dummy
        dummy = (c_float * 4)()
        _check(lib.envl_envmap_from_pixels(dummy, width, height, channels, byref(o),
                                           byref(c_void_p())))
    keep, ptr = _float_buffer(buffer, width, height, channels, flip)
    h = c_void_p()
    _check(lib.envl_envmap_from_pixels(ptr, width, height, channels, byref(o), byref(h)))
    del keep
    return Envmap(h)


def from_pixels_in_place(fill, width, height, channels, flip=False, layout="auto", rotate=0.0,
                         map_width=None, strict=False, threads=None):
    """An envmap from pixels written straight into the library's memory, without a copy:
    fill(array) writes width x height x channels float32 values (row-major; rows top to
    bottom, or bottom-up with flip=True) into `array`, a flat float32 view of memory the
    library then takes as its map (e.g. Blender's image.pixels.foreach_get(array)): a numpy
    array, or a memoryview of format 'f' without numpy. The view must not be used once fill has
    returned. If fill raises, the memory is freed and the exception goes on. Otherwise as
    from_pixels: channels 1, 3 or 4 (alpha ignored), map_width the canonical map's width."""
    width = A.integer(width, "from_pixels_in_place: width", 1, A.INT32_MAX)
    height = A.integer(height, "from_pixels_in_place: height", 1, A.INT32_MAX)
    channels = A.integer(channels, "from_pixels_in_place: channels", -A.INT32_MAX - 1,
                         A.INT32_MAX)
    flip = A.flag(flip, "from_pixels_in_place: flip")
    o = _load_options("from_pixels_in_place", layout, map_width, rotate, None, strict, False,
                      None, threads, "map_width")
    mem = c_void_p()
    _check(lib.envl_pixels_alloc(width, height, channels, byref(o), byref(mem)))
    n = width * height * channels
    try:
        # format 'f', not ctypes' '<f', which Blender's foreach_get refuses
        floats = (c_float * n).from_address(mem.value)
        if _np is not None:
            view = _np.frombuffer(floats, dtype=_np.float32)
        else:
            view = memoryview(floats).cast("B").cast("f")
        fill(view)
        del view, floats
    except BaseException:
        lib.envl_pixels_free(mem)
        raise
    h = c_void_p()
    _check(lib.envl_envmap_adopt_pixels(mem, width, height, channels, int(flip), byref(o),
                                        byref(h)))
    return Envmap(h)


def save_image(path, rgb, width=None, height=None, format=None, half=False):
    """Writes RGB floats (row 0 at the top) as .hdr / .exr / .pfm (by extension or format),
    atomically. rgb: a (height, width, 3) numpy array or a flat float32 buffer/sequence."""
    if _np is not None and isinstance(rgb, _np.ndarray) and rgb.ndim == 3:
        height, width = rgb.shape[0], rgb.shape[1]
        if rgb.shape[2] != 3:
            raise ArgumentError("save_image: rgb has %d channels, 3 expected" % rgb.shape[2])
    if width is None or height is None:
        raise ArgumentError("save_image: width and height are needed for a flat buffer")
    width = A.integer(width, "save_image: width", 1, A.INT32_MAX)
    height = A.integer(height, "save_image: height", 1, A.INT32_MAX)
    p = A.path(path, "save_image: path")
    o = _save_options("save_image", format, half)
    keep, ptr = _float_buffer(rgb, width, height, 3, False)
    _check(lib.envl_image_save(p, ptr, width, height, byref(o)))
    if half:
        _half_warning("save_image: " + path, ptr, 3 * width * height)
    del keep


HALF_MAX = 65504.0  # ENVL_HALF_MAX: the largest finite IEEE half float


def _half_warning(what, ptr, n):
    """A file of half floats holds at most HALF_MAX: warns (HalfClampWarning) how many of the n
    floats at ptr go above it and how much lower the largest is written, as the command line
    says it on stderr."""
    if _np is not None:
        v = _np.abs(_np.ctypeslib.as_array(ptr, shape=(n,)))
        over = v > HALF_MAX
        count, largest = int(over.sum()), float(v[over].max()) if over.any() else 0.0
    else:
        big = [abs(x) for x in ptr[:n] if abs(x) > HALF_MAX]
        count, largest = len(big), max(big, default=0.0)
    if count:
        warnings.warn("%s: %d values above %g (the largest half float) written as %g: the "
                      "largest was %g (%.1f %% lower)" % (what, count, HALF_MAX, HALF_MAX,
                                                          largest,
                                                          100 * (1 - HALF_MAX / largest)),
                      HalfClampWarning, stacklevel=3)


class HalfClampWarning(UserWarning):
    """Values above the largest half float were written as it (save(..., half=True))."""


def _save_options(f, format, half):
    o = _lib.SaveOptions()
    o.pixel_type = _lib.ENVL_PIXEL_HALF if A.flag(half, f + ": half") else _lib.ENVL_PIXEL_FLOAT
    o.format = A.text(format, f + ": format", None)
    return o


def fibonacci_directions(n=_lib.ENVL_ERROR_NORMALS):
    """The n points of the Fibonacci sphere the error measure uses (n = 1024); n 1..2^24."""
    n = A.integer(n, "fibonacci_directions: n", 1, A.DIRECTIONS_MAX)
    d = (c_double * 3)()
    out = []
    for i in range(n):
        lib.envl_fibonacci_direction(i, n, d)
        out.append(tuple(d))
    return _np.array(out) if _np is not None else out


def relative_rms_luminance(approx_rgb, exact_rgb):
    """docs/design.md's error: sqrt(mean((Ya - Ye)^2)) / mean(|Ye|) over (N, 3) irradiances."""
    na, a = _vectors(approx_rgb, "relative_rms_luminance: approx_rgb")
    ne, e = _vectors(exact_rgb, "relative_rms_luminance: exact_rgb")
    if na != ne or na == 0:
        raise ArgumentError("relative_rms_luminance: approx_rgb has %d values and exact_rgb %d "
                            "(the same number, at least 1, expected)" % (na, ne))
    return lib.envl_relative_rms_luminance(na, a, e)


def sh_basis(order, direction):
    """Y_lm(direction) for l = 0..order (0..32), index l (l + 1) + m."""
    order = A.integer(order, "sh_basis: order", 0, A.SH_MAX_ORDER)
    d = A.triple(direction, "sh_basis: direction")
    n = (order + 1) ** 2
    y = (c_double * n)()
    lib.envl_sh_basis(order, (c_double * 3)(*d), y)
    return list(y)


def cosine_lobe(l):
    """A_l: irradiance coefficient = A_l x radiance coefficient (pi, 2 pi / 3, pi / 4, 0, ...)."""
    return lib.envl_sh_cosine_lobe(A.integer(l, "cosine_lobe: l", 0, A.INT32_MAX))


# ---- handles ---------------------------------------------------------------------------------

class _Handle:
    """A library object. Every call on it goes through _use(), which counts the calls running
    (the library may run for seconds, without the GIL): close() waits for those of other
    threads and refuses one of its own thread's (a progress callback inside the call), so the
    object is never freed under a running call (issue 30, 4.3: a use after free)."""
    _free = None

    def __init__(self, handle):
        self._h = handle
        self._calls = threading.Condition()
        self._running = {}  # thread id -> calls of that thread running on the object

    @property
    def closed(self):
        return self._h is None or not self._h.value

    @contextlib.contextmanager
    def _use(self):
        """The handle, for library calls within the block (ValueError when closed)."""
        me = threading.get_ident()
        with self._calls:
            if self.closed:
                raise ValueError("%s is closed" % type(self).__name__)
            self._running[me] = self._running.get(me, 0) + 1
        try:
            yield self._h
        finally:
            with self._calls:
                self._running[me] -= 1
                if not self._running[me]:
                    del self._running[me]
                self._calls.notify_all()

    def close(self):
        """Releases the library object now (idempotent). A call on it running in another
        thread is waited for; from within one of this thread's (its progress callback) closing
        is refused: ValueError (which, raised in the callback, cancels that call)."""
        with self._calls:
            if threading.get_ident() in self._running:
                raise ValueError("%s.close: a call on it is running in this thread (from its "
                                 "progress callback?): close it once the call has returned"
                                 % type(self).__name__)
            while self._running:
                self._calls.wait()
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
    radians, <= pi; rect: the region's pixel rectangle (x0, y0, x1, y1), x1 may pass the seam.
    take_direction, take_solid_angle, take_angle: the light as a lamp over the residual map
    (the direction of the first moment of what it took, and the disc about it; envlight.h's
    envl_light): the same as direction, solid_angle, angle but for 'fit', whose direction is
    where the fit aims (the best with its SH remainder)."""
    direction: Tuple[float, float, float]
    rgb: Tuple[float, float, float]
    solid_angle: float
    angle: float
    rect: Tuple[int, int, int, int]
    take_direction: Tuple[float, float, float]
    take_solid_angle: float
    take_angle: float

    @classmethod
    def _of(cls, c):
        """From an envl_light structure."""
        return cls(_t(c.direction), _t(c.rgb), c.solid_angle, c.angle, _t(c.rect),
                   _t(c.take_direction), c.take_solid_angle, c.take_angle)

    def over_residual(self):
        """(direction, rgb): the delta light that stands for this one over the residual map
        (envl_light_over_residual): along take_direction, rgb (1 - take_solid_angle / 4 pi); a
        disc lamp of take_angle (a Blender sun) takes that rgb at normal incidence."""
        d, rgb = (c_double * 3)(), (c_double * 3)()
        c = _lib.Light(self.direction, self.rgb, self.solid_angle, self.angle, self.rect,
                       self.take_direction, self.take_solid_angle, self.take_angle)
        lib.envl_light_over_residual(byref(c), d, rgb)
        return _t(d), _t(rgb)

    def blender_sun(self, mode="max"):
        """(energy, color) of a Blender sun lamp with energy * color == rgb (docs/design.md).
        mode 'max': energy = the largest channel, colour <= 1; 'luminance': energy = Y."""
        if mode not in SUN_ENERGY_MODES:
            raise ArgumentError("Light.blender_sun: unknown mode %r (%s)"
                                % (mode, ", ".join(SUN_ENERGY_MODES)))
        r, g, b = self.rgb
        e = max(r, g, b) if mode == "max" else lib.envl_luminance(r, g, b)
        if e <= 0:
            return 0.0, (1.0, 1.0, 1.0)
        return e, (r / e, g / e, b / e)

    def as_dict(self):
        return {"direction": list(self.direction), "rgb": list(self.rgb),
                "solid_angle": self.solid_angle, "angle": self.angle, "rect": list(self.rect),
                "take_direction": list(self.take_direction),
                "take_solid_angle": self.take_solid_angle, "take_angle": self.take_angle}


class Envmap(_Handle):
    """The canonical lat-long map (float RGB, row 0 at the top) with its cached tables."""
    _free = "envl_envmap_free"
    _source = None  # the file it was loaded from (bytes), None for pixels and the sky

    @property
    def width(self):
        with self._use() as h:
            return lib.envl_envmap_width(h)

    @property
    def height(self):
        with self._use() as h:
            return lib.envl_envmap_height(h)

    def info(self):
        """What was read and what the map holds, as a dict (envl_info's fields)."""
        i = _lib.Info()
        with self._use() as h:
            _check(lib.envl_envmap_info(h, byref(i)))
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
            "negative_min": i.negative_min, "signed_power": _t(i.signed_power),
            "filled_energy": _t(i.filled_energy), "added_energy": _t(i.added_energy),
            "unfilled_values": i.unfilled_values, "fill_window": i.fill_window,
            "infinity_value": i.infinity_value,
        }

    def pixels(self, first_row=0, end_row=None):
        """A copy of the map: (height, width, 3) float32 numpy array (flat list without numpy);
        rows first_row .. end_row - 1 only (end_row None: to the last), e.g. a band of a map
        too large to copy whole."""
        with self._use() as h:
            w, height = lib.envl_envmap_width(h), lib.envl_envmap_height(h)
            r0 = A.integer(first_row, "Envmap.pixels: first_row", 0, height)
            r1 = A.integer(end_row, "Envmap.pixels: end_row", r0, height, height,
                           "the last row")
            p = ctypes.cast(ctypes.addressof(lib.envl_envmap_pixels(h).contents) +
                            ctypes.sizeof(c_float) * 3 * w * r0, ctypes.POINTER(c_float))
            return _image(p, w, r1 - r0)

    def solid_angle(self, row):
        """Solid angle of a pixel of row 0..height-1 (sr)."""
        with self._use() as h:
            row = A.integer(row, "Envmap.solid_angle: row", 0, lib.envl_envmap_height(h) - 1)
            return lib.envl_envmap_solid_angle(h, row)

    def direction(self, column, row):
        """Unit direction of the centre of pixel (column 0..width-1, row 0..height-1)."""
        with self._use() as h:
            column = A.integer(column, "Envmap.direction: column", 0,
                               lib.envl_envmap_width(h) - 1)
            row = A.integer(row, "Envmap.direction: row", 0, lib.envl_envmap_height(h) - 1)
            d = (c_double * 3)()
            lib.envl_envmap_direction(h, column, row, d)
            return tuple(d)

    def pixel_of(self, direction):
        """Continuous (column, row) of a direction in this map."""
        d = A.triple(direction, "Envmap.pixel_of: direction")
        c, r = c_double(), c_double()
        lib.envl_latlong_pixel(self.width, self.height, (c_double * 3)(*d), byref(c),
                               byref(r))
        return c.value, r.value

    def irradiance(self, normals):
        """Exact irradiance E(n) = sum L dw max(0, n.d) for (N, 3) normals -> (N, 3)."""
        n, buf = _vectors(normals, "Envmap.irradiance: normals")
        out = (c_double * (3 * n))()
        with self._use() as h:
            _check(lib.envl_irradiance_exact(h, n, buf, out))
        return _rows(out, n, 3)

    def reference_irradiance(self):
        """Exact irradiance at the error measure's 1024 Fibonacci normals (cached)."""
        p = ctypes.POINTER(c_double)()
        with self._use() as h:
            _check(lib.envl_envmap_reference_irradiance(h, byref(p)))
            return _rows(p, _lib.ENVL_ERROR_NORMALS, 3)

    def drop_caches(self, which=_lib.ENVL_CACHE_SAT | _lib.ENVL_CACHE_REFERENCE):
        """Drops the cached tables: which = ENVL_CACHE_SAT | ENVL_CACHE_REFERENCE bits (0..3)."""
        which = A.integer(which, "Envmap.drop_caches: which", 0,
                          _lib.ENVL_CACHE_SAT | _lib.ENVL_CACHE_REFERENCE)
        with self._use() as h:
            lib.envl_envmap_drop_caches(h, which)

    def save(self, path, format=None, half=False):
        """Writes the canonical map (.hdr, .exr, .pfm by extension or format), atomically; never
        over the file it was loaded from. half: a HalfClampWarning says what went above 65504."""
        p = A.path(path, "Envmap.save: path")
        o = _save_options("Envmap.save", format, half)
        with self._use() as h:
            _check(lib.envl_envmap_save(h, p, byref(o)))
            if half:
                _half_warning("Envmap.save: " + path, lib.envl_envmap_pixels(h),
                              3 * lib.envl_envmap_width(h) * lib.envl_envmap_height(h))

    def ground_plane(self, albedo):
        """The map as a scene on a ground plane (canonical z = 0) of this albedo sees it: a new
        Envmap whose lower hemisphere is the plane's radiance albedo E_up / pi (E_up: the exact
        irradiance at +Z), and that radiance (rgb). -> (Envmap, [r, g, b])"""
        albedo = A.real(albedo, "Envmap.ground_plane: albedo", 0.0, 1.0)
        g, rgb = c_void_p(), (c_double * 3)()
        with self._use() as h:
            _check(lib.envl_ground_plane_map(h, albedo, 0, byref(g), rgb))
        return Envmap(g), list(rgb)

    def sky_hemisphere(self):
        """A new Envmap with the lower hemisphere black (the sky over a ground plane)."""
        g = c_void_p()
        with self._use() as h:
            _check(lib.envl_sky_hemisphere_map(h, 0, byref(g)))
        return Envmap(g)

    def to_layout(self, layout, size):
        """The map rendered into another layout (not 'auto') -> (height, width, 3) array (or
        flat list). size: face size for cubes and strips, diameter for probes, lat-long width."""
        layout = _layout(layout, "Envmap.to_layout: layout", lo=1)
        size = A.integer(size, "Envmap.to_layout: size", 1, A.INT32_MAX)
        p = ctypes.POINTER(c_float)()
        w, h = c_int32(), c_int32()
        with self._use() as m:
            _check(lib.envl_envmap_to_layout(m, layout, size, byref(p), byref(w), byref(h)))
        try:
            return _image(p, w.value, h.value)
        finally:
            lib.envl_free(p)

    def lights(self, n=None, method=None, order=2, measure=True, residual=True):
        """Directional lights standing in for the map.

        n: number of lights, 1..32 for fit, else 1..2^24 (None = the library's default: fit 4,
        median and variance 16; sun: at most n, 4); method: 'fit' (None: the library's default,
        fit, as everywhere), 'median', 'variance' or 'sun' (the suns split off
        exactly; the residual is the map less their excess); order: fit's SH remainder order
        (0..8), None for lights only (ignored by the cuts and sun); measure: also measure the
        diffuse error (summary["diffuse_error"]; None when False); residual: keep the residual map
        (fit, sun: False keeps none, the same lights for half the memory; .residual then
        raises).
        Returns a LightsResult (a context manager)."""
        o = _lib.LightsOptions()
        o.method = _method(method, "Envmap.lights: method")
        o.count = _count(n, o.method, "Envmap.lights: n")
        o.remainder_order = _order(order, "Envmap.lights: order", A.REMAINDER_MAX_ORDER,
                                   none=_lib.ENVL_REMAINDER_NONE)
        o.measure = 1 if A.flag(measure, "Envmap.lights: measure") else 0
        o.skip_residual = 0 if A.flag(residual, "Envmap.lights: residual") else 1
        h = c_void_p()
        with self._use() as m:
            _check(lib.envl_lights_compute(m, byref(o), byref(h)))
            # the residual has the map's size (the lights object does not export it)
            size = lib.envl_envmap_width(m), lib.envl_envmap_height(m)
        return LightsResult(h, *size, kept=not o.skip_residual, source=self._source, envmap=self)

    def gltf(self, path, size=256, mips=None, lights="sun", n=None, measure=True):
        """Writes a glTF 2.0 file (.glb or .gltf), as `envlight gltf`: the suns (lights: 'sun',
        or 'fit', 'median', 'variance', None for none) as KHR_lights_punctual directional
        lights and the rest as the scene's EXT_lights_image_based light (SH irradiance, GGX
        mips as RGBD cube faces of size >> k, a power of two; mips None: down to 16 x 16).
        Returns the summary as a dict (errors None when measure is False)."""
        p = A.path(path, "Envmap.gltf: path")
        o = _lib.GltfOptions()
        o.face_size = A.integer(size, "Envmap.gltf: size", 16, 4096)
        o.mips = 0 if mips is None else A.integer(mips, "Envmap.gltf: mips", 2, 13)
        lo = _lib.LightsOptions()
        if lights is None:
            o.no_lights = 1
        else:
            lo.method = _method(lights, "Envmap.gltf: lights")
            lo.count = _count(n, lo.method, "Envmap.gltf: n")
        o.lights = pointer(lo)
        o.measure = 1 if A.flag(measure, "Envmap.gltf: measure") else 0
        s = _lib.GltfSummary()
        with self._use() as h:
            _check(lib.envl_gltf_export(h, p, byref(o), byref(s)))
        measured = s.diffuse_error >= 0
        return {"lights": s.lights, "face_size": s.face_size, "mips": s.mips,
                "intensity": s.intensity,
                "diffuse_error": s.diffuse_error if measured else None,
                "glossy_error": [e if e >= 0 else None for e in s.glossy_error[:s.mips]],
                "texel_error": [_texel_dict(t) for t in s.texel_error[:s.mips]],
                "rgbd_error": s.rgbd_error, "bytes": s.bytes,
                "seconds": s.seconds,
                "prefiltered_size": (s.prefiltered_width, s.prefiltered_height)}

    def sh(self, order=2, window="auto", measure=True):
        """Real SH projection of the map (order 0..32; window 'auto', the default as in
        `envlight sh`: the least windowing that keeps the irradiance non-negative in every
        channel; 'none' (can go negative: summary["min_irradiance"] says), 'hann', 'lanczos');
        measure: also measure the diffuse error (summary["diffuse_error"]; None when False).
        Returns an SHResult (a context manager)."""
        o = _lib.SHOptions()
        o.order = _order(A.integer(order, "Envmap.sh: order", 0, A.SH_MAX_ORDER),
                         "Envmap.sh: order", A.SH_MAX_ORDER)
        o.window = A.enum(window, "Envmap.sh: window", lib.envl_window_from_name,
                          lib.envl_window_name)
        o.measure = 1 if A.flag(measure, "Envmap.sh: measure") else 0
        h = c_void_p()
        with self._use() as m:
            _check(lib.envl_sh_compute(m, byref(o), byref(h)))
        return SHResult(h)

    def pov_include(self, path=None, recipe=None, scene=None, ground=None, method=None,
                    n=None, order=None, ambient=None, shadows="auto", sky=False,
                    sky_residual=False, sky_image=None, scene_radius=None, exposure=None,
                    place=True, source=None, command=None, threads=None):
        """A POV-Ray 3.7 include for povray_include/envlight.inc (envl_pov_include_write: what
        `envlight pov` writes, README "POV-Ray: an include for your scene"), written atomically to `path`, or returned as
        text when path is None.

        recipe: 'auto' (from the scene; method, n, order, ambient adjust the recipe picked),
        'dome', 'dome-ambient', 'sh', 'image-radiosity' or 'custom' (method, n, order, ambient
        as given); None: 'custom' when one of those is given, else 'auto' (as `envlight pov`
        without --recipe);
        scene: the .pov file the include is for (what it uses picks the recipe and the ground);
        ground: the albedo 0..1 of a ground plane (None: the scene's, if any); method: 'fit',
        'median' or 'variance'; n: lights 1..65536 (fit 1..32); order: the ambient's SH order
        -1..8; ambient: 'sh', 'hemi' or 'none'; shadows: 'auto' (a dome's soft, others hard),
        'soft', 'hard' or 'none'; sky: declare
        the sky (sky_residual: the residual as the sky), its image written to sky_image (None:
        next to the include, or the map's own lat-long .hdr); scene_radius > 0; exposure: 'auto'
        or > 0 (None: not declared); place: False only declares; source: the map's name in the
        include (None: its file); command: the header's command line; a None is the library's
        default. Returns a dict of envl_pov_result: recipe (name), reason, method, count,
        ambient, ambient_order, ambient_terms, ambient_least, ambient_negative, bounce, ground
        (albedo, None without a plane), ground_radiance, diffuse_error, exposure_auto, seconds,
        no_light, sky_file, text (None when written to path) and warnings (a list of lines)."""
        f = "Envmap.pov_include"
        o = _lib.PovOptions()
        if recipe is not None:
            o.recipe = A.enum(recipe, f + ": recipe", lib.envl_pov_recipe_from_name,
                              lib.envl_pov_recipe_name)
            o.recipe_is_set = 1
        keep = []  # the bytes the C strings point into, alive until the call returns
        if scene is not None:
            keep.append(A.path(scene, f + ": scene"))
            o.scene_path = keep[-1]
        if method is not None:
            o.method = _method(method, f + ": method")
            if o.method not in (_FIT, lib.envl_method_from_name(b"median"),
                                lib.envl_method_from_name(b"variance")):
                raise ArgumentError("%s: method %r: fit, median or variance" % (f, method))
            o.method_is_set = 1
        o.count = A.integer(n, f + ": n", 1, 1 << 16, 0, "the recipe's")
        if order is not None:  # -1: a fit without remainder
            v = A.integer(order, f + ": order", -1, _lib.ENVL_POV_MAX_ORDER)
            o.order = _lib.ENVL_REMAINDER_NONE if v < 0 else _order(v, f + ": order", v)
        o.ambient = _choice(ambient, f + ": ambient", _lib.ENVL_POV_AMBIENT, 0)
        o.shadows = _choice(shadows, f + ": shadows", _lib.ENVL_POV_SHADOWS, 0)
        if ground is not None:
            o.ground_albedo = A.real(ground, f + ": ground", 0.0, 1.0)
            o.ground_plane = 1
        o.sky = A.flag(sky, f + ": sky")
        o.sky_residual = A.flag(sky_residual, f + ": sky_residual")
        if sky_image is not None:
            keep.append(A.path(sky_image, f + ": sky_image"))
            o.sky_image = keep[-1]
        o.scene_radius = A.real(scene_radius, f + ": scene_radius", above=0.0, hi=1e12,
                                default=0.0, note="the default 100")
        if isinstance(exposure, str) and exposure == "auto":
            o.exposure = _lib.ENVL_POV_EXPOSURE_AUTO
        else:
            o.exposure = A.real(exposure, f + ": exposure", above=0.0, hi=1e12, default=0.0,
                                note="not declared")
        o.no_place = 0 if A.flag(place, f + ": place") else 1
        o.source = A.text(source, f + ": source", None)
        o.command = A.text(command, f + ": command", None)
        o.threads = _threads(threads, f + ": threads")
        out = A.path(path, f + ": path") if path is not None else None
        res = _lib.PovResult()
        with self._use() as h:
            rc = lib.envl_pov_include_write(h, byref(o), out, byref(res))
        try:
            _check(rc)
            return _pov_result(res)
        finally:
            lib.envl_pov_result_free(byref(res))


    @staticmethod
    def _prefilter_options(f, levels=None, width=None, min_width=None, samples=None,
                           unfiltered=False, irradiance_method="resampled",
                           irradiance_width=None, irradiance_order=2, threads=None,
                           sun_lights=False, half=False, layout="latlong"):
        """envl_prefilter_options for function f; None = the library's default (envlight.h, docs/design.md).
        layout: the texels the maps are computed at, 'latlong' (also 'atlas') or 'cube' (also
        'cross': faces of width / 4, each texel at its centre, as an (F, 6 F, 3) strip)."""
        o = _lib.PrefilterOptions()
        o.levels = A.integer(levels, f + ": levels", 1, A.PREFILTER_MAX_LEVELS, 0, "the default 6")
        o.width = A.integer(width, f + ": width", 2, A.PREFILTER_MAX_WIDTH, 0, "the default 512")
        o.min_width = A.integer(min_width, f + ": min_width", 2, A.INT32_MAX, 0, "the default 64")
        o.samples = A.integer(samples, f + ": samples", 1, A.PREFILTER_MAX_SAMPLES, 0, "the default 64")
        o.unfiltered = A.flag(unfiltered, f + ": unfiltered")
        o.irradiance_method = A.enum(irradiance_method, f + ": irradiance_method",
                                     lib.envl_irradiance_method_from_name,
                                     lib.envl_irradiance_method_name)
        o.irradiance_width = A.integer(irradiance_width, f + ": irradiance_width", 2,
                                       A.PREFILTER_MAX_WIDTH, 0, "the default 64")
        o.irradiance_order = _order(irradiance_order, f + ": irradiance_order", A.SH_MAX_ORDER)
        o.threads = _threads(threads, f + ": threads")
        o.sun_lights = A.flag(sun_lights, f + ": sun_lights")
        o.half = A.flag(half, f + ": half")
        o.layout = A.enum(layout, f + ": layout", lib.envl_export_layout_from_name,
                          lib.envl_export_layout_name)
        return o

    def prefilter(self, roughness=None, chain=False, mirror=False, irradiance=False,
                  diffuse=False, brdf=False, measure=False, sh_order=2, brdf_size=None,
                  multiscatter=False, shadows=0, shadows_method=None, **options):
        """Prefiltered maps (one envl_compute request; only what is asked is computed):
        roughness: GGX roughness values (one specular level each); chain: all K levels
        (options: levels, width, min_width, samples, unfiltered, irradiance_method
        'resampled'|'sh'|'exact', irradiance_width, irradiance_order, threads, sun_lights: the
        sun as lights, left out of the irradiance map and glossy levels; half: measured as
        half floats hold them, for export(format='ktx2')); mirror: the
        roughness-0 level; irradiance: an irradiance map; diffuse: SH irradiance of sh_order;
        brdf: the split-sum table; shadows: that many lights for shadows (shadows_method
        'fit' (None: the default)|'median'|'variance'|'sun'; 0: none); measure: also the glossy /
        diffuse errors (slow). sh_order 0..32, brdf_size 1..4096; a None option is the library's
        default (see
        _prefilter_options). Returns Products (a context manager)."""
        f = "Envmap.prefilter"
        req = _lib.Request()
        if roughness is None:
            roughness = []
        elif isinstance(roughness, (numbers.Number, str, bytes)):
            raise TypeError("%s: roughness must be a sequence of numbers (one level each), "
                            "not %s" % (f, type(roughness).__name__))
        rough = [A.real(r, f + ": roughness", 0.0, 1.0) for r in roughness]
        keep = (c_double * max(1, len(rough)))(*rough)
        req.n_roughness = A.integer(len(rough), f + ": len(roughness)", 0, A.INT32_MAX)
        req.roughness = keep
        req.specular_chain = A.flag(chain, f + ": chain")
        req.mirror = A.flag(mirror, f + ": mirror")
        req.irradiance_map = A.flag(irradiance, f + ": irradiance")
        req.diffuse = A.flag(diffuse, f + ": diffuse")
        req.brdf_lut = A.flag(brdf, f + ": brdf")
        req.measure = A.flag(measure, f + ": measure")
        req.sh_order = _order(sh_order, f + ": sh_order", A.SH_MAX_ORDER)
        req.prefilter = self._prefilter_options(f, **options)
        req.lights.method = _method(shadows_method, f + ": shadows_method")
        # shadows: 0 is a real value (no lights), so no None here
        req.lights.count = _count(shadows, req.lights.method, f + ": shadows", False, lo=0)
        req.shadows = 1 if req.lights.count else 0
        req.brdf.size = A.integer(brdf_size, f + ": brdf_size", 1, A.BRDF_MAX_SIZE, 0, "the default 128")
        req.brdf.multiscatter = A.flag(multiscatter, f + ": multiscatter")
        h = c_void_p()
        with self._use() as m:
            _check(lib.envl_compute(m, byref(req), byref(h)))
        return Products(h)

    def specular(self, roughness, width=None, **options):
        """One prefiltered GGX specular level (roughness 0..1; width 2..65536, None: by the
        options' mapping) -> ((height, width, 3) array, stats dict)."""
        f = "Envmap.specular"
        roughness = A.real(roughness, f + ": roughness", 0.0, 1.0)
        width = A.integer(width, f + ": width", 2, A.PREFILTER_MAX_WIDTH, 0,
                          "by the options' mapping")
        o = self._prefilter_options(f, **options)
        p = ctypes.POINTER(c_float)()
        st = _lib.Level()
        with self._use() as h:
            _check(lib.envl_prefilter_specular(h, roughness, width, byref(o), byref(p),
                                               byref(st)))
        try:
            return _image(p, st.width, st.height), _level_dict(st, with_rgb=False)
        finally:
            lib.envl_free(p)


def _choice(value, what, table, default):
    """A name of `table` (None: default) -> its value."""
    if value is None:
        return default
    if not isinstance(value, str):
        raise TypeError("%s must be a name (%s), not %s"
                        % (what, ", ".join(table), type(value).__name__))
    if value not in table:
        func, _, arg = what.rpartition(": ")
        raise ArgumentError("%s: unknown %s %r (%s)" % (func, arg, value, ", ".join(table)))
    return table[value]


def _pov_result(r):
    """envl_pov_result -> dict (names for the enums)."""
    ambient = {v: k for k, v in _lib.ENVL_POV_AMBIENT.items()}
    return {
        "recipe": _str(lib.envl_pov_recipe_name(r.recipe)), "reason": _str(r.reason),
        "method": _str(lib.envl_method_name(r.method)), "count": r.count,
        "ambient": ambient.get(r.ambient, "none"), "ambient_order": r.ambient_order,
        "ambient_terms": r.ambient_terms, "ambient_least": r.ambient_least,
        "ambient_negative": r.ambient_negative, "bounce": bool(r.bounce),
        "ground": r.ground_albedo if r.ground_plane else None,
        "ground_radiance": _t(r.ground_radiance), "diffuse_error": r.diffuse_error,
        "exposure_auto": r.exposure_auto, "seconds": r.seconds, "no_light": bool(r.no_light),
        # a file name's bytes kept as os.fsdecode keeps them
        "sky_file": r.sky_file.decode("utf-8", "surrogateescape") if r.sky_file else None,
        "text": r.text.decode("utf-8", "surrogateescape") if r.text is not None else None,
        "warnings": _str(r.warnings).splitlines() if r.warnings else [],
    }


def _texel_dict(t):
    """An envl_texel_error as a dict (rms, worst: None when not measured)."""
    measured = t.rms >= 0 and t.worst >= 0
    return {"rms": t.rms if measured else None, "worst": t.worst if measured else None,
            "worst_direction": _t(t.worst_direction) if measured else None,
            "texels_measured": t.measured, "texels": t.texels}


def _layout_name(layout):
    """'latlong' or 'hstrip' (six cube faces side by side) of an envl_level.layout."""
    return _str(lib.envl_layout_name(layout))


def _level_dict(st, with_rgb=True):
    d = {"roughness": st.roughness, "alpha": st.alpha, "width": st.width, "height": st.height,
         "layout": _layout_name(st.layout),
         "samples": st.samples, "filtered": bool(st.filtered), "energy_scale": st.energy_scale,
         "glossy_error": st.glossy_error if st.glossy_error >= 0 else None,
         "texel_error": _texel_dict(st.texel_error), "seconds": st.seconds}
    if with_rgb:
        d["rgb"] = _image(st.rgb, st.width, st.height)
    return d


def brdf_lut(size=None, samples=None, multiscatter=False, threads=None):
    """The split-sum BRDF table: (size, size, 2) float32 array (row j = roughness (j+0.5)/S,
    column i = NoV (i+0.5)/S); channels (A, B), or (DFG1, DFG2) with multiscatter.
    size 1..4096 (None: 128), samples 1..2^24 (None: 4096)."""
    o = _lib.BrdfOptions()
    o.size = A.integer(size, "brdf_lut: size", 1, A.BRDF_MAX_SIZE, 0, "the default 128")
    o.samples = A.integer(samples, "brdf_lut: samples", 1, A.BRDF_MAX_SAMPLES, 0, "the default 4096")
    o.multiscatter = A.flag(multiscatter, "brdf_lut: multiscatter")
    o.threads = _threads(threads, "brdf_lut: threads")
    p = ctypes.POINTER(c_float)()
    n = c_int32()
    _check(lib.envl_brdf_lut(byref(o), byref(p), byref(n)))
    try:
        return _rows(p, n.value * n.value, 2, "float32").reshape(n.value, n.value, 2) \
            if _np is not None else list(p[:n.value * n.value * 2])
    finally:
        lib.envl_free(p)


def brdf_eval(nov, roughness, samples=None):
    """Single-scatter (A, B) of the split sum at (NoV, roughness), both in [0, 1]; samples
    1..2^24 (None: 4096)."""
    nov = A.real(nov, "brdf_eval: nov", 0.0, 1.0)
    roughness = A.real(roughness, "brdf_eval: roughness", 0.0, 1.0)
    samples = A.integer(samples, "brdf_eval: samples", 1, A.BRDF_MAX_SAMPLES, 0, "the default 4096")
    ab = (c_double * 2)()
    _check(lib.envl_brdf_eval(nov, roughness, samples, ab))
    return ab[0], ab[1]


def _target_width_dict(w, layout):
    """An envl_width_estimate as prefilter.json's target_width (figures None unless found or
    beyond): width, height of the level's image there (six faces side by side, or lat-long)."""
    state = ("not estimated", "met", "found", "beyond")[w.state if 0 <= w.state < 4 else 0]
    has = state in ("found", "beyond")
    faces = _layout_name(layout) == "hstrip"
    return {"target": 0.01, "state": state,
            "width": (6 * w.width if faces else w.width) if has else None,
            "height": (w.width if faces else w.width // 2) if has else None,
            "prefilter_width": w.size if has else None,
            "glossy_error": w.glossy_error if has else None,
            "seconds_estimated": w.seconds if has else None, "widths_tried": w.widths_tried,
            "directions_read": w.directions_read, "seconds_spent": w.seconds_spent}


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
        st, wt = _lib.Level(), _lib.WidthEstimate()
        for i in range(lib.envl_products_level_count(handle)):
            _check(lib.envl_products_level(handle, i, byref(st)))
            _check(lib.envl_products_level_width(handle, i, byref(wt)))
            self.levels.append(_level_dict(st))
            #: the width for 1 % glossy error (docs/design.md, "Level width for 1 %")
            self.levels[-1]["target_width"] = _target_width_dict(wt, st.layout)
        im = _lib.IrradianceMap()
        self.irradiance = None
        if s.irradiance_maps and lib.envl_products_irradiance(handle, byref(im)) == 0:
            self.irradiance = {"method": _str(lib.envl_irradiance_method_name(im.method)),
                               "width": im.width, "height": im.height,
                               "layout": _layout_name(im.layout),
                               "rgb": _image(im.rgb, im.width, im.height),
                               "diffuse_error": im.diffuse_error if im.diffuse_error >= 0
                               else None, "texel_error": _texel_dict(im.texel_error),
                               "seconds": im.seconds}
        shp = lib.envl_products_sh(handle)
        self.sh_irradiance = None
        if shp:
            sm = _lib.SHSummary()
            _check(lib.envl_sh_get_summary(shp, byref(sm)))
            self.sh_irradiance = _rows(lib.envl_sh_irradiance(shp), (sm.order + 1) ** 2, 3)
        n_sun = c_int32()
        sp = lib.envl_products_sun_lights(handle, byref(n_sun))
        #: with sun_lights: the split-off sun as a list of Light (rect unused), else []
        self.sun_lights = [Light._of(sp[i]) for i in range(n_sun.value)]
        size, ms = c_int32(), c_int32()
        bp = lib.envl_products_brdf(handle, byref(size), byref(ms))
        self.brdf = None
        if bp:
            n = size.value
            self.brdf = _rows(bp, n * n, 2, "float32")
            if _np is not None:
                self.brdf = self.brdf.reshape(n, n, 2)

    def find_level(self, roughness):
        """The level of exactly this roughness (0..1), or None."""
        roughness = A.real(roughness, "Products.find_level: roughness", 0.0, 1.0)
        with self._use() as h:
            i = lib.envl_products_find_level(h, roughness)
        return self.levels[i] if i >= 0 else None

    def export(self, directory, format="exr", layout="latlong", frame="blender"):
        """Writes the products into `directory` (with prefilter.json), all-or-nothing. frame:
        'blender' (+Z up) or 'gltf' (+Y up; cube faces in OpenGL's order and orientation)."""
        d = A.path(directory, "Products.export: directory")
        o = _lib.ExportOptions()
        o.format = A.text(format, "Products.export: format", None)
        o.layout = A.enum(layout, "Products.export: layout", lib.envl_export_layout_from_name,
                          lib.envl_export_layout_name)
        o.frame = A.enum(frame, "Products.export: frame", lib.envl_frame_from_name,
                         lib.envl_frame_name)
        with self._use() as h:
            _check(lib.envl_products_export(h, d, byref(o)))


class LightsResult(_Handle):
    """Lights, their summary, the fit remainder and the residual environment."""
    _free = "envl_lights_free"

    def __init__(self, handle, width, height, kept=True, source=None, envmap=None):
        super().__init__(handle)
        self._wh = (width, height)
        self._kept = kept
        self._envmap = envmap  # the Envmap they were computed from (residual_map reads it)
        self._source = source  # the map's file (bytes) or None: save_residual never replaces it
        s = _lib.LightsSummary()
        _check(lib.envl_lights_get_summary(handle, byref(s)))
        self.summary = {
            "method": _str(lib.envl_method_name(s.method)), "count": s.count,
            "power": _t(s.power), "lights_power": _t(s.lights_power),
            "residual_power": _t(s.residual_power),
            "remainder_order": s.remainder_order if s.remainder_order >= 0 else None,
            "diffuse_error": s.diffuse_error if s.diffuse_error >= 0 else None,
            "seconds": s.seconds, "no_light": bool(s.no_light),
        }
        lights = []
        one = _lib.Light()
        for i in range(lib.envl_lights_count(handle)):
            _check(lib.envl_lights_get(handle, i, byref(one)))
            lights.append(Light._of(one))
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
            if not self._kept:
                raise ArgumentError("LightsResult.residual: none was kept (lights(residual=False))")
            with self._use() as h:
                p = lib.envl_lights_residual(h)
                if not p:
                    raise Error(6, "ENVL_ERR_MEMORY", "envl_lights_residual: out of memory")
                self._residual = _image(p, *self._wh)
        return self._residual

    def residual_map(self, width=None):
        """The residual environment as an Envmap of its own, area-resampled to `width` wide
        (the integral of L dw kept per pixel; None or at least the map's width: full size, a
        copy), made in the library without a numpy copy: the sun method's from the map (still
        open) and the suns' pixels (lights(residual=False) will do), the others' from their
        kept residual."""
        f = "LightsResult.residual_map"
        w = 0 if width is None else A.integer(width, f + ": width", 1, A.INT32_MAX)
        if self._envmap is None:
            raise ArgumentError(f + ": these lights were not computed by Envmap.lights")
        g = c_void_p()
        with self._envmap._use() as m, self._use() as h:
            _check(lib.envl_lights_residual_map(m, h, w, byref(g)))
        return Envmap(g)

    def irradiance(self, normals):
        """Irradiance the lights (+ remainder) predict for (N, 3) normals -> (N, 3)."""
        n, buf = _vectors(normals, "LightsResult.irradiance: normals")
        out = (c_double * (3 * n))()
        with self._use() as h:
            _check(lib.envl_lights_irradiance(h, n, buf, out))
        return _rows(out, n, 3)

    def save_residual(self, path, format=None, half=False):
        """Writes the residual environment (.hdr, .exr, .pfm), atomically; never over the map's
        own file (ArgumentError). half: a HalfClampWarning says what went above 65504."""
        f = "LightsResult.save_residual"
        p = A.path(path, f + ": path")
        o = _save_options(f, format, half)
        if self._source:  # never the map's own file (envl_outputs_check)
            _check(lib.envl_outputs_check((ctypes.c_char_p * 1)(self._source), 1,
                                          (ctypes.c_char_p * 1)(p), 1))
        keep, ptr = _float_buffer(self.residual, self._wh[0], self._wh[1], 3, False)
        _check(lib.envl_image_save(p, ptr, self._wh[0], self._wh[1], byref(o)))
        if half:
            _half_warning(f + ": " + path, ptr, 3 * self._wh[0] * self._wh[1])
        del keep


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
            "diffuse_error": s.diffuse_error if s.diffuse_error >= 0 else None,
            "seconds": s.seconds,
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
        n, buf = _vectors(directions, "SHResult.eval_radiance: directions")
        out = (c_double * (3 * n))()
        with self._use() as h:
            _check(lib.envl_sh_eval_radiance(h, n, buf, out))
        return _rows(out, n, 3)

    def eval_irradiance(self, normals):
        """Irradiance of the (windowed) expansion for (N, 3) normals -> (N, 3)."""
        n, buf = _vectors(normals, "SHResult.eval_irradiance: normals")
        out = (c_double * (3 * n))()
        with self._use() as h:
            _check(lib.envl_sh_eval_irradiance(h, n, buf, out))
        return _rows(out, n, 3)
