/* log.h — structured log lines for sylvad: one JSON object per line.
 *
 *   {"ts":"2024-01-01T12:00:00.123Z","level":"info","event":"listening","port":8080}
 *
 * A log is a handle (no global logger): every subsystem receives the sv_log*
 * it writes to. Thread-safe: lines are written whole under a mutex. The log
 * writes to stderr or to a file that sv_log_reopen reopens (SIGHUP, for
 * logrotate). Timestamps are wall-clock UTC: logs are not a bake output, so
 * they are allowed to differ between runs.
 */
#ifndef SVD_LOG_H
#define SVD_LOG_H

#include <stdbool.h>

typedef enum svd_log_level {
    SVD_LOG_DEBUG = 0,
    SVD_LOG_INFO,
    SVD_LOG_WARN,
    SVD_LOG_ERROR
} svd_log_level;

typedef struct svd_log svd_log;

/* Parses "debug", "info", "warn" or "error". Returns false for anything else. */
bool svd_log_level_parse(const char *s, svd_log_level *out);

/* Opens a log writing to path (appending), or to stderr when path is NULL or
 * empty. Returns NULL if the file cannot be opened or memory is short. */
svd_log *svd_log_open(const char *path, svd_log_level level);

/* Reopens the log file (after rotation). A stderr log is left as is.
 * Returns false (and keeps the old stream) if the file cannot be opened. */
bool svd_log_reopen(svd_log *log);

/* Closes the log. NULL is a no-op. */
void svd_log_close(svd_log *log);

/* Writes one line if level is at or above the log's level: "ts", "level",
 * "event", then the variadic pairs (const char *key, const char *value)
 * terminated by a NULL key. Values are JSON-escaped strings; a NULL value is
 * written as null. NULL log is a no-op. */
void svd_log_kv(svd_log *log, svd_log_level level, const char *event, ...);

/* Like svd_log_kv with a single free-text "msg" field formatted printf-style. */
void svd_logf(svd_log *log, svd_log_level level, const char *event, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

#endif
