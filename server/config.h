/* config.h — sylvad configuration: defaults, config file, command-line flags.
 *
 * Every setting has one name used in both places: the config file line
 * `max_upload_bytes = 512M` and the flag `--max-upload-bytes 512M` (or
 * `--max-upload-bytes=512M`). Flags override the file. File syntax: one
 * `key = value` per line, `#` starts a comment, blank lines ignored, unknown
 * keys are errors. Sizes accept K, M, G suffixes (powers of 1024). The table
 * of settings with defaults is in docs/operations.md.
 */
#ifndef SVD_CONFIG_H
#define SVD_CONFIG_H

#include <stdbool.h>
#include <stdint.h>

#include "log.h"
#include "sv.h"

#define SVD_PATH_MAX 1024

typedef struct svd_config {
    char listen_host[256];        /* listen = HOST:PORT, default 127.0.0.1:8080 */
    uint32_t port;                /* 0 = ephemeral */
    char port_file[SVD_PATH_MAX]; /* written with the real port, "" = none */
    char store[SVD_PATH_MAX];     /* default ./sylva-store */
    char worker[SVD_PATH_MAX];    /* "" = dirname(/proc/self/exe)/sylva-bake */
    char prlimit
        [SVD_PATH_MAX]; /* rlimit wrapper, default /usr/bin/prlimit; "" = prlimit(2) after spawn */
    char viewer_dir[SVD_PATH_MAX]; /* the viewer page's files; "" = dirname(sylvad)/viewer if it
                                     exists (build tree), else dirname(sylvad)/../share/sylva/viewer */
    char tokens[SVD_PATH_MAX];     /* bearer tokens file, "" = no auth (loopback only) */
    char log_file[SVD_PATH_MAX];   /* "" = stderr */
    svd_log_level log_level;       /* default info */
    uint32_t workers;              /* 0 = number of cores */
    uint32_t http_threads;         /* thread pool size, default 4 */
    uint32_t connection_limit;     /* default 1024 */
    uint32_t max_conns_per_ip;     /* concurrent connections from one address, default 64;
                                     0 = no limit (behind a proxy) */
    bool reuse_port;               /* SO_REUSEPORT on the listening socket, default off: a
                                     second daemon on the same port fails to start */
    uint64_t connection_memory;    /* per connection, default 64K */
    uint32_t connection_timeout;   /* idle seconds, default 30 */
    uint64_t max_upload_bytes;     /* whole request body, default 1G */
    uint64_t client_upload_bytes;  /* bytes one client's uploads in progress may hold against
                                     store_max_bytes together, default 2G -> 507 */
    uint32_t upload_timeout;       /* seconds one upload request may last, default 1800 */
    uint64_t disk_reserve_bytes;   /* bytes kept free on the store's filesystem beside the
                                     outputs of bakes not finished, default 256M */
    uint64_t max_mesh_bytes;       /* one file part, default 512M */
    uint32_t max_files;            /* companion files per upload, default 256 */
    uint32_t queue_max;            /* queued jobs (all clients), default 1024 -> 503 */
    uint32_t queue_per_client;     /* queued+running jobs per client, default 64 -> 429 */
    uint32_t job_timeout;          /* wall-clock seconds per attempt, default 900 */
    uint32_t attempts;             /* tries before failing a crashing job, default 3 */
    uint32_t max_wait;             /* cap on ?wait=S, default 60 */
    uint32_t drain_timeout;        /* SIGTERM: seconds to let running jobs finish, default 30 */
    uint64_t store_max_bytes;      /* default 20G; LRU eviction beyond */
    uint64_t worker_as_bytes;      /* RLIMIT_AS, default 8G */
    uint32_t worker_cpu_seconds;   /* RLIMIT_CPU, default 1800 */
    uint32_t worker_nofile;        /* RLIMIT_NOFILE, default 256 */
    uint64_t worker_fsize_bytes;   /* RLIMIT_FSIZE, default 4G */
    bool worker_sandbox;           /* pass --sandbox (seccomp filter) to workers, default on */
    uint32_t worker_nice;          /* nice value of workers (0..19), default 10 */
    bool worker_pool;              /* fork workers from a resident `sylva-bake zygote` per
                                     worker thread instead of exec'ing each, default on
                                     (workers.h) */
    bool worker_shader_cache;      /* warm a read-only shader cache at start and give
                                     it to sandboxed jobs, default on (workers.h) */
} svd_config;

/* Fills cfg with the defaults above. */
void svd_config_defaults(svd_config *cfg);

/* Sets one setting by name (file spelling, '-' accepted for '_') from text.
 * SV_ERR_SPEC naming the key on an unknown key or a bad value. */
sv_status svd_config_set(svd_config *cfg, const char *key, const char *value, sv_error *err);

/* Applies a config file's lines. SV_ERR_IO if unreadable, SV_ERR_SPEC with
 * "FILE:LINE: ..." on a bad line. */
sv_status svd_config_load_file(svd_config *cfg, const char *path, sv_error *err);

/* Defaults, then --config FILE (if present), then every other flag.
 * Returns SV_ERR_SPEC on an unknown flag or bad value. --help is reported as
 * SV_ERR_CANCELLED so main can print usage and exit 0. */
sv_status svd_config_from_args(svd_config *cfg, int argc, char **argv, sv_error *err);

/* True if listen_host is a loopback address (127.0.0.0/8, ::1, localhost). */
bool svd_config_is_loopback(const svd_config *cfg);

/* Parses a boolean: on/off, true/false, yes/no, 1/0. False on anything else. */
bool svd_parse_bool(const char *s, bool *out);

/* Parses a size with optional K/M/G suffix. False on junk or overflow. */
bool svd_parse_size(const char *s, uint64_t *out);

/* Writes "PORT\n" to path through a temporary file and a rename, so a reader
 * polling for the file (tests, --listen ...:0) never sees it half written.
 * 0 on success, -1 with errno set. */
int svd_config_write_port_file(const char *path, unsigned port);

/* Usage text for --help. */
const char *svd_config_usage(void);

#endif
