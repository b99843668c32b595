/* http.h — sylvad's HTTP front end on libmicrohttpd (API: docs/api.md).
 *
 * libmicrohttpd runs with an epoll internal thread and a thread pool,
 * a connection limit, a per-connection memory limit, an idle timeout and
 * suspend/resume for long-polls (GET ?wait=S never holds a thread). Every
 * answer is decided from the headers, before a body byte is read: uploads
 * are refused with 413 from Content-Length, chunked uploads are cut off
 * (connection closed) once over the limit; a request that takes no body (any
 * route but an authorised upload, and 404/405/401 answers) has at most 4 KiB
 * of it read and dropped, and a larger or chunked body is answered at once
 * (413, or the route's refusal) and the connection closed. Upload parts are
 * streamed to files under the store's tmp/ while their SHA-256 is computed:
 * a body is never held whole in memory (the spec part, at most 1 MiB, is).
 */
#ifndef SVD_HTTP_H
#define SVD_HTTP_H

#include <stdint.h>

#include "auth.h"
#include "config.h"
#include "jobs.h"
#include "log.h"
#include "metrics.h"

typedef struct svd_http svd_http;

/* Starts listening on cfg->listen_host:cfg->port (port 0 = ephemeral).
 * tokens may be NULL (no auth). NULL with err set on failure. */
svd_http *svd_http_start(const svd_config *cfg, svd_jobs *jobs, svd_metrics *metrics, svd_log *log,
                         const svd_tokens *tokens, sv_error *err);

/* The port actually bound. */
uint16_t svd_http_port(const svd_http *h);

/* From now on new uploads answer 503 and /v1/health reports draining. */
void svd_http_set_draining(svd_http *h);

/* Resumes long-polls and stops the server. NULL is a no-op. */
void svd_http_stop(svd_http *h);

#endif
