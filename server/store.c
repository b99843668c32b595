/* store.c — content-addressed store: temp + fsync + rename, verify on read,
 * quarantine (see store.h). */
#include "store.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdbool.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "journal.h"

#define VCACHE 1024

typedef struct vcache_entry {
    char path[SVD_STORE_PATH];
    dev_t dev;
    ino_t ino;
    off_t size;
    struct timespec mtime;
    char sha[SVD_KEY_HEX];
} vcache_entry;

struct svd_store {
    char root[1024];
    pthread_mutex_t mu;
    uint64_t counter;
    vcache_entry *cache; /* direct-mapped cache of verified files */
    int lock_fd;         /* <root>/lock, flock()ed for the store's lifetime */
    int stray_workers;   /* killed at open: workers of a dead daemon (sweep_stray_workers) */
};

/* One daemon per store: two sylvad on one --store would both recover its
 * jobs and the second wipe the first one's tmp/. Takes an exclusive,
 * non-blocking flock on <root>/lock (close-on-exec: workers do not hold it)
 * and writes our pid there; a held lock fails naming the holder's pid. */
static int lock_store(const char *root, sv_error *err)
{
    char p[SVD_STORE_PATH];
    snprintf(p, sizeof p, "%s/lock", root);
    /* O_NOFOLLOW: a symlink put in its place must not make us truncate and
     * write whatever it names */
    int fd = open(p, O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0) {
        sv_fail(err, SV_ERR_IO, "cannot open %s: %s", p, strerror(errno));
        return -1;
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        int e = errno;
        char buf[32] = {0};
        ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
        long pid = n > 0 ? strtol(buf, NULL, 10) : 0;
        close(fd);
        if (e == EWOULDBLOCK)
            sv_fail(err, SV_ERR_IO, "store %s is in use by another sylvad (pid %ld; %s)", root, pid,
                    p);
        else sv_fail(err, SV_ERR_IO, "cannot lock %s: %s", p, strerror(e));
        return -1;
    }
    char buf[32];
    int n = snprintf(buf, sizeof buf, "%ld\n", (long)getpid());
    if (ftruncate(fd, 0) != 0 || pwrite(fd, buf, (size_t)n, 0) != n) {
        /* the lock holds without the pid: only the message loses it */
    }
    return fd;
}

/* Removes everything in dir but dir itself: removing and re-creating it
 * could fail on a full disk (a daemon without root may not take back the
 * block it just freed when only the root reserve is left). */
static void empty_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        char sub[4096];
        if (snprintf(sub, sizeof sub, "%s/%s", dir, e->d_name) >= (int)sizeof sub) continue;
        svd_rm_rf(sub);
    }
    closedir(d);
}

void svd_rm_rf(const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0) return;
    if (S_ISDIR(st.st_mode)) {
        /* a folder made read-only on purpose (the warmed shader cache,
         * workers.h) is the daemon's own: writable again to be emptied */
        if ((st.st_mode & S_IRWXU) != S_IRWXU) chmod(path, (st.st_mode & 07777) | S_IRWXU);
        empty_dir(path);
        rmdir(path);
    } else {
        unlink(path);
    }
}

uint64_t svd_dir_bytes(const char *dir)
{
    struct stat st;
    if (lstat(dir, &st) != 0) return 0;
    if (!S_ISDIR(st.st_mode)) return S_ISREG(st.st_mode) ? (uint64_t)st.st_size : 0;
    uint64_t total = 0;
    DIR *d = opendir(dir);
    if (!d) return 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        char sub[4096];
        if (snprintf(sub, sizeof sub, "%s/%s", dir, e->d_name) >= (int)sizeof sub) continue;
        total += svd_dir_bytes(sub);
    }
    closedir(d);
    return total;
}

/* Creates a directory unless it is one already: mkdir fails with ENOSPC on a
 * full disk even where nothing needs creating. */
static sv_status mkdir_p1(const char *path, sv_error *err)
{
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) return SV_OK;
    if (mkdir(path, 0700) != 0 && errno != EEXIST)
        return sv_fail(err, SV_ERR_IO, "%s: cannot create directory: %s", path, strerror(errno));
    return SV_OK;
}

