/* multipart.c — streaming multipart/form-data parser (RFC 7578; delimiter and
 * body-part grammar of RFC 2046 §5.1.1). The body is treated as if it started
 * with CRLF, so every delimiter, the first included, is "\r\n--" boundary. */
#include "multipart.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

enum mp_state { MP_PREAMBLE, MP_AFTER_DELIM, MP_HEADERS, MP_BODY, MP_EPILOGUE, MP_ERROR };

struct svd_multipart {
    svd_multipart_callbacks cb;
    void *user;
    char delim[2 + 2 + 70 + 1]; /* "\r\n--" boundary */
    size_t dlen;
    enum mp_state state;
    uint8_t *buf;
    size_t len, cap;
    sv_status err_status;
    char err_msg[200];
};

sv_status svd_multipart_boundary(const char *ct, char out[71], sv_error *err)
{
    if (!ct)
        return sv_fail(err, SV_ERR_FORMAT, "missing Content-Type: expected multipart/form-data");
    while (*ct == ' ' || *ct == '\t') ct++;
    if (strncasecmp(ct, "multipart/form-data", 19) != 0 ||
        (ct[19] != '\0' && ct[19] != ';' && ct[19] != ' '))
        return sv_fail(err, SV_ERR_FORMAT, "Content-Type must be multipart/form-data");
    const char *p = ct + 19;
    while (*p) {
        while (*p == ';' || *p == ' ' || *p == '\t') p++;
        const char *eq = strchr(p, '=');
        if (!eq) break;
        size_t klen = (size_t)(eq - p);
        while (klen && (p[klen - 1] == ' ' || p[klen - 1] == '\t')) klen--;
        const char *v = eq + 1;
        while (*v == ' ' || *v == '\t') v++;
        char val[128];
        size_t n = 0;
        if (*v == '"') {
            v++;
            while (*v && *v != '"') {
                if (*v == '\\' && v[1]) v++;
                if (n + 1 < sizeof val) val[n++] = *v;
                else return sv_fail(err, SV_ERR_PARSE, "multipart boundary too long");
                v++;
            }
            if (*v == '"') v++;
        } else {
            while (*v && *v != ';' && *v != ' ' && *v != '\t') {
                if (n + 1 < sizeof val) val[n++] = *v;
                else return sv_fail(err, SV_ERR_PARSE, "multipart boundary too long");
                v++;
            }
        }
        val[n] = '\0';
        if (klen == 8 && strncasecmp(p, "boundary", 8) == 0) {
            if (n == 0 || n > 70)
                return sv_fail(err, SV_ERR_PARSE, "multipart boundary must be 1..70 bytes");
            memcpy(out, val, n + 1);
            return SV_OK;
        }
        p = v;
    }
    return sv_fail(err, SV_ERR_PARSE, "multipart/form-data without a boundary parameter");
}

svd_multipart *svd_multipart_create(const char *boundary, const svd_multipart_callbacks *cb,
                                    void *user)
{
    size_t bl = boundary ? strlen(boundary) : 0;
    if (bl == 0 || bl > 70 || !cb) return NULL;
    svd_multipart *mp = calloc(1, sizeof *mp);
    if (!mp) return NULL;
    mp->cb = *cb;
    mp->user = user;
    memcpy(mp->delim, "\r\n--", 4);
    memcpy(mp->delim + 4, boundary, bl + 1);
    mp->dlen = 4 + bl;
    mp->cap = SVD_MP_HEADER_MAX + 65536 + 128;
    mp->buf = malloc(mp->cap);
    if (!mp->buf) {
        free(mp);
        return NULL;
    }
    memcpy(mp->buf, "\r\n", 2); /* the virtual CRLF before the first delimiter */
    mp->len = 2;
    mp->state = MP_PREAMBLE;
    return mp;
}

void svd_multipart_destroy(svd_multipart *mp)
{
    if (!mp) return;
    free(mp->buf);
    free(mp);
}

static sv_status mp_error(svd_multipart *mp, sv_status st, const char *msg)
{
    mp->state = MP_ERROR;
    mp->err_status = st;
    snprintf(mp->err_msg, sizeof mp->err_msg, "%s", msg);
    return st;
}

/* Copies a header parameter value (quoted-string or token) into out,
 * truncated to what out holds; returns the value's whole length. */
