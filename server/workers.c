/* workers.c — supervised sylva-bake processes (see workers.h). The pattern is
 * Redis' child handling: a pipe for reports, waitpid, WIFSIGNALED = failure. */
#define _GNU_SOURCE /* pipe2, prlimit */
#include "workers.h"

#include <cjson/cJSON.h>
#include "json_strict.h"
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdatomic.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "zygote_proto.h"

extern char **environ;

struct svd_workers {
    svd_jobs *jobs;
    char path[SVD_PATH_MAX];
    unsigned count;
    pthread_t *threads;
    /* the pool (worker_pool): 0 not tried yet, 1 a zygote said hello, -1
     * the first zygote failed (a worker that does not speak the protocol,
     * or threads at fork): one exec per job from then on */
    atomic_int pool_state;
    /* the shader cache (worker_shader_cache; workers.h): shader_db is
     * written by the warm-up thread before it sets shader_state to 1; -1
     * failed or off, 0 warming */
    char shader_db[SVD_PATH_MAX];
    atomic_int shader_state;
    atomic_int warm_pid; /* the warm-up process while it runs, else 0 */
    pthread_t warm_thread;
    bool warm_started;
};

/* One worker thread's zygote (`sylva-bake zygote`, common/zygote_proto.h),
 * started at the thread's first job, again after it died. */
typedef struct zygote {
    pid_t pid; /* 0 = none; the daemon's own child, reaped by zygote_stop */
    int fd;    /* the control socket, -1 = none */
} zygote;

static cJSON *read_json(const char *path, size_t max)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    char *buf = malloc(max);
    size_t n = buf ? fread(buf, 1, max, f) : 0;
    fclose(f);
    cJSON *j = buf ? sv_json_parse_strict(buf, n, "worker JSON", SV_ERR_PARSE, NULL) : NULL;
    free(buf);
    return j;
}

/* Verifies every input of a job against inputs.json; fills argv pieces. */
static sv_status check_inputs(svd_store *store, const char *key, cJSON **inputs_out, sv_error *err)
{
    char p[SVD_STORE_PATH];
    svd_store_job_path(store, key, "inputs.json", p);
    cJSON *in = read_json(p, 1 << 20);
    if (!in) return sv_fail(err, SV_ERR_IO, "inputs.json missing or unreadable");
    const cJSON *objs = cJSON_GetObjectItemCaseSensitive(in, "objects");
    const cJSON *o;
    cJSON_ArrayForEach(o, objs)
    {
        const char *h = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(o, "sha256"));
        const cJSON *sz = cJSON_GetObjectItemCaseSensitive(o, "size");
        if (!o->string || !svd_name_valid(o->string) || !h || !cJSON_IsNumber(sz)) {
            cJSON_Delete(in);
            return sv_fail(err, SV_ERR_IO, "inputs.json is malformed");
        }
        char sub[SVD_NAME_MAX + 8];
        snprintf(sub, sizeof sub, "in/%s", o->string);
        svd_store_job_path(store, key, sub, p);
        sv_status st = svd_store_verify(store, p, (uint64_t)sz->valuedouble, h, err);
        if (st != SV_OK) {
            if (st == SV_ERR_INVALID) svd_store_quarantine(store, key, p);
            cJSON_Delete(in);
            return st;
        }
    }
    *inputs_out = in;
    return SV_OK;
}

typedef struct run_result {
    int status; /* waitpid status */
    int timed_out, cancelled, aborted, spawn_failed;
    int zygote_lost; /* the pool's zygote died mid-bake (and the worker with it) */
    char spawn_error[256];
    struct rusage ru; /* of the reaped worker (wait4) */
} run_result;

static void apply_rlimits(pid_t pid, const svd_config *c)
{
    struct rlimit r;
    if (c->worker_as_bytes) { /* 0 = no address-space limit */
        r.rlim_cur = r.rlim_max = c->worker_as_bytes;
        prlimit(pid, RLIMIT_AS, &r, NULL);
    }
    r.rlim_cur = r.rlim_max = c->worker_cpu_seconds;
    prlimit(pid, RLIMIT_CPU, &r, NULL);
    r.rlim_cur = r.rlim_max = c->worker_nofile;
    prlimit(pid, RLIMIT_NOFILE, &r, NULL);
    r.rlim_cur = r.rlim_max = c->worker_fsize_bytes;
    prlimit(pid, RLIMIT_FSIZE, &r, NULL);
    r.rlim_cur = r.rlim_max = 0;
    prlimit(pid, RLIMIT_CORE, &r, NULL);
}

/* posix_spawn of path with argv: stdin /dev/null, stdout and stderr the
 * file out (opened with oflags, mode 0600), fd 3 = fd3 (its FD_CLOEXEC
 * cleared by the dup2), every signal unblocked and at its default, in a
 * process group of its own (a terminal's ^C is the daemon's to handle).
 * Returns posix_spawn's result (0, or an errno). */
static int spawn_child(const char *path, char *const argv[], const char *out, int oflags, int fd3,
                       pid_t *pid)
{
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t at;
    posix_spawn_file_actions_init(&fa);
    posix_spawnattr_init(&at);
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 1, out, oflags, 0600);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    posix_spawn_file_actions_adddup2(&fa, fd3, 3);
    sigset_t none, def;
    sigemptyset(&none);
    sigfillset(&def);
    sigdelset(&def, SIGKILL);
    sigdelset(&def, SIGSTOP);
    posix_spawnattr_setsigmask(&at, &none);
    posix_spawnattr_setsigdefault(&at, &def);
    posix_spawnattr_setpgroup(&at, 0);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF |
                                      POSIX_SPAWN_SETPGROUP);
    int rc = posix_spawn(pid, path, &fa, &at, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&at);
    return rc;
}

