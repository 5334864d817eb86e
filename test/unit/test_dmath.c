/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo/dmath.h: the deterministic elementary functions against libm (accuracy; libm itself is within
 * about 0.5-1 ulp) and their special values. Cross-target bit identity is checked by test_determinism. */
#include "tvo_test.h"

#include <float.h>
#include <math.h>

#include "tinyvo/dmath.h"

/* |a - b| in units of the last place of b (b finite, non-zero) */
static double ulps(double a, double b)
{
    return fabs(a - b) / (nextafter(fabs(b), INFINITY) - fabs(b));
}

static double uniform(uint64_t *s, double lo, double hi)
{
    return lo + (hi - lo) * (double)(tvo_test_rand(s) >> 11) * 0x1p-53;
}

#define MAX_ULPS 4.0

static void check1(const char *name, double (*f)(double), double (*ref)(double), double lo, double hi,
                   int logscale)
{
    uint64_t s = 12345;
    double worst = 0.0;
    for (int i = 0; i < 20000; ++i) {
        double x = logscale ? pow(10.0, uniform(&s, lo, hi)) : uniform(&s, lo, hi);
        double r, e;
        if (logscale && (tvo_test_rand(&s) & 1))
            x = -x;
        r = ref(x);
        if (r == 0.0 || !isfinite(r))
            continue;
        e = ulps(f(x), r);
        if (e > worst)
            worst = e;
    }
    printf("%s: max %.2f ulp from libm on [%g, %g]%s\n", name, worst, lo, hi, logscale ? " (log10)" : "");
    assert_true(worst <= MAX_ULPS);
}

static double log1p_small(double x)
{
    return log1p(x);
}
static double exp_ref(double x)
{
    return exp(x);
}
static double log_ref(double x)
{
    return log(x);
}

static void test_accuracy(void **state)
{
    (void)state;
    check1("sin", tvo_dm_sin, sin, -20.0, 20.0, 0);
    check1("cos", tvo_dm_cos, cos, -20.0, 20.0, 0);
    check1("sin", tvo_dm_sin, sin, -1000.0, 1000.0, 0);
    check1("tan", tvo_dm_tan, tan, -1.55, 1.55, 0);
    check1("atan", tvo_dm_atan, atan, -12.0, 12.0, 1);
    check1("log1p", tvo_dm_log1p, log1p_small, -0.999999, 50.0, 0);
    check1("log1p", tvo_dm_log1p, log1p_small, -15.0, 300.0, 1); /* negative side: x in (-1, 0) only */
    check1("log", tvo_dm_log, log_ref, -300.0, 300.0, 1);        /* negative x: NaN from both, skipped */
    check1("log", tvo_dm_log, log_ref, 0.5, 2.0, 0);
    check1("exp", tvo_dm_exp, exp_ref, -708.0, 709.0, 0);
    check1("exp", tvo_dm_exp, exp_ref, -1.0, 1.0, 0);
    {
        uint64_t s = 99;
        double worst = 0.0, worst_h = 0.0;
        for (int i = 0; i < 20000; ++i) {
            const double y = uniform(&s, -4.0, 4.0), x = uniform(&s, -4.0, 4.0);
            const double r = atan2(y, x), h = hypot(x, y);
            if (r != 0.0 && ulps(tvo_dm_atan2(y, x), r) > worst)
                worst = ulps(tvo_dm_atan2(y, x), r);
            if (ulps(tvo_dm_hypot(x, y), h) > worst_h)
                worst_h = ulps(tvo_dm_hypot(x, y), h);
        }
        printf("atan2: max %.2f ulp, hypot: max %.2f ulp from libm\n", worst, worst_h);
        assert_true(worst <= MAX_ULPS);
        assert_true(worst_h <= MAX_ULPS);
    }
}

