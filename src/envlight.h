/* envlight — HDR environment images into lights, SH and prefiltered maps.
 *
 * Public C API. Conventions (README, "Library API"; docs/design.md):
 *  - every call returns an envl_result (ENVL_OK = 0); on failure envl_last_error() gives a
 *    message for this thread naming the file, the offset and what was expected;
 *  - options structs: zero means "sensible default" (each field's comment gives the default),
 *    resolved in one pass per struct (src/products/options.c); an SH order is always given as
 *    the order L itself (`order`, `*_order`), 0 there meaning the default and ENVL_ORDER_0 the
 *    order 0;
 *  - opaque handles are released with NULL-safe *_free functions;
 *  - the canonical frame is Blender's world frame (right-handed, +Z up) and the envmap is a
 *    lat-long image in it: column c, row r (0 = top), u = (c+0.5)/W, v = (r+0.5)/H,
 *    phi = pi (1 - 2u), theta = pi (0.5 - v), d = (cos t cos p, cos t sin p, sin t).
 */
#ifndef ENVLIGHT_H
#define ENVLIGHT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#if defined(ENVL_BUILDING_LIBRARY)
#define ENVL_API __attribute__((visibility("default")))
#else
#define ENVL_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped whenever a struct layout or a function signature changes (the ctypes shim checks it). */
#define ENVL_ABI_VERSION 5

/* pi, the one definition every part of envlight uses. */
#define ENVL_PI 3.14159265358979323846
/* The most worker threads any call uses (every `threads` option: 0 = all cores, capped here). */
#define ENVL_MAX_THREADS 256

/* SH orders in options: an `order` field holds the order L; 0 there is the default
 * (ENVL_DEFAULT_ORDER) and ENVL_ORDER_0 asks for order 0 (the constant term alone). */
#define ENVL_DEFAULT_ORDER 2
#define ENVL_ORDER_0 (-2)

/* ---- results ------------------------------------------------------------------------------ */
typedef int32_t envl_result;
/* X-macro: code, value, short description. One table, so codes and names never drift apart. */
#define ENVL_RESULT_TABLE(X)                                                                   \
    X(ENVL_OK, 0, "success")                                                                   \
    X(ENVL_ERR_ARGUMENT, 1, "invalid argument")                                                \
    X(ENVL_ERR_IO, 2, "cannot read or write the file")                                         \
    X(ENVL_ERR_FORMAT, 3, "malformed or truncated file")                                       \
    X(ENVL_ERR_UNSUPPORTED, 4, "unsupported file variant")                                     \
    X(ENVL_ERR_LIMIT, 5, "exceeds a configured limit")                                         \
    X(ENVL_ERR_MEMORY, 6, "out of memory")                                                     \
    X(ENVL_ERR_NONFINITE, 7, "non-finite, overflowing or negative values where none may be") \
    X(ENVL_ERR_CANCELLED, 8, "cancelled by the progress callback")
#define ENVL_RESULT_ENUM_(name, value, text) name = value,
enum { ENVL_RESULT_TABLE(ENVL_RESULT_ENUM_) };
#undef ENVL_RESULT_ENUM_

ENVL_API int32_t envl_abi_version(void);
ENVL_API const char *envl_version_string(void);
/* Progress of the long calls made from this thread: envl_compute (per product and level),
 * envl_lights_compute (fit, takes, measure), envl_products_export (per map),
 * envl_envmap_load (reading the file, the canonical frame) and envl_envmap_to_layout (the
 * resampling). fn(user, fraction, stage) is called on the calling thread between steps, the
 * fraction (0..1) rising to 1 at the end of each call; a nonzero return cancels: the call
 * frees what it made, writes nothing and fails with ENVL_ERR_CANCELLED. Other calls (saving
 * an image, SH) report nothing. NULL: none (the default). Set per thread. */
typedef int (*envl_progress_fn)(void *user, double fraction, const char *stage);
ENVL_API void envl_set_progress(envl_progress_fn fn, void *user);

/* "ENVL_ERR_FORMAT" for a code; "ENVL_UNKNOWN" for a value outside the table. */
ENVL_API const char *envl_result_name(envl_result code);
ENVL_API const char *envl_result_text(envl_result code);
/* Message of the last failure on this thread ("" if none). Valid until the next failing call. */
ENVL_API const char *envl_last_error(void);

/* ---- layouts of input images ------------------------------------------------------------- */
#define ENVL_LAYOUT_AUTO 0          /* pick by metadata and aspect ratio */
#define ENVL_LAYOUT_LATLONG 1       /* equirectangular, canonical frame */
#define ENVL_LAYOUT_ANGULAR 2       /* Debevec angular probe */
#define ENVL_LAYOUT_MIRRORBALL 3    /* photographed mirror ball */
#define ENVL_LAYOUT_CROSS_V 4       /* vertical cube cross, 3 x 4 faces */
#define ENVL_LAYOUT_CROSS_H 5       /* horizontal cube cross, 4 x 3 faces */
#define ENVL_LAYOUT_STRIP_H 6       /* six faces side by side, 6 x 1 */
#define ENVL_LAYOUT_STRIP_V 7       /* six faces stacked, 1 x 6 */
#define ENVL_LAYOUT_EXR_LATLONG 8   /* OpenEXR envmap=latlong convention */
#define ENVL_LAYOUT_EXR_CUBE 9      /* OpenEXR envmap=cube convention (N x 6N) */
#define ENVL_LAYOUT_COUNT 10
/* "latlong", "angular", ... ; NULL for an unknown value. */
ENVL_API const char *envl_layout_name(int32_t layout);
/* Inverse of envl_layout_name ("auto" -> 0, "cross" -> vertical cross); -1 if unknown. */
ENVL_API int32_t envl_layout_from_name(const char *name);

/* ---- envmap: the canonical lat-long map with its tables ------------------------------------ */
typedef struct envl_envmap envl_envmap;

/* Default limit on the pixels a file's header may claim: 2^28 (16384 x 16384). */
#define ENVL_DEFAULT_MAX_PIXELS ((int64_t)1 << 28)

typedef struct envl_load_options {
    int32_t layout;           /* ENVL_LAYOUT_*; default AUTO */
    int32_t width;            /* width of the canonical lat-long map (height = width/2);
                                 default: lat-long input keeps its size, others 4 x face size
                                 or 2 x probe diameter */
    double rotate_degrees;    /* turn the map about +Z (counter-clockwise seen from above); 0 */
    int64_t max_pixels;       /* refuse files whose header claims more pixels; default above */
    int32_t strict;           /* nonzero: NaN, Inf or negative pixels are an error; default 0:
                                 NaN -> 0, +Inf -> largest finite value, negative values filled
                                 from the light around them (envl_info says what was done) */
    int32_t apply_exposure;   /* nonzero: divide Radiance pixels by the file's EXPOSURE; 0 */
    const char *exr_part;     /* multipart EXR: part name; default: first part with colour */
    int32_t threads;          /* worker threads; default: all cores (at most ENVL_MAX_THREADS) */
} envl_load_options;

/* What was read and what the map holds. Strings are NUL-terminated, truncated if long. */
typedef struct envl_info {
    char file[1024];          /* path as given ("" for pixels from memory, "sky" for the sky) */
    char format[8];           /* "hdr", "exr", "pfm", "memory", "sky" */
    int32_t layout;           /* ENVL_LAYOUT_* the input was read as */
    int32_t layout_guessed;   /* 1 if the layout came from ENVL_LAYOUT_AUTO */
    int32_t source_width, source_height, channels;  /* of the file */
    int32_t width, height;    /* of the canonical lat-long map */
    double mean[3];           /* average radiance over the sphere = power / 4 pi */
    double power[3];          /* integral of L dw over the sphere */
    double max[3];            /* largest value of each channel */
    double brightest_direction[3]; /* direction of the pixel of largest luminance */
    int64_t nonfinite_pixels; /* pixels of the file with a NaN or Inf channel */
    int64_t negative_pixels;  /* pixels of the file with a negative channel */
    double exposure;          /* product of the file's EXPOSURE values (1 if none) */
    int32_t has_primaries;    /* the file named its primaries */
    float primaries[8];       /* CIE xy of R, G, B, white */
    double rotate_degrees;    /* rotation applied on load */
    /* What the loader did to the file's values (docs/design.md, "Units"), in the map's units
     * (ABI 5); but for signed_power all 0 when no value was replaced: */
    double negative_min;      /* the most negative value of the file */
    double signed_power[3];   /* integral of L dw of the file's values as read (NaN and Inf
                                 replaced), negative ones included, in the file's layout: the
                                 light the file holds (= power when no value was replaced) */
    double filled_energy[3];  /* integral of -L dw of the negative values filled from the
                                 positive light around them (taken from it: power stays
                                 signed_power) */
    double added_energy[3];   /* of the negative values set to 0 with too little light around
                                 them: added to the power */
    int64_t unfilled_values;  /* how many such values */
    int32_t fill_window;      /* the widest window the filling took light from, pixels */
    double infinity_value;    /* what +Inf became: the largest finite value of the file */
} envl_info;

