/* parallel.h — a fixed split of an index range over a few threads.
 *
 * The machine that bakes has 2 cores; the renderer (llvmpipe) uses both, and
 * this is how the CPU stages do (docs/design.md, "Threads in a bake").
 *
 * Contract, which is what keeps every output byte-identical whatever the
 * thread count, the scheduling, or whether a thread could start at all:
 *  - [0, n) is cut into c = min(threads, n, SV_PARALLEL_MAX) contiguous
 *    chunks, chunk t = [n·t/c, n·(t+1)/c); fn(ctx, t, lo, hi) is called once
 *    per chunk. Chunk 0 runs on the calling thread, every other chunk on a
 *    thread of its own (created per call, joined before the call returns).
 *  - fn writes only what its chunk owns: per-index slots in [lo, hi), or
 *    per-chunk slots (scratch, partial counts) indexed by t. Everything else
 *    it reads is left unchanged by every chunk while the call runs.
 *  - Any reduction is the caller's, after the call, in index or chunk order;
 *    and a per-chunk partial may only be combined when it does not depend on
 *    where the cuts fall (integer counts, per-index lists concatenated in
 *    chunk order). A floating-point sum is never split: the cut would change
 *    its rounding.
 *  - A chunk whose thread cannot be created (pthread_create fails: a sandbox,
 *    RLIMIT_NPROC or RLIMIT_AS) runs on the calling thread once the others
 *    are started: the same calls with the same arguments, so the same bytes.
 */
#ifndef SV_PARALLEL_H
#define SV_PARALLEL_H

#include <stdint.h>

#define SV_PARALLEL_MAX 16    /* chunks (threads) per call, at most */
#define SV_PARALLEL_DEFAULT 2 /* threads when the caller has no setting: the cores */

/* One chunk's work: chunk index t (0-based), indices [lo, hi). */
typedef void (*sv_range_fn)(void *ctx, uint32_t t, uint32_t lo, uint32_t hi);

/* Runs fn over [0, n) in chunks as stated above. threads 0 counts as 1; n 0
 * calls nothing. Returns the number of threads that ran chunks (1 when
 * serial, including when no thread could be created). */
uint32_t sv_parallel_for(uint32_t n, uint32_t threads, sv_range_fn fn, void *ctx);

/* The number of chunks sv_parallel_for(n, threads, ...) cuts [0, n) into, so
 * a caller can size per-chunk slots. */
uint32_t sv_parallel_chunks(uint32_t n, uint32_t threads);

#endif
