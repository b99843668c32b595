/* workers.c — supervised sylva-bake processes (see workers.h). The pattern is
 * Redis' child handling: a pipe for reports, waitpid, WIFSIGNALED = failure. */
#define _GNU_SOURCE /* pipe2, prlimit */
#include "workers.h"

#include <cjson/cJSON.h>
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
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

struct svd_workers {
    svd_jobs *jobs;
    char path[SVD_PATH_MAX];
    unsigned count;
    pthread_t *threads;
};

static cJSON *read_json(const char *path, size_t max)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    char *buf = malloc(max);
    size_t n = buf ? fread(buf, 1, max, f) : 0;
    fclose(f);
    cJSON *j = buf ? cJSON_ParseWithLength(buf, n) : NULL;
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
    int status;        /* waitpid status */
    int timed_out, cancelled, aborted, spawn_failed;
    char spawn_error[256];
    struct rusage ru;  /* of the reaped worker (wait4) */
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

static void handle_line(svd_jobs *jobs, svd_ticket *t, const char *line)
{
    cJSON *j = cJSON_Parse(line);
    const char *stage = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(j, "stage"));
    const cJSON *pr = cJSON_GetObjectItemCaseSensitive(j, "progress");
    const cJSON *tk = cJSON_GetObjectItemCaseSensitive(j, "try");
    const cJSON *tn = cJSON_GetObjectItemCaseSensitive(j, "tries");
    if (stage)
        svd_jobs_progress(jobs, t, stage, cJSON_IsNumber(pr) ? pr->valuedouble : -1,
                          cJSON_IsNumber(tk) ? tk->valueint : 0, cJSON_IsNumber(tn) ? tn->valueint : 0);
    cJSON_Delete(j);
}

