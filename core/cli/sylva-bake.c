/* sylva-bake — the offline baker and the daemon's worker.
 *
 *   sylva-bake info MESH [FILES...] [--spec SPEC.json] [--json] [--cpu-limit S]
 *   sylva-bake bake MESH [FILES...] --spec SPEC.json --out DIR [--progress-fd N] [--sandbox]
 *                   [--cpu-limit S]
 *   sylva-bake check-spec SPEC.json
 *   sylva-bake sandbox-selftest [socket|exec]     (testing: see cmd_sandbox_selftest)
 *   sylva-bake zygote --control-fd N --parent-pid P  (sylvad's worker pool: zygote.h)
 *
 * Exit status: 0 success; 1 the input was refused or the bake failed (one line
 * on stderr; with bake, DIR/error.json holds {"error":{"code","message"}});
 * 2 usage; 3 (bake) the spec's "target" was not met: every output is written
 * (the best try's bake) and stderr says why (report.json target.reason).
 * Anything else (a signal) is a crash. sylvad takes 0 and 3 as done.
 *
 * CPU-time guard: every info and bake runs under RLIMIT_CPU, so a
 * file that makes a reader spin cannot keep a core busy forever. The limit is
 * --cpu-limit S; without it, the RLIMIT_CPU the process inherited (ulimit -t,
 * sylvad's worker_cpu_seconds through prlimit) when there is one, else
 * SV_DEFAULT_CPU_LIMIT; --cpu-limit 0 sets none of its own. A limit is never
 * raised above the inherited hard limit. The soft limit sits a little below
 * the hard one, so SIGXCPU comes first: its handler writes one line on stderr
 * (and, for bake, DIR/error.json with code "limit") and exits 1, which sylvad
 * records as a permanent failure instead of retrying the same spin.
 */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/personality.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "image.h"
#include "image_io.h"
#include "out_names.h"
#include "pipeline.h"
#include "view.h"
#include "warm_shaders.h"
#include "sandbox.h"
#include "spec.h"
#include "zygote.h"
#include "zygote_proto.h"
#include "companions.h"
#include "error_body.h"
#include "spec_flags.h"
#include "summary_table.h"

#define MAX_FILES 256
#define EXIT_TARGET_UNMET 3      /* bake: outputs written, the spec's target not met */
#define SV_DEFAULT_CPU_LIMIT 600 /* seconds of CPU time */

#ifndef SYLVA_DOC_DIR
#define SYLVA_DOC_DIR "/usr/local/share/doc/sylva"
#endif

static const char usage[] =
    "usage: sylva-bake info MESH [FILES...] [--json] [--spec SPEC.json] [SPEC FLAGS]\n"
    "                       [-q|--quiet] [-v|--verbose] [--cpu-limit S]\n"
    "       sylva-bake bake MESH [FILES...] -o|--out DIR [--spec SPEC.json] [SPEC FLAGS]\n"
    "                       [-q|--quiet] [-v|--verbose] [--progress auto|bar|plain|none]\n"
    "                       [--progress-fd N] [--sandbox] [--cpu-limit S]\n"
    "                       [--shader-cache DB --shader-cache-dir DIR]\n"
    "       sylva-bake check-spec SPEC.json\n"
    "       sylva-bake view DIR --lod NAME --dir X,Y,Z [--size S] --out FILE.png\n"
    "       sylva-bake warm-shaders DIR   (sylvad's: fills a shader cache, prints its DB)\n"
    "\n"
    "MESH is a .glb, .gltf, .obj, .ply, .fbx or .dae file; FILES are the files it\n"
    "references (.bin, .mtl, textures), matched by base name. Those it names that\n"
    "FILES lack (an OBJ's mtllib, a .mtl's map_* lines, a glTF's buffer and image\n"
    "uris) are looked for beside it, plain names or relative paths without '..'\n"
    "only, and each one used is said on stderr. One that cannot be found refuses\n"
    "the input (code \"missing\") unless the spec says\n"
    "\"import\": {\"missing_files\": \"warn\"}.\n"
    "\n"
    "SPEC FLAGS (the same for `sylva bake`; they override --spec):\n"
    "--method NAME    the spec's \"method\" (billboard_cloud, leaf_clusters, ...)\n"
    "--set key=value  a spec setting, the value as JSON when it parses, else a\n"
    "           string: an undotted key is a setting of the method, a dotted key\n"
    "           a path from the root (--set billboard_cloud.lods=[20]); repeatable\n"
    "--units U  m, cm, mm, in, ft or metres per unit (--set import.units=U)\n"
    "--up Y|Z|auto  the source's up axis (--set import.up=...)\n"
    "\n"
    "-o, --out DIR  created with its parents; files an earlier bake left there\n"
    "           (sylva's names only) are removed first. A bake ends with a table\n"
    "           on stdout: level, triangles, texels, switch size in px, IoU at\n"
    "           64 px, file.\n"
    "-q, --quiet  no progress, notes, warnings or table: errors and an unmet\n"
    "           target only (info: no notes of the companions used).\n"
    "-v, --verbose  also the spec baked with, on stderr.\n"
    "--progress auto|bar|plain|none  on stderr: a bar with the stage, the target\n"
    "           search's try k of at most n and the elapsed time on a terminal\n"
    "           (auto), one line per stage or try otherwise (auto when stderr is\n"
    "           not a terminal), or nothing (auto with --progress-fd).\n"
    "--progress-fd N  JSON lines {\"stage\",\"progress\"[,\"try\",\"tries\"]} on fd N.\n"
    "--parent-pid P  die with process P, the parent (sylvad passes its pid): a\n"
    "           worker never outlives its daemon. A worker (--progress-fd,\n"
    "           --parent-pid or --sandbox) bakes only the files it is given.\n"
    "\n"
    "--sandbox  bake under a seccomp filter, entered before any input is read: only\n"
    "           the system calls a bake needs are allowed, others fail with EPERM,\n"
    "           and network, exec and ptrace calls kill the process with SIGSYS\n"
    "           (operations.md). sylvad passes it unless worker_sandbox = off.\n"
    "\n"
    "--shader-cache DB --shader-cache-dir DIR  Mesa's shader cache for this bake:\n"
    "           DB (printed by `sylva-bake warm-shaders DIR`) read-only, what the\n"
    "           bake compiles written into DIR, an empty directory of its own.\n"
    "           Without them a --sandbox bake runs with the cache off.\n"
    "\n"
    "--cpu-limit S  stop after S seconds of CPU time (RLIMIT_CPU): one line on stderr,\n"
    "           with bake DIR/error.json (code \"limit\"), exit 1. Default: the\n"
    "           inherited RLIMIT_CPU (ulimit -t; sylvad's worker_cpu_seconds) if\n"
    "           any, else 600. 0: no limit of its own. Never above the inherited\n"
    "           hard limit; the soft limit sits up to 5 s below a finite hard one\n"
    "           so the message comes before the kernel's SIGKILL.\n"
    "\n"
    "view       draws level NAME of the bake in DIR from direction X,Y,Z (towards\n"
    "           the viewer) as the evaluator does (report.json's evaluation.frame,\n"
    "           orthographic, S×S px, default 256, one sample per pixel, unlit; an\n"
    "           octahedral level by the C reference runtime): an RGBA PNG, alpha\n"
    "           255 where drawn. For comparing a runtime with the evaluator.\n"
    "\n"
    "Exit status (the same as sylva's): 0 done; 1 input refused or missing, or\n"
    "the bake failed (DIR/error.json); 2 usage; 3 bake done but the spec's\n"
    "\"target\" was not met (outputs written, the reason on stderr and in\n"
    "report.json). Warnings go to stderr.\n"
    "Guides: " SYLVA_DOC_DIR "/ (spec.md, outputs.md, client.md, methods/)\n";

