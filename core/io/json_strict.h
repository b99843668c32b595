/* json_strict.h — the one JSON reader for documents another parser reads too.
 *
 * A glTF is read by the pre-check (cJSON) and then by assimp (its own
 * parser); a spec by the daemon and then by the worker. When two parsers can
 * read the same bytes as different documents (a duplicate key: cJSON keeps
 * the first, others the last; a key with a NUL: cJSON stops at the NUL, so
 * "children\u0000" reads as "children"; content after the value: ignored by
 * one, refused by another), a check by one proves nothing about what the
 * other sees. Every such document goes through sv_json_parse_strict. */
#ifndef SV_JSON_STRICT_H
#define SV_JSON_STRICT_H

#include <cJSON.h>
#include <stddef.h>

#include "sv.h"

/* Parses exactly one JSON value from text[0..len) and refuses, with `st` and a
 * message starting with `what` naming the problem and its byte offset: a
 * syntax error, anything but whitespace after the value, a string holding
 * NUL (raw or \u0000) or another raw control byte, and an object with the
 * same key twice. Returns the tree (the caller frees it with cJSON_Delete)
 * or NULL with err set. Time and memory linear in len. */
cJSON *sv_json_parse_strict(const char *text, size_t len, const char *what, sv_status st,
                            sv_error *err);

#endif
