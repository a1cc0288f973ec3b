/* Private declarations shared by the library's files. Not installed. */
#ifndef ENVL_INTERNAL_H
#define ENVL_INTERNAL_H

#include "envlight.h"

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* Rec. 709 luminance (docs/design.md), inline for the per-pixel loops; envl_luminance is the same
 * formula for callers of the library. */
static inline double envl__lum(double r, double g, double b)
{
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

/* Van der Corput radical inverse in base 2 (bit reversal): the second coordinate of the
 * Hammersley point set used by the GGX samplers (prefilter.c, brdf.c). */
static inline double envl__radical_inverse(uint32_t i)
{
    i = (i << 16) | (i >> 16);
    i = ((i & 0x55555555u) << 1) | ((i & 0xAAAAAAAAu) >> 1);
    i = ((i & 0x33333333u) << 2) | ((i & 0xCCCCCCCCu) >> 2);
    i = ((i & 0x0F0F0F0Fu) << 4) | ((i & 0xF0F0F0F0u) >> 4);
    i = ((i & 0x00FF00FFu) << 8) | ((i & 0xFF00FF00u) >> 8);
    return (double)i * (1.0 / 4294967296.0);
}

/* ---- errors (error.c) ---- */
/* Records "printf-style message" as this thread's last error and returns `code`. */
envl_result envl__fail(envl_result code, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
/* Prefixes the current message with "prefix: " (e.g. the file name) and returns `code`. */
envl_result envl__fail_prefix(envl_result code, const char *prefix);
/* The message is about `name`, written through the temporary file `tmp`: a leading "tmp: "
 * becomes "name: ", else "name: " is prefixed. Returns `code`. */
envl_result envl__fail_as(envl_result code, const char *name, const char *tmp);

/* ---- images as read from files (image.c) ---- */
/* What a file said about itself, beyond its pixels. */
typedef struct envl_file_meta {
    char format[8];         /* "hdr", "exr", "pfm" */
    int32_t channels;       /* channels the file holds: 1 (Y / grey), 3, 4 (RGBA), 2 (YC...) */
    double exposure;        /* product of Radiance EXPOSURE lines; 1 if none */
    int32_t has_primaries;
    float primaries[8];     /* xy of R, G, B, white */
    int32_t envmap_layout;  /* ENVL_LAYOUT_EXR_LATLONG / _EXR_CUBE from the EXR envmap attribute,
                               else 0 */
    int32_t block_x0, block_y0; /* where the lossy codec's 8 x 8 blocks start in the image
                               (DWAA / DWAB: the data window's origin, modulo 8), else 0, 0 */
    int32_t finite_nonnegative; /* every value is finite and >= 0 by the format's construction
                               (RGBE): the loader need not look for NaN, Inf or negatives */
} envl_file_meta;

/* A decoded image: RGB floats, row 0 = top of the image as displayed. */
typedef struct envl_image {
    int32_t width, height;
    float *px;              /* width * height * 3 */
    envl_file_meta meta;
} envl_image;

/* Limits a reader applies before it allocates. */
typedef struct envl_limits {
    int64_t max_pixels;     /* refuse headers that claim more; > 0 */
    const char *exr_part;   /* NULL: first part with colour channels */
    int32_t threads;        /* decoding threads; 0: all cores */
} envl_limits;

/* Allocates img->px for w x h (checks w, h > 0, the limit and size_t overflow first). The error
 * message names `what` (the file). Zero-filled. */
envl_result envl__image_alloc(envl_image *img, int32_t w, int32_t h, const envl_limits *lim,
                              const char *what);
void envl__image_free(envl_image *img);
/* Hints that a large fresh buffer be backed by 2 MiB pages (Linux madvise MADV_HUGEPAGE over
 * its aligned span; nothing elsewhere or under 4 MiB). Contents unchanged. */
void envl__huge_pages(void *p, size_t bytes);

/* ENVL_ERR_UNSUPPORTED, the message naming `what`, when this build lacks the format "exr" or
 * "png" (CMake ENVL_OPENEXR / ENVL_PNG OFF, and always the Blender add-on's copy of the library:
 * then exr.c is not compiled and png.c keeps only its RGBM code); ENVL_OK otherwise. */
envl_result envl__format_built(const char *what, const char *format);

/* ---- input files read by offset (infile.c): what a streaming reader keeps of a file ---- */
typedef struct envl_infile {
    int fd;
    uint64_t size;          /* bytes, at open */
    int64_t mtime_ns;       /* modification time at open */
    const char *path;       /* for messages */
} envl_infile;
/* Opens a regular, non-empty file of at most max_bytes (refuses directories, empty and larger
 * files). */
envl_result envl__infile_open(const char *path, uint64_t max_bytes, envl_infile *f);
/* Exactly n bytes at `offset` into buf (any thread); a short file is ENVL_ERR_IO naming it. */
envl_result envl__infile_read(const envl_infile *f, uint64_t offset, void *buf, size_t n);
/* ENVL_ERR_IO when the file's size or modification time changed since it was opened. */
envl_result envl__infile_unchanged(const envl_infile *f);
void envl__infile_close(envl_infile *f);

/* ---- readers: whole file in memory, `name` only for messages (hdr.c, exr.c, pfm.c) ---- */
envl_result envl__read_hdr(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out);
envl_result envl__read_exr(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out);
envl_result envl__read_pfm(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out);
/* The same readers on an open file, read by offset: the file is never wholly in memory (hdr:
 * windows of a few MiB; exr: the chunks being decoded). */
envl_result envl__read_hdr_file(const envl_infile *f, const envl_limits *lim, envl_image *out);
envl_result envl__read_exr_file(const envl_infile *f, const envl_limits *lim, envl_image *out);
/* Detects the format from the first bytes; reads. */
envl_result envl__read_image_memory(const uint8_t *data, size_t size, const char *name,
                                    const envl_limits *lim, envl_image *out);
envl_result envl__read_image_file(const char *path, const envl_limits *lim, envl_image *out);

/* ---- writers (rgb: w x h x 3 floats, row 0 = top); write straight to `path` — callers go
 * through envl_image_save, which writes a temporary file and renames it ---- */
envl_result envl__write_hdr(const char *path, const float *rgb, int32_t w, int32_t h);
/* envmap: ENVL_LAYOUT_EXR_LATLONG / _EXR_CUBE, written as the `envmap` attribute; 0: none */
envl_result envl__write_exr(const char *path, const float *rgb, int32_t w, int32_t h,
                            int32_t pixel_type, int32_t envmap);
envl_result envl__write_pfm(const char *path, const float *rgb, int32_t w, int32_t h);

/* ---- file names (paths.c) ---- */
/* `name` made absolute, the symbolic links of the part that exists resolved, ".", ".." and
 * repeated slashes of the rest taken out (malloc'd; NULL when out of memory). */
char *envl__normalised_path(const char *name);
/* The path of `to` relative to the folder `from`, both normalised ("../x/y.hdr"; "." for the
 * folder itself). malloc'd; NULL when out of memory. */
char *envl__relative_path(const char *from, const char *to);

/* ---- files (io.c) ---- */
/* Reads a whole regular file (envl__infile_open's refusals). Caller frees. */
envl_result envl__read_file(const char *path, size_t max_bytes, uint8_t **data, size_t *size);
/* Every temporary file of the writers is DIR/.envl-PID-..., PID the writing process's. */
#define ENVL__TEMP_PREFIX ".envl-"
/* Removes the temporaries in `dir` (NULL or "": the working folder) that processes which are
 * gone left behind (a SIGKILL): this user's regular files named .envl-PID-..., PID not this
 * process's and either not running on this host or unchanged for a day (io.c). Best effort:
 * nothing is reported. Called by every writer before it writes into a folder. */
void envl__remove_stale_temporaries(const char *dir);
/* Atomic replace: *tmp_path gets a fresh unique name in path's directory (caller frees). */
envl_result envl__atomic_begin(const char *path, char **tmp_path);
/* Renames tmp over path (on failure removes tmp). `ok` false: just removes tmp. */
envl_result envl__atomic_end(const char *path, char *tmp_path, bool ok);
/* Test-only fault injection. Every step that writes a file (create, write, close, rename) in
 * every writer (io.c, hdr.c, pfm.c, exr.c; png.c through io.c) first calls envl__io_fault():
 * it counts the steps of this thread in envl__io_calls, and step number envl__io_fail_at
 * (1-based) fails as on a full disk: it returns true with errno = ENOSPC. 0 (the default):
 * nothing fails. Used by tests/test_writers.c and fuzz/fuzz_writers.c. */
extern _Thread_local int64_t envl__io_fail_at, envl__io_calls;
bool envl__io_fault(void);
/* Closes a file a writer wrote through stdio: err (an errno of an earlier write, 0 if none) or
 * the close's own failure becomes ENVL_ERR_IO naming `path`; else ENVL_OK. */
envl_result envl__close_written(FILE *f, const char *path, int err);

/* ---- layouts (layout.c) ---- */
/* Guesses the layout of an image from metadata and aspect ratio. */
int32_t envl__guess_layout(const envl_image *img);
/* Resamples src in `layout` into a canonical lat-long image `out_width` x out_width/2,
 * area-weighted (each output pixel averages the input over its footprint). */
envl_result envl__layout_to_latlong(const envl_image *src, int32_t layout, int32_t out_width,
                                    envl_image *out);
/* The inverse, for tests and `envlight convert`: renders a canonical lat-long image into
 * `layout` with face size / probe diameter `size`. */
envl_result envl__latlong_to_layout(const envl_image *latlong, int32_t layout, int32_t size,
                                    envl_image *out);
/* The six faces of a horizontal strip (ENVL_LAYOUT_STRIP_H, or ENVL__LAYOUT_GL_STRIP: OpenGL's
 * faces of the glTF frame) rendered from a lat-long image: *out (malloc'd) holds them one after
 * another in the strip's order, each `face` x `face` RGB texels, row 0 first. */
envl_result envl__latlong_to_faces(const envl_image *latlong, int32_t strip, int32_t face,
                                   float **out);
/* Default lat-long width for an image read in `layout`. */
int32_t envl__default_latlong_width(const envl_image *src, int32_t layout);
/* Solid angle of pixel (i, j) of a w x h image in `layout`: for LATLONG the exact one of its
 * row, for the others dw/dA at the pixel's centre times its area (the midpoint rule; OpenEXR's
 * layouts, whose samples lie on the edges, the trapezoid rule); 0 where the layout sees no
 * direction (outside a probe's disc, the empty cells of a cross) and for a size the layout
 * cannot hold. */
double envl__layout_pixel_solid_angle(int32_t layout, int32_t w, int32_t h, int32_t i, int32_t j);

/* ---- negative values (ringing.c; docs/methods.md, "Negative pixels") ---- */
/* With NaN and Inf gone from img (read in `layout`): the sum of its L dw (negative values
 * included, dw from envl__layout_pixel_solid_angle) into info->signed_power, then, when
 * info->negative_pixels, every negative value filled from the positive light around it, so
 * that the sum keeps the file's signed sum; what it did goes to info's filled_energy,
 * added_energy, unfilled_values and fill_window. */
envl_result envl__fill_negatives(envl_image *img, int32_t layout, const char *file,
                                 envl_info *info);
/* The texels of a product image (docs/design.md, "Canonical frame"): ENVL_LAYOUT_LATLONG (w x
 * h) or ENVL_LAYOUT_STRIP_H (six faces of h texels side by side, w = 6 h): the centre direction
 * of texel (col, row) and its exact solid angle. */
void envl__texel_direction(int32_t layout, int32_t w, int32_t h, int32_t col, int32_t row,
                           double d[3]);
double envl__texel_solid_angle(int32_t layout, int32_t w, int32_t h, int32_t col, int32_t row);
/* The direction through point (s, t) of the plane of face `face` (0..5, in ENVL_LAYOUT_STRIP_H's
 * order; s, t in [-1, 1] on the face, beyond it on the plane's extension). */
void envl__face_direction(int32_t face, double s, double t, double d[3]);
/* The mean of a lat-long image, read as piecewise constant (each pixel its own value, as the
 * brute force sums it), over the footprint of texel (col, row) of a product image, by n x n
 * sub-texels of equal solid angle (lat-long) or weighted by their solid angle (faces). */
void envl__texel_footprint_mean(const envl_image *latlong, int32_t layout, int32_t w, int32_t h,
                                int32_t col, int32_t row, int32_t n, double out[3]);
/* Sub-texels per side for a footprint mean of texels about `texel` radians across over a
 * lat-long image h pixels tall: 4 per input pixel, 4..64. */
int32_t envl__footprint_subdivision(double texel, int32_t h);
/* A strip of six faces (ENVL_LAYOUT_STRIP_H, face texels square) read bilinearly in direction
 * d, a tap beyond a face's edge read from the face it falls on (as layout.c's input cubes). */
void envl__strip_sample(const float *strip, int32_t face, const double d[3], double out[3]);
/* The four texels a product image (ENVL_LAYOUT_LATLONG w x h, or ENVL_LAYOUT_STRIP_H of h-texel
 * faces) is read from bilinearly in direction d, and their weights (summing to 1): what
 * envl_latlong_sample and envl__strip_sample read, but for a lat-long image between the first
 * (last) row's centre and the pole the row itself, not its blend with the pole's mean, and for
 * faces a tap beyond a face's edge clamped to the face, not read from the next face. The
 * level-width estimate (level_width.c) reads levels it has not computed through it. */
void envl__texel_taps(int32_t layout, int32_t w, int32_t h, const double d[3],
                      int32_t col[4], int32_t row[4], double weight[4]);
/* The texels of a strip of six faces put into `layout` (ENVL_LAYOUT_STRIP_H, ENVL_LAYOUT_CROSS_V
 * or ENVL__LAYOUT_GL_STRIP) of the same face size: each output texel is the input texel with
 * the same centre direction (the faces' texel grids coincide), nothing resampled. */
envl_result envl__faces_to_layout(const float *strip, int32_t face, int32_t layout,
                                  envl_image *out);

/* ---- lat-long resampling (resample.c) ---- */
/* Exact area-weighted resampling of a lat-long image to out_w x out_h, turned by
 * rotate_degrees about +Z: every output pixel is the solid-angle weighted mean of the input
 * over its footprint, so the integral of L dw is preserved. */
/* A lat-long map out_w wide (height in proportion, at least 1) resampled as above from px, as
 * an envmap of `threads` threads (envmap.c). */
envl_result envl__envmap_resampled(const float *px, int32_t w, int32_t h, int32_t out_w,
                                   int32_t threads, envl_envmap **out);
envl_result envl__latlong_resample(const float *src, int32_t w, int32_t h, int32_t out_w,
                                   int32_t out_h, double rotate_degrees, float **out);
/* A few pixels of an image replaced by other values, sorted by row (then column). */
typedef struct envl_pixel_patch {
    int32_t r, c;
    float rgb[3];
} envl_pixel_patch;
/* The same, of src with the `npatch` pixels of `patch` replaced: what resampling a patched
 * copy of src gives, bit for bit, without the copy (rows with a patch go through one row). */
envl_result envl__latlong_resample_patched(const float *src, int32_t w, int32_t h,
                                           const envl_pixel_patch *patch, int32_t npatch,
                                           int32_t out_w, int32_t out_h, double rotate_degrees,
                                           float **out);
/* The same with the rows outside [row0, row1) read as black (a window of the map's rows,
 * envl__envmap_window): what resampling a copy of src with those rows black gives. */
envl_result envl__latlong_resample_rows(const float *src, int32_t w, int32_t h, int32_t row0,
                                        int32_t row1, const envl_pixel_patch *patch,
                                        int32_t npatch, int32_t out_w, int32_t out_h,
                                        double rotate_degrees, float **out);
/* An envmap of a lat-long RGB image (w x h x 3 floats, malloc'd, row 0 on top) that takes the
 * pixels over without a copy; they are freed on failure too (envmap.c). `name` names the map
 * in messages and its info. */
envl_result envl__envmap_adopt(float *px, int32_t w, int32_t h, const envl_load_options *o,
                               const char *name, envl_envmap **out);
envl_result envl__envmap_resampled_patched(const float *px, int32_t w, int32_t h,
                                           const envl_pixel_patch *patch, int32_t npatch,
                                           int32_t out_w, int32_t threads, envl_envmap **out);

/* ---- the ground plane (ground.c) ---- */
/* albedo x E_up / pi, the radiance a Lambertian plane of that albedo under map shows
 * (envl_ground_plane_map's ground_rgb, without its copy of the map); E_up itself, the map's
 * exact irradiance at +Z, in e_up (may be NULL). */
envl_result envl__ground_radiance(const envl_envmap *map, double albedo, double ground_rgb[3],
                                  double e_up[3]);

/* ---- lights (lights.c, lights_sun.c) ---- */
/* The residual of the lights `ls` of m as a map of `threads` threads that owns its pixels (one
 * copy): for the sun method (computed with skip_residual or not) made now from the map and the
 * suns' pixels at the split's threshold, for the others a copy of ls's residual (an error when
 * skipped). gltf.c asks for it for the other methods, only when there is a light (the sun
 * method's: envl__sun_residual_view). */
envl_result envl__lights_residual_map(const envl_envmap *m, const envl_lights *ls,
                                      int32_t threads, envl_envmap **out);
/* The same into out (w x h x 3 floats). */
void envl__sun_residual(const envl_envmap *m, const envl_lights *ls, float *out);
/* The sun method's residual without a copy: m's own pixels with the suns' patches written in
 * (the pixels they replace saved in *saved, malloc'd), as a map of `threads` threads that
 * borrows them (*out, its own tables and statistics: envl__lights_residual_map's map). Until
 * envl__sun_residual_view_end, m's pixels are the residual's: use *out, not m. */
envl_result envl__sun_residual_view(envl_envmap *m, const envl_lights *ls, int32_t threads,
                                    float **saved, envl_envmap **out);
/* Frees the view and puts m's pixels back, bit for bit (NULL view and saved: nothing to do). */
void envl__sun_residual_view_end(envl_envmap *m, const envl_lights *ls, float *saved,
                                 envl_envmap *view);
/* A lat-long map over pixels it does not own (they must be finite, non-negative and outlive
 * it): its tables and statistics only. */
envl_result envl__envmap_borrow(float *px, int32_t w, int32_t h, int32_t threads,
                                envl_envmap **out);

/* ---- prefiltering (prefilter.c, png.c) ---- */
/* 8-bit RGB (channels 3) or RGBA (4) pixels as a PNG in memory (*out malloc'd); srgb: with the
 * sRGB chunk. `what` names the output in messages. */
envl_result envl__png_encode(const char *what, const uint8_t *px, int32_t w, int32_t h,
                             int channels, int srgb, uint8_t **out, size_t *size);
/* Reads an 8-bit RGB / RGBA PNG; *px gets w * h * channels bytes (caller frees). */
envl_result envl__png_read(const char *path, int32_t *w, int32_t *h, int32_t *channels,
                           uint8_t **px);

/* ---- threads (parallel.c) ---- */
typedef void (*envl_range_fn)(void *ctx, int64_t begin, int64_t end);
/* Calls fn on contiguous blocks of [0, n) on up to `threads` threads; returns when all are
 * done. Deterministic: block boundaries depend only on n and threads. */
void envl__parallel_for(int64_t n, int32_t threads, envl_range_fn fn, void *ctx);

/* Number of worker threads for `requested` (0 = all cores), at most ENVL_MAX_THREADS. */
int32_t envl__threads(int32_t requested);

/* ---- the frame's geometry (frame.c) ---- */
/* A light's angular diameter from its solid angle: 2 acos(1 - omega / 2 pi), capped at pi. */
void envl__light_set_angle(envl_light *l);

/* ---- envmap (envmap.c) ---- */
/* The file the map was read from (envl_envmap_load), in full; NULL for the sky and pixels from
 * memory. */
const char *envl__envmap_source(const envl_envmap *m);
/* envl_outputs_check of `outputs` against the map's file and `other_input` (may be NULL). */
envl_result envl__outputs_of_map(const envl_envmap *m, const char *other_input,
                                 const char *const *outputs, int32_t n_outputs);
/* Takes ownership of img (img->px is moved). */
envl_result envl__envmap_from_image(envl_image *img, const envl_load_options *options,
                                    const char *file, envl_envmap **out);

/* Output only (envl__latlong_to_layout): OpenGL's six cube faces of the glTF frame side by
 * side, +X -X +Y -Y +Z -Z, each as GL samples it (layout.c). */
#define ENVL__LAYOUT_GL_STRIP ENVL_LAYOUT_COUNT
/* out = the coefficients of f(R^T d) given those of f(d): R (row-major) turns f by R
 * (sh_rotate.c). */
envl_result envl__sh_rotate(int32_t order, const double R[9], int32_t channels, const double *in,
                            double *out);

/* Reports fraction (0..1) and stage to the calling thread's progress callback; its cancel as
 * ENVL_ERR_CANCELLED (progress.c). */
envl_result envl__progress(double fraction, const char *stage);
/* Inside a step's long loop: the last step reported again, at most every 0.1 s, so that a
 * cancel is seen within that (ENVL_ERR_CANCELLED); ENVL_OK without a callback (every worker
 * thread: the callback is the calling thread's). */
envl_result envl__progress_poll(void);
/* A cancel shared by the threads of one parallel loop, zero-initialised: each item calls
 * envl__cancel_check, 1 (stop) once the caller's thread has seen a cancel in its poll; the
 * loop's caller then returns ENVL_ERR_CANCELLED (the message is its thread's). */
typedef struct envl_cancel {
    atomic_int stop;
} envl_cancel;
int envl__cancel_check(envl_cancel *c);

#endif