/* A usage error: one line (fmt with its one string argument) and where the
 * help is, on stderr. Returns 2, the usage exit status. */
static int usage_error(const char *fmt, const char *arg)
{
    fputs("sylva-bake: ", stderr);
    fprintf(stderr, fmt, arg);
    fputs("\ntry 'sylva-bake --help'\n", stderr);
    return 2;
}

typedef struct loaded {
    sv_file files[MAX_FILES];
    void *data[MAX_FILES];
    size_t count;
} loaded;

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* Reads a whole file; returns NULL with errno set on failure. */
static void *read_all(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (n < cap) break;
        char *nb = (cap > SIZE_MAX / 2) ? NULL : realloc(buf, cap * 2);
        if (!nb) {
            free(buf);
            buf = NULL;
            errno = ENOMEM;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    if (buf && ferror(f)) {
        free(buf);
        buf = NULL;
        errno = EIO;
    }
    fclose(f);
    *size = n;
    return buf;
}

static int load_files(char **paths, size_t n, loaded *l)
{
    memset(l, 0, sizeof *l);
    if (n > MAX_FILES) {
        fprintf(stderr, "sylva-bake: at most %d files\n", MAX_FILES);
        return 1;
    }
    for (size_t i = 0; i < n; i++) {
        size_t size = 0;
        void *d = read_all(paths[i], &size);
        if (!d) {
            fprintf(stderr, "sylva-bake: cannot read %s: %s\n", paths[i], strerror(errno));
            return 1;
        }
        l->data[i] = d;
        l->files[i].name = base_name(paths[i]);
        l->files[i].data = d;
        l->files[i].size = size;
        l->count++;
    }
    return 0;
}

static void free_files(loaded *l)
{
    for (size_t i = 0; i < l->count; i++) free(l->data[i]);
}

static void write_error_json(const char *dir, const sv_error *e)
{
    if (!dir) return;
    char path[4096];
    snprintf(path, sizeof path, "%s/error.json", dir);
    cJSON *root = cJSON_CreateObject(), *o = cJSON_AddObjectToObject(root, "error");
    cJSON_AddStringToObject(o, "code", sv_status_code(e->status));
    cJSON_AddStringToObject(o, "message", e->message);
    char *s = cJSON_PrintUnformatted(root);
    FILE *f = fopen(path, "w");
    if (f && s) {
        fprintf(f, "%s\n", s);
    }
    if (f) fclose(f);
    free(s);
    cJSON_Delete(root);
}

/* ---- the CPU-time guard (see the top of this file) ---- */

static char g_xcpu_line[1200];
static size_t g_xcpu_line_len;
static char g_xcpu_json_path[4200];
static char g_xcpu_json[1400];
static size_t g_xcpu_json_len;

/* SIGXCPU: async-signal-safe only (write, open, close, _exit), from buffers
 * prepared by cpu_guard. */
static void on_xcpu(int sig)
{
    (void)sig;
    if (g_xcpu_json_path[0]) {
        int fd = open(g_xcpu_json_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            if (write(fd, g_xcpu_json, g_xcpu_json_len) < 0) { /* nothing more to do */
            }
            close(fd);
        }
    }
    if (write(2, g_xcpu_line, g_xcpu_line_len) < 0) { /* nothing more to do */
    }
    _exit(1);
}

/* Parses --cpu-limit's value: whole seconds, 0 .. 10^7. */
static bool parse_cpu_limit(const char *s, long *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < 0 || v > 10000000) {
        fprintf(stderr, "sylva-bake: --cpu-limit: expected whole seconds (0 = none), not '%s'\n",
                s);
        return false;
    }
    *out = v;
    return true;
}

/* Sets RLIMIT_CPU and the SIGXCPU handler. requested: seconds from
 * --cpu-limit, -1 when not given. mesh names the input in the message;
 * out_dir (bake) gets error.json. */