static void handle_line(svd_jobs *jobs, svd_ticket *t, const char *line)
{
    cJSON *j = sv_json_parse_strict(line, strlen(line), "worker progress", SV_ERR_PARSE, NULL);
    const char *stage = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(j, "stage"));
    const cJSON *pr = cJSON_GetObjectItemCaseSensitive(j, "progress");
    const cJSON *tk = cJSON_GetObjectItemCaseSensitive(j, "try");
    const cJSON *tn = cJSON_GetObjectItemCaseSensitive(j, "tries");
    if (stage)
        svd_jobs_progress(jobs, t, stage, cJSON_IsNumber(pr) ? pr->valuedouble : -1,
                          cJSON_IsNumber(tk) ? tk->valueint : 0,
                          cJSON_IsNumber(tn) ? tn->valueint : 0);
    cJSON_Delete(j);
}

/* The progress pipe's partial line. */
typedef struct progress_reader {
    char line[4096];
    size_t len;
} progress_reader;

/* Reads what the pipe holds and hands each complete line to the job table.
 * 1 at EOF (or a read error), else 0. */
static int read_progress(svd_jobs *jobs, svd_ticket *t, int fd, progress_reader *pr)
{
    char buf[4096];
    ssize_t n = read(fd, buf, sizeof buf);
    if (n <= 0) return !(n < 0 && (errno == EINTR || errno == EAGAIN));
    for (ssize_t i = 0; i < n; i++) {
        if (buf[i] == '\n') {
            pr->line[pr->len] = '\0';
            handle_line(jobs, t, pr->line);
            pr->len = 0;
        } else if (pr->len + 1 < sizeof pr->line) {
            pr->line[pr->len++] = buf[i];
        }
    }
    return 0;
}

/* Whether the running worker must be killed now: past the deadline, the job
 * cancelled (DELETE) or the daemon draining. Sets rr's flag, logs, returns
 * the reason; NULL to let it run. */
static const char *kill_reason(svd_workers *w, svd_ticket *t, double deadline, run_result *rr)
{
    const char *why = NULL;
    if (sv_now() >= deadline) rr->timed_out = 1, why = "timeout";
    else if (svd_jobs_cancelled(w->jobs, t)) rr->cancelled = 1, why = "cancel";
    else if (svd_jobs_aborting(w->jobs)) rr->aborted = 1, why = "drain";
    if (why)
        svd_log_kv(svd_jobs_log(w->jobs), SVD_LOG_WARN, "worker_killed", "key", t->key, "reason",
                   why, (const char *)NULL);
    return why;
}

/* Runs argv (today's exec path) to its end: posix_spawn, limits, progress,
 * deadline / cancel / drain kills, wait4. */
static void run_exec(svd_workers *w, svd_ticket *t, char **argv, const char *logpath,
                     run_result *rr)
{
    svd_jobs *jobs = w->jobs;
    const svd_config *c = svd_jobs_config(jobs);
    memset(rr, 0, sizeof *rr);
    int p[2];
    if (pipe2(p, O_CLOEXEC) != 0) {
        rr->spawn_failed = 1;
        snprintf(rr->spawn_error, sizeof rr->spawn_error, "pipe: %s", strerror(errno));
        return;
    }
    pid_t pid;
    int rc = spawn_child(argv[0], argv, logpath, O_WRONLY | O_CREAT | O_TRUNC, p[1], &pid);
    close(p[1]);
    if (rc != 0) {
        close(p[0]);
        rr->spawn_failed = 1;
        snprintf(rr->spawn_error, sizeof rr->spawn_error, "cannot start %s: %s", argv[0],
                 strerror(rc));
        return;
    }
    if (!c->prlimit[0]) apply_rlimits(pid, c);
    /* Bakes yield the cores to the HTTP threads: health and status stay fast
     * while every worker renders. Set before the worker starts its render
     * threads (they inherit it). It fails (EPERM) only when worker_nice is
     * below the daemon's own nice; the worker then keeps the daemon's. */
    if (c->worker_nice) setpriority(PRIO_PROCESS, (id_t)pid, (int)c->worker_nice);
    char logbuf[32];
    snprintf(logbuf, sizeof logbuf, "%d", (int)pid);
    svd_log_kv(svd_jobs_log(jobs), SVD_LOG_DEBUG, "worker_started", "key", t->key, "pid", logbuf,
               (const char *)NULL);

    double deadline = sv_now() + (c->job_timeout ? c->job_timeout : 1e9);
    progress_reader pr = {0};
    int eof = 0, killed = 0, reaped = 0;
    while (!reaped) {
        double now = sv_now();
        if (!killed && kill_reason(w, t, deadline, rr)) {
            kill(-pid, SIGKILL); /* the whole process group */
            kill(pid, SIGKILL);
            killed = 1;
        }
        if (!eof) {
            struct pollfd pfd = {.fd = p[0], .events = POLLIN};
            int ms = (int)((deadline - now) * 1000);
            if (ms > 100) ms = 100;
            if (ms < 0) ms = 0;
            if (poll(&pfd, 1, ms) > 0) eof = read_progress(jobs, t, p[0], &pr);
        } else {
            struct timespec ts = {0, 20 * 1000 * 1000};
            nanosleep(&ts, NULL);
        }
        pid_t r = wait4(pid, &rr->status, WNOHANG, &rr->ru);
        if (r == pid) reaped = 1;
    }
    kill(-pid, SIGKILL); /* leftovers the worker may have started */
    close(p[0]);
}

/* ---- the pool (worker_pool; common/zygote_proto.h, docs/design.md) ---- */

#define ZYGOTE_HELLO_WAIT 30.0 /* s: loading the libraries takes ~0.5 s, more under ASan */
#define ZYGOTE_KILL_WAIT 5.0   /* s after a kill request before the zygote itself is killed */

/* Kills and reaps the zygote (the daemon's child) and closes its socket. Its
 * child, if any, dies with it (PR_SET_PDEATHSIG). A zygote with no pid is a
 * no-op. */
static void zygote_stop(zygote *z)
{
    if (z->fd >= 0) close(z->fd);
    if (z->pid > 0) {
        kill(z->pid, SIGKILL);
        while (waitpid(z->pid, NULL, 0) < 0 && errno == EINTR) {}
    }
    z->pid = 0;
    z->fd = -1;
}

/* Receives one message of exactly size bytes within timeout seconds.
 * 1 done, 0 the zygote closed its end (it died), -1 timeout or a bad
 * message. */
