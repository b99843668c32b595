/* sylva.c — the `sylva` command: bake, status, fetch, cancel, health against
 * sylvad (docs/client.md). Built on libsylva (sylva.h) and the pure helpers of
 * cli.h. Exit codes: cli.h (0 ok, 1 failed or input missing, 2 usage, 3 done
 * but the spec's target not met, 4 integrity, 5 cancelled, 6 service: the
 * same table as sylva-bake's). One clear line on stderr
 * on failure; --json prints one JSON document on stdout for every command. */
#include "clock.h"
#include "cli.h"
#include "companions.h"
#include "summary_table.h"
#include "sylva.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#ifndef SYLVA_DOC_DIR
#define SYLVA_DOC_DIR "/usr/local/share/doc/sylva"
#endif

static const char usage_text[] =
    "usage: sylva [--server URL]... [--token T] [--json] COMMAND ...\n"
    "  sylva bake MESH [FILES...] [-- MESH [FILES...]]... -o|--out DIR\n"
    "             [--spec spec.json] [--method M] [--set key=value]...\n"
    "             [--units U] [--up Y|Z|auto] [-q|--quiet] [-v|--verbose]\n"
    "             [--timeout S] [--progress auto|bar|plain|none]\n"
    "             [--retries N]  (on every command; default 7)\n"
    "  sylva status KEY [--wait S]\n"
    "  sylva fetch KEY --out DIR\n"
    "  sylva cancel KEY [--delete]  (--delete: also a finished bake, results and all)\n"
    "  sylva health\n"
    "KEY: the 64 hex digits a bake printed, or a prefix of at least 8 naming one bake.\n"
    "The companions a mesh names (.mtl, textures, .bin) are found beside it when\n"
    "not listed. --method, --set, --units, --up, -o, -q and -v mean what they mean\n"
    "for sylva-bake bake; flags override --spec.\n"
    "Server from --server (repeatable, or a comma list: failover in order) or\n"
    "SYLVA_SERVER (default " SYLVA_DEFAULT_SERVER "); token from --token or SYLVA_TOKEN.\n"
    "Exit: 0 ok, 1 failed/refused/input missing, 2 usage, 3 done (outputs\n"
    "downloaded) but the spec's \"target\" was not met, 4 artifact verification\n"
    "failed, 5 cancelled, 6 server unreachable or failing.\n"
    "Guide: " SYLVA_DOC_DIR "/client.md\n";

/* Prints the JSON document (compact, one line) on stdout. */
static void print_json(const cJSON *doc)
{
    char *text = cJSON_PrintUnformatted(doc);
    if (text) {
        fputs(text, stdout);
        fputc('\n', stdout);
        free(text);
    }
}

static cJSON *error_json(const char *code, const char *message)
{
    cJSON *doc = cJSON_CreateObject();
    cJSON *e = cJSON_AddObjectToObject(doc, "error");
    cJSON_AddStringToObject(e, "code", code);
    cJSON_AddStringToObject(e, "message", message);
    return doc;
}

/* Reports a failure: one line on stderr; with --json also the error object. */
static int fail_out(const sylva_cli *cli, int code, const char *errcode, const char *message)
{
    fprintf(stderr, "sylva: error: %s\n", message);
    if (cli && cli->json) {
        cJSON *doc = error_json(errcode, message);
        print_json(doc);
        cJSON_Delete(doc);
    }
    return code;
}

/* libsylva's detail when nothing listens at any server (connection refused
 * before any answer), with where the address came from. */
static const char *no_daemon_line(sylva_client *c, sylva_status st, char *buf, size_t len)
{
    const char *detail = sylva_client_error(c);
    if (st != SYLVA_ERR_CONNECT || strncmp(detail, "no sylva daemon answers", 23) != 0) return NULL;
    snprintf(buf, len, "%s (--server / SYLVA_SERVER)", detail);
    return buf;
}

static int fail_client(const sylva_cli *cli, sylva_client *c, sylva_status st)
{
    const char *detail = sylva_client_error(c);
    const char *code = sylva_client_error_code(c);
    char line[1200];
    const char *nd = no_daemon_line(c, st, line, sizeof line);
    return fail_out(cli, sylva_cli_exit_code(st), code[0] ? code : sylva_status_name(st),
                    nd          ? nd
                    : detail[0] ? detail
                                : sylva_status_message(st));
}

