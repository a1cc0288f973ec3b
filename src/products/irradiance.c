/* The exact irradiance integrator (the reference for every approximation) and the error
 * measure of docs/design.md. */
#include "envmap_impl.h"
#include "error_measure.h"
#include "kernel_tree.h"

#include <math.h>
#include <stdlib.h>

/* E(n) = integral of L(d) max(0, n.d) dw with L constant over each pixel (the map as it is).
 *
 * For a pixel wholly on the lit side the integral is exactly L n . D, with D = integral of d dw
 * over the pixel, in closed form for a lat-long cell [phi0, phi1] x [t0, t1] (t = elevation):
 *   D = (I (sin phi1 - sin phi0), I (cos phi0 - cos phi1), (phi1 - phi0)(sin^2 t1 - sin^2 t0)/2)
 *   I = integral cos^2 t dt = ((t1 - t0) + sin t1 cos t1 - sin t0 cos t0) / 2.
 * n . D = I_r (nx Sx_c + ny Sy_c) + nz Z_r: per-column and per-row factors, one multiply-add
 * per pixel.
 *
 * A pixel whose centre is within its angular radius of the horizon of n straddles it. Along
 * one azimuth phi, n.d = A cos t + B sin t (A = nx cos phi + ny sin phi, B = nz) is lit on one
 * side of t* = atan(-A/B), so the integral over t is closed form:
 *   integral (A cos t + B sin t) cos t dt = A (t + sin t cos t)/2 + B sin^2 t / 2
 * over [t0, t1] clipped to the lit side. Only azimuth is sampled: `sub` slices per pixel (at
 * least SUB_MIN, and more for wide pixels so that a slice is at most SUB_DEGREES wide). The
 * plain midpoint sum L dw max(0, n.d_centre) is off by O(h^2); this leaves O((h/sub)^2) on the
 * horizon's pixels only.
 *
 * A pixel wider than it is tall (at its widest latitude: a map narrower than twice its height)
 * is integrated the other way round, so that its cost does not grow with its width (a map one
 * pixel wide took 256 slices of every pixel, for every normal): exact in azimuth, in slices of
 * elevation at most SUB_DEGREES high (at least one). At elevation t, n.d = a cos(phi - phi_n)
 * + b with a = |n_xy| cos t, b = n_z sin t is lit on the arc |phi - phi_n| < acos(-b / a), and
 *   integral of (a cos(phi - phi_n) + b) dphi = a sin(phi - phi_n) + b phi
 * over [phi0, phi1] clipped to that arc; each slice is that at its middle elevation times
 * cos t dt. */
#define SUB_MIN 4
#define SUB_MAX 256
#define SUB_DEGREES 0.25

typedef struct irradiance_tables {
    int32_t w, h, sub;
    double *sx, *sy;        /* per column: sin phi1 - sin phi0, cos phi0 - cos phi1 */
    double *ccos, *csin;    /* per column: cos, sin of the centre phi */
    double *ri, *rz;        /* per row: I, (phi1 - phi0)(sin^2 t1 - sin^2 t0) / 2 */
    double *rho;            /* per row: angular radius of a pixel (+ margin) */
    double *wide;           /* per row: 0, or the elevation slices of a pixel wider than tall
                               (exact in azimuth) */
    double *t0, *t1, *s0, *c0, *s1, *c1; /* per row: edges, their sin and cos */
    double *subc, *subs;    /* per column x sub slices: cos, sin of the slice's centre phi */
} irradiance_tables;

static void free_tables(irradiance_tables *t) { free(t->sx); }

/* Column c's factors of a pixel's D (the top of the file): column c spans u in [c/W, (c+1)/W],
 * phi from p0 = pi (1 - 2 (c + 1) / W) up to p1 = pi (1 - 2 c / W); sx = sin p1 - sin p0,
 * sy = cos p0 - cos p1. */
static void column_factors(int32_t w, int32_t c, double *p0, double *p1, double *sx, double *sy)
{
    *p0 = ENVL_PI * (1.0 - 2.0 * (c + 1.0) / w), *p1 = ENVL_PI * (1.0 - 2.0 * c / w);
    *sx = sin(*p1) - sin(*p0);
    *sy = cos(*p0) - cos(*p1);
}