static void cpu_guard(long requested, const char *mesh, const char *out_dir)
{
    if (requested == 0) return;
    struct rlimit r;
    if (getrlimit(RLIMIT_CPU, &r) != 0) return;
    rlim_t limit;
    const char *why;
    if (requested > 0) {
        limit = (rlim_t)requested;
        why = "--cpu-limit";
    } else if (r.rlim_cur != RLIM_INFINITY) {
        limit = r.rlim_cur;
        why = "the inherited RLIMIT_CPU";
    } else {
        limit = SV_DEFAULT_CPU_LIMIT;
        why = "sylva-bake's default --cpu-limit";
    }
    if (r.rlim_max != RLIM_INFINITY && limit > r.rlim_max) limit = r.rlim_max;
    struct rlimit n = {limit, r.rlim_max};
    if (r.rlim_max == RLIM_INFINITY) {
        n.rlim_max = limit + 5; /* SIGKILL if the handler cannot finish */
    } else if (n.rlim_cur >= r.rlim_max && r.rlim_max >= 2) {
        rlim_t grace = r.rlim_max >= 50 ? 5 : 1; /* soft = hard gives SIGKILL, no message */
        n.rlim_cur = r.rlim_max - grace;
    }
    const char *base = strrchr(mesh, '/') ? strrchr(mesh, '/') + 1 : mesh;
    char msg[700];
    snprintf(msg, sizeof msg,
             "'%.200s': stopped after %llu s of CPU time, the limit set by %s: the input takes "
             "more than that to import or bake",
             base, (unsigned long long)n.rlim_cur, why);
    int len = snprintf(g_xcpu_line, sizeof g_xcpu_line, "sylva-bake: %.400s: %s\n", mesh, msg);
    g_xcpu_line_len = len < 0                            ? 0
                      : (size_t)len < sizeof g_xcpu_line ? (size_t)len
                                                         : sizeof g_xcpu_line - 1;
    g_xcpu_json_path[0] = 0;
    if (out_dir) {
        cJSON *root = cJSON_CreateObject(), *o = cJSON_AddObjectToObject(root, "error");
        cJSON_AddStringToObject(o, "code", sv_status_code(SV_ERR_LIMIT));
        cJSON_AddStringToObject(o, "message", msg);
        char *js = cJSON_PrintUnformatted(root);
        cJSON_Delete(root);
        if (js && strlen(js) + 2 < sizeof g_xcpu_json &&
            strlen(out_dir) + 16 < sizeof g_xcpu_json_path) {
            g_xcpu_json_len = (size_t)snprintf(g_xcpu_json, sizeof g_xcpu_json, "%s\n", js);
            snprintf(g_xcpu_json_path, sizeof g_xcpu_json_path, "%s/error.json", out_dir);
        }
        free(js);
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_xcpu;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGXCPU, &sa, NULL);
    if (setrlimit(RLIMIT_CPU, &n) != 0)
        fprintf(stderr, "sylva-bake: cannot set the CPU time limit: %s\n", strerror(errno));
}

/* How progress shows on stderr (--progress; docs/client.md's rules): a bar
 * redrawn with \r on a terminal, one plain line per stage or target try
 * otherwise, nothing with --quiet or --progress none. */
typedef enum { PROGRESS_AUTO, PROGRESS_BAR, PROGRESS_PLAIN, PROGRESS_NONE } progress_mode;

typedef struct progress_ctx {
    int fd;              /* --progress-fd: JSON lines for sylvad, or -1 */
    progress_mode mode;  /* resolved: BAR, PLAIN or NONE */
    double t0;           /* start, for the elapsed time */
    int try_k, try_most; /* target search: try k of at most try_most; 0 = none */
    char last[48];       /* the last plain line's stage and try */
    bool drawn;          /* a bar is on the terminal line */
} progress_ctx;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static void on_search(void *user, int k, int most)
{
    progress_ctx *p = user;
    p->try_k = k;
    p->try_most = most;
}

static bool on_progress(void *user, const char *stage, double fraction)
{
    progress_ctx *p = user;
    char tries[48] = "";
    if (p->fd >= 0) {
        char line[192];
        if (p->try_k > 0)
            snprintf(tries, sizeof tries, ",\"try\":%d,\"tries\":%d", p->try_k, p->try_most);
        int n = snprintf(line, sizeof line, "{\"stage\":\"%s\",\"progress\":%.3f%s}\n", stage,
                         fraction, tries);
        if (n > 0 && write(p->fd, line, (size_t)n) < 0) { /* the reader went away: go on */
        }
    }
    if (p->mode == PROGRESS_NONE) return true;
    int pct = (int)(fraction * 100 + 0.5);
    double el = now_s() - p->t0;
    if (p->try_k > 0) snprintf(tries, sizeof tries, "try %d of at most %d", p->try_k, p->try_most);
    else tries[0] = '\0';
    if (p->mode == PROGRESS_BAR) {
        char bar[21];
        int fill = pct / 5;
        for (int i = 0; i < 20; i++) bar[i] = i < fill ? '#' : '.';
        bar[20] = '\0';
        fprintf(stderr, "\r[%s] %3d%% %-9s %-20s %6.1f s", bar, pct, stage, tries, el);
        p->drawn = true;
    } else {
        char key[48];
        snprintf(key, sizeof key, "%s|%d", stage, p->try_k);
        if (strcmp(key, p->last) == 0) return true;
        snprintf(p->last, sizeof p->last, "%s", key);
        fprintf(stderr, "sylva-bake: %s %d%%%s%s%s, %.1f s\n", stage, pct, tries[0] ? " (" : "",
                tries, tries[0] ? ")" : "", el);
    }
    fflush(stderr);
    return true;
}

/* The command line of info and bake. */
typedef struct bake_opts {
    char *paths[MAX_FILES]; /* MESH, then FILES */
    size_t n;
    const char *spec_path, *out_dir;
    const char *method;
    const char *sets[MAX_FILES]; /* --set, --units and --up, in order */
    size_t set_count;
    char *owned[MAX_FILES]; /* the sets made of --units and --up */
    size_t owned_count;
    bool json, quiet, verbose, sandbox, help;
    int progress_fd;
    progress_mode mode;
    long parent;
    long cpu_limit;
    const char *shader_db, *shader_dir;
} bake_opts;

static void opts_free(bake_opts *o)
{
    for (size_t i = 0; i < o->owned_count; i++) free(o->owned[i]);
    o->owned_count = 0;
}

/* Parses the arguments of info (bake false) or bake: "--opt value" and
 * "--opt=value", the short -o, -q, -v, -h. Returns 0, or 2 after a usage
 * error's line on stderr. --help sets o->help. */
