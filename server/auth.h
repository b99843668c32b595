/* auth.h — optional bearer-token authentication and client identity.
 * Tokens file: one token per line (blank lines and '#' comments ignored).
 * Tokens are compared in constant time (CRYPTO_memcmp). */
#ifndef SVD_AUTH_H
#define SVD_AUTH_H

#include <stdbool.h>
#include <stddef.h>

#include "sv.h"

typedef struct svd_tokens svd_tokens;

/* Loads a tokens file. SV_ERR_IO if unreadable, SV_ERR_SPEC if it holds no token. */
svd_tokens *svd_tokens_load(const char *path, sv_error *err);

/* Frees the tokens. NULL is a no-op. */
void svd_tokens_free(svd_tokens *t);

/* True if the Authorization header value is "Bearer <a known token>". */
bool svd_tokens_check(const svd_tokens *t, const char *authorization);

/* Client identity for the fair queue: "token:<first 16 hex of SHA-256(token)>"
 * when an Authorization bearer token is present, else "addr:<remote address>". */
void svd_client_id(const char *authorization, const char *remote_addr, char *out, size_t cap);

#endif
