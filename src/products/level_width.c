/* What a specular level's accuracy costs: the width at which its glossy error would meet
 * ENVL_GLOSSY_TARGET, and the time that width would take (docs/design.md, "Level width for
 * 1 %"; the measured curve: docs/specular_width.md).
 *
 * The glossy error of a filtered level is that of its texels read bilinearly at the 1024
 * error directions: each texel is P at its centre from the level's own cut (cells.c), so the
 * error at another width u needs only the four texels around each direction at u, 4096 cuts
 * in all, whatever u is (a whole level is 6 u^2 or u^2 / 2 cuts). The search reads them
 * (envl__texel_taps: the same bilinear read, but clamped at a face's edge and at the poles'
 * half rows) at widths chosen by the model that bilinear interpolation's error falls as the
 * texel spacing squared (e ~ u^-2 for a P smooth on the texels' scale; from a width where the
 * lobe is not yet resolved it falls faster or not monotonically), bracketing the target and
 * then halving the bracket in log u until it is within 5 %; a width meets the target when
 * it and the widths 5 % and 10 % wider do (STAY_1, STAY_2). Only the directions that carry the
 * level's error are read again: the fewest, largest, whose squares leave out at most
 * (REST x target)^2 of the sum at the level's own width; the rest keep their error there
 * (not scaled down: the estimate errs on the wide side, by at most 0.5 % of the target). The
 * time: the level's seconds per texel times the texels at the width found (its quadrature,
 * rho, is the level's at any width of the same chain). */
#include "prefilter_impl.h"

#include <math.h>
#include <stdlib.h>

#define TAPS 4
#define BRACKET 1.05   /* the search stops when hi / lo is within this */
#define MAX_TRIES 40   /* error_at calls */
#define STAY_1 1.05     /* a width meets the target when these wider ones meet it too */
#define STAY_2 1.1
#define REST 0.1       /* what the directions not read again may leave, of the target */

typedef struct width_search {
    const envl_cells *C;
    cut_accuracy cut;
    double alpha, roughness;
    int32_t layout, threads;
    const envl_light *sun;
    int32_t n_sun;
    int32_t n;                /* directions read again */
    double *dirs, *ref;       /* theirs (n x 3) */
    double rest, norm;        /* the others' sum of squared errors; N mean^2 (all N) */
    double *taps, *values, *weights, *approx; /* scratch */
    int32_t tries;
} width_search;

/* The glossy error of the level read from texels computed at width u (faces: u texels
 * square; lat-long: u x u / 2). */
static envl_result error_at(width_search *s, int32_t u, double *error)
{
    int32_t faces = s->layout == ENVL_LAYOUT_STRIP_H;
    int32_t w = faces ? 6 * u : u, h = faces ? u : u / 2;
    for (int32_t i = 0; i < s->n; i++) {
        int32_t col[TAPS], row[TAPS];
        envl__texel_taps(s->layout, w, h, s->dirs + 3 * i, col, row, s->weights + TAPS * i);
        for (int k = 0; k < TAPS; k++)
            envl__texel_direction(s->layout, w, h, col[k], row[k], s->taps + 3 * (TAPS * i + k));
    }
    envl_result rc = envl__cells_at(s->C, &s->cut, s->alpha, TAPS * s->n, s->taps, s->threads,
                                    s->values);
    if (rc)
        return rc;
    for (int32_t i = 0; i < s->n; i++)
        for (int c = 0; c < 3; c++) {
            double v = 0;
            for (int k = 0; k < TAPS; k++)
                v += s->weights[TAPS * i + k] * s->values[3 * (TAPS * i + k) + c];
            s->approx[3 * i + c] = v;
        }
    envl__sun_lights_add(s->sun, s->n_sun, s->roughness, s->n, s->dirs, s->approx);
    /* envl_relative_rms_luminance over all N directions, the others at the level's width */
    double se = s->rest;
    for (int32_t i = 0; i < s->n; i++) {
        const double *a = s->approx + 3 * i, *e = s->ref + 3 * i;
        double d = envl__lum(a[0], a[1], a[2]) - envl__lum(e[0], e[1], e[2]);
        se += d * d;
    }
    *error = sqrt(se / s->norm);
    s->tries++;
    return ENVL_OK;
}

typedef struct dir_error {
    double d2;                /* squared luminance error at the level's width */
    int32_t i;
} dir_error;

static int larger_first(const void *a, const void *b)
{
    double x = ((const dir_error *)a)->d2, y = ((const dir_error *)b)->d2;
    return x < y ? 1 : x > y ? -1 : 0;
}

/* The directions to read again (s->dirs, s->ref, s->n) and what the others leave (s->rest,
 * s->norm), from the level as computed, read as the glossy error reads it. */