/* Row r's: its edges t0 < t1 (elevation), I = integral cos^2 t dt, rz = dphi (sin^2 t1 -
 * sin^2 t0) / 2, a pixel's width dw at the row's widest latitude, and rho, the angle from a
 * pixel's centre to its corner (half the diagonal), past which n.d keeps its sign over it. */
static void row_factors(int32_t w, int32_t h, int32_t r, double *t0, double *t1, double *I,
                        double *rz, double *dw, double *rho)
{
    *t1 = ENVL_PI * (0.5 - (double)r / h), *t0 = ENVL_PI * (0.5 - (r + 1.0) / h);
    *I = 0.5 * ((*t1 - *t0) + sin(*t1) * cos(*t1) - sin(*t0) * cos(*t0));
    *rz = 2.0 * ENVL_PI / w * 0.5 * (sin(*t1) * sin(*t1) - sin(*t0) * sin(*t0));
    double widest = fmax(cos(*t0), cos(*t1));
    if (*t0 < 0 && *t1 > 0)
        widest = 1.0;
    double dt = *t1 - *t0;
    *dw = 2.0 * ENVL_PI / w * widest;
    *rho = 0.5 * sqrt(dt * dt + *dw * *dw) * 1.0001 + 1e-12;
}

static envl_result make_tables(const envl_envmap *m, irradiance_tables *t)
{
    int32_t w = m->width, h = m->height;
    int32_t sub = (int32_t)fmin(SUB_MAX, fmax(SUB_MIN, ceil(360.0 / w / SUB_DEGREES)));
    t->sub = sub;
    size_t n = (size_t)4 * w + 10 * (size_t)h + 2 * (size_t)w * sub;
    double *mem = malloc(sizeof(double) * n);
    if (!mem)
        return envl__fail(ENVL_ERR_MEMORY, "irradiance: out of memory");
    t->w = w;
    t->h = h;
    double *q = mem;
    t->sx = q, q += w;
    t->sy = q, q += w;
    t->ccos = q, q += w;
    t->csin = q, q += w;
    t->ri = q, q += h;
    t->rz = q, q += h;
    t->rho = q, q += h;
    t->wide = q, q += h;
    t->t0 = q, q += h;
    t->t1 = q, q += h;
    t->s0 = q, q += h;
    t->c0 = q, q += h;
    t->s1 = q, q += h;
    t->c1 = q, q += h;
    t->subc = q, q += (size_t)w * sub;
    t->subs = q;
    for (int32_t c = 0; c < w; c++) {
        double p0, p1;
        column_factors(w, c, &p0, &p1, &t->sx[c], &t->sy[c]);
        t->ccos[c] = m->col_cos[c];
        t->csin[c] = m->col_sin[c];
        for (int32_t j = 0; j < sub; j++) {
            double phi = p0 + (p1 - p0) * (j + 0.5) / sub;
            t->subc[(size_t)c * sub + j] = cos(phi);
            t->subs[(size_t)c * sub + j] = sin(phi);
        }
    }
    for (int32_t r = 0; r < h; r++) {
        double t0, t1, dw;
        row_factors(w, h, r, &t0, &t1, &t->ri[r], &t->rz[r], &dw, &t->rho[r]);
        t->t0[r] = t0;
        t->t1[r] = t1;
        t->s0[r] = sin(t0);
        t->c0[r] = cos(t0);
        t->s1[r] = sin(t1);
        t->c1[r] = cos(t1);
        double dt = t1 - t0;
        t->wide[r] = dw > dt ? fmin(SUB_MAX, fmax(1, ceil(dt * 180 / ENVL_PI / SUB_DEGREES))) : 0;
    }
    return ENVL_OK;
}

_Thread_local int64_t envl__horizon_slices;

/* Integral of a cos x + b over [x0, x1] clipped to where it is positive, |x0|, |x1| within
 * 3 pi: the lit arcs are |x - 2 pi k| < acos(-b / a) (a > 0), k = -1, 0, 1. */
