/* workers.h — the pool that runs bakes in `sylva-bake` processes.
 *
 * N supervisor threads; each takes a job from the table (jobs.h), verifies
 * its inputs against their SHA-256, and runs
 *   [prlimit --as=.. --cpu=.. --nofile=.. --fsize=.. --core=0 --]
 *   sylva-bake bake IN/MESH IN/FILES... --spec SPEC --out TMP --progress-fd 3 [--sandbox]
 * with posix_spawn (never fork() from the threaded daemon), in its own process
 * group, stdin /dev/null, stdout+stderr to a log file, signal mask and
 * dispositions reset. Limits are applied by util-linux prlimit(1), which sets
 * them on itself and then execs the worker (same pid, no window without
 * limits); with `prlimit = ""` they are set by prlimit(2) right after spawn.
 * Progress lines ({"stage":..,"progress":..}) come over a pipe. A wall-clock
 * timeout, DELETE or a drain kills the process group (SIGKILL); it is reaped
 * with waitpid. Exit 0: the outputs are hashed, a manifest written, fsynced
 * and renamed into the store. Exit 1: failed with DIR/error.json's reason.
 * A signal, an unexpected exit or a timeout: retried (jobs.h decides when
 * to give up).
 *
 * The pool (worker_pool, default on; docs/design.md "The worker pool"):
 * instead of spawning the command line above, each thread hands it to its
 * own `sylva-bake zygote` (spawned at the thread's first job, again after it
 * died), which forks a child that sets the same process group, fds, signal
 * state, limits (setrlimit: no prlimit wrapper) and nice, and runs the bake;
 * the zygote reports the pid, then the wait status and rusage, and carries
 * out kills, so the rest is the same. A zygote that dies mid-bake makes the
 * job a crash (retried). When the first zygote fails its hello (a worker
 * that is not sylva-bake) the daemon logs worker_pool_unavailable and
 * spawns one worker per job.
 *
 * The shader cache (worker_shader_cache, default on, with worker_sandbox):
 * at start a thread runs `sylva-bake warm-shaders STORE/shaders` on
 * the worker's own built-in scene (no upload), which fills a Mesa shader
 * cache and prints its DB; the DB's files are made read-only (0444) and
 * every later sandboxed job gets `--shader-cache DB --shader-cache-dir D`,
 * D a fresh directory under tmp/ removed after the job, so llvmpipe loads
 * its JIT code instead of compiling it and nothing a job writes reaches
 * another. Jobs that start before the warm-up is done, or after it failed
 * (logged as shader_cache_unavailable), bake with the cache off as before.
 */
#ifndef SVD_WORKERS_H
#define SVD_WORKERS_H

#include "jobs.h"

typedef struct svd_workers svd_workers;

/* Starts count supervisor threads running jobs from the table. worker_path
 * is the sylva-bake executable. NULL with err set on failure. */
svd_workers *svd_workers_start(svd_jobs *jobs, const char *worker_path, unsigned count,
                               sv_error *err);

/* Joins the threads (call after svd_jobs_stop, and svd_jobs_abort if they
 * must not wait for running bakes). NULL is a no-op. */
void svd_workers_join(svd_workers *w);

#endif
