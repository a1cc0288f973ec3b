/* The calling thread's progress callback (envlight.h, envl_set_progress): reported between
 * the steps of long calls, and their cancel; inside a step's long loops, polled. */
#include "internal.h"
#include "clock.h"

#include <stdio.h>

static _Thread_local envl_progress_fn progress_fn;
static _Thread_local void *progress_user;
/* the last step reported, repeated by the polls inside it, and when the callback last ran */
static _Thread_local double last_fraction, last_call;
static _Thread_local char last_stage[96];

void envl_set_progress(envl_progress_fn fn, void *user)
{
    progress_fn = fn;
    progress_user = user;
}

static envl_result call(double fraction, const char *stage)
{
    last_call = envl__seconds();
    if (progress_fn(progress_user, fraction, stage))
        return envl__fail(ENVL_ERR_CANCELLED, "cancelled during %s (the progress callback)",
                          stage);
    return ENVL_OK;
}

envl_result envl__progress(double fraction, const char *stage)
{
    if (!progress_fn)
        return ENVL_OK;
    double f = fraction < 0 ? 0 : fraction > 1 ? 1 : fraction;
    envl_result rc = call(f, stage);
    /* the step the polls repeat; none once a call is done (1) */
    last_fraction = f < 1 ? f : 0;
    snprintf(last_stage, sizeof last_stage, "%s", f < 1 ? stage : "");
    return rc;
}

/* A poll calls the callback again with the last step at most every POLL_SECONDS: a cancel
 * (Ctrl-C) is seen within that of the loop's items, at a clock read per item. */
#define POLL_SECONDS 0.1

envl_result envl__progress_poll(void)
{
    if (!progress_fn || envl__seconds() - last_call < POLL_SECONDS)
        return ENVL_OK;
    return call(last_fraction, last_stage[0] ? last_stage : "the computation");
}

int envl__cancel_check(envl_cancel *c)
{
    if (atomic_load_explicit(&c->stop, memory_order_relaxed))
        return 1;
    if (envl__progress_poll() == ENVL_OK)
        return 0;
    atomic_store_explicit(&c->stop, 1, memory_order_relaxed);
    return 1;
}
