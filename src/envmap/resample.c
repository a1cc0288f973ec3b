/* Exact area-weighted resampling of lat-long images (and turns about +Z).
 *
 * The input is treated as piecewise constant over its pixels. An output pixel's value is the
 * solid-angle weighted mean of the input over the output pixel's footprint. On the sphere the
 * solid angle element is dphi * dz (z = sin(elevation)), so the weights separate: columns
 * overlap linearly in azimuth, rows overlap linearly in z. Hence the integral of L dw over the
 * sphere is preserved exactly (up to rounding), whatever the sizes. */
#include "internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* z = sin(elevation) at the top edge of row r of an h-row lat-long image. */
static double row_top_z(int32_t h, int32_t r) { return sin(ENVL_PI * (0.5 - (double)r / h)); }

/* One row: out[C] = mean of in over [C*scale + shift, (C+1)*scale + shift) (pixel units,
 * wrapping around the seam). */
static void resample_row(const float *in, int32_t w, float *out, int32_t out_w, double shift)
{
    double scale = (double)w / out_w;
    if (shift == 0 && w % out_w == 0) {
        /* whole input pixels, each of weight 1: the loop below's sums in its order, so the
         * same floats, without its per-pixel overlap (the reference copies: 8K to 256 wide) */
        int32_t span = w / out_w;
        for (int32_t c = 0; c < out_w; c++) {
            const float *p = in + 3 * (size_t)c * span;
            double acc[3] = {0, 0, 0};
            for (int32_t j = 0; j < span; j++, p += 3) {
                acc[0] += p[0];
                acc[1] += p[1];
                acc[2] += p[2];
            }
            for (int i = 0; i < 3; i++)
                out[3 * c + i] = (float)(acc[i] / scale);
        }
        return;
    }
    for (int32_t c = 0; c < out_w; c++) {
        double a = c * scale + shift, b = a + scale;
        double acc[3] = {0, 0, 0}, k = floor(a);
        int64_t idx = (int64_t)k % w; /* k mod w, stepped along with k */
        if (idx < 0)
            idx += w;
        for (; k < b; k += 1.0, idx = idx + 1 < w ? idx + 1 : 0) {
            /* the overlap of [a, b) with pixel [k, k + 1): fmax / fmin as compares (the
             * same values for these finite numbers, without a libm call per input pixel) */
            double lo = a > k ? a : k, hi = b < k + 1.0 ? b : k + 1.0;
            double wgt = hi - lo;
            if (wgt <= 0)
                continue;
            const float *p = in + 3 * idx;
            acc[0] += wgt * p[0];
            acc[1] += wgt * p[1];
            acc[2] += wgt * p[2];
        }
        for (int i = 0; i < 3; i++)
            out[3 * c + i] = (float)(acc[i] / scale);
    }
}

/* The input rows, with the patched pixels replaced: a row that holds a patch is copied into
 * `line` and patched (the last such row is kept there); a row outside [row0, row1) is `zero`,
 * black. */
typedef struct row_source {
    const float *src;
    int32_t w;
    const envl_pixel_patch *patch;
    int32_t npatch;
    float *line;
    int32_t line_row;
    int32_t row0, row1;
    const float *zero;
} row_source;

static const float *source_row(row_source *s, int32_t k)
{
    if (k < s->row0 || k >= s->row1)
        return s->zero;
    const float *row = s->src + (size_t)k * s->w * 3;
    int32_t lo = 0, hi = s->npatch; /* the first patch of row >= k */
    while (lo < hi) {
        int32_t mid = lo + (hi - lo) / 2;
        if (s->patch[mid].r < k)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo == s->npatch || s->patch[lo].r != k)
        return row;
    if (s->line_row != k) {
        memcpy(s->line, row, sizeof(float) * 3 * (size_t)s->w);
        for (int32_t i = lo; i < s->npatch && s->patch[i].r == k; i++)
            memcpy(s->line + 3 * (size_t)s->patch[i].c, s->patch[i].rgb, sizeof(float) * 3);
        s->line_row = k;
    }
    return s->line;
}

envl_result envl__latlong_resample(const float *src, int32_t w, int32_t h, int32_t out_w,
                                   int32_t out_h, double rotate_degrees, float **out)
{
    return envl__latlong_resample_patched(src, w, h, NULL, 0, out_w, out_h, rotate_degrees, out);
}

