"""The one loader, the structure mirrors and the one table of argtypes/restypes of libenvlight.

Everything here mirrors src/envlight.h at ENVL_ABI_VERSION == ABI_VERSION. When the header
changes a struct or a signature it bumps ENVL_ABI_VERSION, and load_library() refuses the
library until this file is updated to match.
"""
import ctypes
import glob
import os
from ctypes import (CFUNCTYPE, POINTER, Structure, c_char, c_char_p, c_double, c_float,
                    c_int, c_int32, c_int64, c_size_t, c_uint8, c_void_p)

#: ENVL_ABI_VERSION of the envlight.h these bindings mirror.
ABI_VERSION = 5

_HERE = os.path.dirname(os.path.abspath(__file__))


class Error(Exception):
    """A libenvlight call failed. ``code`` is the envl_result value, ``name`` its name
    (e.g. ``"ENVL_ERR_FORMAT"``) and ``message`` the library's envl_last_error() text."""

    def __init__(self, code, name, message):
        self.code = code
        self.name = name
        self.message = message
        super().__init__("%s: %s" % (name, message))


#: envl_result of a bad argument
ENVL_ERR_ARGUMENT = 1


class ArgumentError(Error, ValueError):
    """A bad argument value (ENVL_ERR_ARGUMENT): refused by the shim before the call (see
    _args.py) or by the library. Both an envlight.Error and a ValueError, so either catches it."""

    def __init__(self, message):
        super().__init__(ENVL_ERR_ARGUMENT, "ENVL_ERR_ARGUMENT", message)


# ---- structure mirrors (field for field, fixed-width types, as in envlight.h) ---------------

class LoadOptions(Structure):
    _fields_ = [
        ("layout", c_int32),
        ("width", c_int32),
        ("rotate_degrees", c_double),
        ("max_pixels", c_int64),
        ("strict", c_int32),
        ("apply_exposure", c_int32),
        ("exr_part", c_char_p),
        ("threads", c_int32),
    ]


class Info(Structure):
    _fields_ = [
        ("file", c_char * 1024),
        ("format", c_char * 8),
        ("layout", c_int32),
        ("layout_guessed", c_int32),
        ("source_width", c_int32),
        ("source_height", c_int32),
        ("channels", c_int32),
        ("width", c_int32),
        ("height", c_int32),
        ("mean", c_double * 3),
        ("power", c_double * 3),
        ("max", c_double * 3),
        ("brightest_direction", c_double * 3),
        ("nonfinite_pixels", c_int64),
        ("negative_pixels", c_int64),
        ("exposure", c_double),
        ("has_primaries", c_int32),
        ("primaries", c_float * 8),
        ("rotate_degrees", c_double),
        ("negative_min", c_double),
        ("signed_power", c_double * 3),
        ("filled_energy", c_double * 3),
        ("added_energy", c_double * 3),
        ("unfilled_values", c_int64),
        ("fill_window", c_int32),
        ("infinity_value", c_double),
    ]


class SkyOptions(Structure):
    _fields_ = [
        ("sun_elevation_degrees", c_double),
        ("sun_azimuth_degrees", c_double),
        ("width", c_int32),
        ("sun_irradiance", c_double),
        ("zenith_radiance", c_double),
        ("ground_albedo", c_double),
        ("sun_elevation_is_set", c_int32),
    ]


class SaveOptions(Structure):
    _fields_ = [
        ("pixel_type", c_int32),
        ("format", c_char_p),
        ("envmap", c_int32),
    ]


class LightsOptions(Structure):
    _fields_ = [
        ("method", c_int32),
        ("count", c_int32),
        ("remainder_order", c_int32),
        ("measure", c_int32),
        ("skip_residual", c_int32),
    ]


class Light(Structure):
    _fields_ = [
        ("direction", c_double * 3),
        ("rgb", c_double * 3),
        ("solid_angle", c_double),
        ("angle", c_double),
        ("rect", c_int32 * 4),
        ("take_direction", c_double * 3),
        ("take_solid_angle", c_double),
        ("take_angle", c_double),
    ]


class LightsSummary(Structure):
    _fields_ = [
        ("method", c_int32),
        ("count", c_int32),
        ("power", c_double * 3),
        ("lights_power", c_double * 3),
        ("residual_power", c_double * 3),
        ("remainder_order", c_int32),
        ("diffuse_error", c_double),
        ("seconds", c_double),
        ("no_light", c_int32),
    ]


