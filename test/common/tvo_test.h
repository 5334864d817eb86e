/* SPDX-License-Identifier: Apache-2.0 */
/* Helpers shared by the cmocka unit tests. Include after <cmocka.h>'s prerequisites. */
#ifndef TVO_TEST_H
#define TVO_TEST_H

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

/* Folder with the shared EuRoC samples, or NULL (then data tests call skip()). */
static inline const char *tvo_test_data_dir(void)
{
    const char *d = getenv("TVO_DATA_DIR");
    return (d != NULL && d[0] != '\0') ? d : NULL;
}

/* The file test/data/nn/<name> of the source tree (TVO_SOURCE_DIR, else the working directory) in a
 * malloc'd buffer followed by `pad` zero bytes (room for tests that grow a file); *size gets the file's
 * size. NULL (and *size 0) when it is missing, empty or unreadable. */
static inline uint8_t *tvo_test_read_nn_file(const char *name, size_t pad, size_t *size)
{
    char path[4096];
    const char *src = getenv("TVO_SOURCE_DIR");
    uint8_t *buf = NULL;
    long len;
    FILE *fp;
    *size = 0;
    snprintf(path, sizeof path, "%s/test/data/nn/%s", src != NULL ? src : ".", name);
    fp = fopen(path, "rb");
    if (fp == NULL)
        return NULL;
    if (fseek(fp, 0, SEEK_END) == 0 && (len = ftell(fp)) > 0 && fseek(fp, 0, SEEK_SET) == 0) {
        buf = (uint8_t *)calloc((size_t)len + pad, 1);
        if (buf != NULL && fread(buf, 1, (size_t)len, fp) == (size_t)len) {
            *size = (size_t)len;
        } else {
            free(buf);
            buf = NULL;
        }
    }
    fclose(fp);
    return buf;
}

/* Skip the current test with a message saying why. */
#define TVO_SKIP(msg)                                      \
    do {                                                   \
        fprintf(stderr, "SKIP %s: %s\n", __func__, (msg)); \
        skip();                                            \
    } while (0)

#include "tvo_rand.h"

#endif
