/* sandbox.c — the worker's seccomp filter (see sandbox.h).
 *
 * The lists below came from `strace -f` of real bakes (every tree of the test
 * data, every method, normal and ASan builds), keeping the calls made after
 * sv_sandbox_enter; docs/operations.md says how to redo that. Names this
 * architecture does not have (open on arm64, ...) are skipped. */
#define _GNU_SOURCE /* CLONE_THREAD */
#include "sandbox.h"

#include <errno.h>
#include <sched.h>
#include <seccomp.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>

#if defined(__SANITIZE_ADDRESS__) /* gcc */
#define SV_SANDBOX_SANITIZER 1
#elif defined(__has_feature) /* clang */
#if __has_feature(address_sanitizer) || __has_feature(leak_sanitizer)
#define SV_SANDBOX_SANITIZER 1
#endif
#endif

/* Allowed without conditions. */
static const char *const allowed[] = {
    /* files, on descriptors and paths (the inputs, the output directory) */
    "read",
    "write",
    "readv",
    "writev",
    "pread64",
    "pwrite64",
    "preadv",
    "pwritev",
    "preadv2",
    "pwritev2",
    "lseek",
    "close",
    "close_range",
    "open",
    "openat",
    "creat",
    "stat",
    "fstat",
    "lstat",
    "newfstatat",
    "statx",
    "statfs",
    "fstatfs",
    "access",
    "faccessat",
    "faccessat2",
    "readlink",
    "readlinkat",
    "getdents",
    "getdents64",
    "getcwd",
    "mkdir",
    "mkdirat",
    "unlink",
    "unlinkat",
    "rename",
    "renameat",
    "renameat2",
    "ftruncate",
    "fsync",
    "fdatasync",
    "fadvise64",
    "fallocate",
    "flock",
    "fcntl",
    "dup",
    "dup2",
    "dup3",
    "pipe",
    "pipe2",
    "poll",
    "ppoll",
    "select",
    "pselect6",
    "umask",
    /* memory (llvmpipe JITs its shaders: PROT_EXEC mappings) */
    "brk",
    "mmap",
    "munmap",
    "mremap",
    "mprotect",
    "madvise",
    "msync",
    "mincore",
    "membarrier",
    /* threads (llvmpipe's rasteriser, OIIO's pool, the billboard-cloud workers) */
    "futex",
    "futex_waitv",
    "set_robust_list",
    "get_robust_list",
    "set_tid_address",
    "rseq",
    "gettid",
    "sched_yield",
    "sched_getaffinity",
    "sched_setaffinity",
    "sched_getparam",
    "sched_getscheduler",
    "sched_get_priority_max",
    "sched_get_priority_min",
    "getpriority",
    "setpriority",
    "arch_prctl",
    "exit",
    "exit_group",
    /* signals to itself (abort, sanitizer reports) */
    "rt_sigaction",
    "rt_sigprocmask",
    "rt_sigreturn",
    "sigaltstack",
    "tgkill",
    "tkill",
    "getpid",
    "getppid",
    /* clocks, identity, limits, randomness */
    "clock_gettime",
    "clock_getres",
    "clock_nanosleep",
    "nanosleep",
    "gettimeofday",
    "time",
    "getrusage",
    "times",
    "getuid",
    "geteuid",
    "getgid",
    "getegid",
    "getresuid",
    "getresgid",
    "uname",
    "sysinfo",
    "getrlimit",
    "getrandom",
};

/* Kill the process: a bake never needs these; one of them means the worker
 * runs code it was not built with (network, exec, tracing other processes,
 * namespaces and mounts, kernel interfaces, io_uring which bypasses seccomp). */
static const char *const killed[] = {
    "socket",
    "socketpair",
    "connect",
    "bind",
    "listen",
    "accept",
    "accept4",
    "sendto",
    "sendmsg",
    "sendmmsg",
    "recvfrom",
    "recvmsg",
    "recvmmsg",
    "getsockopt",
    "setsockopt",
    "getsockname",
    "getpeername",
    "shutdown",
    "execve",
    "execveat",
#if !defined(SV_SANDBOX_SANITIZER)
    "ptrace",
#endif
    "process_vm_readv",
    "process_vm_writev",
    "pidfd_open",
    "pidfd_getfd",
    "kcmp",
    "mount",
    "umount2",
    "move_mount",
    "fsopen",
    "fsmount",
    "fsconfig",
    "fspick",
    "open_tree",
    "mount_setattr",
    "pivot_root",
    "chroot",
    "unshare",
    "setns",
    "bpf",
    "perf_event_open",
    "userfaultfd",
    "init_module",
    "finit_module",
    "delete_module",
    "kexec_load",
    "kexec_file_load",
    "reboot",
    "swapon",
    "swapoff",
    "iopl",
    "ioperm",
    "keyctl",
    "add_key",
    "request_key",
    "open_by_handle_at",
    "name_to_handle_at",
    "io_uring_setup",
    "io_uring_enter",
    "io_uring_register",
};