static double lit_arc_integral(double a, double b, double x0, double x1)
{
    if (!(a > 1e-300))
        return b > 0 ? b * (x1 - x0) : 0.0;
    double k = -b / a;
    if (k >= 1)
        return 0.0;
    double psi = k <= -1 ? ENVL_PI : acos(k), acc = 0;
    for (int j = -1; j <= 1; j++) {
        double lo = fmax(x0, 2 * ENVL_PI * j - psi), hi = fmin(x1, 2 * ENVL_PI * j + psi);
        if (hi > lo)
            acc += a * (sin(hi) - sin(lo)) + b * (hi - lo);
    }
    return acc;
}

/* Integral of max(0, n.d) over pixel (c, r) wider than tall: exact in azimuth, t->wide[r]
 * slices of elevation. */
static double straddling_wide(const irradiance_tables *t, const double n[3], int32_t c,
                              int32_t r)
{
    int32_t slices = (int32_t)t->wide[r];
    double t0 = t->t0[r], dt = (t->t1[r] - t0) / slices;
    double nxy = sqrt(n[0] * n[0] + n[1] * n[1]), phin = atan2(n[1], n[0]);
    /* column c spans phi from pi (1 - 2 (c + 1) / W) to pi (1 - 2 c / W) */
    double p0 = ENVL_PI * (1.0 - 2.0 * (c + 1.0) / t->w) - phin;
    p0 -= 2 * ENVL_PI * floor((p0 + ENVL_PI) / (2 * ENVL_PI)); /* into [-pi, pi) */
    double p1 = p0 + 2.0 * ENVL_PI / t->w;
    double acc = 0.0;
    envl__horizon_slices += slices;
    for (int32_t s = 0; s < slices; s++) {
        double el = t0 + (s + 0.5) * dt, ce = cos(el);
        acc += ce * lit_arc_integral(nxy * ce, n[2] * sin(el), p0, p1);
    }
    return acc * dt;
}

/* Integral over elevations [a, b] (their sin and cos given) of max(0, A cos t + B sin t) cos t:
 * the lit side of t* (A cos t* + B sin t* = 0, t* in [-pi/2, pi/2]) in closed form. */
static double slice_integral(double A, double B, double a, double sa, double ca, double b,
                             double sb, double cb)
{
    if (B == 0.0) {
        if (!(A > 0))
            return 0;
    } else {
        double R = sqrt(A * A + B * B);
        double ss = (B > 0 ? -A : A) / R, cs = fabs(B) / R; /* sin t*, cos t* */
        double ts = atan2(ss, cs);
        if (B > 0) { /* lit above t* */
            if (ts >= b)
                return 0;
            if (ts > a)
                a = ts, sa = ss, ca = cs;
        } else {     /* lit below t* */
            if (ts <= a)
                return 0;
            if (ts < b)
                b = ts, sb = ss, cb = cs;
        }
    }
    return A * 0.5 * ((b - a) + sb * cb - sa * ca) + B * 0.5 * (sb * sb - sa * sa);
}

/* Integral of max(0, n.d) over pixel (c, r): exact in elevation, `sub` slices in azimuth (or,
 * wider than tall, the other way round). */
static double straddling_pixel(const irradiance_tables *t, const double n[3], int32_t c,
                               int32_t r)
{
    if (t->wide[r])
        return straddling_wide(t, n, c, r);
    const int32_t sub = t->sub;
    const double B = n[2], slice = 2.0 * ENVL_PI / t->w / sub;
    double acc = 0.0;
    envl__horizon_slices += sub;
    for (int32_t j = 0; j < sub; j++) {
        size_t k = (size_t)c * sub + j;
        double A = n[0] * t->subc[k] + n[1] * t->subs[k];
        acc += slice_integral(A, B, t->t0[r], t->s0[r], t->c0[r], t->t1[r], t->s1[r], t->c1[r]);
    }
    return acc * slice;
}

