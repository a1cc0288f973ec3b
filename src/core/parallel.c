/* A deterministic parallel for: items [0, n) cut into `threads` contiguous blocks, block t on
 * thread t (block 0 on the caller). Each item is computed by one thread start to end, so
 * results do not depend on the thread count as long as items are independent. */
#include "internal.h"

#include <pthread.h>
#include <unistd.h>

typedef struct block {
    envl_range_fn fn;
    void *ctx;
    int64_t begin, end;
} block;

static void *run_block(void *arg)
{
    block *b = arg;
    if (b->begin < b->end)
        b->fn(b->ctx, b->begin, b->end);
    return NULL;
}

void envl__parallel_for(int64_t n, int32_t threads, envl_range_fn fn, void *ctx)
{
    enum { MAX = ENVL_MAX_THREADS };
    if (threads > MAX)
        threads = MAX;
    if (threads > n)
        threads = (int32_t)(n > 0 ? n : 1);
    if (threads < 1)
        threads = 1;
    block blocks[MAX];
    pthread_t tid[MAX];
    int started[MAX] = {0};
    for (int32_t t = 0; t < threads; t++)
        blocks[t] = (block){fn, ctx, n * t / threads, n * (t + 1) / threads};
    for (int32_t t = 1; t < threads; t++)
        started[t] = pthread_create(&tid[t], NULL, run_block, &blocks[t]) == 0;
    run_block(&blocks[0]);
    for (int32_t t = 1; t < threads; t++) {
        if (started[t])
            pthread_join(tid[t], NULL);
        else
            run_block(&blocks[t]); /* no thread to be had: do it here */
    }
}

/* The one place a thread count is resolved: `requested` if > 0, else the online cores, both
 * capped at ENVL_MAX_THREADS. */
int32_t envl__threads(int32_t requested)
{
    if (requested > 0)
        return requested > ENVL_MAX_THREADS ? ENVL_MAX_THREADS : requested;
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : n > ENVL_MAX_THREADS ? ENVL_MAX_THREADS : (int32_t)n;
}
