/* Decoded images: allocation under limits. */
#include "internal.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

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
    envl__huge_pages(px, (size_t)n * 3 * sizeof(float));
    free(img->px);
    img->px = px;
    img->width = w;
    img->height = h;
    return ENVL_OK;
}

/* Large buffers are written whole soon after they are allocated: asking the kernel for 2 MiB
 * pages (Linux's transparent huge pages, when set to "madvise") takes one page fault where
 * 4 KiB pages take 512; at 8K a map's first write spent 40 % of its CPU in page faults. Only
 * the 2 MiB-aligned span inside the buffer can use them; a hint, its failure harmless. */
void envl__huge_pages(void *p, size_t bytes)
{
#ifdef MADV_HUGEPAGE
    const uintptr_t huge = (uintptr_t)2 << 20;
    uintptr_t lo = ((uintptr_t)p + huge - 1) & ~(huge - 1);
    uintptr_t hi = ((uintptr_t)p + bytes) & ~(huge - 1);
    if (bytes >= 2 * huge && hi > lo)
        (void)madvise((void *)lo, hi - lo, MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

void envl__image_free(envl_image *img)
{
    if (!img)
        return;
    free(img->px);
    img->px = NULL;
    img->width = img->height = 0;
}
