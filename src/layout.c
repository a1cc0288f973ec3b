/* Input layouts (angular probe, mirror ball, cube crosses, strips, OpenEXR envmap) to and from
 * the canonical lat-long frame. (being written) */
#include "internal.h"

#include <string.h>

int32_t envl__guess_layout(const envl_image *img) { return ENVL_LAYOUT_LATLONG; }

int32_t envl__default_latlong_width(const envl_image *src, int32_t layout) { return src->width; }

envl_result envl__layout_to_latlong(const envl_image *src, int32_t layout, int32_t out_width,
                                    envl_image *out)
{
    if (layout != ENVL_LAYOUT_LATLONG)
        return envl__fail(ENVL_ERR_UNSUPPORTED, "layout %d not written yet", (int)layout);
    float *px = NULL;
    envl_result rc = envl__latlong_resample(src->px, src->width, src->height, out_width,
                                            out_width / 2 > 0 ? out_width / 2 : 1, 0.0, &px);
    if (rc)
        return rc;
    memset(out, 0, sizeof *out);
    out->px = px;
    out->width = out_width;
    out->height = out_width / 2 > 0 ? out_width / 2 : 1;
    out->meta = src->meta;
    return ENVL_OK;
}

envl_result envl__latlong_to_layout(const envl_image *latlong, int32_t layout, int32_t size,
                                    envl_image *out)
{
    return envl__fail(ENVL_ERR_UNSUPPORTED, "layout %d not written yet", (int)layout);
}

const char *envl_layout_name(int32_t layout)
{
    static const char *names[ENVL_LAYOUT_COUNT] = {
        "auto", "latlong", "angular", "mirrorball", "cross", "hcross", "hstrip", "vstrip",
        "exr-latlong", "exr-cube"};
    return layout >= 0 && layout < ENVL_LAYOUT_COUNT ? names[layout] : NULL;
}

int32_t envl_layout_from_name(const char *name)
{
    if (!name)
        return -1;
    for (int32_t i = 0; i < ENVL_LAYOUT_COUNT; i++)
        if (strcmp(name, envl_layout_name(i)) == 0)
            return i;
    if (strcmp(name, "vcross") == 0)
        return ENVL_LAYOUT_CROSS_V;
    return -1;
}