/* Loads an .hdr/.pic, .exr or .pfm file (detected by content) into the canonical frame. */
ENVL_API envl_result envl_envmap_load(const char *path, const envl_load_options *options,
                                      envl_envmap **out);
/* Pixels from memory: width x height, channels 1 (grey), 3 (RGB) or 4 (RGBA, alpha ignored),
 * row 0 at the top, floats laid out row-major. Interpreted with options->layout (AUTO guesses
 * from the aspect ratio). */
ENVL_API envl_result envl_envmap_from_pixels(const float *pixels, int32_t width, int32_t height,
                                             int32_t channels, const envl_load_options *options,
                                             envl_envmap **out);
/* The same without a copy, for a host that writes an image's pixels straight into memory
 * (Blender's Image.pixels.foreach_get): envl_pixels_alloc gives room for width x height pixels
 * of `channels` floats (1, 3 or 4; options: max_pixels, else the default limit), which the
 * caller fills (row-major, row 0 at the top, or at the bottom with bottom_up nonzero) and hands
 * to envl_envmap_adopt_pixels. That call always takes the memory: the map's pixels are made in
 * it (the rows put top-down, RGBA compacted to RGB, grey spread to RGB, the rest given back),
 * and on failure it is freed; the caller must not touch it afterwards. envl_pixels_free frees
 * memory that is never adopted. Otherwise as envl_envmap_from_pixels. */
ENVL_API envl_result envl_pixels_alloc(int32_t width, int32_t height, int32_t channels,
                                       const envl_load_options *options, float **out);
ENVL_API void envl_pixels_free(float *pixels);
ENVL_API envl_result envl_envmap_adopt_pixels(float *pixels, int32_t width, int32_t height,
                                              int32_t channels, int32_t bottom_up,
                                              const envl_load_options *options,
                                              envl_envmap **out);
ENVL_API void envl_envmap_free(envl_envmap *map);

/* The environment as a scene on a ground plane sees it (ground.c). A copy of `map` whose lower
 * hemisphere (canonical z < 0) is the uniform radiance albedo * E_up / pi of a Lambertian plane
 * at z = 0, E_up the map's exact irradiance at the normal +Z; ground_rgb (may be NULL)
 * receives that radiance. albedo within [0, 1]. The copy is a canonical lat-long map from
 * memory (rotation already applied); release with envl_envmap_free. */
ENVL_API envl_result envl_ground_plane_map(const envl_envmap *map, double albedo,
                                           int32_t threads, envl_envmap **out,
                                           double ground_rgb[3]);
/* A copy of `map` with its lower hemisphere black: the sky a scene on a ground plane sees. */
ENVL_API envl_result envl_sky_hemisphere_map(const envl_envmap *map, int32_t threads,
                                             envl_envmap **out);

ENVL_API envl_result envl_envmap_info(const envl_envmap *map, envl_info *out);
ENVL_API int32_t envl_envmap_width(const envl_envmap *map);
ENVL_API int32_t envl_envmap_height(const envl_envmap *map);
/* RGB floats, width * height * 3, row 0 = top. Owned by the map. */
ENVL_API const float *envl_envmap_pixels(const envl_envmap *map);
/* Solid angle of a pixel of row r (exact), and the unit direction of pixel centre (c, r). */
ENVL_API double envl_envmap_solid_angle(const envl_envmap *map, int32_t row);
ENVL_API void envl_envmap_direction(const envl_envmap *map, int32_t column, int32_t row,
                                    double direction[3]);
/* Same formulas for any lat-long size (docs/design.md). */
ENVL_API double envl_latlong_solid_angle(int32_t width, int32_t height, int32_t row);
ENVL_API void envl_latlong_direction(int32_t width, int32_t height, double column, double row,
                                     double direction[3]);
/* Continuous pixel coordinates (column, row) of a direction: the inverse of the above. */
ENVL_API void envl_latlong_pixel(int32_t width, int32_t height, const double direction[3],
                                 double *column, double *row);

/* ---- built-in procedural sky ----------------------------------------------------------------- */
typedef struct envl_sky_options {
    double sun_elevation_degrees;  /* default 35 (exact 0 via ENVL_SKY_HORIZON) */
    double sun_azimuth_degrees;    /* canonical phi of the sun, from +X towards +Y; 0 */
    int32_t width;                 /* lat-long width, height = width / 2; default 1024 */
    double sun_irradiance;         /* irradiance of the sun disc at normal incidence; default 12 */
    double zenith_radiance;        /* sky radiance (luminance) at the zenith; default 0.6 */
    double ground_albedo;          /* default 0.2 */
    int32_t sun_elevation_is_set;  /* nonzero: sun_elevation_degrees is used even when 0 */
} envl_sky_options;
/* Angular diameter of the sun disc, degrees. */
#define ENVL_SKY_SUN_DIAMETER_DEGREES 0.53
ENVL_API envl_result envl_envmap_sky(const envl_sky_options *options, envl_envmap **out);

/* ---- saving images ---------------------------------------------------------------------------- */
#define ENVL_PIXEL_FLOAT 0  /* EXR: 32-bit float channels (default) */
#define ENVL_PIXEL_HALF 1   /* EXR: 16-bit half, values beyond +-65504 clamp */
typedef struct envl_save_options {
    int32_t pixel_type;       /* ENVL_PIXEL_*; EXR only */
    const char *format;       /* "hdr", "exr", "pfm"; default: from the file name's extension */
    int32_t envmap;           /* EXR only: ENVL_LAYOUT_EXR_LATLONG or ENVL_LAYOUT_EXR_CUBE, written
                                 as OpenEXR's `envmap` attribute (the pixels must be in that
                                 layout: envl_envmap_to_layout); 0: no attribute */
} envl_save_options;
/* Writes RGB floats (width x height x 3, row 0 = top) atomically: a temporary file in the
 * same directory, renamed over the target only when complete. */
ENVL_API envl_result envl_image_save(const char *path, const float *rgb, int32_t width,
                                     int32_t height, const envl_save_options *options);
ENVL_API envl_result envl_envmap_save(const envl_envmap *map, const char *path,
                                      const envl_save_options *options);
/* Renders the map into another layout (size: face size for cubes and strips, diameter for
 * probes, width for lat-long). *pixels (RGB floats) is allocated; release with envl_free. */
ENVL_API envl_result envl_envmap_to_layout(const envl_envmap *map, int32_t layout, int32_t size,
                                           float **pixels, int32_t *width, int32_t *height);
ENVL_API void envl_free(void *memory);
/* Writes `size` bytes to `path` atomically (temporary file in the same directory + rename):
 * an existing file is either replaced whole or left as it was. */
ENVL_API envl_result envl_file_write_atomic(const char *path, const void *data, size_t size);
/* ENVL_ERR_ARGUMENT, the message naming both, when an output is the same file as an input or
 * as another output: the same device and inode when both exist (hard and symbolic links), else
 * the same normalised path (absolute; the symbolic links of the part that exists resolved;
 * ".", ".." and repeated slashes of the rest taken out). NULL and empty names are skipped.
 * Every writer of the library that knows its inputs checks its outputs this way (the map's
 * file, a POV-Ray scene: envl_envmap_save, envl_products_export, envl_gltf_export,
 * envl_preview_write, envl_pov_include_write); a caller writing several files checks them. */
ENVL_API envl_result envl_outputs_check(const char *const *inputs, int32_t n_inputs,
                                        const char *const *outputs, int32_t n_outputs);

/* ---- exact irradiance and the error measure (docs/design.md) ------------------------------------- */
/* E(n) = sum over pixels of L dw max(0, n.d), in double, for `count` unit normals. */
ENVL_API envl_result envl_irradiance_exact(const envl_envmap *map, int32_t count,
                                           const double *normals, double *rgb_out);
