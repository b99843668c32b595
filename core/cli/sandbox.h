/* sandbox.h — the worker's seccomp filter (libseccomp).
 *
 * An allowlist of the system calls a bake makes (file I/O on descriptors and
 * paths, memory, threads and futexes, clocks, signals to itself), derived by
 * tracing real bakes of every test tree with every method, in normal and
 * sanitizer builds (docs/operations.md, "Seccomp filter"). Any other call
 * fails with EPERM, so an unforeseen harmless call degrades instead of killing
 * a bake. Network, exec, debugging, namespace/mount, kernel-module, BPF and
 * io_uring calls kill the whole process (SIGSYS): a bake never needs them, so
 * one of them means the worker was subverted. Syscalls of a foreign ABI (i386,
 * x32) kill too.
 *
 * Sanitizer builds (tests only) also allow ptrace and non-thread clone, which
 * LeakSanitizer's exit-time check needs; the network and exec kills stay.
 */
#ifndef SV_SANDBOX_H
#define SV_SANDBOX_H

#include "sv.h"

/* Installs the filter on the calling process and every thread it has (TSYNC),
 * after setting no_new_privs. Irreversible; inherited by threads started
 * later. Call once, after anything that needs a forbidden call (it needs
 * none at start: libraries are linked, not dlopen'ed, and input files are
 * opened later with plain open). SV_ERR_INTERNAL naming the step if the
 * kernel or libseccomp refuses. */
sv_status sv_sandbox_enter(sv_error *err);

#endif
