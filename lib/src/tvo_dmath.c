/* SPDX-License-Identifier: Apache-2.0 */
/* Deterministic elementary functions (see dmath.h): Taylor / atanh series on small reduced arguments,
 * constants as hexadecimal literals (computed with mpmath at 300 bits), only correctly rounded or exact
 * operations, so the result bits are the same on every IEEE-754 double target. */
#include "tinyvo/dmath.h"

#include <math.h>

/* pi/2 = P1 + P2 + P3, P1 and P2 with 33 significant bits (k * P1 and k * P2 exact for |k| < 2^20) */
#define DM_PIO2_1 0x1.921fb544p+0
#define DM_PIO2_2 0x1.0b4611a6p-34
#define DM_PIO2_3 0x1.3198a2e037073p-69
#define DM_INV_PIO2 0x1.45f306dc9c883p-1
#define DM_PIO2_HI 0x1.921fb54442d18p+0
#define DM_PIO2_LO 0x1.1a62633145c07p-54
#define DM_PI_HI 0x1.921fb54442d18p+1
#define DM_PI_LO 0x1.1a62633145c07p-53
/* ln 2 = HI + LO, HI with 42 significant bits (e * HI exact for |e| < 2^11) */
#define DM_LN2_HI 0x1.62e42fefa38p-1
#define DM_LN2_LO 0x1.ef35793c7673p-45
#define DM_SQRT1_2 0x1.6a09e667f3bcdp-1
/* exp's split of ln 2: the high part has 32 significant bits, so k * DM_EXP_LN2_HI is exact for |k| < 2^21 */
#define DM_EXP_LN2_HI 0x1.62e42feep-1
#define DM_EXP_LN2_LO 0x1.a39ef35793c76p-33
#define DM_INV_LN2 0x1.71547652b82fep+0

/* atan(j / 8) = hi[j] + lo[j] */
static const double dm_atan_hi[9] = {
        0.0,
        0x1.fd5ba9aac2f6ep-4,
        0x1.f5b75f92c80ddp-3,
        0x1.6f61941e4def1p-2,
        0x1.dac670561bb4fp-2,
        0x1.1e00babdefeb4p-1,
        0x1.4978fa3269ee1p-1,
        0x1.700a7c5784634p-1,
        0x1.921fb54442d18p-1,
};
static const double dm_atan_lo[9] = {
        0.0,
        -0x1.cd37686760c17p-59,
        0x1.8ab6e3cf7afbdp-57,
        -0x1.c63aae6f6e918p-56,
        0x1.a2b7f222f65e2p-56,
        -0x1.928df287a668fp-58,
        0x1.2419a87f2a458p-56,
        -0x1.8c34d25aadef6p-56,
        0x1.1a62633145c07p-55,
};

/* sin(r) for |r| <= pi/4 (a little more after reduction): Taylor to r^17, truncation < 1e-19 */
static double dm_sin_k(double r)
{
    const double z = r * r;
    const double p = -1.0 / 6.0 +
            z *
                    (1.0 / 120.0 +
                     z *
                             (-1.0 / 5040.0 +
                              z *
                                      (1.0 / 362880.0 +
                                       z *
                                               (-1.0 / 39916800.0 +
                                                z *
                                                        (1.0 / 6227020800.0 +
                                                         z *
                                                                 (-1.0 / 1307674368000.0 +
                                                                  z * (1.0 / 355687428096000.0)))))));
    return r + r * z * p;
}

/* cos(r) for |r| <= pi/4: Taylor to r^18 */
static double dm_cos_k(double r)
{
    const double z = r * r;
    const double p = 1.0 / 24.0 +
            z *
                    (-1.0 / 720.0 +
                     z *
                             (1.0 / 40320.0 +
                              z *
                                      (-1.0 / 3628800.0 +
                                       z *
                                               (1.0 / 479001600.0 +
                                                z *
                                                        (-1.0 / 87178291200.0 +
                                                         z *
                                                                 (1.0 / 20922789888000.0 +
                                                                  z * (-1.0 / 6402373705728000.0)))))));
    const double hz = 0.5 * z;
    const double w = 1.0 - hz;
    /* 1 - z/2 + z^2 p, with the rounding error of w = 1 - z/2 added back */
    return w + (((1.0 - w) - hz) + z * z * p);
}

/* x = k * pi/2 + r, |r| <= about pi/4; returns k mod 4 */
static int dm_reduce(double x, double *r)
{
    const double k = floor(x * DM_INV_PIO2 + 0.5);
    double q;
    *r = ((x - k * DM_PIO2_1) - k * DM_PIO2_2) - k * DM_PIO2_3;
    q = k - 4.0 * floor(k * 0.25);
    return (int)q;
}

double tvo_dm_sin(double x)
{
    double r;
    int q;
    if (!isfinite(x))
        return x - x; /* NaN */
    if (fabs(x) < 0x1p-26)
        return x;
    q = dm_reduce(x, &r);
    switch (q) {
    case 0:
        return dm_sin_k(r);
    case 1:
        return dm_cos_k(r);
    case 2:
        return -dm_sin_k(r);
    default:
        return -dm_cos_k(r);
    }
}

double tvo_dm_cos(double x)
{
    double r;
    int q;
    if (!isfinite(x))
        return x - x;
    if (fabs(x) < 0x1p-27)
        return 1.0;
    q = dm_reduce(x, &r);
    switch (q) {
    case 0:
        return dm_cos_k(r);
    case 1:
        return -dm_sin_k(r);
    case 2:
        return -dm_cos_k(r);
    default:
        return dm_sin_k(r);
    }
}

