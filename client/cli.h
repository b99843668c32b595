/* cli.h — the pure parts of the `sylva` command (client/sylva.c): command-line
 * parsing, grouping of meshes and companions into bakes, spec building from
 * --method/--set, the result summary, exit codes. Internal to the command (not
 * part of libsylva's public API; kept here so the unit tests can reach them).
 * User guide: docs/client.md. */
#ifndef SYLVA_CLI_H
#define SYLVA_CLI_H

#include <cjson/cJSON.h>

#include "sylva.h"

#include <stdbool.h>
#include <stddef.h>

#define SYLVA_DEFAULT_SERVER "http://127.0.0.1:8080"

/* Exit codes of the command: one table for sylva, sylva-bake and what a
 * libsylva status maps to (sylva_cli_exit_code; docs/client.md "Exit status").
 * The same outcome has the same code in both tools. */
enum {
    SYLVA_EXIT_OK = 0,
    SYLVA_EXIT_FAILED = 1,    /* the input was refused or missing (a local file that cannot
                                 be read included), or the bake failed */
    SYLVA_EXIT_USAGE = 2,     /* bad command line */
    SYLVA_EXIT_TARGET = 3,    /* done (outputs written or downloaded), but the spec's
                                 "target" was not met */
    SYLVA_EXIT_INTEGRITY = 4, /* a downloaded artifact did not match its SHA-256 */
    SYLVA_EXIT_CANCELLED = 5, /* the bake was cancelled */
    SYLVA_EXIT_SERVICE = 6    /* no server, server error, busy, timeout, auth, protocol */
};

typedef enum sylva_cmd {
    SYLVA_CMD_NONE = 0,
    SYLVA_CMD_BAKE,
    SYLVA_CMD_STATUS,
    SYLVA_CMD_FETCH,
    SYLVA_CMD_CANCEL,
    SYLVA_CMD_HEALTH,
    SYLVA_CMD_HELP
} sylva_cmd;

typedef enum sylva_progress_mode {
    SYLVA_PROGRESS_AUTO = 0, /* bar on a terminal, plain lines otherwise */
    SYLVA_PROGRESS_BAR,
    SYLVA_PROGRESS_PLAIN,
    SYLVA_PROGRESS_NONE
} sylva_progress_mode;

/* A parsed command line. Pointers point into argv or into storage the struct
 * owns (freed by sylva_cli_free). */
typedef struct sylva_cli {
    sylva_cmd cmd;
    char **servers; /* --server (repeatable, comma lists), else SYLVA_SERVER, else default */
    size_t server_count;
    const char *token;            /* --token, else SYLVA_TOKEN, else NULL */
    bool json;                    /* --json */
    bool delete_done;             /* --delete: `cancel` may delete a finished bake */
    sylva_progress_mode progress; /* --progress=auto|bar|plain|none, --quiet = none */
    const char *out;              /* --out DIR */
    const char *spec_path;        /* --spec FILE */
    const char *method;           /* --method M */
    const char **sets;            /* --set key=value, --units U, --up A, in order */
    size_t set_count;
    char **owned; /* the sets made of --units and --up */
    size_t owned_count;
    bool quiet;   /* -q, --quiet: no progress, no summary table, no notes */
    bool verbose; /* -v, --verbose: the spec sent and each companion looked for */
    const char **args; /* positional arguments; NULL entries are "--" separators */
    size_t arg_count;
    double timeout_s; /* --timeout S (bake wait), 0 = none */
    double wait_s;    /* status --wait S */
    int retries;      /* --retries N (attempts = N + 1); -1 = library default */
} sylva_cli;

/* Parses argv (argv[0] is the program). Options may come before or after the
 * command. env_server / env_token are the values of SYLVA_SERVER / SYLVA_TOKEN
 * (may be NULL). Returns SYLVA_EXIT_OK, or SYLVA_EXIT_USAGE with a one-line
 * message in err. On failure *cli is still safe to sylva_cli_free. */
int sylva_cli_parse(int argc, char **argv, const char *env_server, const char *env_token,
                    sylva_cli *cli, char *err, size_t errlen);

/* Frees what sylva_cli_parse allocated and zeroes *cli. */
void sylva_cli_free(sylva_cli *cli);

