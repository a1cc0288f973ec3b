/* The canonical envmap: lat-long RGB floats in Blender's world frame with per-row solid angles
 * and per-row / per-column direction tables; loading, sanitising, statistics. */
#include "internal.h"
#include "envmap_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- construction ---- */

/* NaN, Inf and negative values of the file (docs/design.md, "Units"): counted, refused in strict
 * mode; else NaN and -Inf become 0 and +Inf the largest finite value of the image (refused when
 * no value is positive and finite: nothing can stand for it), and negative values are filled
 * from the light around them (ringing.c). img is in `layout`. */
/* Rows [begin, end) of the image: flag[r] = 1 when row r holds a NaN, an infinity or a
 * negative value. As unsigned integers the bits of a float are >= 0x7f800000 exactly for +Inf,
 * NaN and every value with the sign set, of which only -0 (0x80000000) is not negative: a
 * compare per value, which the compiler vectorises. */
typedef struct bad_rows {
    const float *px;
    int32_t width;
    uint8_t *flag;
} bad_rows;

static void find_bad_rows(void *ctx, int64_t begin, int64_t end)
{
    const bad_rows *b = ctx;
    size_t n = (size_t)b->width * 3;
    for (int64_t r = begin; r < end; r++) {
        const float *p = b->px + (size_t)r * n;
        uint32_t bad = 0;
        for (size_t i = 0; i < n; i++) {
            uint32_t u;
            memcpy(&u, p + i, sizeof u);
            bad |= (u >= 0x7f800000u) & (u != 0x80000000u);
        }
        b->flag[r] = (uint8_t)bad;
    }
}

/* Whether some value is NaN, infinite or negative: one parallel pass, skipped when the file's
 * format cannot hold such values (RGBE). -1: no memory for the row flags. */
static int has_bad_values(const envl_image *img, int32_t threads)
{
    if (img->meta.finite_nonnegative)
        return 0;
    uint8_t *flag = malloc((size_t)img->height);
    if (!flag)
        return -1;
    bad_rows b = {img->px, img->width, flag};
    envl__parallel_for(img->height, threads, find_bad_rows, &b);
    int any = 0;
    for (int32_t r = 0; r < img->height; r++)
        any |= flag[r];
    free(flag);
    return any;
}

static envl_result sanitise(envl_image *img, int32_t layout, int32_t strict, int32_t threads,
                            const char *file, envl_info *info)
{
    int any = has_bad_values(img, threads);
    if (any < 0)
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", file);
    if (!any) {
        info->nonfinite_pixels = info->negative_pixels = 0;
        info->negative_min = 0.0;
        return ENVL_OK;
    }
    size_t n = (size_t)img->width * img->height;
    int64_t nonfinite = 0, negative = 0, infinite = 0;
    float maxfinite = 0.0f, minimum = 0.0f;
    for (size_t i = 0; i < n; i++) {
        const float *p = img->px + 3 * i;
        int bad = 0, neg = 0, inf = 0;
        for (int k = 0; k < 3; k++) {
            if (!isfinite(p[k])) {
                bad = 1;
                inf |= p[k] > 0;
            } else if (p[k] < 0) {
                neg = 1;
                minimum = p[k] < minimum ? p[k] : minimum;
            } else if (p[k] > maxfinite) {
                maxfinite = p[k];
            }
        }
        nonfinite += bad;
        negative += neg;
        infinite += inf;
    }
    info->nonfinite_pixels = nonfinite;
    info->negative_pixels = negative;
    info->negative_min = minimum;
    if (!nonfinite && !negative)
        return ENVL_OK;
    if (strict)
        return envl__fail(ENVL_ERR_NONFINITE,
                          "%s: %lld pixels with NaN or Inf and %lld with negative values "
                          "(--strict)",
                          file, (long long)nonfinite, (long long)negative);
    if (infinite && !(maxfinite > 0.0f))
        return envl__fail(ENVL_ERR_NONFINITE,
                          "%s: %lld pixels are +Inf and no value is positive and finite: nothing "
                          "to stand for +Inf (the largest finite value of the file does)",
                          file, (long long)infinite);
    for (size_t i = 0; i < 3 * n; i++) {
        float v = img->px[i];
        if (isnan(v) || v == -INFINITY)
            img->px[i] = 0.0f;
        else if (isinf(v))
            img->px[i] = maxfinite;
    }
    info->infinity_value = infinite ? maxfinite : 0.0;
    return envl__fill_negatives(img, layout, file, info);
}

