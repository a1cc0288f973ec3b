/* Prefiltered maps: the GGX specular chain (filtered importance sampling over a cached mip
 * pyramid), irradiance maps, the brute-force glossy reference, requests that compute only what
 * a scene needs, and the export of the products (EXR / HDR / PFM / RGBM PNG, lat-long, cube
 * faces, vertical cross, RGBM atlas, JSON sidecar).
 *
 * ---- The specular level of roughness r (alpha = r^2) -----------------------------------------
 * DESIGN.md's split-sum prefiltered radiance, N = V = R:
 *   P(R) = int L(l) D(h) max(R.l, 0) dl / int D(h) max(R.l, 0) dl.
 * Sampling half vectors h from D(h) (N.h) (GGX, Hammersley points) and reflecting V = R about
 * them gives l with pdf D(h) (N.h) / (4 V.h) = D(h) / 4 (N = V); the estimator of P is then
 * sum L(l_i) (R.l_i) / sum (R.l_i) (Karis 2013). The same n directions, in the texel's tangent
 * frame (east, north, R), serve every texel, so results are deterministic and smooth.
 * Filtered importance sampling (Colbert & Krivanek 2007): sample i stands for the solid angle
 * omega_i = 1 / (n pdf_i) = 4 / (n D(h_i)); it reads the mip level whose texels are as tall as
 * that footprint, lod = 0.5 log2(omega_i / (pi / H)^2) + 0.5 (H: the map's height; a texel of
 * level k spans pi 2^k / H in elevation and less in azimuth, so this never blurs more than the
 * footprint in either direction). Measured on real maps, a bias of 0.5 level beat Colbert &
 * Krivanek's 1 and 0, and the elevation rule beat matching the texel's area (which blurs the
 * polar rows). Lookups are linear in azimuth and linear in z between the rows' z-midpoints
 * (see mip_view), blending into the row mean at the poles. The pyramid is the map
 * area-averaged by envl__latlong_resample (exact), built once per map.
 * Roughness exactly 0 is the map itself, area-resampled to the level's size.
 *
 * Energy: the kernel D(h) max(R.l, 0) / norm depends on R.l only, so the integral of P over
 * the sphere equals the map's exactly. A finite sample pattern misses that by a little (the
 * pattern's points land at different phases of the mip texels); each level is therefore
 * scaled, per channel, so its integral of L dw equals the map's. The factor before the
 * correction is reported (energy_scale) and tested to stay near 1.
 */
#include "internal.h"
#include "envmap_impl.h"
#include "sun_split.h"
#include "json.h" /* json_write_escaped only (header-only) */

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define DEFAULT_WIDTH 512
#define DEFAULT_MIN_WIDTH 64
#define DEFAULT_SAMPLES 64
#define DEFAULT_IRRADIANCE_WIDTH 64
#define RESAMPLED_IRRADIANCE_WIDTH 256
/* Mip level offset of a sample: 0 reads the level whose texel is as tall as the sample's solid
 * angle. With bilinear row lookups, 0.5 (a blurrier level, as Karis suggests against noise)
 * cost accuracy at roughness 0.5-1 on every map measured (1.0-1.4 % against 0.6-1.3 % at 1). */
#define LOD_BIAS 0.0

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* ---- names ---- */

static const char *irr_names[ENVL_IRRADIANCE_COUNT] = {"resampled", "sh", "exact"};
static const char *export_names[ENVL_EXPORT_COUNT] = {"latlong", "cube", "cross", "atlas"};

const char *envl_irradiance_method_name(int32_t m)
{
    return m >= 0 && m < ENVL_IRRADIANCE_COUNT ? irr_names[m] : NULL;
}

int32_t envl_irradiance_method_from_name(const char *name)
{
    for (int32_t i = 0; name && i < ENVL_IRRADIANCE_COUNT; i++)
        if (!strcmp(name, irr_names[i]))
            return i;
    return -1;
}

const char *envl_export_layout_name(int32_t l)
{
    return l >= 0 && l < ENVL_EXPORT_COUNT ? export_names[l] : NULL;
}

int32_t envl_export_layout_from_name(const char *name)
{
    for (int32_t i = 0; name && i < ENVL_EXPORT_COUNT; i++)
        if (!strcmp(name, export_names[i]))
            return i;
    return -1;
}

/* ---- options ---- */

typedef struct resolved {
    int32_t levels, width, min_width, samples, unfiltered;
    int32_t irr_method, irr_width, irr_order, threads, sun_lights;
} resolved;

static envl_result resolve(const envl_prefilter_options *o, const envl_envmap *m, resolved *r)
{
    static const envl_prefilter_options defaults;
    if (!o)
        o = &defaults;
    r->levels = o->levels ? o->levels : ENVL_DEFAULT_LEVELS;
    r->width = o->width ? o->width : DEFAULT_WIDTH;
    r->min_width = o->min_width ? o->min_width : DEFAULT_MIN_WIDTH;
    r->samples = o->samples ? o->samples : DEFAULT_SAMPLES;
    r->unfiltered = o->unfiltered != 0;
    r->irr_method = o->irradiance_method;
    r->irr_width = o->irradiance_width ? o->irradiance_width : DEFAULT_IRRADIANCE_WIDTH;
    r->irr_order = o->irradiance_order ? o->irradiance_order : 2;
    r->threads = o->threads > 0 ? o->threads : m ? m->threads : envl__threads(0);
    r->sun_lights = o->sun_lights != 0;
    if (r->sun_lights && r->unfiltered)
        return envl__fail(ENVL_ERR_ARGUMENT, "prefilter: sun lights need the filtered levels "
                          "(the unfiltered baseline samples the map as it is)");
    if (r->levels < 1 || r->levels > 16 || r->width < 2 || r->width > 65536 ||
        r->min_width < 2 || r->samples < 1 || r->samples > (1 << 20) || r->irr_method < 0 ||
        r->irr_method >= ENVL_IRRADIANCE_COUNT || r->irr_width < 2 || r->irr_width > 65536 ||
        r->irr_order < 0 || r->irr_order > 32 || o->threads < 0)
        return envl__fail(ENVL_ERR_ARGUMENT,
                          "prefilter: levels %d (1..16), width %d (2..65536), min width %d (>= "
                          "2), samples %d (1..2^20), irradiance method %d, width %d or order %d "
                          "out of range", (int)r->levels, (int)r->width, (int)r->min_width,
                          (int)r->samples, (int)r->irr_method, (int)r->irr_width,
                          (int)r->irr_order);
    return ENVL_OK;
}

static int32_t level_width(const resolved *r, double roughness)
{
    int32_t k = r->levels > 1 ? (int32_t)floor(roughness * (r->levels - 1) + 1e-9) : 0;
    if (k < 0)
        k = 0;
    int32_t w = k >= 31 ? 0 : r->width >> k;
    int32_t mn = r->min_width < r->width ? r->min_width : r->width;
    return w < mn ? mn : w;
}

/* GGX samples per texel of a filtered level w wide: M at the base width W and M (W / w)^2 below
 * it, at most ROUGH_SAMPLES_MAX x M: a rough level's few texels get the samples its wide lobe
 * needs for about the base level's cost (at roughness 1 the sum of 128 mip footprints was
 * 0.4-6.8 % off the lobe on the built-in sky, adams_place_bridge, lebombo and forest_slope;
 * of 512, 0.1-2.9 %; README "Accuracy against time (specular)" has today's figures). The
 * unfiltered baseline always takes M. */
#define ROUGH_SAMPLES_MAX 8
static int32_t level_samples(const resolved *r, int32_t w)
{
    if (r->unfiltered || w >= r->width)
        return r->samples;
    double f = (double)r->width / w;
    double n = r->samples * fmin(f * f, ROUGH_SAMPLES_MAX);
    return n > (1 << 20) ? (1 << 20) : (int32_t)n;
}

int32_t envl_prefilter_level_width(const envl_prefilter_options *options, double roughness)
{
    resolved r;
    if (resolve(options, NULL, &r) || !(roughness >= 0 && roughness <= 1))
        return 0;
    return level_width(&r, roughness);
}