static envl_result pick_directions(width_search *s, const envl_level *l, const double *dirs,
                                   const double *ref)
{
    dir_error *de = malloc(sizeof(dir_error) * ENVL_ERROR_NORMALS);
    double *a = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!de || !a) {
        free(de);
        free(a);
        return envl__fail(ENVL_ERR_MEMORY, "level width estimate: out of memory");
    }
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++) {
        if (l->layout == ENVL_LAYOUT_STRIP_H)
            envl__strip_sample(l->rgb, l->height, dirs + 3 * i, a + 3 * i);
        else
            envl_latlong_sample(l->rgb, l->width, l->height, dirs + 3 * i, a + 3 * i);
    }
    envl__sun_lights_add(s->sun, s->n_sun, s->roughness, ENVL_ERROR_NORMALS, dirs, a);
    double sum = 0, mean = 0;
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++) {
        const double *e = ref + 3 * i;
        double ye = envl__lum(e[0], e[1], e[2]);
        double d = envl__lum(a[3 * i], a[3 * i + 1], a[3 * i + 2]) - ye;
        de[i] = (dir_error){d * d, i};
        sum += d * d;
        mean += fabs(ye) / ENVL_ERROR_NORMALS;
    }
    free(a);
    qsort(de, ENVL_ERROR_NORMALS, sizeof *de, larger_first);
    s->norm = ENVL_ERROR_NORMALS * mean * mean;
    double allowed = REST * ENVL_GLOSSY_TARGET * REST * ENVL_GLOSSY_TARGET * s->norm;
    s->rest = sum;
    s->n = 0;
    while (s->n < ENVL_ERROR_NORMALS && s->rest > allowed) {
        int32_t i = de[s->n].i;
        for (int c = 0; c < 3; c++)
            s->dirs[3 * s->n + c] = dirs[3 * i + c], s->ref[3 * s->n + c] = ref[3 * i + c];
        s->rest -= de[s->n++].d2;
    }
    s->rest = fmax(s->rest, 0);
    free(de);
    return ENVL_OK;
}

/* u rounded up to a width the layout takes (lat-long: even), within [lo, hi]. */
static int32_t legal(double u, int32_t step, int32_t lo, int32_t hi)
{
    double r = ceil(u / step) * step;
    return r < lo ? lo : r > hi ? hi : (int32_t)r;
}

/* Whether width u meets the target and keeps it at the widths STAY above (a sharp light's
 * error depends on where the texel grid falls, and a width can meet it by luck: on the
 * built-in sky at roughness 0.2, 850 lat-long texels 0.62 %, 1012 1.11 %); *e: the error at
 * u. */
static envl_result meets(width_search *s, int32_t u, int32_t step, int32_t umax, double *e,
                         int *ok)
{
    envl_result rc = error_at(s, u, e);
    *ok = !rc && *e <= ENVL_GLOSSY_TARGET;
    for (int k = 0; !rc && *ok && k < 2; k++) {
        int32_t v = legal(u * (k ? STAY_2 : STAY_1), step, u + step, umax);
        double ev;
        if (v > u && !(rc = error_at(s, v, &ev)))
            *ok = ev <= ENVL_GLOSSY_TARGET;
    }
    return rc;
}

envl_result envl__level_width_estimate(const envl_cells *C, const resolved *o,
                                       const envl_level *l, const envl_light *sun,
                                       int32_t n_sun, const double *dirs, const double *ref,
                                       envl_width_estimate *out)
{
    double t0 = envl__seconds();
    *out = (envl_width_estimate){0};
    if (l->glossy_error < 0 || !(l->roughness > 0) || !l->filtered || !C)
        return ENVL_OK;
    if (l->glossy_error <= ENVL_GLOSSY_TARGET) {
        out->state = ENVL_WIDTH_MET;
        return ENVL_OK;
    }
    int32_t faces = l->layout == ENVL_LAYOUT_STRIP_H;
    int32_t step = faces ? 1 : 2, scale = faces ? 4 : 1;
    int32_t u0 = faces ? l->height : l->width, k = envl__level_shift(o, l->roughness);
    int32_t umax = (65536 >> (k < 16 ? k : 16)) / scale / step * step;
    width_search s = {.C = C, .cut = envl__level_cut, .alpha = l->alpha,
                      .roughness = l->roughness, .layout = l->layout, .threads = o->threads,
                      .sun = sun, .n_sun = n_sun};
    s.cut.rho = envl__level_rho(o, envl__level_width(o, l->roughness));
    size_t n = (size_t)TAPS * ENVL_ERROR_NORMALS;
    s.dirs = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    s.ref = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    s.taps = malloc(sizeof(double) * 3 * n);
    s.values = malloc(sizeof(double) * 3 * n);
    s.weights = malloc(sizeof(double) * n);
    s.approx = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    envl_result rc = s.dirs && s.ref && s.taps && s.values && s.weights && s.approx
                         ? pick_directions(&s, l, dirs, ref)
                         : envl__fail(ENVL_ERR_MEMORY, "level width estimate: out of memory");
    /* the bracket: lo misses the target (the level's own width first), hi meets it */
    int32_t lo = u0, hi = 0;
    double elo = l->glossy_error, ehi = -1, e = elo;
    while (!rc && s.tries < MAX_TRIES) {
        int32_t u;
        if (!hi) { /* e ~ u^-2: the target at u sqrt(e / target); at least 25 % wider */
            if (lo >= umax)
                break;
            u = legal(lo * fmax(sqrt(e / ENVL_GLOSSY_TARGET), 1.25), step, lo + step, umax);
        } else { /* bracketed: halve it in log u */
            if (hi <= lo * BRACKET || hi - lo <= step)
                break;
            u = legal(sqrt((double)lo * hi), step, lo + step, hi - step);
        }
        int ok;
        if ((rc = meets(&s, u, step, umax, &e, &ok)))
            break;
        if (ok)
            hi = u, ehi = e;
        else
            lo = u, elo = e;
    }
    if (!rc) {
        out->state = hi ? ENVL_WIDTH_FOUND : ENVL_WIDTH_BEYOND;
        out->width = hi ? hi : lo;
        out->glossy_error = hi ? ehi : elo;
        out->size = (out->width * scale) << k;
        double ratio = (double)out->width / u0;
        out->seconds = l->seconds * ratio * ratio;
        out->widths_tried = s.tries;
        out->directions_read = s.n;
    }
    free(s.dirs);
    free(s.ref);
    free(s.taps);
    free(s.values);
    free(s.weights);
    free(s.approx);
    out->seconds_spent = envl__seconds() - t0;
    return rc;
}
