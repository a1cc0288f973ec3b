/* KTX 2.0 containers of linear float RGBA texels (ktx2.c): cube maps with a mip chain, or 2D
 * images. Internal to the library; prefilter_files.c writes them for `--format ktx2`. */
#ifndef ENVL_KTX2_H
#define ENVL_KTX2_H

#include "internal.h"

/* The two pixel formats written (Vulkan's VkFormat numbers, as KTX 2.0 stores them). */
#define ENVL__VK_FORMAT_R16G16B16A16_SFLOAT 97
#define ENVL__VK_FORMAT_R32G32B32A32_SFLOAT 109

/* IEEE 754 binary16 from binary32, rounded to nearest, ties to even. Finite values above the
 * largest half (65504) in magnitude and infinities become +-65504 (0x7BFF / 0xFBFF); NaN
 * becomes +0. Never returns an infinity or a NaN. */
uint16_t envl__half_from_float(float f);
/* binary16 to binary32 (exact). */
float envl__float_from_half(uint16_t h);
/* A copy of n floats each rounded to binary16 and back, as a half-float file holds them
 * (envl__half_from_float: clamped at +-65504); NULL when out of memory. */
float *envl__half_rounded(const float *v, size_t n);

/* What to write. Level k (0 = the largest) has faces of max(1, size >> k) texels square;
 * rgb[k] holds its `faces` images one after another, each rows of 3 floats from the top row
 * (KTX's default orientation, "rd"); alpha is written as 1. */
typedef struct envl__ktx2_desc {
    int32_t vk_format;  /* ENVL__VK_FORMAT_R16G16B16A16_SFLOAT or ..._R32G32B32A32_SFLOAT */
    int32_t size;       /* level 0's width = height */
    int32_t faces;      /* 6: a cube map (+X -X +Y -Y +Z -Z), 1: a 2D image */
    int32_t levels;     /* >= 1, at most floor(log2(size)) + 1 */
    const float *const *rgb;
    const char *writer; /* the KTXwriter value */
} envl__ktx2_desc;

/* What the conversion had to change (every value written is finite). */
typedef struct envl__ktx2_report {
    int64_t clamped;    /* values above 65504 in magnitude (half) or infinite: written +-max */
    int64_t nan;        /* NaN values: written 0 */
} envl__ktx2_report;

/* Writes the container straight to `path` (callers rename it into place). Every write step goes
 * through envl__io_fault(). ENVL_ERR_ARGUMENT for a bad desc, ENVL_ERR_IO naming `path`. */
envl_result envl__write_ktx2(const char *path, const envl__ktx2_desc *d, envl__ktx2_report *rep);

#endif
