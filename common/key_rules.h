/* key_rules.h — the content key's rules, shared by sylvad (server/key.c)
 * and libsylva (client/key.c, client/libsylva.c) so the two cannot drift:
 * which upload names are valid, what a key looks like, and how
 * the key frames each part (docs/api.md "Content key"):
 *
 *   SHA-256 of  "sylva-key-v1\n"
 *               "spec <len>\n" <spec bytes> "\n"        (absent or empty: "{}")
 *               "mesh <name> <len>\n" <bytes> "\n"
 *               "file <name> <len>\n" <bytes> "\n"      (files by name, bytewise)
 *
 * Header-only (static inline): the client links nothing of core or server,
 * and each side keeps its own I/O and error convention around these.
 */
#ifndef SYLVA_KEY_RULES_H
#define SYLVA_KEY_RULES_H

#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#define SYLVA_KEY_MAGIC "sylva-key-v1\n" /* the framing's first bytes */
#define SYLVA_KEY_MAGIC_LEN 13
#define SYLVA_UPLOAD_NAME_MAX 255 /* longest upload name, bytes */
#define SYLVA_KEY_HEX_LEN 64      /* a key: 64 lowercase hex digits */
#define SYLVA_KEY_PREFIX_MIN 8    /* a key may be named by a unique prefix this long */

/* The length of the well-formed UTF-8 sequence at s[0..n) (RFC 3629: no
 * overlong form, no surrogate, nothing above U+10FFFF), or 0 if there is none. */
static inline size_t sylva_utf8_seq(const unsigned char *s, size_t n)
{
    if (n == 0) return 0;
    unsigned char c = s[0];
    if (c < 0x80) return 1;
    size_t len = c >= 0xC2 && c <= 0xDF   ? 2
                 : c >= 0xE0 && c <= 0xEF ? 3
                 : c >= 0xF0 && c <= 0xF4 ? 4
                                          : 0;
    if (len == 0 || len > n) return 0;
    for (size_t i = 1; i < len; i++)
        if ((s[i] & 0xC0) != 0x80) return 0;
    if (c == 0xE0 && s[1] < 0xA0) return 0; /* overlong */
    if (c == 0xED && s[1] > 0x9F) return 0; /* surrogate */
    if (c == 0xF0 && s[1] < 0x90) return 0; /* overlong */
    if (c == 0xF4 && s[1] > 0x8F) return 0; /* above U+10FFFF */
    return len;
}

/* True when s[0..n) is well-formed UTF-8. */
static inline bool sylva_utf8_ok(const char *s, size_t n)
{
    const unsigned char *p = (const unsigned char *)s;
    for (size_t i = 0; i < n;) {
        size_t k = sylva_utf8_seq(p + i, n - i);
        if (!k) return false;
        i += k;
    }
    return true;
}

/* Replaces, in place, every byte of the NUL-terminated s that does not start
 * a well-formed UTF-8 sequence with '?', so s can go into a JSON document. */
static inline void sylva_utf8_fix(char *s)
{
    unsigned char *p = (unsigned char *)s;
    size_t n = strlen(s);
    for (size_t i = 0; i < n;) {
        size_t k = sylva_utf8_seq(p + i, n - i);
        if (!k) {
            p[i] = '?';
            k = 1;
        }
        i += k;
    }
}

/* True when name is a valid upload name: 1..SYLVA_UPLOAD_NAME_MAX bytes of
 * well-formed UTF-8, not "." or "..", no '/', '\\', space or control
 * character (a base name that is safe as a file name in the store and in an
 * output folder, and as a string in a JSON document). */
static inline bool sylva_upload_name_ok(const char *name)
{
    if (!name || !name[0]) return false;
    size_t n = strlen(name);
    if (n > SYLVA_UPLOAD_NAME_MAX) return false;
    if (strcmp(name, ".") == 0 || strcmp(name, "..") == 0) return false;
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)name[i];
        if (c < 0x20 || c == 0x7f || c == ' ' || c == '/' || c == '\\') return false;
    }
    return sylva_utf8_ok(name, n);
}

/* True when s is a key (or any SHA-256 in hex): exactly 64 of [0-9a-f]. */
static inline bool sylva_key_hex_ok(const char *s)
{
    if (!s || strlen(s) != SYLVA_KEY_HEX_LEN) return false;
    for (int i = 0; i < SYLVA_KEY_HEX_LEN; i++) {
        char c = s[i];
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
    }
    return true;
}

/* True when s names a key: SYLVA_KEY_PREFIX_MIN..64 of [0-9a-f] (the whole
 * key, or a prefix that sylvad resolves when it is unique, docs/api.md). */
static inline bool sylva_key_prefix_ok(const char *s)
{
    size_t n = s ? strlen(s) : 0;
    if (n < SYLVA_KEY_PREFIX_MIN || n > SYLVA_KEY_HEX_LEN) return false;
    for (size_t i = 0; i < n; i++) {
        char c = s[i];
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
    }
    return true;
}

/* Writes the 32-byte digest md as 64 lowercase hex digits and a NUL. */
static inline void sylva_hex32(const unsigned char md[32], char out[SYLVA_KEY_HEX_LEN + 1])
{
    static const char digits[] = "0123456789abcdef";
    for (int i = 0; i < 32; i++) {
        out[2 * i] = digits[md[i] >> 4];
        out[2 * i + 1] = digits[md[i] & 15];
    }
    out[SYLVA_KEY_HEX_LEN] = '\0';
}

/* Formats the header line of one framed part into buf (cap bytes):
 * "spec <len>\n" when kind is "spec" (name unused), else
 * "<kind> <name> <len>\n". Returns its length, or -1 when it does not fit. */
static inline int sylva_key_part_head(char *buf, size_t cap, const char *kind, const char *name,
                                      unsigned long long len)
{
    int n = strcmp(kind, "spec") == 0 ? snprintf(buf, cap, "spec %llu\n", len)
                                      : snprintf(buf, cap, "%s %s %llu\n", kind, name, len);
    return n < 0 || (size_t)n >= cap ? -1 : n;
}

/* The spec bytes the key frames: an absent or empty spec counts as "{}"
 * (the server's rule, docs/api.md). */
static inline const char *sylva_key_spec(const char *spec, size_t len, size_t *out_len)
{
    if (!spec || len == 0) {
        *out_len = 2;
        return "{}";
    }
    *out_len = len;
    return spec;
}

#endif
