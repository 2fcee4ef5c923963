// A parallel for-loop over pthreads.
#include "core/parallel.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

unsigned pn_parallel_threads(void)
{
    const char *env = getenv("PN_THREADS");
    long n = env && *env ? strtol(env, NULL, 10) : sysconf(_SC_NPROCESSORS_ONLN);
    if (n < 1)
        n = 1;
    if (n > 256)
        n = 256;
    return (unsigned)n;
}

typedef struct job {
    atomic_uint_fast64_t next;
    uint64_t count, chunk;
    pn_parallel_fn fn;
    void *ctx;
} job;

typedef struct worker {
    job *job;
    unsigned index;
} worker;

static void *run(void *arg)
{
    worker *w = arg;
    job *j = w->job;
    for (;;) {
        uint64_t begin = atomic_fetch_add(&j->next, j->chunk);
        if (begin >= j->count)
            break;
        uint64_t end = begin + j->chunk < j->count ? begin + j->chunk : j->count;
        j->fn(j->ctx, begin, end, w->index);
    }
    return NULL;
}

void pn_parallel_for(uint64_t count, uint64_t chunk, pn_parallel_fn fn, void *ctx)
{
    if (count == 0)
        return;
    if (chunk == 0)
        chunk = 1;
    unsigned n = pn_parallel_threads();
    if ((count + chunk - 1) / chunk < n)
        n = (unsigned)((count + chunk - 1) / chunk);
    job j = {.count = count, .chunk = chunk, .fn = fn, .ctx = ctx};
    atomic_init(&j.next, 0);
    worker w[256];
    pthread_t t[256];
    unsigned started = 0;
    for (unsigned i = 1; i < n; i++) {
        w[i] = (worker){&j, i};
        if (pthread_create(&t[i], NULL, run, &w[i]) != 0)
            break; // fewer threads: the others still finish every item
        started = i;
    }
    w[0] = (worker){&j, 0};
    run(&w[0]);
    for (unsigned i = 1; i <= started; i++)
        pthread_join(t[i], NULL);
}
