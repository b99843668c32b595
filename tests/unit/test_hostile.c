/* test_hostile.c — the hostile corpus and the truncation sweep, in-process
 * (beside the fuzz targets of tests/fuzz/).
 *
 *  - every file of tests/corpus/MANIFEST.tsv goes through the import path that
 *    `sylva-bake info` takes (sv_pipeline_info: sniff, pre-check, assimp,
 *    validate, classify) and must be refused;
 *  - every file of tests/corpus/valid/ must import, and every prefix of it
 *    (cut at every byte, 0 .. size-1) must be refused or imported: never crash,
 *    never spin;
 *  - the committed corpus must be what make_corpus.py writes today, byte for byte;
 *  - the 38-byte PLY header is refused in well under a second, with a
 *    message naming the file and end_header.
 *
 * A hang must fail the test, not stall CI: the cases run in a forked child
 * that gives each case its own RLIMIT_CPU budget (CASE_CPU_SECONDS on top of
 * what the child has used so far). When a case spins past it, the kernel
 * kills the child with SIGXCPU; the parent records that case as a failure,
 * names it, and starts a new child at the next case. One child runs many cases
 * (a fork per case would cost more than the imports). Under ASan the child
 * runs LeakSanitizer before it ends, so a leak fails the batch.
 *
 * The corpus is found under $SYLVA_ROOT, else by walking up from the
 * executable (build/tests/ or build/asan/tests/).
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <assimp/cimport.h>
#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#ifdef __SANITIZE_ADDRESS__
#include <sanitizer/lsan_interface.h>
#endif

#include "import.h"
#include "pipeline.h"

#ifndef CASE_CPU_SECONDS
#define CASE_CPU_SECONDS 5
#endif

static char g_root[PATH_MAX];

static bool is_root(const char *dir)
{
    char p[PATH_MAX + 64];
    snprintf(p, sizeof p, "%s/tests/corpus/MANIFEST.tsv", dir);
    return access(p, R_OK) == 0;
}

static const char *root(void)
{
    if (g_root[0]) return g_root;
    const char *env = getenv("SYLVA_ROOT");
    if (env && is_root(env)) {
        snprintf(g_root, sizeof g_root, "%s", env);
        return g_root;
    }
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = 0;
        for (char *s = strrchr(exe, '/'); s; s = strrchr(exe, '/')) {
            *s = 0;
            if (exe[0] && is_root(exe)) {
                snprintf(g_root, sizeof g_root, "%s", exe);
                return g_root;
            }
        }
    }
    if (is_root(".")) snprintf(g_root, sizeof g_root, ".");
    return g_root;
}

static uint8_t *read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 4096, n = 0;
    uint8_t *buf = malloc(cap);
    for (;;) {
        if (!buf) break;
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap) break;
        uint8_t *nb = realloc(buf, cap * 2);
        if (!nb) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    fclose(f);
    *size = n;
    return buf;
}

/* ---------- running cases under a CPU limit ---------- */

typedef struct icase {
    char name[96];   /* file name as uploaded */
    char label[128]; /* for messages */
    const uint8_t *data;
    size_t size;
    bool spin; /* test of the harness: a busy loop instead of an import */
} icase;

enum { R_CPU = -1, R_CRASH = -2 };

typedef struct result {
    int status; /* sv_status, or R_CPU / R_CRASH */
    double cpu; /* seconds the case took (child CPU) */
} result;

typedef struct record {
    uint32_t index;
    int32_t status;
    double cpu;
} record;

static double cpu_now(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_utime.tv_sec + ru.ru_utime.tv_usec / 1e6 + (double)ru.ru_stime.tv_sec +
           ru.ru_stime.tv_usec / 1e6;
}

static int import_one(const icase *c)
{
    if (c->spin) {
        volatile unsigned long x = 0;
        for (;;) x++;
    }
    sv_file f = {c->name, c->data, c->size};
    char *json = NULL;
    sv_error e = {0};
    sv_status st = sv_pipeline_info(&f, 1, NULL, 0, &json, &e);
    free(json);
    if (st != SV_OK && !e.message[0]) return 1000; /* a refusal must say why */
    return (int)st;
}