static size_t param_value(const char *v, const char *end, char out[SVD_MP_FIELD_MAX])
{
    size_t n = 0, total = 0;
    if (v < end && *v == '"') {
        v++;
        while (v < end && *v != '"') {
            if (*v == '\\' && v + 1 < end) v++;
            if (n + 1 < SVD_MP_FIELD_MAX) out[n++] = *v;
            total++;
            v++;
        }
    } else {
        while (v < end && *v != ';' && *v != ' ' && *v != '\t') {
            if (n + 1 < SVD_MP_FIELD_MAX) out[n++] = *v;
            total++;
            v++;
        }
    }
    out[n] = '\0';
    return total;
}

/* Parses "form-data; name=...; filename=..." into info. */
static int parse_disposition(const char *v, const char *end, svd_part_info *info)
{
    while (v < end && (*v == ' ' || *v == '\t')) v++;
    if ((size_t)(end - v) < 9 || strncasecmp(v, "form-data", 9) != 0) return -1;
    const char *p = v + 9;
    int have_name = 0;
    while (p < end) {
        while (p < end && (*p == ';' || *p == ' ' || *p == '\t')) p++;
        const char *eq = memchr(p, '=', (size_t)(end - p));
        if (!eq) break;
        size_t klen = (size_t)(eq - p);
        while (klen && (p[klen - 1] == ' ' || p[klen - 1] == '\t')) klen--;
        const char *val = eq + 1;
        while (val < end && (*val == ' ' || *val == '\t')) val++;
        if (klen == 4 && strncasecmp(p, "name", 4) == 0) {
            param_value(val, end, info->name);
            have_name = 1;
        } else if (klen == 8 && strncasecmp(p, "filename", 8) == 0) {
            info->filename_len = param_value(val, end, info->filename);
            info->has_filename = 1;
        }
        /* skip the value */
        p = val;
        if (p < end && *p == '"') {
            p++;
            while (p < end && *p != '"') {
                if (*p == '\\' && p + 1 < end) p++;
                p++;
            }
            if (p < end) p++;
        } else {
            while (p < end && *p != ';') p++;
        }
    }
    return have_name ? 0 : -1;
}

/* Parses the header block hdr[0..n) (lines separated by CRLF, no final blank). */
static sv_status parse_headers(svd_multipart *mp, const char *hdr, size_t n, svd_part_info *info)
{
    memset(info, 0, sizeof *info);
    int have_disp = 0;
    const char *p = hdr, *end = hdr + n;
    while (p < end) {
        const char *eol = p;
        while (eol + 1 < end && !(eol[0] == '\r' && eol[1] == '\n')) eol++;
        if (eol + 1 >= end) eol = end;
        const char *colon = memchr(p, ':', (size_t)(eol - p));
        if (!colon) return mp_error(mp, SV_ERR_PARSE, "multipart part header without ':'");
        size_t klen = (size_t)(colon - p);
        if (klen == 19 && strncasecmp(p, "Content-Disposition", 19) == 0) {
            if (parse_disposition(colon + 1, eol, info) != 0)
                return mp_error(
                    mp, SV_ERR_PARSE,
                    "multipart part: Content-Disposition must be form-data with a name");
            have_disp = 1;
        } else if (klen == 12 && strncasecmp(p, "Content-Type", 12) == 0) {
            const char *v = colon + 1;
            while (v < eol && (*v == ' ' || *v == '\t')) v++;
            size_t vl = (size_t)(eol - v);
            if (vl >= SVD_MP_FIELD_MAX) vl = SVD_MP_FIELD_MAX - 1;
            memcpy(info->content_type, v, vl);
            info->content_type[vl] = '\0';
        }
        p = eol + 2;
    }
    if (!have_disp) return mp_error(mp, SV_ERR_PARSE, "multipart part without Content-Disposition");
    return SV_OK;
}

/* First occurrence of needle in hay (memmem is a GNU extension). */
static uint8_t *find(uint8_t *hay, size_t n, const void *needle, size_t nl)
{
    const uint8_t *nd = needle;
    if (nl == 0 || n < nl) return NULL;
    uint8_t *p = hay, *last = hay + (n - nl);
    while (p <= last) {
        p = memchr(p, nd[0], (size_t)(last - p) + 1);
        if (!p) return NULL;
        if (memcmp(p, nd, nl) == 0) return p;
        p++;
    }
    return NULL;
}

static void consume(svd_multipart *mp, size_t n)
{
    memmove(mp->buf, mp->buf + n, mp->len - n);
    mp->len -= n;
}

