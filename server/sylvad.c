/* sylvad — the sylva baking daemon (docs/api.md, docs/operations.md).
 *
 * main: configuration, store + journal recovery, the worker pool, the HTTP
 * front end, then a signal loop (signals are blocked in every thread and
 * taken synchronously here with sigtimedwait: no handler, no global flag).
 * SIGTERM/SIGINT drain, SIGHUP reopens the log file.
 */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "auth.h"
#include "config.h"
#include "http.h"
#include "jobs.h"
#include "log.h"
#include "metrics.h"
#include "store.h"
#include "workers.h"

#ifndef SYLVA_DOC_DIR
#define SYLVA_DOC_DIR "/usr/local/share/doc/sylva"
#endif

/* The directory of this executable into out (false when /proc cannot say). */
static bool exe_dir(char *out, size_t cap)
{
    char exe[SVD_PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0) return false;
    exe[n] = '\0';
    char *slash = strrchr(exe, '/');
    if (slash) *slash = '\0';
    snprintf(out, cap, "%.1000s", exe);
    return true;
}

static void default_worker(char *out, size_t cap)
{
    char dir[1024];
    if (!exe_dir(dir, sizeof dir)) snprintf(out, cap, "sylva-bake");
    else snprintf(out, cap, "%.1000s/sylva-bake", dir);
}

/* viewer_dir's default: dirname(exe)/viewer when that directory exists (the
 * build tree: build/sylvad beside build/viewer), else
 * dirname(exe)/../share/sylva/viewer (`make install`'s layout). */
static void default_viewer_dir(char *out, size_t cap)
{
    char dir[1024];
    if (!exe_dir(dir, sizeof dir)) {
        snprintf(out, cap, "viewer");
        return;
    }
    struct stat sb;
    snprintf(out, cap, "%.1000s/viewer", dir);
    if (stat(out, &sb) == 0 && S_ISDIR(sb.st_mode)) return;
    snprintf(out, cap, "%.1000s/../share/sylva/viewer", dir);
}

/* The first command-line option that names no setting (--bogus, -x), or
 * NULL: checked before the values are read, so that an unknown option is
 * called unknown rather than short of a value. */
static const char *unknown_option(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) return NULL;
        if (a[0] != '-') continue; /* a value, or an argument config.c refuses */
        if (a[1] != '-' || !a[2]) return a;
        char key[64];
        const char *eq = strchr(a, '=');
        size_t kl = eq ? (size_t)(eq - a - 2) : strlen(a + 2);
        if (kl >= sizeof key) return a;
        memcpy(key, a + 2, kl);
        key[kl] = '\0';
        if (!eq) i++; /* its value */
        if (strcmp(key, "config") == 0) continue;
        svd_config scratch;
        svd_config_defaults(&scratch);
        sv_error e = {0};
        if (svd_config_set(&scratch, key, "", &e) != SV_OK &&
            strncmp(e.message, "unknown setting", 15) == 0)
            return a;
    }
    return NULL;
}

