/* Decoded images: allocation under limits. */
#include "internal.h"

#include <stdlib.h>
#include <string.h>

envl_result envl__image_alloc(envl_image *img, int32_t w, int32_t h, const envl_limits *lim,
                              const char *what)
{
    if (w <= 0 || h <= 0)
        return envl__fail(ENVL_ERR_FORMAT, "%s: image size %d x %d: both must be at least 1",
                          what, (int)w, (int)h);
    int64_t n = (int64_t)w * (int64_t)h;
    int64_t max = lim && lim->max_pixels > 0 ? lim->max_pixels : ENVL_DEFAULT_MAX_PIXELS;
    if (n > max)
        return envl__fail(ENVL_ERR_LIMIT,
                          "%s: image size %d x %d = %lld pixels exceeds the limit of %lld pixels",
                          what, (int)w, (int)h, (long long)n, (long long)max);
    if ((uint64_t)n > SIZE_MAX / (3 * sizeof(float)))
        return envl__fail(ENVL_ERR_LIMIT, "%s: image size %d x %d too large for memory", what,
                          (int)w, (int)h);
    float *px = calloc((size_t)n * 3, sizeof(float));
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate %d x %d pixels", what, (int)w,
                          (int)h);
    free(img->px);
    img->px = px;
    img->width = w;
    img->height = h;
    return ENVL_OK;
}

void envl__image_free(envl_image *img)
{
    if (!img)
        return;
    free(img->px);
    img->px = NULL;
    img->width = img->height = 0;
}
