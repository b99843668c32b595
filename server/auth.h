/* auth.h — optional bearer-token authentication and client identity.
 * Tokens file: one token per line, its first blank-separated word (blank
 * lines and '#' comments ignored), lines of any length read whole. Only the
 * SHA-256 of each token is kept; a bearer is checked by comparing digests
 * with CRYPTO_memcmp, every token each time, so the check takes the same
 * time whatever the tokens' content and length. */
#ifndef SVD_AUTH_H
#define SVD_AUTH_H

#include <stdbool.h>
#include <stddef.h>

#include "sv.h"

typedef struct svd_tokens svd_tokens;

/* Longest token accepted, in bytes. */
#define SVD_TOKEN_MAX 4096

/* Loads a tokens file. NULL with err set: SV_ERR_IO if unreadable;
 * SV_ERR_SPEC, naming the file and line, for a token over SVD_TOKEN_MAX
 * bytes or a NUL byte in a line (refused, never cut), or when the file holds
 * no token; SV_ERR_NOMEM. */
svd_tokens *svd_tokens_load(const char *path, sv_error *err);

/* Frees the tokens. NULL is a no-op. */
void svd_tokens_free(svd_tokens *t);

/* True if the Authorization header value is "Bearer <a known token>". */
bool svd_tokens_check(const svd_tokens *t, const char *authorization);

/* Client identity for the fair queue: "token:<first 16 hex of SHA-256(token)>"
 * when an Authorization bearer token is present, else "addr:<remote address>". */
void svd_client_id(const char *authorization, const char *remote_addr, char *out, size_t cap);

#endif