class SHOptions(Structure):
    _fields_ = [
        ("order", c_int32),
        ("window", c_int32),
        ("measure", c_int32),
    ]


class SHSummary(Structure):
    _fields_ = [
        ("order", c_int32),
        ("window", c_int32),
        ("window_width", c_double),
        ("min_irradiance", c_double),
        ("diffuse_error", c_double),
        ("seconds", c_double),
        ("ambient", c_double * 3),
        ("deltas", (c_double * 3) * 3),
        ("hemi_axis", c_double * 3),
        ("hemi_sky", c_double * 3),
        ("hemi_ground", c_double * 3),
    ]


class PrefilterOptions(Structure):
    _fields_ = [
        ("levels", c_int32),
        ("width", c_int32),
        ("min_width", c_int32),
        ("samples", c_int32),
        ("unfiltered", c_int32),
        ("irradiance_method", c_int32),
        ("irradiance_width", c_int32),
        ("irradiance_order", c_int32),
        ("threads", c_int32),
        ("sun_lights", c_int32),
        ("half", c_int32),
        ("layout", c_int32),
    ]


class TexelError(Structure):
    _fields_ = [
        ("rms", c_double),
        ("worst", c_double),
        ("worst_direction", c_double * 3),
        ("measured", c_int32),
        ("texels", c_int32),
    ]


class Level(Structure):
    _fields_ = [
        ("roughness", c_double),
        ("alpha", c_double),
        ("width", c_int32),
        ("height", c_int32),
        ("rgb", POINTER(c_float)),
        ("samples", c_int32),
        ("filtered", c_int32),
        ("energy_scale", c_double),
        ("glossy_error", c_double),
        ("seconds", c_double),
        ("layout", c_int32),
        ("texel_error", TexelError),
    ]


class WidthEstimate(Structure):
    _fields_ = [
        ("state", c_int32),
        ("width", c_int32),
        ("size", c_int32),
        ("glossy_error", c_double),
        ("seconds", c_double),
        ("widths_tried", c_int32),
        ("directions_read", c_int32),
        ("seconds_spent", c_double),
    ]


class IrradianceMap(Structure):
    _fields_ = [
        ("method", c_int32),
        ("width", c_int32),
        ("height", c_int32),
        ("rgb", POINTER(c_float)),
        ("diffuse_error", c_double),
        ("seconds", c_double),
        ("layout", c_int32),
        ("texel_error", TexelError),
    ]


class BrdfOptions(Structure):
    _fields_ = [
        ("size", c_int32),
        ("samples", c_int32),
        ("multiscatter", c_int32),
        ("threads", c_int32),
    ]


class Request(Structure):
    _fields_ = [
        ("diffuse", c_int32),
        ("irradiance_map", c_int32),
        ("mirror", c_int32),
        ("shadows", c_int32),
        ("specular_chain", c_int32),
        ("n_roughness", c_int32),
        ("roughness", POINTER(c_double)),
        ("brdf_lut", c_int32),
        ("measure", c_int32),
        ("sh_order", c_int32),
        ("prefilter", PrefilterOptions),
        ("lights", LightsOptions),
        ("brdf", BrdfOptions),
    ]


class ProductsSummary(Structure):
    _fields_ = [
        ("sh_projections", c_int32),
        ("pyramids_built", c_int32),
        ("pyramid_levels", c_int32),
        ("specular_levels", c_int32),
        ("irradiance_maps", c_int32),
        ("lights_computed", c_int32),
        ("brdf_tables", c_int32),
        ("seconds", c_double),
        ("seconds_sh", c_double),
        ("seconds_pyramid", c_double),
        ("seconds_specular", c_double),
        ("seconds_irradiance", c_double),
        ("seconds_lights", c_double),
        ("seconds_brdf", c_double),
        ("prefiltered_width", c_int32),
        ("prefiltered_height", c_int32),
    ]


class ExportOptions(Structure):
    _fields_ = [
        ("format", c_char_p),
        ("layout", c_int32),
        ("frame", c_int32),
    ]


