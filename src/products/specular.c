/* The GGX specular level of roughness r (alpha = r^2): filtered importance sampling over the
 * cached mip pyramid (mips.c) or, when bright pixels were split off, over the residual's own
 * pyramid with the bright pixels added as lobes (bright_lobes.c).
 *
 * docs/design.md's split-sum prefiltered radiance, N = V = R:
 *   P(R) = int L(l) D(h) max(R.l, 0) dl / int D(h) max(R.l, 0) dl.
 * Sampling half vectors h from D(h) (N.h) (GGX, Hammersley points) and reflecting V = R about
 * them gives l with pdf D(h) (N.h) / (4 V.h) = D(h) / 4 (N = V); the estimator of P is then
 * sum L(l_i) (R.l_i) / sum (R.l_i) (Karis 2013). The same n directions, in the texel's tangent
 * frame (east, north, R), serve every texel, so results are deterministic and smooth.
 * Filtered importance sampling (Colbert & Krivanek 2007): sample i stands for the solid angle
 * omega_i = 1 / (n pdf_i) = 4 / (n D(h_i)); it reads the mip level whose texels are as tall as
 * that footprint, lod = 0.5 log2(omega_i / (pi / H)^2) + LOD_BIAS (H: the map's height; a texel
 * of level k spans pi 2^k / H in elevation and less in azimuth, so this never blurs more than
 * the footprint in either direction; LOD_BIAS below says why it is 0). The elevation rule beat
 * matching the texel's area (which blurs the polar rows). Lookups are bilinear in the lat-long
 * image (linear in azimuth and between row centres; see mip_view), blending into the row mean
 * at the poles. The pyramid is the map
 * area-averaged by envl__latlong_resample (exact), built once per map.
 * Roughness exactly 0 is the map itself, area-resampled to the level's size.
 *
 * Energy: the kernel D(h) max(R.l, 0) / norm depends on R.l only, so the integral of P over
 * the sphere equals the map's exactly. A finite sample pattern misses that by a little (the
 * pattern's points land at different phases of the mip texels); each level is therefore
 * scaled, per channel, so its integral of L dw equals the map's. The factor before the
 * correction is reported (energy_scale) and tested to stay near 1.
 */
#include "prefilter_impl.h"
#include "ggx.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Mip level offset of a sample: 0 reads the level whose texel is as tall as the sample's solid
 * angle. With bilinear row lookups, 0.5 (a blurrier level, as Karis suggests against noise)
 * cost accuracy at roughness 0.5-1 on every map measured (1.0-1.4 % against 0.6-1.3 % at 1). */
#define LOD_BIAS 0.0

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

/* A lat-long image as the lookups see it (the map, a level of its pyramid or a product). */
typedef struct mip_view {
    const float *px;
    int32_t w, h;
    int32_t *taps;            /* NULL: 1; else lookups per row: 1, or ~1 / sin(colatitude) near
                                 the poles,
                                 where a texel is that much narrower than it is tall, so a
                                 lookup covers the footprint its level was chosen for (else a
                                 thin bright line through a pole aliases into +-20 % noise) */
    double pole[6];           /* means of the first and last rows */
} mip_view;

/* Near a pole: the mean of n lerps one texel apart (an n-texel box in azimuth), which is
 * texels x0 .. x0 + n weighted (1 - tx, 1, ..., 1, tx) / n. */
static void row_box_add(const mip_view *lv, int32_t r, int32_t n, double x, double wgt,
                        double acc[3])
{
    double start = x - 0.5 * (n - 1), fx = floor(start), tx = start - fx;
    int64_t c = (int64_t)fx % lv->w;
    if (c < 0)
        c += lv->w;
    const float *row = lv->px + 3 * (size_t)r * lv->w;
    wgt /= n;
    for (int32_t i = 0; i <= n; i++) {
        const float *p = row + 3 * c;
        double f = wgt * (i == 0 ? 1 - tx : i == n ? tx : 1.0);
        acc[0] += f * p[0], acc[1] += f * p[1], acc[2] += f * p[2];
        if (++c == lv->w)
            c = 0;
    }
}