static char *read_file(const char *path, size_t *len, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "cannot open %s: %s", path, strerror(errno));
        return NULL;
    }
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    size_t got;
    while (buf && (got = fread(buf + n, 1, cap - n - 1, f)) > 0) {
        n += got;
        if (cap - n - 1 == 0) {
            char *nb = cap > ((size_t)1 << 30) ? NULL : realloc(buf, cap * 2);
            if (!nb) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = nb;
            cap *= 2;
        }
    }
    if (!buf || ferror(f)) {
        snprintf(err, errlen, "cannot read %s", path);
        free(buf);
        fclose(f);
        return NULL;
    }
    fclose(f);
    buf[n] = '\0';
    *len = n;
    return buf;
}

/* Says on stderr why the client is waiting (with no server, a command
 * would otherwise sit through its retries in silence). */
static void retry_notice(void *user, const char *error, long delay_ms, int attempt, int max)
{
    (void)user;
    fprintf(stderr, "sylva: %s; retrying in %.1f s (attempt %d of %d)\n", error,
            (double)delay_ms / 1000.0, attempt + 1, max);
}

static sylva_client *open_client(const sylva_cli *cli, sylva_status *st)
{
    sylva_options o;
    sylva_options_init(&o);
    o.token = cli->token;
    if (cli->retries >= 0) o.max_attempts = cli->retries + 1;
    else if (cli->cmd == SYLVA_CMD_HEALTH)
        o.max_attempts = (int)cli->server_count; /* a probe: each server once, no waiting */
    if (cli->progress != SYLVA_PROGRESS_NONE) o.on_retry = retry_notice; /* not with --quiet */
    sylva_client *c = NULL;
    char err[512];
    *st = sylva_client_create((const char *const *)cli->servers, cli->server_count, &o, &c, err,
                              sizeof err);
    if (*st != SYLVA_OK) fail_out(cli, sylva_cli_exit_code(*st), sylva_status_name(*st), err);
    return c;
}

/* Prints a summary on stdout, however long (every warning: a fixed buffer
 * would cut the list short). */
static void print_summary(const cJSON *summary)
{
    char small[4096];
    size_t want = sylva_cli_summary_format(summary, small, sizeof small);
    char *text = want >= sizeof small ? malloc(want + 1) : NULL;
    if (text) {
        sylva_cli_summary_format(summary, text, want + 1);
        fputs(text, stdout);
        free(text);
    } else {
        fputs(small, stdout);
    }
    fflush(stdout);
}

/* Prints the summary table (summary_table.h) of the report.json in dir, as
 * sylva-bake prints it; nothing when there is none. */
static void print_table(const char *dir)
{
    char path[4200], err[256];
    size_t len = 0;
    snprintf(path, sizeof path, "%s/report.json", dir);
    char *text = read_file(path, &len, err, sizeof err);
    cJSON *rep = text ? cJSON_ParseWithLength(text, len) : NULL;
    sylva_summary_table(rep, dir, stdout);
    cJSON_Delete(rep);
    free(text);
}

/* A done, downloaded bake whose spec's target was not met: says so on stderr
 * with the reason, where the outputs are and the exit code. Returns the bake's
 * exit code (SYLVA_EXIT_TARGET or SYLVA_EXIT_OK). */
static int report_target(const char *label, const char *out_dir, const cJSON *summary)
{
    int code = sylva_cli_done_exit_code(summary);
    if (code == SYLVA_EXIT_TARGET) {
        const char *why = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(summary, "target"), "reason"));
        fprintf(stderr, "sylva: %s: target not met: %s\n", label, why ? why : "see report.json");
        fprintf(stderr,
                "sylva: %s: the outputs in %s are that bake (report.json: \"target\"); "
                "exit %d\n",
                label, out_dir, SYLVA_EXIT_TARGET);
    }
    return code;
}

/* ---- bake ------------------------------------------------------------------ */

