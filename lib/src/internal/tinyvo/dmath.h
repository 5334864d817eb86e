/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: deterministic elementary functions.
 *
 * libm's sin, cos, tan, atan, atan2, log, log1p, exp and hypot are not correctly rounded, and their last bit
 * differs between C libraries, library versions and CPUs (glibc picks FMA variants at run time on
 * x86-64 and computes differently on aarch64; newlib on a Cortex-M has its own code). tinyvo's per-frame
 * path calls these functions instead, so that a frame gives bit-identical poses on every IEEE-754
 * double target (docs/ports.md, "Determinism across targets").
 *
 * They use only + - * / and sqrt (correctly rounded in IEEE-754), floor, frexp, ldexp, copysign (exact),
 * evaluated in double with -ffp-contract=off, so every target computes exactly the same bits. Accuracy:
 * within a few units in the last place of the exact result (tested against libm in test/unit/test_dmath.c);
 * sin/cos/tan reduce the argument with a three-part pi/2, exact for |x| < 2^19 * pi/2 (about 8e5 rad),
 * with growing absolute error beyond (still deterministic). Not meant as fast general-purpose libm
 * replacements: they serve a few calls per RANSAC model or frame. */
#ifndef TINYVO_DMATH_H
#define TINYVO_DMATH_H

#ifdef __cplusplus
extern "C" {
#endif

double tvo_dm_sin(double x);
double tvo_dm_cos(double x);
double tvo_dm_tan(double x);
double tvo_dm_atan(double x);
/* atan2 with C99's quadrants, signed zeros and infinities; NaN in -> NaN out. */
double tvo_dm_atan2(double y, double x);
/* log(1 + x): NaN for x < -1 or NaN, -inf for x = -1, +inf for +inf. */
double tvo_dm_log1p(double x);
/* Natural log: NaN for x < 0 or NaN, -inf for 0, +inf for +inf (subnormal x are handled exactly). */
double tvo_dm_log(double x);
/* e^x: +inf above log(DBL_MAX), 0 below -745.2, NaN for NaN. */
double tvo_dm_exp(double x);
/* sqrt(x^2 + y^2) without libm's overflow protection: for |x|, |y| below 1e150 (tinyvo's normalised
 * coordinates are below 1e6). */
double tvo_dm_hypot(double x, double y);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_DMATH_H */