class GltfOptions(Structure):
    _fields_ = [
        ("face_size", c_int32),
        ("mips", c_int32),
        ("no_lights", c_int32),
        ("lights", POINTER(LightsOptions)),
        ("samples", c_int32),
        ("measure", c_int32),
        ("threads", c_int32),
    ]


class GltfSummary(Structure):
    _fields_ = [
        ("lights", c_int32),
        ("face_size", c_int32),
        ("mips", c_int32),
        ("intensity", c_double),
        ("diffuse_error", c_double),
        ("glossy_error", c_double * 16),
        ("rgbd_error", c_double),
        ("bytes", c_int64),
        ("seconds", c_double),
        ("texel_error", TexelError * 16),
        ("prefiltered_width", c_int32),
        ("prefiltered_height", c_int32),
    ]


class PreviewOptions(Structure):
    _fields_ = [
        ("median_count", c_int32),
        ("fit_count", c_int32),
        ("tonemap", c_int32),
        ("exposure_set", c_int32),
        ("exposure_ev", c_double),
        ("diffuse", c_int32),
        ("specular", c_int32),
        ("roughness", c_double * 2),
        ("sphere_size", c_int32),
        ("reference_width", c_int32),
        ("title", c_char_p),
    ]


class PovOptions(Structure):
    _fields_ = [
        ("recipe", c_int32),
        ("recipe_is_set", c_int32),
        ("scene_path", c_char_p),
        ("method", c_int32),
        ("method_is_set", c_int32),
        ("count", c_int32),
        ("ambient", c_int32),
        ("order", c_int32),
        ("ground_plane", c_int32),
        ("ground_albedo", c_double),
        ("shadows", c_int32),
        ("sky", c_int32),
        ("sky_residual", c_int32),
        ("sky_image", c_char_p),
        ("scene_radius", c_double),
        ("exposure", c_double),
        ("no_place", c_int32),
        ("source", c_char_p),
        ("command", c_char_p),
        ("threads", c_int32),
    ]


class PovResult(Structure):
    _fields_ = [
        ("recipe", c_int32),
        ("reason", c_char * 320),
        ("method", c_int32),
        ("count", c_int32),
        ("ambient", c_int32),
        ("ambient_order", c_int32),
        ("ambient_terms", c_int32),
        ("ambient_least", c_double),
        ("ambient_negative", c_int32),
        ("bounce", c_int32),
        ("ground_plane", c_int32),
        ("ground_albedo", c_double),
        ("ground_radiance", c_double * 3),
        ("diffuse_error", c_double),
        ("exposure_auto", c_double),
        ("seconds", c_double),
        ("no_light", c_int32),
        ("sky_file", c_char_p),
        ("text", c_char_p),
        ("warnings", c_char_p),
    ]


#: Every public struct mirrored here, by its C name (the tests compare sizes and offsets
#: against the C compiler's).
STRUCTS = {
    "envl_load_options": LoadOptions,
    "envl_info": Info,
    "envl_sky_options": SkyOptions,
    "envl_save_options": SaveOptions,
    "envl_lights_options": LightsOptions,
    "envl_light": Light,
    "envl_lights_summary": LightsSummary,
    "envl_sh_options": SHOptions,
    "envl_sh_summary": SHSummary,
    "envl_prefilter_options": PrefilterOptions,
    "envl_texel_error": TexelError,
    "envl_level": Level,
    "envl_width_estimate": WidthEstimate,
    "envl_irradiance_map": IrradianceMap,
    "envl_brdf_options": BrdfOptions,
    "envl_request": Request,
    "envl_products_summary": ProductsSummary,
    "envl_export_options": ExportOptions,
    "envl_gltf_options": GltfOptions,
    "envl_gltf_summary": GltfSummary,
    "envl_preview_options": PreviewOptions,
    "envl_pov_options": PovOptions,
    "envl_pov_result": PovResult,
}

# ---- the one table of functions: name -> (restype, argtypes) -------------------------------
# envl_result is int32_t; functions returning it are checked by _check().
#: envl_progress_fn: int (*)(void *user, double fraction, const char *stage)
PROGRESS_FN = CFUNCTYPE(c_int, c_void_p, c_double, c_char_p)
_R = c_int32
_map = c_void_p      # envl_envmap *
_lts = c_void_p      # envl_lights *
_sh = c_void_p       # envl_sh *
_prod = c_void_p     # envl_products *
_pd = POINTER(c_double)
_pf = POINTER(c_float)