typedef struct bake {
    sylva_bake_group *group;
    char label[128]; /* mesh base name, for progress lines */
    sylva_file *files;
    sylva_input in;
    char key[SYLVA_KEY_HEX + 1];
    sylva_job job;
    sylva_status st; /* SYLVA_OK while running / when done */
    bool finished;
    char error[1024];
    char error_code[32];
    char last_stage[32]; /* for plain progress lines */
    int last_pct;
    int last_try;
    char cur_stage[32]; /* as last reported by the progress callback */
    double cur_progress;
    double t0;             /* submitted (monotonic s), for the elapsed time */
    int refetch_resubmits; /* submitted again after a 404 on download */
    sylva_companions comp; /* companions found beside the mesh */
} bake;

/* How often a bake whose artifacts vanished is submitted again (finish_done). */
#define REFETCH_RESUBMITS 3

typedef struct display {
    sylva_progress_mode mode; /* BAR, PLAIN or NONE (AUTO resolved) */
    bool bar_open;            /* a \r line is on screen */
} display;

static void show_plain(bake *b, const char *stage, double fraction)
{
    int pct = (int)(fraction * 100 + 1e-9);
    /* Plain lines: one per stage or target try, not per percent (logs stay short). */
    if (strcmp(stage, b->last_stage) == 0 && b->job.search_try == b->last_try) return;
    snprintf(b->last_stage, sizeof b->last_stage, "%s", stage);
    b->last_pct = pct;
    b->last_try = b->job.search_try;
    char line[256];
    sylva_cli_progress_format(b->label, stage, fraction, b->job.search_try, b->job.search_tries,
                              sylva_now_s() - b->t0, false, line, sizeof line);
    printf("%s\n", line);
    fflush(stdout);
}

static void show_bar(display *d, bake *bakes, size_t n)
{
    char line[512] = "";
    size_t used = 0;
    for (size_t i = 0; i < n && used < sizeof line - 1; i++) {
        char one[200];
        const char *stage = bakes[i].finished       ? (bakes[i].st == SYLVA_OK ? "done" : "failed")
                            : bakes[i].cur_stage[0] ? bakes[i].cur_stage
                                                    : "upload";
        bool running = !bakes[i].finished;
        sylva_cli_progress_format(bakes[i].label, stage, bakes[i].cur_progress,
                                  running ? bakes[i].job.search_try : 0, bakes[i].job.search_tries,
                                  n == 1 ? sylva_now_s() - bakes[i].t0 : -1, n == 1, one,
                                  sizeof one);
        int w = snprintf(line + used, sizeof line - used, "%s%s", i ? "  " : "", one);
        if (w > 0) used += (size_t)w;
    }
    printf("\r%s\033[K", line);
    fflush(stdout);
    d->bar_open = true;
}

static void bar_close(display *d)
{
    if (d->bar_open) {
        printf("\n");
        fflush(stdout);
        d->bar_open = false;
    }
}

typedef struct wait_ctx {
    display *d;
    bake *b;
} wait_ctx;

static bool on_progress(const char *stage, double fraction, void *ud)
{
    wait_ctx *w = ud;
    /* stage may point into w->b->job (sylva_wait's job): copy, never alias. */
    if (stage != w->b->cur_stage) snprintf(w->b->cur_stage, sizeof w->b->cur_stage, "%s", stage);
    w->b->cur_progress = fraction;
    if (w->d->mode == SYLVA_PROGRESS_BAR) show_bar(w->d, w->b, 1);
    else if (w->d->mode == SYLVA_PROGRESS_PLAIN) show_plain(w->b, stage, fraction);
    return true;
}

static void record_failure(bake *b, sylva_client *c, sylva_status st)
{
    b->st = st;
    b->finished = true;
    snprintf(b->error, sizeof b->error, "%s: %s", b->group->mesh,
             sylva_client_error(c)[0] ? sylva_client_error(c) : sylva_status_message(st));
    const char *code = sylva_client_error_code(c);
    snprintf(b->error_code, sizeof b->error_code, "%s", code[0] ? code : sylva_status_name(st));
}

/* Downloads a done bake and marks it finished. A 404 on the download means the
 * node that baked it went away between its "done" and the download, and the
 * request reached another node (failover, docs/deploy.md): the same inputs are
 * submitted again and the bake stays unfinished, to be waited for again (at
 * most REFETCH_RESUBMITS times). */
