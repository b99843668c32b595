/* zygote.c — `sylva-bake zygote` (see zygote.h; protocol in zygote_proto.h).
 *
 * The loop: say hello; then, per job, receive the argv and two fds, fork,
 * report the pid, wait for the child (a pidfd, or a 50 ms poll when the
 * kernel has none) while serving kill requests, kill what is left of the
 * child's process group, reap it (wait4: status and rusage) and report.
 *
 * The child does what posix_spawn and prlimit(2) did for an exec'ed worker:
 * its own process group, stdin /dev/null, stdout and stderr to the job's
 * log, the progress pipe on fd 3, every other fd closed, signal mask and
 * dispositions reset, the same rlimits (AS, CPU, NOFILE, FSIZE, CORE = 0),
 * the nice value; then PR_SET_PDEATHSIG against the zygote and cmd_bake
 * with the job's arguments, which enters the seccomp sandbox where it
 * always does.
 */
#define _GNU_SOURCE /* close_range, pidfd_open */
#include "zygote.h"

#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/pidfd.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "image.h"
#include "image_io.h"
#include "zygote_proto.h"

/* Tasks (threads) of this process, from /proc/self/task; -1 if unreadable. */
static int thread_count(void)
{
    DIR *d = opendir("/proc/self/task");
    if (!d) return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        if (e->d_name[0] != '.') n++;
    closedir(d);
    return n;
}

/* Stops the threads a library started when it was loaded, where it can be
 * told to. One is known: log4cplus 2.0 (linked by libopenvdb, an
 * OpenImageIO plugin's dependency) starts a pool of idle threads in a static
 * initializer; log4cplus::shutdownThreadPool joins them (log4cplus then logs
 * synchronously, which nothing in a bake asks it to anyway). Looked up with
 * dlsym so that sylva neither builds against log4cplus nor needs it: in the
 * image plugin's scope (libsvimage.so pulls OIIO in, loaded privately), or
 * the global one. Returns the threads left, waiting up to 0.2 s for joined
 * ones to leave /proc. */
static int stop_library_threads(void)
{
    void (*shutdown_pool)(void) = NULL;
    const char *name = "_ZN9log4cplus18shutdownThreadPoolEv";
    void *sym = sv_image_plugin_symbol(name);
    if (!sym) sym = dlsym(RTLD_DEFAULT, name);
    memcpy(&shutdown_pool, &sym, sizeof sym); /* (ISO C has no object-to-function cast) */
    if (shutdown_pool) shutdown_pool();
    int n = thread_count();
    for (int i = 0; i < 20 && n > 1; i++) {
        struct timespec ts = {0, 10 * 1000 * 1000};
        nanosleep(&ts, NULL);
        n = thread_count();
    }
    return n;
}

static int send_msg(int fd, const void *m, size_t len)
{
    ssize_t r;
    do r = send(fd, m, len, MSG_NOSIGNAL);
    while (r < 0 && errno == EINTR);
    return r == (ssize_t)len ? 0 : -1;
}

/* Receives one message and at most two fds. Returns its length, 0 at EOF,
 * -1 on error; *nfds the fds received (closed by the caller). */
static ssize_t recv_msg(int fd, void *buf, size_t cap, int fds[2], int *nfds)
{
    char cbuf[CMSG_SPACE(2 * sizeof(int))];
    struct iovec iov = {buf, cap};
    struct msghdr mh = {
        .msg_iov = &iov, .msg_iovlen = 1, .msg_control = cbuf, .msg_controllen = sizeof cbuf};
    ssize_t n;
    do n = recvmsg(fd, &mh, MSG_CMSG_CLOEXEC);
    while (n < 0 && errno == EINTR);
    *nfds = 0;
    for (struct cmsghdr *c = CMSG_FIRSTHDR(&mh); c; c = CMSG_NXTHDR(&mh, c)) {
        if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_RIGHTS) continue;
        size_t k = (c->cmsg_len - CMSG_LEN(0)) / sizeof(int);
        for (size_t i = 0; i < k; i++) {
            int f;
            memcpy(&f, CMSG_DATA(c) + i * sizeof(int), sizeof f);
            if (*nfds < 2) fds[(*nfds)++] = f;
            else close(f);
        }
    }
    if (n > 0 && (mh.msg_flags & (MSG_TRUNC | MSG_CTRUNC))) return -1;
    return n;
}

