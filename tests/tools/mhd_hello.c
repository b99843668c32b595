/* mhd_hello.c — a bare libmicrohttpd server, the baseline for the load
 * measurement of tests/reliability/load.sh (docs/reliability.md).
 *
 * Every request, whatever its method or URL, is answered 200 with the body
 * {"status":"ok"} and Content-Type application/json: the same 15-byte body
 * and header as sylvad's GET /v1/health, so the two differ only by what sylvad
 * does per request (route match, client id, per-request state, metrics).
 * With --serve-dir DIR, GET /files/NAME (NAME a plain file of DIR, no '/')
 * is answered with that file instead, opened per request and sent with
 * MHD_create_response_from_fd64 as sylvad sends an artifact (sendfile), so
 * an artifact download can be compared with bare libmicrohttpd sending the
 * same bytes; a missing NAME is 404.
 *
 * Configured as sylvad configures libmicrohttpd (server/http.c,
 * svd_http_start) so the comparison is fair. The same:
 *   - flags MHD_USE_EPOLL_INTERNAL_THREAD | MHD_ALLOW_SUSPEND_RESUME |
 *     MHD_USE_ERROR_LOG (| MHD_USE_IPv6 for an IPv6 address);
 *   - MHD_OPTION_THREAD_POOL_SIZE http_threads (0 means 1),
 *     MHD_OPTION_CONNECTION_LIMIT connection_limit,
 *     MHD_OPTION_CONNECTION_MEMORY_LIMIT connection_memory,
 *     MHD_OPTION_CONNECTION_TIMEOUT connection_timeout,
 *     MHD_OPTION_LISTENING_ADDRESS_REUSE 1, the address from getaddrinfo;
 *   - the values: they come from sylvad's own parser (svd_config_from_args
 *     with sylvad's defaults, config file and flags), so `--http-threads 2`
 *     or `--config FILE` mean here what they mean to sylvad;
 *   - the response is made per request from a copied buffer
 *     (MHD_RESPMEM_MUST_COPY), given a Content-Type, queued and released, as
 *     sylvad's send_text does; SIGPIPE is ignored.
 *   - the answer is queued on the second call of the access handler, never
 *     the first: libmicrohttpd 0.9.75 closes the connection after a response
 *     queued on the first call (before the body), which would make every
 *     request pay a new TCP connection. sylvad does the same for all but
 *     refused uploads.
 * Different, on purpose: no route table, no per-request allocation, no
 * metrics, no completion callback, no per-request logging; a file is served
 * without sylvad's job lookup, store verification (its SHA-256 cache) or ETag.
 *
 * usage: mhd_hello --listen HOST:PORT [--port-file FILE] [--serve-dir DIR]
 *                  [any sylvad flag]
 *   Flags that concern HTTP (listen, port_file, http_threads,
 *   connection_limit, connection_memory, connection_timeout) are used; the
 *   others (store, workers, ...) are parsed and ignored. Port 0 picks a free
 *   port; the port actually bound is written to FILE (FILE.tmp then rename,
 *   as sylvad does). Runs until SIGTERM or SIGINT, then exits 0. Exit 2 on a
 *   bad flag, 1 if it cannot listen (one line on stderr).
 */
#include <fcntl.h>
#include <microhttpd.h>
#include <netdb.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include "config.h"

static const char BODY[] = "{\"status\":\"ok\"}";

/* --serve-dir: answers GET /files/NAME with DIR/NAME; MHD_NO on failure. */
static enum MHD_Result send_file(struct MHD_Connection *c, const char *dir, const char *name)
{
    char path[SVD_PATH_MAX + 300];
    struct stat st;
    int fd = -1;
    if (*name && !strchr(name, '/') && strcmp(name, ".") != 0 && strcmp(name, "..") != 0 &&
        (size_t)snprintf(path, sizeof path, "%s/%s", dir, name) < sizeof path)
        fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd >= 0 && (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))) {
        close(fd);
        fd = -1;
    }
    struct MHD_Response *r;
    unsigned status = MHD_HTTP_OK;
    if (fd < 0) {
        status = MHD_HTTP_NOT_FOUND;
        r = MHD_create_response_from_buffer(0, (void *)"", MHD_RESPMEM_PERSISTENT);
    } else {
        r = MHD_create_response_from_fd64((uint64_t)st.st_size, fd); /* closes fd */
        if (!r) close(fd);
    }
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", "application/octet-stream");
    enum MHD_Result ret = MHD_queue_response(c, status, r);
    MHD_destroy_response(r);
    return ret;
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c, const char *url,
                                  const char *method, const char *version, const char *upload_data,
                                  size_t *upload_data_size, void **con_cls)
{
    (void)version, (void)upload_data;
    const char *serve_dir = cls;
    static int seen;         /* a marker, not state: its address tags "headers seen" */
    if (*con_cls != &seen) { /* first call: headers only */
        *con_cls = &seen;
        return MHD_YES;
    }
    if (*upload_data_size) { /* a body: discard it, answer when it is read */
        *upload_data_size = 0;
        return MHD_YES;
    }
    if (serve_dir && strcmp(method, "GET") == 0 && strncmp(url, "/files/", 7) == 0)
        return send_file(c, serve_dir, url + 7);
    struct MHD_Response *r = MHD_create_response_from_buffer(sizeof BODY - 1, (void *)BODY,
                                                             MHD_RESPMEM_MUST_COPY);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", "application/json");
    enum MHD_Result ret = MHD_queue_response(c, MHD_HTTP_OK, r);
    MHD_destroy_response(r);
    return ret;
}

