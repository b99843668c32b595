/* key.c — libsylva's pure parts: status table, upload-name rules, the content
 * key framing (docs/api.md "Content key"), SHA-256 through OpenSSL's EVP API,
 * and the retry/backoff policy. No network here. */
#include "sylva.h"

#include "key_rules.h" /* the rules sylvad applies too (common/) */

#include <openssl/evp.h>

#include <sys/stat.h>

#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const struct {
    const char *name;
    const char *message;
} status_table[SYLVA_STATUS_COUNT] = {
    [SYLVA_OK] = {"ok", "success"},
    [SYLVA_ERR_NOMEM] = {"nomem", "out of memory"},
    [SYLVA_ERR_ARG] = {"arg", "invalid argument"},
    [SYLVA_ERR_IO] = {"io", "local file input/output failed"},
    [SYLVA_ERR_CONNECT] = {"connect", "no server could be reached"},
    [SYLVA_ERR_TIMEOUT] = {"timeout", "timed out"},
    [SYLVA_ERR_AUTH] = {"auth", "not authorised (token missing or wrong)"},
    [SYLVA_ERR_NOT_FOUND] = {"not_found", "no such bake or artifact"},
    [SYLVA_ERR_REJECTED] = {"rejected", "the server refused the request"},
    [SYLVA_ERR_BUSY] = {"busy", "the server is busy (queue full)"},
    [SYLVA_ERR_SERVER] = {"server", "the server failed"},
    [SYLVA_ERR_PROTOCOL] = {"protocol", "unexpected response from the server"},
    [SYLVA_ERR_BAKE_FAILED] = {"failed", "the bake failed"},
    [SYLVA_ERR_CANCELLED] = {"cancelled", "the bake was cancelled"},
    [SYLVA_ERR_INTEGRITY] = {"integrity", "a downloaded artifact does not match its SHA-256"},
};

const char *sylva_status_name(sylva_status st)
{
    if ((unsigned)st >= SYLVA_STATUS_COUNT) return "unknown";
    return status_table[st].name;
}

const char *sylva_status_message(sylva_status st)
{
    if ((unsigned)st >= SYLVA_STATUS_COUNT) return "unknown status";
    return status_table[st].message;
}

void sylva_options_init(sylva_options *opts)
{
    if (!opts) return;
    memset(opts, 0, sizeof *opts);
    opts->connect_timeout_ms = 5000;
    opts->request_timeout_ms = 300000;
    opts->max_attempts = 8;
    opts->backoff_base_ms = 250;
    opts->backoff_max_ms = 8000;
    opts->user_agent = "libsylva/" SYLVA_VERSION;
}

long sylva_retry_delay(const sylva_options *opts, int attempt, size_t servers, bool transport_error,
                       long http_status, long retry_after_ms)
{
    sylva_options d;
    sylva_options_init(&d);
    int max_attempts = opts && opts->max_attempts > 0 ? opts->max_attempts : d.max_attempts;
    long base = opts && opts->backoff_base_ms > 0 ? opts->backoff_base_ms : d.backoff_base_ms;
    long cap = opts && opts->backoff_max_ms > 0 ? opts->backoff_max_ms : d.backoff_max_ms;
    bool retryable = transport_error || http_status == 429 ||
                     (http_status >= 500 && http_status <= 599);
    if (!retryable || attempt < 1 || attempt >= max_attempts) return -1;
    if (servers == 0) servers = 1;
    /* Fail over first: the next server in the list is tried at once, unless a
     * full round over every server has just failed. */
    if ((size_t)attempt % servers != 0) return 0;
    size_t round = (size_t)attempt / servers; /* 1, 2, ... */
    long delay = base;
    for (size_t r = 1; r < round && delay < cap; r++) delay = delay > cap / 2 ? cap : delay * 2;
    if (delay > cap) delay = cap;
    if (retry_after_ms > delay) {
        long ra_cap = cap > LONG_MAX / 4 ? cap : cap * 4;
        delay = retry_after_ms < ra_cap ? retry_after_ms : ra_cap;
    }
    return delay;
}

_Static_assert(SYLVA_NAME_MAX == SYLVA_UPLOAD_NAME_MAX, "sylva.h's name limit is the server's");
_Static_assert(SYLVA_KEY_HEX == SYLVA_KEY_HEX_LEN, "a key is 64 hex digits on both sides");

bool sylva_name_valid(const char *name)
{
    return sylva_upload_name_ok(name);
}