static int parse_opts(int argc, char **argv, bool bake, bake_opts *o)
{
    memset(o, 0, sizeof *o);
    o->progress_fd = -1;
    o->mode = PROGRESS_AUTO;
    o->cpu_limit = -1;
    static const char *const with_value[] = {"--spec",
                                             "--out",
                                             "--method",
                                             "--set",
                                             "--units",
                                             "--up",
                                             "--cpu-limit",
                                             "--progress",
                                             "--progress-fd",
                                             "--parent-pid",
                                             "--shader-cache",
                                             "--shader-cache-dir",
                                             NULL};
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        char name[32];
        const char *val = NULL;
        if (strcmp(a, "-o") == 0) snprintf(name, sizeof name, "--out");
        else if (strcmp(a, "-q") == 0) snprintf(name, sizeof name, "--quiet");
        else if (strcmp(a, "-v") == 0) snprintf(name, sizeof name, "--verbose");
        else if (strcmp(a, "-h") == 0) snprintf(name, sizeof name, "--help");
        else if (a[0] == '-' && a[1] == '-' && a[2]) {
            const char *eq = strchr(a, '=');
            size_t k = eq ? (size_t)(eq - a) : strlen(a);
            if (k >= sizeof name) return usage_error("unknown option %.60s", a);
            memcpy(name, a, k);
            name[k] = 0;
            val = eq ? eq + 1 : NULL;
        } else if (a[0] == '-' && a[1]) {
            return usage_error("unknown option %.60s", a);
        } else {
            if (o->n >= MAX_FILES) return usage_error("at most %s files", "256");
            o->paths[o->n++] = argv[i];
            continue;
        }
        bool takes = false;
        for (size_t k = 0; with_value[k]; k++) takes |= strcmp(name, with_value[k]) == 0;
        if (takes && !val) {
            if (i + 1 >= argc) return usage_error("%s needs a value", name);
            val = argv[++i];
        } else if (!takes && val) {
            return usage_error("%s takes no value", name);
        }
        bool bake_only = strcmp(name, "--out") == 0 || strcmp(name, "--progress") == 0 ||
                         strcmp(name, "--progress-fd") == 0 || strcmp(name, "--parent-pid") == 0 ||
                         strcmp(name, "--sandbox") == 0 || strcmp(name, "--shader-cache") == 0 ||
                         strcmp(name, "--shader-cache-dir") == 0;
        if (bake_only && !bake) return usage_error("%s belongs to the bake command", name);
        if (strcmp(name, "--json") == 0 && bake)
            return usage_error("%s belongs to the info command", name);
        if (strcmp(name, "--help") == 0) o->help = true;
        else if (strcmp(name, "--json") == 0) o->json = true;
        else if (strcmp(name, "--spec") == 0) o->spec_path = val;
        else if (strcmp(name, "--out") == 0) o->out_dir = val;
        else if (strcmp(name, "--method") == 0) o->method = val;
        else if ((strcmp(name, "--set") == 0 || strcmp(name, "--units") == 0 ||
                  strcmp(name, "--up") == 0) &&
                 o->set_count >= MAX_FILES)
            return usage_error("at most %s --set, --units and --up", "256");
        else if (strcmp(name, "--set") == 0) {
            const char *eq = strchr(val, '=');
            if (!eq || eq == val) return usage_error("--set expects key=value, not '%.60s'", val);
            o->sets[o->set_count++] = val;
        } else if (strcmp(name, "--units") == 0 || strcmp(name, "--up") == 0) {
            bool units = name[3] == 'n';
            if (!val[0]) return usage_error("%s needs a value", name);
            if (!units && strcmp(val, "Y") != 0 && strcmp(val, "Z") != 0 &&
                strcmp(val, "auto") != 0)
                return usage_error("--up expects Y, Z or auto, not '%.40s'", val);
            char *own = malloc(strlen(val) + 16);
            if (!own) return usage_error("%s", "out of memory");
            sprintf(own, "import.%s=%s", units ? "units" : "up", val);
            o->owned[o->owned_count++] = own;
            o->sets[o->set_count++] = own;
        } else if (strcmp(name, "--quiet") == 0) o->quiet = true;
        else if (strcmp(name, "--verbose") == 0) o->verbose = true;
        else if (strcmp(name, "--sandbox") == 0) o->sandbox = true;
        else if (strcmp(name, "--shader-cache") == 0) o->shader_db = val;
        else if (strcmp(name, "--shader-cache-dir") == 0) o->shader_dir = val;
        else if (strcmp(name, "--cpu-limit") == 0) {
            if (!parse_cpu_limit(val, &o->cpu_limit)) return 2;
        } else if (strcmp(name, "--parent-pid") == 0) {
            char *end;
            o->parent = strtol(val, &end, 10);
            if (*end || o->parent <= 0)
                return usage_error("--parent-pid: expected a process id, not '%.40s'", val);
        } else if (strcmp(name, "--progress") == 0) {
            if (strcmp(val, "auto") == 0) o->mode = PROGRESS_AUTO;
            else if (strcmp(val, "bar") == 0) o->mode = PROGRESS_BAR;
            else if (strcmp(val, "plain") == 0) o->mode = PROGRESS_PLAIN;
            else if (strcmp(val, "none") == 0) o->mode = PROGRESS_NONE;
            else
                return usage_error("--progress: expected auto, bar, plain or none, not '%.40s'",
                                   val);
        } else if (strcmp(name, "--progress-fd") == 0) {
            char *end;
            long fd = strtol(val, &end, 10);
            if (*end || fd < 0 || fd > 65535)
                return usage_error("--progress-fd: expected a file descriptor, not '%.40s'", val);
            o->progress_fd = (int)fd;
        } else {
            return usage_error("unknown option %.60s", a);
        }
    }
    return 0;
}

/* The spec to run with: the --spec file's bytes with the flags applied
 * (spec_flags.h). *spec is NULL (the default spec) when there is neither.
 * Returns 0; 1 when the file cannot be read (the message in e); 2 after a
 * usage error's line on stderr. */
static int load_spec(const bake_opts *o, char **spec, size_t *len, sv_error *e)
{
    *spec = NULL;
    *len = 0;
    size_t base_len = 0;
    char *base = NULL;
    if (o->spec_path && !(base = read_all(o->spec_path, &base_len))) {
        sv_fail(e, SV_ERR_IO, "cannot read %s: %s", o->spec_path, strerror(errno));
        return 1;
    }
    char err[300];
    int rc = sylva_spec_build(base, base_len, o->method, o->sets, o->set_count, spec, len, err,
                              sizeof err);
    free(base);
    if (rc != 0) return usage_error("%s", err);
    if (o->verbose)
        fprintf(stderr, "sylva-bake: spec: %.*s\n", (int)(*spec ? *len : 2), *spec ? *spec : "{}");
    return 0;
}