static void finish_done(bake *b, sylva_client *c)
{
    sylva_status st = sylva_fetch_dir(c, b->key, &b->job, b->group->out_dir);
    if (st == SYLVA_ERR_NOT_FOUND && b->refetch_resubmits < REFETCH_RESUBMITS) {
        b->refetch_resubmits++;
        st = sylva_submit(c, &b->in, &b->job);
        if (st == SYLVA_OK) return;
    }
    if (st != SYLVA_OK) {
        record_failure(b, c, st);
        return;
    }
    b->finished = true;
    b->st = SYLVA_OK;
}

static cJSON *bake_result_json(const bake *b, cJSON *summary)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "mesh", b->group->mesh);
    cJSON_AddStringToObject(o, "key", b->key);
    cJSON_AddStringToObject(o, "state",
                            b->st == SYLVA_OK                     ? "done"
                            : b->job.state != SYLVA_STATE_UNKNOWN ? sylva_state_name(b->job.state)
                                                                  : "error");
    cJSON_AddStringToObject(o, "out", b->group->out_dir);
    if (b->st != SYLVA_OK) {
        cJSON *e = cJSON_AddObjectToObject(o, "error");
        cJSON_AddStringToObject(e, "code", b->error_code);
        cJSON_AddStringToObject(e, "message", b->error);
        cJSON_Delete(summary);
        return o;
    }
    sylva_artifact *arts = NULL;
    size_t n = 0;
    if (sylva_job_artifacts(&b->job, &arts, &n) == SYLVA_OK) {
        cJSON *a = cJSON_AddArrayToObject(o, "artifacts");
        for (size_t i = 0; i < n; i++) {
            cJSON *ai = cJSON_CreateObject();
            cJSON_AddStringToObject(ai, "name", arts[i].name);
            cJSON_AddNumberToObject(ai, "size", (double)arts[i].size);
            cJSON_AddStringToObject(ai, "sha256", arts[i].sha256);
            cJSON_AddItemToArray(a, ai);
        }
        free(arts);
    }
    if (summary) cJSON_AddItemToObject(o, "summary", summary);
    return o;
}

static cJSON *summary_for(const bake *b)
{
    char path[4200], err[256];
    size_t len = 0;
    snprintf(path, sizeof path, "%s/report.json", b->group->out_dir);
    char *report = read_file(path, &len, err, sizeof err);
    snprintf(path, sizeof path, "%s/planes.json", b->group->out_dir);
    char *planes = read_file(path, &len, err, sizeof err);
    cJSON *s = sylva_cli_summary(b->job.json, report, planes);
    free(report);
    free(planes);
    return s;
}