static void set_err(char *errbuf, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void set_err(char *errbuf, size_t errlen, const char *fmt, ...)
{
    if (!errbuf || errlen == 0) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(errbuf, errlen, fmt, ap);
    va_end(ap);
}

/* Feeds a whole file into the digest; *size receives its length. */
static sylva_status digest_file(EVP_MD_CTX *md, const char *path, uint64_t *size, char *errbuf,
                                size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        set_err(errbuf, errlen, "cannot open %s: %s", path, strerror(errno));
        return SYLVA_ERR_IO;
    }
    sylva_status st = SYLVA_OK;
    unsigned char buf[65536];
    uint64_t total = 0;
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, f)) > 0) {
        if (md && EVP_DigestUpdate(md, buf, got) != 1) {
            st = SYLVA_ERR_NOMEM;
            set_err(errbuf, errlen, "SHA-256 update failed");
            break;
        }
        total += got;
    }
    if (st == SYLVA_OK && ferror(f)) {
        set_err(errbuf, errlen, "cannot read %s: %s", path, strerror(errno));
        st = SYLVA_ERR_IO;
    }
    fclose(f);
    *size = total;
    return st;
}

/* The framing's header (which holds the length) precedes the bytes, so a file
 * on disk is stat'ed first and the streamed length is checked against it. */