/* Child: runs cases [from, n), one record per case on fd. */
static void child_run(const icase *cases, size_t from, size_t n, int fd, unsigned budget)
{
    struct rlimit core = {0, 0};
    setrlimit(RLIMIT_CORE, &core);
    signal(SIGXCPU, SIG_DFL);
    for (size_t i = from; i < n; i++) {
        double t0 = cpu_now();
        struct rlimit r;
        getrlimit(RLIMIT_CPU, &r);
        r.rlim_cur = (rlim_t)t0 + 1 + budget;
        if (r.rlim_max != RLIM_INFINITY && r.rlim_cur > r.rlim_max) r.rlim_cur = r.rlim_max;
        setrlimit(RLIMIT_CPU, &r);
        int st = import_one(&cases[i]);
        record rec = {(uint32_t)i, st, cpu_now() - t0};
        if (write(fd, &rec, sizeof rec) != (ssize_t)sizeof rec) _exit(3);
    }
    close(fd);
    /* _exit, not exit: the parent's libraries (log4cplus, through OIIO) run
     * finalizers at exit that wait for threads the child does not have. Under
     * ASan, LeakSanitizer checks the child here instead. */
#ifdef __SANITIZE_ADDRESS__
    if (__lsan_do_recoverable_leak_check()) _exit(23);
#endif
    _exit(0);
}

/* Runs every case; fills res[]. Returns the number of child processes used. */
static unsigned run_cases(const icase *cases, size_t n, result *res, unsigned budget)
{
    unsigned children = 0;
    size_t next = 0;
    while (next < n) {
        int p[2];
        assert_int_equal(pipe(p), 0);
        fflush(stdout);
        fflush(stderr);
        pid_t pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
            close(p[0]);
            child_run(cases, next, n, p[1], budget);
        }
        children++;
        close(p[1]);
        record rec;
        size_t got = 0;
        ssize_t r;
        for (;;) {
            r = read(p[0], (char *)&rec + got, sizeof rec - got);
            if (r < 0 && errno == EINTR) continue;
            if (r <= 0) break;
            got += (size_t)r;
            if (got < sizeof rec) continue;
            got = 0;
            if (rec.index < n) {
                res[rec.index].status = rec.status;
                res[rec.index].cpu = rec.cpu;
                next = rec.index + 1;
            }
        }
        close(p[0]);
        int ws = 0;
        while (waitpid(pid, &ws, 0) < 0 && errno == EINTR) {}
        if (WIFEXITED(ws) && WEXITSTATUS(ws) == 0) {
            assert_int_equal(next, n);
            break;
        }
        if (next >= n) { /* every case ran; the exit itself failed (a leak) */
            fail_msg("the child that ran cases up to %zu exited with %d (LeakSanitizer?)", n - 1,
                     WIFEXITED(ws) ? WEXITSTATUS(ws) : 128 + WTERMSIG(ws));
        }
        bool cpu = WIFSIGNALED(ws) && (WTERMSIG(ws) == SIGXCPU || WTERMSIG(ws) == SIGKILL);
        res[next].status = cpu ? R_CPU : R_CRASH;
        res[next].cpu = 0;
        fprintf(stderr, "# %s: %s\n", cases[next].label,
                cpu               ? "over its CPU limit (killed by the RLIMIT_CPU guard)"
                : WIFSIGNALED(ws) ? strsignal(WTERMSIG(ws))
                                  : "child exited early");
        next++;
    }
    return children;
}

/* ---------- the hostile corpus ---------- */

typedef struct corpus {
    icase *cases;
    uint8_t **bufs;
    size_t n;
} corpus;

static void corpus_free(corpus *c)
{
    for (size_t i = 0; i < c->n; i++) free(c->bufs[i]);
    free(c->bufs);
    free(c->cases);
    memset(c, 0, sizeof *c);
}

static void load_manifest(corpus *c)
{
    char path[PATH_MAX + 64];
    snprintf(path, sizeof path, "%s/tests/corpus/MANIFEST.tsv", root());
    FILE *f = fopen(path, "r");
    if (!f) fail_msg("cannot open %s (run from the repository or set SYLVA_ROOT)", path);
    size_t cap = 128;
    c->cases = calloc(cap, sizeof *c->cases);
    c->bufs = calloc(cap, sizeof *c->bufs);
    char line[1024];
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#' || line[0] == '\n') continue;
        char *tab = strchr(line, '\t');
        if (tab) *tab = 0;
        assert_true(c->n < cap);
        icase *k = &c->cases[c->n];
        snprintf(k->name, sizeof k->name, "%.90s", line);
        snprintf(k->label, sizeof k->label, "corpus %.90s", line);
        snprintf(path, sizeof path, "%s/tests/corpus/%s", root(), k->name);
        size_t size = 0;
        c->bufs[c->n] = read_file(path, &size);
        if (!c->bufs[c->n]) fail_msg("%s is listed in MANIFEST.tsv but cannot be read", k->name);
        k->data = c->bufs[c->n];
        k->size = size;
        c->n++;
    }
    fclose(f);
}

