/* auth.c — bearer tokens and client identity (see auth.h). */
#include "auth.h"

#include <errno.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "key.h"

#define SHA256_LEN 32

/* Only the SHA-256 of each token is kept: a bearer is checked by hashing it
 * and comparing fixed-size digests, so neither the time of the check nor the
 * memory of the daemon depends on the tokens' content or length. */
struct svd_tokens {
    unsigned char (*digest)[SHA256_LEN];
    size_t count;
};

static void sha256(const void *data, size_t size, unsigned char out[SHA256_LEN])
{
    unsigned int n = 0;
    EVP_Digest(data, size, out, &n, EVP_sha256(), NULL);
}

void svd_tokens_free(svd_tokens *t)
{
    if (!t) return;
    if (t->digest) OPENSSL_cleanse(t->digest, t->count * sizeof *t->digest);
    free(t->digest);
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
    char *line = NULL;
    size_t linecap = 0, cap = 0, lineno = 0;
    ssize_t len;
    sv_status st = t ? SV_OK : sv_fail(err, SV_ERR_NOMEM, "tokens: out of memory");
    errno = 0;
    /* getline: a line of any length arrives whole, never split in two. */
    while (st == SV_OK && (len = getline(&line, &linecap, f)) >= 0) {
        lineno++;
        if (memchr(line, '\0', (size_t)len)) {
            st = sv_fail(err, SV_ERR_SPEC, "%s:%zu: a NUL byte in the line", path, lineno);
            break;
        }
        char *s = line;
        while (*s == ' ' || *s == '\t') s++;
        size_t n = strcspn(s, " \t\r\n");
        if (!n || *s == '#') continue;
        if (n > SVD_TOKEN_MAX) {
            st = sv_fail(err, SV_ERR_SPEC,
                         "%s:%zu: a token of %zu bytes, over the limit of %d bytes", path, lineno,
                         n, SVD_TOKEN_MAX);
            break;
        }
        if (t->count == cap) {
            cap = cap ? cap * 2 : 8;
            unsigned char(*nd)[SHA256_LEN] = realloc(t->digest, cap * sizeof *nd);
            if (!nd) {
                st = sv_fail(err, SV_ERR_NOMEM, "tokens: out of memory");
                break;
            }
            t->digest = nd;
        }
        sha256(s, n, t->digest[t->count++]);
    }
    if (st == SV_OK && ferror(f))
        st = sv_fail(err, SV_ERR_IO, "%s: cannot read tokens file: %s", path, strerror(errno));
    fclose(f);
    if (line) OPENSSL_cleanse(line, linecap);
    free(line);
    if (st == SV_OK && t->count == 0)
        st = sv_fail(err, SV_ERR_SPEC, "%s: no token in the file", path);
    if (st != SV_OK) {
        svd_tokens_free(t);
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
    unsigned char d[SHA256_LEN];
    sha256(b, strlen(b), d);
    /* every digest compared, no early exit: the time depends on the number
     * of tokens only */
    int ok = 0;
    for (size_t i = 0; i < t->count; i++) ok |= CRYPTO_memcmp(t->digest[i], d, SHA256_LEN) == 0;
    OPENSSL_cleanse(d, sizeof d);
    return ok != 0;
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
