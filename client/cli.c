/* cli.c — pure helpers of the `sylva` command: argument parsing, batch grouping,
 * spec building, summary and exit codes (contracts in cli.h). No network. */
#include "cli.h"
#include "spec_flags.h"

#include <ctype.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static void set_err(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void set_err(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || !errlen) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

void sylva_cli_free(sylva_cli *cli)
{
    if (!cli) return;
    for (size_t i = 0; i < cli->server_count; i++) free(cli->servers[i]);
    free(cli->servers);
    for (size_t i = 0; i < cli->owned_count; i++) free(cli->owned[i]);
    free(cli->owned);
    free(cli->sets);
    free(cli->args);
    memset(cli, 0, sizeof *cli);
}

/* Appends each comma-separated, non-empty item of list to cli->servers. */
static bool add_servers(sylva_cli *cli, const char *list)
{
    const char *p = list;
    while (*p) {
        const char *e = strchr(p, ',');
        size_t n = e ? (size_t)(e - p) : strlen(p);
        while (n > 0 && isspace((unsigned char)*p)) {
            p++;
            n--;
        }
        while (n > 0 && isspace((unsigned char)p[n - 1])) n--;
        if (n > 0) {
            char **ns = realloc(cli->servers, (cli->server_count + 1) * sizeof *ns);
            if (!ns) return false;
            cli->servers = ns;
            char *s = malloc(n + 1);
            if (!s) return false;
            memcpy(s, p, n);
            s[n] = '\0';
            cli->servers[cli->server_count++] = s;
        }
        if (!e) break;
        p = e + 1;
    }
    return true;
}

static bool parse_seconds(const char *s, double *out)
{
    char *end = NULL;
    double v = strtod(s, &end);
    if (!s[0] || *end || !(v >= 0) || v > 1e7) return false;
    *out = v;
    return true;
}

static const struct {
    const char *name;
    sylva_cmd cmd;
} commands[] = {
    {"bake", SYLVA_CMD_BAKE},     {"status", SYLVA_CMD_STATUS}, {"fetch", SYLVA_CMD_FETCH},
    {"cancel", SYLVA_CMD_CANCEL}, {"health", SYLVA_CMD_HEALTH}, {"help", SYLVA_CMD_HELP},
};

