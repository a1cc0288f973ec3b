/* The calling thread's progress callback (envlight.h, envl_set_progress): reported between
 * the steps of long calls, and their cancel. */
#include "internal.h"

static _Thread_local envl_progress_fn progress_fn;
static _Thread_local void *progress_user;

void envl_set_progress(envl_progress_fn fn, void *user)
{
    progress_fn = fn;
    progress_user = user;
}

envl_result envl__progress(double fraction, const char *stage)
{
    if (!progress_fn)
        return ENVL_OK;
    double f = fraction < 0 ? 0 : fraction > 1 ? 1 : fraction;
    if (progress_fn(progress_user, f, stage))
        return envl__fail(ENVL_ERR_CANCELLED, "cancelled during %s (the progress callback)",
                          stage);
    return ENVL_OK;
}
