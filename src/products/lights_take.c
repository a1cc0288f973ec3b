/* The fit's residual map: what the fitted lights take from the map (docs/methods.md, "The
 * fit's take").
 *
 * Light i takes, from what the lights before it left (brightest first), the light above a
 * smooth level around its aim l (the fit's direction): at a pixel of luminance Y and direction
 * d the level is
 *
 *     lambda(d) = exp(lb + kappa (1 - d.l) - e1 (d.t1) - e2 (d.t2) + h(d))
 *
 * (t1, t2 a tangent frame of l; envl__aim_shape), and the pixel keeps min(Y, lambda) / Y of each
 * channel: the same fraction of R, G and B (its hue is kept), continuous in d (the residual's
 * log luminance is the least of the map's and the levels': no edge), never below the level (no
 * hole darker than it). kappa = 1 / (1 - cos TAKE_SPREAD_DEGREES): the level rises e-fold that
 * far from l. h is the horizon: 0 on l's side of it, depth / sin(TAKE_HORIZON_DEGREES) on the
 * other (depth = |d_z|): a light above the horizon takes from below it only a source crossing
 * it, whose light a ground plane's normal +Z nearly sees whole.
 *
 * lb solves for the luminance taken, sum (Y - lambda)+ dw = t, the light's target (its fitted
 * luminance), by safeguarded Newton; the tilt (e1, e2) by Newton on the first moment of what
 * it takes, V = sum (Y - lambda)+ d dw, having no component along t1 or t2, with lb solved at
 * every step and |e| at most kappa tan(TAKE_SHIFT_DEGREES) (the level's lowest point stays
 * within that of l): V lies along l (a disc light of irradiance V . l along l, a Blender sun,
 * then gives a surface that sees all of it exactly what was taken). Where no such level can
 * (the light nearby lies on one side of l) the best point is kept; lights_fit.c then points
 * the light along V where the fit allows it. The rgb of a light is what it took, per channel:
 * the map's power is kept exactly (lights + residual), and the fit's remainder is solved for
 * these lights (lights_fit.c).
 *
 * The solve starts on the fit's coarse copy (256 wide), goes on on a 512-wide one and the
 * reference copy (at most 1024 wide), each from the coarser one's solution, and on the map
 * itself solves lb alone (finish_lb: one pass, then within TAKE_WINDOW of the reference copy's
 * level without another); each level keeps its own residual. A pass visits only the pixels
 * where the level can fall below the luminance: the level's log is lb + kappa - R (d.m) + h, a
 * cone about m (level_cone), narrowed row by row to the row's brightest pixel and its horizon
 * term. Sums are per fixed chunk of rows, combined in chunk order: the same result at any
 * thread count. With no residual kept, each pixel's residual is replayed through the lights
 * before (each only within its own cone), with the same float roundings as the kept one. */
#include "lights_impl.h"
#include "error_measure.h"
#include "nnls.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TAKE_SPREAD_DEGREES 15.0
#define TAKE_HORIZON_DEGREES 2.0
#define TAKE_SHIFT_DEGREES 60.0
#define TAKE_MID_WIDTH 512
#define TAKE_CHUNKS 64
#define TAKE_THREAD_PIXELS (1 << 17) /* passes over fewer pixels run on one thread */
#define TAKE_STEPS_FIRST 12          /* tilt steps on the coarsest level, then on each finer */
#define TAKE_STEPS_NEXT 1
#define TAKE_HALVINGS 4
#define TAKE_TOLERANCE 1e-8          /* the luminance taken, relative to the target */
#define TAKE_WINDOW 5e-2             /* finish_lb: the level may move by this (relative) */
#define TAKE_TILT_TOLERANCE 1e-6     /* the moment's angle from the aim, radians */

/* One light's level: its aim and unknowns. */
typedef struct take_level {
    envl__aim a;
    double lb, e1, e2;
} take_level;

/* A map the take works on: its residual (NULL: the map's pixels, replayed through the lights
 * before), the log of each row's largest luminance in its pixels (an upper bound of the
 * residual's) and of the largest. */
typedef struct take_map {
    const envl_envmap *m;
    float *res;
    double *log_row_max;
    double log_max;
} take_map;

