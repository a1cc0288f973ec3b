/* ---- bright pixels split off a map ----
 * A sun (0.5 degrees, 1e5 times the sky) is far below what any sample pattern resolves. So
 * pixels brighter than T = SPLIT_K x the map's mean luminance (at most SPLIT_MAX of them: T is
 * raised to the luminance of the next brightest pixel if needed) are split: the residual keeps
 * the pixel scaled to luminance T, and the excess E_j = L_j (1 - T / Y_j) omega_j (per
 * channel) becomes a lobe at the pixel's centre direction l_j. With options.sun_lights the
 * prefiltered maps turn the groups that are suns into lights and filter the map less what they
 * took (request.c, cells.c); the lights method "sun" returns the sun lights and the residual
 * (lights.c). */
#include "sun_split.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SPLIT_K 50.0
#define SPLIT_MAX 4096

void envl__sun_split_free(envl_sun_split *s)
{
    free(s->lobes);
    memset(s, 0, sizeof *s);
}

static int cmp_desc(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return x > y ? -1 : x < y;
}

/* The map's power in luminance, sum of Y dw (luminance is linear in rgb). */
static double map_power(const envl_envmap *m)
{
    return envl__lum(m->info.power[0], m->info.power[1], m->info.power[2]);
}

envl_result envl__sun_split_lobes(const envl_envmap *m, envl_sun_split *s)
{
    memset(s, 0, sizeof *s);
    int32_t w = m->width, h = m->height;
    double T = SPLIT_K * map_power(m) / (4 * ENVL_PI);
    if (!(T > 0) || !isfinite(T))
        return ENVL_OK;
    int32_t r0 = 0, r1 = h; /* a window's other rows are black: none is over T */
    envl__window_rows(m, &r0, &r1);
    /* one pass: the pixels over T, in row-major order (few: on a map with no negative pixel
     * their solid angle is under 4 pi / SPLIT_K) */
    size_t count = 0, cap = 0, i0 = (size_t)w * r0, i1 = (size_t)w * r1, *over = NULL;
    for (size_t i = i0; i < i1; i++) {
        if (!(envl__lum(m->px[3 * i], m->px[3 * i + 1], m->px[3 * i + 2]) > T))
            continue;
        if (count == cap) {
            size_t *grown = realloc(over, sizeof(size_t) * (cap = cap ? 2 * cap : 1024));
            if (!grown) {
                free(over);
                return envl__fail(ENVL_ERR_MEMORY, "sun split: out of memory");
            }
            over = grown;
        }
        over[count++] = i;
    }
    if (count == 0)
        return ENVL_OK;
    if (count > SPLIT_MAX) {
        float *y = malloc(sizeof(float) * count);
        if (!y) {
            free(over);
            return envl__fail(ENVL_ERR_MEMORY, "sun split: out of memory");
        }
        for (size_t k = 0; k < count; k++) {
            const float *p = m->px + 3 * over[k];
            y[k] = (float)envl__lum(p[0], p[1], p[2]);
        }
        qsort(y, count, sizeof(float), cmp_desc);
        T = y[SPLIT_MAX];
        free(y);
    }
    s->threshold = T;
    s->lobes = malloc(sizeof(envl_sun_lobe) * (count < SPLIT_MAX ? count : SPLIT_MAX));
    if (!s->lobes) {
        free(over);
        return envl__fail(ENVL_ERR_MEMORY, "sun split: out of memory");
    }
    for (size_t k = 0; k < count && s->n < SPLIT_MAX; k++) {
        int32_t r = (int32_t)(over[k] / (size_t)w), c = (int32_t)(over[k] % (size_t)w);
        const float *p = m->px + 3 * over[k];
        double y = envl__lum(p[0], p[1], p[2]);
        if (!(y > T))
            continue;
        envl_sun_lobe *l = s->lobes + s->n++;
        double f = T / y;
        for (int k3 = 0; k3 < 3; k3++) {
            double keep = p[k3] * f;
            l->e[k3] = (p[k3] - keep) * m->row_omega[r];
            l->keep[k3] = (float)keep;
        }
        l->d[0] = m->row_cos[r] * m->col_cos[c];
        l->d[1] = m->row_cos[r] * m->col_sin[c];
        l->d[2] = m->row_sin[r];
        l->r = r, l->c = c;
        l->taken = 0;
    }
    free(over);
    return ENVL_OK;
}

envl_pixel_patch *envl__sun_split_patches(const envl_sun_split *s)
{
    envl_pixel_patch *patch = malloc(sizeof *patch * (size_t)(s->n ? s->n : 1));
    for (int32_t i = 0; patch && i < s->n; i++) {
        const envl_sun_lobe *l = s->lobes + i;
        patch[i] = (envl_pixel_patch){l->r, l->c, {l->keep[0], l->keep[1], l->keep[2]}};
    }
    return patch;
}