static void test_corpus_refused(void **state)
{
    (void)state;
    corpus c = {0};
    load_manifest(&c);
    assert_true(c.n >= 60);
    result *res = calloc(c.n, sizeof *res);
    double t0 = sv_now();
    unsigned kids = run_cases(c.cases, c.n, res, CASE_CPU_SECONDS);
    int bad = 0;
    double max_cpu = 0;
    for (size_t i = 0; i < c.n; i++) {
        if (res[i].cpu > max_cpu) max_cpu = res[i].cpu;
        if (res[i].status == SV_OK) {
            fprintf(stderr, "# %s: accepted, must be refused\n", c.cases[i].name);
            bad++;
        } else if (res[i].status < 0 || res[i].status >= 1000) {
            if (res[i].status >= 1000)
                fprintf(stderr, "# %s: refused without a message\n", c.cases[i].name);
            bad++;
        }
    }
    printf("# hostile corpus: %zu files refused in %.2f s (%u children, slowest case %.3f s "
           "CPU)\n",
           c.n, sv_now() - t0, kids, max_cpu);
    free(res);
    corpus_free(&c);
    assert_int_equal(bad, 0);
}

/* ---------- the truncation sweep ---------- */

static void test_truncation_sweep(void **state)
{
    (void)state;
    char dir[PATH_MAX + 32];
    snprintf(dir, sizeof dir, "%s/tests/corpus/valid", root());
    DIR *d = opendir(dir);
    if (!d) fail_msg("cannot open %s", dir);
    char *names[32];
    size_t nn = 0;
    struct dirent *de;
    /* SYLVA_SWEEP_ONLY=NAME sweeps one file (to find which one a leak or
     * crash report belongs to). */
    const char *only = getenv("SYLVA_SWEEP_ONLY");
    while ((de = readdir(d)) && nn < 32)
        if (de->d_name[0] != '.' && (!only || strcmp(only, de->d_name) == 0))
            names[nn++] = strdup(de->d_name);
    closedir(d);
    if (only) printf("# SYLVA_SWEEP_ONLY=%s: %zu file(s)\n", only, nn);
    else assert_true(nn >= 9);
    /* The formats the sweep must cover: every one sylva accepts. */
    bool seen[SV_FORMAT_COLLADA + 1] = {0};
    uint8_t *bufs[32];
    size_t sizes[32], total = 0;
    for (size_t i = 0; i < nn; i++) {
        char p[PATH_MAX + 64];
        snprintf(p, sizeof p, "%s/%s", dir, names[i]);
        bufs[i] = read_file(p, &sizes[i]);
        assert_non_null(bufs[i]);
        seen[sv_sniff_format(bufs[i], sizes[i])] = true;
        total += sizes[i] + 1;
    }
    for (int f = SV_FORMAT_GLB; f <= SV_FORMAT_COLLADA; f++)
        if (!seen[f] && !only)
            fail_msg("tests/corpus/valid/ has no %s file", sv_format_name((sv_format)f));
    icase *cases = calloc(total, sizeof *cases);
    size_t n = 0;
    for (size_t i = 0; i < nn; i++)
        for (size_t len = 0; len <= sizes[i]; len++) {
            icase *k = &cases[n++];
            snprintf(k->name, sizeof k->name, "%s", names[i]);
            snprintf(k->label, sizeof k->label, "%s cut at %zu of %zu bytes", names[i], len,
                     sizes[i]);
            k->data = len ? bufs[i] : NULL;
            k->size = len;
        }
    result *res = calloc(n, sizeof *res);
    double t0 = sv_now();
    unsigned kids = run_cases(cases, n, res, CASE_CPU_SECONDS);
    double wall = sv_now() - t0;
    int bad = 0;
    size_t accepted = 0;
    double max_cpu = 0;
    const char *slowest = "";
    for (size_t i = 0; i < n; i++) {
        if (res[i].cpu > max_cpu) {
            max_cpu = res[i].cpu;
            slowest = cases[i].label;
        }
        bool whole = cases[i].size > 0 && (i + 1 == n || cases[i + 1].size == 0);
        if (res[i].status < 0) bad++; /* named by run_cases */
        else if (res[i].status >= 1000) {
            fprintf(stderr, "# %s: refused without a message\n", cases[i].label);
            bad++;
        } else if (whole && res[i].status != SV_OK) {
            fprintf(stderr, "# %s: the whole valid file is refused (%s)\n", cases[i].name,
                    sv_status_code((sv_status)res[i].status));
            bad++;
        } else if (res[i].status == SV_OK) {
            accepted++;
        }
    }
    printf("# truncation sweep: %zu valid files, %zu cases (every prefix and the whole file) "
           "in %.2f s, %u children; %zu imported, %zu refused, %d failures; slowest case "
           "%.3f s CPU (%s), limit %d s\n",
           nn, n, wall, kids, accepted, n - accepted - (size_t)bad, bad, max_cpu, slowest,
           CASE_CPU_SECONDS);
    for (size_t i = 0; i < nn; i++) {
        free(bufs[i]);
        free(names[i]);
    }
    free(cases);
    free(res);
    assert_int_equal(bad, 0);
}