/* Workers of a daemon that was SIGKILLed (or crashed)
 * outlived it and wrote into the next daemon's tmp/. Workers now die with
 * their daemon (sylva-bake --parent-pid: PR_SET_PDEATHSIG); this sweep, run
 * with the store's lock held and before tmp/ is emptied, kills any that is
 * still there (a worker of an older sylvad, or one whose daemon died between
 * the spawn and its prctl): a process whose command line is a worker's
 * (`bake`, `--progress-fd`) with `--out` inside this store's tmp/. Returns
 * how many were killed. */
static int sweep_stray_workers(const char *root)
{
    pid_t pids[64];
    char tmp[SVD_STORE_PATH], real_tmp[PATH_MAX];
    snprintf(tmp, sizeof tmp, "%s/tmp", root);
    if (!realpath(tmp, real_tmp)) return 0;
    size_t tl = strlen(real_tmp);
    DIR *d = opendir("/proc");
    if (!d) return 0;
    int killed = 0;
    for (struct dirent *e; (e = readdir(d));) {
        char *end;
        long pid = strtol(e->d_name, &end, 10);
        if (*end || pid <= 1 || pid == (long)getpid()) continue;
        char path[64], cmd[8192];
        snprintf(path, sizeof path, "/proc/%ld/cmdline", pid);
        int fd = open(path, O_RDONLY | O_CLOEXEC);
        if (fd < 0) continue;
        ssize_t n = read(fd, cmd, sizeof cmd - 1);
        close(fd);
        if (n <= 0) continue;
        cmd[n] = '\0';
        bool bake = false, pfd = false;
        const char *out = NULL;
        for (const char *a = cmd; a < cmd + n; a += strlen(a) + 1) {
            if (strcmp(a, "bake") == 0) bake = true;
            else if (strcmp(a, "--progress-fd") == 0) pfd = true;
            else if (strcmp(a, "--out") == 0 && a + strlen(a) + 1 < cmd + n)
                out = a + strlen(a) + 1;
        }
        if (!bake || !pfd || !out) continue;
        char where[PATH_MAX + 64], real_out[PATH_MAX];
        if (out[0] == '/') snprintf(where, sizeof where, "%s", out);
        else snprintf(where, sizeof where, "/proc/%ld/cwd/%s", pid, out);
        if (!realpath(where, real_out)) continue;
        if (strncmp(real_out, real_tmp, tl) == 0 && real_out[tl] == '/' &&
            kill((pid_t)pid, SIGKILL) == 0 && killed < 64)
            pids[killed++] = (pid_t)pid;
    }
    closedir(d);
    /* gone (or a zombie, which writes nothing) before tmp/ is emptied: ≤ 2 s */
    for (int i = 0; i < killed; i++)
        for (int k = 0; k < 200 && kill(pids[i], 0) == 0; k++) {
            char path[64], st[256] = "";
            snprintf(path, sizeof path, "/proc/%d/stat", (int)pids[i]);
            FILE *f = fopen(path, "re");
            if (f) {
                if (!fgets(st, sizeof st, f)) st[0] = '\0';
                fclose(f);
            }
            const char *rp = strrchr(st, ')');
            if (rp && rp[1] == ' ' && rp[2] == 'Z') break;
            usleep(10000);
        }
    return killed;
}

svd_store *svd_store_open(const char *root, sv_error *err)
{
    if (strlen(root) > 900) {
        sv_fail(err, SV_ERR_IO, "store path too long");
        return NULL;
    }
    char p[SVD_STORE_PATH];
    if (mkdir_p1(root, err) != SV_OK) return NULL;
    int lock_fd = lock_store(root, err); /* before tmp/ is emptied */
    if (lock_fd < 0) return NULL;
    int stray = sweep_stray_workers(root);
    const char *subs[] = {"tmp", "jobs", "quarantine"};
    for (int i = 0; i < 3; i++) {
        snprintf(p, sizeof p, "%s/%s", root, subs[i]);
        struct stat st;
        if (i == 0 && lstat(p, &st) == 0 && !S_ISDIR(st.st_mode))
            svd_rm_rf(p);              /* not a directory */
        else if (i == 0) empty_dir(p); /* stray temp files from a crash */
        if (mkdir_p1(p, err) != SV_OK) {
            close(lock_fd);
            return NULL;
        }
    }
    svd_store *s = calloc(1, sizeof *s);
    if (s) s->cache = calloc(VCACHE, sizeof *s->cache);
    if (!s || !s->cache) {
        if (s) free(s);
        close(lock_fd);
        sv_fail(err, SV_ERR_NOMEM, "store: out of memory");
        return NULL;
    }
    s->lock_fd = lock_fd;
    s->stray_workers = stray;
    snprintf(s->root, sizeof s->root, "%s", root);
    pthread_mutex_init(&s->mu, NULL);
    return s;
}

