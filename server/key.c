/* key.c — content key framing and SHA-256 helpers (OpenSSL EVP; see key.h).
 * The rules themselves (names, framing, hex) are common/key_rules.h's,
 * shared with libsylva. */
#include "key.h"

#include "key_rules.h"

#include <errno.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

bool svd_name_valid(const char *name)
{
    return sylva_upload_name_ok(name);
}

bool svd_key_valid(const char *s)
{
    return sylva_key_hex_ok(s);
}

void svd_sha256_hex(const void *data, size_t size, char out[SVD_KEY_HEX])
{
    unsigned char md[32];
    unsigned int mdlen = 0;
    EVP_Digest(data, size, md, &mdlen, EVP_sha256(), NULL);
    sylva_hex32(md, out);
}

/* Feeds a file's bytes into ctx; returns its size through *size. */
static sv_status hash_fd(EVP_MD_CTX *ctx, int fd, const char *path, uint64_t *size, sv_error *err)
{
    unsigned char buf[65536];
    uint64_t total = 0;
    for (;;) {
        ssize_t r = read(fd, buf, sizeof buf);
        if (r < 0) {
            if (errno == EINTR) continue;
            return sv_fail(err, SV_ERR_IO, "%s: read failed: %s", path, strerror(errno));
        }
        if (r == 0) break;
        EVP_DigestUpdate(ctx, buf, (size_t)r);
        total += (uint64_t)r;
    }
    *size = total;
    return SV_OK;
}

sv_status svd_sha256_file(const char *path, char out[SVD_KEY_HEX], uint64_t *size_out,
                          sv_error *err)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return sv_fail(err, SV_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    if (!ctx) {
        close(fd);
        return sv_fail(err, SV_ERR_NOMEM, "sha256: out of memory");
    }
    EVP_DigestInit_ex(ctx, EVP_sha256(), NULL);
    uint64_t size = 0;
    sv_status st = hash_fd(ctx, fd, path, &size, err);
    close(fd);
    if (st == SV_OK) {
        unsigned char md[32];
        unsigned int mdlen = 0;
        EVP_DigestFinal_ex(ctx, md, &mdlen);
        sylva_hex32(md, out);
        if (size_out) *size_out = size;
    }
    EVP_MD_CTX_free(ctx);
    return st;
}

/* Hashes one framed part: header line (already formatted without the length),
 * the length, the bytes, "\n". A file part is read twice (size by fstat first)
 * so the length precedes the bytes as the framing requires. */
static sv_status frame_part(EVP_MD_CTX *ctx, const char *prefix, const svd_key_part *p,
                            sv_error *err)
{
    char head[SVD_NAME_MAX + 64];
    if (p->data || !p->path) {
        const uint8_t *d = p->data;
        size_t n = p->size;
        if (!d || strcmp(prefix, "spec") == 0) /* absent or empty spec: "{}" */
            d = (const uint8_t *)sylva_key_spec((const char *)d, d ? n : 0, &n);
        int hl = sylva_key_part_head(head, sizeof head, prefix, p->name, n);
        if (hl < 0) return sv_fail(err, SV_ERR_SPEC, "%s: name too long", prefix);
        EVP_DigestUpdate(ctx, head, (size_t)hl);
        EVP_DigestUpdate(ctx, d, n);
        EVP_DigestUpdate(ctx, "\n", 1);
        return SV_OK;
    }
    int fd = open(p->path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return sv_fail(err, SV_ERR_IO, "%s: cannot open: %s", p->path, strerror(errno));
    off_t end = lseek(fd, 0, SEEK_END);
    if (end < 0 || lseek(fd, 0, SEEK_SET) != 0) {
        close(fd);
        return sv_fail(err, SV_ERR_IO, "%s: cannot seek", p->path);
    }
    if (end == 0 && strcmp(prefix, "spec") == 0) {
        close(fd);
        svd_key_part empty = {.data = (const uint8_t *)"{}", .size = 2};
        return frame_part(ctx, prefix, &empty, err);
    }
    int hl = sylva_key_part_head(head, sizeof head, prefix, p->name, (unsigned long long)end);
    if (hl < 0) {
        close(fd);
        return sv_fail(err, SV_ERR_SPEC, "%s: name too long", prefix);
    }
    EVP_DigestUpdate(ctx, head, (size_t)hl);
    uint64_t got = 0;
    sv_status st = hash_fd(ctx, fd, p->path, &got, err);
    close(fd);
    if (st != SV_OK) return st;
    if (got != (uint64_t)end) return sv_fail(err, SV_ERR_IO, "%s: changed while hashing", p->path);
    EVP_DigestUpdate(ctx, "\n", 1);
    return SV_OK;
}

static int cmp_part_ptr(const void *a, const void *b)
{
    const svd_key_part *pa = *(const svd_key_part *const *)a;
    const svd_key_part *pb = *(const svd_key_part *const *)b;
    return strcmp(pa->name, pb->name);
}

sv_status svd_key_compute(const svd_key_part *spec, const svd_key_part *mesh,
                          const svd_key_part *files, size_t file_count, char out[SVD_KEY_HEX],
                          sv_error *err)
{
    if (!mesh || !svd_name_valid(mesh->name))
        return sv_fail(err, SV_ERR_SPEC, "mesh: invalid or missing file name");
    const svd_key_part **order = sv_calloc(file_count ? file_count : 1, sizeof *order);
    if (!order) return sv_fail(err, SV_ERR_NOMEM, "key: out of memory");
    sv_status st = SV_OK;
    EVP_MD_CTX *ctx = NULL;
    for (size_t i = 0; i < file_count; i++) {
        if (!svd_name_valid(files[i].name)) {
            st = sv_fail(err, SV_ERR_SPEC, "file %zu: invalid name", i);
            goto out;
        }
        order[i] = &files[i];
    }
    qsort(order, file_count, sizeof *order, cmp_part_ptr);
    for (size_t i = 0; i < file_count; i++) {
        if (strcmp(order[i]->name, mesh->name) == 0 ||
            (i > 0 && strcmp(order[i]->name, order[i - 1]->name) == 0)) {
            st = sv_fail(err, SV_ERR_SPEC, "file '%s': duplicate name", order[i]->name);
            goto out;
        }
    }
    ctx = EVP_MD_CTX_new();
    if (!ctx) {
        st = sv_fail(err, SV_ERR_NOMEM, "key: out of memory");
        goto out;
    }
    EVP_DigestInit_ex(ctx, EVP_sha256(), NULL);
    EVP_DigestUpdate(ctx, SYLVA_KEY_MAGIC, SYLVA_KEY_MAGIC_LEN);
    svd_key_part nospec = {0};
    if ((st = frame_part(ctx, "spec", spec ? spec : &nospec, err)) != SV_OK) goto out;
    if ((st = frame_part(ctx, "mesh", mesh, err)) != SV_OK) goto out;
    for (size_t i = 0; i < file_count; i++)
        if ((st = frame_part(ctx, "file", order[i], err)) != SV_OK) goto out;
    unsigned char md[32];
    unsigned int mdlen = 0;
    EVP_DigestFinal_ex(ctx, md, &mdlen);
    sylva_hex32(md, out);
out:
    EVP_MD_CTX_free(ctx);
    free(order);
    return st;
}