/* The i-th of n points of the Fibonacci sphere (the error measure uses n = 1024); (0, 0, 0)
 * unless 0 <= i < n. */
ENVL_API void envl_fibonacci_direction(int32_t i, int32_t n, double direction[3]);
#define ENVL_ERROR_NORMALS 1024
/* Relative RMS of luminance: sqrt(mean((Ya - Ye)^2)) / mean(|Ye|) over `count` values. */
ENVL_API double envl_relative_rms_luminance(int32_t count, const double *approx_rgb,
                                            const double *exact_rgb);
/* Exact irradiance at the 1024 Fibonacci normals, computed once per map and cached. Maps wider
 * than ENVL_REFERENCE_WIDTH are resampled (exactly, by area) to that width first. Summed
 * through a tree of block sums: each value is within 2e-4 x the mean irradiance of
 * envl_irradiance_exact's (docs/design.md, "Error measures"). */
#define ENVL_REFERENCE_WIDTH 1024
ENVL_API envl_result envl_envmap_reference_irradiance(envl_envmap *map, const double **rgb_out);

ENVL_API double envl_luminance(double r, double g, double b);

/* Tables a map caches for the products that share them (computed on first use). Dropping
 * them lets a benchmark time a product from scratch. */
#define ENVL_CACHE_SAT 1        /* region table of summed energies (lights) */
#define ENVL_CACHE_REFERENCE 2  /* exact irradiance at the error measure's normals */
ENVL_API void envl_envmap_drop_caches(envl_envmap *map, int32_t which);

/* ---- lights ------------------------------------------------------------------------------- */
/* The default, everywhere (C, `envlight lights`, `envlight pov`'s custom recipe, Python): the
 * benchmark's pick for a few lights + an ambient (docs/bench/tables.md). */
#define ENVL_METHOD_FIT 0       /* fitted lights (non-negative) + low-order SH remainder */
#define ENVL_METHOD_MEDIAN 1    /* Debevec 2005 median cut (region table of 32-column blocks) */
#define ENVL_METHOD_VARIANCE 2  /* variance-minimising cut (after Viriyothai & Debevec 2009) */
/* The map's suns, split off exactly: the pixels above 50x the mean luminance (at most 4096:
 * else the threshold is raised; the prefiltered maps' split, as options.sun_lights), one
 * light per 8-connected group that is a sun (at most 5 degrees across, compact, >= 1 % of
 * the power); rgb = the sum of the group's excess L dw above the threshold, direction = its
 * luminance-weighted centroid, solid_angle = the uniform disc of the same spread. count: the
 * most suns kept, the brightest (default 4). The residual is the map less exactly what the
 * lights took (their pixels at the threshold; other bright groups and the suns beyond count
 * keep their full value), no remainder; a map without a sun gives no light and the map as
 * residual. Its diffuse_error is that of the lights plus the residual's exact irradiance (the
 * residual stays an environment map); envl_lights_irradiance gives the lights' part. */
#define ENVL_METHOD_SUN 3
#define ENVL_METHOD_COUNT 4
ENVL_API const char *envl_method_name(int32_t method); /* "fit", "median", "variance", "sun" */
ENVL_API int32_t envl_method_from_name(const char *name); /* -1 if unknown */

#define ENVL_REMAINDER_NONE (-1)
#define ENVL_DEFAULT_FIT_LIGHTS 4
#define ENVL_DEFAULT_CUT_LIGHTS 16
#define ENVL_DEFAULT_SUN_LIGHTS 4
#define ENVL_MAX_REMAINDER_ORDER 8
/* The fit solves the lights' colours and the SH remainder together, one NNLS of at most 128
 * unknowns (32 lights + 81 coefficients at remainder order 8). */
#define ENVL_FIT_MAX_LIGHTS 32
typedef struct envl_lights_options {
    int32_t method;           /* ENVL_METHOD_*; default fit */
    int32_t count;            /* number of lights; default ENVL_DEFAULT_FIT_LIGHTS (fit),
                                 _CUT_LIGHTS (median, variance), _SUN_LIGHTS (sun: at most) */
    int32_t remainder_order;  /* fit: SH order of the remainder, 0..8 (ENVL_ORDER_0 for 0);
                                 default 2; ENVL_REMAINDER_NONE for lights only */
    int32_t measure;          /* nonzero: also measure diffuse_error (default 0: -1, not
                                 measured; the fit's own target is computed either way) */
    int32_t skip_residual;    /* fit, sun: nonzero keeps no residual map (the lights and the
                                 error are the same; the map's floats once, not twice);
                                 envl_lights_residual is then NULL. Default 0: kept (ABI 4) */
} envl_lights_options;

typedef struct envl_light {
    double direction[3];      /* unit vector towards the light, canonical frame */
    double rgb[3];            /* irradiance at normal incidence: sum of L dw it took */
    double solid_angle;       /* of the region it took its light from, sr */
    double angle;             /* angular diameter 2 acos(1 - solid_angle / 2 pi), radians, <= pi */
    int32_t rect[4];          /* region's pixel rectangle x0, y0, x1, y1 (exclusive); x1 may
                                 exceed the width when the region wraps across the seam */
    /* The light as a lamp over the residual map (ABI 5): the direction of the first moment V
     * of what it took from the map, and the solid angle and angular diameter of the uniform
     * disc about it with the same spread. A lamp along take_direction delivering
     * rgb (1 - take_solid_angle / 4 pi) (= |V|) at normal incidence (envl_light_over_residual)
     * makes lamp + residual the map's irradiance for every normal that sees all it took.
     * median, variance, sun: the same as direction, solid_angle, angle; fit: direction is
     * where the fit aims (the best with its SH remainder), which may differ from it. */
    double take_direction[3];
    double take_solid_angle;
    double take_angle;
} envl_light;

typedef struct envl_lights_summary {
    int32_t method, count;
    double power[3];          /* of the environment: integral of L dw */
    double lights_power[3];   /* sum of the lights' rgb */
    double residual_power[3]; /* what the lights did not take; lights + residual = power */
    int32_t remainder_order;  /* fit with remainder: its order, else -1 */
    double diffuse_error;     /* docs/design.md's measure against the exact integrator (sun: of
                                 the lights + the residual's exact irradiance); -1 when
                                 options.measure was 0 */
    double seconds;           /* time to compute the lights (the error measure excluded) */
    int32_t no_light;         /* 1: the map is black; there are no lights */
} envl_lights_summary;

typedef struct envl_lights envl_lights;
/* Computes the lights (and, for fit, the remainder), the residual environment and the error.
 * Intermediate tables are cached in the map and shared with later calls. */
ENVL_API envl_result envl_lights_compute(envl_envmap *map, const envl_lights_options *options,
                                         envl_lights **out);
ENVL_API void envl_lights_free(envl_lights *lights);
ENVL_API int32_t envl_lights_count(const envl_lights *lights);
ENVL_API envl_result envl_lights_get(const envl_lights *lights, int32_t index, envl_light *out);
ENVL_API envl_result envl_lights_get_summary(const envl_lights *lights,
                                             envl_lights_summary *out);
/* Fit remainder: irradiance SH coefficients, (order+1)^2 x RGB, docs/design.md's order; NULL and
 * order -1 when there is none. */
ENVL_API const double *envl_lights_remainder(const envl_lights *lights, int32_t *order);
/* The residual environment (same size as the map), RGB floats owned by the lights object;
 * NULL (and an error message) for a fit or sun lights computed with skip_residual. */
ENVL_API const float *envl_lights_residual(const envl_lights *lights);
/* The residual environment as a map of its own (within ABI 5), area-resampled to `width` wide (each
 * pixel the solid-angle weighted mean over its footprint: the integral of L dw kept; height in
 * proportion); 0 or at least the map's width: the map's size, a copy. `map` is the map the
 * lights were computed from. The sun method's residual is made from the map and the suns'
 * pixels (it needs no kept residual and, resampled, costs no full-size copy); the others' from
 * their kept residual (ENVL_ERR_ARGUMENT when skipped). Release with envl_envmap_free. */
ENVL_API envl_result envl_lights_residual_map(const envl_envmap *map, const envl_lights *lights,
                                             int32_t width, envl_envmap **out);
/* The delta light that stands for `light` over the residual map (ABI 5): direction =
 * take_direction, rgb = light->rgb (1 - take_solid_angle / 4 pi). A disc lamp of the light's
 * take_angle (a Blender sun) takes that rgb as its irradiance at normal incidence. */
