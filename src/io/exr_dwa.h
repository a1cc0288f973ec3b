/* DWAA / DWAB decoding through the OpenEXR C++ library (exr_dwa.cpp). OpenEXRCore 3.1, which
 * exr.c reads with, has no DWA decoder; Debian 12's libOpenEXR-3_1 (the C++ library of the same
 * package) has. exr.c checks the header, picks the part and channels and places the pixels;
 * this file only decodes rows of a DWA part into float buffers. C interface, no exception
 * crosses it. */
#ifndef ENVL_EXR_DWA_H
#define ENVL_EXR_DWA_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

enum { ENVL_DWA_OK = 0, ENVL_DWA_FORMAT = 1, ENVL_DWA_MEMORY = 2 };

typedef struct envl_exr_dwa envl_exr_dwa;

/* Opens part `part` of the OpenEXR file `name` in data[0 .. size) (kept, not copied, until
 * close). Returns ENVL_DWA_* and on failure the library's message in msg. */
int envl__exr_dwa_open(const uint8_t *data, size_t size, const char *name, int part,
                       envl_exr_dwa **out, char *msg, size_t msg_cap);

/* Decodes rows y0 .. y1 (file coordinates, inside the data window) of `n` channels (n <= 3):
 * channel names[k], sampled every xs[k] x ys[k] pixels, goes to dst[k] as floats, one row per
 * sampled line in y0 .. y1 (y % ys == 0) of the samples across the data window (x % xs == 0),
 * rows packed. Returns ENVL_DWA_* and on failure the library's message in msg. */
int envl__exr_dwa_read(envl_exr_dwa *d, int n, const char *const *names, float *const *dst,
                       const int32_t *xs, const int32_t *ys, int32_t y0, int32_t y1, char *msg,
                       size_t msg_cap);

/* NULL-safe. */
void envl__exr_dwa_close(envl_exr_dwa *d);

#ifdef __cplusplus
}
#endif

#endif