double envl__pixel_cosine(int32_t w, int32_t h, int32_t c, int32_t r, const double n[3])
{
    int32_t sub = (int32_t)fmin(SUB_MAX, fmax(SUB_MIN, ceil(360.0 / w / SUB_DEGREES)));
    double p0 = ENVL_PI * (1.0 - 2.0 * (c + 1.0) / w), p1 = ENVL_PI * (1.0 - 2.0 * c / w);
    double t1 = ENVL_PI * (0.5 - (double)r / h), t0 = ENVL_PI * (0.5 - (r + 1.0) / h);
    double s0 = sin(t0), c0 = cos(t0), s1 = sin(t1), c1 = cos(t1), acc = 0;
    for (int32_t j = 0; j < sub; j++) {
        double phi = p0 + (p1 - p0) * (j + 0.5) / sub;
        acc += slice_integral(n[0] * cos(phi) + n[1] * sin(phi), n[2], t0, s0, c0, t1, s1, c1);
    }
    return acc * (p1 - p0) / sub;
}

void envl__pixel_moment(int32_t w, int32_t h, int32_t c, int32_t r, double D[3])
{
    double p0, p1, sx, sy, t0, t1, I, rz, dw, rho;
    column_factors(w, c, &p0, &p1, &sx, &sy);
    row_factors(w, h, r, &t0, &t1, &I, &rz, &dw, &rho);
    D[0] = I * sx, D[1] = I * sy, D[2] = rz;
}

void envl__pixel_cosines(const envl_envmap *m, int32_t c, int32_t r, int32_t count,
                         const double *normals, double *out)
{
    /* the pixel's D and angular radius as make_tables has them, its centre as the map's */
    int32_t w = m->width, h = m->height;
    double p0, p1, sx, sy, t0, t1, I, rz, dw, rho;
    column_factors(w, c, &p0, &p1, &sx, &sy);
    row_factors(w, h, r, &t0, &t1, &I, &rz, &dw, &rho);
    double d[3] = {m->row_cos[r] * m->col_cos[c], m->row_cos[r] * m->col_sin[c], m->row_sin[r]};
    for (int32_t i = 0; i < count; i++) {
        const double *n = normals + 3 * i;
        double centre = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
        out[i] = centre > rho    ? I * (n[0] * sx + n[1] * sy) + n[2] * rz
                 : centre < -rho ? 0.0
                                 : envl__pixel_cosine(w, h, c, r, n);
    }
}

static void irradiance_one(const envl_envmap *m, const irradiance_tables *t, const double n[3],
                           double *colfac, double out[3])
{
    int32_t w = m->width, h = m->height;
    double *cdot = colfac + w; /* n . (centre direction) without the row factor */
    for (int32_t c = 0; c < w; c++) {
        colfac[c] = n[0] * t->sx[c] + n[1] * t->sy[c];
        cdot[c] = n[0] * t->ccos[c] + n[1] * t->csin[c];
    }
    /* n along the pole (a ground's E_up): colfac and cdot are zeros, so a row wholly lit has
     * f = b at every pixel and one wholly unlit none: the same sums, without the tests */
    int pole = n[0] == 0.0 && n[1] == 0.0;
    double acc[3] = {0, 0, 0};
    for (int32_t r = 0; r < h; r++) {
        double I = t->ri[r], b = n[2] * t->rz[r];
        double ct = m->row_cos[r], st = n[2] * m->row_sin[r], rho = t->rho[r];
        double row[3] = {0, 0, 0};
        const float *p = m->px + (size_t)r * w * 3;
        if (pole && (st > rho || st < -rho)) {
            for (int32_t c = 0; st > rho && c < w; c++) {
                row[0] += b * p[3 * c];
                row[1] += b * p[3 * c + 1];
                row[2] += b * p[3 * c + 2];
            }
            for (int k = 0; k < 3; k++)
                acc[k] += row[k];
            continue;
        }
        for (int32_t c = 0; c < w; c++) {
            double centre = ct * cdot[c] + st;
            double f;
            if (centre > rho)
                f = I * colfac[c] + b;
            else if (centre < -rho)
                continue;
            else
                f = straddling_pixel(t, n, c, r);
            row[0] += f * p[3 * c];
            row[1] += f * p[3 * c + 1];
            row[2] += f * p[3 * c + 2];
        }
        for (int k = 0; k < 3; k++)
            acc[k] += row[k];
    }
    for (int k = 0; k < 3; k++)
        out[k] = acc[k];
}

typedef struct irradiance_job {
    const envl_envmap *map;
    const irradiance_tables *tables;
    const double *normals;
    double *out;
    int failed;
    envl_cancel cancel;       /* a cancel seen between normals */
} irradiance_job;