static envl_result build_tables(envl_envmap *m)
{
    int32_t w = m->width, h = m->height;
    m->row_omega = malloc(sizeof(double) * h);
    m->row_cos = malloc(sizeof(double) * h);
    m->row_sin = malloc(sizeof(double) * h);
    m->col_cos = malloc(sizeof(double) * w);
    m->col_sin = malloc(sizeof(double) * w);
    if (!m->row_omega || !m->row_cos || !m->row_sin || !m->col_cos || !m->col_sin)
        return envl__fail(ENVL_ERR_MEMORY, "envmap: cannot allocate tables");
    for (int32_t r = 0; r < h; r++) {
        double theta = ENVL_PI * (0.5 - (r + 0.5) / h);
        m->row_omega[r] = envl_latlong_solid_angle(w, h, r);
        m->row_cos[r] = cos(theta);
        m->row_sin[r] = sin(theta);
    }
    for (int32_t c = 0; c < w; c++) {
        double phi = ENVL_PI * (1.0 - 2.0 * (c + 0.5) / w);
        m->col_cos[c] = cos(phi);
        m->col_sin[c] = sin(phi);
    }
    return ENVL_OK;
}

/* One row's share of the statistics: its sum per channel (in column order), maxima, and its
 * first pixel of greatest luminance. */
typedef struct envl_row_stats {
    double sum[3], max[3], best;
    int32_t best_c;
} row_stats;

typedef struct stats_job {
    const envl_envmap *m;
    row_stats *rows;
} stats_job;

static void stats_of_rows(void *ctx, int64_t begin, int64_t end)
{
    const stats_job *j = ctx;
    const envl_envmap *m = j->m;
    for (int64_t r = begin; r < end; r++) {
        row_stats *o = &j->rows[r];
        if (m->window && (r < m->row0 || r >= m->row1)) { /* black: what a black row gives */
            *o = (row_stats){{0, 0, 0}, {0, 0, 0}, 0, 0};
            continue;
        }
        /* one local per channel (not arrays): the three sums and maxima stay in registers */
        double s0 = 0, s1 = 0, s2 = 0, best = -1.0;
        float m0 = 0, m1 = 0, m2 = 0;
        int32_t best_c = 0;
        const float *p = m->px + (size_t)r * m->width * 3;
        for (int32_t c = 0; c < m->width; c++, p += 3) {
            s0 += p[0];
            s1 += p[1];
            s2 += p[2];
            m0 = p[0] > m0 ? p[0] : m0;
            m1 = p[1] > m1 ? p[1] : m1;
            m2 = p[2] > m2 ? p[2] : m2;
            double y = envl__lum(p[0], p[1], p[2]);
            if (y > best) {
                best = y;
                best_c = c;
            }
        }
        o->sum[0] = s0, o->sum[1] = s1, o->sum[2] = s2;
        o->max[0] = m0, o->max[1] = m1, o->max[2] = m2;
        o->best = best;
        o->best_c = best_c;
    }
}

double envl__row_max_luminance(const envl_envmap *m, int32_t r)
{
    return m->row_stats[r].best;
}

/* Power, mean, maxima and the brightest direction. Rows in parallel, each summed in column
 * order, then the rows in row order: the same sums as one pass, at any thread count. A window
 * of `from`'s pixels (envl__envmap_window) takes from's rows' statistics as they are, but for
 * its rows outside the window (black) and the rows a patch changed (sorted by row): the same
 * numbers without the pass. The rows' statistics are kept with the map for its windows. */
