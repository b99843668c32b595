/* zygote_proto.h — the wire format between sylvad's worker threads and
 * `sylva-bake zygote` (docs/design.md, "The worker pool").
 *
 * One zygote per daemon worker thread, on a SOCK_SEQPACKET unix socketpair
 * (one message per send, boundaries kept, SCM_RIGHTS beside the data). All
 * integers are in host order: both ends run on the same machine from the
 * same build (the zygote's hello carries SVZ_VERSION; a mismatch refuses the
 * pool).
 *
 *   zygote -> daemon  svz_hello     once, when it is ready to fork
 *   daemon -> zygote  svz_run       + the job's argv (argc NUL-terminated
 *                                   strings) in the same message, + two fds
 *                                   (SCM_RIGHTS): the log (the child's
 *                                   stdout and stderr) and the progress
 *                                   pipe's write end (the child's fd 3)
 *   zygote -> daemon  svz_started   right after fork (pid), or err != 0
 *                                   (errno: nothing was started)
 *   daemon -> zygote  svz_kill      (optional) a timeout, DELETE or drain:
 *                                   SIGKILL the child's process group
 *   zygote -> daemon  svz_exited    once the child has exited: its wait
 *                                   status and rusage (wait4), sent after
 *                                   the zygote killed what was left of the
 *                                   child's process group and reaped it
 *
 * A zygote serves one job at a time. The daemon never sends a second run
 * before the exited message of the first.
 *
 * PID reuse: only the zygote signals the child, and only before it reaps it
 * (it waits with WNOWAIT, kills what is left of the group, then reaps), so a
 * signal can never reach a process that reused the pid. The daemon signals
 * only its own child, the zygote (whose death takes the job with it:
 * the child's PR_SET_PDEATHSIG).
 */
#ifndef SV_ZYGOTE_PROTO_H
#define SV_ZYGOTE_PROTO_H

#include <stdint.h>
#include <sys/resource.h>

#define SVZ_VERSION 1u
#define SVZ_MAX_MSG \
    (128u * 1024u) /* a run message, header + argv, at most (well
                                      below a unix socket's default send buffer); a
                                      longer command line runs by exec */
#define SVZ_TITLE_ROOM \
    4096 /* bytes of argv the zygote is started with, so a
                                      child can show its job's command line in ps */

enum { SVZ_HELLO = 1, SVZ_RUN = 2, SVZ_STARTED = 3, SVZ_EXITED = 4, SVZ_KILL = 5 };

typedef struct svz_hello {
    uint32_t type;    /* SVZ_HELLO */
    uint32_t version; /* SVZ_VERSION */
    int32_t pid;      /* the zygote's, for the child's --parent-pid */
    int32_t threads;  /* tasks in the zygote when it said hello; 1, or it refuses to fork */
} svz_hello;

typedef struct svz_run {
    uint32_t type;                             /* SVZ_RUN */
    uint32_t argc;                             /* strings that follow this header */
    uint64_t as_bytes;                         /* RLIMIT_AS, 0 = none */
    uint64_t cpu_seconds, nofile, fsize_bytes; /* RLIMIT_CPU, _NOFILE, _FSIZE */
    int32_t nice;                              /* setpriority of the child, 0 = the zygote's */
    int32_t pad;
} svz_run;

typedef struct svz_started {
    uint32_t type; /* SVZ_STARTED */
    int32_t pid;   /* the child, its own process group leader; 0 when err */
    int32_t err;   /* errno of a failed fork, 0 */
    int32_t pad;
} svz_started;

typedef struct svz_exited {
    uint32_t type; /* SVZ_EXITED */
    int32_t pid;
    int32_t status; /* as from waitpid */
    int32_t pad;
    struct rusage ru;
} svz_exited;

typedef struct svz_kill {
    uint32_t type; /* SVZ_KILL */
    int32_t pid;   /* the child it is meant for (ignored when it is not the current one) */
} svz_kill;

#endif
