/* OpenEXR reader and writer through the OpenEXR C API. (being written) */
#include "internal.h"
envl_result envl__read_exr(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out)
{ return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: .exr reader not written yet", name); }
envl_result envl__write_exr(const char *path, const float *rgb, int32_t w, int32_t h,
                            int32_t pixel_type)
{ return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: .exr writer not written yet", path); }