int sylva_cli_parse(int argc, char **argv, const char *env_server, const char *env_token,
                    sylva_cli *cli, char *err, size_t errlen)
{
    memset(cli, 0, sizeof *cli);
    cli->retries = -1;
    if (err && errlen) err[0] = '\0';
    size_t cap = argc > 0 ? (size_t)argc : 1;
    cli->sets = calloc(cap, sizeof *cli->sets);
    cli->args = calloc(cap, sizeof *cli->args);
    cli->owned = calloc(cap, sizeof *cli->owned);
    if (!cli->sets || !cli->args || !cli->owned) {
        set_err(err, errlen, "out of memory");
        return SYLVA_EXIT_USAGE;
    }
    bool after_command_dashdash = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        /* Options taking a value accept "--opt value" and "--opt=value". */
        const char *val = NULL;
        char name[32];
        if (a[0] == '-' && a[1] == '-' && a[2]) {
            const char *eq = strchr(a, '=');
            size_t n = eq ? (size_t)(eq - a) : strlen(a);
            if (n >= sizeof name) {
                set_err(err, errlen, "unknown option %.40s", a);
                return SYLVA_EXIT_USAGE;
            }
            memcpy(name, a, n);
            name[n] = '\0';
            val = eq ? eq + 1 : NULL;
        } else if (strcmp(a, "-h") == 0) {
            snprintf(name, sizeof name, "--help");
        } else if (strcmp(a, "-o") == 0 || strcmp(a, "-q") == 0 || strcmp(a, "-v") == 0) {
            /* the short forms both tools share (docs/client.md "Options") */
            snprintf(name, sizeof name, "%s", a[1] == 'o'   ? "--out"
                                              : a[1] == 'q' ? "--quiet"
                                                            : "--verbose");
        } else {
            name[0] = '\0';
        }
        static const char *const with_value[] = {"--server",  "--token",    "--out",     "--spec",
                                                 "--method",  "--set",      "--timeout", "--wait",
                                                 "--retries", "--progress", "--units",
                                                 "--up",      NULL};
        bool takes = false;
        for (size_t k = 0; with_value[k]; k++)
            if (strcmp(name, with_value[k]) == 0) takes = true;
        if (takes && !val) {
            if (i + 1 >= argc) {
                set_err(err, errlen, "option %s needs a value", name);
                return SYLVA_EXIT_USAGE;
            }
            val = argv[++i];
        }
        if (name[0] == '\0') {
            if (cli->cmd == SYLVA_CMD_NONE) {
                if (strcmp(a, "--") == 0) {
                    set_err(err, errlen, "\"--\" before the command");
                    return SYLVA_EXIT_USAGE;
                }
                for (size_t k = 0; k < sizeof commands / sizeof commands[0]; k++)
                    if (strcmp(a, commands[k].name) == 0) cli->cmd = commands[k].cmd;
                if (cli->cmd == SYLVA_CMD_NONE) {
                    set_err(err, errlen,
                            "unknown command \"%.60s\" (bake, status, fetch, "
                            "cancel, health, help)",
                            a);
                    return SYLVA_EXIT_USAGE;
                }
            } else if (strcmp(a, "--") == 0) {
                cli->args[cli->arg_count++] = NULL;
                after_command_dashdash = true;
            } else if (a[0] == '-' && a[1] && !after_command_dashdash) {
                set_err(err, errlen, "unknown option %.60s", a);
                return SYLVA_EXIT_USAGE;
            } else {
                cli->args[cli->arg_count++] = a;
            }
            continue;
        }
        if (strcmp(name, "--server") == 0) {
            if (!add_servers(cli, val)) {
                set_err(err, errlen, "out of memory");
                return SYLVA_EXIT_USAGE;
            }
        } else if (strcmp(name, "--token") == 0) {
            cli->token = val;
        } else if (strcmp(name, "--out") == 0) {
            cli->out = val;
        } else if (strcmp(name, "--spec") == 0) {
            cli->spec_path = val;
        } else if (strcmp(name, "--method") == 0) {
            cli->method = val;
        } else if (strcmp(name, "--units") == 0 || strcmp(name, "--up") == 0) {
            /* --units U is --set import.units=U, --up A is --set import.up=A */
            bool units = name[3] == 'n';
            if (!units && strcmp(val, "Y") != 0 && strcmp(val, "Z") != 0 &&
                strcmp(val, "auto") != 0) {
                set_err(err, errlen, "--up expects Y, Z or auto, got \"%.40s\"", val);
                return SYLVA_EXIT_USAGE;
            }
            if (!val[0]) {
                set_err(err, errlen, "--units expects m, cm, mm, in, ft or metres per unit");
                return SYLVA_EXIT_USAGE;
            }
            char *own = malloc(strlen(val) + 16);
            if (!own) {
                set_err(err, errlen, "out of memory");
                return SYLVA_EXIT_USAGE;
            }
            sprintf(own, "import.%s=%s", units ? "units" : "up", val);
            cli->owned[cli->owned_count++] = own;
            cli->sets[cli->set_count++] = own;
        } else if (strcmp(name, "--verbose") == 0 && !val) {
            cli->verbose = true;
        } else if (strcmp(name, "--set") == 0) {
            const char *eq = strchr(val, '=');
            if (!eq || eq == val) {
                set_err(err, errlen, "--set expects key=value, got \"%.60s\"", val);
                return SYLVA_EXIT_USAGE;
            }
            cli->sets[cli->set_count++] = val;
        } else if (strcmp(name, "--timeout") == 0) {
            if (!parse_seconds(val, &cli->timeout_s)) {
                set_err(err, errlen, "--timeout expects seconds, got \"%.40s\"", val);
                return SYLVA_EXIT_USAGE;
            }
        } else if (strcmp(name, "--wait") == 0) {
            if (!parse_seconds(val, &cli->wait_s)) {
                set_err(err, errlen, "--wait expects seconds, got \"%.40s\"", val);
                return SYLVA_EXIT_USAGE;
            }
        } else if (strcmp(name, "--retries") == 0) {
            char *end = NULL;
            long r = strtol(val, &end, 10);
            if (!val[0] || *end || r < 0 || r > 100) {
                set_err(err, errlen, "--retries expects 0..100, got \"%.40s\"", val);
                return SYLVA_EXIT_USAGE;
            }
            cli->retries = (int)r;
        } else if (strcmp(name, "--json") == 0 && !val) {
            cli->json = true;
        } else if (strcmp(name, "--delete") == 0 && !val) {
            cli->delete_done = true;
        } else if (strcmp(name, "--quiet") == 0 && !val) {
            cli->progress = SYLVA_PROGRESS_NONE;
            cli->quiet = true;
        } else if (strcmp(name, "--progress") == 0) {
            const char *m = val;
            if (strcmp(m, "auto") == 0) cli->progress = SYLVA_PROGRESS_AUTO;
            else if (strcmp(m, "bar") == 0) cli->progress = SYLVA_PROGRESS_BAR;
            else if (strcmp(m, "plain") == 0) cli->progress = SYLVA_PROGRESS_PLAIN;
            else if (strcmp(m, "none") == 0) cli->progress = SYLVA_PROGRESS_NONE;
            else {
                set_err(err, errlen, "--progress expects auto, bar, plain or none");
                return SYLVA_EXIT_USAGE;
            }
        } else if (strcmp(name, "--help") == 0) {
            cli->cmd = SYLVA_CMD_HELP;
        } else {
            set_err(err, errlen, "unknown option %.60s", a);
            return SYLVA_EXIT_USAGE;
        }
    }
    if (cli->server_count == 0 &&
        !add_servers(cli, env_server && env_server[0] ? env_server : SYLVA_DEFAULT_SERVER)) {
        set_err(err, errlen, "out of memory");
        return SYLVA_EXIT_USAGE;
    }
    if (cli->server_count == 0) {
        set_err(err, errlen, "no server URL (--server or SYLVA_SERVER)");
        return SYLVA_EXIT_USAGE;
    }
    if (!cli->token && env_token && env_token[0]) cli->token = env_token;
    /* Per-command checks. */
    size_t real_args = 0;
    for (size_t i = 0; i < cli->arg_count; i++) real_args += cli->args[i] != NULL;
    switch (cli->cmd) {
    case SYLVA_CMD_NONE:
        set_err(err, errlen, "no command (bake, status, fetch, cancel, health, help)");
        return SYLVA_EXIT_USAGE;
    case SYLVA_CMD_BAKE:
        if (real_args == 0) {
            set_err(err, errlen, "bake: no mesh given");
            return SYLVA_EXIT_USAGE;
        }
        if (!cli->out) {
            set_err(err, errlen, "bake: --out DIR is required");
            return SYLVA_EXIT_USAGE;
        }
        for (size_t i = 0; i < cli->set_count; i++) {
            const char *eq = strchr(cli->sets[i], '=');
            if (!cli->method && memchr(cli->sets[i], '.', (size_t)(eq - cli->sets[i])) == NULL &&
                !cli->spec_path) {
                set_err(err, errlen, "--set %.*s needs --method (or a --spec naming the method)",
                        (int)(eq - cli->sets[i]), cli->sets[i]);
                return SYLVA_EXIT_USAGE;
            }
        }
        break;
    case SYLVA_CMD_STATUS:
    case SYLVA_CMD_CANCEL:
    case SYLVA_CMD_FETCH:
        if (real_args != 1 || cli->arg_count != 1) {
            set_err(err, errlen, "%s: expects exactly one KEY",
                    cli->cmd == SYLVA_CMD_STATUS   ? "status"
                    : cli->cmd == SYLVA_CMD_CANCEL ? "cancel"
                                                   : "fetch");
            return SYLVA_EXIT_USAGE;
        }
        if (cli->cmd == SYLVA_CMD_FETCH && !cli->out) {
            set_err(err, errlen, "fetch: --out DIR is required");
            return SYLVA_EXIT_USAGE;
        }
        break;
    case SYLVA_CMD_HEALTH:
        if (cli->arg_count) {
            set_err(err, errlen, "health: takes no arguments");
            return SYLVA_EXIT_USAGE;
        }
        break;
    case SYLVA_CMD_HELP:
        break;
    }
    if (cli->cmd != SYLVA_CMD_BAKE && (cli->spec_path || cli->method || cli->set_count)) {
        set_err(err, errlen, "--spec, --method and --set belong to the bake command");
        return SYLVA_EXIT_USAGE;
    }
    return SYLVA_EXIT_OK;
}