static void irradiance_range(void *arg, int64_t begin, int64_t end)
{
    irradiance_job *job = arg;
    double *colfac = malloc(sizeof(double) * 2 * job->map->width);
    if (!colfac) {
        job->failed = 1; /* benign race: every writer stores 1 */
        return;
    }
    for (int64_t i = begin; i < end && !envl__cancel_check(&job->cancel); i++)
        irradiance_one(job->map, job->tables, job->normals + 3 * i, colfac, job->out + 3 * i);
    free(colfac);
}

envl_result envl_irradiance_exact(const envl_envmap *m, int32_t count, const double *normals,
                                  double *rgb_out)
{
    if (!m || count < 0 || (count && (!normals || !rgb_out)))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_irradiance_exact: bad arguments");
    irradiance_tables tables;
    envl_result rc = make_tables(m, &tables);
    if (rc)
        return rc;
    /* Each normal is computed by one thread from start to end: the result does not depend on
     * the thread count. */
    irradiance_job job = {m, &tables, normals, rgb_out, 0, {0}};
    envl__parallel_for(count, m->threads, irradiance_range, &job);
    free_tables(&tables);
    if (atomic_load(&job.cancel.stop))
        return ENVL_ERR_CANCELLED; /* the message: envl__progress_poll's */
    return job.failed ? envl__fail(ENVL_ERR_MEMORY, "envl_irradiance_exact: out of memory")
                      : ENVL_OK;
}

/* ---- the same sum through the kernel tree (kernel_tree.h) ----
 *
 * For a block of the tree, with S = sum of L dw and M = sum of L D (D the exact integral of d
 * over each pixel) and n.d within [lo, hi] over it:
 *   lo > 0 (lit throughout): its irradiance is n.M exactly; hi <= 0 (unlit): 0;
 *   straddling the horizon: max(0, t) = (t + |t|) / 2 gives (n.M + integral of L |t|) / 2,
 *     and integral L |t| lies in [S |t0|, S U] (Jensen; U = max(-lo, hi), t0 = n.M / S):
 *     its middle is taken and the bound is S (U - |t0|) / 4.
 * A straddling block is accepted when that bound is within tol rho / pi (tol: the allowance of
 * one normal, per channel): the blocks along the horizon, about 2 rho of its 2 pi each, then
 * add up to about tol. Every other block opens, down to the pixels, which are summed exactly
 * as envl_irradiance_exact sums them. */
typedef struct irradiance_kernel {
    const envl_envmap *m;
    const irradiance_tables *t;
    const ktree *tree;
    double tol[3];
} irradiance_kernel;

/* The mean of |t| over a distribution on [-a, b] (a, b > 0) with mean t0 lies between |t0|
 * (Jensen) and (2ab + t0 (b - a)) / (a + b) (all of it at -a and b): *mid is the middle of
 * that range, *half its half-width. */
static void abs_mean_range(double t0, double a, double b, double *mid, double *half)
{
    t0 = t0 < -a ? -a : t0 > b ? b : t0;
    double lo = fabs(t0), hi = (2 * a * b + t0 * (b - a)) / (a + b);
    hi = hi > lo ? hi : lo;
    *mid = 0.5 * (lo + hi);
    *half = 0.5 * (hi - lo);
}

static int irradiance_block(const void *ctx, const double n[3], const double *s,
                            int32_t channels, double lo, double hi, double omega, double rho,
                            double *est, double *bound)
{
    (void)channels, (void)omega;
    const irradiance_kernel *k = ctx;
    const double *M = s + 3;
    if (hi <= 0)
        return 1;
    if (lo > 0) {
        for (int c = 0; c < 3; c++)
            est[c] += n[0] * M[3 * c] + n[1] * M[3 * c + 1] + n[2] * M[3 * c + 2];
        return 1;
    }
    double e[3], b[3];
    for (int c = 0; c < 3; c++) {
        double nm = n[0] * M[3 * c] + n[1] * M[3 * c + 1] + n[2] * M[3 * c + 2];
        double t0 = s[c] > 0 ? nm / s[c] : 0, mid, half;
        abs_mean_range(t0, -lo, hi, &mid, &half);
        e[c] = 0.5 * (nm + s[c] * mid);
        b[c] = 0.5 * s[c] * half;
        if (b[c] > k->tol[c] * rho / ENVL_PI)
            return 0;
    }
    for (int c = 0; c < 3; c++)
        est[c] += e[c], bound[c] += b[c];
    return 1;
}