static int zygote_recv(int fd, void *m, size_t size, double timeout)
{
    struct pollfd pfd = {.fd = fd, .events = POLLIN};
    int pr;
    do pr = poll(&pfd, 1, (int)(timeout * 1000));
    while (pr < 0 && errno == EINTR);
    if (pr <= 0) return -1;
    char buf[sizeof(svz_exited) + 64];
    ssize_t n;
    do n = recv(fd, buf, sizeof buf, 0);
    while (n < 0 && errno == EINTR);
    if (n <= 0) return n == 0 || errno == ECONNRESET ? 0 : -1;
    if ((size_t)n != size) return -1;
    memcpy(m, buf, size);
    return 1;
}

/* Starts `WORKER zygote --control-fd 3 --parent-pid DAEMON ROOM` with
 * posix_spawn (the daemon never forks) and waits for its hello. SV_OK with z
 * set, or an error whose message says why the pool cannot be used. */
static sv_status zygote_start(svd_workers *w, zygote *z, sv_error *err)
{
    int sv[2];
    z->pid = 0;
    z->fd = -1;
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0)
        return sv_fail(err, SV_ERR_IO, "socketpair: %s", strerror(errno));
    char ppid[24], room[SVZ_TITLE_ROOM];
    snprintf(ppid, sizeof ppid, "%ld", (long)getpid());
    memset(room, ' ', sizeof room - 1); /* the children's command lines go here (ps) */
    room[sizeof room - 1] = '\0';
    char *argv[] = {w->path, "zygote", "--control-fd", "3", "--parent-pid", ppid, room, NULL};
    pid_t pid;
    int rc = spawn_child(w->path, argv, "/dev/null", O_WRONLY, sv[1], &pid);
    close(sv[1]);
    if (rc != 0) {
        close(sv[0]);
        return sv_fail(err, SV_ERR_IO, "cannot start %s zygote: %s", w->path, strerror(rc));
    }
    z->pid = pid;
    z->fd = sv[0];
    svz_hello h;
    int got = zygote_recv(z->fd, &h, sizeof h, ZYGOTE_HELLO_WAIT);
    sv_status st = SV_OK;
    if (got == 0)
        st = sv_fail(err, SV_ERR_IO,
                     "%s exited without a zygote's hello (a worker that does not "
                     "speak the pool protocol)",
                     w->path);
    else if (got < 0 || h.type != SVZ_HELLO)
        st = sv_fail(err, SV_ERR_IO, "%s zygote: no valid hello within %.0f s", w->path,
                     ZYGOTE_HELLO_WAIT);
    else if (h.version != SVZ_VERSION)
        st = sv_fail(err, SV_ERR_IO, "%s zygote speaks protocol version %u, not %u", w->path,
                     h.version, SVZ_VERSION);
    else if (h.threads != 1)
        st = sv_fail(err, SV_ERR_IO,
                     "%s zygote has %d threads after loading its libraries: "
                     "fork() would not be safe",
                     w->path, h.threads);
    else if (h.pid != pid)
        st = sv_fail(err, SV_ERR_IO, "%s zygote says it is pid %d, not %d", w->path, h.pid,
                     (int)pid);
    if (st != SV_OK) zygote_stop(z);
    return st;
}

/* The run message: header + argv strings (argv[0] is the worker). 0 and the
 * length in *len, or -1 when it does not fit SVZ_MAX_MSG. */
static int build_run(const svd_config *c, char *const *argv, char *msg, size_t *len)
{
    svz_run rq = {.type = SVZ_RUN,
                  .as_bytes = c->worker_as_bytes,
                  .cpu_seconds = c->worker_cpu_seconds,
                  .nofile = c->worker_nofile,
                  .fsize_bytes = c->worker_fsize_bytes,
                  .nice = (int32_t)c->worker_nice};
    size_t at = sizeof rq;
    for (; argv[rq.argc]; rq.argc++) {
        size_t l = strlen(argv[rq.argc]) + 1;
        if (at + l > SVZ_MAX_MSG) return -1;
        memcpy(msg + at, argv[rq.argc], l);
        at += l;
    }
    memcpy(msg, &rq, sizeof rq);
    *len = at;
    return 0;
}

/* Runs argv (no prlimit prefix) as a child of the thread's zygote, with
 * run_exec's loop. Returns 0 when the job ran (rr filled as run_exec fills
 * it, rr->zygote_lost if the zygote died under it), -1 when nothing was
 * started (the zygote is gone or refused; the caller runs the job by exec). */