static envl_result compute_stats(envl_envmap *m, const envl_envmap *from,
                                 const envl_pixel_patch *patch, int32_t npatch)
{
    envl_info *info = &m->info;
    stats_job j = {m, malloc(sizeof(row_stats) * (size_t)m->height)};
    if (!j.rows)
        return envl__fail(ENVL_ERR_MEMORY, "envmap: cannot allocate the row statistics");
    if (from && from->row_stats && from->px == m->px && from->width == m->width &&
        from->height == m->height) {
        memcpy(j.rows, from->row_stats, sizeof(row_stats) * (size_t)m->height);
        if (m->window) { /* what stats_of_rows gives a row outside the window */
            stats_of_rows(&j, 0, m->row0);
            stats_of_rows(&j, m->row1, m->height);
        }
        for (int32_t i = 0; i < npatch; i++)
            if (i == 0 || patch[i].r != patch[i - 1].r)
                stats_of_rows(&j, patch[i].r, patch[i].r + 1);
    } else {
        envl__parallel_for(m->height, m->threads, stats_of_rows, &j);
    }
    double power[3] = {0, 0, 0}, mx[3] = {0, 0, 0}, best = -1.0;
    int32_t best_c = 0, best_r = 0;
    for (int32_t r = 0; r < m->height; r++) {
        const row_stats *o = &j.rows[r];
        for (int k = 0; k < 3; k++) {
            power[k] += o->sum[k] * m->row_omega[r];
            if (o->max[k] > mx[k])
                mx[k] = o->max[k];
        }
        if (o->best > best) {
            best = o->best;
            best_c = o->best_c;
            best_r = r;
        }
    }
    free(m->row_stats);
    m->row_stats = j.rows;
    for (int k = 0; k < 3; k++) {
        info->power[k] = power[k];
        info->mean[k] = power[k] / (4.0 * ENVL_PI);
        info->max[k] = mx[k];
    }
    envl_envmap_direction(m, best_c, best_r, info->brightest_direction);
    info->width = m->width;
    info->height = m->height;
    return ENVL_OK;
}

envl_result envl__envmap_from_image(envl_image *img, const envl_load_options *options,
                                    const char *file, envl_envmap **out)
{
    static const envl_load_options defaults;
    const envl_load_options *o = options ? options : &defaults;
    *out = NULL;
    envl_envmap *m = calloc(1, sizeof *m);
    if (!m) {
        envl__image_free(img);
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", file);
    }
    envl_info *info = &m->info;
    snprintf(info->file, sizeof info->file, "%s", file);
    snprintf(info->format, sizeof info->format, "%s", img->meta.format);
    info->source_width = img->width;
    info->source_height = img->height;
    info->channels = img->meta.channels;
    info->exposure = img->meta.exposure > 0 ? img->meta.exposure : 1.0;
    info->has_primaries = img->meta.has_primaries;
    memcpy(info->primaries, img->meta.primaries, sizeof info->primaries);
    info->rotate_degrees = o->rotate_degrees;
    m->apply_exposure = o->apply_exposure != 0;
    m->threads = envl__threads(o->threads);

    envl_result rc = ENVL_OK;
    int32_t layout = o->layout;
    if (layout < 0 || layout >= ENVL_LAYOUT_COUNT) {
        rc = envl__fail(ENVL_ERR_ARGUMENT, "%s: unknown layout %d", file, (int)layout);
        goto fail;
    }
    if (layout == ENVL_LAYOUT_AUTO) {
        layout = envl__guess_layout(img);
        info->layout_guessed = 1;
    }
    info->layout = layout;
    if (o->apply_exposure && info->exposure != 1.0) {
        size_t n = (size_t)img->width * img->height * 3;
        for (size_t i = 0; i < n; i++)
            img->px[i] = (float)(img->px[i] / info->exposure);
        img->meta.finite_nonnegative = 0; /* a small EXPOSURE can overflow a value */
    }
    /* in the file's own layout: a codec's blocks and a pixel's solid angle are the file's */
    rc = sanitise(img, layout, o->strict, m->threads, file, info);
    if (rc)
        goto fail;
    if (o->width < 0) {
        rc = envl__fail(ENVL_ERR_ARGUMENT, "%s: width %d must be positive", file, (int)o->width);
        goto fail;
    }
    /* the width asked for makes a W x W/2 map: max_pixels bounds it as it bounds a file */
    int64_t max_px = o->max_pixels > 0 ? o->max_pixels : ENVL_DEFAULT_MAX_PIXELS;
    if (o->width > 0 && (int64_t)o->width * (o->width > 1 ? o->width / 2 : 1) > max_px) {
        rc = envl__fail(ENVL_ERR_LIMIT, "%s: width %d makes a %d x %d map: more than max_pixels "
                        "%lld", file, (int)o->width, (int)o->width, (int)(o->width / 2),
                        (long long)max_px);
        goto fail;
    }

    if (layout == ENVL_LAYOUT_LATLONG) {
        int32_t w = o->width ? o->width : img->width;
        int32_t h = w == img->width ? img->height
                                    : (int32_t)fmax(1.0, llround((double)w * img->height /
                                                                 img->width));
        if (w == img->width && h == img->height && o->rotate_degrees == 0.0) {
            m->px = img->px; /* take the pixels as they are */
            img->px = NULL;
        } else {
            rc = envl__latlong_resample(img->px, img->width, img->height, w, h,
                                        o->rotate_degrees, &m->px);
            if (rc) {
                envl__fail_prefix(rc, file);
                goto fail;
            }
        }
        m->width = w;
        m->height = h;
    } else {
        int32_t w = o->width ? o->width : envl__default_latlong_width(img, layout);
        envl_image ll = {0};
        rc = envl__layout_to_latlong(img, layout, w, &ll);
        if (rc) {
            envl__fail_prefix(rc, file);
            goto fail;
        }
        m->width = ll.width; /* before envl__image_free clears ll */
        m->height = ll.height;
        if (o->rotate_degrees != 0.0) {
            rc = envl__latlong_resample(ll.px, ll.width, ll.height, ll.width, ll.height,
                                        o->rotate_degrees, &m->px);
            envl__image_free(&ll);
            if (rc)
                goto fail;
        } else {
            m->px = ll.px;
        }
    }
    envl__image_free(img);
    rc = build_tables(m);
    if (!rc)
        rc = compute_stats(m, NULL, NULL, 0);
    if (rc) {
        envl_envmap_free(m);
        return rc;
    }
    if (!info->nonfinite_pixels && !info->negative_pixels)
        memcpy(info->signed_power, info->power, sizeof info->power);
    *out = m;
    return ENVL_OK;
fail:
    envl__image_free(img);
    envl_envmap_free(m);
    return rc;
}

