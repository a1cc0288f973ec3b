/* The GGX specular level of roughness r (alpha = r^2).
 *
 * docs/design.md's split-sum prefiltered radiance, N = V = R:
 *   P(R) = int L(l) D(h) max(R.l, 0) dl / int D(h) max(R.l, 0) dl.
 * Filtered levels (the default) sum the map's cell pyramid with a quadrature as fine near R as
 * the lobe is narrow and coarser with the distance from R (cells.c); the map is the map less
 * what the sun lights took, when they are asked for.
 * The unfiltered baseline is plain GGX importance sampling of the full map: half vectors h from
 * D(h) (N.h) (Hammersley points) reflected about them give l with pdf D(h) / 4 (N = V); the
 * estimator of P is then sum L(l_i) (R.l_i) / sum (R.l_i) (Karis 2013), the same n directions
 * in every texel's tangent frame (east, north, R), each read bilinearly from the map.
 * Roughness exactly 0 is the map itself, area-resampled to the level's size (cube faces: each
 * texel the map's mean over its footprint).
 * A level's texels are a lat-long image or cube faces (options.layout), each computed at its
 * own centre direction: a cube face is never resampled from a lat-long level (docs/design.md,
 * "Error measures": the per-texel error).
 *
 * Energy: the kernel D(h) max(R.l, 0) / norm depends on R.l only, so the integral of P over
 * the sphere equals the map's exactly. The texels' sum of P dw is a quadrature of that
 * integral on the level's grid, reported as energy_scale (its ratio to the map's power). A
 * filtered level is not scaled by it: each texel holds P at its centre (the cells' sums are
 * normalised per texel, a constant map gives L), and a lobe narrower than the texels makes
 * the sum miss by up to 15 % (one bright pixel at roughness 0.05), which a scaling would put
 * into every texel (per-texel RMS 1.5 % at roughness 0.1 on 64-texel faces of the built-in sky).
 * The unfiltered baseline, whose samples miss energy, is scaled per channel to the map's.
 */
#include "prefilter_impl.h"
#include "ggx.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- lat-long lookups ---- */

/* u, v in [0, 1] of a direction (v = 0 at the top). */
static inline void dir_uv(const double d[3], double *u, double *v)
{
    double z = d[2];
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + z * z);
    z = len > 0 ? z / len : 1.0;
    z = z > 1 ? 1 : z < -1 ? -1 : z;
    *u = 0.5 * (1.0 - atan2(d[1], d[0]) / ENVL_PI);
    *v = 0.5 - asin(z) / ENVL_PI;
}

/* Means of the first and last rows (the values at the poles). */
static void pole_means(const float *img, int32_t w, int32_t h, double out[6])
{
    for (int k = 0; k < 6; k++)
        out[k] = 0;
    for (int32_t c = 0; c < w; c++)
        for (int k = 0; k < 3; k++) {
            out[k] += img[3 * c + k];
            out[3 + k] += img[3 * ((size_t)(h - 1) * w + c) + k];
        }
    for (int k = 0; k < 6; k++)
        out[k] /= w;
}

/* A lat-long image as the lookups see it (the map or a product). */
typedef struct mip_view {
    const float *px;
    int32_t w, h;
    double pole[6];           /* means of the first and last rows */
} mip_view;

/* Adds wgt * (row r at column coordinate x, linear between texel centres, wrapping) to acc. */
static inline void row_lerp_add(const mip_view *lv, int32_t r, double x, double wgt,
                                double acc[3])
{
    double fx = floor(x), tx = x - fx;
    int64_t x0 = (int64_t)fx % lv->w;
    if (x0 < 0)
        x0 += lv->w;
    int64_t x1 = x0 + 1 == lv->w ? 0 : x0 + 1;
    const float *row = lv->px + 3 * (size_t)r * lv->w;
    const float *a = row + 3 * x0, *b = row + 3 * x1;
    double wa = wgt * (1 - tx), wb = wgt * tx;
    for (int k = 0; k < 3; k++)
        acc[k] += wa * a[k] + wb * b[k];
}