/* ---- the mip pyramid ---- */

/* The area-averaged pyramid of a W x H image: levels 1 .. *n - 1 in *buf at off[k]. */
static envl_result build_pyramid(const float *px, int32_t w, int32_t h, float **buf_out,
                                 int32_t *n_out, int32_t mw[40], int32_t mh[40], size_t off[40])
{
    int32_t n = 1;
    size_t total = 0;
    mw[0] = w, mh[0] = h, off[0] = 0;
    while ((w > 1 || h > 1) && n < 40) {
        w = w > 1 ? w / 2 : 1;
        h = h > 1 ? h / 2 : 1;
        mw[n] = w, mh[n] = h, off[n] = total;
        total += (size_t)w * h * 3;
        n++;
    }
    float *buf = n > 1 ? NULL : malloc(sizeof(float));
    if (n == 1 && !buf)
        return envl__fail(ENVL_ERR_MEMORY, "mip pyramid: out of memory");
    const float *prev = px;
    for (int32_t k = 1; k < n; k++) {
        float *lev;
        /* Levels nest (each texel edge of level k is one of level k - 1, in azimuth and in
         * z), so resampling the previous level is the same as resampling the map. */
        envl_result rc = envl__latlong_resample(prev, mw[k - 1], mh[k - 1], mw[k], mh[k],
                                                0.0, &lev);
        if (rc) {
            free(buf);
            return rc;
        }
        if (k == 1) {
            /* Level 1 sits at offset 0: its buffer grows to hold every level (for a large
             * block realloc remaps the pages: no second copy of level 1 at the peak). */
            buf = realloc(lev, sizeof(float) * total);
            if (!buf) {
                free(lev);
                return envl__fail(ENVL_ERR_MEMORY, "mip pyramid: out of memory");
            }
        } else {
            memcpy(buf + off[k], lev, sizeof(float) * (size_t)mw[k] * mh[k] * 3);
            free(lev);
        }
        prev = buf + off[k];
    }
    *buf_out = buf;
    *n_out = n;
    return ENVL_OK;
}

envl_result envl_envmap_mips(envl_envmap *m, int32_t *levels)
{
    if (!m)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_mips: map is NULL");
    if (!m->mip_levels) {
        int32_t n, mw[40], mh[40];
        size_t off[40];
        float *buf;
        envl_result rc = build_pyramid(m->px, m->width, m->height, &buf, &n, mw, mh, off);
        if (rc)
            return rc;
        m->mip_px = buf;
        for (int32_t k = 0; k < n; k++)
            m->mip_w[k] = mw[k], m->mip_h[k] = mh[k], m->mip_offset[k] = off[k];
        m->mip_levels = n;
    }
    if (levels)
        *levels = m->mip_levels;
    return ENVL_OK;
}

void envl_envmap_drop_mips(envl_envmap *m)
{
    if (!m)
        return;
    free(m->mip_px);
    m->mip_px = NULL;
    m->mip_levels = 0;
}

static const float *mip_level(const envl_envmap *m, int32_t k)
{
    return k == 0 ? m->px : m->mip_px + m->mip_offset[k];
}

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

static inline double ggx_d(double noh2, double a2)
{
    double q = noh2 * (a2 - 1.0) + 1.0;
    return a2 / (ENVL_PI * q * q);
}

/* w(u) = D(h) R.l up to a constant, u = R.l > 0 (N = V = R, h = normalize(R + l), so
 * (N.h)^2 = (1 + u) / 2): u / q^2, q = ((1 + u) / 2)(alpha^2 - 1) + 1. */
static inline double ggx_w(double u, double a2)
{
    double q = 0.5 * (1 + u) * (a2 - 1) + 1;
    return u / (q * q);
}


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

/* Integral of L dw of a lat-long image, per channel. */
static void image_energy(const float *px, int32_t w, int32_t h, double e[3])
{
    e[0] = e[1] = e[2] = 0;
    for (int32_t r = 0; r < h; r++) {
        double row[3] = {0, 0, 0};
        const float *p = px + (size_t)r * w * 3;
        for (int32_t c = 0; c < w; c++)
            for (int k = 0; k < 3; k++)
                row[k] += p[3 * c + k];
        double om = envl_latlong_solid_angle(w, h, r);
        for (int k = 0; k < 3; k++)
            e[k] += om * row[k];
    }
}

/* ---- bright pixels as point lobes ----
 * Before sampling, the bright pixels are split off the map (sun_split.c): the residual keeps
 * each pixel above T (SPLIT_K x the map's mean luminance, or raised) scaled to luminance T, and
 * the excess E_j (per channel) is a point lobe at the pixel's centre direction l_j. The
 * residual is filtered as any map (its own pyramid, not the map's cached one) and the lobes are
 * added analytically:
 *   P(R) += sum_j E_j w(R.l_j) / N(alpha),  w(u) = u / q^2,  q = ((1 + u) / 2)(a^2 - 1) + 1,
 * (D(h) R.l up to a constant, as the reference sums it), N(alpha) = integral of w over the
 * sphere = 2 pi int_0^1 u / (A + B u)^2 du = (2 pi / B^2)(ln(a^2 / A) + A / a^2 - 1) with
 * A = (1 + a^2) / 2, B = (a^2 - 1) / 2 (pi at a = 1). Lobes closer than SPLIT_CLUSTER alpha
 * (same cell of a lat-long grid that fine) are merged at their energy-weighted centroid; where
 * an output texel is wider than 2 alpha the lobe is averaged over the texel (supersampled).
 * Both parts are energy-scaled separately (the residual like any level; the lobes to sum E).
 * With options.sun_lights the groups of split pixels that are suns become lights
 * (envl__sun_split_lights) and are not baked. */
#define SPLIT_CLUSTER 0.1

typedef envl_sun_lobe lobe;

typedef struct split {
    envl_sun_split sun;       /* the lobes and the residual (sun_split.c) */
    float *mip;               /* the residual's pyramid, levels 1 .. levels - 1 */
    int32_t levels, mw[40], mh[40];
    size_t off[40];
} split;

static void split_free(split *s)
{
    envl__sun_split_free(&s->sun);
    free(s->mip);
    memset(s, 0, sizeof *s);
}

/* The map's split and, when anything was split, the pyramid of its residual. */
static envl_result make_split(const envl_envmap *m, split *s)
{
    memset(s, 0, sizeof *s);
    envl_result rc = envl__sun_split_make(m, &s->sun);
    if (rc || s->sun.n == 0)
        return rc;
    rc = build_pyramid(s->sun.res, m->width, m->height, &s->mip, &s->levels, s->mw, s->mh,
                       s->off);
    if (rc)
        split_free(s);
    return rc;
}

/* N(alpha): the integral of w over the sphere. */
double envl_ggx_lobe_norm(double alpha)
{
    double a2 = alpha * alpha;
    double A = 0.5 * (1 + a2), B = 0.5 * (a2 - 1), x = B / A;
    if (fabs(x) < 1e-3) /* ln(1+x) + 1/(1+x) - 1 = x^2/2 - 2x^3/3 + 3x^4/4 - ... */
        return 2 * ENVL_PI / (A * A) * (0.5 - 2 * x / 3 + 0.75 * x * x - 0.8 * x * x * x);
    return 2 * ENVL_PI / (B * B) * (log(a2 / A) + A / a2 - 1);
}


typedef struct lobe_job {
    const lobe *l;
    int32_t n, w, h, ss;
    double a2, inv_norm;
    float *out;               /* w x h x 3, the lobes' part (overwritten) */
} lobe_job;