int svd_store_stray_workers(const svd_store *s)
{
    return s ? s->stray_workers : 0;
}

void svd_store_close(svd_store *s)
{
    if (!s) return;
    pthread_mutex_destroy(&s->mu);
    free(s->cache);
    close(s->lock_fd); /* releases the flock */
    free(s);
}

const char *svd_store_root(const svd_store *s)
{
    return s->root;
}

void svd_store_job_path(const svd_store *s, const char *key, const char *sub,
                        char out[SVD_STORE_PATH])
{
    if (sub) snprintf(out, SVD_STORE_PATH, "%s/jobs/%s/%s", s->root, key, sub);
    else snprintf(out, SVD_STORE_PATH, "%s/jobs/%s", s->root, key);
}

sv_status svd_store_mktemp(svd_store *s, const char *prefix, char out[SVD_STORE_PATH],
                           sv_error *err)
{
    snprintf(out, SVD_STORE_PATH, "%s/tmp/%s-XXXXXX", s->root, prefix);
    if (!mkdtemp(out)) {
        int e = errno;
        return sv_fail(err, e == ENOSPC ? SV_ERR_LIMIT : SV_ERR_IO,
                       "%s: cannot create temp dir: %s", out, strerror(e));
    }
    return SV_OK;
}

sv_status svd_store_write_file(const char *dir, const char *name, const void *data, size_t size,
                               sv_error *err)
{
    char tmp[SVD_STORE_PATH + 300], dst[SVD_STORE_PATH + 300];
    snprintf(tmp, sizeof tmp, "%s/.%s.tmp", dir, name);
    snprintf(dst, sizeof dst, "%s/%s", dir, name);
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) return sv_fail(err, SV_ERR_IO, "%s: cannot create: %s", tmp, strerror(errno));
    const char *p = data;
    size_t left = size;
    while (left) {
        ssize_t w = write(fd, p, left);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) {
            int e = errno;
            close(fd);
            unlink(tmp);
            return sv_fail(err, e == ENOSPC ? SV_ERR_LIMIT : SV_ERR_IO, "%s: write failed: %s", tmp,
                           strerror(e));
        }
        p += w;
        left -= (size_t)w;
    }
    if (fsync(fd) != 0) {
        int e = errno;
        close(fd);
        unlink(tmp);
        return sv_fail(err, SV_ERR_IO, "%s: fsync failed: %s", tmp, strerror(e));
    }
    close(fd);
    if (rename(tmp, dst) != 0) {
        int e = errno;
        unlink(tmp);
        return sv_fail(err, SV_ERR_IO, "%s: rename failed: %s", dst, strerror(e));
    }
    return svd_fsync_parent(dst, err);
}