static int cmd_bake(const sylva_cli *cli)
{
    char err[1024];
    int rc = SYLVA_EXIT_OK;
    sylva_bake_group *groups = NULL;
    size_t ng = 0;
    char *base = NULL, *spec = NULL;
    size_t base_len = 0, spec_len = 0;
    bake *bakes = NULL;
    sylva_client *c = NULL;
    if ((rc = sylva_cli_groups(cli, &groups, &ng, err, sizeof err)) != SYLVA_EXIT_OK)
        return fail_out(cli, rc, "usage", err);
    if (cli->spec_path && !(base = read_file(cli->spec_path, &base_len, err, sizeof err))) {
        rc = fail_out(cli, SYLVA_EXIT_FAILED, "missing", err);
        goto out;
    }
    if ((rc = sylva_cli_build_spec(base, base_len, cli->method, cli->sets, cli->set_count, &spec,
                                   &spec_len, err, sizeof err)) != SYLVA_EXIT_OK) {
        rc = fail_out(cli, rc, "usage", err);
        goto out;
    }
    if (cli->verbose)
        fprintf(stderr, "sylva: spec: %.*s\n", (int)(spec ? spec_len : 2), spec ? spec : "{}");
    bakes = calloc(ng, sizeof *bakes);
    if (!bakes) {
        rc = fail_out(cli, SYLVA_EXIT_SERVICE, "nomem", "out of memory");
        goto out;
    }
    /* Inputs and keys first: a bad name or a missing file fails before any upload. */
    for (size_t i = 0; i < ng; i++) {
        bake *b = &bakes[i];
        b->group = &groups[i];
        const char *bn = strrchr(groups[i].mesh, '/');
        snprintf(b->label, sizeof b->label, "%s", bn ? bn + 1 : groups[i].mesh);
        /* the companions the mesh names and the command line lacks, from
         * beside it (companions.h), as sylva-bake finds them */
        sylva_companions_find(groups[i].mesh, groups[i].files, groups[i].file_count, "sylva",
                              cli->quiet ? NULL : stderr, &b->comp);
        size_t nf = groups[i].file_count + b->comp.count;
        b->files = calloc(nf ? nf : 1, sizeof *b->files);
        if (!b->files) {
            rc = fail_out(cli, SYLVA_EXIT_SERVICE, "nomem", "out of memory");
            goto out;
        }
        for (size_t k = 0; k < groups[i].file_count; k++) b->files[k].path = groups[i].files[k];
        for (size_t k = 0; k < b->comp.count; k++)
            b->files[groups[i].file_count + k].path = b->comp.paths[k];
        b->in.spec = spec;
        b->in.spec_len = spec_len;
        b->in.mesh.path = groups[i].mesh;
        b->in.files = b->files;
        b->in.file_count = nf;
        sylva_status st = sylva_key_compute(&b->in, b->key, err, sizeof err);
        if (st != SYLVA_OK) {
            rc = fail_out(cli, sylva_cli_exit_code(st), sylva_status_name(st), err);
            goto out;
        }
    }
    sylva_status cst;
    if (!(c = open_client(cli, &cst))) {
        rc = sylva_cli_exit_code(cst);
        goto out;
    }
    display d = {cli->json ? SYLVA_PROGRESS_NONE : cli->progress, false};
    if (d.mode == SYLVA_PROGRESS_AUTO)
        d.mode = isatty(STDOUT_FILENO) ? SYLVA_PROGRESS_BAR : SYLVA_PROGRESS_PLAIN;
    /* Submit every bake: each PUT returns once the server has the inputs on disk,
     * and the server bakes them concurrently. */
    for (size_t i = 0; i < ng; i++) {
        bake *b = &bakes[i];
        b->t0 = sylva_now_s();
        sylva_status st = sylva_submit(c, &b->in, &b->job);
        char line[1200];
        if (no_daemon_line(c, st, line, sizeof line)) { /* one line for the whole batch */
            rc = fail_out(cli, sylva_cli_exit_code(st), sylva_status_name(st), line);
            goto out;
        }
        if (st != SYLVA_OK) {
            record_failure(b, c, st);
            continue;
        }
        if (d.mode == SYLVA_PROGRESS_PLAIN) printf("%s: submitted as %s\n", b->label, b->key);
    }
    double start = sylva_now_s();
    if (ng == 1 && !bakes[0].finished) {
        bake *b = &bakes[0];
        wait_ctx w = {&d, b};
        while (!b->finished) { /* again only when finish_done resubmitted */
            double left = cli->timeout_s > 0 ? cli->timeout_s - (sylva_now_s() - start) : 0;
            if (cli->timeout_s > 0 && left <= 0) left = 1e-3; /* sylva_wait reports the timeout */
            sylva_status st = sylva_wait(c, b->key, &b->in, left, on_progress, &w, &b->job);
            if (st == SYLVA_OK) finish_done(b, c);
            else record_failure(b, c, st);
        }
        bar_close(&d);
    } else {
        /* Batch: poll every unfinished bake in turn, fetch each as it finishes. */
        for (;;) {
            size_t pending = 0;
            for (size_t i = 0; i < ng; i++) {
                bake *b = &bakes[i];
                if (b->finished) continue;
                sylva_status st = sylva_status_get(c, b->key, 0, &b->job);
                if (st == SYLVA_ERR_NOT_FOUND) st = sylva_submit(c, &b->in, &b->job);
                if (st != SYLVA_OK) {
                    record_failure(b, c, st);
                    continue;
                }
                const char *stage = b->job.state == SYLVA_STATE_QUEUED ? "queued"
                                    : b->job.stage[0]                  ? b->job.stage
                                                      : sylva_state_name(b->job.state);
                snprintf(b->cur_stage, sizeof b->cur_stage, "%s", stage);
                b->cur_progress = b->job.progress;
                if (d.mode == SYLVA_PROGRESS_PLAIN) show_plain(b, stage, b->job.progress);
                if (b->job.state == SYLVA_STATE_DONE) {
                    finish_done(b, c);
                    if (!b->finished) pending++; /* submitted again: wait for it */
                } else if (b->job.state == SYLVA_STATE_FAILED) {
                    b->st = SYLVA_ERR_BAKE_FAILED;
                    b->finished = true;
                    snprintf(b->error, sizeof b->error, "%s: bake failed: %s%s%s", b->group->mesh,
                             b->job.error_code, b->job.error_message[0] ? ": " : "",
                             b->job.error_message);
                    snprintf(b->error_code, sizeof b->error_code, "%s",
                             b->job.error_code[0] ? b->job.error_code : "failed");
                } else if (b->job.state == SYLVA_STATE_CANCELLED) {
                    b->st = SYLVA_ERR_CANCELLED;
                    b->finished = true;
                    snprintf(b->error, sizeof b->error, "%s: the bake was cancelled on the server",
                             b->group->mesh);
                    snprintf(b->error_code, sizeof b->error_code, "cancelled");
                } else {
                    pending++;
                }
            }
            if (d.mode == SYLVA_PROGRESS_BAR) show_bar(&d, bakes, ng);
            if (!pending) break;
            if (cli->timeout_s > 0 && sylva_now_s() - start > cli->timeout_s) {
                for (size_t i = 0; i < ng; i++)
                    if (!bakes[i].finished) {
                        bakes[i].st = SYLVA_ERR_TIMEOUT;
                        bakes[i].finished = true;
                        snprintf(bakes[i].error, sizeof bakes[i].error,
                                 "%s: did not finish within %.0f s", bakes[i].group->mesh,
                                 cli->timeout_s);
                        snprintf(bakes[i].error_code, sizeof bakes[i].error_code, "timeout");
                    }
                break;
            }
            sylva_sleep_ms(500);
        }
        bar_close(&d);
    }
    /* Results. */
    cJSON *results = cJSON_CreateArray();
    int worst = SYLVA_EXIT_OK;
    for (size_t i = 0; i < ng; i++) {
        bake *b = &bakes[i];
        cJSON *summary = NULL;
        if (b->st == SYLVA_OK) {
            summary = summary_for(b);
            if (!cli->json && !cli->quiet) {
                printf("%s: done -> %s (key %.12s)\n", b->label, b->group->out_dir, b->key);
                print_table(b->group->out_dir);
                print_summary(summary);
            }
            worst = sylva_cli_worse_exit(worst,
                                         report_target(b->label, b->group->out_dir, summary));
        } else {
            worst = sylva_cli_worse_exit(worst, sylva_cli_exit_code(b->st));
            fprintf(stderr, "sylva: error: %s\n", b->error);
        }
        cJSON_AddItemToArray(results, bake_result_json(b, summary));
    }
    if (cli->json) {
        if (ng == 1) {
            print_json(cJSON_GetArrayItem(results, 0));
        } else {
            cJSON *doc = cJSON_CreateObject();
            cJSON_AddBoolToObject(doc, "ok", worst == SYLVA_EXIT_OK);
            cJSON_AddItemToObject(doc, "bakes", results);
            results = NULL;
            print_json(doc);
            cJSON_Delete(doc);
        }
    }
    cJSON_Delete(results);
    rc = worst;
out:
    for (size_t i = 0; bakes && i < ng; i++) {
        free(bakes[i].files);
        sylva_companions_free(&bakes[i].comp);
        sylva_job_clear(&bakes[i].job);
    }
    free(bakes);
    sylva_client_destroy(c);
    free(base);
    free(spec);
    sylva_cli_groups_free(groups, ng);
    return rc;
}