/* A straddling pixel as a straddling block (its n.d within centre +- rho; M = L D): the middle
 * estimate when its bound is within the allowance, for every channel. f: per unit radiance,
 * the pixel's L being one constant (the estimate's t0 = n.D / dw is the same for all channels). */
static int straddling_estimate(const irradiance_kernel *k, const double n[3], int32_t c,
                               int32_t r, double *f, double *bound)
{
    const irradiance_tables *t = k->t;
    const float *p = k->m->px + 3 * ((size_t)r * k->m->width + c);
    double om = k->m->row_omega[r], rho = t->rho[r];
    double nd = t->ri[r] * (n[0] * t->sx[c] + n[1] * t->sy[c]) + n[2] * t->rz[r];
    double lo, hi, mid, half;
    envl__ktree_pixel_range(k->tree, n, c, r, &lo, &hi);
    if (hi <= 0 || lo >= 0) /* wholly on one side: the closed form (0 or n.D) */
        mid = fabs(nd) / om, half = 0;
    else
        abs_mean_range(nd / om, -lo, hi, &mid, &half);
    double b = 0.5 * om * half;
    for (int ch = 0; ch < 3; ch++)
        if (b * p[ch] > k->tol[ch] * rho / ENVL_PI)
            return 0;
    *f = 0.5 * (nd + om * mid);
    *bound = b;
    return 1;
}

static void irradiance_pixels(const void *ctx, const double n[3], int32_t c0, int32_t c1,
                              int32_t r0, int32_t r1, double *est, double *bound)
{
    const irradiance_kernel *k = ctx;
    const envl_envmap *m = k->m;
    const irradiance_tables *t = k->t;
    for (int32_t r = r0; r < r1; r++) {
        double I = t->ri[r], b = n[2] * t->rz[r];
        double ct = m->row_cos[r], st = n[2] * m->row_sin[r], rho = t->rho[r];
        const float *p = m->px + (size_t)r * m->width * 3;
        for (int32_t c = c0; c < c1; c++) {
            double centre = ct * (n[0] * t->ccos[c] + n[1] * t->csin[c]) + st;
            double f, fb = 0;
            if (centre > rho)
                f = I * (n[0] * t->sx[c] + n[1] * t->sy[c]) + b;
            else if (centre < -rho)
                continue;
            else if (!straddling_estimate(k, n, c, r, &f, &fb))
                f = straddling_pixel(t, n, c, r);
            for (int ch = 0; ch < 3; ch++)
                bound[ch] += fb * p[3 * c + ch];
            est[0] += f * p[3 * c], est[1] += f * p[3 * c + 1], est[2] += f * p[3 * c + 2];
        }
    }
}

typedef struct fast_job {
    const ktree *tree;
    irradiance_kernel kernel;  /* its tol: the allowance of the first try */
    double limit[3];           /* the promised bound: tolerance x the mean of E */
    double relative;           /* > 0: the promise is relative x max(base + E, limit) instead */
    const double *base;        /* relative: per normal, what the caller adds to E (or NULL) */
    const double *normals;
    double *out, *bound;
    envl_cancel cancel;       /* a cancel seen between normals */
} fast_job;

/* Each normal is summed with the allowance tol, and again with half of it while its bound
 * exceeds the promise (twice tol: the blocks along a horizon hold about 2 rho of it each, but
 * clipped ones count more). Tiny allowances open every straddling block: it ends. */