/* Adds weight * the image at continuous pixel coordinates (x, y) (pixel centres at integers)
 * to acc: bilinear, wrapping in x; between the centre of the first (last) row and the pole,
 * linear towards `pole` (the row's mean: the value at the pole itself). Rows are interpolated
 * linearly in the row coordinate: the weight a row gets, integrated over the sphere, is its own
 * solid angle to second order ((pi / h)^2 / 24). (Interpolating linearly in z between the rows'
 * z-midpoints instead reproduces a map linear in z exactly but gives the first row 1.5 times
 * its solid angle: in the specular levels a bright zenith came out 4-12 % too bright at
 * roughness 0.5-1.) */
static inline void view_add(const mip_view *lv, double x, double y, double weight, double acc[3])
{
    int32_t h = lv->h;
    if (y < 0 || y > h - 1) {
        int top = y < 0;
        double t = top ? -2.0 * y : 2.0 * (y - (h - 1)); /* 0 at the row centre, 1 at the pole */
        t = t > 1 ? 1 : t;
        const double *pv = lv->pole + (top ? 0 : 3);
        for (int k = 0; k < 3; k++)
            acc[k] += weight * t * pv[k];
        row_lerp_add(lv, top ? 0 : h - 1, x, weight * (1 - t), acc);
        return;
    }
    int32_t y0 = (int32_t)y;
    double ty = y - y0;
    row_lerp_add(lv, y0, x, weight * (1 - ty), acc);
    if (ty > 0)
        row_lerp_add(lv, y0 + 1 < h ? y0 + 1 : h - 1, x, weight * ty, acc);
}

/* Adds weight * L(u, v) to acc (u, v: lat-long image coordinates in [0, 1]). */
static inline void mip_add(const mip_view *lv, double u, double v, double weight, double acc[3])
{
    view_add(lv, u * lv->w - 0.5, v * lv->h - 0.5, weight, acc);
}

void envl_latlong_sample(const float *rgb, int32_t w, int32_t h, const double d[3],
                         double out[3])
{
    out[0] = out[1] = out[2] = 0;
    if (!rgb || w <= 0 || h <= 0 || !d)
        return;
    double u, v;
    dir_uv(d, &u, &v);
    mip_view lv = {rgb, w, h, {0}};
    double y = v * h - 0.5;
    if (y < 0 || y > h - 1)
        pole_means(rgb, w, h, lv.pole);
    view_add(&lv, u * w - 0.5, y, 1.0, out);
}

/* ---- GGX ---- */

typedef struct ggx_sample {
    double l[3];       /* in the tangent frame (east, north, R) */
    double weight;     /* R.l */
} ggx_sample;

/* The n GGX directions of a level; returns how many have R.l > 0. */
static int32_t make_samples(double alpha, int32_t n, ggx_sample *s)
{
    double a2 = alpha * alpha;
    int32_t k = 0;
    for (int32_t i = 0; i < n; i++) {
        double e1 = (i + 0.5) / n, e2 = envl__radical_inverse((uint32_t)i);
        double c2 = (1.0 - e1) / (1.0 + (a2 - 1.0) * e1);
        double ct = sqrt(c2), st = sqrt(fmax(0.0, 1.0 - c2));
        double phi = 2.0 * ENVL_PI * e2;
        double h[3] = {st * cos(phi), st * sin(phi), ct};
        /* l = 2 (V.h) h - V with V = (0, 0, 1) */
        double l[3] = {2 * ct * h[0], 2 * ct * h[1], 2 * ct * ct - 1};
        if (l[2] <= 0)
            continue;
        s[k].l[0] = l[0], s[k].l[1] = l[1], s[k].l[2] = l[2];
        s[k].weight = l[2];
        k++;
    }
    return k;
}

typedef struct level_job {
    const ggx_sample *s;
    int32_t ns, layout, w, h; /* the level's texels (layout.c) */
    const mip_view *lv;       /* the map */
    double wsum;
    float *out;
} level_job;