/* Partial sums of a chunk of rows. */
typedef struct take_sums {
    double s0, s1, s2;                  /* sum e dw, e (d.t1) dw, e (d.t2) dw; e = Y - lambda */
    double w, w1, w2, w11, w12, w22;    /* sum lambda dw, ... lambda u_a u_b dw */
    double rgb[3], moment[3], own;      /* the take: what it took, sum e d dw, own extent */
    double far_y, far_w;                /* sum Y dw, lambda dw where Y > (1 + window) lambda */
    int32_t x0, x1, y0, y1;
} take_sums;

/* A pixel near the level: Y / lambda and lambda dw (finish_lb). */
typedef struct take_near {
    double rho, wl;
} take_near;

/* A chunk's pixels near the level: a growing list (n = -1: out of memory). */
typedef struct take_near_list {
    take_near *p;
    int64_t n, cap;
} take_near_list;

typedef struct take_job {
    const take_map *tm;
    const take_level *levels; /* the lights taken before (take order), then this one */
    int32_t light;            /* this light's index in levels */
    int32_t rows;             /* rows per chunk */
    int apply;                /* 0: the solve's sums; 1: take */
    double kappa, sin_h;
    envl__cone_geom g;        /* the pixels the pass visits */
    take_sums *chunks;
    take_near_list *near;     /* a solve pass: each chunk's pixels near the level, or NULL */
} take_job;

/* The level's rise kappa and the sine of its horizon angle. */
static double take_kappa(void) { return 1.0 / (1.0 - cos(TAKE_SPREAD_DEGREES * ENVL_PI / 180.0)); }
static double take_sin_h(void) { return sin(TAKE_HORIZON_DEGREES * ENVL_PI / 180.0); }

/* Light q's log level at direction (x, y, z), and d.t1, d.t2. */
static inline double log_level(const take_level *q, double kappa, double sin_h, double x,
                               double y, double z, double *u1, double *u2)
{
    return q->lb + envl__aim_shape(&q->a, kappa, sin_h, x, y, z, u1, u2) - q->e1 * *u1 -
           q->e2 * *u2;
}

/* Light q's take at one pixel: v (float, in place) keeps min(Y, lambda) / Y; returns lambda
 * when it took (Y > lambda), else -1. log_max: the row's bound of log Y. */
static inline double take_step(const take_level *q, const take_job *j, double x, double y,
                               double z, double log_max, float v[3], double *u1, double *u2)
{
    double a = log_level(q, j->kappa, j->sin_h, x, y, z, u1, u2);
    if (!(a < log_max))
        return -1.0;
    double lam = exp(a), Y = envl__lum(v[0], v[1], v[2]);
    if (!(Y > lam))
        return -1.0;
    double keep = lam / Y;
    for (int k = 0; k < 3; k++)
        v[k] = (float)(v[k] * keep);
    return lam;
}

/* The pixels where light q's log level can fall under log_bound, h its horizon term there (the
 * least over the pixels: it depends on d_z alone). With m = (kappa l + e1 t1 + e2 t2) / R,
 * R = sqrt(kappa^2 + e1^2 + e2^2) (l, t1, t2 orthonormal), the level's log is exactly
 * lb + kappa - R (d.m) + h: a cone about m, d.m > (lb + kappa + h - log_bound) / R. */
static envl__cone_geom level_cone(const take_level *q, double kappa, const envl_envmap *m,
                                  double log_bound, double h)
{
    double R = sqrt(kappa * kappa + q->e1 * q->e1 + q->e2 * q->e2), dir[3];
    for (int k = 0; k < 3; k++)
        dir[k] = (kappa * q->a.l[k] + q->e1 * q->a.t1[k] + q->e2 * q->a.t2[k]) / R;
    double c = (q->lb + kappa + h - log_bound) / R;
    envl__cone_geom g = envl__cone_geometry(m, dir, acos(fmax(-1.0, fmin(1.0, c))));
    if (!(c < 1.0))
        g.r0 = m->height, g.r1 = -1; /* none */
    return g;
}