static void fast_range(void *arg, int64_t begin, int64_t end)
{
    fast_job *j = arg;
    for (int64_t i = begin; i < end && !envl__cancel_check(&j->cancel); i++) {
        irradiance_kernel k = j->kernel;
        ktree_kernel kn = {irradiance_block, irradiance_pixels, &k};
        double e[KTREE_MAX_CHANNELS], b[KTREE_MAX_CHANNELS], lim[3];
        for (int tries = 0;; tries++) {
            envl__ktree_sum(j->tree, &kn, j->normals + 3 * i, e, b);
            for (int c = 0; c < 3; c++)
                lim[c] = j->relative > 0
                             ? j->relative * fmax((j->base ? j->base[3 * i + c] : 0) + e[c],
                                                  j->limit[c])
                             : j->limit[c];
            if ((b[0] <= lim[0] && b[1] <= lim[1] && b[2] <= lim[2]) || tries == 60)
                break;
            /* halved, and at once down to half the promise the estimate now gives (relative:
             * a dark normal needs a far smaller allowance than the mean's) */
            for (int c = 0; c < 3; c++)
                k.tol[c] = fmin(0.5 * k.tol[c], 0.5 * lim[c]);
        }
        for (int c = 0; c < 3; c++) {
            j->out[3 * i + c] = e[c];
            if (j->bound)
                j->bound[3 * i + c] = b[c];
        }
    }
}

/* The tree's sums at `count` normals: within `tolerance` x the mean of E, or (relative > 0)
 * within relative x max(base + E, floor) per normal and channel. */
static envl_result fast_sums(const envl_envmap *m, int32_t count, const double *normals,
                             double tolerance, double relative, const double floor[3],
                             const double *base, double *rgb_out, double *bound_out)
{
    irradiance_tables tables;
    envl_result rc = make_tables(m, &tables);
    if (rc)
        return rc;
    /* pixel (c, r): weight dw, moment D = (I_r sx_c, I_r sy_c, rz_r) */
    ktree *tree = NULL;
    ktree_moments mo = {m->row_omega, tables.ri, tables.rz, tables.sx, tables.sy, 0};
    rc = envl__ktree_build(m->px, m->width, m->height, &mo, m->threads, &tree);
    if (!rc) {
        double total[KTREE_MAX_CHANNELS];
        envl__ktree_total(tree, total);
        fast_job j = {tree, {m, &tables, tree, {0}}, {0}, relative, base, normals, rgb_out,
                      bound_out, {0}};
        /* the mean of E(n) over the sphere is S / 4 (the mean of max(0, n.d) is 1/4) */
        for (int c = 0; c < 3; c++) {
            j.limit[c] = relative > 0 ? floor[c] : tolerance * total[c] / 4;
            /* relative: the first try's allowance as if E were the mean (halved on) */
            j.kernel.tol[c] = 0.5 * (relative > 0 ? relative * fmax(total[c] / 4, floor[c])
                                                  : j.limit[c]);
        }
        envl__parallel_for(count, m->threads, fast_range, &j);
        if (atomic_load(&j.cancel.stop))
            rc = ENVL_ERR_CANCELLED; /* the message: envl__progress_poll's */
    }
    envl__ktree_free(tree);
    free_tables(&tables);
    return rc;
}

envl_result envl__irradiance_fast(const envl_envmap *m, int32_t count, const double *normals,
                                  double tolerance, double *rgb_out, double *bound_out)
{
    return fast_sums(m, count, normals, tolerance, 0, NULL, NULL, rgb_out, bound_out);
}

envl_result envl__irradiance_relative(const envl_envmap *m, int32_t count, const double *normals,
                                      double relative, const double floor[3], const double *base,
                                      double *rgb_out)
{
    return fast_sums(m, count, normals, 0, relative, floor, base, rgb_out, NULL);
}

/* Fibonacci sphere: z_i = 1 - (2i + 1)/n, phi_i = 2 pi i / golden ratio. */
void envl_fibonacci_direction(int32_t i, int32_t n, double d[3])
{
    if (n < 1 || i < 0 || i >= n) { /* no such point (n = 0 divided by zero) */
        d[0] = d[1] = d[2] = 0.0;
        return;
    }
    const double golden = (1.0 + sqrt(5.0)) / 2.0;
    double z = 1.0 - (2.0 * i + 1.0) / n;
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    double phi = 2.0 * ENVL_PI * fmod(i / golden, 1.0);
    d[0] = r * cos(phi);
    d[1] = r * sin(phi);
    d[2] = z;
}

double *envl__fibonacci_dirs(void)
{
    double *d = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (d)
        for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
            envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, d + 3 * i);
    return d;
}