static void level_rows(void *ctx, int64_t begin, int64_t end)
{
    level_job *j = ctx;
    for (int64_t r = begin; r < end; r++) {
        for (int32_t c = 0; c < j->w; c++) {
            /* R and its frame: east T = normalize(z x R), north B = R x T (any T at a pole) */
            double R[3], T[3] = {-1, 0, 0}, B[3];
            envl__texel_direction(j->layout, j->w, j->h, c, (int32_t)r, R);
            double e = sqrt(R[0] * R[0] + R[1] * R[1]);
            if (e > 0)
                T[0] = -R[1] / e, T[1] = R[0] / e, T[2] = 0;
            B[0] = R[1] * T[2] - R[2] * T[1];
            B[1] = R[2] * T[0] - R[0] * T[2];
            B[2] = R[0] * T[1] - R[1] * T[0];
            double acc[3] = {0, 0, 0};
            for (int32_t i = 0; i < j->ns; i++) {
                const ggx_sample *s = j->s + i;
                double d[3];
                for (int k = 0; k < 3; k++)
                    d[k] = s->l[0] * T[k] + s->l[1] * B[k] + s->l[2] * R[k];
                double u, v;
                dir_uv(d, &u, &v);
                mip_add(j->lv, u, v, s->weight, acc);
            }
            float *o = j->out + 3 * ((size_t)r * j->w + c);
            for (int k = 0; k < 3; k++)
                o[k] = (float)(acc[k] / j->wsum);
        }
    }
}

/* The mirror level as cube faces: each texel the map's mean over its footprint (the map read
 * as piecewise constant, as the lat-long level's exact area resampling reads it), by sub-texels
 * at least 4 to a pixel of the coarsest mip level no coarser than the texels (an area mean of
 * the map: a 4K map's 256-texel faces read its 1024-wide level, 36 lookups a texel, not 441). */
typedef struct mirror_job {
    envl_image map;
    int32_t w, h, n;
    float *out;
} mirror_job;

static void mirror_rows(void *ctx, int64_t begin, int64_t end)
{
    mirror_job *j = ctx;
    for (int64_t r = begin; r < end; r++)
        for (int32_t c = 0; c < j->w; c++) {
            double v[3];
            envl__texel_footprint_mean(&j->map, ENVL_LAYOUT_STRIP_H, j->w, j->h, c, (int32_t)r,
                                       j->n, v);
            for (int k = 0; k < 3; k++)
                j->out[3 * ((size_t)r * j->w + c) + k] = (float)v[k];
        }
}

static envl_result mirror_faces(envl_envmap *m, int32_t face, int32_t threads, float **out)
{
    /* a texel at a face's centre is 2 / face radians across, the widest */
    envl_image map;
    envl_result rc = envl__mip_level_for(m, 2.0 / face, &map);
    if (rc)
        return rc;
    float *px = malloc(sizeof(float) * 3 * 6 * (size_t)face * face);
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory for %d-texel faces",
                          (int)face);
    mirror_job j = {map, 6 * face, face, envl__footprint_subdivision(2.0 / face, map.height),
                    px};
    envl__parallel_for(face, threads, mirror_rows, &j);
    *out = px;
    return ENVL_OK;
}

/* sp: the map's split with the cells of the map less its sun lights (NULL or no cells: the
 * map's own cells). The level's texels: a lat-long image `width` wide, or with o->faces cube
 * faces of width / 4 (layout.c's strip), each computed at its own centre direction. */