/* The horizon term of a light's level on row r: depth / sin_h on the far side from l. */
static double row_horizon(const take_level *q, double sin_h, const envl_envmap *m, int32_t r)
{
    double zs = m->row_sin[r] * q->a.side;
    return zs < 0.0 ? -zs / sin_h : 0.0;
}

/* Columns lo..hi of row r (as envl__cone_span) where light q's level can fall under
 * log_bound; 0 if none. */
static int row_span(const take_job *j, const take_level *q, int32_t r, double log_bound,
                    int32_t *lo, int32_t *hi)
{
    const envl_envmap *m = j->tm->m;
    envl__cone_geom g = level_cone(q, j->kappa, m, log_bound, row_horizon(q, j->sin_h, m, r));
    return r >= g.r0 && r <= g.r1 && envl__cone_span(m, &g, r, lo, hi);
}

/* Whether column c (0..W-1) lies in the wrapping run lo..hi. */
static inline int in_span(int32_t c, int32_t lo, int32_t hi, int32_t W)
{
    int32_t d = c - lo;
    d += d < 0 ? W : d >= W ? -W : 0;
    return d <= hi - lo;
}

static void sums_clear(take_sums *s, int32_t W, int32_t H)
{
    memset(s, 0, sizeof *s);
    s->x0 = W;
    s->y0 = H;
    s->x1 = s->y1 = -1;
}

/* Adds a pixel near the level to list l; on failure to grow, marks it (n = -1). */
static void near_add(take_near_list *l, double rho, double wl)
{
    if (l->n < 0)
        return;
    if (l->n == l->cap) {
        int64_t cap = l->cap ? 2 * l->cap : 1024;
        take_near *p = realloc(l->p, sizeof *p * (size_t)cap);
        if (!p) {
            l->n = -1;
            return;
        }
        l->p = p, l->cap = cap;
    }
    l->p[l->n++] = (take_near){rho, wl};
}

/* How far above the level's log a solve pass for finish_lb looks: down to pixels of
 * (1 - window) lambda, which a level lowered by the window takes. */
static double near_log(const take_job *j)
{
    return j->near && !j->apply ? -log1p(-TAKE_WINDOW) : 0.0;
}

