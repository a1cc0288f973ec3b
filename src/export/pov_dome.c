/* The dome's lights: the sky as lights with soft shadows (docs/methods.md, "POV-Ray").
 *
 * The suns of the sky (sun_split.c: pixels above 50 x its mean luminance, grouped) become
 * lights of their own size: a sun inside a variance cell would cast its shadow from the cell's
 * centroid, a few degrees off, and as wide as the cell. The rest of the sky is cut by variance
 * (lights_cut.c), whose cells follow the sky's spread. Without a ground (a scene whose ground
 * is not known), the map's lower half is cut apart with its share of the lights (2 .. count / 4):
 * a cell across the horizon would put its light below a floor that hides it (-10 % on a studio
 * map). Each light then gets the shape of its region (pov_area.c). The two halves of a map of
 * even height are windows of its rows (envl__envmap_window): no copy, so a 16K map's dome
 * needs little beyond the map (docs/scale_bench.md). */
#include "pov_light.h"
#include "envmap_impl.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The map less its upper hemisphere: map - upper, pixel by pixel (upper is map with its lower
 * half black, the row across the horizon mixed: the two add up to the map). Above the horizon
 * the difference is 0: those pixels are left as calloc gave them, pages backed by the system's
 * one zero page until written (half a map of memory, not a whole one), and the pixels are the
 * new map's own (adopted, not copied). */
static envl_result lower_half(const envl_envmap *map, const envl_envmap *upper, int32_t threads,
                              envl_envmap **out)
{
    size_t n = (size_t)3 * map->width * map->height;
    float *px = calloc(n, sizeof(float));
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "pov: out of memory");
    for (size_t i = 0; i < n; i++) {
        float d = fmaxf(0, map->px[i] - upper->px[i]);
        if (d != 0)
            px[i] = d;
    }
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    return envl__envmap_adopt(px, map->width, map->height, &lo, "", out);
}

static double power_lum(const envl_envmap *m)
{
    return envl_luminance(m->info.power[0], m->info.power[1], m->info.power[2]);
}

/* Appends the lights of `ls`, shaped from `source`. */
static void append(const envl_lights *ls, const envl_envmap *source, double sun_threshold,
                   int sun, int side, pov_light *out, int32_t *n)
{
    for (int32_t j = 0; ls && j < envl_lights_count(ls); j++) {
        pov_light *p = out + (*n)++;
        memset(p, 0, sizeof *p);
        envl_lights_get(ls, j, &p->l);
        p->sun = sun;
        p->side = side;
        pov_area_shape(source, sun_threshold, p);
    }
}

/* count lights of `map` by variance cut (none when count is 0 or the map is black). */
static envl_result cut(envl_envmap *map, int32_t count, envl_lights **ls)
{
    *ls = NULL;
    if (count <= 0 || !(power_lum(map) > 0))
        return ENVL_OK;
    envl_lights_options o = {.method = ENVL_METHOD_VARIANCE, .count = count};
    return envl_lights_compute(map, &o, ls);
}

envl_result pov_dome_lights(const envl_envmap *upper_c, const envl_envmap *map_c, int32_t count,
                            int32_t threads, pov_light **lights, int32_t *n, int32_t *suns,
                            int32_t *below)
{
    envl_envmap *upper = (envl_envmap *)upper_c, *lower = NULL, *rest = NULL; /* rest: a view */
    envl_envmap *window = NULL; /* the sky half as the map's rows, when upper_c is NULL */
    envl_lights *sun = NULL, *cells = NULL, *down = NULL;
    pov_light *down_lights = NULL, *sun_lights = NULL;
    float *saved = NULL; /* the sky's pixels under the suns while `rest` views them */
    *lights = NULL;
    *n = *suns = *below = 0;
    envl_result r = ENVL_OK;
    if (!upper) {
        /* the horizon between rows h / 2 - 1 and h / 2: each half is the map's own rows */
        int32_t h = map_c->height;
        if ((r = envl__envmap_window(map_c, 0, h / 2, &window)) ||
            (r = envl__envmap_window(map_c, h / 2, h, &lower))) {
            envl_envmap_free(window);
            return r;
        }
        upper = window;
    } else if (map_c && (r = lower_half(map_c, upper, threads, &lower))) {
        return r;
    }
    double pu = power_lum(upper), pl = lower ? power_lum(lower) : 0;
    int32_t nd = 0;
    if (pl > 0 && count >= 2) {
        nd = (int32_t)lround(count * pl / (pu + pl));
        int32_t most = count / 4 > 1 ? count / 4 : 1, least = count >= 8 ? 2 : 1;
        nd = nd < least ? least : nd > most ? most : nd;
    }
    int32_t nu = count - nd;
    /* The lower half first, shaped and let go before the upper half's suns leave their rest:
     * never the two copies at once. */
    int32_t nbelow = 0;
    if ((r = cut(lower, nd, &down)))
        goto done;
    down_lights = calloc(envl_lights_count(down) > 0 ? (size_t)envl_lights_count(down) : 1,
                         sizeof *down_lights);
    if (!down_lights) {
        r = envl__fail(ENVL_ERR_MEMORY, "pov: out of memory");
        goto done;
    }
    append(down, lower, 0, 0, POV_SIDE_DOWN, down_lights, &nbelow);
    envl_envmap_free(lower);
    lower = NULL;
    /* the suns take at most a quarter of the sky's lights */
    int32_t ns = nu / 4 < POV_DOME_SUNS ? nu / 4 : POV_DOME_SUNS;
    double threshold = 50.0 * pu / (4 * ENVL_PI); /* sun_split.c's SPLIT_K x the mean */
    if (ns > 0 && pu > 0) {
        envl_lights_options so = {.method = ENVL_METHOD_SUN, .count = ns, .skip_residual = 1};
        if ((r = envl_lights_compute(upper, &so, &sun)))
            goto done;
    }
    int32_t k = envl_lights_count(sun), nsun = 0;
    sun_lights = calloc(k > 0 ? (size_t)k : 1, sizeof *sun_lights);
    if (!sun_lights) {
        r = envl__fail(ENVL_ERR_MEMORY, "pov: out of memory");
        goto done;
    }
    append(sun, upper, threshold, 1, POV_SIDE_UP, sun_lights, &nsun); /* shaped from the sky */
    /* The rest of the sky, cut into cells: the sky's own pixels with the suns patched in (no
     * copy), put back before this returns. */
    if (k > 0 && (r = envl__sun_residual_view(upper, sun, threads, &saved, &rest)))
        goto done;
    if ((r = cut(rest ? rest : upper, nu - k, &cells)))
        goto done;
    int32_t total = k + envl_lights_count(cells) + nbelow;
    *lights = calloc(total > 0 ? (size_t)total : 1, sizeof **lights);
    if (!*lights) {
        r = envl__fail(ENVL_ERR_MEMORY, "pov: out of memory");
        goto done;
    }
    memcpy(*lights, sun_lights, sizeof *sun_lights * (size_t)nsun);
    *n = nsun;
    append(cells, rest ? rest : upper, 0, 0, POV_SIDE_UP, *lights, n);
    memcpy(*lights + *n, down_lights, sizeof *down_lights * (size_t)nbelow);
    *n += nbelow;
    pov_area_samples(*lights, *n);
    *suns = k;
    *below = nbelow;
done:
    envl__sun_residual_view_end(upper, sun, saved, rest); /* the sky's pixels back */
    free(sun_lights);
    free(down_lights);
    envl_lights_free(sun);
    envl_lights_free(cells);
    envl_lights_free(down);
    envl_envmap_free(lower);
    envl_envmap_free(window);
    return r;
}