FUNCTIONS = {
    "envl_abi_version": (c_int32, []),
    "envl_version_string": (c_char_p, []),
    "envl_result_name": (c_char_p, [c_int32]),
    "envl_result_text": (c_char_p, [c_int32]),
    "envl_last_error": (c_char_p, []),
    "envl_layout_name": (c_char_p, [c_int32]),
    "envl_layout_from_name": (c_int32, [c_char_p]),
    "envl_envmap_load": (_R, [c_char_p, POINTER(LoadOptions), POINTER(_map)]),
    "envl_envmap_from_pixels": (_R, [_pf, c_int32, c_int32, c_int32, POINTER(LoadOptions),
                                     POINTER(_map)]),
    "envl_pixels_alloc": (_R, [c_int32, c_int32, c_int32, POINTER(LoadOptions),
                               POINTER(c_void_p)]),
    "envl_pixels_free": (None, [c_void_p]),
    "envl_envmap_adopt_pixels": (_R, [c_void_p, c_int32, c_int32, c_int32, c_int32,
                                      POINTER(LoadOptions), POINTER(_map)]),
    "envl_envmap_free": (None, [_map]),
    "envl_ground_plane_map": (_R, [_map, c_double, c_int32, POINTER(_map), _pd]),
    "envl_sky_hemisphere_map": (_R, [_map, c_int32, POINTER(_map)]),
    "envl_envmap_info": (_R, [_map, POINTER(Info)]),
    "envl_envmap_width": (c_int32, [_map]),
    "envl_envmap_height": (c_int32, [_map]),
    "envl_envmap_pixels": (_pf, [_map]),
    "envl_envmap_solid_angle": (c_double, [_map, c_int32]),
    "envl_envmap_direction": (None, [_map, c_int32, c_int32, _pd]),
    "envl_latlong_solid_angle": (c_double, [c_int32, c_int32, c_int32]),
    "envl_latlong_direction": (None, [c_int32, c_int32, c_double, c_double, _pd]),
    "envl_latlong_pixel": (None, [c_int32, c_int32, _pd, _pd, _pd]),
    "envl_envmap_sky": (_R, [POINTER(SkyOptions), POINTER(_map)]),
    "envl_image_save": (_R, [c_char_p, _pf, c_int32, c_int32, POINTER(SaveOptions)]),
    "envl_envmap_save": (_R, [_map, c_char_p, POINTER(SaveOptions)]),
    "envl_envmap_to_layout": (_R, [_map, c_int32, c_int32, POINTER(_pf), POINTER(c_int32),
                                   POINTER(c_int32)]),
    "envl_free": (None, [c_void_p]),
    "envl_file_write_atomic": (_R, [c_char_p, c_void_p, c_size_t]),
    "envl_outputs_check": (_R, [POINTER(c_char_p), c_int32, POINTER(c_char_p), c_int32]),
    "envl_irradiance_exact": (_R, [_map, c_int32, _pd, _pd]),
    "envl_fibonacci_direction": (None, [c_int32, c_int32, _pd]),
    "envl_relative_rms_luminance": (c_double, [c_int32, _pd, _pd]),
    "envl_envmap_reference_irradiance": (_R, [_map, POINTER(_pd)]),
    "envl_luminance": (c_double, [c_double, c_double, c_double]),
    "envl_envmap_drop_caches": (None, [_map, c_int32]),
    "envl_method_name": (c_char_p, [c_int32]),
    "envl_method_from_name": (c_int32, [c_char_p]),
    "envl_lights_compute": (_R, [_map, POINTER(LightsOptions), POINTER(_lts)]),
    "envl_lights_free": (None, [_lts]),
    "envl_lights_count": (c_int32, [_lts]),
    "envl_lights_get": (_R, [_lts, c_int32, POINTER(Light)]),
    "envl_lights_get_summary": (_R, [_lts, POINTER(LightsSummary)]),
    "envl_lights_remainder": (_pd, [_lts, POINTER(c_int32)]),
    "envl_lights_residual": (_pf, [_lts]),
    "envl_lights_residual_map": (_R, [_map, _lts, c_int32, POINTER(_map)]),
    "envl_lights_irradiance": (_R, [_lts, c_int32, _pd, _pd]),
    "envl_light_over_residual": (None, [POINTER(Light), _pd, _pd]),
    "envl_window_name": (c_char_p, [c_int32]),
    "envl_window_from_name": (c_int32, [c_char_p]),
    "envl_sh_compute": (_R, [_map, POINTER(SHOptions), POINTER(_sh)]),
    "envl_sh_free": (None, [_sh]),
    "envl_sh_get_summary": (_R, [_sh, POINTER(SHSummary)]),
    "envl_sh_radiance": (_pd, [_sh]),
    "envl_sh_irradiance": (_pd, [_sh]),
    "envl_sh_window_factors": (_pd, [_sh]),
    "envl_sh_eval_radiance": (_R, [_sh, c_int32, _pd, _pd]),
    "envl_sh_eval_irradiance": (_R, [_sh, c_int32, _pd, _pd]),
    "envl_sh_basis": (None, [c_int32, _pd, _pd]),
    "envl_sh_cosine_lobe": (c_double, [c_int32]),
    # prefiltered maps, BRDF table, requests
    "envl_irradiance_method_name": (c_char_p, [c_int32]),
    "envl_irradiance_method_from_name": (c_int32, [c_char_p]),
    "envl_prefilter_level_width": (c_int32, [POINTER(PrefilterOptions), c_double]),
    "envl_compute": (_R, [_map, POINTER(Request), POINTER(_prod)]),
    "envl_products_free": (None, [_prod]),
    "envl_products_get_summary": (_R, [_prod, POINTER(ProductsSummary)]),
    "envl_products_level_count": (c_int32, [_prod]),
    "envl_products_level": (_R, [_prod, c_int32, POINTER(Level)]),
    "envl_products_find_level": (c_int32, [_prod, c_double]),
    "envl_products_level_width": (_R, [_prod, c_int32, POINTER(WidthEstimate)]),
    "envl_products_irradiance": (_R, [_prod, POINTER(IrradianceMap)]),
    "envl_products_sh": (_sh, [_prod]),
    "envl_products_lights": (_lts, [_prod]),
    "envl_products_sun_lights": (POINTER(Light), [_prod, POINTER(c_int32)]),
    "envl_ggx_lobe_norm": (c_double, [c_double]),
    "envl_products_brdf": (_pf, [_prod, POINTER(c_int32), POINTER(c_int32)]),
    "envl_prefilter_specular": (_R, [_map, c_double, c_int32, POINTER(PrefilterOptions),
                                     POINTER(_pf), POINTER(Level)]),
    "envl_envmap_mips": (_R, [_map, POINTER(c_int32)]),
    "envl_envmap_drop_mips": (None, [_map]),
    "envl_prefilter_reference": (_R, [_map, c_double, c_int32, _pd, _pd]),
    "envl_latlong_sample": (None, [_pf, c_int32, c_int32, _pd, _pd]),
    "envl_glossy_error": (_R, [_map, c_double, _pf, c_int32, c_int32, _pd]),
    "envl_brdf_lut": (_R, [POINTER(BrdfOptions), POINTER(_pf), POINTER(c_int32)]),
    "envl_brdf_eval": (_R, [c_double, c_double, c_int32, _pd]),
    "envl_rgbm_encode": (None, [_pf, c_double, POINTER(c_uint8)]),
    "envl_rgbm_decode": (None, [POINTER(c_uint8), c_double, _pf]),
    "envl_rgbd_encode": (None, [_pf, POINTER(c_uint8)]),
    "envl_rgbd_decode": (None, [POINTER(c_uint8), _pf]),
    "envl_gltf_export": (_R, [_map, c_char_p, POINTER(GltfOptions), POINTER(GltfSummary)]),
    "envl_png_save_rgbm": (_R, [c_char_p, _pf, c_int32, c_int32, c_double]),
    "envl_png_save_srgb": (_R, [c_char_p, _pf, c_int32, c_int32]),
    "envl_export_layout_name": (c_char_p, [c_int32]),
    "envl_export_layout_from_name": (c_int32, [c_char_p]),
    "envl_frame_name": (c_char_p, [c_int32]),
    "envl_frame_from_name": (c_int32, [c_char_p]),
    "envl_set_progress": (None, [PROGRESS_FN, c_void_p]),
    "envl_frame_vector": (None, [c_int32, _pd, _pd]),
    "envl_sh_to_frame": (_R, [c_int32, c_int32, c_int32, _pd, _pd]),
    "envl_products_export": (_R, [_prod, c_char_p, POINTER(ExportOptions)]),
    # FILE *notes: c_void_p (NULL from Python)
    "envl_preview_write": (_R, [_map, POINTER(PreviewOptions), c_char_p, c_void_p,
                                POINTER(c_int32), POINTER(c_int32)]),
    # the POV-Ray include
    "envl_pov_recipe_name": (c_char_p, [c_int32]),
    "envl_pov_recipe_from_name": (c_int32, [c_char_p]),
    "envl_pov_include_write": (_R, [_map, POINTER(PovOptions), c_char_p, POINTER(PovResult)]),
    "envl_pov_result_free": (None, [POINTER(PovResult)]),
}