static void take_range(void *ctx, int64_t begin, int64_t end)
{
    const take_job *j = ctx;
    const take_map *tm = j->tm;
    const envl_envmap *m = tm->m;
    const take_level *q = j->levels + j->light;
    int32_t W = m->width;
    double reach_log = near_log(j);
    for (int64_t ch = begin; ch < end; ch++) {
        take_sums *s = j->chunks + ch;
        sums_clear(s, W, m->height);
        take_near_list *near = j->near && !j->apply ? j->near + ch : NULL;
        if (near)
            near->n = 0; /* a new pass, a new list */
        int32_t r0 = (int32_t)ch * j->rows, r1 = r0 + j->rows - 1;
        r0 = r0 > j->g.r0 ? r0 : j->g.r0;
        r1 = r1 < j->g.r1 ? r1 : j->g.r1;
        for (int32_t r = r0; r <= r1; r++) {
            double lm = tm->log_row_max[r];
            /* the row's own cone (its largest luminance and its horizon term): the columns
             * where the level can fall below the row's pixels; the same for the lights
             * before, replayed (a pixel outside theirs keeps its value) */
            int32_t lo, hi, plo[ENVL_NNLS_MAX], phi[ENVL_NNLS_MAX], pin[ENVL_NNLS_MAX];
            if (!row_span(j, q, r, lm + reach_log, &lo, &hi))
                continue;
            for (int32_t i = 0; !tm->res && i < j->light; i++)
                pin[i] = row_span(j, j->levels + i, r, lm, &plo[i], &phi[i]);
            double om = m->row_omega[r], rc = m->row_cos[r], z = m->row_sin[r];
            for (int32_t cw = lo; cw <= hi; cw++) {
                int32_t c = cw < 0 ? cw + W : cw >= W ? cw - W : cw;
                double x = rc * m->col_cos[c], y = rc * m->col_sin[c], u1, u2;
                float v[3];
                size_t at = 3 * ((size_t)r * W + c);
                memcpy(v, (tm->res ? tm->res : m->px) + at, sizeof v);
                if (!tm->res) /* replay the lights before */
                    for (int32_t i = 0; i < j->light; i++)
                        if (pin[i] && in_span(c, plo[i], phi[i], W))
                            take_step(j->levels + i, j, x, y, z, lm, v, &u1, &u2);
                float before[3] = {v[0], v[1], v[2]};
                double Y = envl__lum(v[0], v[1], v[2]);
                if (!j->apply) { /* the solve's sums (and the pixels near the level) */
                    double a = log_level(q, j->kappa, j->sin_h, x, y, z, &u1, &u2);
                    if (!(a < lm + reach_log))
                        continue;
                    double lam = exp(a);
                    if (near && Y > (1.0 - TAKE_WINDOW) * lam) {
                        if (Y > (1.0 + TAKE_WINDOW) * lam)
                            s->far_y += Y * om, s->far_w += lam * om;
                        else
                            near_add(near, Y / lam, lam * om);
                    }
                    if (!(Y > lam))
                        continue;
                    double e = (Y - lam) * om, wl = lam * om;
                    s->s0 += e;
                    s->s1 += e * u1;
                    s->s2 += e * u2;
                    s->w += wl;
                    s->w1 += wl * u1;
                    s->w2 += wl * u2;
                    s->w11 += wl * u1 * u1;
                    s->w12 += wl * u1 * u2;
                    s->w22 += wl * u2 * u2;
                    continue;
                }
                if (take_step(q, j, x, y, z, lm, v, &u1, &u2) < 0)
                    continue;
                /* what left the residual, exactly (float differences in double) */
                for (int k = 0; k < 3; k++)
                    s->rgb[k] += ((double)before[k] - v[k]) * om;
                double e = (Y - envl__lum(v[0], v[1], v[2])) * om;
                s->moment[0] += e * x;
                s->moment[1] += e * y;
                s->moment[2] += e * z;
                s->own += e * om / (4.0 * ENVL_PI);
                if (tm->res)
                    memcpy(tm->res + at, v, sizeof v);
                s->x0 = c < s->x0 ? c : s->x0;
                s->x1 = c + 1 > s->x1 ? c + 1 : s->x1;
                s->y0 = r < s->y0 ? r : s->y0;
                s->y1 = r + 1 > s->y1 ? r + 1 : s->y1;
            }
        }
    }
}

/* One pass of light j->light over j->tm; *out: the chunks' sums in chunk order. */
static void take_pass(take_job *j, int apply, take_sums *out)
{
    const envl_envmap *m = j->tm->m;
    const take_level *q = j->levels + j->light;
    int32_t n = (m->height + j->rows - 1) / j->rows;
    j->apply = apply;
    /* A pixel is taken only where the level falls under the largest luminance (a solve pass
     * for finish_lb: down to its window); each row then within its own largest. */
    j->g = level_cone(q, j->kappa, m, j->tm->log_max + near_log(j), 0.0);
    /* a pass over few pixels on one thread: starting threads would cost more */
    double rows = j->g.r1 >= j->g.r0 ? j->g.r1 - j->g.r0 + 1.0 : 0.0;
    envl__parallel_for(n, rows * m->width < TAKE_THREAD_PIXELS ? 1 : m->threads, take_range, j);
    sums_clear(out, m->width, m->height);
    for (int32_t c = 0; c < n; c++) {
        const take_sums *s = j->chunks + c;
        out->s0 += s->s0, out->s1 += s->s1, out->s2 += s->s2;
        out->w += s->w, out->w1 += s->w1, out->w2 += s->w2;
        out->w11 += s->w11, out->w12 += s->w12, out->w22 += s->w22;
        out->far_y += s->far_y, out->far_w += s->far_w;
        for (int k = 0; k < 3; k++) {
            out->rgb[k] += s->rgb[k];
            out->moment[k] += s->moment[k];
        }
        out->own += s->own;
        out->x0 = s->x0 < out->x0 ? s->x0 : out->x0;
        out->x1 = s->x1 > out->x1 ? s->x1 : out->x1;
        out->y0 = s->y0 < out->y0 ? s->y0 : out->y0;
        out->y1 = s->y1 > out->y1 ? s->y1 : out->y1;
    }
}

