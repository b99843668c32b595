/* key.h — the content key of a bake and the upload-name rules.
 *
 * key = lowercase hex SHA-256 (OpenSSL EVP) of the byte stream
 *   "sylva-key-v1\n"
 *   "spec " <decimal length> "\n" <spec bytes as uploaded> "\n"
 *   "mesh " <name> " " <decimal length> "\n" <mesh bytes> "\n"
 *   for each companion file in bytewise (strcmp) order of name:
 *   "file " <name> " " <decimal length> "\n" <bytes> "\n"
 * An empty spec part counts as the two bytes "{}". The client (libsylva)
 * computes the same framing; docs/api.md documents it.
 *
 * Names are base names: 1..255 bytes, no '/', '\\', space or control byte
 * (< 0x20 or 0x7f), and not "." or "..".
 */
#ifndef SVD_KEY_H
#define SVD_KEY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "sv.h"

#include "key_rules.h"

#define SVD_KEY_HEX 65                     /* 64 hex digits + NUL */
#define SVD_NAME_MAX SYLVA_UPLOAD_NAME_MAX /* common/key_rules.h */

/* True if name (NUL-terminated) is an acceptable upload/artifact name. */
bool svd_name_valid(const char *name);

/* True if s is exactly 64 lowercase hex digits. */
bool svd_key_valid(const char *s);

/* One part of a bake: bytes in memory (data/size) or a file on disk (path,
 * size read from the file). */
typedef struct svd_key_part {
    const char *name;    /* upload name (ignored for the spec) */
    const uint8_t *data; /* in-memory bytes, or NULL to read path */
    size_t size;         /* length of data when data is non-NULL */
    const char *path;    /* file to hash when data is NULL */
} svd_key_part;

/* Computes the key of spec + mesh + files (files in any order: they are
 * sorted by name here). Fails with SV_ERR_SPEC naming the part for an invalid
 * or duplicate name, SV_ERR_IO for an unreadable file, SV_ERR_NOMEM. */
sv_status svd_key_compute(const svd_key_part *spec, const svd_key_part *mesh,
                          const svd_key_part *files, size_t file_count, char out[SVD_KEY_HEX],
                          sv_error *err);

/* SHA-256 of a buffer, as lowercase hex. */
void svd_sha256_hex(const void *data, size_t size, char out[SVD_KEY_HEX]);

/* SHA-256 of a whole file, as lowercase hex; *size_out (if non-NULL) gets
 * its length. SV_ERR_IO if it cannot be read. */
sv_status svd_sha256_file(const char *path, char out[SVD_KEY_HEX], uint64_t *size_out,
                          sv_error *err);

#endif