static void test_special_values(void **state)
{
    const double pi = 3.14159265358979323846;
    (void)state;
    /* exact small-argument and zero results, signs kept */
    assert_true(tvo_dm_sin(0.0) == 0.0 && !signbit(tvo_dm_sin(0.0)));
    assert_true(tvo_dm_sin(-0.0) == 0.0 && signbit(tvo_dm_sin(-0.0)));
    assert_true(tvo_dm_cos(0.0) == 1.0);
    assert_true(tvo_dm_tan(1e-300) == 1e-300);
    assert_true(tvo_dm_atan(-1e-300) == -1e-300);
    assert_true(tvo_dm_log1p(1e-300) == 1e-300);
    assert_true(tvo_dm_log1p(0.0) == 0.0);
    /* non-finite input */
    assert_true(isnan(tvo_dm_sin(INFINITY)) && isnan(tvo_dm_cos(-INFINITY)) && isnan(tvo_dm_tan(NAN)));
    assert_true(isnan(tvo_dm_atan(NAN)) && isnan(tvo_dm_atan2(NAN, 1.0)) && isnan(tvo_dm_atan2(1.0, NAN)));
    assert_true(isnan(tvo_dm_log1p(-1.5)) && isnan(tvo_dm_log1p(NAN)) && isnan(tvo_dm_log1p(-INFINITY)));
    assert_true(tvo_dm_log1p(-1.0) == -INFINITY && tvo_dm_log1p(INFINITY) == INFINITY);
    assert_true(isnan(tvo_dm_log(-1.0)) && isnan(tvo_dm_log(NAN)) && tvo_dm_log(0.0) == -INFINITY);
    assert_true(tvo_dm_log(INFINITY) == INFINITY && tvo_dm_log(1.0) == 0.0);
    assert_true(fabs(tvo_dm_log(4.9e-324) - log(4.9e-324)) <= 1e-13); /* smallest subnormal */
    assert_true(tvo_dm_exp(0.0) == 1.0 && isnan(tvo_dm_exp(NAN)) && tvo_dm_exp(-INFINITY) == 0.0);
    assert_true(tvo_dm_exp(710.0) == INFINITY && tvo_dm_exp(INFINITY) == INFINITY &&
                tvo_dm_exp(-746.0) == 0.0);
    assert_true(tvo_dm_exp(-740.0) > 0.0 && fabs(tvo_dm_exp(-740.0) - exp(-740.0)) <= 4.9e-324);
    assert_true(fabs(tvo_dm_atan(INFINITY) - pi / 2) < 1e-15 && fabs(tvo_dm_atan(-1e300) + pi / 2) < 1e-15);
    /* atan2's quadrants, zeros and infinities as C99 */
    {
        const double c[][2] = {{0.0, 1.0},
                               {-0.0, 1.0},
                               {0.0, -1.0},
                               {-0.0, -1.0},
                               {0.0, 0.0},
                               {-0.0, 0.0},
                               {0.0, -0.0},
                               {-0.0, -0.0},
                               {1.0, 0.0},
                               {-1.0, -0.0},
                               {INFINITY, INFINITY},
                               {INFINITY, -INFINITY},
                               {-INFINITY, INFINITY},
                               {-INFINITY, -INFINITY},
                               {1.0, INFINITY},
                               {1.0, -INFINITY},
                               {-1.0, -INFINITY},
                               {INFINITY, 1.0},
                               {-2.0, -3.0},
                               {2.0, -3.0}};
        for (size_t i = 0; i < sizeof(c) / sizeof(c[0]); ++i) {
            const double got = tvo_dm_atan2(c[i][0], c[i][1]), want = atan2(c[i][0], c[i][1]);
            assert_true(signbit(got) == signbit(want));
            assert_true(fabs(got - want) <= 4.0 * DBL_EPSILON * fabs(want));
        }
    }
    /* periodicity and symmetry hold exactly where the reduction is exact */
    assert_true(tvo_dm_sin(-0.7) == -tvo_dm_sin(0.7));
    assert_true(tvo_dm_cos(-2.5) == tvo_dm_cos(2.5));
    assert_true(tvo_dm_atan(-3.0) == -tvo_dm_atan(3.0));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_accuracy),
            cmocka_unit_test(test_special_values),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