/* Adds wgt * (row r at column coordinate x, linear between texel centres, wrapping) to acc. */
static inline void row_lerp_add(const mip_view *lv, int32_t r, double x, double wgt,
                                double acc[3])
{
    int32_t n = lv->taps ? lv->taps[r] : 1;
    if (n > 1) {
        row_box_add(lv, r, n, x, wgt, acc);
        return;
    }
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
    mip_view lv = {rgb, w, h, NULL, {0}};
    double y = v * h - 0.5;
    if (y < 0 || y > h - 1)
        pole_means(rgb, w, h, lv.pole);
    view_add(&lv, u * w - 0.5, y, 1.0, out);
}

/* ---- GGX ---- */

typedef struct ggx_sample {
    double l[3];       /* in the tangent frame (east, north, R) */
    double weight;     /* R.l */
    double lod0;       /* mip level: 0.5 log2(omega_s / (pi / H)^2) + LOD_BIAS */
} ggx_sample;

/* The n GGX directions of a level; returns how many have R.l > 0. */
static int32_t make_samples(double alpha, int32_t n, int32_t w0, int32_t h0, ggx_sample *s)
{
    double a2 = alpha * alpha;
    double log2_texel = 2.0 * log2(ENVL_PI / h0);
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
        double pdf = ggx_d(c2, a2) / 4.0;
        double omega = 1.0 / (n * pdf);
        s[k].l[0] = l[0], s[k].l[1] = l[1], s[k].l[2] = l[2];
        s[k].weight = l[2];
        s[k].lod0 = 0.5 * (log2(omega) - log2_texel) + LOD_BIAS;
        k++;
    }
    return k;
}

typedef struct level_job {
    const ggx_sample *s;
    int32_t ns, w, h;
    const mip_view *lv;       /* the pyramid (or the map alone: unfiltered) */
    int32_t nlev;
    double wsum;
    float *out;
} level_job;

static void level_rows(void *ctx, int64_t begin, int64_t end)
{
    level_job *j = ctx;
    int32_t nlev = j->nlev;
    for (int64_t r = begin; r < end; r++) {
        double theta = ENVL_PI * (0.5 - (r + 0.5) / j->h);
        double ct = cos(theta), st = sin(theta);
        for (int32_t c = 0; c < j->w; c++) {
            double phi = ENVL_PI * (1.0 - 2.0 * (c + 0.5) / j->w);
            double cp = cos(phi), sp = sin(phi);
            double R[3] = {ct * cp, ct * sp, st};
            double T[3] = {-sp, cp, 0};
            double B[3] = {-st * cp, -st * sp, ct};
            double acc[3] = {0, 0, 0};
            for (int32_t i = 0; i < j->ns; i++) {
                const ggx_sample *s = j->s + i;
                double d[3];
                for (int k = 0; k < 3; k++)
                    d[k] = s->l[0] * T[k] + s->l[1] * B[k] + s->l[2] * R[k];
                double u, v;
                dir_uv(d, &u, &v);
                if (nlev == 1) {
                    mip_add(&j->lv[0], u, v, s->weight, acc);
                    continue;
                }
                double lod = s->lod0;
                if (lod < 0)
                    lod = 0;
                if (lod > nlev - 1)
                    lod = nlev - 1;
                int32_t k0 = (int32_t)lod;
                double t = lod - k0;
                mip_add(&j->lv[k0], u, v, s->weight * (1 - t), acc);
                if (t > 0 && k0 + 1 < nlev)
                    mip_add(&j->lv[k0 + 1], u, v, s->weight * t, acc);
            }
            float *o = j->out + 3 * ((size_t)r * j->w + c);
            for (int k = 0; k < 3; k++)
                o[k] = (float)(acc[k] / j->wsum);
        }
    }
}