static void lobe_rows(void *ctx, int64_t begin, int64_t end)
{
    lobe_job *j = ctx;
    int32_t ss = j->ss;
    for (int64_t r = begin; r < end; r++)
        for (int32_t c = 0; c < j->w; c++) {
            double acc[3] = {0, 0, 0}, wt = 0;
            for (int32_t sy = 0; sy < ss; sy++)
                for (int32_t sx = 0; sx < ss; sx++) {
                    double R[3];
                    envl_latlong_direction(j->w, j->h, c + (sx + 0.5) / ss - 0.5,
                                           r + (sy + 0.5) / ss - 0.5, R);
                    double sw = ss > 1 ? sqrt(fmax(0.0, 1 - R[2] * R[2])) : 1.0;
                    wt += sw;
                    for (int32_t i = 0; i < j->n; i++) {
                        const lobe *l = j->l + i;
                        double u = R[0] * l->d[0] + R[1] * l->d[1] + R[2] * l->d[2];
                        if (u <= 0)
                            continue;
                        double v = sw * ggx_w(u, j->a2);
                        acc[0] += v * l->e[0], acc[1] += v * l->e[1], acc[2] += v * l->e[2];
                    }
                }
            float *o = j->out + 3 * ((size_t)r * j->w + c);
            double f = wt > 0 ? j->inv_norm / wt : 0;
            for (int k = 0; k < 3; k++)
                o[k] = (float)(acc[k] * f);
        }
}

typedef struct cluster_key {
    int64_t key;
    int32_t i;
} cluster_key;

static int cmp_key(const void *a, const void *b)
{
    const cluster_key *x = a, *y = b;
    return x->key != y->key ? (x->key < y->key ? -1 : 1) : (x->i > y->i) - (x->i < y->i);
}

/* The lobes' part of a level (w x h, alpha), energy-scaled per channel to sum E. */
static envl_result add_lobes(const envl_sun_split *s, int32_t mh, double alpha, int32_t w,
                             int32_t h, int32_t threads, float *px)
{
    /* merge lobes in cells of f x f map pixels, f = the largest power of 2 with
     * f pi / H <= SPLIT_CLUSTER alpha */
    int32_t f = 1;
    while (f < (1 << 20) && 2.0 * f * ENVL_PI / mh <= SPLIT_CLUSTER * alpha)
        f *= 2;
    cluster_key *k = malloc(sizeof(cluster_key) * s->n);
    lobe *cl = calloc((size_t)s->n, sizeof(lobe));
    float *lp = malloc(sizeof(float) * 3 * (size_t)w * h);
    if (!k || !cl || !lp) {
        free(k), free(cl), free(lp);
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory");
    }
    int32_t nk = 0;
    for (int32_t i = 0; i < s->n; i++)
        if (!s->lobes[i].taken)
            k[nk].key = (int64_t)(s->lobes[i].r / f) * (1 << 30) + s->lobes[i].c / f,
            k[nk++].i = i;
    qsort(k, (size_t)nk, sizeof *k, cmp_key);
    int32_t nc = 0;
    double etot[3] = {0, 0, 0};
    for (int32_t i = 0; i < nk; i++) {
        if (i == 0 || k[i].key != k[i - 1].key)
            nc++;
        lobe *c = cl + nc - 1;
        const lobe *l = s->lobes + k[i].i;
        double y = envl__lum(l->e[0], l->e[1], l->e[2]);
        for (int q = 0; q < 3; q++)
            c->e[q] += l->e[q], c->d[q] += y * l->d[q], etot[q] += l->e[q];
    }
    for (int32_t i = 0; i < nc; i++) {
        double n = sqrt(cl[i].d[0] * cl[i].d[0] + cl[i].d[1] * cl[i].d[1] +
                        cl[i].d[2] * cl[i].d[2]);
        for (int q = 0; q < 3; q++)
            cl[i].d[q] = n > 0 ? cl[i].d[q] / n : 0;
    }
    double texel = ENVL_PI / h;
    int32_t ss = texel > 2 * alpha ? (int32_t)ceil(texel / alpha) : 1;
    ss = ss > 32 ? 32 : ss;
    lobe_job j = {cl, nc, w, h, ss, alpha * alpha, 1.0 / envl_ggx_lobe_norm(alpha), lp};
    envl__parallel_for(h, threads, lobe_rows, &j);
    double eout[3];
    image_energy(lp, w, h, eout);
    for (int q = 0; q < 3; q++) {
        double sc = eout[q] > 0 && etot[q] > 0 ? etot[q] / eout[q] : 1.0;
        for (size_t i = 0; i < (size_t)w * h; i++)
            px[3 * i + q] += (float)(lp[3 * i + q] * sc);
    }
    free(k), free(cl), free(lp);
    return ENVL_OK;
}

/* x, y completing the unit z to a right-handed frame (Duff et al. 2017). */
static void orthonormal_basis(const double z[3], double x[3], double y[3])
{
    double sg = z[2] >= 0 ? 1.0 : -1.0, a = -1.0 / (sg + z[2]), b = z[0] * z[1] * a;
    x[0] = 1 + sg * z[0] * z[0] * a, x[1] = sg * b, x[2] = -sg * z[0];
    y[0] = b, y[1] = sg + z[1] * z[1] * a, y[2] = -z[1];
}

/* Adds what the lights give to P(R) at roughness > 0, or to the irradiance E(n) for roughness
 * < 0, in `count` directions. A light is the uniform disc of its solid angle about its
 * direction (a sun as Cycles draws a sun lamp of that angle), integrated over SUN_DISC points
 * spread uniformly in solid angle (a Fibonacci spiral on the cap): P += E mean w(R.l) / N(alpha),
 * E += E mean max(n.l, 0). */
#define SUN_DISC 256
static void sun_lights_add(const envl_light *l, int32_t n, double roughness, int32_t count,
                           const double *dirs, double *out)
{
    double a = roughness * roughness, a2 = a * a;
    double inv = roughness > 0 ? 1.0 / envl_ggx_lobe_norm(a) : 0;
    for (int32_t j = 0; j < n; j++) {
        const double *z = l[j].direction;
        double x[3], y[3];
        orthonormal_basis(z, x, y);
        double cap = fmin(2.0, l[j].solid_angle / (2 * ENVL_PI)); /* 1 - cos(radius) */
        int32_t np = cap > 0 ? SUN_DISC : 1;
        for (int32_t p = 0; p < np; p++) {
            double ct = 1 - cap * (p + 0.5) / np, st = sqrt(fmax(0.0, 1 - ct * ct));
            double ph = p * ENVL_PI * (3 - sqrt(5.0)), cp = cos(ph) * st, sp = sin(ph) * st;
            double d[3];
            for (int k = 0; k < 3; k++)
                d[k] = cp * x[k] + sp * y[k] + ct * z[k];
            for (int32_t i = 0; i < count; i++) {
                const double *R = dirs + 3 * i;
                double u = R[0] * d[0] + R[1] * d[1] + R[2] * d[2];
                if (u <= 0)
                    continue;
                double f = (roughness > 0 ? ggx_w(u, a2) * inv : u) / np;
                for (int k = 0; k < 3; k++)
                    out[3 * i + k] += f * l[j].rgb[k];
            }
        }
    }
}