/* lb alone, e1 and e2 fixed: the luminance taken, s0(lb), falls as lb grows (continuous,
 * piecewise smooth), from everything on l's side (lb = lb_min, lambda ~ 0) to nothing (lb at
 * the largest row maximum). Newton steps (ds0 / dlb = -w) from q->lb (log t when it is not
 * finite), inside the bracket known so far, else doubling steps out of it or its middle,
 * until s0 = t within TAKE_TOLERANCE. Returns 0, or 1 when even lb_min takes less than t
 * (then q->lb = lb_min: all there is). *s: the sums at q->lb. */
static int solve_lb(take_job *j, take_level *q, double t, take_sums *s)
{
    double top = j->tm->log_max, lb_min = fmin(top, log(t)) - 60.0;
    double lo = -INFINITY, hi = INFINITY, x = isfinite(q->lb) ? q->lb : log(t), out = 1.0;
    x = fmin(fmax(x, lb_min), top);
    for (int it = 0; it < 200; it++) {
        q->lb = x;
        take_pass(j, 0, s);
        if (fabs(s->s0 - t) <= TAKE_TOLERANCE * t)
            return 0;
        if (s->s0 > t)
            lo = x;
        else
            hi = x;
        if (s->s0 < t && x <= lb_min)
            return 1; /* all there is */
        if (isfinite(lo) && isfinite(hi) && hi - lo <= 1e-15 * fmax(1.0, fabs(hi)))
            break;
        double next = s->w > 0 ? x + (s->s0 - t) / s->w : NAN;
        if (!(next > lo && next < hi)) {
            if (isfinite(lo) && isfinite(hi)) {
                next = 0.5 * (lo + hi);
            } else {
                next = fmin(fmax(isfinite(lo) ? lo + out : hi - out, lb_min), top);
                out *= 2.0;
            }
        }
        x = next;
    }
    if (isfinite(lo) && q->lb != lo) { /* the largest lb found that takes at least t */
        q->lb = lo;
        take_pass(j, 0, s);
    }
    return 0;
}

/* g(x) of finish_lb: the luminance taken at x times the level, x within the window. */
static double near_taken(const take_job *j, int32_t n, const take_sums *s, double x,
                         double *slope)
{
    double g = s->far_y - x * s->far_w, w = s->far_w;
    for (int32_t c = 0; c < n; c++)
        for (int64_t i = 0; i < j->near[c].n; i++) {
            const take_near *p = j->near[c].p + i;
            if (p->rho > x)
                g += p->wl * (p->rho - x), w += p->wl;
        }
    *slope = -w;
    return g;
}

/* lb on the map itself, from the finer copy's solution, which is close. One pass at it keeps
 * what taken pixels farther than TAKE_WINDOW above the level hold (sum Y dw, sum lambda dw)
 * and each pixel within the window of it (Y / lambda, lambda dw): with the level times x,
 * |x - 1| <= TAKE_WINDOW, the luminance taken is exactly
 *     g(x) = sum_far (Y - x lambda) dw + sum_near (Y - x lambda)+ dw,
 * piecewise linear and falling in x: solved there (Newton steps inside a bracket, no pass),
 * lb += log x, to TAKE_TOLERANCE. Where t is not within the window (or a list could not
 * grow), solve_lb. A pass or two less per light over the largest map. */