/* One bake of a batch: a mesh, its companions, and where its results go. */
typedef struct sylva_bake_group {
    const char *mesh;
    const char **files;
    size_t file_count;
    char out_dir[4096];
} sylva_bake_group;

/* Groups the positional arguments of `sylva bake` into bakes (docs/client.md
 * "Several meshes"):
 *   - "--" separates groups explicitly; in a group the first file is the mesh,
 *     the rest are its companions;
 *   - without "--": the files with a mesh extension (.obj .gltf .glb .ply .fbx
 *     .dae, any case) are the meshes; with one mesh every other file is its
 *     companion; with several, each other file belongs to the one mesh in its
 *     own directory (an error when there is none or more than one).
 * One bake writes into out; several write into out/<mesh stem>/ (the base
 * name with '.' replaced by '_' where two stems collide).
 * Returns SYLVA_EXIT_OK or SYLVA_EXIT_USAGE with err set. *groups (free with
 * sylva_cli_groups_free) receives *count groups. */
int sylva_cli_groups(const sylva_cli *cli, sylva_bake_group **groups, size_t *count, char *err,
                     size_t errlen);
void sylva_cli_groups_free(sylva_bake_group *groups, size_t count);

/* True when the file name ends with a mesh extension (see above). */
bool sylva_cli_is_mesh(const char *path);

/* Builds the spec to upload. base (may be NULL: none) is the --spec file's
 * bytes. Without method and sets the spec is base exactly (or NULL when base is
 * NULL: the client then sends "{}"). Otherwise base (or {}) is parsed, "method"
 * is set, and each "key=value" is applied: the value is JSON when it parses as
 * JSON, else a string; an undotted key is a setting of the method
 * (spec[method][key]), a dotted key a path from the spec root (scene.viewer).
 * *out (free()) receives the bytes, *out_len their length. */
int sylva_cli_build_spec(const char *base, size_t base_len, const char *method,
                         const char *const *sets, size_t set_count, char **out, size_t *out_len,
                         char *err, size_t errlen);

/* Builds the summary of a done bake from the job's JSON and the downloaded
 * report.json and planes.json (each may be NULL): {"lods":[{"name","planes",
 * "triangles","atlas":[w,h],"accuracy":{"pixels","iou_mean","color_error_mean"}}],
 * "planes": total, "atlas_texels": total, "warnings": [text] (report.json's
 * input.warnings, else the status document's "warnings"; left out when none),
 * "target": {"goal","met","chosen","reason"} (report.json's target, else the
 * status document's; left out when the spec had none),
 * "times": {stage: seconds}}. Never NULL unless out of memory; missing sources
 * leave fields out. */
cJSON *sylva_cli_summary(const char *job_json, const char *report_json, const char *planes_json);

/* Formats a summary as short human-readable lines into buf (one line per
 * level: its name, triangles, and planes and atlas only when it has planes;
 * one "  warning: ..." line per warning, "  target met" or "  target not met: why";
 * always NUL-terminated, truncated to len). Returns the length it wanted. */
size_t sylva_cli_summary_format(const cJSON *summary, char *buf, size_t len);

/* Formats one progress line, "label: stage 42% (try 2 of at most 4), 3.1 s",
 * or with bar "label [########............]  42% stage  try 2/4  3.1 s";
 * the try part only when try_k > 0, the time only when elapsed_s >= 0. */
size_t sylva_cli_progress_format(const char *label, const char *stage, double fraction, int try_k,
                                 int tries, double elapsed_s, bool bar, char *buf, size_t len);

/* The exit code for a libsylva status. */
int sylva_cli_exit_code(sylva_status st);

/* The exit code of a bake that is done and downloaded, from its summary:
 * SYLVA_EXIT_TARGET when summary.target.met is false, else SYLVA_EXIT_OK. */
int sylva_cli_done_exit_code(const cJSON *summary);

/* The exit code of a batch holding bakes that ended with a and b: any failure
 * (1, 2, 4-6) outranks an unmet target (3), which outranks success; among
 * failures the higher code wins. */
int sylva_cli_worse_exit(int a, int b);

#endif