/* sp: the map's split (NULL: made here when needed). */
static envl_result specular_level(envl_envmap *m, const resolved *o, double roughness,
                                  int32_t width, const split *sp, float **out, envl_level *st)
{
    double t0 = now();
    *out = NULL;
    if (!(roughness >= 0 && roughness <= 1))
        return envl__fail(ENVL_ERR_ARGUMENT, "prefilter: roughness %g is not in [0, 1]",
                          roughness);
    if (width <= 0)
        width = level_width(o, roughness);
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
        st->seconds = now() - t0;
        return rc;
    }
    split own = {0};
    if (!o->unfiltered && !sp) {
        if ((rc = make_split(m, &own)))
            return rc;
        sp = &own;
    }
    int use_split = !o->unfiltered && sp->sun.n > 0;
    if (!o->unfiltered && !use_split && (rc = envl_envmap_mips(m, NULL))) {
        split_free(&own);
        return rc;
    }
    int32_t nsamp = level_samples(o, width);
    ggx_sample *s = malloc(sizeof(ggx_sample) * (size_t)nsamp);
    float *px = malloc(sizeof(float) * 3 * (size_t)width * h);
    if (!s || !px) {
        free(s);
        free(px);
        split_free(&own);
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
        split_free(&own);
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
        split_free(&own);
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory");
    }
    for (int32_t k = 0, off = 0; k < nlev; k++) {
        if (use_split) {
            lv[k].px = k == 0 ? sp->sun.res : sp->mip + sp->off[k];
            lv[k].w = sp->mw[k];
            lv[k].h = sp->mh[k];
        } else {
            lv[k].px = mip_level(m, k);
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
    image_energy(use_split ? sp->sun.res : m->px, m->width, m->height, ein);
    image_energy(px, width, h, eout);
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
        rc = add_lobes(&sp->sun, m->height, st->alpha, width, h, o->threads, px);
    split_free(&own);
    if (rc) {
        free(px);
        return rc;
    }
    st->samples = nsamp;
    st->filtered = !o->unfiltered;
    st->seconds = now() - t0;
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
    envl_result rc = resolve(options, m, &o);
    if (rc)
        return rc;
    envl_level st;
    rc = specular_level(m, &o, roughness, width, NULL, rgb, &st);
    if (rc == ENVL_OK && stats) {
        st.rgb = *rgb;
        *stats = st;
    }
    return rc;
}

/* ---- the brute-force reference ---- */

typedef struct ref_job {
    const envl_envmap *m;
    double a2;
    const double *dirs;
    double *out;
    int failed;
} ref_job;

static void ref_range(void *ctx, int64_t begin, int64_t end)
{
    ref_job *j = ctx;
    const envl_envmap *m = j->m;
    double *ac = malloc(sizeof(double) * m->width);
    if (!ac) {
        j->failed = 1;
        return;
    }
    for (int64_t i = begin; i < end; i++) {
        const double *R = j->dirs + 3 * i;
        double *o = j->out + 3 * i;
        if (j->a2 == 0) {
            double c, r;
            envl_latlong_pixel(m->width, m->height, R, &c, &r);
            int64_t ci = (int64_t)floor(c + 0.5), ri = (int64_t)floor(r + 0.5);
            ci %= m->width;
            if (ci < 0)
                ci += m->width;
            ri = ri < 0 ? 0 : ri >= m->height ? m->height - 1 : ri;
            for (int k = 0; k < 3; k++)
                o[k] = m->px[3 * (ri * m->width + ci) + k];
            continue;
        }
        for (int32_t c = 0; c < m->width; c++)
            ac[c] = R[0] * m->col_cos[c] + R[1] * m->col_sin[c];
        double s[3] = {0, 0, 0}, ws = 0;
        for (int32_t r = 0; r < m->height; r++) {
            double rc = m->row_cos[r], rz = R[2] * m->row_sin[r];
            double rs[3] = {0, 0, 0}, rw = 0;
            const float *p = m->px + (size_t)r * m->width * 3;
            for (int32_t c = 0; c < m->width; c++) {
                double d = rc * ac[c] + rz; /* R.l */
                if (d <= 0)
                    continue;
                double w = ggx_w(d, j->a2);
                rs[0] += w * p[3 * c], rs[1] += w * p[3 * c + 1], rs[2] += w * p[3 * c + 2];
                rw += w;
            }
            double om = m->row_omega[r];
            for (int k = 0; k < 3; k++)
                s[k] += om * rs[k];
            ws += om * rw;
        }
        for (int k = 0; k < 3; k++)
            o[k] = ws > 0 ? s[k] / ws : 0.0;
    }
    free(ac);
}

envl_result envl_prefilter_reference(const envl_envmap *m, double roughness, int32_t count,
                                     const double *dirs, double *out)
{
    if (!m || count < 0 || (count && (!dirs || !out)) || !(roughness >= 0 && roughness <= 1))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_prefilter_reference: bad arguments");
    double a = roughness * roughness;
    ref_job j = {m, a * a, dirs, out, 0};
    envl__parallel_for(count, m->threads, ref_range, &j);
    return j.failed ? envl__fail(ENVL_ERR_MEMORY, "prefilter reference: out of memory")
                    : ENVL_OK;
}

static double *fibonacci_dirs(void)
{
    double *d = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (d)
        for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
            envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, d + 3 * i);
    return d;
}

/* The error of a lat-long product read bilinearly, plus n_sun sun lights as they add to P(R)
 * at `roughness` (or to E(n) for roughness < 0). */
static envl_result sampled_error(const double *dirs, const double *ref, const float *rgb,
                                 int32_t w, int32_t h, const envl_light *sun, int32_t n_sun,
                                 double roughness, double *error)
{
    double *approx = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!approx)
        return envl__fail(ENVL_ERR_MEMORY, "error measure: out of memory");
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
        envl_latlong_sample(rgb, w, h, dirs + 3 * i, approx + 3 * i);
    sun_lights_add(sun, n_sun, roughness, ENVL_ERROR_NORMALS, dirs, approx);
    *error = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, approx, ref);
    free(approx);
    return ENVL_OK;
}

envl_result envl_glossy_error(const envl_envmap *m, double roughness, const float *rgb,
                              int32_t w, int32_t h, double *error)
{
    if (!m || !rgb || w <= 0 || h <= 0 || !error)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_glossy_error: bad arguments");
    double *dirs = fibonacci_dirs();
    double *ref = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    envl_result rc = !dirs || !ref ? envl__fail(ENVL_ERR_MEMORY, "glossy error: out of memory")
                                   : ENVL_OK;
    if (!rc)
        rc = envl_prefilter_reference(m, roughness, ENVL_ERROR_NORMALS, dirs, ref);
    if (!rc)
        rc = sampled_error(dirs, ref, rgb, w, h, NULL, 0, roughness, error);
    free(dirs);
    free(ref);
    return rc;
}

/* ---- irradiance maps ---- */

static double *latlong_dirs(int32_t w, int32_t h)
{
    double *d = malloc(sizeof(double) * 3 * (size_t)w * h);
    if (d)
        for (int32_t r = 0; r < h; r++)
            for (int32_t c = 0; c < w; c++)
                envl_latlong_direction(w, h, c, r, d + 3 * ((size_t)r * w + c));
    return d;
}

/* Every value of a float product is finite (checked before anything is written). */
static int floats_finite(const float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* `sh` may be given (an SH object of the right order, shared with the diffuse product). */
static envl_result irradiance_map(envl_envmap *m, const resolved *o, const envl_sh *sh,
                                  float **out, envl_irradiance_map *st, int *projected)
{
    double t0 = now();
    int32_t w = o->irr_width, h = w / 2 > 0 ? w / 2 : 1;
    size_t n = (size_t)w * h;
    *out = NULL;
    double *dirs = latlong_dirs(w, h), *e = malloc(sizeof(double) * 3 * n);
    float *px = malloc(sizeof(float) * 3 * n);
    envl_result rc = ENVL_OK;
    envl_sh *own = NULL;
    envl_envmap *small = NULL;
    if (!dirs || !e || !px) {
        rc = envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
        goto done;
    }
    if (o->irr_method == ENVL_IRRADIANCE_SH) {
        if (!sh) {
            /* window auto: the least windowing that keeps the irradiance non-negative */
            envl_sh_options so = {.bands = o->irr_order + 1, .window = ENVL_WINDOW_AUTO};
            if ((rc = envl_sh_compute(m, &so, &own)))
                goto done;
            sh = own;
            *projected = 1;
        }
        rc = envl_sh_eval_irradiance(sh, (int32_t)n, dirs, e);
        /* the auto window keeps it >= 0 at its 4096 test directions; a dip between them
         * (small) becomes 0 */
        for (size_t i = 0; !rc && i < 3 * n; i++)
            e[i] = e[i] < 0 ? 0 : e[i];
    } else if (o->irr_method == ENVL_IRRADIANCE_EXACT || m->width <= RESAMPLED_IRRADIANCE_WIDTH) {
        rc = envl_irradiance_exact(m, (int32_t)n, dirs, e);
    } else {
        /* The clamped cosine is smooth: the map area-averaged to 256 x 128 changes E by about
         * h^2 relative (h = pi / 128: ~6e-4), at a fraction of the cost. */
        float *spx;
        int32_t sw = RESAMPLED_IRRADIANCE_WIDTH, sh_ = sw / 2;
        if ((rc = envl__latlong_resample(m->px, m->width, m->height, sw, sh_, 0.0, &spx)))
            goto done;
        envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = o->threads};
        rc = envl_envmap_from_pixels(spx, sw, sh_, 3, &lo, &small);
        free(spx);
        if (!rc)
            rc = envl_irradiance_exact(small, (int32_t)n, dirs, e);
    }
    if (rc)
        goto done;
    for (size_t i = 0; i < 3 * n; i++) {
        /* stored as float: a map near FLT_MAX has irradiance (pi L) beyond it */
        if (!(fabs(e[i]) <= FLT_MAX)) {
            rc = envl__fail(ENVL_ERR_NONFINITE, "%s: the irradiance map overflows the float "
                            "range (%g; the largest is %g)", m->info.file, e[i], FLT_MAX);
            goto done;
        }
        px[i] = (float)e[i];
    }
    memset(st, 0, sizeof *st);
    st->method = o->irr_method;
    st->width = w;
    st->height = h;
    st->diffuse_error = -1;
    st->seconds = now() - t0;
    *out = px;
    px = NULL;
done:
    free(dirs);
    free(e);
    free(px);
    envl_sh_free(own);
    envl_envmap_free(small);
    return rc;
}