static void finish_lb(take_job *j, take_level *q, double t, take_sums *s)
{
    int32_t n = (j->tm->m->height + j->rows - 1) / j->rows;
    if (!isfinite(q->lb) || !j->near) {
        solve_lb(j, q, t, s);
        return;
    }
    take_pass(j, 0, s);
    if (fabs(s->s0 - t) <= TAKE_TOLERANCE * t)
        return;
    int full = 1;
    for (int32_t c = 0; c < n; c++)
        full = full && j->near[c].n >= 0;
    double lo = 1.0 - TAKE_WINDOW, hi = 1.0 + TAKE_WINDOW, slope;
    double g_lo = full ? near_taken(j, n, s, lo, &slope) : NAN;
    double g_hi = full ? near_taken(j, n, s, hi, &slope) : NAN;
    if (g_lo >= t && g_hi <= t) {
        double x = 1.0;
        for (int it = 0; it < 100; it++) {
            double g = near_taken(j, n, s, x, &slope);
            if (fabs(g - t) <= TAKE_TOLERANCE * t)
                break;
            if (g > t)
                lo = x;
            else
                hi = x;
            double next = slope < 0 ? x + (g - t) / -slope : NAN;
            x = next > lo && next < hi ? next : 0.5 * (lo + hi);
        }
        q->lb += log(x);
        return;
    }
    /* outside the window: solve_lb from its nearer edge (not the pass just made again), with
     * no lists kept */
    if (g_lo < t)
        q->lb += log(lo);
    else if (g_hi > t)
        q->lb += log(hi);
    j->near = NULL;
    solve_lb(j, q, t, s);
}

/* The moment's tangential part relative to the luminance taken: |(s1, s2)| / s0, the sine of
 * its angle from the aim to first order. */
static double tilt_of(const take_sums *s)
{
    return s->s0 > 0 ? hypot(s->s1, s->s2) / s->s0 : 0.0;
}

/* The tilt (e1, e2): Newton on the moment's tangential part (s1, s2) = 0 with lb solved at
 * every point (the luminance taken stays t). The reduced Jacobian, d(s1, s2) / de with
 * dlb / de = (w1, w2) / w from ds0 = 0, is w_ab - w_a w_b / w (a covariance of d.t1, d.t2
 * over the level's weights). Steps keep |e| <= emax and halve until the tilt falls; at most
 * `steps` of them; the best point is kept. */
static void align(take_job *j, take_level *q, double t, int steps, double emax)
{
    take_sums s;
    if (solve_lb(j, q, t, &s))
        return;
    double cur = tilt_of(&s);
    for (int it = 0; it < steps && cur > TAKE_TILT_TOLERANCE; it++) {
        double a = s.w11 - s.w1 * s.w1 / s.w, b = s.w12 - s.w1 * s.w2 / s.w,
               d = s.w22 - s.w2 * s.w2 / s.w, det = a * d - b * b;
        if (!(s.w > 0) || !(a > 0) || !(det > 1e-14 * (a * d)))
            return; /* one pixel (or a line of them): the moment cannot move */
        double de1 = -(d * s.s1 - b * s.s2) / det, de2 = -(a * s.s2 - b * s.s1) / det;
        take_level best = *q;
        take_sums bs = s;
        double bt = cur;
        int bound = 0;
        for (int half = 0; half < TAKE_HALVINGS; half++) {
            take_level trial = best;
            double f = ldexp(1.0, -half);
            trial.e1 += f * de1;
            trial.e2 += f * de2;
            double e = hypot(trial.e1, trial.e2);
            if (e > emax) {
                trial.e1 *= emax / e;
                trial.e2 *= emax / e;
                bound = 1;
            }
            *q = trial;
            if (solve_lb(j, q, t, &s) == 0 && tilt_of(&s) < bt) {
                bt = tilt_of(&s);
                bs = s;
                break;
            }
        }
        if (!(bt < cur)) {
            *q = best;
            solve_lb(j, q, t, &s);
            return; /* no step lowers the tilt: the best there is */
        }
        /* at the bound and gaining little: the moment cannot come much closer */
        int stop = bound && bt > 0.75 * cur;
        cur = bt;
        s = bs;
        if (stop)
            return;
    }
}

/* A level's map: its residual (res, or a copy of its pixels when copy is set), the log of each
 * row's largest luminance (the map's statistics; a little above: rounding never lifts a pixel
 * over it). */