ENVL_API void envl_light_over_residual(const envl_light *light, double direction[3],
                                       double rgb[3]);
/* Irradiance the lights (+ remainder) predict for `count` normals. */
ENVL_API envl_result envl_lights_irradiance(const envl_lights *lights, int32_t count,
                                            const double *normals, double *rgb_out);

/* ---- spherical harmonics -------------------------------------------------------------------
 * Real SH without the Condon-Shortley phase; coefficient index l (l + 1) + m, l = 0..order;
 * for l <= 2 the basis of Ramamoorthi & Hanrahan 2001 (docs/design.md). Irradiance coefficients are
 * radiance coefficients times A_l (A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4, odd l > 1: 0, ...). */
#define ENVL_WINDOW_NONE 0
#define ENVL_WINDOW_HANN 1     /* w_l = (1 + cos(pi l / (order + 1))) / 2 */
#define ENVL_WINDOW_LANCZOS 2  /* w_l = sinc(pi l / (order + 1)) */
#define ENVL_WINDOW_AUTO 3     /* the least windowing that keeps the reconstructed irradiance
                                  non-negative in every channel at 4096 Fibonacci directions:
                                  Hann-type factors (1 + cos(pi l / wd)) / 2
                                  (0 for l >= wd) with the largest width wd that does */
#define ENVL_WINDOW_COUNT 4
ENVL_API const char *envl_window_name(int32_t window);     /* "none", "hann", ... */
ENVL_API int32_t envl_window_from_name(const char *name);  /* -1 if unknown */

/* Output frames (every export's --frame): ENVL_FRAME_BLENDER, the canonical frame (right-handed,
 * +Z up, the default), and ENVL_FRAME_GLTF: right-handed, +Y up, as glTF, OpenGL, three.js and
 * Filament use; a canonical vector (x, y, z) is (x, z, -y) there (Blender's glTF exporter's
 * conversion). The lat-long image is the same in both: u = 0.5 + atan2(z, x) / 2 pi,
 * v = 0.5 - asin(y) / pi (row 0 at the top) in the glTF frame. */
#define ENVL_FRAME_BLENDER 0
#define ENVL_FRAME_GLTF 1
#define ENVL_FRAME_COUNT 2
#define ENVL_MAX_SH_ORDER 32
ENVL_API const char *envl_frame_name(int32_t frame);     /* "blender", "gltf"; NULL if unknown */
ENVL_API int32_t envl_frame_from_name(const char *name); /* -1 if unknown */
/* A canonical vector in `frame` (out may be in). */
ENVL_API void envl_frame_vector(int32_t frame, const double in[3], double out[3]);
/* Real SH coefficients (docs/design.md's basis; index l (l + 1) + m, `channels` interleaved)
 * of a function given in the canonical frame, as its coefficients in `frame`: exact at any
 * order (each band turned by its rotation matrix, integrated by exact quadrature). out may
 * be in. */
ENVL_API envl_result envl_sh_to_frame(int32_t frame, int32_t order, int32_t channels,
                                      const double *in, double *out);

typedef struct envl_sh_options {
    int32_t order;            /* SH order L, 0..32 (ENVL_ORDER_0 for 0); default 2 */
    int32_t window;           /* ENVL_WINDOW_*; default none: the plain truncated expansion,
                                 which can go negative (min_irradiance says); auto cannot
                                 (the CLI's default) */
    int32_t measure;          /* nonzero: also measure diffuse_error (default 0: -1) */
} envl_sh_options;

typedef struct envl_sh_summary {
    int32_t order, window;
    double window_width;      /* Hann-type width used (auto), or order + 1; 0 for none */
    double min_irradiance;    /* least luminance irradiance of the (windowed) reconstruction over
                                 4096 directions */
    double diffuse_error;     /* docs/design.md's measure of the irradiance reconstruction; -1
                                 when options.measure was 0 */
    double seconds;           /* projection + windowing */
    /* Artist forms (irradiance units, canonical frame): E(n) ~ ambient + deltas . n, and the
     * hemispheric pair: E = sky at n = axis, ground at n = -axis, linear between (the least
     * squares best over the sphere with sky, ground >= 0: never negative; where the plain fit
     * ambient -+ deltas . axis has a negative end, that end is 0 and the other
     * (3 ambient + |deltas . axis|) / 2). */
    double ambient[3];
    double deltas[3][3];      /* [x, y, z][r, g, b] */
    double hemi_axis[3];
    double hemi_sky[3], hemi_ground[3];
} envl_sh_summary;

typedef struct envl_sh envl_sh;
ENVL_API envl_result envl_sh_compute(envl_envmap *map, const envl_sh_options *options,
                                     envl_sh **out);
ENVL_API void envl_sh_free(envl_sh *sh);
ENVL_API envl_result envl_sh_get_summary(const envl_sh *sh, envl_sh_summary *out);
/* (order + 1)^2 x RGB: windowed radiance coefficients, and irradiance = A_l x those. */
ENVL_API const double *envl_sh_radiance(const envl_sh *sh);
ENVL_API const double *envl_sh_irradiance(const envl_sh *sh);
ENVL_API const double *envl_sh_window_factors(const envl_sh *sh); /* order + 1 */
/* Radiance / irradiance of the (windowed) expansion in `count` directions. */
ENVL_API envl_result envl_sh_eval_radiance(const envl_sh *sh, int32_t count,
                                           const double *directions, double *rgb_out);
ENVL_API envl_result envl_sh_eval_irradiance(const envl_sh *sh, int32_t count,
                                             const double *normals, double *rgb_out);
/* The basis itself: y[l (l+1) + m] = Y_lm(d) for l = 0..order. */
ENVL_API void envl_sh_basis(int32_t order, const double direction[3], double *y);
ENVL_API double envl_sh_cosine_lobe(int32_t l); /* A_l; 0 for l < 0 (no such band) */

/* ---- prefiltered maps, the split-sum BRDF table, requests (prefilter.c, brdf.c, png.c) ------
 * Conventions (docs/methods.md, "Prefiltered maps"; docs/design.md): every map is a lat-long image in the
 * canonical frame. GGX alpha = roughness^2. The prefiltered specular radiance of roughness r
 * (split sum, N = V = R, Karis 2013) is
 *   P(R) = sum L(l) D(h) max(R.l, 0) dw / sum D(h) max(R.l, 0) dw,  h = normalize(R + l).
 * The specular chain has K levels (default 6); level k has roughness r_k = k / (K - 1) (K = 1:
 * r = 0) and, by default, width max(64, w_0 >> k) (w_0 = 512: 512, 256, 128, 64, 64, 64). A level
 * of any other roughness r gets the size of chain level floor(r (K - 1)) (never coarser). */
#define ENVL_DEFAULT_LEVELS 6

#define ENVL_IRRADIANCE_SPLIT 0     /* default: the bright pixels (the sun split's, more than 50x
                                       the mean luminance) exactly, the rest (at most 2048
                                       wide) through the kernel tree, each texel within 0.5 %
                                       of its E (or of 1 % of the mean, ABI 5; SH order 16
                                       before) */
#define ENVL_IRRADIANCE_SH 1        /* from the SH irradiance of order irradiance_order (fast) */
#define ENVL_IRRADIANCE_EXACT 2     /* envl_irradiance_exact per texel (reference; slow) */
#define ENVL_IRRADIANCE_RESAMPLED 3 /* envl_irradiance_exact per texel over an area-resampled copy
                                       of the map, 256 wide (the default before ABI 3) */
#define ENVL_IRRADIANCE_COUNT 4
/* "split", "sh", "exact", "resampled" */
ENVL_API const char *envl_irradiance_method_name(int32_t method);
ENVL_API int32_t envl_irradiance_method_from_name(const char *name); /* -1 if unknown */