/* ---- status / fetch / cancel / health ----------------------------------------- */

static int cmd_status(const sylva_cli *cli)
{
    sylva_status st;
    sylva_client *c = open_client(cli, &st);
    if (!c) return sylva_cli_exit_code(st);
    sylva_job job = {0};
    st = sylva_status_get(c, cli->args[0], cli->wait_s, &job);
    int rc;
    if (st != SYLVA_OK) {
        rc = fail_client(cli, c, st);
    } else {
        if (cli->json) {
            fputs(job.json, stdout);
            fputc('\n', stdout);
        } else {
            printf("%s %s", job.key, sylva_state_name(job.state));
            if (job.state == SYLVA_STATE_RUNNING)
                printf(" %s %d%%", job.stage, (int)(job.progress * 100 + 1e-9));
            if (job.state == SYLVA_STATE_FAILED)
                printf(": %s: %s", job.error_code, job.error_message);
            printf("\n");
            if (job.state == SYLVA_STATE_DONE) {
                /* the table from the manifest's copy of report.json's summary */
                cJSON *doc = cJSON_Parse(job.json);
                sylva_summary_table(
                    cJSON_GetObjectItemCaseSensitive(
                        cJSON_GetObjectItemCaseSensitive(doc, "manifest"), "summary"),
                    NULL, stdout);
                cJSON_Delete(doc);
                cJSON *s = sylva_cli_summary(job.json, NULL, NULL);
                print_summary(s);
                cJSON_Delete(s);
            }
        }
        /* The command succeeded; a failed bake is still reported by the exit code. */
        rc = job.state == SYLVA_STATE_FAILED      ? SYLVA_EXIT_FAILED
             : job.state == SYLVA_STATE_CANCELLED ? SYLVA_EXIT_CANCELLED
                                                  : SYLVA_EXIT_OK;
    }
    sylva_job_clear(&job);
    sylva_client_destroy(c);
    return rc;
}