static void set_limit(int what, uint64_t v)
{
    struct rlimit r = {(rlim_t)v, (rlim_t)v};
    setrlimit(what, &r);
}

/* The forked child: never returns. */
static void run_child(const svz_run *rq, char **argv, int logfd, int progfd, pid_t zygote,
                      char *title, size_t title_room, sv_zygote_bake_fn bake)
{
    /* the daemon kills by process group (through the zygote) */
    setpgid(0, 0);
    /* dies with the zygote, which dies with the daemon */
    if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || getppid() != zygote) _exit(1);
    /* fds above 3 first, so the dup2s below cannot overwrite one another */
    int lf = fcntl(logfd, F_DUPFD, 10), pf = fcntl(progfd, F_DUPFD, 10);
    int nul = open("/dev/null", O_RDONLY);
    if (lf < 0 || pf < 0 || nul < 0 || dup2(nul, 0) < 0 || dup2(lf, 1) < 0 || dup2(lf, 2) < 0 ||
        dup2(pf, 3) < 0)
        _exit(127);
    /* like an exec: nothing else open (O_CLOEXEC fds would have gone) */
    if (close_range(4, ~0u, 0) != 0)
        for (int f = 4; f < 4096; f++) close(f);
    sigset_t none;
    sigemptyset(&none);
    for (int s = 1; s < NSIG; s++)
        if (s != SIGKILL && s != SIGSTOP) signal(s, SIG_DFL);
    sigprocmask(SIG_SETMASK, &none, NULL);
    if (rq->as_bytes) set_limit(RLIMIT_AS, rq->as_bytes); /* 0 = no address-space limit */
    set_limit(RLIMIT_CPU, rq->cpu_seconds);
    set_limit(RLIMIT_NOFILE, rq->nofile);
    set_limit(RLIMIT_FSIZE, rq->fsize_bytes);
    set_limit(RLIMIT_CORE, 0);
    /* before the bake starts its render threads (they inherit it); EPERM
     * (below the daemon's own nice) keeps the zygote's, as before */
    if (rq->nice) setpriority(PRIO_PROCESS, 0, rq->nice);
    if (title && title_room > 1) { /* ps / pgrep -f: the job's command line */
        size_t at = 0;
        memset(title, 0, title_room);
        for (uint32_t i = 0; i < rq->argc && at + 1 < title_room; i++) {
            size_t l = strlen(argv[i]);
            if (l > title_room - 1 - at) l = title_room - 1 - at;
            memcpy(title + at, argv[i], l);
            at += l + 1;
        }
    }
    prctl(PR_SET_NAME, "sylva-bake", 0, 0, 0);
    /* argv: WORKER bake ARGS...: what main would have passed to cmd_bake */
    exit(bake((int)rq->argc - 2, argv + 2));
}

/* Waits for the child, serving kill requests; kills what is left of its
 * group, reaps it and reports. -1 when the daemon is gone (the child then
 * killed and reaped too). */
static int wait_child(int fd, pid_t pid)
{
    int pidfd = pidfd_open(pid, 0);
    int gone = 0, exited = 0;
    while (!exited) {
        struct pollfd p[2] = {{.fd = fd, .events = POLLIN}, {.fd = pidfd, .events = POLLIN}};
        int r = poll(p, pidfd >= 0 ? 2 : 1, pidfd >= 0 ? -1 : 50);
        if (r < 0 && errno != EINTR) break;
        if (r > 0 && (p[0].revents & (POLLIN | POLLHUP | POLLERR))) {
            svz_kill k;
            int fds[2], nf;
            ssize_t n = recv_msg(fd, &k, sizeof k, fds, &nf);
            for (int i = 0; i < nf; i++) close(fds[i]);
            if (n <= 0) { /* the daemon went away: so does the job */
                gone = 1;
                kill(-pid, SIGKILL);
                kill(pid, SIGKILL);
                break;
            }
            if ((size_t)n == sizeof k && k.type == SVZ_KILL && k.pid == pid) {
                kill(-pid, SIGKILL); /* the whole process group */
                kill(pid, SIGKILL);
            }
        }
        siginfo_t si;
        memset(&si, 0, sizeof si);
        if (waitid(P_PID, (id_t)pid, &si, WEXITED | WNOHANG | WNOWAIT) == 0 && si.si_pid == pid)
            exited = 1;
    }
    /* still unreaped, so the pid (and group id) cannot have been reused:
     * leftovers the worker may have started go with it */
    kill(-pid, SIGKILL);
    svz_exited ex = {.type = SVZ_EXITED, .pid = pid};
    int st = 0;
    while (wait4(pid, &st, 0, &ex.ru) < 0 && errno == EINTR) {}
    ex.status = st;
    if (pidfd >= 0) close(pidfd);
    if (gone) return -1;
    return send_msg(fd, &ex, sizeof ex);
}