/* Adds to o->paths the companions the mesh names that the command line
 * lacks, found beside it (companions.h), saying each on stderr unless quiet.
 * found keeps the paths (sylva_companions_free after the bake). */
static void add_companions(bake_opts *o, sylva_companions *found)
{
    sylva_companions_find(o->paths[0], (const char *const *)o->paths + 1, o->n - 1, "sylva-bake",
                          o->quiet ? NULL : stderr, found);
    for (size_t i = 0; i < found->count && o->n < MAX_FILES; i++)
        o->paths[o->n++] = found->paths[i];
}

static int cmd_info(int argc, char **argv)
{
    bake_opts o;
    int prc = parse_opts(argc, argv, false, &o);
    if (prc || o.help) {
        opts_free(&o);
        if (o.help) fputs(usage, stdout);
        return prc;
    }
    if (o.n == 0) {
        opts_free(&o);
        return usage_error("%s", "info needs MESH");
    }
    cpu_guard(o.cpu_limit, o.paths[0], NULL);
    sylva_companions found;
    add_companions(&o, &found);
    char **paths = o.paths;
    size_t n = o.n;
    bool json = o.json;
    loaded l;
    if (load_files(paths, n, &l)) {
        free_files(&l);
        sylva_companions_free(&found);
        opts_free(&o);
        return 1;
    }
    size_t spec_len = 0;
    char *spec = NULL;
    sv_error se = {0};
    int src = load_spec(&o, &spec, &spec_len, &se);
    if (src) {
        if (src == 1) fprintf(stderr, "sylva-bake: %s\n", se.message);
        free_files(&l);
        sylva_companions_free(&found);
        opts_free(&o);
        return src;
    }
    char *out = NULL;
    sv_error e = {0};
    sv_status st = sv_pipeline_info(l.files, l.count, spec, spec_len, &out, &e);
    free(spec);
    free_files(&l);
    if (st) {
        fprintf(stderr, "sylva-bake: %s: %s\n", paths[0], e.message);
        sylva_companions_free(&found);
        opts_free(&o);
        return 1;
    }
    if (json) {
        printf("%s\n", out);
    } else {
        cJSON *j = cJSON_Parse(out);
        const cJSON *m = cJSON_GetObjectItem(j, "mesh");
        const cJSON *c = cJSON_GetObjectItem(j, "classification");
        const cJSON *lv = cJSON_GetObjectItem(j, "leaves");
        const cJSON *b = cJSON_GetObjectItem(j, "bounds");
        printf("%s: %s, %d triangles, %d vertices, %d materials\n", paths[0],
               cJSON_GetStringValue(cJSON_GetObjectItem(j, "format")),
               (int)cJSON_GetNumberValue(cJSON_GetObjectItem(m, "triangles")),
               (int)cJSON_GetNumberValue(cJSON_GetObjectItem(m, "vertices")),
               (int)cJSON_GetNumberValue(cJSON_GetObjectItem(m, "materials")));
        printf("units: %g m per unit, up %s\n",
               cJSON_GetNumberValue(cJSON_GetObjectItem(j, "unit_scale")),
               cJSON_GetStringValue(cJSON_GetObjectItem(j, "up")));
        const cJSON *mn = cJSON_GetObjectItem(b, "min"), *mx = cJSON_GetObjectItem(b, "max");
        printf("bounds: [%.4g %.4g %.4g] .. [%.4g %.4g %.4g] m\n",
               cJSON_GetNumberValue(cJSON_GetArrayItem(mn, 0)),
               cJSON_GetNumberValue(cJSON_GetArrayItem(mn, 1)),
               cJSON_GetNumberValue(cJSON_GetArrayItem(mn, 2)),
               cJSON_GetNumberValue(cJSON_GetArrayItem(mx, 0)),
               cJSON_GetNumberValue(cJSON_GetArrayItem(mx, 1)),
               cJSON_GetNumberValue(cJSON_GetArrayItem(mx, 2)));
        printf("foliage: %d triangles, trunk: %d triangles\n",
               (int)cJSON_GetNumberValue(cJSON_GetObjectItem(c, "foliage_triangles")),
               (int)cJSON_GetNumberValue(cJSON_GetObjectItem(c, "trunk_triangles")));
        const cJSON *mat;
        cJSON_ArrayForEach(mat, cJSON_GetObjectItem(c, "materials"))
        {
            printf("  material %-24s %-7s %7d triangles  (%s)\n",
                   cJSON_GetStringValue(cJSON_GetObjectItem(mat, "name")),
                   cJSON_GetStringValue(cJSON_GetObjectItem(mat, "part")),
                   (int)cJSON_GetNumberValue(cJSON_GetObjectItem(mat, "triangles")),
                   cJSON_GetStringValue(cJSON_GetObjectItem(mat, "reason")));
        }
        printf("leaf elements: %d (median area %.4g m², max %.4g m², %d split)\n",
               (int)cJSON_GetNumberValue(cJSON_GetObjectItem(lv, "count")),
               cJSON_GetNumberValue(cJSON_GetObjectItem(lv, "median_area")),
               cJSON_GetNumberValue(cJSON_GetObjectItem(lv, "max_area")),
               (int)cJSON_GetNumberValue(cJSON_GetObjectItem(lv, "split")));
        const cJSON *rep = cJSON_GetObjectItem(j, "repairs");
        const cJSON *r;
        cJSON_ArrayForEach(r, rep)
        {
            if (cJSON_IsNumber(r) && r->valuedouble > 0)
                printf("repair: %s %d\n", r->string, (int)r->valuedouble);
        }
        const cJSON *w = cJSON_GetObjectItem(j, "warnings");
        cJSON_ArrayForEach(r, w) printf("warning: %s\n", cJSON_GetStringValue(r));
        cJSON_Delete(j);
    }
    free(out);
    sylva_companions_free(&found);
    opts_free(&o);
    return 0;
}

/* The outcome of a finished bake, from out_dir/report.json, so a degraded
 * result is not silent: prints every input warning on stderr as
 * "sylva-bake: warning: ..." (not when quiet), and when the spec's target was not met
 * (target.met false) why, and returns EXIT_TARGET_UNMET; else 0. Prints
 * nothing and returns 0 when there is no report. */