static int run_pool(svd_workers *w, zygote *z, svd_ticket *t, char **argv, const char *logpath,
                    run_result *rr)
{
    svd_jobs *jobs = w->jobs;
    const svd_config *c = svd_jobs_config(jobs);
    memset(rr, 0, sizeof *rr);
    char *msg = malloc(SVZ_MAX_MSG);
    size_t len = 0;
    if (!msg || build_run(c, argv, msg, &len) != 0) {
        free(msg);
        return -1;
    }
    int p[2], logfd = -1;
    if (pipe2(p, O_CLOEXEC) != 0) {
        free(msg);
        rr->spawn_failed = 1;
        snprintf(rr->spawn_error, sizeof rr->spawn_error, "pipe: %s", strerror(errno));
        return 0;
    }
    logfd = open(logpath, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (logfd < 0) {
        free(msg);
        close(p[0]);
        close(p[1]);
        rr->spawn_failed = 1;
        snprintf(rr->spawn_error, sizeof rr->spawn_error, "cannot start %s: %s", argv[0],
                 strerror(errno)); /* as posix_spawn says it when its open fails */
        return 0;
    }
    int fds[2] = {logfd, p[1]};
    char cbuf[CMSG_SPACE(sizeof fds)];
    memset(cbuf, 0, sizeof cbuf);
    struct iovec iov = {msg, len};
    struct msghdr mh = {
        .msg_iov = &iov, .msg_iovlen = 1, .msg_control = cbuf, .msg_controllen = sizeof cbuf};
    struct cmsghdr *cm = CMSG_FIRSTHDR(&mh);
    cm->cmsg_level = SOL_SOCKET;
    cm->cmsg_type = SCM_RIGHTS;
    cm->cmsg_len = CMSG_LEN(sizeof fds);
    memcpy(CMSG_DATA(cm), fds, sizeof fds);
    ssize_t sent;
    do sent = sendmsg(z->fd, &mh, MSG_NOSIGNAL);
    while (sent < 0 && errno == EINTR);
    free(msg);
    close(logfd);
    close(p[1]);
    svz_started s = {0};
    int got = sent == (ssize_t)len ? zygote_recv(z->fd, &s, sizeof s, ZYGOTE_HELLO_WAIT) : 0;
    if (got <= 0 || s.type != SVZ_STARTED || s.err != 0 || s.pid <= 0) {
        close(p[0]);
        char why[96];
        snprintf(why, sizeof why, "%s",
                 got == 0  ? "the zygote is gone"
                 : got < 0 ? "no answer from the zygote"
                 : s.err   ? strerror(s.err)
                           : "a bad answer from the zygote");
        svd_log_kv(svd_jobs_log(jobs), SVD_LOG_WARN, "zygote_failed", "key", t->key, "reason", why,
                   (const char *)NULL);
        zygote_stop(z);
        return -1;
    }
    pid_t pid = s.pid;
    char pbuf[32], zbuf[32];
    snprintf(pbuf, sizeof pbuf, "%d", (int)pid);
    snprintf(zbuf, sizeof zbuf, "%d", (int)z->pid);
    svd_log_kv(svd_jobs_log(jobs), SVD_LOG_DEBUG, "worker_started", "key", t->key, "pid", pbuf,
               "zygote", zbuf, (const char *)NULL);

    double deadline = sv_now() + (c->job_timeout ? c->job_timeout : 1e9), killed_at = 0;
    progress_reader pr = {0};
    int eof = 0, killed = 0, reaped = 0;
    while (!reaped) {
        double now = sv_now();
        if (!killed && kill_reason(w, t, deadline, rr)) {
            /* only the zygote signals its child: it alone knows whether the
             * pid is still the worker's (it has not reaped it) */
            svz_kill k = {.type = SVZ_KILL, .pid = pid};
            send(z->fd, &k, sizeof k, MSG_NOSIGNAL);
            killed = 1;
            killed_at = now;
        } else if (killed && now - killed_at > ZYGOTE_KILL_WAIT) {
            zygote_stop(z); /* an unresponsive zygote: the worker dies with it */
            rr->zygote_lost = 1;
            break;
        }
        struct pollfd pfd[2] = {{.fd = z->fd, .events = POLLIN},
                                {.fd = eof ? -1 : p[0], .events = POLLIN}};
        int ms = (int)((deadline - now) * 1000);
        if (ms > 100) ms = 100;
        if (ms < 0) ms = 0;
        if (poll(pfd, 2, ms) <= 0) continue;
        if (pfd[1].revents) eof = read_progress(jobs, t, p[0], &pr);
        if (pfd[0].revents) {
            svz_exited ex;
            int r = zygote_recv(z->fd, &ex, sizeof ex, 0);
            if (r == 1 && ex.type == SVZ_EXITED && ex.pid == pid) {
                rr->status = ex.status;
                rr->ru = ex.ru;
                reaped = 1;
            } else { /* the zygote died (or broke the protocol): so did its child */
                zygote_stop(z);
                rr->zygote_lost = 1;
                break;
            }
        }
    }
    close(p[0]);
    return 0;
}

/* Runs the job's argv: through the thread's zygote when the pool is on and
 * works, else by exec. argv[base] is the worker (before it: the prlimit
 * wrapper, which the pool does without: the child sets the same limits with
 * setrlimit); ppid is the --parent-pid argument's buffer, set here to the
 * process the worker must die with. */
static void run_process(svd_workers *w, zygote *z, svd_ticket *t, char **argv, size_t base,
                        char *ppid, size_t ppid_cap, const char *logpath, run_result *rr)
{
    const svd_config *c = svd_jobs_config(w->jobs);
    if (c->worker_pool && atomic_load(&w->pool_state) >= 0) {
        /* an idle zygote says nothing: anything readable on its socket is
         * its death (EOF) */
        struct pollfd zp = {.fd = z->fd, .events = POLLIN};
        if (z->fd >= 0 && poll(&zp, 1, 0) != 0) {
            char zb[32];
            snprintf(zb, sizeof zb, "%d", (int)z->pid);
            svd_log_kv(svd_jobs_log(w->jobs), SVD_LOG_WARN, "zygote_lost", "pid", zb, "msg",
                       "the idle zygote died: starting another", (const char *)NULL);
            zygote_stop(z);
        }
        if (z->fd < 0) {
            sv_error err = {0};
            if (zygote_start(w, z, &err) == SV_OK) {
                int zero = 0;
                atomic_compare_exchange_strong(&w->pool_state, &zero, 1);
                char zb[32];
                snprintf(zb, sizeof zb, "%d", (int)z->pid);
                svd_log_kv(svd_jobs_log(w->jobs), SVD_LOG_INFO, "zygote_started", "pid", zb,
                           (const char *)NULL);
            } else {
                int zero = 0;
                if (atomic_compare_exchange_strong(&w->pool_state, &zero, -1))
                    svd_log_kv(svd_jobs_log(w->jobs), SVD_LOG_WARN, "worker_pool_unavailable",
                               "reason", err.message, "msg",
                               "worker_pool is on but the first zygote failed: one exec per job",
                               (const char *)NULL);
                else
                    svd_log_kv(svd_jobs_log(w->jobs), SVD_LOG_WARN, "zygote_failed", "key", t->key,
                               "reason", err.message, (const char *)NULL);
            }
        }
        if (z->fd >= 0) {
            snprintf(ppid, ppid_cap, "%ld", (long)z->pid);
            if (run_pool(w, z, t, argv + base, logpath, rr) == 0) return;
        }
    }
    snprintf(ppid, ppid_cap, "%ld", (long)getpid());
    run_exec(w, t, argv, logpath, rr);
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Hashes the outputs, writes manifest.json, fsyncs, installs as result/.
 * Returns the manifest JSON (malloc'ed) or NULL with err set. */
static char *install_result(svd_store *store, const char *key, const char *outdir, svd_ticket *t,
                            sv_error *err)
{
    (void)t;
    DIR *d = opendir(outdir);
    if (!d) {
        sv_fail(err, SV_ERR_IO, "%s: cannot list outputs", outdir);
        return NULL;
    }
    char *names[512];
    size_t n = 0;
    bool oom = false, too_many = false;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!svd_name_valid(e->d_name) || e->d_name[0] == '.' ||
            strcmp(e->d_name, "manifest.json") == 0)
            continue;
        char p[SVD_STORE_PATH + 300];
        snprintf(p, sizeof p, "%s/%s", outdir, e->d_name);
        struct stat sb;
        if (lstat(p, &sb) != 0 || !S_ISREG(sb.st_mode)) continue;
        if (n == sizeof names / sizeof names[0]) {
            too_many = true;
            break;
        }
        /* every artifact or none: a manifest that leaves one out would be served */
        if (!(names[n] = strdup(e->d_name))) {
            oom = true;
            break;
        }
        n++;
    }
    closedir(d);
    qsort(names, n, sizeof names[0], cmp_str);
    cJSON *m = cJSON_CreateObject();
    cJSON *arr = m ? cJSON_AddArrayToObject(m, "artifacts") : NULL;
    sv_status st = oom || !arr || !cJSON_AddStringToObject(m, "key", key)
                       ? sv_fail(err, SV_ERR_NOMEM, "manifest: out of memory")
                   : too_many
                       ? sv_fail(err, SV_ERR_LIMIT, "the worker wrote more than %zu artifacts",
                                 sizeof names / sizeof names[0])
                   : n ? SV_OK
                       : sv_fail(err, SV_ERR_IO, "the worker exited 0 but wrote no artifacts");
    for (size_t i = 0; i < n && st == SV_OK; i++) {
        char p[SVD_STORE_PATH + 300], h[SVD_KEY_HEX];
        uint64_t size = 0;
        snprintf(p, sizeof p, "%s/%s", outdir, names[i]);
        st = svd_sha256_file(p, h, &size, err);
        if (st != SV_OK) break;
        cJSON *a = cJSON_CreateObject();
        if (!a || !cJSON_AddStringToObject(a, "name", names[i]) ||
            !cJSON_AddNumberToObject(a, "size", (double)size) ||
            !cJSON_AddStringToObject(a, "sha256", h) || !cJSON_AddItemToArray(arr, a)) {
            cJSON_Delete(a);
            st = sv_fail(err, SV_ERR_NOMEM, "manifest: out of memory");
        }
    }
    for (size_t i = 0; i < n; i++) free(names[i]);
    if (st == SV_OK) { /* a summary from report.json, when the worker wrote one */
        char p[SVD_STORE_PATH + 32];
        snprintf(p, sizeof p, "%s/report.json", outdir);
        cJSON *rep = read_json(p, 16u << 20);
        if (rep) {
            cJSON *sum = cJSON_AddObjectToObject(m, "summary");
            /* "target": the search's goal, met, chosen try and reason (docs/spec.md) */
            const char *keep[] = {"method", "lods", "evaluation", "effects", "target"};
            for (int k = 0; k < 5; k++) {
                cJSON *it = cJSON_GetObjectItemCaseSensitive(rep, keep[k]);
                if (it) cJSON_AddItemToObject(sum, keep[k], cJSON_Duplicate(it, 1));
            }
            /* the input's warnings (missing files, Z-up, implausible size), for the
             * status document's "warnings" (docs/api.md) */
            cJSON *w = cJSON_GetObjectItemCaseSensitive(
                cJSON_GetObjectItemCaseSensitive(rep, "input"), "warnings");
            cJSON *wl = cJSON_AddArrayToObject(m, "warnings");
            const cJSON *x;
            cJSON_ArrayForEach(x, w) if (wl && cJSON_IsString(x))
                cJSON_AddItemToArray(wl, cJSON_CreateString(x->valuestring));
            cJSON_Delete(rep);
        }
    }
    char *text = st == SV_OK ? cJSON_PrintUnformatted(m) : NULL;
    cJSON_Delete(m);
    if (st != SV_OK) return NULL;
    if (!text) {
        sv_fail(err, SV_ERR_NOMEM, "manifest: out of memory");
        return NULL;
    }
    st = svd_store_write_file(outdir, "manifest.json", text, strlen(text), err);
    if (st == SV_OK) st = svd_store_sync_tree(outdir, err);
    if (st == SV_OK) {
        svd_store_remove(store, key, "result"); /* a stale one from a quarantine */
        st = svd_store_install(store, outdir, key, "result", err);
    }
    if (st != SV_OK) {
        free(text);
        return NULL;
    }
    return text;
}

static void tail_of_log(const char *path, char *out, size_t cap)
{
    out[0] = '\0';
    FILE *f = fopen(path, "rb");
    if (!f) return;
    char buf[4096];
    if (fseek(f, -(long)(sizeof buf - 1), SEEK_END) != 0) fseek(f, 0, SEEK_SET);
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    while (n && (buf[n - 1] == '\n' || buf[n - 1] == '\r')) buf[--n] = '\0';
    char *last = strrchr(buf, '\n');
    const char *src = last ? last + 1 : buf;
    size_t l = strlen(src);
    if (l >= cap) l = cap - 1;
    memcpy(out, src, l);
    out[l] = '\0';
}

/* Why a worker died of a signal, naming the limit when one was hit:
 * RLIMIT_CPU sends SIGXCPU at the soft limit and SIGKILL at the hard one
 * (prlimit --cpu=N sets both, so it is SIGKILL), recognised by the CPU time
 * the worker used (wait4's figure runs up to ~15 % below the kernel's own
 * accounting at the kill, hence the 80 % threshold); RLIMIT_AS makes
 * allocations fail, which C++ code (assimp) turns into std::bad_alloc and
 * abort(), recognised by the last line the worker logged. Anything else:
 * "worker killed by signal N". */
static void signal_reason(const svd_config *c, const run_result *rr, const char *logpath, char *msg,
                          size_t cap)
{
    int sig = WTERMSIG(rr->status);
    double cpu = (double)rr->ru.ru_utime.tv_sec + rr->ru.ru_utime.tv_usec / 1e6 +
                 (double)rr->ru.ru_stime.tv_sec + rr->ru.ru_stime.tv_usec / 1e6;
    if (c->worker_cpu_seconds &&
        (sig == SIGXCPU || (sig == SIGKILL && cpu >= 0.8 * c->worker_cpu_seconds))) {
        snprintf(msg, cap,
                 "worker killed by signal %d after %.1f s of CPU: the CPU time limit of %u s "
                 "(RLIMIT_CPU)",
                 sig, cpu, c->worker_cpu_seconds);
        return;
    }
    char tail[300];
    tail_of_log(logpath, tail, sizeof tail);
    if (c->worker_as_bytes && (sig == SIGABRT || sig == SIGSEGV || sig == SIGBUS) &&
        (strstr(tail, "bad_alloc") || strcasestr(tail, "out of memory") ||
         strcasestr(tail, "cannot allocate memory") || strstr(tail, "MemoryError"))) {
        snprintf(msg, cap,
                 "worker killed by signal %d out of memory: the address-space limit of %llu bytes "
                 "(RLIMIT_AS)",
                 sig, (unsigned long long)c->worker_as_bytes);
        return;
    }
    snprintf(msg, cap, "worker killed by signal %d", sig);
}

static void run_job(svd_workers *w, zygote *z, svd_ticket *t)
{
    svd_jobs *jobs = w->jobs;
    svd_store *store = svd_jobs_store(jobs);
    const svd_config *c = svd_jobs_config(jobs);
    sv_error err = {0};
    cJSON *inputs = NULL;
    sv_status st = check_inputs(store, t->key, &inputs, &err);
    if (st != SV_OK) {
        svd_jobs_finish(jobs, t, SVD_OUT_FAILED, "corrupt", err.message, NULL);
        return;
    }
    char outdir[SVD_STORE_PATH], logpath[SVD_STORE_PATH + 8];
    if (svd_store_mktemp(store, "out", outdir, &err) != SV_OK) {
        cJSON_Delete(inputs);
        svd_jobs_finish(jobs, t, SVD_OUT_RETRY, NULL, "cannot create an output directory", NULL);
        return;
    }
    snprintf(logpath, sizeof logpath, "%s.log", outdir);

    /* argv: [prlimit opts --] worker bake MESH FILES... --spec S --out D --progress-fd 3
     *       [--sandbox] */
    const cJSON *files = cJSON_GetObjectItemCaseSensitive(inputs, "files");
    const char *mesh = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(inputs, "mesh"));
    int nfiles = cJSON_GetArraySize(files);
    size_t argc_max = 24 + (size_t)nfiles;
    char **argv = sv_calloc(argc_max + 1, sizeof *argv);
    char **inpaths = sv_calloc((size_t)nfiles + 1, sizeof *inpaths);
    if (!argv || !inpaths) { /* a NULL in argv would end the command line early */
        free(argv);
        free(inpaths);
        cJSON_Delete(inputs);
        svd_rm_rf(outdir);
        svd_jobs_finish(jobs, t, SVD_OUT_RETRY, NULL,
                        "out of memory building the worker's command line", NULL);
        return;
    }
    char *owned[8] = {0};
    size_t no = 0, ac = 0;
    bool oom = false;
    char buf[SVD_STORE_PATH + 300];
#define OWN(s) (owned[no] = strdup(s), oom |= !owned[no], owned[no++])
    if (c->prlimit[0]) {
        argv[ac++] = (char *)c->prlimit;
        if (c->worker_as_bytes) { /* 0 = no address-space limit */
            snprintf(buf, sizeof buf, "--as=%llu", (unsigned long long)c->worker_as_bytes);
            argv[ac++] = OWN(buf);
        }
        snprintf(buf, sizeof buf, "--cpu=%u", c->worker_cpu_seconds);
        argv[ac++] = OWN(buf);
        snprintf(buf, sizeof buf, "--nofile=%u", c->worker_nofile);
        argv[ac++] = OWN(buf);
        snprintf(buf, sizeof buf, "--fsize=%llu", (unsigned long long)c->worker_fsize_bytes);
        argv[ac++] = OWN(buf);
        argv[ac++] = "--core=0";
        argv[ac++] = "--";
    }
    size_t base = ac; /* the worker: where the pool's argv starts */
    argv[ac++] = w->path;
    argv[ac++] = "bake";
    snprintf(buf, sizeof buf, "in/%s", mesh ? mesh : "");
    char p[SVD_STORE_PATH];
    svd_store_job_path(store, t->key, buf, p);
    inpaths[0] = strdup(p);
    oom |= !inpaths[0];
    argv[ac++] = inpaths[0];
    for (int i = 0; i < nfiles; i++) {
        const char *fname = cJSON_GetStringValue(cJSON_GetArrayItem(files, i));
        snprintf(buf, sizeof buf, "in/%s", fname ? fname : "");
        svd_store_job_path(store, t->key, buf, p);
        inpaths[i + 1] = strdup(p);
        oom |= !inpaths[i + 1];
        argv[ac++] = inpaths[i + 1];
    }
    svd_store_job_path(store, t->key, "spec.json", p);
    argv[ac++] = "--spec";
    argv[ac++] = OWN(p);
    argv[ac++] = "--out";
    argv[ac++] = outdir;
    argv[ac++] = "--progress-fd";
    argv[ac++] = "3";
    /* the worker dies with the daemon (PR_SET_PDEATHSIG),
     * or with its zygote, which dies with the daemon: run_process says */
    char ppid[24] = "";
    argv[ac++] = "--parent-pid";
    argv[ac++] = ppid;
    if (c->worker_sandbox) argv[ac++] = "--sandbox"; /* seccomp filter (core/cli/sandbox.h) */
    char shader_dir[SVD_STORE_PATH] = "";
    if (c->worker_sandbox && atomic_load(&w->shader_state) == 1 &&
        svd_store_mktemp(store, "sc", shader_dir, &err) == SV_OK) {
        argv[ac++] = "--shader-cache";
        argv[ac++] = w->shader_db;
        argv[ac++] = "--shader-cache-dir";
        argv[ac++] = shader_dir;
    }
    argv[ac] = NULL;
#undef OWN
    run_result rr;
    memset(&rr, 0, sizeof rr);
    if (oom) { /* as a spawn that could not happen: retried */
        rr.spawn_failed = 1;
        snprintf(rr.spawn_error, sizeof rr.spawn_error,
                 "out of memory building the worker's command line");
    } else {
        run_process(w, z, t, argv, base, ppid, sizeof ppid, logpath, &rr);
    }
    if (shader_dir[0]) svd_rm_rf(shader_dir);
    for (size_t i = 0; i < no; i++) free(owned[i]);
    for (int i = 0; i <= nfiles; i++) free(inpaths[i]);
    free(inpaths);
    free(argv);
    cJSON_Delete(inputs);

    char msg[600];
    if (rr.spawn_failed) {
        svd_jobs_finish(jobs, t, SVD_OUT_FAILED, "internal", rr.spawn_error, NULL);
    } else if (rr.cancelled) {
        svd_jobs_finish(jobs, t, SVD_OUT_CANCELLED, NULL, NULL, NULL);
    } else if (rr.aborted) {
        svd_jobs_finish(jobs, t, SVD_OUT_REQUEUE, NULL, "stopped by a drain", NULL);
    } else if (rr.timed_out) {
        svd_metrics_worker_crash(svd_jobs_metrics(jobs), 1);
        snprintf(msg, sizeof msg, "worker timed out after %u s", c->job_timeout);
        svd_jobs_finish(jobs, t, SVD_OUT_RETRY, NULL, msg, NULL);
    } else if (rr.zygote_lost) { /* as a crash: retried */
        svd_metrics_worker_crash(svd_jobs_metrics(jobs), 0);
        svd_jobs_finish(jobs, t, SVD_OUT_RETRY, NULL,
                        "the worker pool's zygote died during the bake", NULL);
    } else if (WIFSIGNALED(rr.status)) {
        svd_metrics_worker_crash(svd_jobs_metrics(jobs), 0);
        signal_reason(c, &rr, logpath, msg, sizeof msg);
        svd_jobs_finish(jobs, t, SVD_OUT_RETRY, NULL, msg, NULL);
    } else if (WEXITSTATUS(rr.status) == 0 || WEXITSTATUS(rr.status) == 3) {
        /* 3: done, every output written, but the spec's target was not met
         * (sylva-bake's exit status): the status document says so ("target") */
        char *manifest = install_result(store, t->key, outdir, t, &err);
        if (manifest) svd_jobs_finish(jobs, t, SVD_OUT_DONE, NULL, NULL, manifest);
        else svd_jobs_finish(jobs, t, SVD_OUT_RETRY, NULL, err.message, NULL);
        free(manifest);
    } else if (WEXITSTATUS(rr.status) == 1) {
        char ep[SVD_STORE_PATH + 16];
        snprintf(ep, sizeof ep, "%s/error.json", outdir);
        cJSON *ej = read_json(ep, 65536);
        const cJSON *e = cJSON_GetObjectItemCaseSensitive(ej, "error");
        const char *code = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(e, "code"));
        const char *m = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(e, "message"));
        char tail[300];
        if (!m) tail_of_log(logpath, tail, sizeof tail);
        /* The input's fault fails the bake; the server's (an
         * I/O error in the store, or no error.json at all because the disk
         * was full) is retried with backoff like a crash. "nomem" is the
         * input's: what it asks for does not fit the worker's limits, and
         * would not fit them on the next attempt either. */
        bool transient = !code || strcmp(code, "io") == 0;
        snprintf(msg, sizeof msg, "%s",
                 m ? m : (tail[0] ? tail : "the worker failed without saying why (no error.json)"));
        svd_jobs_finish(jobs, t, transient ? SVD_OUT_RETRY : SVD_OUT_FAILED,
                        code ? code : (transient ? "io" : "failed"), msg, NULL);
        cJSON_Delete(ej);
    } else if (WEXITSTATUS(rr.status) == 2) {
        char tail[300];
        tail_of_log(logpath, tail, sizeof tail);
        snprintf(msg, sizeof msg, "worker usage error (exit 2): %s", tail);
        svd_jobs_finish(jobs, t, SVD_OUT_FAILED, "internal", msg, NULL);
    } else {
        svd_metrics_worker_crash(svd_jobs_metrics(jobs), 0);
        snprintf(msg, sizeof msg, "worker exited with status %d", WEXITSTATUS(rr.status));
        svd_jobs_finish(jobs, t, SVD_OUT_RETRY, NULL, msg, NULL);
    }
    svd_rm_rf(outdir);
    unlink(logpath);
}

