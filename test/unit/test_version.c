/* SPDX-License-Identifier: Apache-2.0 */
/* version.h: the run-time version equals the header's, the macros agree with each other, and both
 * equal project(VERSION) of the top CMakeLists.txt (read from TVO_SOURCE_DIR, set by ctest). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "tinyvo/tinyvo.h"

static void test_runtime_matches_header(void **state)
{
    (void)state;
    const char *v = tvo_version();
    assert_non_null(v);
    assert_string_equal(v, TVO_VERSION_STRING);
    assert_int_equal(tvo_version_number(), TVO_VERSION_NUMBER);
    char buf[32];
    snprintf(buf, sizeof buf, "%d.%d.%d", TVO_VERSION_MAJOR, TVO_VERSION_MINOR, TVO_VERSION_PATCH);
    assert_string_equal(buf, TVO_VERSION_STRING);
    assert_int_equal(TVO_VERSION_NUMBER,
                     TVO_VERSION_MAJOR * 10000L + TVO_VERSION_MINOR * 100L + TVO_VERSION_PATCH);
    assert_true(TVO_VERSION_MINOR < 100 && TVO_VERSION_PATCH < 100);
}

/* "project(tinyvo VERSION x.y.z" in the top CMakeLists.txt */
static void test_matches_project_version(void **state)
{
    (void)state;
    const char *src = getenv("TVO_SOURCE_DIR");
    if (src == NULL) {
        fprintf(stderr,
                "test_version: TVO_SOURCE_DIR not set (run through ctest): project version not checked\n");
        skip();
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/CMakeLists.txt", src);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    char line[512];
    int found = 0;
    while (fgets(line, sizeof line, f) != NULL) {
        const char *p = strstr(line, "project(tinyvo VERSION ");
        if (p != NULL) {
            char ver[32] = {0};
            assert_int_equal(sscanf(p + strlen("project(tinyvo VERSION "), "%31[0-9.]", ver), 1);
            assert_string_equal(ver, tvo_version());
            found = 1;
            break;
        }
    }
    fclose(f);
    assert_true(found);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_runtime_matches_header),
            cmocka_unit_test(test_matches_project_version),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