static int report_outcome(const char *out_dir, bool quiet)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/report.json", out_dir);
    size_t len = 0;
    char *text = read_all(path, &len);
    cJSON *rep = text ? cJSON_ParseWithLength(text, len) : NULL;
    const cJSON *w;
    cJSON_ArrayForEach(w, cJSON_GetObjectItem(cJSON_GetObjectItem(rep, "input"),
                                              "warnings")) if (cJSON_IsString(w) && !quiet)
        fprintf(stderr, "sylva-bake: warning: %s\n", w->valuestring);
    const cJSON *t = cJSON_GetObjectItem(rep, "target");
    int rc = 0;
    if (cJSON_IsFalse(cJSON_GetObjectItem(t, "met"))) {
        const char *why = cJSON_GetStringValue(cJSON_GetObjectItem(t, "reason"));
        fprintf(stderr, "sylva-bake: target not met: %s\n", why ? why : "see report.json, target");
        fprintf(stderr,
                "sylva-bake: the outputs in %s are that bake (report.json: \"target\"); "
                "exit %d\n",
                out_dir, EXIT_TARGET_UNMET);
        rc = EXIT_TARGET_UNMET;
    }
    cJSON_Delete(rep);
    free(text);
    return rc;
}

/* mkdir -p DIR, then removes the sylva output files in it
 * (sylva_is_output_name) but for the n inputs (a mesh named model.glb baked
 * into its own folder is read, not removed). 0, or -1 after a message on
 * stderr. */
static int prepare_out_dir(const char *dir, char *const *inputs, size_t n)
{
    char path[4096];
    if (snprintf(path, sizeof path, "%s", dir) >= (int)sizeof path) {
        fprintf(stderr, "sylva-bake: --out: path too long\n");
        return -1;
    }
    for (char *p = path + 1;; p++) {
        if (*p != '/' && *p != '\0') continue;
        char saved = *p;
        *p = '\0';
        if (mkdir(path, 0755) != 0 && errno != EEXIST) {
            fprintf(stderr, "sylva-bake: cannot create %s: %s\n", path, strerror(errno));
            return -1;
        }
        *p = saved;
        if (!saved) break;
    }
    DIR *d = opendir(dir);
    if (!d) {
        fprintf(stderr, "sylva-bake: cannot open %s: %s\n", dir, strerror(errno));
        return -1;
    }
    int rc = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!sylva_is_output_name(e->d_name)) continue;
        struct stat st;
        bool input = false;
        if (fstatat(dirfd(d), e->d_name, &st, 0) == 0)
            for (size_t i = 0; i < n && !input; i++) {
                struct stat si;
                input = stat(inputs[i], &si) == 0 && si.st_dev == st.st_dev &&
                        si.st_ino == st.st_ino;
            }
        if (input) continue;
        if (unlinkat(dirfd(d), e->d_name, 0) != 0 && errno != ENOENT) {
            fprintf(stderr, "sylva-bake: cannot remove the stale %s/%s: %s\n", dir, e->d_name,
                    strerror(errno));
            rc = -1;
        }
    }
    closedir(d);
    return rc;
}

/* Whether name ends with suffix, ignoring ASCII case. */
static bool name_ends_ci(const char *name, const char *suffix)
{
    size_t n = strlen(name), k = strlen(suffix);
    return n >= k && strcasecmp(name + n - k, suffix) == 0;
}

/* Whether the file starts as a PNG or a JPEG does: image_decode.c reads
 * those without the plugin. */
static bool png_or_jpeg(const char *path)
{
    uint8_t b[8] = {0};
    FILE *f = fopen(path, "rb");
    if (!f) return false;
    size_t n = fread(b, 1, sizeof b, f);
    fclose(f);
    return (n == 8 && memcmp(b, "\x89PNG\r\n\x1a\n", 8) == 0) ||
           (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF);
}

/* Whether a bake of these files (the mesh first) may need the image plugin:
 * a companion that is neither .mtl nor a PNG or JPEG by its first bytes, or a
 * mesh format that can embed textures of any format (anything but OBJ, PLY,
 * STL), judged by its name. */
static bool may_need_plugin(char **paths, int n)
{
    static const char *const plain[] = {".obj", ".ply", ".stl"};
    bool plain_mesh = false;
    for (size_t k = 0; k < sizeof plain / sizeof plain[0]; k++)
        plain_mesh |= name_ends_ci(paths[0], plain[k]);
    if (!plain_mesh) return true;
    for (int i = 1; i < n; i++)
        if (!name_ends_ci(paths[i], ".mtl") && !png_or_jpeg(paths[i])) return true;
    return false;
}

static int bake_run(const bake_opts *o, char **paths, size_t n, const char *out_dir,
                    int progress_fd, progress_mode mode, bool quiet, long parent, bool sandbox,
                    const char *shader_db, const char *shader_dir);

static int cmd_bake(int argc, char **argv)
{
    bake_opts o;
    int prc = parse_opts(argc, argv, true, &o);
    if (prc || o.help) {
        opts_free(&o);
        if (o.help) fputs(usage, stdout);
        return prc;
    }
    if (o.n == 0 || !o.out_dir) {
        opts_free(&o);
        return usage_error("%s", "bake needs MESH and -o/--out DIR");
    }
    char **paths = o.paths;
    const char *out_dir = o.out_dir;
    int progress_fd = o.progress_fd;
    progress_mode mode = o.mode;
    bool quiet = o.quiet;
    long parent = o.parent;
    bool sandbox = o.sandbox;
    const char *shader_db = o.shader_db, *shader_dir = o.shader_dir;
    /* sylvad's worker bakes the upload as it is: the client looked for the
     * companions on its side */
    bool worker = progress_fd >= 0 || parent > 0 || sandbox;
    sylva_companions found = {0};
    if (!worker) add_companions(&o, &found);
    size_t n = o.n;
    int rc = bake_run(&o, paths, n, out_dir, progress_fd, mode, quiet, parent, sandbox, shader_db,
                      shader_dir);
    if (rc != 2 && rc != 1 && !quiet && !worker) {
        char path[4200];
        snprintf(path, sizeof path, "%s/report.json", out_dir);
        size_t len = 0;
        char *text = read_all(path, &len);
        cJSON *rep = text ? cJSON_ParseWithLength(text, len) : NULL;
        fflush(stderr);
        sylva_summary_table(rep, out_dir, stdout);
        cJSON_Delete(rep);
        free(text);
    }
    sylva_companions_free(&found);
    opts_free(&o);
    return rc;
}