/* sp: the map's split (NULL: made here when needed). */
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
    int32_t h = width / 2;
    memset(st, 0, sizeof *st);
    st->roughness = roughness;
    st->alpha = roughness * roughness;
    st->width = width;
    st->height = h;
    st->energy_scale = 1.0;
    st->glossy_error = -1;
    envl_result rc;
    if (roughness == 0) {
        rc = envl__latlong_resample(m->px, m->width, m->height, width, h, 0.0, out);
        st->seconds = envl__seconds() - t0;
        return rc;
    }
    split own = {0};
    if (!o->unfiltered && !sp) {
        if ((rc = envl__split_make(m, &own)))
            return rc;
        sp = &own;
    }
    int use_split = !o->unfiltered && sp->sun.n > 0;
    if (!o->unfiltered && !use_split && (rc = envl_envmap_mips(m, NULL))) {
        envl__split_free(&own);
        return rc;
    }
    int32_t nsamp = envl__level_samples(o, width);
    ggx_sample *s = malloc(sizeof(ggx_sample) * (size_t)nsamp);
    float *px = malloc(sizeof(float) * 3 * (size_t)width * h);
    if (!s || !px) {
        free(s);
        free(px);
        envl__split_free(&own);
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory for a %d x %d level",
                          (int)width, (int)h);
    }
    int32_t ns = make_samples(st->alpha, nsamp, m->width, m->height, s);
    double wsum = 0;
    for (int32_t i = 0; i < ns; i++)
        wsum += s[i].weight;
    if (ns == 0 || !(wsum > 0)) {
        /* Cannot happen for n >= 1 (the first sample has the largest N.h), but be safe. */
        free(s);
        free(px);
        envl__split_free(&own);
        return envl__fail(ENVL_ERR_ARGUMENT, "prefilter: no usable GGX sample");
    }
    int32_t nlev = o->unfiltered ? 1 : use_split ? sp->levels : m->mip_levels;
    mip_view *lv = calloc((size_t)nlev, sizeof(mip_view));
    size_t nz = 0;
    for (int32_t k = 0; k < nlev; k++)
        nz += o->unfiltered ? m->height : use_split ? sp->mh[k] : m->mip_h[k];
    int32_t *taps = malloc(sizeof(int32_t) * nz);
    if (!lv || !taps) {
        free(taps);
        free(lv);
        free(s);
        free(px);
        envl__split_free(&own);
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory");
    }
    for (int32_t k = 0, off = 0; k < nlev; k++) {
        if (use_split) {
            lv[k].px = k == 0 ? sp->sun.res : sp->mip + sp->off[k];
            lv[k].w = sp->mw[k];
            lv[k].h = sp->mh[k];
        } else {
            lv[k].px = envl__mip_level(m, k);
            lv[k].w = o->unfiltered ? m->width : m->mip_w[k];
            lv[k].h = o->unfiltered ? m->height : m->mip_h[k];
        }
        lv[k].taps = taps + off;
        for (int32_t r = 0; r < lv[k].h; r++) {
            double sc = sin(ENVL_PI * (r + 0.5) / lv[k].h); /* sin(colatitude) at the centre */
            double n = floor(1.0 / sc + 1e-9);
            lv[k].taps[r] = o->unfiltered || n < 2 ? 1 : n > lv[k].w ? lv[k].w : (int32_t)n;
        }
        off += lv[k].h;
        pole_means(lv[k].px, lv[k].w, lv[k].h, lv[k].pole);
    }
    level_job job = {s, ns, width, h, lv, nlev, wsum, px};
    envl__parallel_for(h, o->threads, level_rows, &job);
    free(lv);
    free(taps);
    free(s);
    double ein[3], eout[3];
    envl__image_energy(use_split ? sp->sun.res : m->px, m->width, m->height, ein);
    envl__image_energy(px, width, h, eout);
    double yin = envl__lum(ein[0], ein[1], ein[2]), yout = envl__lum(eout[0], eout[1], eout[2]);
    if (yout > 0 && yin > 0)
        st->energy_scale = yout / yin;
    for (int k = 0; k < 3; k++) {
        if (!(eout[k] > 0 && ein[k] > 0))
            continue;
        double f = ein[k] / eout[k];
        for (size_t i = 0; i < (size_t)width * h; i++)
            px[3 * i + k] = (float)(px[3 * i + k] * f);
    }
    if (use_split)
        rc = envl__add_lobes(&sp->sun, m->height, st->alpha, width, h, o->threads, px);
    envl__split_free(&own);
    if (rc) {
        free(px);
        return rc;
    }
    st->samples = nsamp;
    st->filtered = !o->unfiltered;
    st->seconds = envl__seconds() - t0;
    *out = px;
    return ENVL_OK;
}

envl_result envl_prefilter_specular(envl_envmap *m, double roughness, int32_t width,
                                    const envl_prefilter_options *options, float **rgb,
                                    envl_level *stats)
{
    if (!m || !rgb)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_prefilter_specular: NULL argument");
    resolved o;
    envl_result rc = envl__prefilter_resolve(options, m, &o);
    if (rc)
        return rc;
    envl_level st;
    rc = envl__specular_level(m, &o, roughness, width, NULL, rgb, &st);
    if (rc == ENVL_OK && stats) {
        st.rgb = *rgb;
        *stats = st;
    }
    return rc;
}