static void *worker_main(void *arg)
{
    svd_workers *w = arg;
    svd_ticket t;
    zygote z = {0, -1}; /* this thread's, started at its first job */
    while (svd_jobs_take(w->jobs, &t)) run_job(w, &z, &t);
    zygote_stop(&z);
    return NULL;
}

/* ---- the shader cache (worker_shader_cache; workers.h) ---- */

#define WARM_TIMEOUT 120.0 /* s: the built-in scene bakes in about 2 s */

/* The warm-up thread: runs `WORKER warm-shaders DIR` (stdout, the DB's
 * path, and stderr into DIR.log), waits for it (killed after WARM_TIMEOUT
 * or by svd_workers_join), checks the path it printed and makes the DB
 * read-only. Sets shader_state to 1 or -1. */
static void *warm_main(void *arg)
{
    svd_workers *w = arg;
    svd_jobs *jobs = w->jobs;
    svd_store *store = svd_jobs_store(jobs);
    char dir[SVD_STORE_PATH] = "", logpath[SVD_STORE_PATH + 8] = "", why[SVD_PATH_MAX + 600] = "";
    int state = -1;
    pid_t pid = 0;
    /* ROOT/shaders (store.h): what an earlier daemon left there goes first */
    snprintf(dir, sizeof dir, "%s/shaders", svd_store_root(store));
    snprintf(logpath, sizeof logpath, "%s.log", dir);
    svd_rm_rf(dir);
    char *argv[] = {w->path, "warm-shaders", dir, NULL};
    int devnull = open("/dev/null", O_RDONLY | O_CLOEXEC);
    int rc = devnull < 0
                 ? errno
                 : spawn_child(w->path, argv, logpath, O_WRONLY | O_CREAT | O_TRUNC, devnull, &pid);
    if (devnull >= 0) close(devnull);
    if (rc != 0) {
        snprintf(why, sizeof why, "cannot start %s warm-shaders: %s", w->path, strerror(rc));
        goto done;
    }
    atomic_store(&w->warm_pid, pid);
    int status = 0;
    double t0 = sv_now();
    pid_t got;
    while ((got = waitpid(pid, &status, WNOHANG)) == 0 && sv_now() - t0 < WARM_TIMEOUT) {
        struct timespec ts = {0, 20 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
    if (got == 0) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
        snprintf(why, sizeof why, "warm-shaders took more than %.0f s", WARM_TIMEOUT);
    }
    atomic_store(&w->warm_pid, 0);
    if (got == 0) goto done;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        char tail[200];
        tail_of_log(logpath, tail, sizeof tail);
        snprintf(why, sizeof why, "warm-shaders failed: %s", tail);
        goto done;
    }
    /* the log's first line is the DB (the worker's stdout) */
    FILE *f = fopen(logpath, "r");
    char line[SVD_PATH_MAX] = "";
    if (f) {
        if (!fgets(line, sizeof line, f)) line[0] = 0;
        fclose(f);
    }
    line[strcspn(line, "\n")] = 0;
    char foz[SVD_PATH_MAX + 16], idx[SVD_PATH_MAX + 16];
    snprintf(foz, sizeof foz, "%s.foz", line);
    snprintf(idx, sizeof idx, "%s_idx.foz", line);
    char adir[PATH_MAX] = ""; /* the worker prints an absolute path */
    if (!realpath(dir, adir)) adir[0] = 0;
    size_t dl = strlen(adir);
    if (!dl || strncmp(line, adir, dl) != 0 || line[dl] != '/' || strstr(line, "/../") ||
        chmod(foz, 0444) != 0 || chmod(idx, 0444) != 0) {
        snprintf(why, sizeof why, "warm-shaders printed no DB under %s", dir);
        goto done;
    }
    /* and its folders, up to dir: a job runs as the daemon's user, and its
     * sandbox allows open, unlink and rename but not chmod, so it can
     * neither rewrite the DB nor put another in its place (root ignores
     * modes: run sylvad as its own user, deploy/sylvad.service) */
    for (char *slash = strrchr(line, '/'); slash && (size_t)(slash - line) >= strlen(adir);
         slash = strrchr(line, '/')) {
        *slash = 0;
        chmod(line, 0555);
        if (strlen(line) == strlen(adir)) break;
    }
    snprintf(w->shader_db, sizeof w->shader_db, "%.*s", (int)(sizeof w->shader_db - 1), foz);
    w->shader_db[strlen(w->shader_db) - 4] = 0; /* the DB's name: foz without ".foz" */
    state = 1;
done:
    unlink(logpath);
    if (state != 1) svd_rm_rf(dir);
    if (state != 1)
        svd_log_kv(svd_jobs_log(jobs), SVD_LOG_WARN, "shader_cache_unavailable", "reason", why,
                   NULL);
    else
        svd_log_kv(svd_jobs_log(jobs), SVD_LOG_INFO, "shader_cache_ready", "db", w->shader_db,
                   NULL);
    atomic_store(&w->shader_state, state);
    return NULL;
}

