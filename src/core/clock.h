/* The one clock every timing in envlight reads (the library and the command line): seconds on
 * CLOCK_MONOTONIC, for differences only. Header-only so the command line, which sees only the
 * public API, shares it. */
#ifndef ENVL_CLOCK_H
#define ENVL_CLOCK_H

#include <time.h>

static inline double envl__seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

#endif
