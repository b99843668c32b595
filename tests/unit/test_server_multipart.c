/* Unit tests: server/multipart.c, the streaming multipart/form-data parser. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "multipart.h"

typedef struct collected {
    int parts;
    char names[8][SVD_MP_FIELD_MAX];
    char filenames[8][SVD_MP_FIELD_MAX];
    uint8_t *data[8];
    size_t len[8];
    size_t cap[8];
    int ended;
    int refuse_begin;
} collected;

static int cb_begin(void *u, const svd_part_info *info)
{
    collected *c = u;
    if (c->refuse_begin) return 1;
    if (c->parts >= 8) return 1;
    snprintf(c->names[c->parts], SVD_MP_FIELD_MAX, "%s", info->name);
    snprintf(c->filenames[c->parts], SVD_MP_FIELD_MAX, "%s", info->filename);
    c->data[c->parts] = NULL;
    c->len[c->parts] = 0;
    c->cap[c->parts] = 0;
    c->parts++;
    return 0;
}

static int cb_data(void *u, const uint8_t *d, size_t n)
{
    collected *c = u;
    int i = c->parts - 1;
    /* geometric growth: a 300 KB part fed in 7-byte chunks with a realloc
     * per chunk took 67 s under ASan (a copy of the whole part each time) */
    if (c->len[i] + n > c->cap[i]) {
        size_t cap = c->cap[i] ? c->cap[i] : 64;
        while (cap < c->len[i] + n) cap *= 2;
        uint8_t *p = realloc(c->data[i], cap);
        if (!p) return 1;
        c->data[i] = p;
        c->cap[i] = cap;
    }
    memcpy(c->data[i] + c->len[i], d, n);
    c->len[i] += n;
    return 0;
}

static int cb_end(void *u)
{
    ((collected *)u)->ended++;
    return 0;
}

static const svd_multipart_callbacks cbs = {cb_begin, cb_data, cb_end};

static void free_collected(collected *c)
{
    for (int i = 0; i < c->parts; i++) free(c->data[i]);
}

/* Feeds body in chunks of `chunk` bytes; returns the status of feed+finish. */
static sv_status parse(const char *boundary, const uint8_t *body, size_t n, size_t chunk,
                       collected *c, sv_error *err)
{
    svd_multipart *mp = svd_multipart_create(boundary, &cbs, c);
    assert_non_null(mp);
    sv_status st = SV_OK;
    for (size_t off = 0; off < n && st == SV_OK; off += chunk)
        st = svd_multipart_feed(mp, body + off, n - off < chunk ? n - off : chunk, err);
    if (st == SV_OK) st = svd_multipart_finish(mp, err);
    svd_multipart_destroy(mp);
    return st;
}

static const char simple[] =
    "--XyZ\r\n"
    "Content-Disposition: form-data; name=\"spec\"\r\n"
    "Content-Type: application/json\r\n\r\n"
    "{\"method\":\"x\"}\r\n"
    "--XyZ\r\n"
    "Content-Disposition: form-data; name=\"mesh\"; filename=\"tree.obj\"\r\n\r\n"
    "v 0 0 0\r\n"
    "--XyZ--\r\n";

static void multipart_splits_spec_and_mesh_parts(void **state)
{
    (void)state;
    collected c = {0};
    sv_error e = {0};
    assert_int_equal(parse("XyZ", (const uint8_t *)simple, strlen(simple), 1 << 20, &c, &e), SV_OK);
    assert_int_equal(c.parts, 2);
    assert_int_equal(c.ended, 2);
    assert_string_equal(c.names[0], "spec");
    assert_string_equal(c.names[1], "mesh");
    assert_string_equal(c.filenames[1], "tree.obj");
    assert_int_equal(c.len[0], 14);
    assert_memory_equal(c.data[0], "{\"method\":\"x\"}", 14);
    assert_int_equal(c.len[1], 7); /* the CRLF before a delimiter belongs to the delimiter */
    assert_memory_equal(c.data[1], "v 0 0 0", 7);
    free_collected(&c);
}

static void multipart_gives_same_parts_fed_one_byte_at_a_time(void **state)
{
    (void)state;
    collected c = {0};
    sv_error e = {0};
    assert_int_equal(parse("XyZ", (const uint8_t *)simple, strlen(simple), 1, &c, &e), SV_OK);
    assert_int_equal(c.parts, 2);
    assert_int_equal(c.len[0], 14);
    assert_int_equal(c.len[1], 7);
    assert_memory_equal(c.data[1], "v 0 0 0", 7);
    free_collected(&c);
}