envl_result envl__specular_level(envl_envmap *m, const resolved *o, double roughness,
                                  int32_t width, const split *sp, float **out, envl_level *st)
{
    double t0 = envl__seconds();
    *out = NULL;
    if (!(roughness >= 0 && roughness <= 1))
        return envl__fail(ENVL_ERR_ARGUMENT, "prefilter: roughness %g is not in [0, 1]",
                          roughness);
    if (width <= 0)
        width = envl__level_width(o, roughness);
    if (width < 2 || width > 65536)
        return envl__fail(ENVL_ERR_ARGUMENT, "prefilter: level width %d (2..65536)", (int)width);
    int32_t layout = o->faces ? ENVL_LAYOUT_STRIP_H : ENVL_LAYOUT_LATLONG;
    int32_t face = width / 4 > 0 ? width / 4 : 1;
    int32_t w = o->faces ? 6 * face : width, h = o->faces ? face : width / 2;
    memset(st, 0, sizeof *st);
    st->roughness = roughness;
    st->alpha = roughness * roughness;
    st->width = w;
    st->height = h;
    st->layout = layout;
    st->energy_scale = 1.0;
    st->glossy_error = -1;
    st->texel_error = envl__texel_error_none;
    envl_result rc;
    if (roughness == 0) {
        rc = o->faces ? mirror_faces(m, face, o->threads, out)
                      : envl__latlong_resample(m->px, m->width, m->height, w, h, 0.0, out);
        st->seconds = envl__seconds() - t0;
        return rc;
    }
    double ein[3];
    float *px = malloc(sizeof(float) * 3 * (size_t)w * h);
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory for a %d x %d level",
                          (int)w, (int)h);
    int32_t nsamp = o->samples;
    if (o->unfiltered) {
        ggx_sample *s = malloc(sizeof(ggx_sample) * (size_t)nsamp);
        if (!s) {
            free(px);
            return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory");
        }
        int32_t ns = make_samples(st->alpha, nsamp, s);
        double wsum = 0;
        for (int32_t i = 0; i < ns; i++)
            wsum += s[i].weight;
        if (ns == 0 || !(wsum > 0)) {
            /* Cannot happen for n >= 1 (the first sample has the largest N.h), but be safe. */
            free(s);
            free(px);
            return envl__fail(ENVL_ERR_ARGUMENT, "prefilter: no usable GGX sample");
        }
        mip_view lv = {m->px, m->width, m->height, {0}};
        pole_means(m->px, m->width, m->height, lv.pole);
        level_job job = {s, ns, layout, w, h, &lv, wsum, px};
        envl__parallel_for(h, o->threads, level_rows, &job);
        free(s);
        envl__image_energy(m->px, ENVL_LAYOUT_LATLONG, m->width, m->height, ein);
    } else {
        const envl_cells *C = sp && sp->cells ? sp->cells : NULL;
        int32_t base = envl__cells_base(NULL, st->alpha, m->height);
        if (!C && (rc = envl__map_cells(m, base, &C, NULL))) {
            free(px);
            return rc;
        }
        double terms;
        if ((rc = envl__cells_level(C, st->alpha, envl__level_rho(o, width), layout, w, h,
                                    o->threads, px, &terms))) {
            free(px);
            return rc;
        }
        nsamp = (int32_t)floor(terms + 0.5);
        envl__cells_energy(C, ein);
    }
    double eout[3];
    envl__image_energy(px, layout, w, h, eout);
    double yin = envl__lum(ein[0], ein[1], ein[2]), yout = envl__lum(eout[0], eout[1], eout[2]);
    if (yout > 0 && yin > 0)
        st->energy_scale = yout / yin;
    for (int k = 0; k < 3 && o->unfiltered; k++) {
        if (!(eout[k] > 0 && ein[k] > 0))
            continue;
        double f = ein[k] / eout[k];
        for (size_t i = 0; i < (size_t)w * h; i++)
            px[3 * i + k] = (float)(px[3 * i + k] * f);
    }
    st->samples = nsamp;
    st->filtered = !o->unfiltered;
    st->seconds = envl__seconds() - t0;
    *out = px;
    return ENVL_OK;
}

envl_result envl__level_finite(const envl_envmap *m, const envl_level *st, float **px)
{
    if (envl__floats_finite(*px, 3 * (size_t)st->width * st->height))
        return ENVL_OK;
    free(*px);
    *px = NULL;
    return envl__fail(ENVL_ERR_NONFINITE, "%s: the specular level of roughness %g overflows "
                      "the float range", m->info.file[0] ? m->info.file : "the map",
                      st->roughness);
}

envl_result envl_prefilter_specular(envl_envmap *m, double roughness, int32_t width,
                                    const envl_prefilter_options *options, float **rgb,
                                    envl_level *stats)
{
    if (!m || !rgb)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_prefilter_specular: NULL argument");
    *rgb = NULL;
    resolved o;
    envl_result rc = envl__points_map(m, &m); /* a too coarse map split first */
    if (!rc)
        rc = envl__prefilter_resolve(options, m, &o);
    if (rc)
        return rc;
    envl_level st;
    rc = envl__specular_level(m, &o, roughness, width, NULL, rgb, &st);
    if (!rc) /* never silently non-finite */
        rc = envl__level_finite(m, &st, rgb);
    if (rc == ENVL_OK && stats) {
        st.rgb = *rgb;
        *stats = st;
    }
    return rc;
}