/* ---- requests and products ---- */

struct envl_products {
    envl_products_summary summary;
    resolved opt;
    int32_t n_levels;
    envl_level *levels;
    float **level_px;
    int32_t has_irradiance;
    envl_irradiance_map irr;
    float *irr_px;
    envl_sh *sh;
    envl_lights *lights;
    envl_light *sun;          /* options.sun_lights: the split-off pixels as lights */
    int32_t n_sun;
    float *brdf;
    int32_t brdf_size, brdf_multiscatter, brdf_samples;
    char file[1024];
};

void envl_products_free(envl_products *p)
{
    if (!p)
        return;
    for (int32_t i = 0; i < p->n_levels; i++)
        free(p->level_px[i]);
    free(p->level_px);
    free(p->levels);
    free(p->irr_px);
    envl_sh_free(p->sh);
    envl_lights_free(p->lights);
    free(p->sun);
    free(p->brdf);
    free(p);
}

envl_result envl_compute(envl_envmap *m, const envl_request *q, envl_products **out)
{
    if (!m || !q || !out || q->n_roughness < 0 || (q->n_roughness && !q->roughness))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_compute: bad arguments");
    *out = NULL;
    double t0 = now();
    envl_products *p = calloc(1, sizeof *p);
    if (!p)
        return envl__fail(ENVL_ERR_MEMORY, "envl_compute: out of memory");
    envl_result rc = resolve(&q->prefilter, m, &p->opt);
    if (rc)
        goto fail;
    snprintf(p->file, sizeof p->file, "%s", m->info.file);
    for (int32_t i = 0; i < q->n_roughness; i++)
        if (!(q->roughness[i] >= 0 && q->roughness[i] <= 1)) {
            rc = envl__fail(ENVL_ERR_ARGUMENT, "request: roughness %g is not in [0, 1]",
                            q->roughness[i]);
            goto fail;
        }
    int32_t sh_order = q->sh_order ? q->sh_order : 2;
    if (sh_order < 0 || sh_order > 32) {
        rc = envl__fail(ENVL_ERR_ARGUMENT, "request: SH order %d (0..32)", (int)sh_order);
        goto fail;
    }
    envl_products_summary *s = &p->summary;
    double t;

    /* The list of levels: (roughness, width), without repeats. */
    int32_t cap = 1 + p->opt.levels + q->n_roughness;
    double *want = malloc(sizeof(double) * cap);
    p->levels = calloc((size_t)cap, sizeof(envl_level));
    p->level_px = calloc((size_t)cap, sizeof(float *));
    if (!want || !p->levels || !p->level_px) {
        free(want);
        rc = envl__fail(ENVL_ERR_MEMORY, "envl_compute: out of memory");
        goto fail;
    }
    int32_t nw = 0;
#define WANT(r)                                                                                \
    do {                                                                                       \
        double r_ = (r);                                                                       \
        int dup_ = 0;                                                                          \
        for (int32_t k_ = 0; k_ < nw; k_++)                                                    \
            dup_ |= want[k_] == r_;                                                            \
        if (!dup_)                                                                             \
            want[nw++] = r_;                                                                   \
    } while (0)
    int32_t K = p->opt.levels;
    if (q->mirror && !q->specular_chain)
        WANT(0.0);
    if (q->specular_chain)
        for (int32_t k = 0; k < K; k++)
            WANT(K > 1 ? (double)k / (K - 1) : 0.0);
    for (int32_t i = 0; i < q->n_roughness; i++)
        WANT(q->roughness[i]);
#undef WANT

    /* Diffuse: one SH projection, shared with an SH irradiance map of the same order. */
    int irr_sh = q->irradiance_map && p->opt.irr_method == ENVL_IRRADIANCE_SH;
    if (q->diffuse) {
        t = now();
        envl_sh_options so = {.bands = sh_order + 1, .window = ENVL_WINDOW_AUTO};
        if ((rc = envl_sh_compute(m, &so, &p->sh))) {
            free(want);
            goto fail;
        }
        s->sh_projections++;
        s->seconds_sh += now() - t;
    }
    /* The bright pixels split off once for every filtered level (see make_split), and for
     * the irradiance map when they become lights. */
    int need_mips = 0;
    for (int32_t i = 0; i < nw; i++)
        need_mips |= want[i] > 0 && !p->opt.unfiltered;
    split sp = {0};
    if ((need_mips || (p->opt.sun_lights && q->irradiance_map)) && (rc = make_split(m, &sp))) {
        free(want);
        goto fail;
    }
    if (p->opt.sun_lights && (rc = envl__sun_split_lights(m, &sp.sun, &p->sun, &p->n_sun))) {
        split_free(&sp);
        free(want);
        goto fail;
    }
    if (q->irradiance_map) {
        t = now();
        int projected = 0;
        const envl_sh *shared = p->sh && irr_sh && p->opt.irr_order == sh_order ? p->sh : NULL;
        envl_envmap *residual = NULL;
        if (p->n_sun) { /* the map without what the lights took */
            size_t npx = (size_t)m->width * m->height;
            float *px = malloc(sizeof(float) * 3 * npx);
            if (!px) {
                rc = envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
            } else {
                memcpy(px, m->px, sizeof(float) * 3 * npx);
                for (int32_t i = 0; i < sp.sun.n; i++)
                    if (sp.sun.lobes[i].taken) {
                        const lobe *b = sp.sun.lobes + i;
                        size_t at = 3 * ((size_t)b->r * m->width + b->c);
                        memcpy(px + at, sp.sun.res + at, sizeof(float) * 3);
                    }
                envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = p->opt.threads};
                rc = envl_envmap_from_pixels(px, m->width, m->height, 3, &lo, &residual);
                free(px);
            }
            shared = NULL;
        }
        if (!rc)
            rc = irradiance_map(residual ? residual : m, &p->opt, shared, &p->irr_px, &p->irr,
                                &projected);
        envl_envmap_free(residual);
        if (rc) {
            split_free(&sp);
            free(want);
            goto fail;
        }
        p->irr.rgb = p->irr_px;
        p->has_irradiance = 1;
        s->sh_projections += projected;
        s->irradiance_maps++;
        s->seconds_irradiance += now() - t;
    }
    if (q->shadows) {
        t = now();
        if ((rc = envl_lights_compute(m, &q->lights, &p->lights))) {
            split_free(&sp);
            free(want);
            goto fail;
        }
        s->lights_computed = 1;
        s->seconds_lights += now() - t;
    }
    /* One pyramid for every filtered specular level of non-zero roughness. */
    if (need_mips) {
        t = now();
        int built = m->mip_levels == 0;
        if ((rc = envl_envmap_mips(m, &s->pyramid_levels))) {
            split_free(&sp);
            free(want);
            goto fail;
        }
        s->pyramids_built += built;
        s->seconds_pyramid += now() - t;
    }
    for (int32_t i = 0; i < nw; i++) {
        t = now();
        rc = specular_level(m, &p->opt, want[i], 0, &sp, &p->level_px[i], &p->levels[i]);
        if (!rc && !floats_finite(p->level_px[i], 3 * (size_t)p->levels[i].width *
                                                      p->levels[i].height))
            rc = envl__fail(ENVL_ERR_NONFINITE, "%s: the specular level of roughness %g "
                            "overflows the float range", m->info.file, want[i]);
        if (rc) {
            split_free(&sp);
            free(want);
            goto fail;
        }
        p->levels[i].rgb = p->level_px[i];
        p->n_levels++;
        s->specular_levels++;
        s->seconds_specular += now() - t;
    }
    split_free(&sp);
    free(want);
    if (q->brdf_lut) {
        t = now();
        envl_brdf_options bo = q->brdf;
        if (!bo.threads)
            bo.threads = p->opt.threads;
        if ((rc = envl_brdf_lut(&bo, &p->brdf, &p->brdf_size)))
            goto fail;
        p->brdf_multiscatter = bo.multiscatter != 0;
        p->brdf_samples = bo.samples ? bo.samples : 4096;
        s->brdf_tables = 1;
        s->seconds_brdf += now() - t;
    }
    s->seconds = now() - t0;

    if (q->measure) {
        double *dirs = fibonacci_dirs();
        double *ref = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
        if (!dirs || !ref)
            rc = envl__fail(ENVL_ERR_MEMORY, "error measure: out of memory");
        for (int32_t i = 0; !rc && i < p->n_levels; i++) {
            envl_level *l = &p->levels[i];
            rc = envl_prefilter_reference(m, l->roughness, ENVL_ERROR_NORMALS, dirs, ref);
            if (!rc)
                rc = sampled_error(dirs, ref, l->rgb, l->width, l->height, p->sun,
                                   l->roughness > 0 ? p->n_sun : 0, l->roughness,
                                   &l->glossy_error);
        }
        if (!rc && p->has_irradiance) {
            const double *eref;
            rc = envl_envmap_reference_irradiance(m, &eref);
            if (!rc)
                rc = sampled_error(dirs, eref, p->irr_px, p->irr.width, p->irr.height, p->sun,
                                   p->n_sun, -1, &p->irr.diffuse_error);
        }
        free(dirs);
        free(ref);
        if (rc)
            goto fail;
    }
    *out = p;
    return ENVL_OK;
