/* Reading the shared trees in the cmocka unit tests (include after
 * test_skip.h): one whole file into memory. */
#ifndef SV_TEST_DATA_H
#define SV_TEST_DATA_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* The whole file at path (malloc'd, *size bytes), or NULL when it cannot be
 * opened or read. */
static inline uint8_t *sv_test_read_all(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *b = malloc(n > 0 ? (size_t)n : 1);
    if (b && n > 0 && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *size = n > 0 ? (size_t)n : 0;
    return b;
}

/* The file `rel` under the shared data folder `data`, read whole (NULL when
 * it cannot be read). */
static inline uint8_t *sv_test_read_data(const char *data, const char *rel, size_t *size)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", data, rel);
    return sv_test_read_all(path, size);
}

#endif