/* Runs the state machine over the buffered bytes; consumes what it can. */
static sv_status run(svd_multipart *mp, int at_end)
{
    for (;;) {
        switch (mp->state) {
        case MP_PREAMBLE: {
            uint8_t *m = find(mp->buf, mp->len, mp->delim, mp->dlen);
            if (!m) {
                if (mp->len >= mp->dlen) consume(mp, mp->len - (mp->dlen - 1));
                return SV_OK;
            }
            consume(mp, (size_t)(m - mp->buf) + mp->dlen);
            mp->state = MP_AFTER_DELIM;
            break;
        }
        case MP_AFTER_DELIM: {
            if (mp->len < 2) return SV_OK;
            if (mp->buf[0] == '-' && mp->buf[1] == '-') {
                mp->state = MP_EPILOGUE;
                break;
            }
            /* transport padding (LWSP) then CRLF */
            size_t i = 0;
            while (i < mp->len && (mp->buf[i] == ' ' || mp->buf[i] == '\t')) i++;
            if (i > 128) return mp_error(mp, SV_ERR_PARSE, "multipart delimiter line too long");
            if (mp->len < i + 2) return SV_OK;
            if (mp->buf[i] != '\r' || mp->buf[i + 1] != '\n')
                return mp_error(mp, SV_ERR_PARSE, "multipart delimiter not followed by CRLF");
            consume(mp, i + 2);
            mp->state = MP_HEADERS;
            break;
        }
        case MP_HEADERS: {
            size_t hend, skip;
            if (mp->len >= 2 && mp->buf[0] == '\r' && mp->buf[1] == '\n') {
                hend = 0;
                skip = 2;
            } else {
                uint8_t *m = find(mp->buf, mp->len, "\r\n\r\n", 4);
                if (!m) {
                    if (mp->len > SVD_MP_HEADER_MAX)
                        return mp_error(mp, SV_ERR_PARSE, "multipart part headers over 8192 bytes");
                    return SV_OK;
                }
                hend = (size_t)(m - mp->buf);
                skip = hend + 4;
                if (hend > SVD_MP_HEADER_MAX)
                    return mp_error(mp, SV_ERR_PARSE, "multipart part headers over 8192 bytes");
            }
            svd_part_info info;
            sv_status st = parse_headers(mp, (const char *)mp->buf, hend, &info);
            if (st != SV_OK) return st;
            consume(mp, skip);
            if (mp->cb.part_begin && mp->cb.part_begin(mp->user, &info) != 0)
                return mp_error(mp, SV_ERR_IO, "multipart: part refused by the receiver");
            mp->state = MP_BODY;
            break;
        }
        case MP_BODY: {
            uint8_t *m = find(mp->buf, mp->len, mp->delim, mp->dlen);
            size_t emit = m ? (size_t)(m - mp->buf)
                            : (mp->len >= mp->dlen ? mp->len - (mp->dlen - 1) : 0);
            if (emit && mp->cb.part_data && mp->cb.part_data(mp->user, mp->buf, emit) != 0)
                return mp_error(mp, SV_ERR_IO, "multipart: part data refused by the receiver");
            consume(mp, emit);
            if (!m) return SV_OK;
            consume(mp, mp->dlen);
            if (mp->cb.part_end && mp->cb.part_end(mp->user) != 0)
                return mp_error(mp, SV_ERR_IO, "multipart: part end refused by the receiver");
            mp->state = MP_AFTER_DELIM;
            break;
        }
        case MP_EPILOGUE:
            mp->len = 0;
            return SV_OK;
        case MP_ERROR:
            return mp->err_status;
        }
        (void)at_end;
    }
}

sv_status svd_multipart_feed(svd_multipart *mp, const uint8_t *data, size_t size, sv_error *err)
{
    if (mp->state == MP_ERROR) return sv_fail(err, mp->err_status, "%s", mp->err_msg);
    while (size > 0) {
        size_t room = mp->cap - mp->len;
        size_t n = size < room ? size : room;
        memcpy(mp->buf + mp->len, data, n);
        mp->len += n;
        data += n;
        size -= n;
        sv_status st = run(mp, 0);
        if (st != SV_OK) return sv_fail(err, st, "%s", mp->err_msg);
        if (mp->len == mp->cap) /* cannot happen: BODY keeps < dlen, HEADERS errors first */
            return sv_fail(err, mp_error(mp, SV_ERR_PARSE, "multipart: parser buffer full"),
                           "multipart: parser buffer full");
    }
    return SV_OK;
}

sv_status svd_multipart_finish(svd_multipart *mp, sv_error *err)
{
    if (mp->state == MP_ERROR) return sv_fail(err, mp->err_status, "%s", mp->err_msg);
    if (mp->state != MP_EPILOGUE)
        return sv_fail(err, SV_ERR_PARSE,
                       mp->state == MP_PREAMBLE ? "multipart body without any part"
                                                : "multipart body truncated: no closing delimiter");
    return SV_OK;
}