fail:
    envl_products_free(p);
    return rc;
}

envl_result envl_products_get_summary(const envl_products *p, envl_products_summary *out)
{
    if (!p || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_products_get_summary: NULL argument");
    *out = p->summary;
    return ENVL_OK;
}

int32_t envl_products_level_count(const envl_products *p) { return p ? p->n_levels : 0; }

envl_result envl_products_level(const envl_products *p, int32_t i, envl_level *out)
{
    if (!p || !out || i < 0 || i >= p->n_levels)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_products_level: no level %d", (int)i);
    *out = p->levels[i];
    return ENVL_OK;
}

int32_t envl_products_find_level(const envl_products *p, double roughness)
{
    for (int32_t i = 0; p && i < p->n_levels; i++)
        if (p->levels[i].roughness == roughness)
            return i;
    return -1;
}

envl_result envl_products_irradiance(const envl_products *p, envl_irradiance_map *out)
{
    if (!p || !out || !p->has_irradiance)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_products_irradiance: no irradiance map was "
                          "requested");
    *out = p->irr;
    return ENVL_OK;
}

const envl_sh *envl_products_sh(const envl_products *p) { return p ? p->sh : NULL; }
const envl_lights *envl_products_lights(const envl_products *p) { return p ? p->lights : NULL; }

const envl_light *envl_products_sun_lights(const envl_products *p, int32_t *count)
{
    if (count)
        *count = p ? p->n_sun : 0;
    return p && p->n_sun ? p->sun : NULL;
}

const float *envl_products_brdf(const envl_products *p, int32_t *size, int32_t *multiscatter)
{
    if (size)
        *size = p && p->brdf ? p->brdf_size : 0;
    if (multiscatter)
        *multiscatter = p && p->brdf ? p->brdf_multiscatter : 0;
    return p ? p->brdf : NULL;
}

/* ---- export ----
 * Files in DIR: irradiance.EXT, specular_NN.EXT (NN = index of the level in the products),
 * brdf_lut.EXT (float RG, blue 0; .png: sRGB); layout cube: NAME_px.EXT ... NAME_nz.EXT (faces
 * seen from inside, canonical axes, orientation as layout.c's strips); cross: NAME.EXT as a
 * vertical cross; atlas: specular_atlas.EXT. prefilter.json describes them all. */

typedef struct pending {
    char *tmp, *final;
} pending;

typedef struct exporter {
    const char *dir, *format; /* format: exr hdr pfm png */
    int rgbm;
    pending *files;
    int32_t n, cap;
    FILE *json;               /* the sidecar being written (memory stream) */
    char *json_buf;
    size_t json_size;
} exporter;

static envl_result add_pending(exporter *x, const char *name, char **tmp_out)
{
    if (x->n == x->cap) {
        int32_t cap = x->cap ? 2 * x->cap : 16;
        pending *f = realloc(x->files, sizeof(pending) * cap);
        if (!f)
            return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
        x->files = f, x->cap = cap;
    }
    size_t ln = strlen(x->dir) + strlen(name) + 64;
    char *fin = malloc(ln), *tmp = malloc(ln);
    if (!fin || !tmp) {
        free(fin);
        free(tmp);
        return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    }
    snprintf(fin, ln, "%s/%s", x->dir, name);
    snprintf(tmp, ln, "%s/.envl-%ld-%d-%s", x->dir, (long)getpid(), (int)x->n, name);
    x->files[x->n].tmp = tmp;
    x->files[x->n].final = fin;
    x->n++;
    *tmp_out = tmp;
    return ENVL_OK;
}

/* All temporaries complete: renames each over its target as one step for the folder. Each
 * existing target is first hard-linked to a backup (TMP-old), so that when a rename fails
 * half-way the targets already replaced get their old files back (a target that did not exist
 * is removed again) and the folder is as it was; the backups go on success. On a file system
 * without hard links (EPERM, ENOTSUP) a replaced file cannot be undone and is left new. */
static envl_result put_in_place(exporter *x)
{
    enum { NEW_FILE, KEPT, NOT_KEPT };
    char **old = calloc((size_t)x->n, sizeof *old);
    int *state = calloc((size_t)x->n, sizeof *state);
    envl_result rc = old && state ? ENVL_OK : envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    for (int32_t i = 0; i < x->n && !rc; i++) {
        if (access(x->files[i].final, F_OK) != 0)
            continue; /* NEW_FILE */
        size_t ln = strlen(x->files[i].tmp) + 8;
        if (!(old[i] = malloc(ln))) {
            rc = envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
            break;
        }
        snprintf(old[i], ln, "%s-old", x->files[i].tmp);
        if (!envl__io_fault() && link(x->files[i].final, old[i]) == 0) {
            state[i] = KEPT;
        } else if (errno == EPERM || errno == ENOTSUP || errno == EOPNOTSUPP) {
            state[i] = NOT_KEPT;
        } else {
            rc = envl__fail(ENVL_ERR_IO, "%s: cannot keep the old file while replacing it: %s",
                            x->files[i].final, strerror(errno));
        }
    }
    int32_t done = 0; /* renamed into place */
    while (!rc && done < x->n) {
        if (envl__io_fault() || rename(x->files[done].tmp, x->files[done].final) != 0)
            rc = envl__fail(ENVL_ERR_IO, "%s: cannot rename into place: %s",
                            x->files[done].final, strerror(errno));
        else
            done++;
    }
    for (int32_t i = 0; state && i < x->n; i++) {
        if (rc && i < done && state[i] == KEPT)
            rename(old[i], x->files[i].final); /* undo: the old file back */
        else if (rc && i < done && state[i] == NEW_FILE)
            unlink(x->files[i].final);         /* undo: no file where there was none */
        else if (state[i] == KEPT)
            unlink(old[i]);
        if (old)
            free(old[i]);
    }
    free(old);
    free(state);
    return rc;
}