svd_workers *svd_workers_start(svd_jobs *jobs, const char *worker_path, unsigned count,
                               sv_error *err)
{
    svd_workers *w = calloc(1, sizeof *w);
    if (!w || !(w->threads = sv_calloc(count ? count : 1, sizeof *w->threads))) {
        free(w);
        sv_fail(err, SV_ERR_NOMEM, "workers: out of memory");
        return NULL;
    }
    w->jobs = jobs;
    snprintf(w->path, sizeof w->path, "%s", worker_path);
    const svd_config *c = svd_jobs_config(jobs);
    atomic_store(&w->shader_state, -1);
    if (c->worker_sandbox && c->worker_shader_cache) {
        atomic_store(&w->shader_state, 0);
        w->warm_started = pthread_create(&w->warm_thread, NULL, warm_main, w) == 0;
        if (!w->warm_started) atomic_store(&w->shader_state, -1);
    }
    for (unsigned i = 0; i < count; i++) {
        if (pthread_create(&w->threads[i], NULL, worker_main, w) != 0) {
            sv_fail(err, SV_ERR_INTERNAL, "cannot start worker thread %u", i);
            svd_jobs_stop(jobs);
            for (unsigned k = 0; k < i; k++) pthread_join(w->threads[k], NULL);
            free(w->threads);
            free(w);
            return NULL;
        }
        w->count++;
    }
    return w;
}

void svd_workers_join(svd_workers *w)
{
    if (!w) return;
    for (unsigned i = 0; i < w->count; i++) pthread_join(w->threads[i], NULL);
    if (w->warm_started) {
        pid_t p = atomic_load(&w->warm_pid);
        if (p > 0) kill(p, SIGKILL); /* reaped by its thread */
        pthread_join(w->warm_thread, NULL);
    }
    if (atomic_load(&w->shader_state) == 1) { /* ROOT/shaders, read-only */
        char dir[SVD_STORE_PATH];
        snprintf(dir, sizeof dir, "%s/shaders", svd_store_root(svd_jobs_store(w->jobs)));
        svd_rm_rf(dir);
    }
    free(w->threads);
    free(w);
}
