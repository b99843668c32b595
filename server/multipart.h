/* multipart.h — streaming multipart/form-data parser (RFC 7578, RFC 2046 §5.1).
 *
 * Feed the request body in chunks of any size (down to one byte); part data
 * is handed to callbacks as it arrives, so a part of any size (binary or not)
 * passes through a bounded buffer: memory is O(boundary + header limit +
 * chunk), never O(part). Pure: no I/O, no globals; fuzzed and unit-tested.
 */
#ifndef SVD_MULTIPART_H
#define SVD_MULTIPART_H

#include <stddef.h>
#include <stdint.h>

#include "sv.h"

#define SVD_MP_HEADER_MAX 8192 /* bytes of headers per part */
#define SVD_MP_FIELD_MAX 256   /* name / filename / content type, bytes */

typedef struct svd_part_info {
    char name[SVD_MP_FIELD_MAX];         /* form field name ("spec", "mesh", "file") */
    char filename[SVD_MP_FIELD_MAX];     /* "" when the part has no filename */
    char content_type[SVD_MP_FIELD_MAX]; /* "" when absent */
    int has_filename;
    size_t filename_len; /* the whole value's length: longer than
                                             filename holds = truncated, refuse it */
} svd_part_info;

/* Callbacks return 0 to continue; any other value stops the parser with
 * SV_ERR_IO ("callback refused") — the caller's own error then explains. */
typedef struct svd_multipart_callbacks {
    int (*part_begin)(void *user, const svd_part_info *info);
    int (*part_data)(void *user, const uint8_t *data, size_t size);
    int (*part_end)(void *user);
} svd_multipart_callbacks;

typedef struct svd_multipart svd_multipart;

/* Extracts the boundary parameter from a Content-Type value
 * ("multipart/form-data; boundary=XYZ" or quoted). Returns SV_ERR_FORMAT if the
 * type is not multipart/form-data, SV_ERR_PARSE if the boundary is missing,
 * empty or longer than 70 bytes (RFC 2046). out needs 71 bytes. */
sv_status svd_multipart_boundary(const char *content_type, char out[71], sv_error *err);

/* Creates a parser for a boundary (without the leading "--"). NULL when out
 * of memory or the boundary is empty/over 70 bytes. */
svd_multipart *svd_multipart_create(const char *boundary, const svd_multipart_callbacks *cb,
                                    void *user);

/* Consumes size bytes. Returns SV_ERR_PARSE with a message on malformed input
 * (bad part headers, headers over SVD_MP_HEADER_MAX, missing name), SV_ERR_IO if
 * a callback refused. After an error every further call returns it again. */
sv_status svd_multipart_feed(svd_multipart *mp, const uint8_t *data, size_t size, sv_error *err);

/* Declares the end of the body: SV_OK only if the closing delimiter was seen. */
sv_status svd_multipart_finish(svd_multipart *mp, sv_error *err);

/* Frees the parser. NULL is a no-op. */
void svd_multipart_destroy(svd_multipart *mp);

#endif