typedef struct envl_prefilter_options {
    int32_t levels;           /* K levels of the chain; default 6 */
    int32_t width;            /* lat-long width of the roughness-0 level; default 512 */
    int32_t min_width;        /* no specular level narrower than this; default 64 */
    int32_t samples;          /* the filtered levels' density, default 64: a level w wide sums
                                 pyramid cells whole from rho = 1 + sqrt(n) / 8 of their widths
                                 from R, n = samples (width / w)^2 within 4 and 8 x samples (rho
                                 3, 3, 3.8 at 512, 256, <= 128 wide); unfiltered: GGX samples per
                                 texel */
    int32_t unfiltered;       /* nonzero: plain GGX importance sampling of the full-resolution
                                 map (no pyramid): the benchmark's baseline */
    int32_t irradiance_method;/* ENVL_IRRADIANCE_*; default SPLIT */
    int32_t irradiance_width; /* lat-long width of the irradiance map; default 64 */
    int32_t irradiance_order; /* ENVL_IRRADIANCE_SH: SH order 0..32 (ENVL_ORDER_0 for 0);
                                 default 2 */
    int32_t threads;          /* default: the map's */
    int32_t sun_lights;       /* nonzero: the bright pixels split off before filtering (more
                                 than 50x the mean luminance: a sun) are not baked into the
                                 levels of roughness > 0 nor into the irradiance map but
                                 returned as lights (envl_products_sun_lights) that the renderer
                                 adds analytically, as engines light with a sun; each product's
                                 error is measured with them added (docs/methods.md, "Prefiltered maps") */
    int32_t half;             /* nonzero: the maps will be stored as IEEE half floats (KTX2,
                                 "ktx2"): each is measured as written, its values rounded to
                                 half and those above ENVL_HALF_MAX written as ENVL_HALF_MAX
                                 (ABI 5); default 0: 32-bit floats */
    int32_t layout;           /* the texels the maps are computed at (ABI 5): ENVL_EXPORT_LATLONG
                                 (default; also ATLAS) lat-long images; ENVL_EXPORT_CUBE (or
                                 CROSS) cube faces of width / 4 texels (irradiance_width / 4),
                                 each texel computed at its own centre direction, held as a
                                 horizontal strip (envl_level.layout ENVL_LAYOUT_STRIP_H): what
                                 envl_products_export writes as cube faces, a cross or KTX2
                                 without resampling */
} envl_prefilter_options;
/* The largest finite IEEE half float: larger values are written as it (KTX2 "ktx2", EXR half). */
#define ENVL_HALF_MAX 65504.0

/* Width of the specular level of `roughness` under `options` (height = width / 2). */
ENVL_API int32_t envl_prefilter_level_width(const envl_prefilter_options *options,
                                            double roughness);

/* The per-texel error of a map product (docs/design.md, "Error measures"): at each texel's
 * centre direction, e = (Y - Y_exact) / max(Y_exact, ENVL_TEXEL_DARK x the mean of Y_exact
 * over the sphere), Y luminance, Y_exact the exact value there (the brute force's, summed
 * within a stated tolerance; roughness 0: the map's mean over the texel); the RMS weighted
 * by the texels' solid angles, and the largest |e|. Over every texel, or over
 * ENVL_TEXEL_SAMPLES of them spread evenly through the image when it has more. */
#define ENVL_TEXEL_DARK 0.01
#define ENVL_TEXEL_SAMPLES 8192
typedef struct envl_texel_error {
    double rms;               /* -1 when not measured */
    double worst;             /* the largest |e| (-1 when not measured) */
    double worst_direction[3];/* that texel's centre direction (canonical frame) */
    int32_t measured, texels; /* texels measured, of all the product has */
} envl_texel_error;

typedef struct envl_level {
    double roughness, alpha;  /* alpha = roughness^2 */
    int32_t width, height;    /* of rgb: the lat-long map, or the strip of six faces (6F x F) */
    const float *rgb;         /* width * height * 3, row 0 = top; owned by the products */
    int32_t samples;          /* filtered: pyramid cells summed per texel (mean); unfiltered: GGX
                                 samples per texel; 0 for roughness 0 (the map resampled by area) */
    int32_t filtered;         /* 1: the cell pyramid's quadrature, 0: plain GGX sampling */
    double energy_scale;      /* the level's texel sum of P dw against the map's integral of
                                 L dw (luminance; the continuous P(R) keeps it exactly): how
                                 well its grid resolves the lobe. Filtered levels are not scaled
                                 by it (each texel is P at its centre, ABI 5); the unfiltered
                                 baseline is scaled to the map's power, per channel */
    double glossy_error;      /* docs/design.md's glossy error (request.measure), else -1 */
    double seconds;           /* to compute the level (the error measure excluded) */
    int32_t layout;           /* ENVL_LAYOUT_LATLONG, or ENVL_LAYOUT_STRIP_H: six cube faces of
                                 height texels side by side, px nx py ny pz nz, each as
                                 docs/design.md's face table (prefilter options.layout) */
    envl_texel_error texel_error; /* request.measure; else rms and worst -1 */
} envl_level;

typedef struct envl_irradiance_map {
    int32_t method, width, height;
    const float *rgb;         /* owned by the products */
    double diffuse_error;     /* docs/design.md's diffuse error (request.measure), else -1 */
    double seconds;
    int32_t layout;           /* as envl_level's */
    envl_texel_error texel_error;
} envl_irradiance_map;

#define ENVL_BRDF_DEFAULT_SIZE 128
#define ENVL_BRDF_DEFAULT_SAMPLES 4096
typedef struct envl_brdf_options {
    int32_t size;             /* table size S x S; default ENVL_BRDF_DEFAULT_SIZE */
    int32_t samples;          /* GGX samples per texel (integrated in double); default
                                 ENVL_BRDF_DEFAULT_SAMPLES */
    int32_t multiscatter;     /* nonzero: the multiscatter form (see envl_brdf_lut) */
    int32_t threads;          /* default: all cores */
} envl_brdf_options;

/* What a scene needs. Zero-initialised = nothing. Products are computed once each, sharing the
 * intermediate work (one SH projection; one cell pyramid, cached on the map, for every specular
 * level). */
typedef struct envl_request {
    int32_t diffuse;          /* diffuse ambient: SH irradiance coefficients of order sh_order,
                                 window auto (non-negative; so is an SH irradiance map) */
    int32_t irradiance_map;   /* an irradiance map (prefilter.irradiance_*) */
    int32_t mirror;           /* mirror reflections / background: the roughness-0 level */
    int32_t shadows;          /* lights for shadows (options in `lights`) */
    int32_t specular_chain;   /* all K levels of the chain */
    int32_t n_roughness;      /* glossy reflections at these roughness values (0..1): one level
                                 each, nothing else */
    const double *roughness;
    int32_t brdf_lut;         /* the split-sum table (options in `brdf`) */
    int32_t measure;          /* nonzero: also measure the diffuse / glossy error of each
                                 product (docs/design.md, "Error measures") */
    int32_t sh_order;         /* diffuse: SH order 0..32 (ENVL_ORDER_0 for 0); default 2 */
    envl_prefilter_options prefilter;
    envl_lights_options lights;
    envl_brdf_options brdf;
} envl_request;

/* What a call computed: counters that show the sharing, and times. */
typedef struct envl_products_summary {
    int32_t sh_projections;   /* SH passes over the map (0 or 1) */
    int32_t pyramids_built;   /* cell pyramids built by this call (0: none needed, or cached) */
    int32_t pyramid_levels;   /* levels of the map's pyramid (0 if it has none) */
    int32_t specular_levels;  /* levels computed */
    int32_t irradiance_maps, lights_computed, brdf_tables;
    double seconds;           /* everything (error measures excluded) */
    double seconds_sh, seconds_pyramid, seconds_specular, seconds_irradiance, seconds_lights,
        seconds_brdf;
    int32_t prefiltered_width, prefiltered_height; /* the map the products were computed
                                 from: the map's own size, or the finer copy that a map too
                                 coarse for the GGX sums (each pixel a point at its centre:
                                 fewer than 16 columns or 8 rows, pixels more than twice as
                                 wide as tall or as tall as wide) is split into first (ABI 5) */
} envl_products_summary;

typedef struct envl_products envl_products;
ENVL_API envl_result envl_compute(envl_envmap *map, const envl_request *request,
                                  envl_products **out);
ENVL_API void envl_products_free(envl_products *products);
ENVL_API envl_result envl_products_get_summary(const envl_products *products,
                                               envl_products_summary *out);
/* Specular levels: the mirror level first (if asked and not in the chain), then the chain in
 * order, then the requested roughness values not already computed, in the order given. */
ENVL_API int32_t envl_products_level_count(const envl_products *products);
ENVL_API envl_result envl_products_level(const envl_products *products, int32_t index,
                                         envl_level *out);
