// A parallel for-loop over pthreads: the only threading primitive penumbra needs. Work is handed
// out in chunks from an atomic counter, so uneven items balance themselves.
#pragma once
#include <stdint.h>

// fn(ctx, begin, end, thread) processes items [begin, end); `thread` is in [0, thread count).
typedef void (*pn_parallel_fn)(void *ctx, uint64_t begin, uint64_t end, unsigned thread);

// Number of worker threads used: PN_THREADS if set, else the online CPU count (at least 1).
unsigned pn_parallel_threads(void);

// Runs fn over [0, count) in chunks of `chunk` items on pn_parallel_threads() threads (the caller
// is one of them). Returns when every item is done.
void pn_parallel_for(uint64_t count, uint64_t chunk, pn_parallel_fn fn, void *ctx);