/* The bake itself, once the command line is read (cmd_bake): 0 done, 1
 * refused or failed, 3 the target not met. */
static int bake_run(const bake_opts *o, char **paths, size_t n, const char *out_dir,
                    int progress_fd, progress_mode mode, bool quiet, long parent, bool sandbox,
                    const char *shader_db, const char *shader_dir)
{
    long cpu_limit = o->cpu_limit;
    /* sylvad's worker dies with it: SIGKILL when the parent
     * goes; a parent already gone before the prctl is caught by getppid. */
    if (parent > 0) {
        if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || getppid() != (pid_t)parent) {
            fprintf(stderr, "sylva-bake: the daemon (pid %ld) is gone: not baking\n", parent);
            return 1;
        }
    }
    /* --out as a user expects it: parents created, and the files of an
     * earlier bake there (sylva's names only: out_names.h) removed, so the
     * folder describes this bake alone, a stale error.json included. Before
     * the sandbox, which allows neither mkdir of parents nor directory
     * listing. */
    if (prepare_out_dir(out_dir, paths, n) != 0) return 1;
    /* Before the sandbox, which does not allow setrlimit. */
    cpu_guard(cpu_limit, paths[0], out_dir);
    sv_error e = {0};
    /* As early as possible: before the spec and the mesh are read. Libraries
     * are linked, not dlopen'ed, so nothing later needs a forbidden call, but
     * for Mesa's on-disk shader cache: it finds its directory with
     * getpwuid_r, whose NSS lookup opens a socket (nscd), and it would let a
     * subverted bake plant JIT code for later bakes. Sandboxed bakes go
     * without it (outputs are the same; llvmpipe compiles its few shaders),
     * or, given --shader-cache and --shader-cache-dir (sylvad's jobs), read
     * a DB that `warm-shaders` filled and write only into a directory of
     * their own (warm_shaders.h). */
    if ((sandbox || shader_db || shader_dir) && !sv_shader_cache_env(shader_db, shader_dir) &&
        (shader_db || shader_dir) && !quiet)
        fprintf(stderr,
                "sylva-bake: warning: the shader cache is off: --shader-cache needs an absolute "
                "DB path without commas and --shader-cache-dir an existing directory\n");
    /* The image plugin (OpenImageIO, dlopen'ed: image.h) before the sandbox
     * when the upload may hold a texture it decodes, so that its libraries'
     * initialisers run outside the filter (one of them reports "insecure
     * memory" under it); an OBJ, PLY or STL whose companions are .mtl, PNG
     * or JPEG cannot (those two are decoded in process). A plugin that
     * cannot load is reported by the decode that needs it. */
    if (sandbox && may_need_plugin(paths, n)) {
        sv_error pe = {0};
        (void)sv_image_plugin_load(&pe);
    }
    if (sandbox && sv_sandbox_enter(&e) != SV_OK) {
        fprintf(stderr, "sylva-bake: %s\n", e.message);
        write_error_json(out_dir, &e);
        return 1;
    }
    size_t spec_len = 0;
    char *spec = NULL;
    int src = load_spec(o, &spec, &spec_len, &e);
    if (src == 1) {
        fprintf(stderr, "sylva-bake: %s\n", e.message);
        write_error_json(out_dir, &e);
    }
    if (src) return src;
    loaded l;
    if (load_files(paths, n, &l)) {
        free(spec);
        free_files(&l);
        return 1;
    }
    /* auto: a bar on a terminal, plain lines otherwise; nothing as sylvad's
     * worker (--progress-fd), whose stderr is the daemon's log. */
    if (quiet) mode = PROGRESS_NONE;
    if (mode == PROGRESS_AUTO)
        mode = progress_fd >= 0 ? PROGRESS_NONE : isatty(2) ? PROGRESS_BAR : PROGRESS_PLAIN;
    progress_ctx pc = {.fd = progress_fd, .mode = mode, .t0 = now_s()};
    sv_bake_request req = {l.files, l.count, spec, spec_len, out_dir, on_progress, &pc, on_search};
    sv_status st = sv_pipeline_run(&req, &e);
    if (pc.drawn) fputc('\n', stderr);
    free(spec);
    free_files(&l);
    if (st) {
        fprintf(stderr, "sylva-bake: %s: %s\n", paths[0], e.message);
        write_error_json(out_dir, &e);
        return 1;
    }
    return report_outcome(out_dir, quiet);
}

static int cmd_check_spec(int argc, char **argv)
{
    if (argc != 1) return usage_error("%s", "check-spec takes one SPEC.json");
    size_t len = 0;
    char *s = read_all(argv[0], &len);
    sv_error e = {0};
    sv_spec spec;
    sv_status st;
    if (!s) st = sv_fail(&e, SV_ERR_IO, "cannot read %s: %s", argv[0], strerror(errno));
    else st = sv_spec_parse(s, len, &spec, &e);
    free(s);
    if (st) {
        char *body = sylva_error_body(sv_status_code(st), e.message);
        printf("%s\n", body ? body : "{\"error\":{}}");
        free(body);
        return 1;
    }
    sv_spec_free(&spec);
    printf("{\"ok\":true}\n");
    return 0;
}

/* Testing aid for tests/integration/sandbox_seccomp.sh: enters the sandbox,
 * shows that an allowed call works (a line on stdout) and that a call off the
 * list fails with EPERM (personality(2)'s query, which never fails outside
 * the sandbox), then makes a call of the kill set: socket(AF_INET) (default)
 * or execve (`exec`). Reaching the end is a failure (exit 1): the process
 * must die by SIGSYS first. */