# Constants of envlight.h the Python side uses.
ENVL_CACHE_SAT = 1
ENVL_CACHE_REFERENCE = 2
ENVL_REMAINDER_NONE = -1
ENVL_ORDER_0 = -2
ENVL_ERROR_NORMALS = 1024
ENVL_PIXEL_FLOAT = 0
ENVL_PIXEL_HALF = 1
ENVL_POV_AMBIENT = {"sh": 1, "hemi": 2, "none": 3}      # ENVL_POV_AMBIENT_* (0: auto)
ENVL_POV_SHADOWS = {"auto": 0, "soft": 1, "none": 2, "hard": 3}  # ENVL_POV_SHADOWS_*
ENVL_POV_EXPOSURE_AUTO = -1.0
ENVL_POV_MAX_ORDER = 8


def _candidates():
    env = os.environ.get("ENVLIGHT_LIBRARY")
    if env:
        return [env], True
    found = []
    for folder in (_HERE, os.path.join(os.path.dirname(_HERE), "lib")):
        found += sorted(glob.glob(os.path.join(folder, "libenvlight.so*")), key=len)
    repo = os.path.dirname(os.path.dirname(_HERE))  # <repo>/py_shim/envlight -> <repo>
    found.append(os.path.join(repo, "build", "libenvlight.so"))
    return found, False