/* Writes one RGB image under `name` (extension added) into a temporary file. */
static envl_result put_image(exporter *x, const char *stem, const float *rgb, int32_t w,
                             int32_t h)
{
    char name[512], *tmp;
    snprintf(name, sizeof name, "%s.%s", stem, x->format);
    envl_result rc = add_pending(x, name, &tmp);
    if (rc)
        return rc;
    if (x->rgbm)
        rc = envl_png_save_rgbm(tmp, rgb, w, h, ENVL_RGBM_RANGE);
    else
        rc = envl_image_save(tmp, rgb, w, h, &(envl_save_options){.format = x->format});
    if (rc)
        envl__fail_as(rc, x->files[x->n - 1].final, tmp);
    return rc;
}

/* A lat-long map in the export layout (not atlas); lists its files in the JSON. */
static envl_result put_map(exporter *x, int32_t layout, const char *stem, const float *rgb,
                           int32_t w, int32_t h)
{
    char name[512];
    if (layout == ENVL_EXPORT_LATLONG || layout == ENVL_EXPORT_ATLAS) {
        fprintf(x->json, "\"files\": [\"%s.%s\"], \"layout\": \"latlong\"", stem, x->format);
        return put_image(x, stem, rgb, w, h);
    }
    envl_image src = {.width = w, .height = h, .px = (float *)rgb};
    envl_image img = {0};
    int32_t face = w / 4 > 0 ? w / 4 : 1;
    envl_result rc = envl__latlong_to_layout(
        &src, layout == ENVL_EXPORT_CUBE ? ENVL_LAYOUT_STRIP_H : ENVL_LAYOUT_CROSS_V, face, &img);
    if (rc)
        return rc;
    if (layout == ENVL_EXPORT_CROSS) {
        fprintf(x->json, "\"files\": [\"%s.%s\"], \"layout\": \"cross\", \"face_size\": %d", stem,
                x->format, (int)face);
        rc = put_image(x, stem, img.px, img.width, img.height);
        envl__image_free(&img);
        return rc;
    }
    /* Strip order (layout.c): front +X, back -X, left +Y, right -Y, top +Z, bottom -Z. */
    static const char *suffix[6] = {"px", "nx", "py", "ny", "pz", "nz"};
    float *f = malloc(sizeof(float) * 3 * (size_t)face * face);
    if (!f) {
        envl__image_free(&img);
        return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    }
    fprintf(x->json, "\"files\": [");
    for (int k = 0; k < 6 && !rc; k++) {
        for (int32_t r = 0; r < face; r++)
            memcpy(f + 3 * (size_t)r * face, img.px + 3 * ((size_t)r * img.width + k * face),
                   sizeof(float) * 3 * face);
        snprintf(name, sizeof name, "%s_%s", stem, suffix[k]);
        fprintf(x->json, "%s\"%s.%s\"", k ? ", " : "", name, x->format);
        rc = put_image(x, name, f, face, face);
    }
    fprintf(x->json, "], \"layout\": \"cube\", \"face_size\": %d", (int)face);
    free(f);
    envl__image_free(&img);
    return rc;
}

static void json_num(FILE *f, const char *key, double v)
{
    if (isfinite(v))
        fprintf(f, ", \"%s\": %.9g", key, v);
    else
        fprintf(f, ", \"%s\": null", key);
}

static int cmp_level(const void *a, const void *b)
{
    const envl_level *x = *(const envl_level *const *)a, *y = *(const envl_level *const *)b;
    return x->roughness < y->roughness ? -1 : x->roughness > y->roughness;
}

/* The atlas: W = width of the lowest-roughness level; slot k (k-th level by increasing
 * roughness) is (W >> k) x (W >> (k + 1)) at x = 0, rows [W >> (k + 1), W >> k) from the top;
 * the image is W x W, the lowest roughness fills the bottom half; unused pixels are 0. */
static envl_result put_atlas(exporter *x, const envl_products *p)
{
    const envl_level **lv = malloc(sizeof(envl_level *) * (size_t)p->n_levels);
    if (!lv)
        return envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    for (int32_t i = 0; i < p->n_levels; i++)
        lv[i] = &p->levels[i];
    qsort(lv, (size_t)p->n_levels, sizeof *lv, cmp_level);
    int32_t W = lv[0]->width;
    float *atlas = calloc((size_t)W * W * 3, sizeof(float));
    envl_result rc = atlas ? ENVL_OK : envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
    fprintf(x->json, "\"atlas\": {\"file\": \"specular_atlas.%s\", \"width\": %d, \"height\": %d, "
            "\"pixel_layout\": \"slot k (levels by increasing roughness) is a lat-long image of "
            "(W >> k) x (W >> (k+1)) pixels at column 0, rows W >> (k+1) .. (W >> k) - 1 counted "
            "from the top: the lowest roughness fills the bottom half, each next level is half "
            "the size of the previous; unused pixels are 0\", \"slots\": [", x->format, (int)W,
            (int)W);
    int32_t slots = 0;
    for (int32_t k = 0; !rc && k < p->n_levels && (W >> (k + 1)) >= 1; k++) {
        int32_t sw = W >> k, shh = W >> (k + 1);
        float *px;
        rc = envl__latlong_resample(lv[k]->rgb, lv[k]->width, lv[k]->height, sw, shh, 0.0, &px);
        if (rc)
            break;
        for (int32_t r = 0; r < shh; r++)
            memcpy(atlas + 3 * (size_t)(shh + r) * W, px + 3 * (size_t)r * sw,
                   sizeof(float) * 3 * sw);
        free(px);
        fprintf(x->json, "%s{\"roughness\": %.9g, \"x\": 0, \"y\": %d, \"width\": %d, "
                "\"height\": %d}", k ? ", " : "", lv[k]->roughness, (int)shh, (int)sw, (int)shh);
        slots++;
    }
    fprintf(x->json, "]}");
    if (!rc && slots < p->n_levels)
        rc = envl__fail(ENVL_ERR_ARGUMENT, "atlas: %d levels do not fit a %d-pixel atlas",
                        (int)p->n_levels, (int)W);
    if (!rc)
        rc = put_image(x, "specular_atlas", atlas, W, W);
    free(atlas);
    free(lv);
    return rc;
}