double tvo_dm_tan(double x)
{
    double r, s, c;
    int q;
    if (!isfinite(x))
        return x - x;
    if (fabs(x) < 0x1p-27)
        return x;
    q = dm_reduce(x, &r);
    s = dm_sin_k(r);
    c = dm_cos_k(r);
    return (q & 1) ? -c / s : s / c;
}

/* atan(a) for 0 <= a <= 1 as hi + lo parts of a reference angle plus a series term */
static double dm_atan_01(double a, double *lo)
{
    const int j = (int)(a * 8.0 + 0.5); /* 0..8 */
    const double c = (double)j * 0.125;
    const double t = (a - c) / (1.0 + a * c); /* |t| <= 1/16 */
    const double z = t * t;
    const double p = t +
            t * z *
                    (-1.0 / 3.0 +
                     z *
                             (1.0 / 5.0 +
                              z *
                                      (-1.0 / 7.0 +
                                       z *
                                               (1.0 / 9.0 +
                                                z * (-1.0 / 11.0 + z * (1.0 / 13.0 + z * (-1.0 / 15.0)))))));
    *lo = dm_atan_lo[j] + p;
    return dm_atan_hi[j];
}

double tvo_dm_atan(double x)
{
    const double a = fabs(x);
    double hi, lo, r;
    if (isnan(x))
        return x;
    if (a < 0x1p-27)
        return x;
    if (a <= 1.0) {
        hi = dm_atan_01(a, &lo);
        r = hi + lo;
    } else {
        /* atan(a) = pi/2 - atan(1/a) */
        hi = dm_atan_01(1.0 / a, &lo);
        r = (DM_PIO2_HI - hi) + (DM_PIO2_LO - lo);
    }
    return copysign(r, x);
}

double tvo_dm_atan2(double y, double x)
{
    const double ay = fabs(y), ax = fabs(x);
    double r;
    if (isnan(x) || isnan(y))
        return x + y;
    if (ay == 0.0) /* atan2(+-0, +x or +0) = +-0, atan2(+-0, -x or -0) = +-pi */
        return signbit(x) ? copysign(DM_PI_HI, y) : y;
    if (ax == 0.0)
        return copysign(DM_PIO2_HI, y);
    if (isinf(ax)) {
        if (isinf(ay))
            r = signbit(x) ? 3.0 * (0.5 * DM_PIO2_HI) : 0.5 * DM_PIO2_HI;
        else
            r = signbit(x) ? DM_PI_HI : 0.0;
        return copysign(r, y);
    }
    if (isinf(ay))
        return copysign(DM_PIO2_HI, y);
    r = tvo_dm_atan(ay / ax); /* in [0, pi/2] */
    if (signbit(x))
        r = (DM_PI_HI - r) + DM_PI_LO;
    return copysign(r, y);
}

/* log(u) for finite u > 0 */
static double dm_log(double u)
{
    int e;
    double m = frexp(u, &e); /* u = m 2^e, m in [0.5, 1) */
    double s, z, p;
    if (m < DM_SQRT1_2) {
        m *= 2.0;
        --e;
    }
    /* log m = 2 atanh(s), s = (m - 1) / (m + 1), |s| <= 0.1716 (m - 1 is exact) */
    s = (m - 1.0) / (m + 1.0);
    z = s * s;
    p = 1.0 / 3.0 +
            z *
                    (1.0 / 5.0 +
                     z *
                             (1.0 / 7.0 +
                              z *
                                      (1.0 / 9.0 +
                                       z *
                                               (1.0 / 11.0 +
                                                z *
                                                        (1.0 / 13.0 +
                                                         z *
                                                                 (1.0 / 15.0 +
                                                                  z *
                                                                          (1.0 / 17.0 +
                                                                           z *
                                                                                   (1.0 / 19.0 +
                                                                                    z *
                                                                                            (1.0 / 21.0 +
                                                                                             z *
                                                                                                     (1.0 /
                                                                                                      23.0))))))))));
    return (double)e * DM_LN2_HI + ((double)e * DM_LN2_LO + (2.0 * s + 2.0 * s * z * p));
}

double tvo_dm_log1p(double x)
{
    double u;
    if (isnan(x) || x < -1.0)
        return (double)NAN;
    if (x == -1.0)
        return -HUGE_VAL;
    if (isinf(x))
        return x;
    if (fabs(x) < 0x1p-54)
        return x;
    u = 1.0 + x;
    if (u == 1.0)
        return x;
    /* log(u) * x / (u - 1): corrects the rounding of 1 + x (u - 1 is exact) */
    return dm_log(u) * (x / (u - 1.0));
}

double tvo_dm_log(double x)
{
    if (isnan(x) || x < 0.0)
        return (double)NAN;
    if (x == 0.0)
        return -HUGE_VAL;
    if (isinf(x))
        return x;
    return dm_log(x); /* frexp normalises subnormals exactly */
}

double tvo_dm_exp(double x)
{
    double k, r, p;
    if (isnan(x))
        return x;
    if (x > 709.782712893384)
        return HUGE_VAL;
    if (x < -745.2)
        return 0.0;
    /* x = k ln2 + r, |r| <= ln2 / 2 (two-part ln2, k * hi exact); the Taylor series to r^17 is below
       2^-60 relative there; 2^k applied by ldexp (exact; rounds once into the subnormal range) */
    k = floor(x * DM_INV_LN2 + 0.5);
    r = (x - k * DM_EXP_LN2_HI) - k * DM_EXP_LN2_LO;
    p = 1.0;
    for (int i = 17; i >= 1; --i)
        p = 1.0 + p * r / (double)i;
    return ldexp(p, (int)k);
}

double tvo_dm_hypot(double x, double y)
{
    return sqrt(x * x + y * y);
}