static void run_process(svd_workers *w, svd_ticket *t, char **argv, const char *logpath,
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
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t at;
    posix_spawn_file_actions_init(&fa);
    posix_spawnattr_init(&at);
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 1, logpath, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    posix_spawn_file_actions_adddup2(&fa, p[1], 3); /* dup2 clears FD_CLOEXEC on fd 3 */
    sigset_t none, def;
    sigemptyset(&none);
    sigfillset(&def);
    sigdelset(&def, SIGKILL);
    sigdelset(&def, SIGSTOP);
    posix_spawnattr_setsigmask(&at, &none);
    posix_spawnattr_setsigdefault(&at, &def);
    posix_spawnattr_setpgroup(&at, 0);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETPGROUP);
    pid_t pid;
    int rc = posix_spawn(&pid, argv[0], &fa, &at, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&at);
    close(p[1]);
    if (rc != 0) {
        close(p[0]);
        rr->spawn_failed = 1;
        snprintf(rr->spawn_error, sizeof rr->spawn_error, "cannot start %s: %s", argv[0], strerror(rc));
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
    char line[4096];
    size_t ll = 0;
    int eof = 0, killed = 0, reaped = 0;
    while (!reaped) {
        double now = sv_now();
        if (!killed) {
            const char *why = NULL;
            if (now >= deadline) rr->timed_out = 1, why = "timeout";
            else if (svd_jobs_cancelled(jobs, t)) rr->cancelled = 1, why = "cancel";
            else if (svd_jobs_aborting(jobs)) rr->aborted = 1, why = "drain";
            if (why) {
                kill(-pid, SIGKILL); /* the whole process group */
                kill(pid, SIGKILL);
                killed = 1;
                svd_log_kv(svd_jobs_log(jobs), SVD_LOG_WARN, "worker_killed", "key", t->key,
                           "reason", why, (const char *)NULL);
            }
        }
        if (!eof) {
            struct pollfd pfd = {.fd = p[0], .events = POLLIN};
            int ms = (int)((deadline - now) * 1000);
            if (ms > 100) ms = 100;
            if (ms < 0) ms = 0;
            int pr = poll(&pfd, 1, ms);
            if (pr > 0) {
                char buf[4096];
                ssize_t n = read(p[0], buf, sizeof buf);
                if (n <= 0 && !(n < 0 && errno == EINTR)) eof = 1;
                for (ssize_t i = 0; i < n; i++) {
                    if (buf[i] == '\n') {
                        line[ll] = '\0';
                        handle_line(jobs, t, line);
                        ll = 0;
                    } else if (ll + 1 < sizeof line) {
                        line[ll++] = buf[i];
                    }
                }
            }
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
    struct dirent *e;
    while ((e = readdir(d)) && n < 512) {
        if (!svd_name_valid(e->d_name) || e->d_name[0] == '.' || strcmp(e->d_name, "manifest.json") == 0)
            continue;
        char p[SVD_STORE_PATH + 300];
        snprintf(p, sizeof p, "%s/%s", outdir, e->d_name);
        struct stat sb;
        if (lstat(p, &sb) != 0 || !S_ISREG(sb.st_mode)) continue;
        names[n] = strdup(e->d_name);
        if (names[n]) n++;
    }
    closedir(d);
    qsort(names, n, sizeof names[0], cmp_str);
    cJSON *m = cJSON_CreateObject();
    cJSON_AddStringToObject(m, "key", key);
    cJSON *arr = cJSON_AddArrayToObject(m, "artifacts");
    sv_status st = n ? SV_OK : sv_fail(err, SV_ERR_IO, "the worker exited 0 but wrote no artifacts");
    for (size_t i = 0; i < n && st == SV_OK; i++) {
        char p[SVD_STORE_PATH + 300], h[SVD_KEY_HEX];
        uint64_t size = 0;
        snprintf(p, sizeof p, "%s/%s", outdir, names[i]);
        st = svd_sha256_file(p, h, &size, err);
        if (st != SV_OK) break;
        cJSON *a = cJSON_CreateObject();
        cJSON_AddStringToObject(a, "name", names[i]);
        cJSON_AddNumberToObject(a, "size", (double)size);
        cJSON_AddStringToObject(a, "sha256", h);
        cJSON_AddItemToArray(arr, a);
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
            cJSON_ArrayForEach(x, w)
                if (wl && cJSON_IsString(x)) cJSON_AddItemToArray(wl, cJSON_CreateString(x->valuestring));
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
static void signal_reason(const svd_config *c, const run_result *rr, const char *logpath,
                          char *msg, size_t cap)
{
    int sig = WTERMSIG(rr->status);
    double cpu = (double)rr->ru.ru_utime.tv_sec + rr->ru.ru_utime.tv_usec / 1e6 +
                 (double)rr->ru.ru_stime.tv_sec + rr->ru.ru_stime.tv_usec / 1e6;
    if (c->worker_cpu_seconds &&
        (sig == SIGXCPU || (sig == SIGKILL && cpu >= 0.8 * c->worker_cpu_seconds))) {
        snprintf(msg, cap,
                 "worker killed by signal %d after %.1f s of CPU: the CPU time limit of %u s (RLIMIT_CPU)",
                 sig, cpu, c->worker_cpu_seconds);
        return;
    }
    char tail[300];
    tail_of_log(logpath, tail, sizeof tail);
    if (c->worker_as_bytes && (sig == SIGABRT || sig == SIGSEGV || sig == SIGBUS) &&
        (strstr(tail, "bad_alloc") || strcasestr(tail, "out of memory") ||
         strcasestr(tail, "cannot allocate memory") || strstr(tail, "MemoryError"))) {
        snprintf(msg, cap,
                 "worker killed by signal %d out of memory: the address-space limit of %llu bytes (RLIMIT_AS)",
                 sig, (unsigned long long)c->worker_as_bytes);
        return;
    }
    snprintf(msg, cap, "worker killed by signal %d", sig);
}

static void run_job(svd_workers *w, svd_ticket *t)
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
        svd_jobs_finish(jobs, t, SVD_OUT_RETRY, NULL, "out of memory building the worker's command line", NULL);
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
    /* the worker dies with the daemon (PR_SET_PDEATHSIG; issue 22 item 9) */
    char ppid[24];
    snprintf(ppid, sizeof ppid, "%ld", (long)getpid());
    argv[ac++] = "--parent-pid";
    argv[ac++] = ppid;
    if (c->worker_sandbox) argv[ac++] = "--sandbox"; /* seccomp filter (core/sandbox.h) */
    argv[ac] = NULL;
#undef OWN
    run_result rr;
    memset(&rr, 0, sizeof rr);
    if (oom) { /* as a spawn that could not happen: retried */
        rr.spawn_failed = 1;
        snprintf(rr.spawn_error, sizeof rr.spawn_error, "out of memory building the worker's command line");
    } else {
        run_process(w, t, argv, logpath, &rr);
    }
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
        /* Issue 22 item 2: the input's fault fails the bake; the server's (an
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
    while (svd_jobs_take(w->jobs, &t)) run_job(w, &t);
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
    free(w->threads);
    free(w);
}
