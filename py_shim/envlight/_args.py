"""The shim's argument checks: every value a public function passes to C goes through one of
these first, so nothing reaches libenvlight truncated to its C type, wrapped around, or turned
into the library's "0 = default" by accident.

- integers: int or anything with __index__ (numpy integers), never bool (True is not 1 light)
  nor float; within the C type and the library's limit;
- None asks for the library's default where there is one: a 0 or negative value the C side
  would read as "default" is refused (0 only where it is a real value);
- floats: real numbers (not bool, not str), finite, within the argument's range;
- flags: bool (numpy's too) or 0/1;
- paths: str, bytes or os.PathLike (os.fsencode: a str's undecodable bytes go back as they
  were), not empty, no NUL byte (C would stop there and open another file);
- names (format, EXR part, enums): str, not empty, no NUL byte.

A bad value raises ArgumentError (a ValueError and an envlight.Error ENVL_ERR_ARGUMENT) whose
message names the function, the argument and its valid range; a wrong type raises TypeError.
"""
import math
import numbers
import operator
import os

from ._lib import ArgumentError

try:
    import numpy as _np
except ImportError:  # pragma: no cover - numpy is optional
    _np = None

INT32_MAX = 2 ** 31 - 1
INT64_MAX = 2 ** 63 - 1

# ---- the library's limits (mirrored; tests/py_shim_arguments.py checks them against it) ----
#: lights.c envl_lights_compute: count 1..32 for fit, else 1..2^24
LIGHTS_MAX_FIT = 32
LIGHTS_MAX = 1 << 24
#: lights: the fit's remainder order 0..8 (ENVL_MAX_REMAINDER_ORDER)
REMAINDER_MAX_ORDER = 8
#: SH orders 0..32
SH_MAX_ORDER = 32
#: sky.c: width <= 65536 and width x width/2 <= ENVL_DEFAULT_MAX_PIXELS (2^28): 23170
SKY_MAX_WIDTH = 23170
#: prefilter.c resolve(): levels 1..16, widths 2..65536, samples 1..2^20
PREFILTER_MAX_LEVELS = 16
PREFILTER_MAX_WIDTH = 65536
PREFILTER_MAX_SAMPLES = 1 << 20
#: brdf.c: table size 1..4096, samples 1..2^24
BRDF_MAX_SIZE = 4096
BRDF_MAX_SAMPLES = 1 << 24
#: fibonacci_directions: at most as many directions as lights (a Python loop, one C call each)
DIRECTIONS_MAX = 1 << 24

_REQUIRED = object()


def _is_bool(value):
    return isinstance(value, bool) or (_np is not None and isinstance(value, _np.bool_))


def _default_text(default, note):
    if note:
        return "; None: " + note
    return "" if default is _REQUIRED else "; None for the default"


def integer(value, what, lo, hi, default=_REQUIRED, note=None):
    """value as an int within [lo, hi]. default: what None gives (the C side's "default"
    value), if None is allowed; note: what None means, for the message."""
    if value is None and default is not _REQUIRED:
        return default
    if _is_bool(value):
        raise TypeError("%s must be an integer, not bool (%r)" % (what, value))
    try:
        v = operator.index(value)
    except TypeError:
        raise TypeError("%s must be an integer, not %s" % (what, type(value).__name__)) from None
    if not lo <= v <= hi:
        raise ArgumentError("%s %d is out of range (%d..%d%s)"
                            % (what, v, lo, hi, _default_text(default, note)))
    return v


def real(value, what, lo=-math.inf, hi=math.inf, above=None, default=_REQUIRED, note=None):
    """value as a finite float within [lo, hi] (above: > above instead of >= lo)."""
    if value is None and default is not _REQUIRED:
        return default
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise TypeError("%s must be a number, not %s" % (what, type(value).__name__))
    v = float(value)
    if above is not None:
        span = "> %g" % above + ("" if hi == math.inf else " and <= %g" % hi)
        ok = v > above and v <= hi
    elif lo == -math.inf and hi == math.inf:
        span, ok = "finite", True
    else:
        span, ok = "%g..%g" % (lo, hi), lo <= v <= hi
    if not math.isfinite(v):
        raise ArgumentError("%s %r is not a finite number%s"
                            % (what, v, "" if span == "finite" else " (%s%s)"
                               % (span, _default_text(default, note))))
    if not ok:
        raise ArgumentError("%s %r is out of range (%s%s)"
                            % (what, v, span, _default_text(default, note)))
    return v


