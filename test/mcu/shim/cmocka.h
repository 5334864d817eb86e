/* SPDX-License-Identifier: Apache-2.0 */
/* The part of cmocka's API the unit tests use, for the bare-metal Cortex-M7 run (tools/run-mcu.sh):
 * no mocking, no signal handling; a failed assertion prints its place and ends the test (longjmp), the
 * group goes on with the next test. cmocka_run_group_tests returns the number of failed tests and
 * prints "[  PASSED  ] n test(s)." / "[  FAILED  ] n test(s)." lines as cmocka does, which
 * tools/run-mcu.sh reads. Written for tinyvo's tests, not a copy of cmocka. */
#ifndef TVO_MCU_CMOCKA_H
#define TVO_MCU_CMOCKA_H

#include <setjmp.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

typedef void (*CMUnitTestFunction)(void **state);
typedef int (*CMFixtureFunction)(void **state);

struct CMUnitTest {
    const char *name;
    CMUnitTestFunction test_func;
    CMFixtureFunction setup_func;
    CMFixtureFunction teardown_func;
    void *initial_state;
};

#define cmocka_unit_test(f)     \
    {                           \
#f, f, NULL, NULL, NULL \
    }
#define cmocka_unit_test_setup_teardown(f, s, t) \
    {                                            \
#f, f, s, t, NULL                        \
    }

static jmp_buf tvo_cm_jmp;
static int tvo_cm_skipped;

static void tvo_cm_fail(const char *file, int line, const char *fmt, ...)
{
    va_list ap;
    printf("%s:%d: error: ", file, line);
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    printf("\n");
    longjmp(tvo_cm_jmp, 1);
}

#define print_message(...) printf(__VA_ARGS__)
#define print_error(...) printf(__VA_ARGS__)
#define fail() tvo_cm_fail(__FILE__, __LINE__, "fail()")
#define fail_msg(...) tvo_cm_fail(__FILE__, __LINE__, __VA_ARGS__)
#define skip()                  \
    do {                        \
        tvo_cm_skipped = 1;     \
        longjmp(tvo_cm_jmp, 2); \
    } while (0)
#define assert_true(c)                                 \
    do {                                               \
        if (!(c))                                      \
            tvo_cm_fail(__FILE__, __LINE__, "%s", #c); \
    } while (0)
#define assert_false(c)                                   \
    do {                                                  \
        if (c)                                            \
            tvo_cm_fail(__FILE__, __LINE__, "!(%s)", #c); \
    } while (0)
#define assert_non_null(p)                                     \
    do {                                                       \
        if ((p) == NULL)                                       \
            tvo_cm_fail(__FILE__, __LINE__, "%s is NULL", #p); \
    } while (0)
#define assert_null(p)                                             \
    do {                                                           \
        if ((p) != NULL)                                           \
            tvo_cm_fail(__FILE__, __LINE__, "%s is not NULL", #p); \
    } while (0)
#define assert_int_equal(a, b)                                                                          \
    do {                                                                                                \
        const long long tvo_a_ = (long long)(a), tvo_b_ = (long long)(b);                               \
        if (tvo_a_ != tvo_b_)                                                                           \
            tvo_cm_fail(__FILE__, __LINE__, "%ld != %ld (%s, %s)", (long)tvo_a_, (long)tvo_b_, #a, #b); \
    } while (0)
#define assert_int_not_equal(a, b)                               \
    do {                                                         \
        if ((long long)(a) == (long long)(b))                    \
            tvo_cm_fail(__FILE__, __LINE__, "%s == %s", #a, #b); \
    } while (0)
#define assert_memory_equal(a, b, n)                                            \
    do {                                                                        \
        if (memcmp((a), (b), (n)) != 0)                                         \
            tvo_cm_fail(__FILE__, __LINE__, "memory differs (%s, %s)", #a, #b); \
    } while (0)
#define assert_string_equal(a, b)                                          \
    do {                                                                   \
        if (strcmp((a), (b)) != 0)                                         \
            tvo_cm_fail(__FILE__, __LINE__, "\"%s\" != \"%s\"", (a), (b)); \
    } while (0)
#define assert_string_not_equal(a, b)                                      \
    do {                                                                   \
        if (strcmp((a), (b)) == 0)                                         \
            tvo_cm_fail(__FILE__, __LINE__, "\"%s\" == \"%s\"", (a), (b)); \
    } while (0)

static int tvo_cm_run(const char *group, const struct CMUnitTest *t, size_t n, CMFixtureFunction gsetup,
                      CMFixtureFunction gteardown)
{
    void *gstate = NULL;
    int failed = 0, passed = 0, skipped = 0;
    printf("[==========] %s: running %d test(s).\n", group, (int)n);
    if (gsetup != NULL && gsetup(&gstate) != 0) {
        printf("[  FAILED  ] group setup\n");
        return (int)n;
    }
    for (size_t i = 0; i < n; ++i) {
        void *state = t[i].initial_state != NULL ? t[i].initial_state : gstate;
        volatile int ok = 1;
        tvo_cm_skipped = 0;
        printf("[ RUN      ] %s\n", t[i].name);
        if (setjmp(tvo_cm_jmp) == 0) {
            if (t[i].setup_func != NULL && t[i].setup_func(&state) != 0)
                tvo_cm_fail(__FILE__, __LINE__, "setup failed");
            t[i].test_func(&state);
        } else if (!tvo_cm_skipped) {
            ok = 0;
        }
        if (t[i].teardown_func != NULL)
            (void)t[i].teardown_func(&state);
        if (tvo_cm_skipped) {
            ++skipped;
            printf("[  SKIPPED ] %s\n", t[i].name);
        } else if (ok) {
            ++passed;
            printf("[       OK ] %s\n", t[i].name);
        } else {
            ++failed;
            printf("[  FAILED  ] %s\n", t[i].name);
        }
    }
    if (gteardown != NULL)
        (void)gteardown(&gstate);
    printf("[  PASSED  ] %d test(s).\n", passed);
    if (skipped)
        printf("[  SKIPPED ] %d test(s).\n", skipped);
    if (failed)
        printf("[  FAILED  ] %d test(s).\n", failed);
    return failed;
}

#define cmocka_run_group_tests(tests, gs, gt) \
    tvo_cm_run(#tests, tests, sizeof(tests) / sizeof((tests)[0]), gs, gt)

#endif /* TVO_MCU_CMOCKA_H */