envl_result envl_products_export(const envl_products *p, const char *dir,
                                 const envl_export_options *options)
{
    static const envl_export_options defaults;
    const envl_export_options *o = options ? options : &defaults;
    if (!p || !dir || !*dir)
        return envl__fail(ENVL_ERR_ARGUMENT, "export: need products and a directory");
    const char *fmt = o->format ? o->format : "exr";
    int rgbm = !strcmp(fmt, "rgbm-png");
    if (!rgbm && strcmp(fmt, "exr") && strcmp(fmt, "hdr") && strcmp(fmt, "pfm"))
        return envl__fail(ENVL_ERR_ARGUMENT, "export: unknown format '%s' (exr, hdr, pfm, "
                          "rgbm-png)", fmt);
    if (envl__format_built(dir, rgbm ? "png" : fmt)) /* refused before anything is written */
        return ENVL_ERR_UNSUPPORTED;
    if (o->layout < 0 || o->layout >= ENVL_EXPORT_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "export: unknown layout %d", (int)o->layout);
    if (o->layout == ENVL_EXPORT_ATLAS && p->n_levels == 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "export: the atlas needs specular levels");
    exporter x = {.dir = dir, .format = rgbm ? "png" : fmt, .rgbm = rgbm};
    x.json = open_memstream(&x.json_buf, &x.json_size);
    if (!x.json)
        return envl__fail(ENVL_ERR_MEMORY, "export: cannot buffer the sidecar");
    FILE *j = x.json;
    const resolved *r = &p->opt;
    fprintf(j, "{\"source\": ");
    json_write_escaped(j, p->file); /* json.h: valid UTF-8 whatever the bytes */
    fprintf(j, ",\n \"frame\": \"blender-z-up\", \"latlong\": \"column c, row r (0 = top) of W x "
            "H: u = (c+0.5)/W, v = (r+0.5)/H, phi = pi (1 - 2u), theta = pi (0.5 - v), d = (cos "
            "theta cos phi, cos theta sin phi, sin theta)\",\n \"format\": \"%s\", \"layout\": "
            "\"%s\", \"units\": \"radiance as in the source (irradiance map: irradiance)\",\n",
            fmt, envl_export_layout_name(o->layout));
    if (o->layout == ENVL_EXPORT_CUBE || o->layout == ENVL_EXPORT_CROSS)
        fprintf(j, " \"cube_faces\": \"seen from inside; px = +X (front): right -Y, up +Z; nx = "
                "-X: right +Y, up +Z; py = +Y: right +X, up +Z; ny = -Y: right -X, up +Z; pz = +Z:"
                " right -Y, up -X; nz = -Z: right -Y, up +X; the cross: top, left front right, "
                "bottom, back (turned 180 degrees)\",\n");
    if (rgbm)
        fprintf(j, " \"rgbm\": {\"range\": %g, \"decode\": \"rgb = %g * rgbm.rgb * rgbm.a "
                "(bytes / 255, linear)\", \"encode\": \"a = ceil(255 min(max(rgb) / %g, 1)) / "
                "255, rgb8 = round(255 rgb / (%g a)); values above %g clamp\"},\n",
                ENVL_RGBM_RANGE, ENVL_RGBM_RANGE, ENVL_RGBM_RANGE, ENVL_RGBM_RANGE,
                ENVL_RGBM_RANGE);
    fprintf(j, " \"ggx\": {\"alpha\": \"roughness^2\", \"prefiltered_radiance\": \"P(R) = sum "
            "L(l) D(h) max(R.l,0) dw / sum D(h) max(R.l,0) dw, h = normalize(R + l), N = V = R\", "
            "\"roughness_mapping\": \"chain level k of K: roughness = k / (K - 1)\", "
            "\"levels\": %d, \"base_width\": %d, \"min_width\": %d, \"samples\": %d, "
            "\"filtered\": %s},\n", (int)r->levels, (int)r->width, (int)r->min_width,
            (int)r->samples, r->unfiltered ? "false" : "true");
    if (r->sun_lights) {
        fprintf(j, " \"sun_lights\": {\"split\": \"pixels above 50x the mean luminance, one "
                "light per 8-connected group; not in the irradiance map nor in the levels of "
                "roughness > 0 (the roughness-0 level keeps them)\", \"add\": \"irradiance map: "
                "+ rgb max(n.l, 0); level of roughness r: P(R) + rgb w(R.l) / N(alpha), w(u) = u / "
                "q^2, q = ((1 + u) / 2)(alpha^2 - 1) + 1, N(alpha) = (2 pi / B^2)(ln(alpha^2 / A) + "
                "A / alpha^2 - 1), A = (1 + alpha^2) / 2, B = (alpha^2 - 1) / 2 (pi at alpha = 1)\","
                " \"count\": %d, \"lights\": [", (int)p->n_sun);
        for (int32_t i = 0; i < p->n_sun; i++) {
            const envl_light *l = p->sun + i;
            fprintf(j, "%s\n  {\"direction\": [%.9g, %.9g, %.9g], \"rgb\": [%.9g, %.9g, %.9g], "
                    "\"solid_angle\": %.9g, \"angle\": %.9g}", i ? "," : "", l->direction[0],
                    l->direction[1], l->direction[2], l->rgb[0], l->rgb[1], l->rgb[2],
                    l->solid_angle, l->angle);
        }
        fprintf(j, "]},\n");
    }
    envl_result rc = ENVL_OK;
    if (p->has_irradiance) {
        fprintf(j, " \"irradiance\": {\"method\": \"%s\"",
                envl_irradiance_method_name(p->irr.method));
        if (p->irr.method == ENVL_IRRADIANCE_SH)
            fprintf(j, ", \"sh_order\": %d", (int)r->irr_order);
        fprintf(j, ", \"width\": %d, \"height\": %d", (int)p->irr.width, (int)p->irr.height);
        json_num(j, "diffuse_error", p->irr.diffuse_error >= 0 ? p->irr.diffuse_error : NAN);
        json_num(j, "seconds", p->irr.seconds);
        fprintf(j, ", ");
        rc = put_map(&x, o->layout == ENVL_EXPORT_ATLAS ? ENVL_EXPORT_LATLONG : o->layout,
                     "irradiance", p->irr.rgb, p->irr.width, p->irr.height);
        fprintf(j, "},\n");
    }
    if (!rc && p->n_levels) {
        fprintf(j, " \"specular\": [");
        for (int32_t i = 0; !rc && i < p->n_levels; i++) {
            const envl_level *l = &p->levels[i];
            fprintf(j, "%s\n  {\"roughness\": %.9g, \"alpha\": %.9g, \"width\": %d, \"height\": "
                    "%d, \"samples\": %d, \"filtered\": %s", i ? "," : "", l->roughness,
                    l->alpha, (int)l->width, (int)l->height, (int)l->samples,
                    l->filtered ? "true" : "false");
            json_num(j, "energy_scale", l->energy_scale);
            json_num(j, "glossy_error", l->glossy_error >= 0 ? l->glossy_error : NAN);
            json_num(j, "seconds", l->seconds);
            if (o->layout != ENVL_EXPORT_ATLAS) {
                char stem[32];
                snprintf(stem, sizeof stem, "specular_%02d", (int)i);
                fprintf(j, ", ");
                rc = put_map(&x, o->layout, stem, l->rgb, l->width, l->height);
            }
            fprintf(j, "}");
        }
        fprintf(j, "],\n");
        if (!rc && o->layout == ENVL_EXPORT_ATLAS) {
            fprintf(j, " ");
            rc = put_atlas(&x, p);
            fprintf(j, ",\n");
        }
    }
    if (!rc && p->brdf) {
        int32_t s = p->brdf_size;
        float *rgb = malloc(sizeof(float) * 3 * (size_t)s * s);
        if (!rgb) {
            rc = envl__fail(ENVL_ERR_MEMORY, "export: out of memory");
        } else {
            for (size_t i = 0; i < (size_t)s * s; i++)
                rgb[3 * i] = p->brdf[2 * i], rgb[3 * i + 1] = p->brdf[2 * i + 1],
                rgb[3 * i + 2] = 0;
            char name[64], *tmp;
            snprintf(name, sizeof name, "brdf_lut.%s", x.format);
            rc = add_pending(&x, name, &tmp);
            if (!rc &&
                (rc = rgbm ? envl_png_save_srgb(tmp, rgb, s, s)
                           : envl_image_save(tmp, rgb, s, s, &(envl_save_options){.format = fmt})))
                envl__fail_as(rc, x.files[x.n - 1].final, tmp);
            free(rgb);
        }
        fprintf(j, " \"brdf_lut\": {\"file\": \"brdf_lut.%s\", \"size\": %d, \"samples\": %d, "
                "\"multiscatter\": %s, \"encoding\": \"%s\", \"axes\": \"column i: NoV = (i + "
                "0.5) / S; row j from the top: roughness = (j + 0.5) / S\", \"channels\": \"%s\"},\n",
                x.format, (int)s, (int)p->brdf_samples, p->brdf_multiscatter ? "true" : "false",
                rgbm ? "sRGB 8-bit" : "float, blue = 0",
                p->brdf_multiscatter ? "R = B, G = A + B: specular = mix(R, G, F0) * (1 + F0 (1 / "
                                       "G - 1))"
                                     : "R = A (scale), G = B (bias): specular = F0 A + B");
    }
    fprintf(j, " \"seconds\": %.9g}\n", p->summary.seconds);
    fclose(x.json);
    if (!rc) {
        char *tmp;
        rc = add_pending(&x, "prefilter.json", &tmp);
        if (!rc && (rc = envl_file_write_atomic(tmp, x.json_buf, x.json_size)))
            envl__fail_as(rc, x.files[x.n - 1].final, tmp);
    }
    free(x.json_buf);
    rc = rc ? rc : put_in_place(&x);
    for (int32_t i = 0; i < x.n; i++) {
        if (rc)
            unlink(x.files[i].tmp);
        free(x.files[i].tmp);
        free(x.files[i].final);
    }
    free(x.files);
    return rc;
}
