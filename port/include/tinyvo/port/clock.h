/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: a monotonic clock for timing (POSIX clock_gettime). */
#ifndef TINYVO_PORT_CLOCK_H
#define TINYVO_PORT_CLOCK_H

#include <stdint.h>
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Nanoseconds of CLOCK_MONOTONIC (arbitrary origin, never goes backwards); 0 if the clock fails. */
TVO_API int64_t tvo_clock_now_ns(void);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_PORT_CLOCK_H */