double envl_relative_rms_luminance(int32_t count, const double *approx, const double *exact)
{
    if (count <= 0)
        return 0.0;
    double se = 0.0, sa = 0.0;
    for (int32_t i = 0; i < count; i++) {
        double ya = envl__lum(approx[3 * i], approx[3 * i + 1], approx[3 * i + 2]);
        double ye = envl__lum(exact[3 * i], exact[3 * i + 1], exact[3 * i + 2]);
        se += (ya - ye) * (ya - ye);
        sa += fabs(ye);
    }
    double rms = sqrt(se / count), mean = sa / count;
    /* No light at all: the error is 0 when the approximation is also dark, else infinite. */
    if (mean == 0.0)
        return rms == 0.0 ? 0.0 : INFINITY;
    return rms / mean;
}

/* Maps wider than ENVL_REFERENCE_WIDTH are resampled (exactly, by area) to that width: the
 * clamped cosine is smooth, so this changes E by at most ~4 pi h^2 relative (h = pi / 512:
 * 1.5e-4), and keeps the reference fast for huge maps. A map whose pixels are far from square
 * (envl__points_map: one pixel wide, say) is split into near-square pixels first, the same
 * function (beyond 1024 x 512, area-resampled to it), so that its cost follows its pixels and
 * the tree serves it. The copy is cached in the map (the fit's target sums over it too). */
envl_result envl__reference_copy(envl_envmap *m, const envl_envmap **out)
{
    if (m->window) {
        /* a window of the map's rows (the others black): a map of its own of them, at most
         * ENVL_REFERENCE_WIDTH wide, the same pixels as the copy with those rows black would
         * give. Only of a map whose pixels need no points copy (pov_include.c makes no other) */
        *out = NULL;
        if (!envl__points_fine(m))
            return envl__fail(ENVL_ERR_ARGUMENT, "reference: a window of a %d x %d map, too "
                              "coarse for its reference", (int)m->width, (int)m->height);
        if (!m->reference_copy) {
            envl_result rc = envl__envmap_window_copy(
                m, m->width < ENVL_REFERENCE_WIDTH ? m->width : ENVL_REFERENCE_WIDTH,
                &m->reference_copy);
            if (rc)
                return rc;
        }
        *out = m->reference_copy;
        return ENVL_OK;
    }
    envl_envmap *src;
    envl_result rc = envl__points_map(m, &src);
    *out = src;
    if (rc || src->width <= ENVL_REFERENCE_WIDTH)
        return rc;
    if (!m->reference_copy) {
        rc = envl__envmap_resampled(src->px, src->width, src->height, ENVL_REFERENCE_WIDTH,
                                    m->threads, &m->reference_copy);
        if (rc)
            return rc;
    }
    *out = m->reference_copy;
    return ENVL_OK;
}

/* Up to 256 x 128 the reference is the brute force itself (exact to rounding; a few
 * hundredths of a second at most). */
#define REFERENCE_EXACT_PIXELS (256 * 128)

envl_result envl__irradiance_reference(const envl_envmap *m, int32_t count,
                                       const double *normals, double *rgb_out)
{
    if ((int64_t)m->width * m->height <= REFERENCE_EXACT_PIXELS)
        return envl_irradiance_exact(m, count, normals, rgb_out);
    return envl__irradiance_fast(m, count, normals, ENVL_REFERENCE_TOLERANCE, rgb_out, NULL);
}

envl_result envl_envmap_reference_irradiance(envl_envmap *m, const double **rgb_out)
{
    if (!m || !rgb_out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_reference_irradiance: NULL argument");
    if (!m->reference) {
        double *normals = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
        double *ref = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
        if (!normals || !ref) {
            free(normals);
            free(ref);
            return envl__fail(ENVL_ERR_MEMORY, "reference irradiance: out of memory");
        }
        for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
            envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, normals + 3 * i);
        const envl_envmap *r;
        envl_result rc = envl__reference_copy(m, &r);
        if (rc == ENVL_OK)
            rc = envl__irradiance_reference(r, ENVL_ERROR_NORMALS, normals, ref);
        free(normals);
        if (rc) {
            free(ref);
            return rc;
        }
        m->reference = ref;
    }
    *rgb_out = m->reference;
    return ENVL_OK;
}