static sylva_status file_size(const sylva_file *f, uint64_t *size, char *errbuf, size_t errlen)
{
    if (f->data || !f->path) {
        *size = f->size;
        return SYLVA_OK;
    }
    struct stat sb;
    if (stat(f->path, &sb) != 0) {
        set_err(errbuf, errlen, "cannot stat %s: %s", f->path, strerror(errno));
        return SYLVA_ERR_IO;
    }
    if (!S_ISREG(sb.st_mode)) {
        set_err(errbuf, errlen, "%s is not a regular file", f->path);
        return SYLVA_ERR_IO;
    }
    *size = (uint64_t)sb.st_size;
    return SYLVA_OK;
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* The upload name of f (its name, or the base name of its path), or NULL. */
static const char *upload_name(const sylva_file *f)
{
    if (f->name) return f->name;
    if (f->path) return base_name(f->path);
    return NULL;
}

static int cmp_file_by_name(const void *a, const void *b)
{
    const sylva_file *const *fa = a;
    const sylva_file *const *fb = b;
    /* strcmp compares as unsigned char: bytewise order. */
    return strcmp(upload_name(*fa), upload_name(*fb));
}

static sylva_status digest_part(EVP_MD_CTX *md, const char *kind, const sylva_file *f, char *errbuf,
                                size_t errlen)
{
    uint64_t size = 0;
    sylva_status st = file_size(f, &size, errbuf, errlen);
    if (st != SYLVA_OK) return st;
    char head[SYLVA_NAME_MAX + 64];
    int n = sylva_key_part_head(head, sizeof head, kind, upload_name(f), (unsigned long long)size);
    if (n < 0 || EVP_DigestUpdate(md, head, (size_t)n) != 1) {
        set_err(errbuf, errlen, "SHA-256 update failed");
        return SYLVA_ERR_NOMEM;
    }
    if (f->data) {
        if (f->size && EVP_DigestUpdate(md, f->data, f->size) != 1) {
            set_err(errbuf, errlen, "SHA-256 update failed");
            return SYLVA_ERR_NOMEM;
        }
    } else {
        uint64_t got = 0;
        st = digest_file(md, f->path, &got, errbuf, errlen);
        if (st != SYLVA_OK) return st;
        if (got != size) {
            set_err(errbuf, errlen, "%s changed while it was read", f->path);
            return SYLVA_ERR_IO;
        }
    }
    if (EVP_DigestUpdate(md, "\n", 1) != 1) {
        set_err(errbuf, errlen, "SHA-256 update failed");
        return SYLVA_ERR_NOMEM;
    }
    return SYLVA_OK;
}

/* Checks the names of in: valid, and no two equal (the mesh included). */
static sylva_status check_names(const sylva_input *in, const sylva_file **sorted, char *errbuf,
                                size_t errlen)
{
    if (!in->mesh.data && !in->mesh.path) {
        set_err(errbuf, errlen, "the mesh has neither data nor a path");
        return SYLVA_ERR_ARG;
    }
    const char *mname = upload_name(&in->mesh);
    if (!sylva_name_valid(mname)) {
        set_err(errbuf, errlen,
                "invalid mesh name \"%.64s\": names are base names without "
                "spaces or control characters, 1-255 bytes",
                mname ? mname : "");
        return SYLVA_ERR_ARG;
    }
    for (size_t i = 0; i < in->file_count; i++) {
        const sylva_file *f = &in->files[i];
        const char *name = upload_name(f);
        if (!f->data && !f->path) {
            set_err(errbuf, errlen, "file %zu has neither data nor a path", i);
            return SYLVA_ERR_ARG;
        }
        if (!sylva_name_valid(name)) {
            set_err(errbuf, errlen,
                    "invalid file name \"%.64s\": names are base names without "
                    "spaces or control characters, 1-255 bytes",
                    name ? name : "");
            return SYLVA_ERR_ARG;
        }
        if (strcmp(name, mname) == 0) {
            set_err(errbuf, errlen, "file name \"%s\" is the mesh's name too", name);
            return SYLVA_ERR_ARG;
        }
        sorted[i] = f;
    }
    if (in->file_count > 1) qsort(sorted, in->file_count, sizeof *sorted, cmp_file_by_name);
    for (size_t i = 1; i < in->file_count; i++) {
        if (strcmp(upload_name(sorted[i - 1]), upload_name(sorted[i])) == 0) {
            set_err(errbuf, errlen, "duplicate file name \"%s\"", upload_name(sorted[i]));
            return SYLVA_ERR_ARG;
        }
    }
    return SYLVA_OK;
}

sylva_status sylva_key_compute(const sylva_input *in, char key[SYLVA_KEY_HEX + 1], char *errbuf,
                               size_t errlen)
{
    if (errbuf && errlen) errbuf[0] = '\0';
    if (!in || !key) {
        set_err(errbuf, errlen, "sylva_key_compute: NULL input or key");
        return SYLVA_ERR_ARG;
    }
    key[0] = '\0';
    sylva_status st = SYLVA_OK;
    const sylva_file **sorted = NULL;
    EVP_MD_CTX *md = NULL;
    if (in->file_count) {
        sorted = calloc(in->file_count, sizeof *sorted);
        if (!sorted) {
            set_err(errbuf, errlen, "out of memory for %zu file names", in->file_count);
            return SYLVA_ERR_NOMEM;
        }
    }
    st = check_names(in, sorted, errbuf, errlen);
    if (st != SYLVA_OK) goto out;
    md = EVP_MD_CTX_new();
    if (!md || EVP_DigestInit_ex(md, EVP_sha256(), NULL) != 1) {
        set_err(errbuf, errlen, "cannot start SHA-256");
        st = SYLVA_ERR_NOMEM;
        goto out;
    }
    /* An empty spec part counts as "{}" (the server's rule). */
    size_t spec_len = 0;
    const char *spec = sylva_key_spec(in->spec, in->spec ? in->spec_len : 0, &spec_len);
    char head[64];
    int n = sylva_key_part_head(head, sizeof head, "spec", NULL, (unsigned long long)spec_len);
    if (n < 0 || EVP_DigestUpdate(md, SYLVA_KEY_MAGIC, SYLVA_KEY_MAGIC_LEN) != 1 ||
        EVP_DigestUpdate(md, head, (size_t)n) != 1 ||
        (spec_len && EVP_DigestUpdate(md, spec, spec_len) != 1) ||
        EVP_DigestUpdate(md, "\n", 1) != 1) {
        set_err(errbuf, errlen, "SHA-256 update failed");
        st = SYLVA_ERR_NOMEM;
        goto out;
    }
    st = digest_part(md, "mesh", &in->mesh, errbuf, errlen);
    for (size_t i = 0; st == SYLVA_OK && i < in->file_count; i++)
        st = digest_part(md, "file", sorted[i], errbuf, errlen);
    if (st != SYLVA_OK) goto out;
    unsigned char out_md[EVP_MAX_MD_SIZE];
    unsigned int out_len = 0;
    if (EVP_DigestFinal_ex(md, out_md, &out_len) != 1 || out_len != 32) {
        set_err(errbuf, errlen, "SHA-256 final failed");
        st = SYLVA_ERR_NOMEM;
        goto out;
    }
    sylva_hex32(out_md, key);
out:
    EVP_MD_CTX_free(md);
    free(sorted);
    return st;
}

sylva_status sylva_sha256_hex(const void *data, size_t size, char hex[SYLVA_KEY_HEX + 1])
{
    if ((!data && size) || !hex) return SYLVA_ERR_ARG;
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    if (EVP_Digest(size ? data : "", size, md, &len, EVP_sha256(), NULL) != 1 || len != 32)
        return SYLVA_ERR_NOMEM;
    sylva_hex32(md, hex);
    return SYLVA_OK;
}

sylva_status sylva_sha256_file(const char *path, char hex[SYLVA_KEY_HEX + 1])
{
    if (!path || !hex) return SYLVA_ERR_ARG;
    EVP_MD_CTX *md = EVP_MD_CTX_new();
    if (!md || EVP_DigestInit_ex(md, EVP_sha256(), NULL) != 1) {
        EVP_MD_CTX_free(md);
        return SYLVA_ERR_NOMEM;
    }
    uint64_t size = 0;
    sylva_status st = digest_file(md, path, &size, NULL, 0);
    unsigned char out[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    if (st == SYLVA_OK && (EVP_DigestFinal_ex(md, out, &len) != 1 || len != 32))
        st = SYLVA_ERR_NOMEM;
    if (st == SYLVA_OK) sylva_hex32(out, hex);
    EVP_MD_CTX_free(md);
    return st;
}