/* ---- the split-off lobes as lights ----
 * An 8-connected group of split pixels (columns wrap; a pole row is one group) becomes a light
 * when it is a sun: rgb = sum E_j, direction = the luminance-weighted centroid of the l_j, and
 * the solid angle of the uniform disc with the same spread, 4 pi mean(1 - cos t) over the
 * group's pixels, each pixel counted as its own disc (mean(1 - cos t) = omega_j / 4 pi), as
 * lights.c sizes fit lights. A sun: that disc at most SUN_MAX_ANGLE across, the group's pixels
 * filling at least 1 / SUN_MIN_FILL of it (a window frame or a ring of lamps is no disc), and
 * at least SUN_MIN_SHARE of the map's power (no light for a glint). The other groups stay
 * in the map the prefiltered levels filter (request.c), or in the residual (lights.c). */
#define SUN_MAX_ANGLE (5.0 * ENVL_PI / 180)
#define SUN_MIN_FILL 2.0
#define SUN_MIN_SHARE 0.01
static int lobes_touch(const envl_sun_lobe *a, const envl_sun_lobe *b, int32_t w, int32_t h)
{
    int32_t dr = abs(a->r - b->r), dc = abs(a->c - b->c);
    if (dr > 1)
        return 0;
    if (dr == 0 && (a->r == 0 || a->r == h - 1))
        return 1;
    return dc <= 1 || dc == w - 1;
}

static int32_t find_root(int32_t *parent, int32_t i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

envl_result envl__sun_split_lights(const envl_envmap *m, envl_sun_split *s, envl_light **out,
                                   int32_t *count)
{
    *out = NULL;
    *count = 0;
    if (s->n == 0)
        return ENVL_OK;
    int32_t *parent = malloc(sizeof(int32_t) * s->n), *group = malloc(sizeof(int32_t) * s->n);
    /* per group: e[3], sum y d[3], sum y, sum y (1 - cos t) (pixels as discs: omega / 4 pi
     * each, then the distance to the centroid), solid angle of its pixels */
    double *acc = calloc((size_t)s->n, 9 * sizeof(double));
    envl_light *l = calloc((size_t)s->n, sizeof(envl_light));
    if (!parent || !group || !acc || !l) {
        free(parent), free(group), free(acc), free(l);
        return envl__fail(ENVL_ERR_MEMORY, "sun split: out of memory");
    }
    for (int32_t i = 0; i < s->n; i++)
        parent[i] = i;
    /* lobes are in row-major order: only the rows r and r + 1 can touch */
    for (int32_t i = 0; i < s->n; i++)
        for (int32_t j = i + 1; j < s->n && s->lobes[j].r <= s->lobes[i].r + 1; j++)
            if (lobes_touch(s->lobes + i, s->lobes + j, m->width, m->height))
                parent[find_root(parent, j)] = find_root(parent, i);
    int32_t n = 0;
    for (int32_t i = 0; i < s->n; i++)
        if (find_root(parent, i) == i)
            group[i] = n++;
    for (int32_t i = 0; i < s->n; i++) {
        group[i] = group[find_root(parent, i)];
        const envl_sun_lobe *b = s->lobes + i;
        double *a = acc + 9 * group[i], y = envl__lum(b->e[0], b->e[1], b->e[2]);
        double om = m->row_omega[b->r];
        for (int k = 0; k < 3; k++)
            a[k] += b->e[k], a[3 + k] += y * b->d[k];
        a[6] += y;
        a[7] += y * om / (4 * ENVL_PI);
        a[8] += om;
    }
    for (int32_t g = 0; g < n; g++) { /* the direction first, then the spread about it */
        const double *a = acc + 9 * g;
        double nd = sqrt(a[3] * a[3] + a[4] * a[4] + a[5] * a[5]);
        for (int k = 0; k < 3; k++)
            l[g].direction[k] = nd > 0 ? a[3 + k] / nd : 0;
    }
    for (int32_t i = 0; i < s->n; i++) {
        const envl_sun_lobe *b = s->lobes + i;
        const double *dir = l[group[i]].direction;
        acc[9 * group[i] + 7] += envl__lum(b->e[0], b->e[1], b->e[2]) *
                                 (1 - (b->d[0] * dir[0] + b->d[1] * dir[1] + b->d[2] * dir[2]));
    }
    int32_t nl = 0, *light = parent; /* group -> light, or -1 (parent is no longer needed) */
    for (int32_t g = 0; g < n; g++) {
        const double *a = acc + 9 * g;
        envl_light li = l[g];
        li.solid_angle = a[6] > 0 ? fmin(4 * ENVL_PI, 4 * ENVL_PI * a[7] / a[6]) : 0;
        for (int k = 0; k < 3; k++)
            li.rgb[k] = a[k];
        envl__light_set_angle(&li);
        memcpy(li.take_direction, li.direction, sizeof li.direction); /* what it took */
        li.take_solid_angle = li.solid_angle;
        li.take_angle = li.angle;
        int keep = li.angle <= SUN_MAX_ANGLE && li.solid_angle <= SUN_MIN_FILL * a[8] &&
                   a[6] >= SUN_MIN_SHARE * map_power(m);
        light[g] = keep ? nl : -1;
        if (keep)
            l[nl++] = li;
    }
    for (int32_t i = 0; i < s->n; i++)
        s->lobes[i].taken = light[group[i]] + 1;
    free(parent), free(group), free(acc);
    if (nl == 0) {
        free(l);
        l = NULL;
    }
    *out = l;
    *count = nl;
    return ENVL_OK;
}
