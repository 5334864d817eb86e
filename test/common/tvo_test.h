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

/* Skip the current test with a message saying why. */
#define TVO_SKIP(msg)                                                             \
    do {                                                                          \
        fprintf(stderr, "SKIP %s: %s\n", __func__, (msg));                        \
        skip();                                                                   \
    } while (0)

#include "tvo_rand.h"

#endif