static sv_status add_rules(scmp_filter_ctx ctx, const char *const *names, size_t n, uint32_t action,
                           sv_error *err)
{
    for (size_t i = 0; i < n; i++) {
        int nr = seccomp_syscall_resolve_name(names[i]);
        if (nr < 0) continue; /* not on this architecture (or a multiplexed pseudo-call) */
        int rc = seccomp_rule_add(ctx, action, nr, 0);
        if (rc < 0)
            return sv_fail(err, SV_ERR_INTERNAL, "sandbox: rule for %s: %s", names[i],
                           strerror(-rc));
    }
    return SV_OK;
}

/* Argument `arg` == v, written out: the SCMP_A0 macros' partial
 * initialisers trip clang's -Wmissing-field-initializers. */
static struct scmp_arg_cmp arg_eq(unsigned arg, scmp_datum_t v)
{
    struct scmp_arg_cmp c = {.arg = arg, .op = SCMP_CMP_EQ, .datum_a = v, .datum_b = 0};
    return c;
}

/* Calls allowed only with some arguments. */
static sv_status add_conditional(scmp_filter_ctx ctx, sv_error *err)
{
    int rc = 0;
#if defined(SV_SANDBOX_SANITIZER)
    /* LeakSanitizer's exit-time check clones a tracer task (no CLONE_THREAD)
     * that ptraces (and waits for) the threads, after PR_SET_PTRACER and
     * PR_SET_PDEATHSIG; if one of these fails it hangs. Sanitizer builds
     * (tests) allow them; the network and exec kills stay. */
    rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(clone), 0);
    if (rc == 0) rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(ptrace), 0);
    if (rc == 0) rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(wait4), 0);
    if (rc == 0) rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(waitid), 0);
    static const int prctl_lsan[] = {PR_SET_PTRACER, PR_SET_PDEATHSIG, PR_SET_DUMPABLE};
    for (size_t i = 0; rc == 0 && i < sizeof prctl_lsan / sizeof prctl_lsan[0]; i++)
        rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(prctl), 1,
                              arg_eq(0, (scmp_datum_t)prctl_lsan[i]));
#else
    /* Threads only: clone without CLONE_THREAD (fork) fails with EPERM. */
    struct scmp_arg_cmp thread = {
        .arg = 0, .op = SCMP_CMP_MASKED_EQ, .datum_a = CLONE_THREAD, .datum_b = CLONE_THREAD};
    rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(clone), 1, thread);
#endif
    /* clone3's flags are in memory, out of the filter's reach: ENOSYS makes
     * glibc's pthread_create fall back to clone, which is checked above. */
    if (rc == 0) rc = seccomp_rule_add(ctx, SCMP_ACT_ERRNO(ENOSYS), SCMP_SYS(clone3), 0);
    /* prlimit64 on itself (getrlimit/setrlimit); lowering or raising a soft
     * limit up to the hard one the daemon set is harmless. */
    if (rc == 0) rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(prlimit64), 1, arg_eq(0, 0));
    /* ioctl: isatty() and the terminal size only (stderr progress). */
    static const unsigned long ioctl_ok[] = {TCGETS, TIOCGWINSZ};
    for (size_t i = 0; rc == 0 && i < sizeof ioctl_ok / sizeof ioctl_ok[0]; i++)
        rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(ioctl), 1,
                              arg_eq(1, (scmp_datum_t)ioctl_ok[i]));
    /* prctl: thread names and reading the dumpable flag only. */
    static const int prctl_ok[] = {PR_SET_NAME, PR_GET_NAME, PR_GET_DUMPABLE};
    for (size_t i = 0; rc == 0 && i < sizeof prctl_ok / sizeof prctl_ok[0]; i++)
        rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, SCMP_SYS(prctl), 1,
                              arg_eq(0, (scmp_datum_t)prctl_ok[i]));
    if (rc < 0)
        return sv_fail(err, SV_ERR_INTERNAL, "sandbox: conditional rule: %s", strerror(-rc));
    return SV_OK;
}

sv_status sv_sandbox_enter(sv_error *err)
{
    scmp_filter_ctx ctx = seccomp_init(SCMP_ACT_ERRNO(EPERM));
    if (!ctx) return sv_fail(err, SV_ERR_INTERNAL, "sandbox: seccomp_init failed");
    sv_status st = SV_OK;
    int rc = seccomp_attr_set(ctx, SCMP_FLTATR_ACT_BADARCH, SCMP_ACT_KILL_PROCESS);
    if (rc == 0) rc = seccomp_attr_set(ctx, SCMP_FLTATR_CTL_NNP, 1);
    if (rc == 0) rc = seccomp_attr_set(ctx, SCMP_FLTATR_CTL_TSYNC, 1);
    if (rc < 0) st = sv_fail(err, SV_ERR_INTERNAL, "sandbox: filter attribute: %s", strerror(-rc));
    if (st == SV_OK)
        st = add_rules(ctx, allowed, sizeof allowed / sizeof allowed[0], SCMP_ACT_ALLOW, err);
    if (st == SV_OK)
        st = add_rules(ctx, killed, sizeof killed / sizeof killed[0], SCMP_ACT_KILL_PROCESS, err);
    if (st == SV_OK) st = add_conditional(ctx, err);
    if (st == SV_OK && (rc = seccomp_load(ctx)) < 0)
        st = sv_fail(err, SV_ERR_INTERNAL, "sandbox: cannot load the seccomp filter: %s",
                     strerror(-rc));
    seccomp_release(ctx);
    return st;
}
