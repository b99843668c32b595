/* journal.c — append-only, checksummed, fsynced journal (see journal.h).
 * The layout follows the write-ahead-log idea of SQLite and Redis' AOF: length
 * prefix + checksum per record; a torn tail is detected and truncated. */
#include "journal.h"

#include <errno.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define HDR 24

struct svd_journal {
    pthread_mutex_t mu;
    int fd;
    char *path;
    uint64_t size; /* bytes of intact records */
};

static void checksum(const void *p, size_t n, unsigned char out[16])
{
    unsigned char md[32];
    unsigned int mdlen = 0;
    EVP_Digest(p, n, md, &mdlen, EVP_sha256(), NULL);
    memcpy(out, md, 16);
}

static void put_header(unsigned char *h, const void *payload, size_t n)
{
    memcpy(h, "SVJ1", 4);
    h[4] = (unsigned char)(n & 0xff);
    h[5] = (unsigned char)((n >> 8) & 0xff);
    h[6] = (unsigned char)((n >> 16) & 0xff);
    h[7] = (unsigned char)((n >> 24) & 0xff);
    checksum(payload, n, h + 8);
}

sv_status svd_fsync_parent(const char *path, sv_error *err)
{
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (slash == path) snprintf(dir, sizeof dir, "/");
    else snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        return sv_fail(err, SV_ERR_IO, "%s: cannot open directory: %s", dir, strerror(errno));
    int r = fsync(fd);
    int e = errno;
    close(fd);
    if (r != 0) return sv_fail(err, SV_ERR_IO, "%s: fsync failed: %s", dir, strerror(e));
    return SV_OK;
}

static int write_all(int fd, const void *p, size_t n)
{
    const unsigned char *b = p;
    while (n) {
        ssize_t w = write(fd, b, n);
        if (w < 0) {
            if (errno == EINTR) continue;
            return -1;
        }
        b += w;
        n -= (size_t)w;
    }
    return 0;
}

static void quarantine(const char *path, const unsigned char *data, uint64_t off, size_t n)
{
    char q[4200];
    snprintf(q, sizeof q, "%s.corrupt-%llu", path, (unsigned long long)off);
    int fd = open(q, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) return;
    if (write_all(fd, data, n) == 0) fsync(fd);
    close(fd);
}

/* Reads the whole file into memory (journals are compacted at start, so they
 * stay small: one record per live job plus this run's appends). */
static unsigned char *slurp(int fd, uint64_t *size_out)
{
    struct stat st;
    if (fstat(fd, &st) != 0) return NULL;
    size_t n = (size_t)st.st_size;
    unsigned char *buf = malloc(n ? n : 1);
    if (!buf) return NULL;
    size_t got = 0;
    while (got < n) {
        ssize_t r = pread(fd, buf + got, n - got, (off_t)got);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        got += (size_t)r;
    }
    *size_out = got;
    return buf;
}

static const unsigned char *find_magic(const unsigned char *p, const unsigned char *end)
{
    while (p + 4 <= end) {
        const unsigned char *m = memchr(p, 'S', (size_t)(end - p));
        if (!m || m + 4 > end) return NULL;
        if (memcmp(m, "SVJ1", 4) == 0) return m;
        p = m + 1;
    }
    return NULL;
}

svd_journal *svd_journal_open(const char *path, svd_journal_replay_fn fn, void *user,
                              svd_journal_stats *stats, sv_error *err)
{
    svd_journal_stats local = {0};
    if (!stats) stats = &local;
    memset(stats, 0, sizeof *stats);
    int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) {
        sv_fail(err, SV_ERR_IO, "%s: cannot open journal: %s", path, strerror(errno));
        return NULL;
    }
    uint64_t n = 0;
    unsigned char *buf = slurp(fd, &n);
    if (!buf) {
        close(fd);
        sv_fail(err, SV_ERR_IO, "%s: cannot read journal", path);
        return NULL;
    }
    const unsigned char *p = buf, *end = buf + n;
    uint64_t good_end = 0;
    while (p < end) {
        if ((size_t)(end - p) < HDR) break; /* torn header */
        if (memcmp(p, "SVJ1", 4) != 0) {
            const unsigned char *next = find_magic(p + 1, end);
            size_t skip = (size_t)((next ? next : end) - p);
            if (!next) break; /* garbage to the end: treat as torn tail */
            quarantine(path, p, (uint64_t)(p - buf), skip);
            stats->corrupt++;
            p = next;
            continue;
        }
        uint32_t len = (uint32_t)p[4] | (uint32_t)p[5] << 8 | (uint32_t)p[6] << 16 |
                       (uint32_t)p[7] << 24;
        if (len > SVD_JOURNAL_MAX_RECORD) { /* a lying length: resync at the next magic */
            const unsigned char *next = find_magic(p + 4, end);
            if (!next) break;
            quarantine(path, p, (uint64_t)(p - buf), (size_t)(next - p));
            stats->corrupt++;
            p = next;
            continue;
        }
        if ((size_t)(end - p - HDR) < len) break; /* torn payload */
        unsigned char sum[16];
        checksum(p + HDR, len, sum);
        if (memcmp(sum, p + 8, 16) != 0) {
            quarantine(path, p, (uint64_t)(p - buf), HDR + len);
            stats->corrupt++;
            p += HDR + len;
            good_end = (uint64_t)(p - buf);
            continue;
        }
        if (fn) fn(user, (const char *)p + HDR, len);
        stats->records++;
        p += HDR + len;
        good_end = (uint64_t)(p - buf);
    }
    free(buf);
    if (good_end < n) {
        stats->torn_bytes = n - good_end;
        if (ftruncate(fd, (off_t)good_end) != 0 || fsync(fd) != 0) {
            sv_fail(err, SV_ERR_IO, "%s: cannot truncate torn tail: %s", path, strerror(errno));
            close(fd);
            return NULL;
        }
    }
    svd_journal *j = calloc(1, sizeof *j);
    if (!j || !(j->path = strdup(path))) {
        free(j);
        close(fd);
        sv_fail(err, SV_ERR_NOMEM, "journal: out of memory");
        return NULL;
    }
    pthread_mutex_init(&j->mu, NULL);
    j->fd = fd;
    j->size = good_end;
    return j;
}