def flag(value, what):
    """True/False (numpy's too) or 0/1 -> 0/1."""
    if _is_bool(value):
        return 1 if value else 0
    if isinstance(value, numbers.Integral) and value in (0, 1):
        return int(value)
    raise TypeError("%s must be True or False, not %r" % (what, value))


def path(value, what):
    """A file or directory name as the bytes C gets."""
    try:
        b = os.fsencode(value)
    except TypeError:
        raise TypeError("%s must be a path (str, bytes or os.PathLike), not %s"
                        % (what, type(value).__name__)) from None
    except UnicodeError as e:
        raise ArgumentError("%s %r cannot be encoded for the file system (%s)"
                            % (what, value, e)) from None
    if not b:
        raise ArgumentError("%s is empty" % what)
    if b"\0" in b:
        raise ArgumentError("%s %r contains a NUL byte" % (what, value))
    return b


def text(value, what, default=_REQUIRED):
    """A name (str or bytes) as the bytes C gets; None -> None (C's NULL: the default) if
    allowed."""
    if value is None and default is not _REQUIRED:
        return None
    if isinstance(value, str):
        b = value.encode("utf-8")
    elif isinstance(value, bytes):
        b = value
    else:
        raise TypeError("%s must be a str, not %s" % (what, type(value).__name__))
    if not b:
        raise ArgumentError("%s is empty%s" % (what, "" if default is _REQUIRED
                                               else " (None for the default)"))
    if b"\0" in b:
        raise ArgumentError("%s %r contains a NUL byte" % (what, value))
    return b


def enum(value, what, from_name, to_name, lo=0):
    """An enum given by name ('fit') or value (ENVL_METHOD_FIT) -> its value (>= lo)."""
    names = []
    while to_name(len(names)) is not None:
        names.append(to_name(len(names)).decode())
    allowed = ", ".join(names[lo:])
    func, _, arg = what.rpartition(": ")  # "unknown method 'nope'", as the CLI says it
    if isinstance(value, (str, bytes)):
        name = value.decode("utf-8", "replace") if isinstance(value, bytes) else value
        v = -1 if "\0" in name else from_name(name.encode("utf-8"))
        if not lo <= v < len(names):
            raise ArgumentError("%s: unknown %s %r (%s)" % (func, arg, value, allowed))
        return v
    if _is_bool(value) or not isinstance(value, numbers.Integral):
        raise TypeError("%s must be a name (%s) or an int, not %s"
                        % (what, allowed, type(value).__name__))
    if not lo <= value < len(names):
        raise ArgumentError("%s: unknown %s %r (%s, or %d..%d)"
                            % (func, arg, value, allowed, lo, len(names) - 1))
    return int(value)


def triple(value, what):
    """One direction: three finite numbers -> tuple of floats."""
    try:
        vals = list(value)
    except TypeError:
        raise TypeError("%s must be 3 numbers, not %s" % (what, type(value).__name__)) from None
    if len(vals) != 3:
        raise ArgumentError("%s has %d values, 3 expected" % (what, len(vals)))
    return tuple(real(x, what + " component") for x in vals)


def vectors(values, what):
    """(N, 3) finite numbers -> (N, flat list or float64 numpy array of 3 N values)."""
    if _np is not None:
        try:
            a = _np.asarray(values)
        except ValueError as e:  # ragged
            raise ArgumentError("%s: %s (N x 3 numbers expected)" % (what, e)) from None
        if a.dtype.kind not in "iuf" and a.size:
            raise TypeError("%s must hold numbers, not %s" % (what, a.dtype))
        a = a.astype(_np.float64).reshape(-1)
        if a.size % 3:
            raise ArgumentError("%s holds %d values, not a multiple of 3 (N x 3 expected)"
                                % (what, a.size))
        if not _np.isfinite(a).all():
            raise ArgumentError("%s holds non-finite values" % what)
        flat = a
    else:
        flat = [x for v in values for x in triple(v, what)]
    n = len(flat) // 3
    if n > INT32_MAX:
        raise ArgumentError("%s: %d vectors, at most %d" % (what, n, INT32_MAX))
    return n, flat