def load_library(path=None):
    """Loads libenvlight (``path``, else $ENVLIGHT_LIBRARY, else next to the package, else the
    build tree), checks its ABI version and declares every function of FUNCTIONS."""
    if path:
        paths, explicit = [path], True
    else:
        paths, explicit = _candidates()
    tried = []
    lib = None
    for p in paths:
        if not explicit and not os.path.exists(p):
            tried.append(p + " (absent)")
            continue
        try:
            lib = ctypes.CDLL(p)
            break
        except OSError as e:
            tried.append("%s (%s)" % (p, e))
    if lib is None:
        raise ImportError("envlight: cannot load libenvlight; tried: " + "; ".join(tried) +
                          ". Set ENVLIGHT_LIBRARY to the built libenvlight.so.")
    lib.envl_abi_version.restype = c_int32
    lib.envl_abi_version.argtypes = []
    abi = lib.envl_abi_version()
    if abi != ABI_VERSION:
        raise ImportError("envlight: %s has ABI version %d, these bindings were written for %d"
                          % (lib._name, abi, ABI_VERSION))
    for name, (restype, argtypes) in FUNCTIONS.items():
        fn = getattr(lib, name)  # AttributeError names a symbol the library lacks
        fn.restype = restype
        fn.argtypes = argtypes
    return lib


lib = load_library()
#: the path of the loaded library
library_path = lib._name


def _str(b):
    return b.decode("utf-8", "replace") if b is not None else ""


def _check(rc):
    """Raises Error with the library's message for every nonzero envl_result (ArgumentError
    for ENVL_ERR_ARGUMENT: a bad argument is a ValueError whoever finds it)."""
    if rc == ENVL_ERR_ARGUMENT:
        raise ArgumentError(_str(lib.envl_last_error()))
    if rc != 0:
        raise Error(rc, _str(lib.envl_result_name(rc)), _str(lib.envl_last_error()))
    return rc