static envl_limits limits_of(const envl_load_options *o)
{
    envl_limits lim = {ENVL_DEFAULT_MAX_PIXELS, NULL, 0};
    if (o && o->max_pixels > 0)
        lim.max_pixels = o->max_pixels;
    if (o) {
        lim.exr_part = o->exr_part;
        lim.threads = o->threads;
    }
    return lim;
}

envl_result envl_envmap_load(const char *path, const envl_load_options *options,
                             envl_envmap **out)
{
    if (!out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_load: out is NULL");
    *out = NULL;
    if (!path || !*path)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_load: no file name");
    envl_limits lim = limits_of(options);
    envl_image img = {0};
    /* progress: reading and decoding, then the canonical frame (resampling, tables, stats) */
    envl_result rc = envl__progress(0.0, "reading the file");
    if (!rc)
        rc = envl__read_image_file(path, &lim, &img);
    if (rc)
        return rc;
    if ((rc = envl__progress(0.5, "to the canonical lat-long frame"))) {
        envl__image_free(&img);
        return rc;
    }
    rc = envl__envmap_from_image(&img, options, path, out);
    if (!rc && !((*out)->source_path = strdup(path)))
        rc = envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", path);
    if (!rc && (rc = envl__progress(1.0, "done"))) {
        envl_envmap_free(*out);
        *out = NULL;
    }
    return rc;
}

envl_result envl__envmap_resampled(const float *px, int32_t w, int32_t h, int32_t out_w,
                                   int32_t threads, envl_envmap **out)
{
    return envl__envmap_resampled_patched(px, w, h, NULL, 0, out_w, threads, out);
}

static envl_result resampled(const float *px, int32_t w, int32_t h, int32_t row0, int32_t row1,
                             const envl_pixel_patch *patch, int32_t npatch, int32_t out_w,
                             int32_t threads, envl_envmap **out)
{
    *out = NULL;
    int32_t out_h = (int32_t)fmax(1, llround((double)out_w * h / w));
    float *spx;
    envl_result rc = envl__latlong_resample_rows(px, w, h, row0, row1, patch, npatch, out_w,
                                                 out_h, 0.0, &spx);
    if (rc)
        return rc;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    rc = envl_envmap_from_pixels(spx, out_w, out_h, 3, &lo, out);
    free(spx);
    return rc;
}

envl_result envl__envmap_resampled_patched(const float *px, int32_t w, int32_t h,
                                           const envl_pixel_patch *patch, int32_t npatch,
                                           int32_t out_w, int32_t threads, envl_envmap **out)
{
    return resampled(px, w, h, 0, h, patch, npatch, out_w, threads, out);
}

envl_result envl__envmap_window_copy(const envl_envmap *m, int32_t out_w, envl_envmap **out)
{
    return resampled(m->px, m->width, m->height, m->window ? m->row0 : 0,
                     m->window ? m->row1 : m->height, NULL, 0, out_w, m->threads, out);
}

envl_result envl__envmap_adopt(float *px, int32_t w, int32_t h, const envl_load_options *o,
                               const char *name, envl_envmap **out)
{
    envl_image img = {.width = w, .height = h, .px = px};
    snprintf(img.meta.format, sizeof img.meta.format, "memory");
    img.meta.channels = 3;
    img.meta.exposure = 1.0;
    return envl__envmap_from_image(&img, o, name, out);
}

static envl_result borrow(float *px, int32_t w, int32_t h, int32_t row0, int32_t row1,
                          int32_t threads, const envl_envmap *from,
                          const envl_pixel_patch *patch, int32_t npatch, envl_envmap **out)
{
    *out = NULL;
    envl_envmap *m = calloc(1, sizeof *m);
    if (!m)
        return envl__fail(ENVL_ERR_MEMORY, "envmap: out of memory");
    /* the info as envl__envmap_adopt gives a lat-long map of finite, non-negative pixels */
    envl_info *info = &m->info;
    snprintf(info->format, sizeof info->format, "memory");
    info->source_width = w;
    info->source_height = h;
    info->channels = 3;
    info->exposure = 1.0;
    info->layout = ENVL_LAYOUT_LATLONG;
    m->threads = envl__threads(threads);
    m->px = px;
    m->px_borrowed = 1;
    m->width = w;
    m->height = h;
    m->window = row0 > 0 || row1 < h;
    m->row0 = row0;
    m->row1 = row1;
    envl_result rc = build_tables(m);
    if (!rc)
        rc = compute_stats(m, from, patch, npatch);
    if (rc) {
        envl_envmap_free(m);
        return rc;
    }
    memcpy(info->signed_power, info->power, sizeof info->power);
    *out = m;
    return ENVL_OK;
}

envl_result envl__envmap_borrow(float *px, int32_t w, int32_t h, int32_t threads,
                                envl_envmap **out)
{
    return borrow(px, w, h, 0, h, threads, NULL, NULL, 0, out);
}

envl_result envl__envmap_window(const envl_envmap *map, int32_t row0, int32_t row1,
                                envl_envmap **out)
{
    return envl__envmap_window_patched(map, row0, row1, NULL, 0, out);
}

envl_result envl__envmap_window_patched(const envl_envmap *map, int32_t row0, int32_t row1,
                                        const envl_pixel_patch *patch, int32_t npatch,
                                        envl_envmap **out)
{
    *out = NULL;
    if (!(row0 >= 0 && row0 < row1 && row1 <= map->height))
        return envl__fail(ENVL_ERR_ARGUMENT, "envmap: rows [%d, %d) are no window of a map %d "
                          "rows high", (int)row0, (int)row1, (int)map->height);
    return borrow(map->px, map->width, map->height, row0, row1, map->threads, map, patch,
                  npatch, out);
}

envl_result envl_envmap_from_pixels(const float *pixels, int32_t width, int32_t height,
                                    int32_t channels, const envl_load_options *options,
                                    envl_envmap **out)
{
    if (!out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_from_pixels: out is NULL");
    *out = NULL;
    if (!pixels)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_from_pixels: pixels is NULL");
    if (channels != 1 && channels != 3 && channels != 4)
        return envl__fail(ENVL_ERR_ARGUMENT,
                          "envl_envmap_from_pixels: %d channels (expected 1, 3 or 4)",
                          (int)channels);
    envl_limits lim = limits_of(options);
    envl_image img = {0};
    envl_result rc = envl__image_alloc(&img, width, height, &lim, "pixels");
    if (rc)
        return rc;
    size_t n = (size_t)width * height;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            img.px[3 * i + k] = pixels[channels * i + (channels == 1 ? 0 : k)];
    snprintf(img.meta.format, sizeof img.meta.format, "memory");
    img.meta.channels = channels;
    img.meta.exposure = 1.0;
    return envl__envmap_from_image(&img, options, "", out);
}

/* Room for width x height pixels of `channels` floats and their RGB (grey is spread to RGB in
 * place: 3 floats a pixel at least). */
envl_result envl_pixels_alloc(int32_t width, int32_t height, int32_t channels,
                              const envl_load_options *options, float **out)
{
    if (!out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_pixels_alloc: out is NULL");
    *out = NULL;
    if (channels != 1 && channels != 3 && channels != 4)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_pixels_alloc: %d channels (expected 1, 3 "
                          "or 4)", (int)channels);
    envl_limits lim = limits_of(options);
    envl_image img = {0};
    envl_result rc = envl__image_alloc(&img, width, height, &lim, "pixels");
    if (rc || channels < 4) {
        *out = img.px;
        return rc;
    }
    if ((uint64_t)width * (uint64_t)height > SIZE_MAX / (4 * sizeof(float))) {
        envl__image_free(&img);
        return envl__fail(ENVL_ERR_LIMIT, "pixels: image size %d x %d too large for memory",
                          (int)width, (int)height);
    }
    float *px = realloc(img.px, (size_t)width * height * 4 * sizeof(float));
    if (!px) {
        envl__image_free(&img);
        return envl__fail(ENVL_ERR_MEMORY, "pixels: cannot allocate %d x %d pixels",
                          (int)width, (int)height);
    }
    envl__huge_pages(px, (size_t)width * height * 4 * sizeof(float));
    *out = px;
    return ENVL_OK;
}

void envl_pixels_free(float *pixels)
{
    free(pixels);
}

typedef struct row_swap {
    float *px;
    size_t row;     /* floats a row */
    int32_t height;
} row_swap;

/* Rows [begin, end) of the top half swapped with their mirror rows. */
static void swap_rows(void *ctx, int64_t begin, int64_t end)
{
    const row_swap *s = ctx;
    float tmp[1024];
    for (int64_t r = begin; r < end; r++) {
        float *a = s->px + (size_t)r * s->row, *b = s->px + (size_t)(s->height - 1 - r) * s->row;
        for (size_t i = 0; i < s->row; i += 1024) {
            size_t k = s->row - i < 1024 ? s->row - i : 1024;
            memcpy(tmp, a + i, k * sizeof(float));
            memcpy(a + i, b + i, k * sizeof(float));
            memcpy(b + i, tmp, k * sizeof(float));
        }
    }
}

envl_result envl_envmap_adopt_pixels(float *pixels, int32_t width, int32_t height,
                                     int32_t channels, int32_t bottom_up,
                                     const envl_load_options *options, envl_envmap **out)
{
    envl_image img = {.width = width, .height = height, .px = pixels};
    envl_result rc = ENVL_OK;
    if (!out)
        rc = envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_adopt_pixels: out is NULL");
    else
        *out = NULL;
    if (!rc && !pixels)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_adopt_pixels: pixels is NULL");
    if (!rc && channels != 1 && channels != 3 && channels != 4)
        rc = envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_adopt_pixels: %d channels (expected 1, "
                        "3 or 4)", (int)channels);
    envl_limits lim = limits_of(options);
    if (!rc && (width <= 0 || height <= 0 || (int64_t)width * height > lim.max_pixels))
        rc = envl__fail(width <= 0 || height <= 0 ? ENVL_ERR_ARGUMENT : ENVL_ERR_LIMIT,
                        "envl_envmap_adopt_pixels: %d x %d pixels: not what envl_pixels_alloc "
                        "allows", (int)width, (int)height);
    if (!rc)
        rc = envl__progress(0.0, "to the canonical lat-long frame");
    if (rc) {
        free(pixels);
        return rc;
    }
    size_t n = (size_t)width * height;
    if (bottom_up) {
        row_swap s = {pixels, (size_t)width * channels, height};
        envl__parallel_for(height / 2, envl__threads(options ? options->threads : 0), swap_rows,
                           &s);
    }
    if (channels == 4) { /* forward: pixel i's RGB (3i..3i+2) never lies past its RGBA (4i..) */
        for (size_t i = 0; i < n; i++)
            for (int k = 0; k < 3; k++)
                pixels[3 * i + k] = pixels[4 * i + k];
        float *px = realloc(pixels, n * 3 * sizeof(float)); /* the alpha's room given back */
        img.px = px ? px : pixels;
    } else if (channels == 1) { /* backward: pixel i's RGB (3i..) never lies before its grey */
        for (size_t i = n; i-- > 0;)
            pixels[3 * i] = pixels[3 * i + 1] = pixels[3 * i + 2] = pixels[i];
    }
    snprintf(img.meta.format, sizeof img.meta.format, "memory");
    img.meta.channels = channels;
    img.meta.exposure = 1.0;
    rc = envl__envmap_from_image(&img, options, "", out);
    if (!rc && (rc = envl__progress(1.0, "done"))) {
        envl_envmap_free(*out);
        *out = NULL;
    }
    return rc;
}

void envl_envmap_free(envl_envmap *m)
{
    if (!m)
        return;
    if (!m->px_borrowed)
        free(m->px);
    free(m->source_path);
    free(m->row_omega);
    free(m->row_cos);
    free(m->row_sin);
    free(m->col_cos);
    free(m->col_sin);
    free(m->reference);
    envl_envmap_free(m->reference_copy);
    free(m->region_table);
    free(m->row_stats);
    free(m->mip_px);
    free(m->cells);
    envl_envmap_free(m->points_copy);
    free(m);
}

void envl_envmap_drop_caches(envl_envmap *m, int32_t which)
{
    if (!m)
        return;
    if (which & ENVL_CACHE_SAT) {
        free(m->region_table);
        m->region_table = NULL;
    }
    if (which & ENVL_CACHE_REFERENCE) {
        free(m->reference);
        m->reference = NULL;
        envl_envmap_free(m->reference_copy);
        m->reference_copy = NULL;
    }
}

/* ---- accessors ---- */

envl_result envl_envmap_info(const envl_envmap *m, envl_info *out)
{
    if (!m || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_info: NULL argument");
    *out = m->info;
    return ENVL_OK;
}

int32_t envl_envmap_width(const envl_envmap *m) { return m ? m->width : 0; }
int32_t envl_envmap_height(const envl_envmap *m) { return m ? m->height : 0; }
const float *envl_envmap_pixels(const envl_envmap *m) { return m ? m->px : NULL; }

double envl_envmap_solid_angle(const envl_envmap *m, int32_t row)
{
    return m && row >= 0 && row < m->height ? m->row_omega[row] : 0.0;
}

void envl_envmap_direction(const envl_envmap *m, int32_t c, int32_t r, double d[3])
{
    if (!m || c < 0 || r < 0 || c >= m->width || r >= m->height) {
        d[0] = d[1] = d[2] = 0.0;
        return;
    }
    d[0] = m->row_cos[r] * m->col_cos[c];
    d[1] = m->row_cos[r] * m->col_sin[c];
    d[2] = m->row_sin[r];
}

/* ---- maps too coarse for the GGX sums (envmap_impl.h) ---- */

static int too_coarse(int32_t w, int32_t h)
{
    return w < 16 || h < 8 || w < h || w > 4 * (int64_t)h;
}

int envl__points_fine(const envl_envmap *m) { return !too_coarse(m->width, m->height); }

envl_result envl__points_copy(const envl_envmap *m, envl_envmap **copy)
{
    *copy = NULL;
    int32_t w = m->width, h = m->height;
    if (!too_coarse(w, h))
        return ENVL_OK;
    /* each pixel split into k x j: at least 64 x 32, pixels within [1/2, 2] in aspect */
    int64_t k = (64 + w - 1) / w, j = (32 + h - 1) / h;
    if (w * k < h * j)
        k = (h * j + w - 1) / w;
    if (w * k > 4 * h * j)
        j = (w * k + 4 * (int64_t)h - 1) / (4 * (int64_t)h);
    int64_t cw = w * k, ch = h * j;
    if (cw * ch > 1024 * 512) /* too many: area-resampled (a mean of rows or columns) */
        cw = 1024, ch = 512;
    /* rows and columns apart (area weights separate), the pass that leaves fewer pixels first:
     * one pass would resample every one of 16384 rows of a 1 x 16384 map to the full width */
    int rows_first = (int64_t)w * ch <= cw * (int64_t)h;
    int32_t mw = rows_first ? w : (int32_t)cw, mh = rows_first ? (int32_t)ch : h;
    float *mid, *px = NULL;
    envl_result rc = envl__latlong_resample(m->px, w, h, mw, mh, 0.0, &mid);
    if (!rc)
        rc = envl__latlong_resample(mid, mw, mh, (int32_t)cw, (int32_t)ch, 0.0, &px);
    free(mid);
    if (rc)
        return rc;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = m->threads};
    rc = envl_envmap_from_pixels(px, (int32_t)cw, (int32_t)ch, 3, &lo, copy);
    free(px);
    if (!rc) /* messages about the copy name the map */
        memcpy((*copy)->info.file, m->info.file, sizeof m->info.file);
    return rc;
}

envl_result envl__points_map(envl_envmap *m, envl_envmap **out)
{
    *out = m;
    if (!too_coarse(m->width, m->height))
        return ENVL_OK;
    if (!m->points_copy) {
        envl_result rc = envl__points_copy(m, &m->points_copy);
        if (rc)
            return rc;
    }
    *out = m->points_copy;
    return ENVL_OK;
}

const char *envl__envmap_source(const envl_envmap *m)
{
    return m->source_path;
}

envl_result envl__outputs_of_map(const envl_envmap *m, const char *other_input,
                                 const char *const *outputs, int32_t n_outputs)
{
    const char *inputs[2] = {m->source_path, other_input};
    return envl_outputs_check(inputs, 2, outputs, n_outputs);
}

envl_result envl_envmap_save(const envl_envmap *m, const char *path,
                             const envl_save_options *options)
{
    if (!m)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_save: map is NULL");
    envl_result rc = envl__outputs_of_map(m, NULL, &path, 1);
    return rc ? rc : envl_image_save(path, m->px, m->width, m->height, options);
}

envl_result envl_envmap_to_layout(const envl_envmap *m, int32_t layout, int32_t size,
                                  float **pixels, int32_t *width, int32_t *height)
{
    if (!m || !pixels || !width || !height)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_to_layout: a NULL argument");
    if (size <= 0 || layout <= ENVL_LAYOUT_AUTO || layout >= ENVL_LAYOUT_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_to_layout: %s %d (a size of at least "
                          "1; a layout from latlong to exr-cube)",
                          size <= 0 ? "size" : "layout", size <= 0 ? (int)size : (int)layout);
    *pixels = NULL;
    char stage[64];
    snprintf(stage, sizeof stage, "resampling to %s", envl_layout_name(layout));
    envl_result rc = envl__progress(0.0, stage);
    if (rc)
        return rc;
    envl_image src = {.width = m->width, .height = m->height, .px = m->px}, out = {0};
    rc = envl__latlong_to_layout(&src, layout, size, &out); /* lat-long too: area-resampled */
    if (!rc)
        rc = envl__progress(1.0, "done");
    if (rc) {
        envl__image_free(&out);
        return rc;
    }
    *pixels = out.px;
    *width = out.width;
    *height = out.height;
    return ENVL_OK;
}

void envl_free(void *memory) { free(memory); }
