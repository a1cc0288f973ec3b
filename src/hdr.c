/* Radiance .hdr/.pic reader and writer. (being written) */
#include "internal.h"
envl_result envl__read_hdr(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out)
{ return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: .hdr reader not written yet", name); }
envl_result envl__write_hdr(const char *path, const float *rgb, int32_t w, int32_t h)
{ return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: .hdr writer not written yet", path); }