/* Whether argv names a store (--store DIR, --store=DIR). */
static bool store_given(int argc, char **argv)
{
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--store") == 0 || strncmp(argv[i], "--store=", 8) == 0) return true;
    return false;
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--version") == 0) {
        printf("sylvad %s\n", SV_VERSION);
        return 0;
    }
    const char *unknown = unknown_option(argc, argv);
    if (unknown) {
        fprintf(stderr, "sylvad: unknown option %.80s\ntry 'sylvad --help'\n", unknown);
        return 2;
    }
    svd_config cfg;
    sv_error err = {0};
    sv_status st = svd_config_from_args(&cfg, argc, argv, &err);
    if (st == SV_ERR_CANCELLED) {
        fputs(svd_config_usage(), stdout);
        printf("Installed guides: %s/ (operations.md, api.md, deploy.md)\n", SYLVA_DOC_DIR);
        return 0;
    }
    if (st != SV_OK) {
        fprintf(stderr, "sylvad: %s\ntry 'sylvad --help'\n", err.message);
        return 2;
    }
    /* No store named, by flag or config file: refuse rather than fill the
     * current directory (config.c's default is a relative path). */
    svd_config defaults;
    svd_config_defaults(&defaults);
    if (!store_given(argc, argv) && strcmp(cfg.store, defaults.store) == 0) {
        fprintf(stderr,
                "sylvad: no store: pass --store DIR (an absolute path, e.g. /var/lib/sylva) "
                "or set store = DIR in the --config file\ntry 'sylvad --help'\n");
        return 2;
    }
    svd_log *log = svd_log_open(cfg.log_file, cfg.log_level);
    if (!log) {
        fprintf(stderr, "sylvad: cannot open log file %s\n", cfg.log_file);
        return 1;
    }
    int rc = 1;
    svd_store *store = NULL;
    svd_metrics *metrics = NULL;
    svd_jobs *jobs = NULL;
    svd_tokens *tokens = NULL;
    svd_workers *workers = NULL;
    svd_http *http = NULL;

    if (!svd_config_is_loopback(&cfg) && !cfg.tokens[0]) {
        svd_log_kv(log, SVD_LOG_ERROR, "config_error", "msg",
                   "listening beyond loopback requires --tokens FILE (bearer auth)",
                   (const char *)NULL);
        rc = 2;
        goto out;
    }
    if (!cfg.worker[0]) default_worker(cfg.worker, sizeof cfg.worker);
    if (!cfg.viewer_dir[0]) default_viewer_dir(cfg.viewer_dir, sizeof cfg.viewer_dir);
    if (cfg.workers == 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        cfg.workers = n > 0 ? (uint32_t)n : 1;
    }
    if (cfg.prlimit[0] && access(cfg.prlimit, X_OK) != 0) {
        svd_log_kv(log, SVD_LOG_WARN, "prlimit_missing", "path", cfg.prlimit, "msg",
                   "rlimits will be set with prlimit(2) right after spawn", (const char *)NULL);
        cfg.prlimit[0] = '\0';
    }
    if (access(cfg.worker, X_OK) != 0)
        svd_log_kv(log, SVD_LOG_WARN, "worker_missing", "path", cfg.worker, "msg",
                   "the worker is not executable; bakes will fail until it is", (const char *)NULL);
    char viewer_index[SVD_PATH_MAX + 16];
    snprintf(viewer_index, sizeof viewer_index, "%s/index.html", cfg.viewer_dir);
    if (access(viewer_index, R_OK) != 0)
        svd_log_kv(log, SVD_LOG_WARN, "viewer_missing", "path", cfg.viewer_dir, "msg",
                   "no viewer page there: GET /v1/bakes/{key}/view answers 404",
                   (const char *)NULL);

    /* Block the signals we take synchronously before any thread starts. */
    sigset_t sigs;
    sigemptyset(&sigs);
    sigaddset(&sigs, SIGTERM);
    sigaddset(&sigs, SIGINT);
    sigaddset(&sigs, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &sigs, NULL);
    signal(SIGPIPE, SIG_IGN);

    if (cfg.tokens[0] && !(tokens = svd_tokens_load(cfg.tokens, &err))) goto fail;
    if (!(store = svd_store_open(cfg.store, &err))) goto fail;
    if (svd_store_stray_workers(store) > 0) {
        char n[16];
        snprintf(n, sizeof n, "%d", svd_store_stray_workers(store));
        svd_log_kv(log, SVD_LOG_WARN, "stray_workers_killed", "count", n, "msg",
                   "workers of a previous daemon were still baking into tmp/", (const char *)NULL);
    }
    if (!(metrics = svd_metrics_create())) {
        sv_fail(&err, SV_ERR_NOMEM, "out of memory");
        goto fail;
    }
    if (!(jobs = svd_jobs_create(&cfg, store, log, metrics, &err))) goto fail;
    if (svd_jobs_recover(jobs, &err) != SV_OK) goto fail;
    if (!(workers = svd_workers_start(jobs, cfg.worker, cfg.workers, &err))) goto fail;
    if (!(http = svd_http_start(&cfg, jobs, metrics, log, tokens, &err))) goto fail;

    char port[16], nworkers[16];
    snprintf(port, sizeof port, "%u", svd_http_port(http));
    snprintf(nworkers, sizeof nworkers, "%u", cfg.workers);
    if (cfg.port_file[0] && svd_config_write_port_file(cfg.port_file, svd_http_port(http)) != 0)
        svd_log_kv(log, SVD_LOG_ERROR, "port_file_failed", "path", cfg.port_file,
                   (const char *)NULL);
    svd_log_kv(log, SVD_LOG_INFO, "listening", "host", cfg.listen_host, "port", port, "store",
               cfg.store, "workers", nworkers, "worker", cfg.worker, "version", SV_VERSION,
               (const char *)NULL);

    double drain_deadline = 0;
    for (;;) {
        struct timespec tick = {0, 100 * 1000 * 1000};
        int sig = sigtimedwait(&sigs, NULL, &tick);
        svd_jobs_sweep(jobs, sv_now(), false);
        if (sig == SIGHUP) {
            if (!svd_log_reopen(log)) fprintf(stderr, "sylvad: cannot reopen log file\n");
            svd_log_kv(log, SVD_LOG_INFO, "log_reopened", (const char *)NULL);
        } else if ((sig == SIGTERM || sig == SIGINT) && drain_deadline == 0) {
            svd_log_kv(log, SVD_LOG_INFO, "draining", "signal", sig == SIGTERM ? "TERM" : "INT",
                       (const char *)NULL);
            svd_http_set_draining(http);
            svd_jobs_stop(jobs);
            drain_deadline = sv_now() + cfg.drain_timeout;
        } else if ((sig == SIGTERM || sig == SIGINT) && drain_deadline > 0) {
            drain_deadline = sv_now(); /* a second signal: stop now */
        }
        if (drain_deadline > 0) {
            if (svd_jobs_running(jobs) == 0) break;
            if (sv_now() >= drain_deadline) {
                svd_log_kv(log, SVD_LOG_WARN, "drain_timeout", "msg",
                           "stopping running bakes; they stay accepted and run after restart",
                           (const char *)NULL);
                svd_jobs_abort(jobs);
                break;
            }
        }
    }
    svd_workers_join(workers);
    workers = NULL;
    svd_http_stop(http);
    http = NULL;
    svd_log_kv(log, SVD_LOG_INFO, "stopped", (const char *)NULL);
    rc = 0;
    goto out;
fail:
    svd_log_kv(log, SVD_LOG_ERROR, "startup_failed", "msg", err.message, (const char *)NULL);
    rc = 1;
    if (jobs) svd_jobs_stop(jobs);
out:
    svd_workers_join(workers);
    svd_http_stop(http);
    svd_jobs_destroy(jobs);
    svd_metrics_destroy(metrics);
    svd_store_close(store);
    svd_tokens_free(tokens);
    svd_log_close(log);
    return rc;
}
