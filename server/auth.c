/* auth.c — bearer tokens and client identity (see auth.h). */
#include "auth.h"

#include <errno.h>
#include <openssl/crypto.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "key.h"

struct svd_tokens {
    char **tok;
    size_t count;
};

void svd_tokens_free(svd_tokens *t)
{
    if (!t) return;
    for (size_t i = 0; i < t->count; i++) {
        OPENSSL_cleanse(t->tok[i], strlen(t->tok[i]));
        free(t->tok[i]);
    }
    free(t->tok);
    free(t);
}

svd_tokens *svd_tokens_load(const char *path, sv_error *err)
{
    FILE *f = fopen(path, "re");
    if (!f) {
        sv_fail(err, SV_ERR_IO, "%s: cannot open tokens file: %s", path, strerror(errno));
        return NULL;
    }
    svd_tokens *t = calloc(1, sizeof *t);
    char line[1024];
    size_t cap = 0;
    while (t && fgets(line, sizeof line, f)) {
        char *s = line;
        while (*s == ' ' || *s == '\t') s++;
        size_t n = strcspn(s, " \t\r\n");
        s[n] = '\0';
        if (!*s || *s == '#') continue;
        if (t->count == cap) {
            cap = cap ? cap * 2 : 8;
            char **nt = realloc(t->tok, cap * sizeof *nt);
            if (!nt) {
                svd_tokens_free(t);
                t = NULL;
                break;
            }
            t->tok = nt;
        }
        t->tok[t->count] = strdup(s);
        if (t->tok[t->count]) t->count++;
    }
    fclose(f);
    OPENSSL_cleanse(line, sizeof line);
    if (!t) {
        sv_fail(err, SV_ERR_NOMEM, "tokens: out of memory");
        return NULL;
    }
    if (t->count == 0) {
        svd_tokens_free(t);
        sv_fail(err, SV_ERR_SPEC, "%s: no token in the file", path);
        return NULL;
    }
    return t;
}

static const char *bearer(const char *authorization)
{
    if (!authorization || strncasecmp(authorization, "Bearer ", 7) != 0) return NULL;
    const char *p = authorization + 7;
    while (*p == ' ') p++;
    return *p ? p : NULL;
}

bool svd_tokens_check(const svd_tokens *t, const char *authorization)
{
    const char *b = bearer(authorization);
    if (!t || !b) return false;
    size_t bl = strlen(b);
    bool ok = false;
    for (size_t i = 0; i < t->count; i++) {
        size_t tl = strlen(t->tok[i]);
        if (tl == bl && CRYPTO_memcmp(t->tok[i], b, bl) == 0) ok = true;
    }
    return ok;
}

void svd_client_id(const char *authorization, const char *remote_addr, char *out, size_t cap)
{
    const char *b = bearer(authorization);
    if (b) {
        char h[SVD_KEY_HEX];
        svd_sha256_hex(b, strlen(b), h);
        snprintf(out, cap, "token:%.16s", h);
    } else {
        snprintf(out, cap, "addr:%s", remote_addr ? remote_addr : "unknown");
    }
}