int sv_zygote_serve(int fd, long parent, char *title, size_t title_room, sv_zygote_bake_fn bake)
{
    if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || (parent > 0 && getppid() != (pid_t)parent))
        return 1;
    pid_t self = getpid();
    /* The image plugin once, here, for every job (most decode textures):
     * OIIO's start-up (docs/benchmarks.md) is paid once per zygote, and its threads are
     * stopped below before any fork. A plugin that cannot load is each job's
     * error, as without the pool. */
    sv_error perr = {0};
    (void)sv_image_plugin_load(&perr);
    int threads = stop_library_threads();
    svz_hello h = {.type = SVZ_HELLO, .version = SVZ_VERSION, .pid = self, .threads = threads};
    if (send_msg(fd, &h, sizeof h) != 0) return 1;
    if (threads != 1) return 1; /* the daemon reads why from the hello */
    char *buf = malloc(SVZ_MAX_MSG + 1);
    if (!buf) return 1;
    int rc = 0;
    for (;;) {
        int fds[2], nf;
        ssize_t n = recv_msg(fd, buf, SVZ_MAX_MSG, fds, &nf);
        if (n == 0) break; /* the daemon closed: done */
        svz_run rq;
        char **argv = NULL;
        if (n >= (ssize_t)sizeof rq) {
            memcpy(&rq, buf, sizeof rq);
            if (rq.type != SVZ_RUN || nf != 2 || rq.argc < 3 || rq.argc > 65536) argv = NULL;
            else argv = calloc((size_t)rq.argc + 1, sizeof *argv);
        }
        /* the strings: exactly argc, NUL-terminated, filling the message */
        size_t at = sizeof rq;
        buf[n > 0 ? n : 0] = '\0';
        for (uint32_t i = 0; argv && i < rq.argc; i++) {
            if (at >= (size_t)n) {
                free(argv);
                argv = NULL;
                break;
            }
            argv[i] = buf + at;
            at += strlen(buf + at) + 1;
        }
        if (argv && (at != (size_t)n || strcmp(argv[1], "bake") != 0)) {
            free(argv);
            argv = NULL;
        }
        if (!argv) { /* a kill that came too late is harmless; anything else is not */
            for (int i = 0; i < nf; i++) close(fds[i]);
            if (n == (ssize_t)sizeof(svz_kill) && ((svz_kill *)(void *)buf)->type == SVZ_KILL)
                continue;
            rc = 1;
            break;
        }
        svz_started s = {.type = SVZ_STARTED};
        if (thread_count() != 1) { /* something started a thread since the hello */
            s.err = EDEADLK;
        } else {
            fflush(NULL); /* no stdio buffer written twice */
            pid_t pid = fork();
            if (pid == 0) run_child(&rq, argv, fds[0], fds[1], self, title, title_room, bake);
            if (pid < 0) s.err = errno;
            else {
                setpgid(pid, pid); /* as the child does: a kill cannot precede it */
                s.pid = pid;
            }
        }
        close(fds[0]);
        close(fds[1]);
        free(argv);
        if (send_msg(fd, &s, sizeof s) != 0) {
            if (s.pid > 0) {
                kill(-s.pid, SIGKILL);
                kill(s.pid, SIGKILL);
                waitpid(s.pid, NULL, 0);
            }
            rc = 1;
            break;
        }
        if (s.pid > 0 && wait_child(fd, s.pid) != 0) {
            rc = 1;
            break;
        }
        if (s.err == EDEADLK) {
            rc = 1;
            break;
        }
    }
    free(buf);
    return rc;
}