static void multipart_passes_binary_part_with_boundary_lookalikes(void **state)
{
    (void)state;
    /* 300 KB of binary data with CR, LF, NUL and "--bnd" fragments (no full delimiter). */
    size_t n = 300000;
    uint8_t *bin = malloc(n);
    uint32_t x = 12345;
    for (size_t i = 0; i < n; i++) {
        x = x * 1103515245u + 12345u;
        bin[i] = (uint8_t)(x >> 16);
    }
    memcpy(bin + 1000, "\r\n--bn", 6);
    memcpy(bin + 5000, "\r\n--b\r\n--bnd", 12); /* "\r\n--bnd" would end the part: keep it broken */
    bin[5011] = 'X';
    const char *head =
        "--bnd\r\nContent-Disposition: form-data; name=\"mesh\"; filename=\"a.glb\"\r\n\r\n";
    const char *tail = "\r\n--bnd--";
    size_t total = strlen(head) + n + strlen(tail);
    uint8_t *body = malloc(total);
    memcpy(body, head, strlen(head));
    memcpy(body + strlen(head), bin, n);
    memcpy(body + strlen(head) + n, tail, strlen(tail));
    for (size_t chunk = 7; chunk <= 70000; chunk *= 10) {
        collected c = {0};
        sv_error e = {0};
        assert_int_equal(parse("bnd", body, total, chunk, &c, &e), SV_OK);
        assert_int_equal(c.parts, 1);
        assert_int_equal(c.len[0], n);
        assert_memory_equal(c.data[0], bin, n);
        free_collected(&c);
    }
    free(body);
    free(bin);
}

static void multipart_refuses_truncated_body(void **state)
{
    (void)state;
    collected c = {0};
    sv_error e = {0};
    size_t n = strlen(simple) - 9; /* drop the closing delimiter */
    assert_int_equal(parse("XyZ", (const uint8_t *)simple, n, 64, &c, &e), SV_ERR_PARSE);
    assert_non_null(strstr(e.message, "truncated"));
    free_collected(&c);
}

static void multipart_refuses_part_without_disposition(void **state)
{
    (void)state;
    const char *b = "--q\r\nContent-Type: text/plain\r\n\r\nhello\r\n--q--\r\n";
    collected c = {0};
    sv_error e = {0};
    assert_int_equal(parse("q", (const uint8_t *)b, strlen(b), 100, &c, &e), SV_ERR_PARSE);
    assert_non_null(strstr(e.message, "Content-Disposition"));
    free_collected(&c);
}

static void multipart_refuses_headers_over_limit(void **state)
{
    (void)state;
    size_t n = SVD_MP_HEADER_MAX + 200;
    char *b = malloc(n + 64);
    strcpy(b, "--q\r\nX-Long: ");
    size_t l = strlen(b);
    memset(b + l, 'a', n - l);
    b[n] = '\0';
    collected c = {0};
    sv_error e = {0};
    assert_int_equal(parse("q", (const uint8_t *)b, n, 1000, &c, &e), SV_ERR_PARSE);
    assert_non_null(strstr(e.message, "8192"));
    free(b);
    free_collected(&c);
}

static void multipart_ignores_preamble_and_epilogue(void **state)
{
    (void)state;
    const char *b = "this is a preamble\r\n--q\r\nContent-Disposition: form-data; "
                    "name=\"spec\"\r\n\r\n{}\r\n--q--\r\nepilogue junk";
    collected c = {0};
    sv_error e = {0};
    assert_int_equal(parse("q", (const uint8_t *)b, strlen(b), 5, &c, &e), SV_OK);
    assert_int_equal(c.parts, 1);
    assert_int_equal(c.len[0], 2);
    free_collected(&c);
}

static void multipart_reports_callback_refusal(void **state)
{
    (void)state;
    collected c = {.refuse_begin = 1};
    sv_error e = {0};
    assert_int_equal(parse("XyZ", (const uint8_t *)simple, strlen(simple), 100, &c, &e), SV_ERR_IO);
}

static void boundary_is_read_from_content_type(void **state)
{
    (void)state;
    char b[71];
    sv_error e = {0};
    assert_int_equal(svd_multipart_boundary("multipart/form-data; boundary=----abc123", b, &e),
                     SV_OK);
    assert_string_equal(b, "----abc123");
    assert_int_equal(
        svd_multipart_boundary("Multipart/Form-Data; charset=x; boundary=\"q r\"", b, &e), SV_OK);
    assert_string_equal(b, "q r");
    assert_int_equal(svd_multipart_boundary("application/json", b, &e), SV_ERR_FORMAT);
    assert_int_equal(svd_multipart_boundary(NULL, b, &e), SV_ERR_FORMAT);
    assert_int_equal(svd_multipart_boundary("multipart/form-data", b, &e), SV_ERR_PARSE);
    char longb[200] = "multipart/form-data; boundary=";
    memset(longb + strlen(longb), 'x', 80);
    assert_int_equal(svd_multipart_boundary(longb, b, &e), SV_ERR_PARSE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(multipart_splits_spec_and_mesh_parts),
        cmocka_unit_test(multipart_gives_same_parts_fed_one_byte_at_a_time),
        cmocka_unit_test(multipart_passes_binary_part_with_boundary_lookalikes),
        cmocka_unit_test(multipart_refuses_truncated_body),
        cmocka_unit_test(multipart_refuses_part_without_disposition),
        cmocka_unit_test(multipart_refuses_headers_over_limit),
        cmocka_unit_test(multipart_ignores_preamble_and_epilogue),
        cmocka_unit_test(multipart_reports_callback_refusal),
        cmocka_unit_test(boundary_is_read_from_content_type),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
