/* fuzz_multipart.c — libFuzzer target: the streaming multipart/form-data
 * parser (server/multipart.c; RFC 7578, RFC 2046 §5.1) and the boundary
 * extraction. The first byte picks the chunk size, so the same body is also
 * fed one byte at a time; the part data handed out never exceeds the input. */
#include <stdlib.h>
#include <string.h>

#include "multipart.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

typedef struct tally {
    size_t parts, bytes, open;
} tally;

static int on_begin(void *u, const svd_part_info *info)
{
    tally *t = u;
    if (t->open) abort(); /* begin without end */
    if (strnlen(info->name, SVD_MP_FIELD_MAX) == SVD_MP_FIELD_MAX) abort();
    t->open = 1;
    t->parts++;
    return 0;
}

static int on_data(void *u, const uint8_t *d, size_t n)
{
    tally *t = u;
    if (!t->open || (n && !d)) abort();
    t->bytes += n;
    return 0;
}

static int on_end(void *u)
{
    tally *t = u;
    if (!t->open) abort();
    t->open = 0;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    size_t chunk = (size_t)(data[0] % 17) + 1;
    data++;
    size--;
    /* A Content-Type value from the bytes up to the first newline. */
    const uint8_t *nl = memchr(data, '\n', size < 200 ? size : 200);
    if (nl) {
        size_t n = (size_t)(nl - data);
        char *ct = malloc(n + 1);
        if (!ct) return 0;
        memcpy(ct, data, n);
        ct[n] = 0;
        char b[71];
        sv_error e = {0};
        (void)svd_multipart_boundary(ct, b, &e);
        free(ct);
    }
    svd_multipart_callbacks cb = {on_begin, on_data, on_end};
    tally t = {0};
    svd_multipart *mp = svd_multipart_create("xyzBOUNDARY", &cb, &t);
    if (!mp) return 0;
    sv_error e = {0};
    sv_status st = SV_OK;
    for (size_t at = 0; at < size && st == SV_OK; at += chunk) {
        size_t n = size - at < chunk ? size - at : chunk;
        uint8_t *piece = malloc(n); /* exact-size copy: ASan catches overreads */
        if (!piece) break;
        memcpy(piece, data + at, n);
        st = svd_multipart_feed(mp, piece, n, &e);
        free(piece);
    }
    if (st == SV_OK && svd_multipart_finish(mp, &e) == SV_OK && t.open) abort();
    if (t.bytes > size) abort();
    svd_multipart_destroy(mp);
    return 0;
}