/* What a level's accuracy costs (docs/design.md, "Level width for 1 %"): measured with the
 * errors (request.measure) for each filtered level of roughness > 0 whose glossy error is
 * over ENVL_GLOSSY_TARGET, the narrowest width (within 5 %) from which the same level's glossy
 * error, read at the 1024 directions from texels computed there as the level computes them,
 * meets it (there and 5 % and 10 % wider); the time estimated from the level's own seconds
 * per texel. */
#define ENVL_GLOSSY_TARGET 0.01
#define ENVL_WIDTH_NOT_ESTIMATED 0 /* no errors measured, roughness 0, or the unfiltered baseline */
#define ENVL_WIDTH_MET 1           /* the level's glossy error is within the target already */
#define ENVL_WIDTH_FOUND 2         /* width, size, glossy_error, seconds: where it is met */
#define ENVL_WIDTH_BEYOND 3        /* not met up to the largest size (65536 lat-long texels):
                                      width, size, glossy_error, seconds are that size's */
typedef struct envl_width_estimate {
    int32_t state;            /* ENVL_WIDTH_* */
    int32_t width;            /* the level's width there: lat-long width, or the face size
                                 for cube faces (envl_level.layout ENVL_LAYOUT_STRIP_H) */
    int32_t size;             /* envl_prefilter_options.width that makes the level that wide
                                 in the same request (width << k, x 4 for faces) */
    double glossy_error;      /* the glossy error read there */
    double seconds;           /* estimated: the level's seconds x texels there / texels now */
    int32_t widths_tried;     /* widths the search read */
    int32_t directions_read;  /* of the 1024 error directions, those read at each (the ones
                                 that carry the level's error) */
    double seconds_spent;     /* the search's own time */
} envl_width_estimate;
ENVL_API envl_result envl_products_level_width(const envl_products *products, int32_t index,
                                               envl_width_estimate *out);
/* Index of the level of exactly `roughness` (-1 if none). */
ENVL_API int32_t envl_products_find_level(const envl_products *products, double roughness);
/* ENVL_ERR_ARGUMENT when the product was not requested. */
ENVL_API envl_result envl_products_irradiance(const envl_products *products,
                                              envl_irradiance_map *out);
ENVL_API const envl_sh *envl_products_sh(const envl_products *products);       /* or NULL */
ENVL_API const envl_lights *envl_products_lights(const envl_products *products); /* or NULL */
/* With options.sun_lights: the split-off bright pixels, one light per 8-connected group (the
 * roughness-0 level keeps them: a light's mirror reflection is a delta no renderer draws).
 * rgb = sum of the excess L dw, direction = the luminance-weighted centroid, solid_angle = the
 * uniform disc of the same spread. A renderer adds, per light, E max(n.l, 0) to the irradiance
 * map and E w(R.l) / N(alpha) to a level's P(R), w(u) = u / q^2, q = ((1 + u) / 2)(alpha^2 - 1) +
 * 1, N = envl_ggx_lobe_norm. NULL (count 0) when none were split or not asked. */
ENVL_API const envl_light *envl_products_sun_lights(const envl_products *products,
                                                    int32_t *count);
/* N(alpha) = integral over the sphere of w(R.l) above (pi at alpha = 1). */
ENVL_API double envl_ggx_lobe_norm(double alpha);
/* The BRDF table (size x size x 2 floats) or NULL. */
ENVL_API const float *envl_products_brdf(const envl_products *products, int32_t *size,
                                         int32_t *multiscatter);

/* One specular level on its own: roughness in [0, 1], lat-long width x width/2 (0: by the
 * options' mapping). *rgb is allocated (envl_free). */
ENVL_API envl_result envl_prefilter_specular(envl_envmap *map, double roughness, int32_t width,
                                             const envl_prefilter_options *options, float **rgb,
                                             envl_level *stats);
/* The map's area-averaged mip pyramid (level 0 = the map, each next level half the size, down
 * to 1 x 1; levels wider than 4096 are not kept: the products read the map there), built once
 * and cached on the map; envl_envmap_drop_mips frees it and the specular
 * levels' cell pyramid (docs/methods.md), cached the same way. */
ENVL_API envl_result envl_envmap_mips(envl_envmap *map, int32_t *levels);
ENVL_API void envl_envmap_drop_mips(envl_envmap *map);

/* The brute-force reference: P(R) above summed over every pixel of the map, in double, for
 * `count` unit directions (roughness 0: the pixel that contains R). */
ENVL_API envl_result envl_prefilter_reference(const envl_envmap *map, double roughness,
                                              int32_t count, const double *directions,
                                              double *rgb_out);
/* Bilinear lookup of a lat-long RGB image in a direction (wraps in azimuth, clamps rows). */
ENVL_API void envl_latlong_sample(const float *rgb, int32_t width, int32_t height,
                                  const double direction[3], double out[3]);
/* docs/design.md's glossy error of a lat-long level (sampled bilinearly) against the reference at
 * the 1024 Fibonacci directions. */
ENVL_API envl_result envl_glossy_error(const envl_envmap *map, double roughness,
                                       const float *rgb, int32_t width, int32_t height,
                                       double *error);

/* Split-sum BRDF table (GGX, height-correlated Smith visibility), integrated in double by GGX
 * importance sampling (Hammersley). Texel (i, j), j = row from the top: NoV = (i + 0.5) / S,
 * roughness = (j + 0.5) / S (alpha = roughness^2); uploaded as is (first row at v = 0) it is
 * sampled at (u, v) = (NoV, roughness). Channels:
 *   single scatter: (A, B), Karis's scale and bias: specular = F0 A + B,
 *     A = int (1 - Fc) f NoL dl / F, B = int Fc f NoL dl / F, Fc = (1 - VoH)^5;
 *   multiscatter: (B, A + B) = (DFG1, DFG2): single scatter = mix(DFG1, DFG2, F0), and the
 *     energy compensation of Turquin 2019 / Fdez-Aguera 2019 (as Filament applies it):
 *     specular *= 1 + F0 (1 / (A + B) - 1).
 * *rg gets size * size * 2 floats (envl_free). */
ENVL_API envl_result envl_brdf_lut(const envl_brdf_options *options, float **rg,
                                   int32_t *size);
/* One value of the single-scatter (A, B) at (NoV, roughness), `samples` (0: 4096). */
ENVL_API envl_result envl_brdf_eval(double nov, double roughness, int32_t samples,
                                    double ab[2]);

/* RGBM with range M (the atlas uses 6): rgb = M * rgbm.rgb * rgbm.a; a = ceil(255 max(rgb) /
 * M) / 255 (values above M clamp to M), rgbm.rgb = round(255 rgb / (M a)). */
#define ENVL_RGBM_RANGE 6.0
ENVL_API void envl_rgbm_encode(const float rgb[3], double range, uint8_t rgbm[4]);
ENVL_API void envl_rgbm_decode(const uint8_t rgbm[4], double range, float rgb[3]);
/* RGBD, Babylon.js's packing that EXT_lights_image_based names for its PNG faces (its shaders'
 * toRGBD / fromRGBD): D = min(floor(max(255 / max(rgb), 1)), 255) / 255, rgbd.rgb =
 * round(255 (rgb D)^(1 / 2.2)) / 255, rgbd.a = D; decode rgb = rgbd.rgb^2.2 / rgbd.a. Values
 * above 255 clamp; below 1 the bytes are plain gamma 2.2 (D = 1). */
ENVL_API void envl_rgbd_encode(const float rgb[3], uint8_t rgbd[4]);
ENVL_API void envl_rgbd_decode(const uint8_t rgbd[4], float rgb[3]);
/* PNG files (libpng), written atomically: RGBM RGBA8, or RGB8 sRGB-encoded (values clamped to
 * [0, 1], sRGB chunk). */
ENVL_API envl_result envl_png_save_rgbm(const char *path, const float *rgb, int32_t width,
                                        int32_t height, double range);
ENVL_API envl_result envl_png_save_srgb(const char *path, const float *rgb, int32_t width,
                                        int32_t height);

/* Export of products into a directory (docs/methods.md, "Files and layouts", gives names and layouts). All
 * files are written to temporaries first and renamed only when every one is complete, so a
 * failed export leaves existing files as they were. A JSON sidecar `prefilter.json` states the
 * conventions (frame, roughness mapping, RGBM range, layout) and every file. */