sv_status svd_journal_append(svd_journal *j, const char *payload, size_t size, sv_error *err)
{
    if (size > SVD_JOURNAL_MAX_RECORD)
        return sv_fail(err, SV_ERR_LIMIT, "journal record of %zu bytes over the limit", size);
    unsigned char *rec = malloc(HDR + size);
    if (!rec) return sv_fail(err, SV_ERR_NOMEM, "journal: out of memory");
    put_header(rec, payload, size);
    memcpy(rec + HDR, payload, size);
    sv_status st = SV_OK;
    pthread_mutex_lock(&j->mu);
    /* pwrite at the known end: one write of the whole record. */
    size_t done = 0;
    while (done < HDR + size) {
        ssize_t w = pwrite(j->fd, rec + done, HDR + size - done, (off_t)(j->size + done));
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) {
            st = sv_fail(err, SV_ERR_IO, "%s: journal write failed: %s", j->path, strerror(errno));
            break;
        }
        done += (size_t)w;
    }
    if (st == SV_OK && fdatasync(j->fd) != 0)
        st = sv_fail(err, SV_ERR_IO, "%s: journal fsync failed: %s", j->path, strerror(errno));
    if (st == SV_OK) j->size += HDR + size;
    else if (ftruncate(j->fd, (off_t)j->size) !=
             0) { /* leave no torn record; replay cuts it anyway */
    }
    pthread_mutex_unlock(&j->mu);
    free(rec);
    return st;
}

sv_status svd_journal_rewrite(svd_journal *j, const char *const *payloads, const size_t *sizes,
                              size_t count, sv_error *err)
{
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp", j->path);
    /* O_RDWR: after the rename this descriptor is the journal's (no reopen
     * that could fail and leave appends going to the unlinked old file). */
    int fd = open(tmp, O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) return sv_fail(err, SV_ERR_IO, "%s: cannot create: %s", tmp, strerror(errno));
    uint64_t total = 0;
    sv_status st = SV_OK;
    for (size_t i = 0; i < count && st == SV_OK; i++) {
        if (sizes[i] > SVD_JOURNAL_MAX_RECORD) {
            st = sv_fail(err, SV_ERR_LIMIT, "journal record of %zu bytes over the limit", sizes[i]);
            break;
        }
        unsigned char h[HDR];
        put_header(h, payloads[i], sizes[i]);
        if (write_all(fd, h, HDR) != 0 || write_all(fd, payloads[i], sizes[i]) != 0)
            st = sv_fail(err, SV_ERR_IO, "%s: write failed: %s", tmp, strerror(errno));
        total += HDR + sizes[i];
    }
    if (st == SV_OK && fsync(fd) != 0)
        st = sv_fail(err, SV_ERR_IO, "%s: fsync failed: %s", tmp, strerror(errno));
    if (st != SV_OK) {
        close(fd);
        unlink(tmp);
        return st;
    }
    pthread_mutex_lock(&j->mu);
    if (rename(tmp, j->path) != 0) {
        st = sv_fail(err, SV_ERR_IO, "%s: rename failed: %s", j->path, strerror(errno));
        close(fd);
        unlink(tmp);
    } else {
        close(j->fd);
        j->fd = fd;
        j->size = total;
        st = svd_fsync_parent(j->path, err); /* the new journal is in use either way */
    }
    pthread_mutex_unlock(&j->mu);
    return st;
}

void svd_journal_close(svd_journal *j)
{
    if (!j) return;
    close(j->fd);
    pthread_mutex_destroy(&j->mu);
    free(j->path);
    free(j);
}