static envl_result take_map_make(const envl_envmap *m, float *res, int copy, take_map *tm)
{
    size_t n = (size_t)m->width * m->height * 3;
    tm->m = m;
    tm->res = copy ? malloc(sizeof(float) * n) : res;
    if (copy && tm->res)
        envl__huge_pages(tm->res, sizeof(float) * n);
    tm->log_row_max = malloc(sizeof(double) * (size_t)m->height);
    tm->log_max = -INFINITY;
    if (!tm->log_row_max || (copy && !tm->res)) {
        free(tm->log_row_max);
        if (copy)
            free(tm->res);
        tm->log_row_max = NULL;
        tm->res = NULL;
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    }
    if (copy)
        memcpy(tm->res, m->px, sizeof(float) * n);
    for (int32_t r = 0; r < m->height; r++) {
        double mx = envl__row_max_luminance(m, r);
        tm->log_row_max[r] = mx > 0 ? log(mx) + 1e-6 : -INFINITY;
        tm->log_max = fmax(tm->log_max, tm->log_row_max[r]);
    }
    return ENVL_OK;
}

/* Lights' indices brightest (luminance) first, ties in index order. */
static void take_order(const envl_lights *ls, int32_t *order)
{
    for (int32_t i = 0; i < ls->summary.count; i++)
        order[i] = i;
    for (int32_t i = 1; i < ls->summary.count; i++)
        for (int32_t j = i; j > 0; j--) {
            const double *a = ls->lights[order[j]].rgb, *b = ls->lights[order[j - 1]].rgb;
            if (envl__lum(a[0], a[1], a[2]) <= envl__lum(b[0], b[1], b[2]))
                break;
            int32_t t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
}

/* The light from what it took (the map's take): rgb, rect, and its size about its direction
 * (the aim). */
static void light_from_take(const take_sums *s, int32_t W, int32_t H, envl_light *l)
{
    memcpy(l->rgb, s->rgb, sizeof l->rgb);
    envl__take t = {.moment = {s->moment[0], s->moment[1], s->moment[2]}, .own = s->own};
    envl__light_size(&t, l);
    l->rect[0] = s->x0 < W ? s->x0 : 0;
    l->rect[1] = s->y0 < H ? s->y0 : 0;
    l->rect[2] = s->x1 > 0 ? s->x1 : 0;
    l->rect[3] = s->y1 > 0 ? s->y1 : 0;
}

void envl__light_size(const envl__take *t, envl_light *l)
{
    /* With V = sum e d the first moment of what the light took, a surface that sees all of it
     * receives E(n) = n . V, which is (V . l) (n . l) where V lies along l. The spread about l
     * is sum e (1 - cos t) = taken - V . l, plus each pixel's own extent (a pixel of solid
     * angle om as its own disc: om / 4 pi, as sun_split.c counts it); a uniform disc of solid
     * angle w has mean (1 - cos t) = w / 4 pi, so w = 4 pi spread / taken, and
     * V . l = rgb (1 - w / 4 pi) up to the pixels' own extent: a disc light of that irradiance
     * at normal incidence (a Blender sun's energy) reproduces E(n). */
    double taken = envl__lum(l->rgb[0], l->rgb[1], l->rgb[2]);
    double along = t->moment[0] * l->direction[0] + t->moment[1] * l->direction[1] +
                   t->moment[2] * l->direction[2];
    double spread = taken - along + t->own;
    l->solid_angle = taken > 0 ? fmin(4.0 * ENVL_PI, 4.0 * ENVL_PI * fmax(spread, 0.0) / taken)
                               : 0.0;
    envl__light_set_angle(l);
}

void envl__light_take_size(const envl__take *t, envl_light *l)
{
    /* the same disc as envl__light_size's, about V itself: its spread is the least */
    double len = sqrt(t->moment[0] * t->moment[0] + t->moment[1] * t->moment[1] +
                      t->moment[2] * t->moment[2]);
    envl_light about = *l;
    for (int k = 0; len > 0 && k < 3; k++)
        about.direction[k] = t->moment[k] / len;
    envl__light_size(t, &about);
    memcpy(l->take_direction, about.direction, sizeof about.direction);
    l->take_solid_angle = about.solid_angle;
    l->take_angle = about.angle;
}

double envl__take_level_log(const envl__take *t, double x, double y, double z)
{
    take_level q = {t->aim, t->lb, t->e1, t->e2};
    double u1, u2;
    return log_level(&q, take_kappa(), take_sin_h(), x, y, z, &u1, &u2);
}

envl_result envl__take_lights(envl_envmap *m, const envl_envmap *coarse, envl_lights *ls,
                              envl__take *out)
{
    int32_t K = ls->summary.count, order[ENVL_NNLS_MAX];
    if (K <= 0)
        return ENVL_OK;
    /* the levels: the coarse copy, one TAKE_MID_WIDTH wide, the reference copy, the map (each
     * only when finer than the one before) */
    const envl_envmap *ref = NULL;
    envl_envmap *mid = NULL;
    take_map tms[4];
    int32_t nlev = 0;
    envl_result rc = envl__reference_copy(m, &ref);
    if (!rc && coarse != ref && coarse != m && !(rc = take_map_make(coarse, NULL, 1, &tms[nlev])))
        nlev++;
    if (!rc && ref->width > TAKE_MID_WIDTH && coarse->width < TAKE_MID_WIDTH &&
        !(rc = envl__envmap_resampled(ref->px, ref->width, ref->height, TAKE_MID_WIDTH,
                                      m->threads, &mid)) &&
        !(rc = take_map_make(mid, NULL, 1, &tms[nlev])))
        nlev++;
    if (!rc && ref != m && !(rc = take_map_make(ref, NULL, 1, &tms[nlev])))
        nlev++;
    if (!rc && !(rc = take_map_make(m, ls->residual, 0, &tms[nlev])))
        nlev++;
    take_sums *chunks = rc ? NULL : malloc(sizeof(take_sums) * TAKE_CHUNKS);
    if (!rc && !chunks)
        rc = envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    /* finish_lb's lists, on the map itself after coarser levels (NULL: solve_lb there) */
    take_near_list *near = nlev > 1 ? calloc(TAKE_CHUNKS, sizeof *near) : NULL;
    take_level levels[ENVL_NNLS_MAX]; /* in take order */
    double kappa = take_kappa();
    double emax = kappa * tan(TAKE_SHIFT_DEGREES * ENVL_PI / 180.0);
    take_order(ls, order);
    double t[ENVL_NNLS_MAX], sin_h = take_sin_h();
    for (int32_t i = 0; !rc && i < K; i++) {
        envl_light *l = &ls->lights[order[i]];
        take_level *q = &levels[i];
        memset(q, 0, sizeof *q);
        memcpy(q->a.l, l->direction, sizeof q->a.l);
        envl__tangents(q->a.l, q->a.t1, q->a.t2);
        q->a.side = q->a.l[2] >= 0 ? 1.0 : -1.0;
        t[i] = envl__lum(l->rgb[0], l->rgb[1], l->rgb[2]);
        q->lb = t[i] > 0 ? NAN : INFINITY; /* a light of no luminance takes nothing */
        take_sums s;
        for (int32_t v = 0; v < nlev; v++) {
            take_job j = {.tm = &tms[v], .levels = levels, .light = i,
                          .rows = (tms[v].m->height + TAKE_CHUNKS - 1) / TAKE_CHUNKS,
                          .kappa = kappa, .sin_h = sin_h, .chunks = chunks,
                          .near = v == nlev - 1 ? near : NULL};
            if (t[i] > 0 && (v < nlev - 1 || nlev == 1))
                align(&j, q, t[i], v == 0 ? TAKE_STEPS_FIRST : TAKE_STEPS_NEXT, emax);
            else if (t[i] > 0) /* on the map itself, after coarser levels: its luminance only */
                finish_lb(&j, q, t[i], &s);
            take_pass(&j, 1, &s); /* this level's residual */
        }
        if (out)
            out[order[i]] = (envl__take){.moment = {s.moment[0], s.moment[1], s.moment[2]},
                                         .own = s.own, .aim = q->a, .lb = q->lb, .e1 = q->e1,
                                         .e2 = q->e2};
        light_from_take(&s, m->width, m->height, l);
        rc = envl__progress(0.6 + 0.2 * (i + 1) / K, "the lights' takes");
    }
    free(chunks);
    for (int32_t c = 0; near && c < TAKE_CHUNKS; c++)
        free(near[c].p);
    free(near);
    for (int32_t v = 0; v < nlev; v++) {
        free(tms[v].log_row_max);
        if (tms[v].res != ls->residual)
            free(tms[v].res);
    }
    envl_envmap_free(mid);
    return rc;
}