#define ENVL_EXPORT_LATLONG 0
#define ENVL_EXPORT_CUBE 1     /* six files per map: _px _nx _py _ny _pz _nz (canonical axes) */
#define ENVL_EXPORT_CROSS 2    /* vertical cross, as envl_envmap_to_layout */
#define ENVL_EXPORT_ATLAS 3    /* the specular levels in one image (docs/methods.md) */
#define ENVL_EXPORT_COUNT 4
ENVL_API const char *envl_export_layout_name(int32_t layout); /* "latlong", "cube", ... */
ENVL_API int32_t envl_export_layout_from_name(const char *name);
typedef struct envl_export_options {
    const char *format;       /* "exr" (default, float), "hdr", "pfm", "rgbm-png", "ktx2" (one
                                 KTX 2.0 cube map per map, RGBA half float, the specular levels
                                 as mip levels; needs layout ENVL_EXPORT_CUBE and frame
                                 ENVL_FRAME_GLTF), "ktx2-float" (the same, 32-bit float) */
    int32_t layout;           /* ENVL_EXPORT_*; default lat-long */
    int32_t frame;            /* ENVL_FRAME_*; default Blender's. glTF: cube faces in OpenGL's
                                 order and orientation, sun light directions turned; the cross
                                 is Blender's only (ABI 4) */
} envl_export_options;
ENVL_API envl_result envl_products_export(const envl_products *products, const char *dir,
                                          const envl_export_options *options);

/* ---- glTF 2.0 (gltf.c; docs/methods.md, "glTF") ----------------------------------------------
 * One file, .glb (binary) or .gltf (JSON, images as data URIs), for an engine: the map's suns
 * (lights.method, default ENVL_METHOD_SUN) as KHR_lights_punctual directional lights, and what
 * they did not take (the residual, so nothing is lit twice) as the EXT_lights_image_based
 * light of the scene: its SH irradiance of order 2 (irradianceCoefficients, 9 x RGB) and its
 * GGX specular chain as cube faces, mip k of M the roughness k / (M - 1), face size
 * face_size >> k, RGBD PNGs. Everything is in glTF's frame (+Y up; ENVL_FRAME_GLTF). Units:
 * the map's radiance (taken as cd/m^2: the lights' intensity is then lux). */
typedef struct envl_gltf_options {
    int32_t face_size;        /* specularImageSize: a power of two, 16..4096; default 256 */
    int32_t mips;             /* specular mips (roughness k / (mips - 1)), 2.. log2(face_size)
                                 + 1; default: down to 16 x 16 (5 at 256) */
    int32_t no_lights;        /* nonzero: no punctual light, the whole map is the IBL */
    const envl_lights_options *lights; /* NULL: the suns (ENVL_METHOD_SUN, at most 4); any
                                   method: the IBL is the map less what the lights took */
    int32_t samples;          /* the specular levels' density (envl_prefilter_options) */
    int32_t measure;          /* nonzero: measure the errors of the summary (default 0: -1) */
    int32_t threads;          /* default: the map's */
} envl_gltf_options;

typedef struct envl_gltf_summary {
    int32_t lights;           /* punctual lights written */
    int32_t face_size, mips;
    double intensity;         /* the IBL's intensity: the stored faces and coefficients are the
                                 residual / intensity (its brightest texel stored as 255) */
    double diffuse_error;     /* docs/design.md's diffuse error of the lights + the SH
                                 irradiance against the whole map's exact irradiance; -1 when
                                 not measured */
    double glossy_error[16];  /* mip k's glossy error (its float cube faces read bilinearly,
                                 against the residual's reference); -1 when not measured */
    double rgbd_error;        /* largest relative RMS (luminance) over the mips of the decoded
                                 RGBD faces against the float faces they encode (none clamps:
                                 intensity is the chain's largest value / 255) */
    int64_t bytes;            /* of the file */
    double seconds;           /* everything (the error measures excluded) */
    envl_texel_error texel_error[16]; /* mip k's per-texel error (its float faces, each texel
                                 computed at its centre, against the residual's reference) */
    int32_t prefiltered_width, prefiltered_height; /* the map the mips were computed from: the
                                 map's own size, or a finer copy of a map too coarse for the GGX
                                 sums (envl_products_summary's) */
} envl_gltf_summary;

/* Writes `path` (.glb or .gltf) atomically. summary (may be NULL) gets the figures above. */
ENVL_API envl_result envl_gltf_export(envl_envmap *map, const char *path,
                                      const envl_gltf_options *options,
                                      envl_gltf_summary *summary);

/* ---- the preview picture (docs/methods.md, "Preview") ----------------------------------------------- */
/* One sRGB PNG: the lat-long map with the median cut regions and the median cut and fitted
 * lights marked, then spheres (rows: diffuse, glossy at two roughness values, mirror) lit by
 * the exact reference and by each approximation in the rows it serves (median cut, fit + SH
 * remainder, SH order 2, prefiltered maps), each with its error and seconds under it. */
#define ENVL_PREVIEW_TONEMAP_ACES 0         /* Narkowicz 2015 fit of the ACES filmic curve */
#define ENVL_PREVIEW_TONEMAP_REINHARD 1     /* x / (1 + x) */
#define ENVL_PREVIEW_DIFFUSE_LAMBERT 0
#define ENVL_PREVIEW_DIFFUSE_OREN_NAYAR 1   /* Oren & Nayar 1994 qualitative model, sigma 0.3 */
#define ENVL_PREVIEW_SPECULAR_GGX 0
#define ENVL_PREVIEW_SPECULAR_BLINN_PHONG 1 /* exponent 2 / alpha^2 - 2 (Walter et al. 2007) */
typedef struct envl_preview_options {
    int32_t median_count;     /* median cut lights, 1..4096; default 16 */
    int32_t fit_count;        /* fitted lights, 1..32; default 4 */
    int32_t tonemap;          /* ENVL_PREVIEW_TONEMAP_*; default ACES */
    int32_t exposure_set;     /* nonzero: exposure_ev is used, else automatic (Reinhard 2002's
                                 key: EV = log2(0.18 / log-average luminance)) */
    double exposure_ev;       /* display = tonemap(2^EV x radiance), -64..64 */
    int32_t diffuse;          /* ENVL_PREVIEW_DIFFUSE_*; default Lambert */
    int32_t specular;         /* ENVL_PREVIEW_SPECULAR_*; default GGX */
    double roughness[2];      /* the glossy rows, 0.05..1 (alpha = r^2); default 0.25, 0.5 */
    int32_t sphere_size;      /* pixels, 48..512; default 96 */
    int32_t reference_width;  /* lat-long width, even, 16..4096, of the copy the diffuse and
                                 glossy references sum over; default 256 */
    const char *title;        /* printed at the top (the file name); NULL: none */
} envl_preview_options;
/* Computes the products and the references, draws the picture and writes it to `path` as an
 * sRGB PNG (atomically; libpng). `options` NULL: the defaults. `notes` (may be NULL) gets, once
 * all is computed, one line per approximation (the texts under its spheres, docs/design.md's
 * diffuse error of its product) and one about the references. *width, *height (may be NULL):
 * the picture's size, 80 + 5 (S + 24) + 8 by 66 + (width - 16) / 2 + 4 (S + 28). */
ENVL_API envl_result envl_preview_write(envl_envmap *map, const envl_preview_options *options,
                                        const char *path, FILE *notes, int32_t *width,
                                        int32_t *height);

/* ---- POV-Ray 3.7 include (pov_include.c; docs/methods.md, "POV-Ray") --------------------------------
 * An include for povray_include/envlight.inc: the lights (directions, colours rgb / pi), the
 * ambient the lights did not take, the sky; then the macro calls that place them. POV-Ray's
 * frame is left-handed, +Y up: a canonical vector (x, y, z) is written <x, z, y>. Its header
 * states the source, the recipe and why, the lights, the ambient and its least value, the
 * diffuse error of lights + ambient as written (docs/design.md's measure) and the seconds.
 * The recipes (docs/scene_bench_pov.md measured them in scenes): */
#define ENVL_POV_RECIPE_AUTO 0            /* from the scene (scene_path; none: objects that
                                             shadow others assumed): sh or dome */
#define ENVL_POV_RECIPE_CUSTOM 1          /* the low-level fields as given (method, count,
                                             ambient, order: fit 4 + SH order 2 by default);
                                             AUTO becomes this when one of them is set (but
                                             see recipe_is_set) */
#define ENVL_POV_RECIPE_SH 2              /* 4 fitted lights + the SH ambient (exact where
                                             nothing is occluded) */
#define ENVL_POV_RECIPE_DOME 3            /* 48 or 64 variance-cut lights (the fewer within
                                             1 % diffuse error) with shadows, + radiosity with
                                             no sky for the bounces when there are several
                                             objects */