static int cmd_fetch(const sylva_cli *cli)
{
    sylva_status st;
    sylva_client *c = open_client(cli, &st);
    if (!c) return sylva_cli_exit_code(st);
    sylva_job job = {0};
    int rc = SYLVA_EXIT_OK;
    st = sylva_status_get(c, cli->args[0], 0, &job);
    if (st == SYLVA_OK) st = sylva_fetch_dir(c, cli->args[0], &job, cli->out);
    if (st != SYLVA_OK) {
        rc = fail_client(cli, c, st);
    } else {
        sylva_bake_group g = {.mesh = ""};
        snprintf(g.out_dir, sizeof g.out_dir, "%s", cli->out);
        bake b = {.group = &g, .job = job};
        snprintf(b.key, sizeof b.key, "%s", job.key);
        cJSON *summary = summary_for(&b);
        if (!cli->json) {
            printf("%.12s: fetched -> %s\n", job.key, cli->out);
            print_summary(summary);
        }
        char label[16];
        snprintf(label, sizeof label, "%.12s", job.key);
        rc = report_target(label, cli->out, summary);
        if (cli->json) {
            cJSON *doc = bake_result_json(&b, summary);
            cJSON_DeleteItemFromObject(doc, "mesh");
            print_json(doc);
            cJSON_Delete(doc);
        } else {
            cJSON_Delete(summary);
        }
    }
    sylva_job_clear(&job);
    sylva_client_destroy(c);
    return rc;
}