static sv_status fsync_path(const char *path, int dir, sv_error *err)
{
    int fd = open(path, (dir ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC);
    if (fd < 0) return sv_fail(err, SV_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    int r = fsync(fd);
    int e = errno;
    close(fd);
    if (r != 0) return sv_fail(err, SV_ERR_IO, "%s: fsync failed: %s", path, strerror(e));
    return SV_OK;
}

static sv_status sync_tree(const char *dir, int depth, sv_error *err)
{
    DIR *d = opendir(dir);
    if (!d) return sv_fail(err, SV_ERR_IO, "%s: cannot open: %s", dir, strerror(errno));
    sv_status st = SV_OK;
    struct dirent *e;
    while (st == SV_OK && (e = readdir(d))) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        char sub[4096];
        if (snprintf(sub, sizeof sub, "%s/%s", dir, e->d_name) >= (int)sizeof sub) continue;
        struct stat sb;
        if (lstat(sub, &sb) != 0) continue;
        if (S_ISREG(sb.st_mode)) st = fsync_path(sub, 0, err);
        else if (S_ISDIR(sb.st_mode) && depth > 0) st = sync_tree(sub, depth - 1, err);
    }
    closedir(d);
    if (st == SV_OK) st = fsync_path(dir, 1, err);
    return st;
}

sv_status svd_store_sync_tree(const char *dir, sv_error *err)
{
    return sync_tree(dir, 1, err);
}

sv_status svd_store_install(svd_store *s, const char *src, const char *key, const char *sub,
                            sv_error *err)
{
    char dst[SVD_STORE_PATH];
    svd_store_job_path(s, key, sub, dst);
    struct stat st;
    if (lstat(dst, &st) == 0) return sv_fail(err, SV_ERR_IO, "%s: already exists", dst);
    if (rename(src, dst) != 0)
        return sv_fail(err, SV_ERR_IO, "%s: rename failed: %s", dst, strerror(errno));
    return svd_fsync_parent(dst, err);
}

void svd_store_remove(svd_store *s, const char *key, const char *sub)
{
    char path[SVD_STORE_PATH], tmp[SVD_STORE_PATH];
    svd_store_job_path(s, key, sub, path);
    pthread_mutex_lock(&s->mu);
    unsigned long long n = ++s->counter;
    pthread_mutex_unlock(&s->mu);
    snprintf(tmp, sizeof tmp, "%s/tmp/del-%llu-%s", s->root, n, key);
    if (rename(path, tmp) == 0) {
        svd_fsync_parent(path, NULL);
        svd_rm_rf(tmp);
    } else {
        svd_rm_rf(path);
    }
}

static size_t slot_of(const char *path)
{
    /* FNV-1a: only picks a cache slot; the entry stores the full path. */
    uint64_t h = 1469598103934665603ull;
    for (const unsigned char *p = (const unsigned char *)path; *p; p++)
        h = (h ^ *p) * 1099511628211ull;
    return (size_t)(h % VCACHE);
}

sv_status svd_store_verify(svd_store *s, const char *path, uint64_t size, const char *sha256,
                           sv_error *err)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return sv_fail(err, SV_ERR_IO, "%s: missing: %s", path, strerror(errno));
    size_t slot = slot_of(path);
    pthread_mutex_lock(&s->mu);
    vcache_entry *c = &s->cache[slot];
    int hit = strcmp(c->path, path) == 0 && c->dev == st.st_dev && c->ino == st.st_ino &&
              c->size == st.st_size && c->mtime.tv_sec == st.st_mtim.tv_sec &&
              c->mtime.tv_nsec == st.st_mtim.tv_nsec && strcmp(c->sha, sha256) == 0;
    pthread_mutex_unlock(&s->mu);
    if (hit) return SV_OK;
    if ((uint64_t)st.st_size != size)
        return sv_fail(err, SV_ERR_INVALID, "%s: size %lld, expected %llu", path,
                       (long long)st.st_size, (unsigned long long)size);
    char got[SVD_KEY_HEX];
    uint64_t n = 0;
    sv_status rs = svd_sha256_file(path, got, &n, err);
    if (rs != SV_OK) return rs;
    if (strcmp(got, sha256) != 0 || n != size)
        return sv_fail(err, SV_ERR_INVALID, "%s: SHA-256 mismatch", path);
    pthread_mutex_lock(&s->mu);
    snprintf(c->path, sizeof c->path, "%s", path);
    c->dev = st.st_dev;
    c->ino = st.st_ino;
    c->size = st.st_size;
    c->mtime = st.st_mtim;
    memcpy(c->sha, sha256, SVD_KEY_HEX);
    pthread_mutex_unlock(&s->mu);
    return SV_OK;
}

void svd_store_quarantine(svd_store *s, const char *key, const char *path)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    pthread_mutex_lock(&s->mu);
    unsigned long long n = ++s->counter;
    pthread_mutex_unlock(&s->mu);
    char dst[SVD_STORE_PATH + 300];
    snprintf(dst, sizeof dst, "%s/quarantine/%s-%s-%llu", s->root, key, base, n);
    if (rename(path, dst) != 0) svd_rm_rf(path);
    svd_fsync_parent(path, NULL);
}