/* ---- batch grouping ------------------------------------------------------ */

bool sylva_cli_is_mesh(const char *path)
{
    static const char *const exts[] = {".obj", ".gltf", ".glb", ".ply", ".fbx", ".dae"};
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    if (!dot || (slash && dot < slash)) return false;
    for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++)
        if (strcasecmp(dot, exts[i]) == 0) return true;
    return false;
}

static const char *base_of(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* Length of the directory part of path ("a/b/c.obj" -> 3, "c.obj" -> 0). */
static size_t dir_len(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? (size_t)(s - path) : 0;
}

static bool same_dir(const char *a, const char *b)
{
    size_t la = dir_len(a), lb = dir_len(b);
    return la == lb && strncmp(a, b, la) == 0;
}

void sylva_cli_groups_free(sylva_bake_group *groups, size_t count)
{
    if (!groups) return;
    for (size_t i = 0; i < count; i++) free(groups[i].files);
    free(groups);
}

static bool group_add_file(sylva_bake_group *g, const char *f, size_t cap)
{
    if (!g->files) {
        g->files = calloc(cap ? cap : 1, sizeof *g->files);
        if (!g->files) return false;
    }
    g->files[g->file_count++] = f;
    return true;
}

static void stem_of(const char *path, bool keep_ext, char *out, size_t len)
{
    snprintf(out, len, "%s", base_of(path));
    char *dot = strrchr(out, '.');
    if (!keep_ext) {
        if (dot && dot != out) *dot = '\0';
    } else {
        for (char *p = out; *p; p++)
            if (*p == '.') *p = '_';
    }
}

int sylva_cli_groups(const sylva_cli *cli, sylva_bake_group **groups, size_t *count, char *err,
                     size_t errlen)
{
    *groups = NULL;
    *count = 0;
    size_t n = cli->arg_count;
    sylva_bake_group *g = calloc(n ? n : 1, sizeof *g);
    if (!g) {
        set_err(err, errlen, "out of memory");
        return SYLVA_EXIT_USAGE;
    }
    size_t ng = 0;
    bool explicit_groups = false;
    for (size_t i = 0; i < n; i++) explicit_groups |= cli->args[i] == NULL;
    int rc = SYLVA_EXIT_USAGE;
    if (explicit_groups) {
        bool open = false;
        for (size_t i = 0; i < n; i++) {
            const char *a = cli->args[i];
            if (!a) {
                open = false;
                continue;
            }
            if (!open) {
                g[ng++].mesh = a;
                open = true;
            } else if (!group_add_file(&g[ng - 1], a, n)) {
                set_err(err, errlen, "out of memory");
                goto out;
            }
        }
    } else {
        size_t meshes = 0;
        for (size_t i = 0; i < n; i++) meshes += sylva_cli_is_mesh(cli->args[i]);
        if (meshes <= 1) {
            /* One bake: the mesh-extension file, else the first file. */
            size_t m = 0;
            for (size_t i = 0; i < n; i++)
                if (sylva_cli_is_mesh(cli->args[i])) {
                    m = i;
                    break;
                }
            g[ng++].mesh = cli->args[m];
            for (size_t i = 0; i < n; i++)
                if (i != m && !group_add_file(&g[0], cli->args[i], n)) {
                    set_err(err, errlen, "out of memory");
                    goto out;
                }
        } else {
            for (size_t i = 0; i < n; i++)
                if (sylva_cli_is_mesh(cli->args[i])) g[ng++].mesh = cli->args[i];
            for (size_t i = 0; i < n; i++) {
                const char *a = cli->args[i];
                if (sylva_cli_is_mesh(a)) continue;
                size_t owner = ng, found = 0;
                for (size_t k = 0; k < ng; k++)
                    if (same_dir(a, g[k].mesh)) {
                        owner = k;
                        found++;
                    }
                if (found != 1) {
                    set_err(err, errlen,
                            "cannot tell which mesh %s belongs to (%s mesh in its "
                            "directory); separate the bakes with --",
                            a, found ? "more than one" : "no");
                    goto out;
                }
                if (!group_add_file(&g[owner], a, n)) {
                    set_err(err, errlen, "out of memory");
                    goto out;
                }
            }
        }
    }
    if (ng == 0) {
        set_err(err, errlen, "bake: no mesh given");
        goto out;
    }
    /* Output directories. */
    for (size_t i = 0; i < ng; i++) {
        if (ng == 1) {
            snprintf(g[i].out_dir, sizeof g[i].out_dir, "%s", cli->out);
            continue;
        }
        char stem[512];
        stem_of(g[i].mesh, false, stem, sizeof stem);
        bool collide = false;
        for (size_t k = 0; k < ng; k++) {
            char other[512];
            stem_of(g[k].mesh, false, other, sizeof other);
            if (k != i && strcmp(stem, other) == 0) collide = true;
        }
        if (collide) stem_of(g[i].mesh, true, stem, sizeof stem);
        if (snprintf(g[i].out_dir, sizeof g[i].out_dir, "%s/%s", cli->out, stem) >=
            (int)sizeof g[i].out_dir) {
            set_err(err, errlen, "output path too long for %s", g[i].mesh);
            goto out;
        }
    }
    for (size_t i = 0; i < ng; i++)
        for (size_t k = i + 1; k < ng; k++)
            if (strcmp(g[i].out_dir, g[k].out_dir) == 0) {
                set_err(err, errlen, "%s and %s would both write into %s; separate them", g[i].mesh,
                        g[k].mesh, g[i].out_dir);
                goto out;
            }
    rc = SYLVA_EXIT_OK;
out:
    if (rc != SYLVA_EXIT_OK) {
        sylva_cli_groups_free(g, ng);
        return rc;
    }
    *groups = g;
    *count = ng;
    return rc;
}

/* ---- spec building --------------------------------------------------------- */

int sylva_cli_build_spec(const char *base, size_t base_len, const char *method,
                         const char *const *sets, size_t set_count, char **out, size_t *out_len,
                         char *err, size_t errlen)
{
    return sylva_spec_build(base, base_len, method, sets, set_count, out, out_len, err, errlen) == 0
               ? SYLVA_EXIT_OK
               : SYLVA_EXIT_USAGE;
}

/* ---- summary ----------------------------------------------------------------- */

static const cJSON *get(const cJSON *o, const char *k)
{
    return cJSON_GetObjectItemCaseSensitive(o, k);
}

/* The accuracy entry of a report LOD with the most pixels (the closest view). */
static const cJSON *best_accuracy(const cJSON *acc)
{
    const cJSON *best = NULL, *a;
    double px = -1;
    cJSON_ArrayForEach(a, acc)
    {
        const cJSON *p = get(a, "pixels");
        double v = cJSON_IsNumber(p) ? p->valuedouble : 0;
        if (cJSON_IsObject(a) && v > px) {
            px = v;
            best = a;
        }
    }
    return best;
}

cJSON *sylva_cli_summary(const char *job_json, const char *report_json, const char *planes_json)
{
    cJSON *job = job_json ? cJSON_Parse(job_json) : NULL;
    cJSON *rep = report_json ? cJSON_Parse(report_json) : NULL;
    cJSON *pl = planes_json ? cJSON_Parse(planes_json) : NULL;
    cJSON *s = cJSON_CreateObject();
    if (!s) goto out;
    const cJSON *rl = get(rep, "lods");
    const cJSON *pll = get(pl, "lods");
    const cJSON *manifest = get(job, "manifest");
    if (!cJSON_IsArray(rl)) /* the daemon's copy of report.json's summary */
        rl = get(get(manifest, "summary"), "lods");
    if (!cJSON_IsArray(rl)) rl = get(manifest, "lods");
    const cJSON *src = cJSON_IsArray(rl) ? rl : pll;
    if (cJSON_IsArray(src)) {
        cJSON *lods = cJSON_AddArrayToObject(s, "lods");
        double total_planes = 0, total_texels = 0;
        int idx = 0;
        const cJSON *l;
        cJSON_ArrayForEach(l, src)
        {
            cJSON *o = cJSON_CreateObject();
            if (!o) break;
            cJSON_AddItemToArray(lods, o);
            const cJSON *name = get(l, "name");
            if (cJSON_IsString(name)) cJSON_AddStringToObject(o, "name", name->valuestring);
            const cJSON *pli = cJSON_GetArrayItem(pll, idx);
            const cJSON *quads = get(l, "quads");
            double planes = -1;
            if (cJSON_IsNumber(quads)) planes = quads->valuedouble;
            else if (cJSON_IsArray(quads)) planes = cJSON_GetArraySize(quads);
            else if (cJSON_IsArray(get(pli, "quads")))
                planes = cJSON_GetArraySize(get(pli, "quads"));
            if (planes >= 0) {
                cJSON_AddNumberToObject(o, "planes", planes);
                total_planes += planes;
            }
            const cJSON *tris = get(l, "triangles");
            if (cJSON_IsNumber(tris)) cJSON_AddNumberToObject(o, "triangles", tris->valuedouble);
            const cJSON *at = get(pli, "atlas");
            if (!at) at = get(l, "atlas");
            const cJSON *w = get(at, "width"), *h = get(at, "height");
            if (cJSON_IsNumber(w) && cJSON_IsNumber(h)) {
                double wh[2] = {w->valuedouble, h->valuedouble};
                cJSON_AddItemToObject(o, "atlas", cJSON_CreateDoubleArray(wh, 2));
                total_texels += wh[0] * wh[1];
            } else if (cJSON_IsNumber(get(l, "texels"))) {
                total_texels += get(l, "texels")->valuedouble;
            }
            const cJSON *sw = get(l, "switch_distance");
            if (cJSON_IsNumber(sw)) cJSON_AddNumberToObject(o, "switch_distance", sw->valuedouble);
            const cJSON *acc = best_accuracy(get(l, "accuracy"));
            if (acc) {
                cJSON *ao = cJSON_AddObjectToObject(o, "accuracy");
                static const char *const keys[] = {"pixels", "iou_mean", "iou_worst",
                                                   "color_error_mean", "depth_error_mean"};
                for (size_t k = 0; ao && k < sizeof keys / sizeof keys[0]; k++) {
                    const cJSON *v = get(acc, keys[k]);
                    if (cJSON_IsNumber(v)) cJSON_AddNumberToObject(ao, keys[k], v->valuedouble);
                }
            }
            idx++;
        }
        cJSON_AddNumberToObject(s, "planes", total_planes);
        if (total_texels > 0) cJSON_AddNumberToObject(s, "atlas_texels", total_texels);
    }
    /* Warnings: report.json's input.warnings, else the status document's. */
    const cJSON *warn = get(get(rep, "input"), "warnings");
    if (!cJSON_IsArray(warn)) warn = get(job, "warnings");
    if (cJSON_IsArray(warn) && cJSON_GetArraySize(warn) > 0) {
        cJSON *wl = cJSON_AddArrayToObject(s, "warnings");
        const cJSON *w;
        cJSON_ArrayForEach(w, warn)
        {
            if (wl && cJSON_IsString(w))
                cJSON_AddItemToArray(wl, cJSON_CreateString(w->valuestring));
        }
    }
    /* The target's outcome: report.json's, else the status document's. */
    const cJSON *target = get(rep, "target");
    if (!cJSON_IsObject(target)) target = get(job, "target");
    if (cJSON_IsObject(target)) {
        cJSON *t = cJSON_AddObjectToObject(s, "target");
        static const char *const keys[] = {"goal", "met", "chosen", "reason"};
        for (size_t k = 0; t && k < sizeof keys / sizeof keys[0]; k++) {
            const cJSON *v = get(target, keys[k]);
            if (v) cJSON_AddItemToObject(t, keys[k], cJSON_Duplicate(v, 1));
        }
    }
    /* Per-stage times: report.json's are the worker's own; else the job's. */
    const cJSON *times = get(rep, "times");
    if (!cJSON_IsObject(times)) times = get(job, "times");
    if (cJSON_IsObject(times)) {
        cJSON *t = cJSON_AddObjectToObject(s, "times");
        const cJSON *e;
        cJSON_ArrayForEach(e, times)
        {
            if (cJSON_IsNumber(e) && e->string)
                cJSON_AddNumberToObject(t, e->string, e->valuedouble);
        }
    }
out:
    cJSON_Delete(job);
    cJSON_Delete(rep);
    cJSON_Delete(pl);
    return s;
}

typedef struct outbuf {
    char *buf;
    size_t len, used;
} outbuf;

static void put(outbuf *o, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(outbuf *o, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    size_t room = o->used < o->len ? o->len - o->used : 0;
    int n = vsnprintf(room ? o->buf + o->used : NULL, room, fmt, ap);
    va_end(ap);
    if (n > 0) o->used += (size_t)n;
}

size_t sylva_cli_summary_format(const cJSON *s, char *buf, size_t len)
{
    outbuf o = {buf, len, 0};
    if (buf && len) buf[0] = '\0';
    const cJSON *lods = get(s, "lods");
    if (cJSON_IsArray(lods)) {
        put(&o, "  LODs: %d, planes: %.0f", cJSON_GetArraySize(lods),
            cJSON_IsNumber(get(s, "planes")) ? get(s, "planes")->valuedouble : 0.0);
        const cJSON *tx = get(s, "atlas_texels");
        if (cJSON_IsNumber(tx)) put(&o, ", atlas texels: %.0f", tx->valuedouble);
        put(&o, "\n");
        const cJSON *l;
        cJSON_ArrayForEach(l, lods)
        {
            const cJSON *name = get(l, "name"), *pl = get(l, "planes"), *at = get(l, "atlas");
            const cJSON *tri = get(l, "triangles");
            put(&o, "    %-16s", cJSON_IsString(name) ? name->valuestring : "?");
            if (cJSON_IsNumber(tri)) put(&o, " %7.0f triangles", tri->valuedouble);
            /* planes and an atlas only for the levels that have them: a mesh
             * level has neither */
            bool planar = cJSON_IsNumber(pl) && pl->valuedouble > 0;
            if (planar) put(&o, " %5.0f planes", pl->valuedouble);
            if (planar && cJSON_GetArraySize(at) == 2)
                put(&o, "  atlas %.0fx%.0f", cJSON_GetArrayItem(at, 0)->valuedouble,
                    cJSON_GetArrayItem(at, 1)->valuedouble);
            const cJSON *a = get(l, "accuracy");
            if (cJSON_IsObject(a)) {
                const cJSON *px = get(a, "pixels"), *iou = get(a, "iou_mean"),
                            *ce = get(a, "color_error_mean");
                put(&o, "  accuracy");
                if (cJSON_IsNumber(px)) put(&o, " @%.0fpx", px->valuedouble);
                if (cJSON_IsNumber(iou)) put(&o, " IoU %.3f", floor(iou->valuedouble * 1000.0) / 1000.0);
                if (cJSON_IsNumber(ce)) put(&o, " colour error %.3f", ce->valuedouble);
            }
            put(&o, "\n");
        }
    }
    const cJSON *w;
    cJSON_ArrayForEach(w, get(s, "warnings"))
    {
        if (cJSON_IsString(w)) put(&o, "  warning: %s\n", w->valuestring);
    }
    const cJSON *target = get(s, "target");
    if (cJSON_IsTrue(get(target, "met"))) {
        put(&o, "  target met\n");
    } else if (cJSON_IsFalse(get(target, "met"))) {
        const cJSON *why = get(target, "reason");
        put(&o, "  target not met: %s\n",
            cJSON_IsString(why) ? why->valuestring : "see report.json");
    }
    const cJSON *times = get(s, "times");
    if (cJSON_IsObject(times) && cJSON_GetArraySize(times) > 0) {
        put(&o, "  time:");
        const cJSON *e;
        bool first = true;
        cJSON_ArrayForEach(e, times)
        {
            put(&o, "%s %s %.2fs", first ? "" : ",", e->string, e->valuedouble);
            first = false;
        }
        put(&o, "\n");
    }
    if (buf && len && o.used >= len) buf[len - 1] = '\0';
    return o.used;
}

size_t sylva_cli_progress_format(const char *label, const char *stage, double fraction, int try_k,
                                 int tries, double elapsed_s, bool bar, char *buf, size_t len)
{
    if (!(fraction >= 0)) fraction = 0;
    if (fraction > 1) fraction = 1;
    int pct = (int)(fraction * 100 + 1e-9);
    outbuf o = {buf, len, 0};
    if (buf && len) buf[0] = '\0';
    if (bar) {
        char b[21];
        int fill = (int)(fraction * 20 + 1e-9);
        for (int i = 0; i < 20; i++) b[i] = i < fill ? '#' : '.';
        b[20] = '\0';
        put(&o, "%s [%s] %3d%% %-9s", label, b, pct, stage);
        if (try_k > 0) put(&o, " try %d/%d", try_k, tries);
        if (elapsed_s >= 0) put(&o, " %6.1f s", elapsed_s);
    } else {
        put(&o, "%s: %s %d%%", label, stage, pct);
        if (try_k > 0) put(&o, " (try %d of at most %d)", try_k, tries);
        if (elapsed_s >= 0) put(&o, ", %.1f s", elapsed_s);
    }
    if (buf && len && o.used >= len) buf[len - 1] = '\0';
    return o.used;
}

int sylva_cli_exit_code(sylva_status st)
{
    switch (st) {
    case SYLVA_OK:
        return SYLVA_EXIT_OK;
    case SYLVA_ERR_ARG:
        return SYLVA_EXIT_USAGE;
    case SYLVA_ERR_BAKE_FAILED:
    case SYLVA_ERR_REJECTED:
    case SYLVA_ERR_NOT_FOUND:
    case SYLVA_ERR_IO:
        return SYLVA_EXIT_FAILED;
    case SYLVA_ERR_INTEGRITY:
        return SYLVA_EXIT_INTEGRITY;
    case SYLVA_ERR_CANCELLED:
        return SYLVA_EXIT_CANCELLED;
    case SYLVA_ERR_NOMEM:
    case SYLVA_ERR_CONNECT:
    case SYLVA_ERR_TIMEOUT:
    case SYLVA_ERR_AUTH:
    case SYLVA_ERR_BUSY:
    case SYLVA_ERR_SERVER:
    case SYLVA_ERR_PROTOCOL:
    case SYLVA_STATUS_COUNT:
        break;
    }
    return SYLVA_EXIT_SERVICE;
}

int sylva_cli_done_exit_code(const cJSON *summary)
{
    return cJSON_IsFalse(get(get(summary, "target"), "met")) ? SYLVA_EXIT_TARGET : SYLVA_EXIT_OK;
}

int sylva_cli_worse_exit(int a, int b)
{
    /* rank: success 0, unmet target 1, failures 2 + code */
    int ra = a == SYLVA_EXIT_OK ? 0 : a == SYLVA_EXIT_TARGET ? 1 : 2 + a;
    int rb = b == SYLVA_EXIT_OK ? 0 : b == SYLVA_EXIT_TARGET ? 1 : 2 + b;
    return ra >= rb ? a : b;
}
