/* zygote.h — `sylva-bake zygote`: the resident worker of sylvad's pool
 * (the protocol is common/zygote_proto.h, the design
 * docs/design.md "The worker pool").
 *
 * A process that has loaded sylva-bake's libraries once (OpenImageIO,
 * assimp, Mesa: about half a second of CPU at every exec) and forks one
 * child per job. It is single-threaded and holds no GL context; it refuses
 * to fork (says so in its hello) when it finds more than one thread.
 */
#ifndef SV_ZYGOTE_H
#define SV_ZYGOTE_H

#include <stddef.h>

/* What a forked child runs: sylva-bake's `bake` command with the job's
 * arguments after "bake"; returns its exit status. */
typedef int (*sv_zygote_bake_fn)(int argc, char **argv);

/* Serves the daemon on control_fd until it closes it (returns 0) or breaks
 * the protocol (returns 1). parent: the daemon's pid; the zygote dies with
 * it (PR_SET_PDEATHSIG) and returns 1 at once when it is already gone.
 * title/title_room: the process's own argv area (argv[0] up to the end of
 * its last string), overwritten in each child with the job's command line so
 * that ps and pgrep see a child as they see an exec'ed worker; NULL/0 to
 * leave it. Each child ends with exit(bake(...)) and never returns here. */
int sv_zygote_serve(int control_fd, long parent, char *title, size_t title_room,
                    sv_zygote_bake_fn bake);

#endif