envl_result envl__latlong_resample_patched(const float *src, int32_t w, int32_t h,
                                           const envl_pixel_patch *patch, int32_t npatch,
                                           int32_t out_w, int32_t out_h, double rotate_degrees,
                                           float **out)
{
    return envl__latlong_resample_rows(src, w, h, 0, h, patch, npatch, out_w, out_h,
                                       rotate_degrees, out);
}

envl_result envl__latlong_resample_rows(const float *src, int32_t w, int32_t h, int32_t row0,
                                        int32_t row1, const envl_pixel_patch *patch,
                                        int32_t npatch, int32_t out_w, int32_t out_h,
                                        double rotate_degrees, float **out)
{
    *out = NULL;
    if (w <= 0 || h <= 0 || out_w <= 0 || out_h <= 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "resample: sizes must be positive");
    int whole = row0 <= 0 && row1 >= h; /* no row reads as black */
    /* Turning the map by +a about +Z moves a feature from phi to phi + a, i.e. from u to
     * u - a/360: the output at u samples the input at u + a/360. */
    double turns = fmod(rotate_degrees / 360.0, 1.0);
    double shift = turns * w;
    int plain = out_w == w && shift == 0.0; /* rows need no column pass */
    size_t n_row = (size_t)out_w * 3, n_out = (size_t)out_h * n_row;
    float *dst = malloc(n_out * sizeof(float));
    /* Rows are streamed: an input row is column-resampled when an output row needs it, into
     * one of two row slots (output rows walk the input rows in order and share at most their
     * boundary rows, so each input row is resampled once), never into a whole column-resampled
     * copy of the input (2x the output's memory when halving: the largest transient of the
     * prefilter's pyramid). Same arithmetic as a full column pass, so the same floats. */
    float *row = out_h == h ? NULL : malloc(2 * n_row * sizeof(float));
    double *acc = out_h == h ? NULL : malloc(n_row * sizeof(double));
    float *zero = whole ? NULL : calloc(3 * (size_t)w, sizeof(float));
    row_source rs = {src, w, patch, npatch, npatch ? malloc(sizeof(float) * 3 * (size_t)w) : NULL,
                     -1, row0, row1, zero};
    if (!dst || (out_h != h && (!row || !acc)) || (npatch && !rs.line) || (!whole && !zero)) {
        free(dst);
        free(row);
        free(acc);
        free(rs.line);
        free(zero);
        return envl__fail(ENVL_ERR_MEMORY, "resample: cannot allocate %d x %d", (int)out_w,
                          (int)out_h);
    }
    if (out_h == h) {
        if (plain && !npatch && whole)
            memcpy(dst, src, n_out * sizeof(float));
        else if (plain)
            for (int32_t r = 0; r < h; r++)
                memcpy(dst + (size_t)r * n_row, source_row(&rs, r), n_row * sizeof(float));
        else
            for (int32_t r = 0; r < h; r++)
                resample_row(source_row(&rs, r), w, dst + (size_t)r * n_row, out_w, shift);
    } else {
        /* Rows: weights are overlaps in z. Both row lists run from z = 1 down to z = -1. */
        int32_t r = 0, slot_row[2] = {-1, -1};
        for (int32_t R = 0; R < out_h; R++) {
            double top = row_top_z(out_h, R), bot = row_top_z(out_h, R + 1);
            double span = top - bot;
            memset(acc, 0, n_row * sizeof(double));
            while (r < h && row_top_z(h, r + 1) >= top)
                r++; /* input rows wholly above this output row */
            for (int32_t k = r; k < h; k++) {
                double itop = row_top_z(h, k), ibot = row_top_z(h, k + 1);
                if (itop <= bot)
                    break;
                double wgt = fmin(top, itop) - fmax(bot, ibot);
                if (wgt <= 0)
                    continue;
                const float *p = source_row(&rs, k);
                if (!plain) {
                    int j = slot_row[0] == k ? 0 : slot_row[1] == k ? 1 : -1;
                    if (j < 0) { /* replace the slot of the older (smaller) row */
                        j = slot_row[0] < slot_row[1] ? 0 : 1;
                        resample_row(p, w, row + j * n_row, out_w, shift);
                        slot_row[j] = k;
                    }
                    p = row + j * n_row;
                }
                for (size_t i = 0; i < n_row; i++)
                    acc[i] += wgt * p[i];
            }
            float *q = dst + (size_t)R * n_row;
            for (size_t i = 0; i < n_row; i++)
                q[i] = span > 0 ? (float)(acc[i] / span) : 0.0f;
        }
    }
    free(row);
    free(acc);
    free(rs.line);
    free(zero);
    *out = dst;
    return ENVL_OK;
}
