/* log.c — structured JSON log lines (see log.h). */
#include "log.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <time.h>

struct svd_log {
    pthread_mutex_t mu;
    FILE *f;    /* stderr or an owned file */
    char *path; /* NULL for stderr */
    svd_log_level level;
};

static const char *const level_names[] = {"debug", "info", "warn", "error"};

bool svd_log_level_parse(const char *s, svd_log_level *out)
{
    for (int i = 0; i < 4; i++) {
        if (s && strcmp(s, level_names[i]) == 0) {
            *out = (svd_log_level)i;
            return true;
        }
    }
    return false;
}

svd_log *svd_log_open(const char *path, svd_log_level level)
{
    svd_log *log = calloc(1, sizeof *log);
    if (!log) return NULL;
    pthread_mutex_init(&log->mu, NULL);
    log->level = level;
    if (path && *path) {
        log->path = strdup(path);
        log->f = log->path ? fopen(path, "ae") : NULL;
        if (!log->f) {
            free(log->path);
            pthread_mutex_destroy(&log->mu);
            free(log);
            return NULL;
        }
    } else {
        log->f = stderr;
    }
    return log;
}

bool svd_log_reopen(svd_log *log)
{
    if (!log || !log->path) return true;
    FILE *nf = fopen(log->path, "ae");
    if (!nf) return false;
    pthread_mutex_lock(&log->mu);
    fclose(log->f);
    log->f = nf;
    pthread_mutex_unlock(&log->mu);
    return true;
}

void svd_log_close(svd_log *log)
{
    if (!log) return;
    if (log->path) fclose(log->f);
    free(log->path);
    pthread_mutex_destroy(&log->mu);
    free(log);
}

static void put_escaped(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        switch (*p) {
        case '"':
            fputs("\\\"", f);
            break;
        case '\\':
            fputs("\\\\", f);
            break;
        case '\n':
            fputs("\\n", f);
            break;
        case '\r':
            fputs("\\r", f);
            break;
        case '\t':
            fputs("\\t", f);
            break;
        default:
            if (*p < 0x20) fprintf(f, "\\u%04x", *p);
            else fputc(*p, f);
        }
    }
    fputc('"', f);
}

static void line_start(svd_log *log, svd_log_level level, const char *event)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    struct tm tm;
    gmtime_r(&ts.tv_sec, &tm);
    char buf[64];
    strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
    fprintf(log->f, "{\"ts\":\"%s.%03ldZ\",\"level\":\"%s\",\"event\":", buf, ts.tv_nsec / 1000000L,
            level_names[level]);
    put_escaped(log->f, event);
}

void svd_log_kv(svd_log *log, svd_log_level level, const char *event, ...)
{
    if (!log || level < log->level) return;
    pthread_mutex_lock(&log->mu);
    line_start(log, level, event);
    va_list ap;
    va_start(ap, event);
    for (;;) {
        const char *k = va_arg(ap, const char *);
        if (!k) break;
        const char *v = va_arg(ap, const char *);
        fputc(',', log->f);
        put_escaped(log->f, k);
        fputc(':', log->f);
        if (v) put_escaped(log->f, v);
        else fputs("null", log->f);
    }
    va_end(ap);
    fputs("}\n", log->f);
    fflush(log->f);
    pthread_mutex_unlock(&log->mu);
}

void svd_logf(svd_log *log, svd_log_level level, const char *event, const char *fmt, ...)
{
    if (!log || level < log->level) return;
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    svd_log_kv(log, level, event, "msg", msg, (const char *)NULL);
}
