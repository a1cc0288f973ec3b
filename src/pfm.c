/* PFM reader and writer (stub) */
#include "internal.h"
envl_result envl__read_pfm(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out)
{ return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: pfm todo", name); }
envl_result envl__write_pfm(const char *path, const float *rgb, int32_t w, int32_t h)
{ return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: pfm todo", path); }