static void mhd_logger(void *cls, const char *fmt, va_list ap)
{
    (void)cls;
    fputs("mhd_hello: ", stderr);
    vfprintf(stderr, fmt, ap);
}

int main(int argc, char **argv)
{
    /* --serve-dir is ours; every other flag goes to sylvad's parser. */
    const char *serve_dir = NULL;
    int n = 1;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--serve-dir") == 0 && i + 1 < argc) serve_dir = argv[++i];
        else argv[n++] = argv[i];
    }
    argc = n;
    svd_config cfg;
    sv_error err = {0};
    sv_status st = svd_config_from_args(&cfg, argc, argv, &err);
    if (st == SV_ERR_CANCELLED) {
        puts("usage: mhd_hello --listen HOST:PORT [--port-file FILE] [--serve-dir DIR] [any sylvad "
             "flag]");
        return 0;
    }
    if (st != SV_OK) {
        fprintf(stderr, "mhd_hello: %s\n", err.message);
        return 2;
    }

    /* Signals are taken synchronously below, as in sylvad: block them before
     * libmicrohttpd starts its threads so they inherit the mask. */
    sigset_t sigs;
    sigemptyset(&sigs);
    sigaddset(&sigs, SIGTERM);
    sigaddset(&sigs, SIGINT);
    pthread_sigmask(SIG_BLOCK, &sigs, NULL);
    signal(SIGPIPE, SIG_IGN);

    struct addrinfo hints = {0}, *ai = NULL;
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_NUMERICSERV | AI_PASSIVE;
    char port[16];
    snprintf(port, sizeof port, "%u", cfg.port);
    int gai = getaddrinfo(cfg.listen_host, port, &hints, &ai);
    if (gai != 0 || !ai) {
        fprintf(stderr, "mhd_hello: cannot resolve '%s': %s\n", cfg.listen_host, gai_strerror(gai));
        return 1;
    }
    unsigned flags = MHD_USE_EPOLL_INTERNAL_THREAD | MHD_ALLOW_SUSPEND_RESUME | MHD_USE_ERROR_LOG;
    if (ai->ai_family == AF_INET6) flags |= MHD_USE_IPv6;
    struct MHD_Daemon *d = MHD_start_daemon(
        flags, 0, NULL, NULL, on_request, (void *)serve_dir, MHD_OPTION_EXTERNAL_LOGGER, mhd_logger,
        NULL, MHD_OPTION_SOCK_ADDR, ai->ai_addr, MHD_OPTION_THREAD_POOL_SIZE,
        (unsigned int)(cfg.http_threads ? cfg.http_threads : 1), MHD_OPTION_CONNECTION_LIMIT,
        (unsigned int)cfg.connection_limit, MHD_OPTION_CONNECTION_MEMORY_LIMIT,
        (size_t)cfg.connection_memory, MHD_OPTION_CONNECTION_TIMEOUT,
        (unsigned int)cfg.connection_timeout, MHD_OPTION_LISTENING_ADDRESS_REUSE, (unsigned int)1,
        MHD_OPTION_END);
    freeaddrinfo(ai);
    if (!d) {
        fprintf(stderr, "mhd_hello: cannot listen on %s:%u\n", cfg.listen_host, cfg.port);
        return 1;
    }
    const union MHD_DaemonInfo *di = MHD_get_daemon_info(d, MHD_DAEMON_INFO_BIND_PORT);
    unsigned bound = di ? di->port : cfg.port;
    if (cfg.port_file[0] && svd_config_write_port_file(cfg.port_file, bound) != 0) {
        fprintf(stderr, "mhd_hello: cannot write %s\n", cfg.port_file);
        MHD_stop_daemon(d);
        return 1;
    }
    int sig = 0;
    while (sigwait(&sigs, &sig) != 0 || (sig != SIGTERM && sig != SIGINT)) {}
    MHD_stop_daemon(d);
    return 0;
}