static int cmd_cancel(const sylva_cli *cli)
{
    sylva_status st;
    sylva_client *c = open_client(cli, &st);
    if (!c) return sylva_cli_exit_code(st);
    char state[32] = "";
    /* A finished bake is not cancelled but deleted with its results: only
     * with --delete. The state is read first; a bake that
     * finishes between the two requests is deleted as a cancel would have
     * stopped it. */
    if (!cli->delete_done) {
        sylva_job job = {0};
        st = sylva_status_get(c, cli->args[0], 0, &job);
        sylva_state s = job.state;
        sylva_job_clear(&job);
        if (st != SYLVA_OK) {
            int rc = fail_client(cli, c, st);
            sylva_client_destroy(c);
            return rc;
        }
        if (s == SYLVA_STATE_DONE || s == SYLVA_STATE_FAILED || s == SYLVA_STATE_CANCELLED) {
            char msg[200];
            snprintf(msg, sizeof msg,
                     "the bake has finished (%s): nothing to cancel; `sylva cancel --delete %.64s` "
                     "deletes it and its results",
                     sylva_state_name(s), cli->args[0]);
            sylva_client_destroy(c);
            return fail_out(cli, SYLVA_EXIT_FAILED, "finished", msg);
        }
    }
    st = sylva_cancel_state(c, cli->args[0], state, sizeof state);
    int rc = SYLVA_EXIT_OK;
    /* a finished bake is deleted, not cancelled: say which */
    bool deleted = strcmp(state, "deleted") == 0;
    if (st != SYLVA_OK) {
        rc = fail_client(cli, c, st);
    } else if (cli->json) {
        cJSON *doc = cJSON_CreateObject();
        cJSON_AddStringToObject(doc, "key", cli->args[0]);
        cJSON_AddBoolToObject(doc, "cancelled", !deleted);
        cJSON_AddStringToObject(doc, "state", state[0] ? state : "unknown");
        print_json(doc);
        cJSON_Delete(doc);
    } else if (deleted) {
        printf("%s deleted (it had finished: its results are gone)\n", cli->args[0]);
    } else if (strcmp(state, "cancel_requested") == 0) {
        printf("%s cancel requested (it was running; it ends cancelled shortly)\n", cli->args[0]);
    } else {
        printf("%s cancelled\n", cli->args[0]);
    }
    sylva_client_destroy(c);
    return rc;
}

static int cmd_health(const sylva_cli *cli)
{
    sylva_status st;
    sylva_client *c = open_client(cli, &st);
    if (!c) return sylva_cli_exit_code(st);
    char *body = NULL;
    st = sylva_health(c, &body);
    int rc = SYLVA_EXIT_OK;
    if (st != SYLVA_OK) {
        rc = fail_client(cli, c, st);
    } else if (cli->json) {
        cJSON *doc = cJSON_Parse(body);
        if (!doc) {
            doc = cJSON_CreateObject();
            cJSON_AddStringToObject(doc, "status", "ok");
        }
        cJSON_AddStringToObject(doc, "server", sylva_client_server(c));
        print_json(doc);
        cJSON_Delete(doc);
    } else {
        printf("%s: ok %s\n", sylva_client_server(c), body);
    }
    free(body);
    sylva_client_destroy(c);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--version") == 0) {
        printf("sylva %s\n", SYLVA_VERSION);
        return SYLVA_EXIT_OK;
    }
    sylva_cli cli;
    char err[512];
    int rc = sylva_cli_parse(argc, argv, getenv("SYLVA_SERVER"), getenv("SYLVA_TOKEN"), &cli, err,
                             sizeof err);
    if (rc != SYLVA_EXIT_OK) {
        bool json = false;
        for (int i = 1; i < argc; i++) json |= strcmp(argv[i], "--json") == 0;
        fprintf(stderr, "sylva: error: %s\n(sylva help for usage)\n", err);
        if (json) {
            cJSON *doc = error_json("usage", err);
            print_json(doc);
            cJSON_Delete(doc);
        }
        sylva_cli_free(&cli);
        return rc;
    }
    if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) {
        sylva_cli_free(&cli);
        return fail_out(NULL, SYLVA_EXIT_SERVICE, "nomem", "libcurl failed to initialise");
    }
    switch (cli.cmd) {
    case SYLVA_CMD_BAKE:
        rc = cmd_bake(&cli);
        break;
    case SYLVA_CMD_STATUS:
        rc = cmd_status(&cli);
        break;
    case SYLVA_CMD_FETCH:
        rc = cmd_fetch(&cli);
        break;
    case SYLVA_CMD_CANCEL:
        rc = cmd_cancel(&cli);
        break;
    case SYLVA_CMD_HEALTH:
        rc = cmd_health(&cli);
        break;
    case SYLVA_CMD_HELP:
    case SYLVA_CMD_NONE:
        fputs(usage_text, stdout);
        rc = SYLVA_EXIT_OK;
        break;
    }
    curl_global_cleanup();
    sylva_cli_free(&cli);
    return rc;
}