#define ENVL_POV_RECIPE_DOME_AMBIENT 4    /* 64, 128 or 256 median-cut lights (within 0.5 %)
                                             + the ground's bounce as an ambient, no radiosity */
#define ENVL_POV_RECIPE_IMAGE_RADIOSITY 5 /* 4 fitted lights + the residual sky under
                                             radiosity (implies sky_residual) */
#define ENVL_POV_RECIPE_COUNT 6
/* "auto", "custom", "sh", "dome", "dome-ambient", "image-radiosity"; NULL for an unknown value. */
ENVL_API const char *envl_pov_recipe_name(int32_t recipe);
ENVL_API int32_t envl_pov_recipe_from_name(const char *name); /* -1 if unknown */

#define ENVL_POV_AMBIENT_AUTO 0     /* the recipe's: custom and sh: SH; dome-ambient: the
                                       ground's bounce (SH order 1) with a ground, else none;
                                       dome and image-radiosity: none */
#define ENVL_POV_AMBIENT_SH 1       /* the SH ambient as slope-pattern pigments (no radiosity) */
#define ENVL_POV_AMBIENT_HEMI 2     /* its hemispheric form (sky, ground, axis: the pair of
                                       envl_sh_summary, never negative) */
#define ENVL_POV_AMBIENT_NONE 3
#define ENVL_POV_SHADOWS_AUTO 0     /* default: the recipe's: a dome's lights soft, every other
                                       light hard (ABI 5; HARD was 0 before) */
#define ENVL_POV_SHADOWS_SOFT 1     /* area lights: a dome's light shaped as the sky it stands for
                                       (its region's spread), any other a disc of its angular
                                       diameter */
#define ENVL_POV_SHADOWS_NONE 2     /* shadowless lights */
#define ENVL_POV_SHADOWS_HARD 3     /* point lights: hard shadows (a dome's draw rings) */
#define ENVL_POV_EXPOSURE_AUTO (-1.0) /* envl_pov_options.exposure: a white surface facing up,
                                         unshadowed, reads 0.6 (for an 8-bit image) */
#define ENVL_POV_MAX_ORDER 8        /* the ambient's largest SH order */

typedef struct envl_pov_options {
    int32_t recipe;           /* ENVL_POV_RECIPE_*; default AUTO */
    int32_t recipe_is_set;    /* nonzero: recipe was asked for, so AUTO picks from the scene
                                 even when a low-level field (method, count, ambient, order) is
                                 set, and they adjust the recipe picked; 0: AUTO with one of
                                 them set is CUSTOM */
    const char *scene_path;   /* the .pov scene the include is for: what it uses (shadows
                                 between objects, glossy finishes, a ground plane and its
                                 colour, radiosity) picks the recipe (AUTO) and the ground. Read
                                 tolerantly (no macro expansion, no #include followed); a scene
                                 it cannot read is a warning and the defaults apply; default
                                 NULL: none */
    int32_t method;           /* ENVL_METHOD_FIT, _MEDIAN or _VARIANCE, used when method_is_set;
                                 default: the recipe's (dome: variance, dome-ambient: median,
                                 the others fit) */
    int32_t method_is_set;    /* nonzero: method is used */
    int32_t count;            /* lights, 1..65536 (fit 1..32); default: the recipe's (4; the
                                 domes by their error, see the recipes) */
    int32_t ambient;          /* ENVL_POV_AMBIENT_*; default AUTO */
    int32_t order;            /* SH order of the ambient (fit: of its remainder), 1..8 or
                                 ENVL_ORDER_0; ENVL_REMAINDER_NONE: a fit without remainder (the
                                 ambient is then the SH of its residual, order 2); default 2 (a
                                 fit with ambient none: no remainder) */
    int32_t ground_plane;     /* nonzero: the scene stands on a plane (canonical z = 0, POV-Ray
                                 y = 0) of albedo ground_albedo: lights, ambient and error are
                                 those of the map with its lower hemisphere the plane's radiance
                                 albedo E_up / pi (envl_ground_plane_map); a dome takes its
                                 lights from the sky half. Default 0: the scene's plane if it
                                 has one (its literal colour's luminance, else 0.5), else none;
                                 image-radiosity uses none (radiosity bounces the scene's) */
    double ground_albedo;     /* 0..1, with ground_plane */
    int32_t shadows;          /* ENVL_POV_SHADOWS_*; default AUTO */
    int32_t sky;              /* nonzero: declare the environment as a sky_sphere
                                 (EnvLight_Sky(); under a dome's radiosity a backdrop) */
    int32_t sky_residual;     /* nonzero: the sky shows the residual (what the lights did not
                                 take); implies sky */
    const char *sky_image;    /* where the sky's lat-long .hdr is written (atomically); default:
                                 the include's path without ".inc" + "_sky.hdr", or, for a map
                                 read from a lat-long .hdr (without apply_exposure), that file
                                 itself; the include names it by its absolute path */
    double scene_radius;      /* lights are placed at 2000 R from the scene centre; default 100 */
    double exposure;          /* the default of EnvLight_Exposure, which scales everything
                                 envlight adds: > 0, or ENVL_POV_EXPOSURE_AUTO; default 0: not
                                 declared (envlight.inc's 1: the map's radiometry) */
    int32_t no_place;         /* nonzero: only declare; the scene calls EnvLight_Place_Lights()
                                 etc. itself */
    const char *source;       /* the map's name in the include (EnvLight_Source, the header);
                                 default: the file it was read from (envl_info.file), "sky"
                                 for the built-in sky, "memory" for pixels from memory */
    const char *command;      /* the header's "// command: " line (control characters shown as
                                 '?'); default "envl_pov_include_write" */
    int32_t threads;          /* worker threads; default: all cores */
} envl_pov_options;

typedef struct envl_pov_result {
    int32_t recipe;           /* the recipe written (never AUTO). On failure the fields of
                                 the plan (recipe, reason, method, count, ambient, bounce) are
                                 set once it was made, the others are 0 */
    char reason[320];         /* why that recipe, as the header's "// recipe:" line says */
    int32_t method, count;    /* the lights' */
    int32_t ambient;          /* ENVL_POV_AMBIENT_SH, _HEMI or _NONE, as written */
    int32_t ambient_order;    /* SH order of the ambient; -1 without one */
    int32_t ambient_terms;    /* its slope-pattern terms (ridge functions); 0 without one */
    double ambient_least;     /* the ambient's least irradiance in a channel at 4096 Fibonacci
                                 normals (0 without one) */
    int32_t ambient_negative; /* of those normals, how many see it negative in some channel
                                 (the fit's remainder as fitted; also a warning) */
    int32_t bounce;           /* 1: radiosity carries the bounces (a dome among objects) */
    int32_t ground_plane;     /* 1: a ground plane was used (ground_plane or the scene's) */
    double ground_albedo;     /* its albedo (0 without) */
    double ground_radiance[3];/* its radiance albedo E_up / pi (0 without) */
    double diffuse_error;     /* lights + ambient as written against the exact irradiance
                                 (docs/design.md); under bounce, of the sky the lights take */
    double exposure_auto;     /* the exposure at which a white surface facing up reads 0.6 */
    double seconds;           /* the computation (the scene's reading and the writing excluded) */
    int32_t no_light;         /* 1: the map is black (also a warning) */
    char *sky_file;           /* the sky image the include names, NULL without a sky */
    char *text;               /* path NULL: the include itself (NUL-terminated), else NULL */
    char *warnings;           /* the warnings, one a line, each ended by '\n' (control
                                 characters shown as \xHH); NULL when there are none */
} envl_pov_result;

/* Writes the include to `path` atomically (an existing file is replaced whole or left as it
 * was) or, path NULL, returns it in result->text; the sky image, when asked for, is written
 * first, atomically. `result` (may be NULL) is zeroed, then receives what was written and the
 * warnings (on failure, those met before it); release its strings with envl_pov_result_free.
 * Names with control characters cannot be written into the include (ENVL_ERR_ARGUMENT). */
ENVL_API envl_result envl_pov_include_write(envl_envmap *map, const envl_pov_options *options,
                                           const char *path, envl_pov_result *result);
/* Frees the result's strings (sky_file, text, warnings) and sets them to NULL; NULL-safe. */
ENVL_API void envl_pov_result_free(envl_pov_result *result);

#ifdef __cplusplus
}
#endif
#endif