/* ---------- the guard itself: a spinning case fails, it does not hang ---------- */

static void test_cpu_guard_catches_a_spin(void **state)
{
    (void)state;
    /* Before the fix, assimp's PLY reader spun on the header; a busy
     * loop stands in for it here, between two real cases, to show that the
     * harness reports a spin as that case's failure within its limit and goes
     * on with the next case. */
    static const char obj[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    icase c[3] = {{"a.obj", "a.obj", (const uint8_t *)obj, sizeof obj - 1, false},
                  {"spin", "a busy loop", NULL, 0, true},
                  {"b.obj", "b.obj", (const uint8_t *)obj, sizeof obj - 1, false}};
    result res[3] = {{0}};
    double t0 = sv_now();
    unsigned kids = run_cases(c, 3, res, 1);
    assert_int_equal(res[0].status, SV_OK);
    assert_int_equal(res[1].status, R_CPU);
    assert_int_equal(res[2].status, SV_OK);
    assert_int_equal(kids, 2);
    assert_true(sv_now() - t0 < 60);
}

/* ---------- a PLY header without end_header (assimp's reader spun on it) ---------- */

static void test_ply_header_without_end_refused_fast(void **state)
{
    (void)state;
    static const char bytes[] = "ply\nformat ascii 1.0\nelement vertex 1\n";
    const char *names[] = {"t.ply", "t.glb"};
    for (int k = 0; k < 2; k++) {
        icase c = {0};
        snprintf(c.name, sizeof c.name, "%s", names[k]);
        snprintf(c.label, sizeof c.label, "PLY header without end_header as %s", names[k]);
        c.data = (const uint8_t *)bytes;
        c.size = sizeof bytes - 1;
        result res = {0};
        run_cases(&c, 1, &res, CASE_CPU_SECONDS); /* under the guard: before the fix this spun */
        assert_int_equal(res.status, SV_ERR_PARSE);
        assert_true(res.cpu < 1.0);
        sv_file f = {names[k], (const uint8_t *)bytes, sizeof bytes - 1};
        sv_mesh *m = NULL;
        sv_error e = {0};
        double t0 = sv_now();
        assert_int_equal(sv_import(&f, 1, NULL, &m, NULL, &e), SV_ERR_PARSE);
        double dt = sv_now() - t0;
        assert_null(m);
        assert_non_null(strstr(e.message, names[k]));
        assert_non_null(strstr(e.message, "end_header"));
        assert_true(dt < 1.0);
        printf("# PLY header without end_header as %s: refused in %.6f s: %s\n", names[k], dt,
               e.message);
    }
}

/* The pre-check on its own: what it accepts and refuses, with the file named. */
static void test_mesh_precheck_messages(void **state)
{
    (void)state;
    static const struct {
        sv_format fmt;
        const char *bytes;
        sv_status want;
        const char *says;
    } cases[] = {
        {SV_FORMAT_PLY, "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n", SV_OK, ""},
        {SV_FORMAT_PLY, "ply\nformat ascii 1.0\nelement vertex 0\nend_header", SV_ERR_PARSE,
         "end_header"},
        {SV_FORMAT_PLY, "ply\nformat ascii 1.0\nelement vertex 99999999999\nend_header\n",
         SV_ERR_PARSE, "below 2^32"},
        {SV_FORMAT_PLY,
         "ply\nformat ascii 1.0\nelement vertex 20000000\nproperty float x\n"
         "end_header\n",
         SV_ERR_LIMIT, "vertices"},
        {SV_FORMAT_PLY,
         "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
         "end_header\n1\n",
         SV_ERR_PARSE, "body ends"},
        {SV_FORMAT_PLY,
         "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
         "end_header\nabc\n",
         SV_ERR_PARSE, "not a number"},
        {SV_FORMAT_PLY, "ply\nformat ascii 1.0\nproperty float x\nend_header\n", SV_ERR_PARSE,
         "before any element"},
        {SV_FORMAT_PLY, "ply\nformat ascii 1.0\nelement vertex 1\nend_header\n", SV_ERR_PARSE,
         "no properties"},
        {SV_FORMAT_PLY, "ply\nformat ascii 1.0\nbogus\nend_header\n", SV_ERR_PARSE,
         "not a header line"},
        {SV_FORMAT_PLY,
         "ply\nformat binary_little_endian 1.0\nelement v 1\nproperty int x\n"
         "end_header\n\x01\x02\x03",
         SV_ERR_PARSE, "body ends"},
        {SV_FORMAT_OBJ, "v 0 0 0\n", SV_OK, ""},
        {SV_FORMAT_FBX,
         "; FBX 7.4.0\nFBXHeaderExtension: {\n B: \"x\"\n}\nObjects: {\n}\n"
         "Connections: {\n}\n",
         SV_OK, ""},
        {SV_FORMAT_FBX, "; FBX 7.4.0\nFBXHeaderExtension: {\n}\nObjects: {\n}\n", SV_ERR_PARSE,
         "no top-level Connections"},
        {SV_FORMAT_FBX, "; FBX 7.4.0\nA: {\n B: \"x\n}\n", SV_ERR_PARSE, "not closed"},
        {SV_FORMAT_FBX, "; FBX 7.4.0\nA: {\n}\n}\n", SV_ERR_PARSE, "at the top level"},
        {SV_FORMAT_FBX, "; FBX 7.4.0\nA: 1 }\n", SV_ERR_PARSE, "without"},
        {SV_FORMAT_FBX, "; FBX 7.4.0\nA: {\n}\nB: 1\n", SV_ERR_PARSE, "no {...} block"},
        {SV_FORMAT_FBX, "; FBX 7.4.0\nA: {\n}\nBxx", SV_ERR_PARSE, "at the top level"},
        {SV_FORMAT_FBX, "; FBX 7.4.0\n", SV_ERR_PARSE, "no element"},
        {SV_FORMAT_COLLADA, "<COLLADA></COLLADA>", SV_OK, ""},
        {SV_FORMAT_COLLADA, "<COLLADA><asset>", SV_ERR_PARSE, "</COLLADA>"},
        {SV_FORMAT_FBX, "Kaydara FBX Binary  \0\x1a\0\xe8\x1c\0\0", SV_ERR_PARSE,
         "no top-level FBXHeaderExtension"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        /* the binary FBX header holds NULs: 27 bytes */
        size_t len = cases[i].bytes[0] == 'K' ? 27 : strlen(cases[i].bytes);
        sv_error e = {0};
        sv_status st = sv_mesh_precheck(cases[i].fmt, (const uint8_t *)cases[i].bytes, len, "x.in",
                                        NULL, &e);
        if (st != cases[i].want ||
            (st && (!strstr(e.message, cases[i].says) || !strstr(e.message, "'x.in'"))))
            fail_msg("case %zu: status %s, message '%s' (want %s, '%s')", i, sv_status_code(st),
                     e.message, sv_status_code(cases[i].want), cases[i].says);
    }
}

/* The reader check relies on this: with a name ending in .obj, .ply, .fbx or
 * .dae, assimp 5.2.5 has exactly one reader to pick (and does not fall back to
 * trying every reader by signature). */
static void test_one_reader_per_extension(void **state)
{
    (void)state;
    const char *exts[] = {"obj", "ply", "fbx", "dae"};
    for (size_t k = 0; k < 4; k++) {
        int claims = 0;
        for (size_t i = 0; i < aiGetImportFormatCount(); i++) {
            const struct aiImporterDesc *d = aiGetImportFormatDescription(i);
            char list[512];
            snprintf(list, sizeof list, " %s ", d->mFileExtensions);
            char w[16];
            snprintf(w, sizeof w, " %s ", exts[k]);
            if (strstr(list, w)) claims++;
        }
        if (claims != 1)
            fail_msg(".%s is claimed by %d assimp readers, expected 1", exts[k], claims);
    }
}

/* ---------- the committed corpus is what make_corpus.py writes ---------- */

/* Every file under a/rel must be in b, identical (make_corpus.py itself aside). */
static int compare_tree(const char *a, const char *b, const char *rel, int *files)
{
    char pa[PATH_MAX + 256], pb[PATH_MAX + 256];
    snprintf(pa, sizeof pa, "%s/%s", a, rel);
    DIR *d = opendir(pa);
    if (!d) return 1;
    int bad = 0;
    struct dirent *de;
    while ((de = readdir(d))) {
        if (de->d_name[0] == '.' && (!de->d_name[1] || (de->d_name[1] == '.' && !de->d_name[2])))
            continue;
        if (!rel[0] && strcmp(de->d_name, "make_corpus.py") == 0) continue;
        char r[512];
        snprintf(r, sizeof r, "%s%s%s", rel, rel[0] ? "/" : "", de->d_name);
        snprintf(pa, sizeof pa, "%s/%s", a, r);
        snprintf(pb, sizeof pb, "%s/%s", b, r);
        struct stat sa;
        if (stat(pa, &sa) != 0) continue;
        if (S_ISDIR(sa.st_mode)) {
            bad += compare_tree(a, b, r, files);
            continue;
        }
        size_t na = 0, nb = 0;
        uint8_t *da = read_file(pa, &na), *db = read_file(pb, &nb);
        if (!db) {
            fprintf(stderr, "# %s: only in %s\n", r, a);
            bad++;
        } else if (!da || na != nb || memcmp(da, db, na) != 0) {
            fprintf(stderr, "# %s: differs (%zu vs %zu bytes)\n", r, na, nb);
            bad++;
        }
        (*files)++;
        free(da);
        free(db);
    }
    closedir(d);
    return bad;
}

static void test_corpus_matches_generator(void **state)
{
    (void)state;
    char tmp[] = "/tmp/sylva-corpus.XXXXXX";
    assert_non_null(mkdtemp(tmp));
    char cmd[PATH_MAX * 2 + 64];
    snprintf(cmd, sizeof cmd, "python3 '%s/tests/corpus/make_corpus.py' '%s' > /dev/null", root(),
             tmp);
    int rc = system(cmd);
    char committed[PATH_MAX + 32];
    snprintf(committed, sizeof committed, "%s/tests/corpus", root());
    int files = 0, bad = 0;
    if (rc == 0) {
        /* Everything generated must be committed, identical... */
        bad += compare_tree(tmp, committed, "", &files);
        /* ...and everything committed (but the script) must be generated. */
        int f2 = 0;
        bad += compare_tree(committed, tmp, "", &f2);
    }
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmp);
    if (system(cmd) != 0) fprintf(stderr, "# could not remove %s\n", tmp);
    if (rc != 0) fail_msg("make_corpus.py failed (status %d): is python3 installed?", rc);
    printf("# corpus: %d generated files compared with tests/corpus, %d differ\n", files, bad);
    if (bad) fail_msg("tests/corpus differs from make_corpus.py's output: rerun it and commit");
}

int main(void)
{
    if (!root()[0]) {
        fprintf(stderr, "test_hostile: cannot find tests/corpus (set SYLVA_ROOT)\n");
        return 1;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ply_header_without_end_refused_fast),
        cmocka_unit_test(test_mesh_precheck_messages),
        cmocka_unit_test(test_one_reader_per_extension),
        cmocka_unit_test(test_cpu_guard_catches_a_spin),
        cmocka_unit_test(test_corpus_refused),
        cmocka_unit_test(test_truncation_sweep),
        cmocka_unit_test(test_corpus_matches_generator),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
