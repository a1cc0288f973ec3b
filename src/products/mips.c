/* The area-averaged mip pyramid of a lat-long map (built once per map and cached in it; the
 * public envl_envmap_mips), the cached cell pyramid of the specular levels (cells.c) and the
 * energy of a product image. */
#include "prefilter_impl.h"

#include <stdlib.h>
#include <string.h>

/* ---- the mip pyramid ---- */

/* Levels wider than this are not kept: a 16K map's level 1 alone is 384 MiB, a quarter of the
 * map again, and no product reads it at the chain's default sizes (docs/scale_bench.md). A
 * request for a finer level than the first one kept reads the map itself (pixels no wider
 * than asked for). 8K maps and smaller keep every level. */
#define MIP_KEPT_WIDTH 4096

/* The area-averaged pyramid of a W x H image: the sizes of levels 0 .. *n - 1 in mw, mh; the
 * levels from *first (the first no wider than MIP_KEPT_WIDTH) in *buf at off[k]. */
envl_result envl__build_pyramid(const float *px, int32_t w, int32_t h, float **buf_out,
                                 int32_t *n_out, int32_t *first_out, int32_t mw[40],
                                 int32_t mh[40], size_t off[40])
{
    int32_t n = 1, first = 0;
    size_t total = 0;
    mw[0] = w, mh[0] = h, off[0] = 0;
    while ((w > 1 || h > 1) && n < 40) {
        w = w > 1 ? w / 2 : 1;
        h = h > 1 ? h / 2 : 1;
        mw[n] = w, mh[n] = h, off[n] = total;
        if (!first && w <= MIP_KEPT_WIDTH)
            first = n;
        if (first)
            total += (size_t)w * h * 3;
        n++;
    }
    float *buf = n > 1 ? NULL : malloc(sizeof(float));
    if (n == 1 && !buf)
        return envl__fail(ENVL_ERR_MEMORY, "mip pyramid: out of memory");
    const float *prev = px;
    for (int32_t k = first; k < n; k++) {
        float *lev;
        /* Levels nest (each texel edge of level k is one of level k - 1, in azimuth and in
         * z), so resampling the previous level, or the map, is resampling the map. */
        const int32_t from = k == first ? 0 : k - 1;
        envl_result rc = envl__latlong_resample(prev, mw[from], mh[from], mw[k], mh[k], 0.0,
                                                &lev);
        if (rc) {
            free(buf);
            return rc;
        }
        if (k == first) {
            /* The first level sits at offset 0: its buffer grows to hold every level (for a
             * large block realloc remaps the pages: no second copy of it at the peak). */
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
    *first_out = first;
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
        envl_result rc = envl__build_pyramid(m->px, m->width, m->height, &buf, &n,
                                             &m->mip_first, mw, mh, off);
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
    free(m->cells);
    m->cells = NULL;
    envl_envmap_free(m->points_copy);
    m->points_copy = NULL;
}

envl_result envl__mip_level_for(envl_envmap *m, double pixel, envl_image *out)
{
    /* the coarsest level whose pixels (pi / h tall) are no taller than `pixel`, by the sizes
     * alone: a request the map itself meets builds no pyramid */
    int32_t k = 0, w = m->width, h = m->height;
    while ((w > 1 || h > 1) && k + 1 < 40 && ENVL_PI / (h > 1 ? h / 2 : 1) <= pixel) {
        w = w > 1 ? w / 2 : 1;
        h = h > 1 ? h / 2 : 1;
        k++;
    }
    if (k > 0) {
        envl_result rc = envl_envmap_mips(m, NULL);
        if (rc)
            return rc;
        if (k < m->mip_first) /* not kept: the map */
            k = 0;
    }
    *out = k ? (envl_image){.width = m->mip_w[k], .height = m->mip_h[k],
                            .px = m->mip_px + m->mip_offset[k]}
             : (envl_image){.width = m->width, .height = m->height, .px = m->px};
    return ENVL_OK;
}

envl_result envl__map_cells(envl_envmap *m, int32_t base, const envl_cells **out, int *built)
{
    if (built)
        *built = 0;
    if (!m->cells || envl__cells_base_of(m->cells) > base) {
        envl_cells *c;
        envl_result rc = envl__cells_build(m->px, m->width, m->height, base, m->threads, &c);
        if (rc)
            return rc;
        free(m->cells);
        m->cells = c;
        if (built)
            *built = 1;
    }
    *out = m->cells;
    return ENVL_OK;
}

/* Integral of L dw of a product image (lat-long or a strip of faces), per channel: each
 * texel's value times its solid angle. */
void envl__image_energy(const float *px, int32_t layout, int32_t w, int32_t h, double e[3])
{
    e[0] = e[1] = e[2] = 0;
    for (int32_t r = 0; r < h; r++) {
        double row[3] = {0, 0, 0};
        const float *p = px + (size_t)r * w * 3;
        if (layout == ENVL_LAYOUT_STRIP_H) {
            for (int32_t c = 0; c < w; c++) {
                double om = envl__texel_solid_angle(layout, w, h, c, r);
                for (int k = 0; k < 3; k++)
                    row[k] += om * p[3 * c + k];
            }
        } else {
            for (int32_t c = 0; c < w; c++)
                for (int k = 0; k < 3; k++)
                    row[k] += p[3 * c + k];
            double om = envl_latlong_solid_angle(w, h, r);
            for (int k = 0; k < 3; k++)
                row[k] *= om;
        }
        for (int k = 0; k < 3; k++)
            e[k] += row[k];
    }
}