static int cmd_sandbox_selftest(int argc, char **argv)
{
    const char *what = argc > 0 ? argv[0] : "socket";
    if (argc > 1 || (strcmp(what, "socket") != 0 && strcmp(what, "exec") != 0)) {
        fputs("usage: sylva-bake sandbox-selftest [socket|exec]\n", stderr);
        return 2;
    }
    sv_error e = {0};
    if (sv_sandbox_enter(&e) != SV_OK) {
        fprintf(stderr, "sylva-bake: %s\n", e.message);
        return 1;
    }
    printf("allowed: write works\n");
    errno = 0;
    int r = personality(0xffffffff);
    if (r != -1 || errno != EPERM) {
        printf("eperm: FAILED, personality returned %d (%s)\n", r, strerror(errno));
        return 1;
    }
    printf("eperm: personality failed with EPERM\n");
    /* no mode changes: what keeps a job from making sylvad's warmed shader
     * cache writable again (workers.h). A path that does not exist: the
     * filter answers before the lookup, and without it nothing changes
     * (ENOENT fails the check). */
    errno = 0;
    r = chmod("/nonexistent/sylva-sandbox-selftest", 0755);
    if (r != -1 || errno != EPERM) {
        printf("eperm: FAILED, chmod returned %d (%s)\n", r, strerror(errno));
        return 1;
    }
    printf("eperm: chmod failed with EPERM\n");
    printf("kill: trying %s\n", what);
    fflush(stdout);
    if (strcmp(what, "socket") == 0) {
        int fd = socket(AF_INET, SOCK_STREAM, 0);
        printf("kill: FAILED, socket returned %d (%s)\n", fd, fd < 0 ? strerror(errno) : "open");
    } else {
        char *args[] = {"/bin/true", NULL};
        execv(args[0], args);
        printf("kill: FAILED, execv returned (%s)\n", strerror(errno));
    }
    return 1;
}

/* sylva-bake view DIR --lod NAME --dir X,Y,Z [--size S] --out FILE.png */
static int cmd_view(int argc, char **argv)
{
    const char *dir = NULL, *lod = NULL, *out = NULL;
    double d[3] = {0, 0, 0};
    bool have_dir = false;
    long size = 256;
    for (int i = 0; i < argc; i++) {
        if (strcmp(argv[i], "--lod") == 0 && i + 1 < argc) lod = argv[++i];
        else if (strcmp(argv[i], "--out") == 0 && i + 1 < argc) out = argv[++i];
        else if (strcmp(argv[i], "--dir") == 0 && i + 1 < argc) {
            char tail;
            have_dir = sscanf(argv[++i], "%lf,%lf,%lf%c", &d[0], &d[1], &d[2], &tail) == 3;
            if (!have_dir) {
                fprintf(stderr, "sylva-bake view: --dir wants X,Y,Z (three numbers), got '%s'\n",
                        argv[i]);
                return 2;
            }
        } else if (strcmp(argv[i], "--size") == 0 && i + 1 < argc) {
            char *end;
            size = strtol(argv[++i], &end, 10);
            if (*end || size < 1 || size > 4096) {
                fprintf(stderr, "sylva-bake view: --size wants 1..4096, got '%s'\n", argv[i]);
                return 2;
            }
        } else if (argv[i][0] == '-' || dir) {
            return usage_error("view: unexpected argument '%.60s'", argv[i]);
        } else dir = argv[i];
    }
    if (!dir || !lod || !out || !have_dir) {
        return usage_error("%s", "view: DIR, --lod, --dir and --out are required");
    }
    sv_error err = {0};
    if (sv_view_render(dir, lod, d, (uint32_t)size, out, &err) != SV_OK) {
        fprintf(stderr, "sylva-bake view: %s\n", err.message);
        return 1;
    }
    return 0;
}

/* sylva-bake zygote --control-fd N --parent-pid P [ROOM]: sylvad's resident
 * worker (zygote.h), not for users. ROOM, a long blank argument the daemon
 * appends, is the space a child writes its job's command line into. */
static int cmd_zygote(int argc, char **argv, char **all, int all_argc)
{
    long fd = -1, parent = 0;
    for (int i = 0; i < argc; i++) {
        if (strcmp(argv[i], "--control-fd") == 0 && i + 1 < argc) fd = strtol(argv[++i], NULL, 10);
        else if (strcmp(argv[i], "--parent-pid") == 0 && i + 1 < argc)
            parent = strtol(argv[++i], NULL, 10);
        else if (i != argc - 1 || argv[i][0] != ' ') {
            fprintf(stderr, "sylva-bake zygote: unexpected argument '%.40s'\n", argv[i]);
            return 2;
        }
    }
    if (fd < 3 || fd > 1023 || parent <= 0) {
        fprintf(stderr, "sylva-bake zygote: needs --control-fd N and --parent-pid P (sylvad's)\n");
        return 2;
    }
    /* the argv area, contiguous from argv[0] to the end of the last string */
    char *title = all[0];
    char *end = all[all_argc - 1] + strlen(all[all_argc - 1]) + 1;
    for (int i = 1; i < all_argc; i++)
        if (all[i] != all[i - 1] + strlen(all[i - 1]) + 1) title = NULL;
    if (title && all[all_argc - 1][0] == ' ') /* ps shows the zygote without the room */
        memset(all[all_argc - 1], 0, strlen(all[all_argc - 1]));
    return sv_zygote_serve((int)fd, parent, title, title ? (size_t)(end - title) : 0, cmd_bake);
}

int main(int argc, char **argv)
{
    if (argc < 2) return usage_error("%s", "no command (info, bake, check-spec, view)");
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        fputs(usage, stdout);
        return 0;
    }
    if (strcmp(argv[1], "--version") == 0) {
        printf("sylva-bake %s\n", SV_VERSION);
        return 0;
    }
    if (strcmp(argv[1], "info") == 0) return cmd_info(argc - 2, argv + 2);
    if (strcmp(argv[1], "bake") == 0) return cmd_bake(argc - 2, argv + 2);
    if (strcmp(argv[1], "check-spec") == 0) return cmd_check_spec(argc - 2, argv + 2);
    if (strcmp(argv[1], "view") == 0) return cmd_view(argc - 2, argv + 2);
    if (strcmp(argv[1], "sandbox-selftest") == 0) return cmd_sandbox_selftest(argc - 2, argv + 2);
    if (strcmp(argv[1], "warm-shaders") == 0) return sv_warm_shaders_main(argc - 2, argv + 2);
    if (strcmp(argv[1], "zygote") == 0) return cmd_zygote(argc - 2, argv + 2, argv, argc);
    return usage_error("unknown command '%.60s'", argv[1]);
}
